//! `pt` — unidirectional path tracing.
//!
//! Estimates each pixel's measurement (unbiased) from camera paths. At every non-delta vertex
//! it combines next-event estimation (one light chosen by power, one point on it) with BSDF
//! sampling that hits emitters, weighting the two by the power heuristic; paths continue by
//! BSDF sampling with Russian roulette.
//!
//! Options: [`OPTIONS`] (`lodestar integrators --options`, `docs/integrators.md`).
//!
//! Roulette continues with the local probability of the vertex (`Bsdf::continuation`: its
//! largest reflectance, 1 for glass; a medium's albedo), so that the density of any path, roulette
//! included, can be computed from the path alone (`pdf_unguided`, shared with BDPT).
//!
//! Media: in a homogeneous medium the path samples a free-flight distance (one RGB channel
//! chosen uniformly, the channel-averaged density); a scattering point is a path vertex that
//! does next-event estimation (transmittance computed analytically, through index-matched
//! boundaries) and samples the phase function. Index-matched boundaries (shapes with media and
//! no material) are crossed without a vertex. MIS compares the light's density with the
//! continuation's density times the probability that free flight passes the connecting
//! segment, which is what the continuation really samples. A scene without media never runs
//! any of this (one branch per segment on the current medium, which is always `None`).
//!
//! ```text
//! lodestar render scenes/cornell-box.toml --integrator pt --spp 64 -O strategy=mis
//! ```

use super::IntegratorParams;
use crate::bsdf::TransportMode;
use crate::error::{Error, Result};
use crate::geometry::Ray;
use crate::math::{Sampler, SamplerKind, Spectrum};
use crate::path::{Path, Vertex as PathVertex, VertexKind};
use crate::render::{
    Budget, Integrator, PixelEstimator, RenderContext, RenderResult, render_pixel_estimator,
};
use crate::scene::{Endpoint, Scene, SurfacePoint};
use batch::BatchMode;
use direct::{Queue, Scatterer, TraceNow};
use emission::EmitterAt;
use glam::{Vec2, Vec3};
use guiding::{Guide, Trail};
use options::RR_DEPTH;
pub use options::{OPTIONS, RR_DEPTH_OPTION, STRATEGY_OPTION, check_parts, check_splat_film};
pub use recording::PathRecorder;
use recording::Recording;

pub mod batch;
mod direct;
mod emission;
pub mod guiding;
mod options;
mod recording;
mod round;
pub mod sdtree;
mod unguided;
pub mod wavefront;

/// How emitters are reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// Next-event estimation and BSDF sampling, power heuristic.
    Mis,
    /// BSDF sampling only.
    Bsdf,
    /// Next-event estimation only.
    Nee,
}

/// Options of pt (and of U in guided-pt, and of pssmlt's path tracer).
#[derive(Debug, Clone, PartialEq)]
pub struct PtSettings {
    /// Maximum number of path segments (default 8).
    pub max_depth: u32,
    /// Path length (segments) from which Russian roulette applies (default 5).
    pub rr_depth: u32,
    /// Default `Mis`.
    pub strategy: Strategy,
}

impl Default for PtSettings {
    fn default() -> Self {
        PtSettings {
            max_depth: 8,
            rr_depth: RR_DEPTH as u32,
            strategy: Strategy::Mis,
        }
    }
}

/// Build pt (batched, wavefront or SD-tree guided as its options say) from its parameters.
pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let pt = PathTracer {
        settings: settings(params)?,
    };
    let batch = BatchMode::parse(params)?;
    let sampler = super::options::sampler(&params.options.declared(&[OPTIONS]))?;
    Ok(match guiding::settings(params)? {
        None => Box::new(batch::Pt { pt, batch, sampler }),
        Some(_) if batch == BatchMode::On => {
            return Err(Error::new(
                "option 'batch': 'on' does not apply with guiding=sdtree (guided paths are \
                 traced one at a time); use 'auto' or 'off'",
            ));
        }
        Some(guiding) => Box::new(guiding::GuidedPathTracer {
            pt,
            guiding,
            sampler,
        }),
    })
}

/// pt's settings from `max_depth` and options `rr_depth` and `strategy` (also `pssmlt`'s).
pub fn settings(params: &IntegratorParams) -> Result<PtSettings> {
    let o = params
        .options
        .declared(&[&[RR_DEPTH_OPTION, STRATEGY_OPTION]]);
    let strategy = match o.word("strategy")? {
        "bsdf" => Strategy::Bsdf,
        "nee" => Strategy::Nee,
        _ => Strategy::Mis,
    };
    let rr_depth = o.int("rr_depth")?;
    Ok(PtSettings {
        max_depth: params.max_depth,
        rr_depth,
        strategy,
    })
}

/// The path tracer: one camera path per sample, next-event estimation and BSDF sampling
/// combined by MIS, Russian roulette, media.
pub struct PathTracer {
    /// Depth limit, Russian roulette start and strategy.
    pub settings: PtSettings,
}

impl Integrator for PathTracer {
    fn name(&self) -> &'static str {
        "pt"
    }

    fn settings(&self) -> String {
        format!("{:?}", self.settings)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        render_pixel_estimator(ctx, budget, SamplerKind::Independent, self)
    }
}

impl PixelEstimator for PathTracer {
    fn estimate<S: Sampler>(&self, scene: &Scene, raster: Vec2, sampler: &mut S) -> Spectrum {
        self.li(scene, raster, sampler)
    }
}

impl PathTracer {
    /// `pdf_unguided` (DESIGN.md §3): the density with which pt produces `path` by either of
    /// its techniques (the continuation hits the emitter; next-event estimation), summed. The
    /// techniques are BDPT's s = 0 and (for paths of two or more segments) s = 1, so the
    /// densities come from the same code; a one-segment path is only found by the camera ray.
    pub fn pdf_unguided(&self, scene: &Scene, path: &Path) -> f64 {
        let s = &self.settings;
        super::paths::technique_densities_of(scene, path, s.max_depth, s.rr_depth)
            .map_or(0.0, |(p, k)| p[0] + if k >= 2 { p[1] } else { 0.0 })
    }

    /// Radiance arriving at the pinhole through raster position `raster`.
    pub fn li(&self, scene: &Scene, raster: Vec2, sampler: &mut impl Sampler) -> Spectrum {
        self.li_recorded(scene, raster, sampler, None)
    }

    /// As [`Self::li`], handing every complete path it forms to `recorder`.
    pub fn li_recorded(
        &self,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        recorder: Option<&mut dyn PathRecorder>,
    ) -> Spectrum {
        self.li_inner(scene, raster, sampler, recorder, None, None, None)
    }

    /// As [`Self::li`], the continuation guided by `guide` (`guiding.rs`); with `trail`
    /// (learning), what each continuation brings back is recorded into the guide's tree.
    pub fn li_guided(
        &self,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        guide: &Guide,
        trail: Option<&mut Trail>,
    ) -> Spectrum {
        self.li_inner(scene, raster, sampler, None, Some(guide), trail, None)
    }

    /// As [`Self::li`], and the part of it that only continuing the path finds: emission
    /// reached from a delta vertex or by the camera ray (next-event estimation cannot make
    /// those paths, so their MIS weight is 1). `pssmlt` splits this part off its chains.
    pub fn li_split(
        &self,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
    ) -> (Spectrum, Spectrum) {
        let mut direct = Spectrum::ZERO;
        let l = self.li_inner(scene, raster, sampler, None, None, None, Some(&mut direct));
        (l, direct)
    }

    #[allow(clippy::too_many_arguments)]
    fn li_inner(
        &self,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        recorder: Option<&mut dyn PathRecorder>,
        guide: Option<&Guide>,
        mut trail: Option<&mut Trail>,
        direct: Option<&mut Spectrum>,
    ) -> Spectrum {
        let mut path = PathState::new(scene, raster);
        // Built in place (a path of 64 vertices): `Extras` only borrows it.
        let mut rec = recorder.map(|sink| {
            let pixel = scene.camera.pixel_index(raster) as u32;
            Recording::new(scene, sink, path.ray.d, pixel)
        });
        let mut extras = Extras {
            rec: rec.as_mut(),
            guide,
            trail: trail.as_deref_mut(),
            deferred: None,
            direct: direct.as_ref().map(|_| Spectrum::ZERO),
        };
        loop {
            let sp = scene.intersect(&path.ray);
            if !self.advance(scene, &mut path, sp.as_ref(), sampler, &mut extras) {
                break;
            }
        }
        if let (Some(out), Some(d)) = (direct, extras.direct) {
            *out = d;
        }
        if let (Some(t), Some(g)) = (trail, guide) {
            t.record(g.tree, path.l);
        }
        path.l
    }

    /// One segment of the path: from what `path.ray` found (`sp`, `None` for a miss) to the
    /// next ray. Returns false when the path ends. Next-event estimation either traces its
    /// shadow ray here or, with `extras.deferred`, queues it for a batch (`batch.rs`).
    /// Inlined into both loops (`li_inner`, `li_row`), as is `next_event`: pt on the Cornell
    /// box ran 5-10 % slower with them as calls (the state round-trips through memory).
    #[inline(always)]
    fn advance(
        &self,
        scene: &Scene,
        path: &mut PathState,
        sp: Option<&SurfacePoint>,
        sampler: &mut impl Sampler,
        extras: &mut Extras,
    ) -> bool {
        let s = &self.settings;
        let use_nee = s.strategy != Strategy::Bsdf;
        // The segment just traced (fields read where used: a copy of the whole ray, stored
        // field by field by `Hit::spawn`, stalls on store forwarding).
        let ray = &path.ray;

        // ---- Medium: scatter before the surface, or pass it ----
        if let Some(mi) = path.medium {
            let m = &scene.media[mi as usize];
            let t_hit = sp.map_or(f32::INFINITY, |sp| sp.hit.t);
            let flight = m.sample_distance(t_hit, sampler.next_1d(), sampler.next_1d());
            path.beta *= flight.weight;
            if flight.scattered {
                if path.depth == s.max_depth {
                    return false;
                }
                let p = ray.at(flight.t);
                let wo = -ray.d;
                let here = Endpoint::point(p);
                if let Some(r) = &mut extras.rec {
                    let v = PathVertex {
                        p,
                        n: Vec3::ZERO,
                        ns: Vec3::ZERO,
                        uv: glam::Vec2::ZERO,
                        tangent: Vec3::ZERO,
                        kind: VertexKind::Medium { medium: mi },
                    };
                    r.arrive(scene, v, path.pass * flight.pdf);
                }
                if use_nee {
                    let q_here = self.roulette_probability(path.depth, m.continuation());
                    let phase = Scatterer::Medium {
                        phase: &m.phase,
                        wo,
                    };
                    self.next_event(scene, path, &here, &phase, sampler, extras, q_here);
                }
                let (wi, pdf) = m.phase.sample(wo, sampler.next_2d());
                if let Some(r) = &mut extras.rec {
                    let q = self.roulette_probability(path.depth, m.continuation());
                    r.scatter(pdf, q, false);
                }
                path.prev = Scattered {
                    delta: false,
                    pdf,
                    p,
                };
                path.pass = 1.0;
                if !self.roulette(path.depth, m.continuation(), &mut path.beta, sampler) {
                    return false;
                }
                path.ray = Ray::new(p, wi);
                path.depth += 1;
                return true;
            }
            path.pass *= flight.pdf;
            if path.beta == Spectrum::ZERO {
                return false;
            }
        }

        let Some(sp) = sp else {
            self.escape(scene, path, extras);
            return false;
        };
        let hit = &sp.hit;

        // ---- Index-matched boundary: straight through, still the same segment ----
        if sp.is_null() {
            path.null_crossings += 1;
            if path.null_crossings > 256 {
                return false;
            }
            path.medium = scene.medium_after(sp, ray.d, path.medium);
            path.ray = hit.spawn(ray.d);
            return true;
        }
        let wo = -ray.d;

        // ---- Emission of a hit emitter ----
        if let Some(li) = sp.light() {
            self.hit_emitter(scene, path, extras, li, hit);
        }
        if sp.bsdf.is_black() || path.depth == s.max_depth {
            return false;
        }
        if let Some(r) = &mut extras.rec {
            let kind = VertexKind::Surface {
                material: sp.material,
                shape: sp.info.index,
                delta: sp.bsdf.is_delta(),
            };
            let v = PathVertex {
                p: hit.p,
                n: hit.ng,
                ns: hit.ns,
                uv: sp.frame.uv,
                tangent: PathVertex::tangent_of(sp.bsdf, &sp.frame),
                kind,
            };
            r.arrive(scene, v, path.pass);
        }

        // ---- Next-event estimation (adds a path of depth + 1 segments) ----
        let mix = extras.guide.and_then(|g| g.at(sp));
        if use_nee && !sp.bsdf.is_delta() {
            let q_here = self.roulette_probability(path.depth, sp.bsdf.continuation());
            let surface = Scatterer::Surface { sp, wo, mix };
            let from = Endpoint::surface(hit);
            self.next_event(scene, path, &from, &surface, sampler, extras, q_here);
        }

        // ---- BSDF sampling (mixed with the guide's directions): extend the path ----
        let bs = match &mix {
            Some(m) => m.sample(sp, wo, sampler),
            None => {
                let u_lobe = sampler.next_1d();
                let u = sampler.next_2d();
                sp.bsdf
                    .sample(&sp.frame, wo, u_lobe, u, TransportMode::Radiance)
            }
        };
        let Some(bs) = bs else {
            return false;
        };
        path.beta *= bs.weight;
        if let Some(r) = &mut extras.rec {
            r.scatter(
                bs.pdf,
                self.roulette_probability(path.depth, sp.bsdf.continuation()),
                bs.delta,
            );
        }
        if bs.transmission {
            path.medium = scene.medium_after(sp, bs.wi, path.medium);
        }
        path.prev = Scattered {
            delta: bs.delta,
            pdf: bs.pdf,
            p: hit.p,
        };
        path.pass = 1.0;
        if !self.roulette(path.depth, sp.bsdf.continuation(), &mut path.beta, sampler) {
            return false;
        }
        if let Some(t) = &mut extras.trail
            && !bs.delta
        {
            t.push(hit.p, bs.wi, bs.pdf, path.beta, path.l);
        }
        path.ray = hit.spawn(bs.wi);
        path.depth += 1;
        true
    }

    /// The path's ray escaped: the emission of the lights at infinity along it.
    #[inline(always)]
    fn escape(&self, scene: &Scene, path: &mut PathState, extras: &mut Extras) {
        for &li in &scene.infinite_lights {
            let le = scene.lights[li].le(Vec3::ZERO, Vec3::ZERO, path.ray.d);
            if le != Spectrum::ZERO {
                self.emission(scene, path, extras, li, le, EmitterAt::Infinity);
            }
        }
    }

    /// The path's ray found `hit` on area light `li`: its emission towards the path.
    #[inline(always)]
    fn hit_emitter(
        &self,
        scene: &Scene,
        path: &mut PathState,
        extras: &mut Extras,
        li: usize,
        hit: &crate::geometry::Hit,
    ) {
        let le = scene.lights[li].le(hit.p, hit.ng, -path.ray.d);
        if le != Spectrum::ZERO {
            let at = EmitterAt::Surface {
                p: hit.p,
                n: hit.ng,
            };
            self.emission(scene, path, extras, li, le, at);
        }
    }

    /// Next-event estimation at the path's current vertex (`q_here`: its roulette
    /// continuation, for the recorder): added to `path.l` now, or queued with its shadow
    /// query when `extras.deferred` collects them (scenes without media only).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn next_event(
        &self,
        scene: &Scene,
        path: &mut PathState,
        from: &Endpoint,
        at: &Scatterer,
        sampler: &mut impl Sampler,
        extras: &mut Extras,
        q_here: f32,
    ) {
        let rec = extras.rec.as_deref_mut().map(|r| (r, path.beta, q_here));
        let Some(queue) = &mut extras.deferred else {
            let nee = self.direct(scene, from, path.medium, at, sampler, rec, &mut TraceNow);
            path.l += path.beta * nee;
            return;
        };
        let mut shadow = Queue::default();
        let value = self.direct(scene, from, path.medium, at, sampler, rec, &mut shadow);
        let query = shadow.0;
        queue.push(Deferred {
            beta: path.beta,
            value,
            query,
        });
    }

    /// Russian roulette on paths of `rr_depth` segments or more, continuing with the local
    /// probability `q` of the vertex (`Bsdf::continuation`, the medium's albedo); false
    /// terminates the path. A local rule keeps the path's density computable from the path
    /// alone (`pdf_unguided`), in both directions, like BDPT's.
    fn roulette_probability(&self, depth: u32, q: f32) -> f32 {
        super::paths::roulette(q.min(1.0), depth as usize, self.settings.rr_depth)
    }

    fn roulette(
        &self,
        depth: u32,
        q: f32,
        beta: &mut Spectrum,
        sampler: &mut impl Sampler,
    ) -> bool {
        let q = self.roulette_probability(depth, q);
        if q >= 1.0 {
            return true;
        }
        if sampler.next_1d() >= q {
            return false;
        }
        *beta /= q;
        true
    }
}

/// One camera path between two segments: what [`PathTracer::advance`] carries from one
/// segment to the next.
pub(super) struct PathState {
    /// The segment to trace next.
    ray: Ray,
    /// The medium `ray` starts in.
    medium: Option<u32>,
    /// Radiance gathered so far, and the throughput of the path up to `ray`'s origin.
    l: Spectrum,
    beta: Spectrum,
    /// The last scattering vertex (the pinhole is a delta vertex), for MIS on emitters that
    /// the continuation finds, and the free-flight pass probability since then.
    prev: Scattered,
    pass: f32,
    /// Number of segments of the path once `ray` reaches its next vertex.
    depth: u32,
    null_crossings: u32,
}

impl PathState {
    /// The camera ray through raster position `raster`.
    fn new(scene: &Scene, raster: Vec2) -> PathState {
        let ray = scene.camera.generate_ray(raster);
        PathState {
            ray,
            medium: scene.camera_medium,
            l: Spectrum::ZERO,
            beta: Spectrum::ONE,
            prev: Scattered {
                delta: true,
                pdf: 0.0,
                p: ray.o,
            },
            pass: 1.0,
            depth: 1,
            null_crossings: 0,
        }
    }

    /// The camera paths of a row's rasters, each with its index in the row (batched and
    /// wavefront pt trace them in rounds).
    fn row(scene: &Scene, rasters: &[Vec2]) -> Vec<(usize, PathState)> {
        rasters
            .iter()
            .enumerate()
            .map(|(i, &r)| (i, PathState::new(scene, r)))
            .collect()
    }
}

/// What a path may carry besides its state: the recorder, the directional guide and its
/// learning trail, and the queue of next-event samples waiting for their shadow rays.
struct Extras<'e, 'r, 'g, 't, 'q> {
    rec: Option<&'e mut Recording<'r>>,
    guide: Option<&'g Guide<'g>>,
    trail: Option<&'t mut Trail>,
    deferred: Option<&'q mut Vec<Deferred>>,
    /// With `Some`, the sum of the emission only continuing the path finds (from a delta
    /// vertex or the camera ray; [`PathTracer::li_split`]).
    direct: Option<Spectrum>,
}

/// A next-event sample waiting for its shadow ray: `path.l += beta * value` if `query`
/// (origin, direction, length) is unoccluded, else `beta * 0` (so a non-finite throughput
/// shows as it does when the ray is traced at once).
struct Deferred {
    beta: Spectrum,
    value: Spectrum,
    query: Option<(Vec3, Vec3, f32)>,
}

/// The last scattering vertex of the path.
#[derive(Clone, Copy)]
struct Scattered {
    /// Delta BSDF (or the pinhole): no other strategy shares the next vertex.
    delta: bool,
    /// Solid-angle density (or lobe probability) of the sampled direction.
    pdf: f32,
    p: Vec3,
}
