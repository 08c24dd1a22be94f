//! `bsdf-pt` and `guided-bsdf-pt`: an integrator written outside the lodestar crate, against
//! its public API only, that registers itself by name and is guided through `Guided<U, S>`
//! without a line of guiding code of its own.
//!
//! `bsdf-pt` is path tracing by BSDF (and phase-function) sampling alone: a camera walk that
//! counts the emission of every emitter it hits, with Russian roulette. In BDPT's terms it is
//! the technique s = 0 alone, so it is unbiased, and poor wherever emitters are small (no
//! next-event estimation): a clear case for guiding.
//!
//! What it implements and what it borrows:
//! - the walk is BDPT's camera subpath (`bdpt::camera_subpath`: index-matched boundaries,
//!   media, roulette), so each vertex carries its throughput `beta`;
//! - the estimate of a pixel sample is the sum over the walk's emitter hits of `beta Le`;
//! - as an [`Unguided`] estimator it reports each such hit as a complete path with its
//!   measurement contribution f(X) (`paths::contribution`) and its density `p_u(X)`, that of
//!   technique s = 0 (`paths::path_terms_into`), and it evaluates that density for any path
//!   (`pdf_unguided`). That is all `Guided<U, S>` needs: `guided-bsdf-pt` mixes guided
//!   samples with these by the balance heuristic.
//!
//! Its one option, `rr_depth`, is declared in [`OPTIONS`]; `guided-bsdf-pt` also reads every
//! option the guided integrators share (`guided::options::COMMON`, `SEEDERS`).

use glam::{DVec3, Vec2};
use lodestar::Result;
use lodestar::integrators::bdpt::camera_subpath;
use lodestar::integrators::options::{self, DefaultValue, Spec};
use lodestar::integrators::paths::contribution::contribution;
use lodestar::integrators::paths::{Kind, PathTerms, Vertex, path_terms_into, to_path};
use lodestar::integrators::unguided::{PathSink, Unguided};
use lodestar::integrators::{self, Entry, IntegratorParams, guided};
use lodestar::math::{Sampler, SamplerKind, Spectrum};
use lodestar::path::MAX_VERTICES;
use lodestar::render::{Budget, Integrator, RenderContext, RenderResult, RowTracer, render_rows};
use lodestar::scene::Scene;

/// Russian roulette's default start (pt's).
pub const RR_DEPTH: u32 = 5;

/// bsdf-pt's options.
pub const OPTIONS: &[Spec] = &[Spec {
    name: "rr_depth",
    kind: options::Kind::Int { min: 1 },
    default: DefaultValue::Int(RR_DEPTH as i64),
    doc: "Russian roulette on walks of this many segments or more",
}];

/// Path tracing by BSDF sampling alone.
#[derive(Debug, Clone, Copy)]
pub struct BsdfPt {
    pub max_depth: u32,
    pub rr_depth: u32,
}

/// Register `bsdf-pt` and `guided-bsdf-pt` (an error if either name is taken).
pub fn register() -> Result<()> {
    integrators::register(Entry {
        name: "bsdf-pt",
        summary: "path tracing by BSDF sampling alone (an integrator from examples/bsdf_pt)",
        build,
        options: &[OPTIONS],
        parts: integrators::not_splittable,
        splat_film: integrators::samples_filters_only,
        max_depth: None,
    })?;
    integrators::register(Entry {
        name: "guided-bsdf-pt",
        summary: "selective guided sampling mixed with bsdf-pt (examples/bsdf_pt)",
        build: build_guided,
        options: &[OPTIONS, guided::options::COMMON, guided::options::SEEDERS],
        parts: integrators::not_splittable,
        splat_film: integrators::samples_filters_only,
        max_depth: integrators::STORED_PATHS,
    })
}

fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let rr_depth = params.options.declared(&[OPTIONS]).int("rr_depth")?;
    Ok(Box::new(BsdfPt::new(params.max_depth, rr_depth)?))
}

fn build_guided(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    guided::build_over("guided-bsdf-pt", params, RR_DEPTH, |rr_depth| {
        BsdfPt::new(params.max_depth, rr_depth)
    })
}

impl BsdfPt {
    pub fn new(max_depth: u32, rr_depth: u32) -> Result<BsdfPt> {
        if rr_depth == 0 {
            return Err(lodestar::Error::new(
                "option 'rr_depth': expected an integer >= 1, got 0",
            ));
        }
        Ok(BsdfPt {
            max_depth,
            rr_depth,
        })
    }

    /// The camera walk through `raster` into `walk`: at most `max_depth` segments.
    fn walk<'s>(
        &self,
        scene: &'s Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        walk: &mut Vec<Vertex<'s>>,
    ) {
        let vertices = (self.max_depth as usize)
            .saturating_add(1)
            .min(MAX_VERTICES);
        camera_subpath(scene, raster, vertices, self.rr_depth, sampler, walk);
    }

    /// The emitters hit at the walk's vertex `v`: each as the light vertex that ends a complete
    /// path there, with its emitted radiance towards the walk. An escape reaches every light
    /// at infinity; a surface vertex its own area light, if any.
    fn emitters<'s>(
        scene: &Scene,
        prev: &Vertex<'s>,
        v: &Vertex<'s>,
        out: &mut Vec<(Vertex<'s>, Spectrum)>,
    ) {
        out.clear();
        match v.kind {
            Kind::Light { .. } => {
                for &light in &scene.infinite_lights {
                    let le = scene.lights[light].le(glam::Vec3::ZERO, glam::Vec3::ZERO, v.n);
                    out.push((
                        Vertex {
                            kind: Kind::Light { light },
                            ..*v
                        },
                        le,
                    ));
                }
            }
            Kind::Surface { info, .. } => {
                if let Some(light) = info.light {
                    let light = light as usize;
                    let le = scene.lights[light].le(v.p, v.n, (prev.p - v.p).normalize());
                    out.push((
                        Vertex {
                            kind: Kind::Light { light },
                            delta: false,
                            ..*v
                        },
                        le,
                    ));
                }
            }
            Kind::Camera | Kind::Medium { .. } => {}
        }
    }

    /// The estimate of one pixel sample: the sum over the walk's emitter hits of `beta Le`.
    fn estimate_with(&self, raster: Vec2, sampler: &mut impl Sampler, w: &mut Walker<'_>) -> DVec3 {
        let scene = w.scene;
        self.walk(scene, raster, sampler, &mut w.walk);
        let mut sum = DVec3::ZERO;
        for t in 1..w.walk.len() {
            Self::emitters(scene, &w.walk[t - 1], &w.walk[t], &mut w.hits);
            for (_, le) in &w.hits {
                sum += (w.walk[t].beta * *le).as_dvec3();
            }
        }
        if sum.is_finite() { sum } else { DVec3::ZERO }
    }

    /// Buffers for the walks of one thread.
    fn walker<'s>(&self, scene: &'s Scene) -> Walker<'s> {
        Walker {
            scene,
            walk: Vec::with_capacity(16),
            y: Vec::with_capacity(16),
            hits: Vec::new(),
        }
    }
}

/// bsdf-pt's own render: a row's samples share one walker, so no sample allocates.
struct Rows<'s> {
    pt: &'s BsdfPt,
    w: Walker<'s>,
}

impl RowTracer for Rows<'_> {
    fn sample<S: Sampler>(&mut self, raster: Vec2, sampler: &mut S) -> Spectrum {
        self.pt
            .estimate_with(raster, sampler, &mut self.w)
            .as_vec3()
    }
}

impl Integrator for BsdfPt {
    fn name(&self) -> &'static str {
        "bsdf-pt"
    }

    fn settings(&self) -> String {
        format!("max_depth={} rr_depth={}", self.max_depth, self.rr_depth)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        let pt = *self;
        render_rows(ctx, budget, SamplerKind::Independent, || Rows {
            pt: &pt,
            w: pt.walker(ctx.scene),
        })
    }
}

/// Per-thread state of the guided integrator's samples: the scene and the walk's buffers
/// (the vertices borrow the scene).
pub struct Walker<'s> {
    scene: &'s Scene,
    walk: Vec<Vertex<'s>>,
    y: Vec<Vertex<'s>>,
    hits: Vec<(Vertex<'s>, Spectrum)>,
}

impl Unguided for BsdfPt {
    type Tracer<'s> = Walker<'s>;
    type Pass<'s> = ();

    fn name(&self) -> &'static str {
        "bsdf-pt"
    }

    fn max_depth(&self) -> u32 {
        self.max_depth
    }

    fn begin_pass<'s>(&'s self, _: &'s Scene, _: u64, _: u64, _: u64) {}

    fn tracer<'s, 'p: 's>(&'s self, scene: &'s Scene, _: &'s ()) -> Walker<'s> {
        self.walker(scene)
    }

    /// Every emitter hit of the walk through `raster`, as a complete path with f(X) and
    /// p_u(X).
    fn trace(
        &self,
        w: &mut Walker<'_>,
        _: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn PathSink,
    ) {
        let scene = w.scene;
        self.walk(scene, raster, sampler, &mut w.walk);
        let pixel = scene.camera.pixel_index(raster) as u32;
        for t in 1..w.walk.len() {
            Self::emitters(scene, &w.walk[t - 1], &w.walk[t], &mut w.hits);
            for &(light, _) in &w.hits {
                w.y.clear();
                w.y.extend_from_slice(&w.walk[..t]);
                w.y.push(light);
                // Every segment was traced, so each is visible (`u64::MAX`); media still
                // attenuate.
                let f = contribution(scene, &w.y, u64::MAX);
                let p_u = self.pdf_unguided(scene, &(), &w.y);
                if p_u > 0.0 && f.is_finite() {
                    let path = to_path(&w.y, f.as_vec3(), pixel);
                    sink.record_from_vertices(&path, &w.y, f, p_u, false);
                }
            }
        }
    }

    fn estimate(
        &self,
        w: &mut Walker<'_>,
        _: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        _: &mut Vec<(u32, DVec3)>,
    ) -> DVec3 {
        self.estimate_with(raster, sampler, w)
    }

    /// The density of technique s = 0 (the camera walk hits the emitter) for `y`, image-wide
    /// as every technique's (`paths::PathTerms`); 0 beyond `max_depth`.
    fn pdf_unguided(&self, scene: &Scene, _: &(), y: &[Vertex]) -> f64 {
        let k = y.len() - 1;
        if k == 0 || k > self.max_depth as usize {
            return 0.0;
        }
        let mut p = [0.0f64; MAX_VERTICES];
        TERMS.with_borrow_mut(|terms| {
            path_terms_into(scene, y, self.rr_depth, terms);
            terms.technique_densities(&mut p);
        });
        p[0]
    }
}

thread_local! {
    /// `pdf_unguided`'s scratch, so that evaluating a density allocates nothing.
    static TERMS: std::cell::RefCell<PathTerms> = std::cell::RefCell::new(PathTerms::new(0));
}
