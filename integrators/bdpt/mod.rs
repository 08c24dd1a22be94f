//! `bdpt` — bidirectional path tracing (Veach 1997) with every (s, t) technique and full MIS;
//! `lt` — light tracing, its t = 1 techniques alone.
//!
//! Unbiased. Per pixel and pass: a camera subpath and a light subpath (one light chosen by
//! power), both random walks with media (`walk.rs`); every prefix pair is connected: s = 0
//! (the camera walk hits an emitter, including lights at infinity), s = 1 (next-event
//! estimation), t = 1 (the light vertex connected to the pinhole and splatted; not the
//! emission origin of an emitter the camera sees directly through vacuum in a pixel it
//! fills, which is left to s = 0: `integrators/paths/terms.rs`), and s, t >= 2 (a
//! deterministic connection with transmittance through index-matched boundaries). The MIS
//! weights (`weights.rs`) include Russian roulette (a local continuation probability, so the
//! densities exist in both directions) and free-flight probabilities. With roulette from the
//! first bounce (the default) they are recursive, O(1) per connection (one running sum per
//! subpath vertex, kept in `cache.rs`); otherwise (`-O rr_depth` > 1, `lt`, `--check`, and in
//! the guider's recording the paths whose densities it needs, to add the guided density)
//! each connection assembles every technique's density explicitly (`PathTerms`,
//! `integrators/paths/terms.rs`); tests check the two agree. What every
//! connection through a vertex reuses is cached once per subpath (`cache.rs`), and each
//! connection end costs one BSDF evaluation (`f` and the densities in both directions).
//!
//! Options: [`OPTIONS`], lt's [`LT_OPTIONS`] (`lodestar integrators --options`,
//! `docs/integrators.md`).
//!
//! Light subpaths start in the medium around the light (`Scene::light_medium`); lights at
//! infinity seen through a world medium send none (they are attenuated to nothing).
//!
//! Limits: `lt` cannot see lights at infinity directly, nor anything seen through a specular surface.
//!
//! ```text
//! lodestar render scenes/cornell-box.toml --integrator bdpt --spp 64 -O mis=power
//! ```

mod cache;
mod connections;
mod recording;
mod settings;
mod technique;
mod unguided;
mod walk;
mod weights;

use super::IntegratorParams;
use super::paths::vertex::{
    ConnectionEnd, Edge, connection_end, measure_factor, pdf, scaled, to_measure_factor,
};
use super::paths::{
    Heuristic, Kind, PathTerms, Vertex, direct_to_camera, emission, endpoint, hittable,
    join_subpaths, medium_towards, nee_density, origin_density,
};
use super::unguided::PathSink;
use crate::bsdf::TransportMode;
use crate::error::Result;
use crate::geometry::gamma;
use crate::math::{Sampler, SamplerKind, Spectrum};
use crate::path::{MAX_VERTICES, Path};
use crate::render::{Budget, Integrator, RenderContext, RenderResult, RowTracer, render_rows};
use crate::scene::{Endpoint, Scene};
use cache::{Cached, cache_subpath, mis_sums};
use glam::{Vec2, Vec3};
use settings::settings;
pub use settings::{
    BdptSettings, DIRECT_SPLATS_OPTION, LT_OPTIONS, MIS_OPTION, OPTIONS, RR_DEPTH, RR_DEPTH_OPTION,
    TechniqueFilter, heuristic,
};
pub use technique::TECHNIQUE_STREAMS;
pub use unguided::BdptUnguided;
pub use walk::camera_subpath;
use walk::roulette;
use weights::Bridge;

/// Build bdpt from its parameters.
pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Bdpt {
        settings: settings(params, false)?,
        sampler: params.sampler()?,
    }))
}

/// Build lt (light tracing: bdpt's t = 1 techniques alone) from its parameters.
pub fn build_lt(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Bdpt {
        settings: settings(params, true)?,
        sampler: params.sampler()?,
    }))
}

/// Bidirectional path tracing (and light tracing) as an integrator.
pub struct Bdpt {
    /// Depth limit, Russian roulette, heuristic and techniques.
    pub settings: BdptSettings,
    /// Whose numbers each pixel's camera and light subpaths draw (option `sampler`).
    pub sampler: SamplerKind,
}

impl Integrator for Bdpt {
    fn name(&self) -> &'static str {
        if self.settings.light_tracing {
            "lt"
        } else {
            "bdpt"
        }
    }

    fn settings(&self) -> String {
        format!("{:?}, sampler: {:?}", self.settings, self.sampler)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        render_rows(ctx, budget, self.sampler, || {
            Tracer::new(ctx.scene, &self.settings)
        })
    }
}

/// Next-event density of a light subpath's first vertex from its second (`nee_k` of every
/// technique with s >= 2); 0 for subpaths of fewer than two vertices.
fn light_nee(scene: &Scene, light: &[Vertex]) -> f64 {
    match (light.first(), light.get(1)) {
        (
            Some(
                l0 @ Vertex {
                    kind: Kind::Light { light },
                    ..
                },
            ),
            Some(l1),
        ) => nee_density(scene, l1, l0, *light),
        _ => 0.0,
    }
}

impl<'a> RowTracer for Tracer<'a> {
    fn sample<S: Sampler>(&mut self, raster: Vec2, sampler: &mut S) -> Spectrum {
        Tracer::sample(self, raster, sampler)
    }

    fn take_splats(&mut self) -> Vec<(u32, Spectrum)> {
        std::mem::take(&mut self.splats)
    }
}

/// Called with every complete path a technique forms: the path (camera first), the
/// technique's s, and the density terms it assembled for its MIS weight (for tests).
pub type Inspector<'a> = Box<dyn FnMut(&[Vertex<'a>], usize, &PathTerms) + 'a>;

/// Per-thread state: subpath buffers and their per-vertex caches (reused), the density terms
/// of the current connection, and the splats of the current row.
pub struct Tracer<'a> {
    scene: &'a Scene,
    settings: &'a BdptSettings,
    camera: Vec<Vertex<'a>>,
    light: Vec<Vertex<'a>>,
    camera_cache: Vec<Cached>,
    light_cache: Vec<Cached>,
    /// Next-event density of the light subpath's first vertex from its second (`nee_k` of
    /// every technique with s >= 2).
    light_nee: f64,
    terms: PathTerms,
    /// Scratch for the technique densities of the current connection.
    densities: Vec<f64>,
    /// (pixel, value) light-tracing splats (t = 1) of the current row.
    pub splats: Vec<(u32, Spectrum)>,
    /// Called with every complete path a technique forms, when set (tests).
    pub inspector: Option<std::cell::RefCell<Inspector<'a>>>,
    /// Recording mode ([`Tracer::sample_recorded`]): the weight functions leave the path they
    /// weigh in `joined` and its densities in `pending`, and return 1 (the raw estimate).
    recording: bool,
    pending: Option<recording::Pending>,
    joined: Vec<Vertex<'a>>,
    path_buf: Path,
    /// Pixel of the sample being traced.
    pixel: u32,
    /// Weigh by assembling every technique's density even where the recursive weights apply
    /// (for tests: the two must agree).
    pub explicit_weights: bool,
    /// Recording mode: the light vertex of the last next-event estimation (for `deliver`).
    nee_vertex: Vertex<'a>,
}

impl<'a> Tracer<'a> {
    /// A tracer for `scene` with `settings`, its buffers empty.
    pub fn new(scene: &'a Scene, settings: &'a BdptSettings) -> Tracer<'a> {
        // Room for typical paths; longer ones grow the buffers (max_depth may be unlimited).
        let n = (settings.max_depth as usize)
            .saturating_add(2)
            .min(MAX_VERTICES);
        Tracer {
            scene,
            settings,
            camera: Vec::with_capacity(n),
            light: Vec::with_capacity(n),
            camera_cache: Vec::with_capacity(n),
            light_cache: Vec::with_capacity(n),
            light_nee: 0.0,
            terms: PathTerms::new(0),
            densities: Vec::new(),
            splats: Vec::new(),
            inspector: None,
            recording: false,
            pending: None,
            joined: Vec::with_capacity(n),
            path_buf: Path::default(),
            pixel: 0,
            explicit_weights: false,
            nee_vertex: Vertex::new(Kind::Camera, Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// The recursive (O(1)) MIS weights apply: roulette from the first bounce (every
    /// roulette factor is the vertex's local probability, from either end), no path longer
    /// than the deep-path cap, and nobody inspecting the explicit densities. (In recording
    /// mode they weigh the paths the sink takes without densities: `recording.rs`.)
    fn recursive_mis(&self) -> bool {
        self.settings.rr_depth <= 1
            && (self.settings.max_depth as usize) < super::paths::DEEP_SEGMENTS
            && !self.settings.light_tracing
            && !self.explicit_weights
            && self.inspector.is_none()
            && !crate::check::enabled()
    }

    /// One BDPT sample: returns the value for the pixel at `raster` (t >= 2) and pushes the
    /// light-tracing contributions (t = 1) to `splats`.
    pub fn sample(&mut self, raster: Vec2, sampler: &mut impl Sampler) -> Spectrum {
        self.run(raster, sampler, None)
    }

    /// The sample loop: with `sink`, paths go there (recording mode) and the return is zero.
    fn run<'k>(
        &mut self,
        raster: Vec2,
        sampler: &mut impl Sampler,
        mut sink: Option<&mut (dyn PathSink + 'k)>,
    ) -> Spectrum {
        let (scene, st) = (self.scene, self.settings);
        self.pixel = scene.camera.pixel_index(raster) as u32;
        let max_depth = st.max_depth as usize;
        let mut camera = std::mem::take(&mut self.camera);
        let mut light_buf = std::mem::take(&mut self.light);
        let mut cc = std::mem::take(&mut self.camera_cache);
        let mut lc_buf = std::mem::take(&mut self.light_cache);
        let camera_vertices = if st.light_tracing { 1 } else { max_depth + 1 };
        walk::camera_subpath(
            scene,
            raster,
            camera_vertices,
            st.rr_depth,
            sampler,
            &mut camera,
        );
        cache_subpath(scene, &camera, st.rr_depth, &mut cc);
        let recursive = self.recursive_mis();
        if recursive {
            mis_sums(&camera, &mut cc, None, st.heuristic);
        }
        walk::light_subpath(scene, max_depth + 1, st.rr_depth, sampler, &mut light_buf);
        cache_subpath(scene, &light_buf, st.rr_depth, &mut lc_buf);
        self.light_nee = light_nee(scene, &light_buf);
        if recursive {
            let nee = Some(self.light_nee);
            mis_sums(&light_buf, &mut lc_buf, nee, st.heuristic);
        }
        let (light, lc) = (&light_buf[..], &lc_buf[..]);
        let mut l = Spectrum::ZERO;
        for t in 1..=camera.len() {
            for s in 0..=light.len() {
                let k = s + t - 1;
                if k == 0
                    || k > max_depth
                    || (st.light_tracing && t != 1)
                    || !st.techniques.includes(s, t)
                {
                    continue;
                }
                if s == 0 {
                    l += self.hit_emitter(&camera[..t], &cc[..t], sink.as_deref_mut());
                } else if t == 1 {
                    if let Some((raster, c)) =
                        self.connect_camera(&camera[..1], &cc[..1], &light[..s], &lc[..s])
                    {
                        let u = scene.camera.splat_number(sampler);
                        let Some((pixel, w)) = scene.camera.splat_pixel(raster, u) else {
                            continue;
                        };
                        let (pixel, c) = (pixel as u32, c * w);
                        match sink.as_deref_mut() {
                            Some(sink) => {
                                self.deliver(c, Some(pixel), sink, &camera[..1], &light[..s], true)
                            }
                            None => self.splats.push((pixel, c)),
                        }
                    }
                } else {
                    let c = if s == 1 {
                        self.next_event(&camera[..t], &cc[..t], sampler)
                    } else {
                        self.connect(&camera[..t], &cc[..t], &light[..s], &lc[..s])
                    };
                    match sink.as_deref_mut() {
                        Some(sink) => {
                            // Next-event estimation's light vertex is its own, not the
                            // light subpath's.
                            let nee = [self.nee_vertex];
                            let lp = if s == 1 { &nee[..] } else { &light[..s] };
                            self.deliver(c, None, sink, &camera[..t], lp, true)
                        }
                        None => l += c,
                    }
                }
            }
        }
        self.camera = camera;
        self.light = light_buf;
        self.camera_cache = cc;
        self.light_cache = lc_buf;
        l
    }

    /// s = 0: the last camera vertex is on an emitter (or at infinity). With `sink`
    /// (recording mode) each emitter's path goes there and the return is zero.
    fn hit_emitter<'k>(
        &mut self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        mut sink: Option<&mut (dyn PathSink + 'k)>,
    ) -> Spectrum {
        let scene = self.scene;
        let t = c.len();
        let y = &c[t - 1];
        let prev = c[t - 2].p;
        let mut sum = Spectrum::ZERO;
        let mut add = |tracer: &mut Self, light: usize, le: Spectrum, emitter: Vertex<'a>| {
            if le == Spectrum::ZERO {
                return;
            }
            let w = if tracer.settings.light_tracing {
                1.0
            } else {
                tracer.weight_emitter_hit(c, cc, &emitter, light)
            };
            let value = y.beta * le * w as f32;
            match sink.as_deref_mut() {
                Some(sink) => tracer.deliver(
                    value,
                    None,
                    sink,
                    &c[..t - 1],
                    std::slice::from_ref(&emitter),
                    false,
                ),
                None => sum += value,
            }
        };
        match y.kind {
            Kind::Light { .. } => {
                // Escaped: every light at infinity, each with its own densities.
                for &li in &scene.infinite_lights {
                    let le = scene.lights[li].le(Vec3::ZERO, Vec3::ZERO, y.n);
                    add(
                        self,
                        li,
                        le,
                        Vertex {
                            kind: Kind::Light { light: li },
                            ..*y
                        },
                    );
                }
            }
            Kind::Surface { info, .. } => {
                if let Some(li) = info.light {
                    let li = li as usize;
                    let le = scene.lights[li].le(y.p, y.n, (prev - y.p).normalize());
                    add(
                        self,
                        li,
                        le,
                        Vertex {
                            kind: Kind::Light { light: li },
                            delta: false,
                            ..*y
                        },
                    );
                }
            }
            _ => {}
        }
        sum
    }

    /// s = 1, t >= 2: next-event estimation from the last camera vertex.
    fn next_event(
        &mut self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        sampler: &mut impl Sampler,
    ) -> Spectrum {
        let scene = self.scene;
        let t = c.len();
        let (y, cy) = (&c[t - 1], &cc[t - 1]);
        let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
        if !cy.connectible {
            return Spectrum::ZERO;
        }
        let Some((light, pmf)) = scene.light_sampler.sample(u_light) else {
            return Spectrum::ZERO;
        };
        let l = &scene.lights[light];
        let Some(ls) = l.sample_li(y.p, u) else {
            return Spectrum::ZERO;
        };
        let infinite = l.is_infinite();
        // A light at infinity sits one unit along its direction (see the walk).
        let target = if infinite { y.p + ls.wi } else { ls.p };
        let n = if infinite { ls.wi } else { ls.n };
        let lv = Vertex {
            p_err: gamma(8) * ls.p.abs(),
            delta: l.is_delta(),
            ..Vertex::new(Kind::Light { light }, target, n)
        };
        let end = connection_end(scene, y, cy.wo, ls.wi, TransportMode::Radiance);
        if end.f == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let light_end = (!infinite).then_some(Endpoint {
            p: ls.p,
            n: ls.n,
            err: lv.p_err,
        });
        let Some(tr) = scene.transmittance(
            &endpoint(y),
            light_end.as_ref(),
            ls.wi,
            medium_towards(scene, y, ls.wi),
        ) else {
            return Spectrum::ZERO;
        };
        let contribution = y.beta * end.f * ls.li * tr.tr / (pmf * ls.pdf);
        let conn = Edge::along(&tr);
        // Both the BSDF's and next-event's densities of the light point convert by one factor.
        let g_light = to_measure_factor(scene, y.p, &lv);
        let bridge = Bridge {
            cam_next: scaled(end.pdf_other, g_light) * conn.factor(scene, false, true),
            light_next: pdf(scene, &lv, None, y) * conn.factor(scene, y.is_medium(), false),
            cam_back: end.pdf_prev * cy.to_prev * y.edge.factor(scene, c[t - 2].is_medium(), false),
            light_back: 0.0,
        };
        let nee = pmf * ls.pdf;
        let nee_k = if lv.delta {
            nee as f64
        } else {
            scaled(nee, g_light) as f64
        };
        let lc = [Cached::first(scene, &lv)];
        let w = self.weight_connection(c, cc, std::slice::from_ref(&lv), &lc, &bridge, nee_k);
        if self.recording {
            self.nee_vertex = lv;
        }
        contribution * w as f32
    }

    /// Whether a path pinhole -> `x1` on `light` through vacuum is left to s = 0 under these
    /// settings (`paths::direct_to_camera`; never for `lt` or with `direct_splats`).
    pub(super) fn left_to_camera(&self, light: usize, x1: Vec3) -> bool {
        !self.settings.light_tracing
            && !self.settings.direct_splats
            && direct_to_camera(self.scene, light, x1)
    }
}
