//! `vcm` as the guider's unguided estimator: bdpt's recording tracer with merging in
//! learning passes, vcm's own tracer with claimed held paths in render passes.

use crate::geometry::HashGrid;
use crate::integrators::bdpt::{self, BdptSettings, SharedLights, bdpt_estimate};
use crate::integrators::paths::{self, Vertex};
use crate::integrators::unguided::{HeldPaths, PathSink, Unguided, finite};
use crate::integrators::vcm::{self, CameraTracer, Claimed, LightPaths, Photon, Technique};
use crate::math::{PI, Sampler};
use crate::path::MAX_VERTICES;
use crate::scene::Scene;
use glam::{DVec3, Vec2, Vec3};
use std::sync::Arc;

/// VCM as an unguided estimator: BDPT's techniques and vertex merging, all weighed by the
/// balance heuristic, from explicit densities where the sink needs them, else by the
/// recursive weights (`bdpt/merging.rs`). Consistent: merging's
/// radius shrinks with the pass, r_i = r_0 (i + 1)^((alpha - 1) / 2).
pub struct VcmUnguided {
    /// BDPT's depth limit and Russian roulette, with the balance heuristic.
    pub settings: BdptSettings,
    /// Initial radius r_0 (`None`: 0.003 x the scene's bounding-sphere radius, as `vcm`).
    pub radius: Option<f32>,
    /// Radius schedule exponent alpha in (0, 1].
    pub alpha: f32,
}

impl VcmUnguided {
    /// The merging radius of the pass with this ordinal.
    pub fn radius_at(&self, scene: &Scene, ordinal: u64) -> f32 {
        self.radius.unwrap_or(0.003 * scene.radius)
            * ((ordinal + 1) as f32).powf(0.5 * (self.alpha - 1.0))
    }
}

/// The state of one of guided-vcm's passes.
pub enum VcmPass<'s> {
    /// bdpt's light subpaths and grid, for bdpt's recording tracer (learning passes, and
    /// render passes whose sink needs every path's densities).
    /// (Boxed, as `Fast`: both hold a photon grid inline.)
    Recording(Box<SharedLights<'s>>),
    /// vcm's own light subpaths and grid, for vcm's tracer (render passes with a
    /// [`HeldPaths`] test).
    Fast(Box<FastPass<'s>>),
}

/// A render pass traced by vcm's own tracer: the paths `held` holds are claimed (kept
/// unweighted, `vcm::Claimed`) and handed to the sink with their densities; every other one
/// goes to it with vcm's weight.
pub struct FastPass<'s> {
    settings: vcm::VcmSettings,
    pc: vcm::PassConstants,
    lights: LightPaths<'s>,
    /// The grid's input (kept for its memory).
    points: Vec<(Vec3, Photon)>,
    grid: HashGrid<Photon>,
    held: Arc<dyn HeldPaths>,
    /// eta = pi r^2 N, as `SharedLights` has it.
    eta: f64,
}

/// What traces guided-vcm's samples: bdpt's recording tracer or vcm's (by the pass).
pub enum VcmTracer<'s> {
    /// (Boxed: bdpt's tracer holds its subpath buffers inline.)
    Recording(Box<bdpt::Tracer<'s>>),
    /// (Boxed: the camera tracer keeps its subpath and its structure hash inline.)
    Fast {
        /// vcm's camera tracer over the pass's light subpaths and grid.
        tracer: Box<CameraTracer<'s, 's>>,
        /// eta = pi r^2 N of the pass.
        eta: f64,
    },
}

impl VcmUnguided {
    /// vcm's settings for the same estimator (its tracer plays roulette from the first
    /// bounce: `None` for another `rr_depth`).
    fn vcm_settings(&self) -> Option<vcm::VcmSettings> {
        let s = &self.settings;
        (s.rr_depth <= 1).then_some(vcm::VcmSettings {
            max_depth: s.max_depth,
            radius: self.radius,
            alpha: self.alpha,
            connect: true,
            merge: true,
            direct_splats: s.direct_splats,
        })
    }

    /// The technique densities of `y` (camera first, a light last) for a pass with
    /// `eta = pi r^2 N`: BDPT's by s in `vc[..=k]`, merging at y_j in `vm[j]`, and the sum of
    /// all (`pdf_unguided`); `None` past `max_depth`.
    fn technique_densities(
        &self,
        scene: &Scene,
        eta: f64,
        y: &[Vertex],
    ) -> Option<([f64; MAX_VERTICES], [f64; MAX_VERTICES], f64)> {
        thread_local! {
            /// Scratch of the path's terms: held paths are weighed one after another.
            static TERMS: std::cell::RefCell<paths::PathTerms> =
                std::cell::RefCell::new(paths::PathTerms::new(0));
        }
        let (mut vc, mut vm) = ([0.0f64; MAX_VERTICES], [0.0f64; MAX_VERTICES]);
        let sum = TERMS.with_borrow_mut(|terms| {
            bdpt::densities_from_vertices(scene, y, &self.settings, eta, terms, &mut vc, &mut vm)
        })?;
        Some((vc, vm, sum))
    }

    /// Hand a path vcm's tracer claimed to `sink` with f(X) and `p_u` from its vertices (the
    /// claimed value is the technique's unweighted estimate f / p_technique). The sink is
    /// asked first whether vcm's own weight will do (`PathSink::record_if_own_weight`: the
    /// guided density is 0); so is it when the explicit densities do not take the path (a
    /// vertex count past max_depth, a density of 0 where vcm's differs in f32).
    fn deliver(&self, scene: &Scene, eta: f64, c: &Claimed, sink: &mut dyn PathSink) {
        let own = (c.value * c.weight).as_dvec3();
        let weighted = |sink: &mut dyn PathSink| sink.record_weighted(c.path.pixel, own, c.splat);
        // Most held paths have p_g = 0 at x_1 already: vcm's weight is then theirs.
        if sink.record_if_own_weight(&c.path, own, c.splat) {
            return;
        }
        let Some(y) = paths::from_path(scene, &c.path) else {
            return weighted(sink);
        };
        let Some((vc, vm, p_u)) = self.technique_densities(scene, eta, &y) else {
            return weighted(sink);
        };
        let k = y.len() - 1;
        let p_s = match c.technique {
            Technique::Connect { s } => vc[s],
            Technique::Merge { t } => vm[t],
        };
        if !(p_s > 0.0 && p_s.is_finite() && p_u.is_finite()) || k == 0 {
            return weighted(sink);
        }
        let f = c.value.as_dvec3() * p_s;
        sink.record_from_vertices(&c.path, &y, f, p_u, c.splat);
    }
}

/// The pixel (row-major index) of raster position `raster` (the guider's rasters are
/// `Camera::jittered`, so this is the pixel it traces).
fn pixel_of(scene: &Scene, raster: Vec2) -> usize {
    scene.camera.pixel_index(raster)
}

impl Unguided for VcmUnguided {
    type Tracer<'s> = VcmTracer<'s>;
    type Pass<'s> = VcmPass<'s>;

    fn name(&self) -> &'static str {
        "vcm"
    }

    fn max_depth(&self) -> u32 {
        self.settings.max_depth
    }

    fn begin_pass<'s>(
        &'s self,
        scene: &'s Scene,
        seed: u64,
        stream: u64,
        ordinal: u64,
    ) -> VcmPass<'s> {
        self.renew_pass(scene, seed, stream, ordinal, None)
    }

    fn renew_pass<'s>(
        &'s self,
        scene: &'s Scene,
        seed: u64,
        stream: u64,
        ordinal: u64,
        spent: Option<VcmPass<'s>>,
    ) -> VcmPass<'s> {
        let r = self.radius_at(scene, ordinal);
        let mut pass = match spent {
            Some(VcmPass::Recording(p)) => p,
            _ => Box::default(),
        };
        pass.retrace(scene, &self.settings, seed, stream, r);
        VcmPass::Recording(pass)
    }

    /// vcm's own tracer when the sink needs the densities of held paths only (and vcm's
    /// tracer is the same estimator: roulette from the first bounce); light subpath k from
    /// stream `(seed, stream, LIGHT_STREAMS + k)`, as bdpt's shared ones.
    fn renew_render_pass<'s>(
        &'s self,
        scene: &'s Scene,
        seed: u64,
        stream: u64,
        ordinal: u64,
        spent: Option<VcmPass<'s>>,
        held: Option<&Arc<dyn HeldPaths>>,
    ) -> VcmPass<'s> {
        let (Some(held), Some(settings)) = (held, self.vcm_settings()) else {
            return self.renew_pass(scene, seed, stream, ordinal, spent);
        };
        let pc = vcm::PassConstants::new(&settings, scene, ordinal);
        let mut pass = match spent {
            Some(VcmPass::Fast(mut p)) => {
                p.settings = settings;
                p.pc = pc;
                p.held = held.clone();
                p
            }
            _ => Box::new(FastPass {
                settings,
                pc,
                lights: LightPaths::default(),
                points: Vec::new(),
                grid: HashGrid::default(),
                held: held.clone(),
                eta: 0.0,
            }),
        };
        let p = &mut *pass;
        let res = scene.camera.resolution;
        let (rows, row_len) = (res.y.max(1) as usize, res.x as usize);
        let streams = (seed, stream, bdpt::LIGHT_STREAMS);
        let claims: &dyn HeldPaths = &*p.held;
        p.lights.trace(
            scene,
            &p.settings,
            &p.pc,
            streams,
            rows,
            row_len,
            Some(claims),
        );
        vcm::mergeable_points(&p.lights, &mut p.points);
        p.grid.rebuild(&p.points, p.pc.radius);
        let r = p.pc.radius as f64;
        p.eta = PI as f64 * r * r * scene.camera.pixel_count() as f64;
        VcmPass::Fast(pass)
    }

    fn pass_rays(&self, pass: &VcmPass<'_>) -> u64 {
        match pass {
            VcmPass::Recording(p) => p.rays,
            VcmPass::Fast(p) => p.lights.rays(),
        }
    }

    fn tracer<'s, 'p: 's>(&'s self, scene: &'s Scene, pass: &'s VcmPass<'p>) -> VcmTracer<'s> {
        match pass {
            VcmPass::Recording(p) => {
                VcmTracer::Recording(Box::new(bdpt::Tracer::merging(scene, &self.settings, p)))
            }
            VcmPass::Fast(p) => VcmTracer::Fast {
                tracer: Box::new(CameraTracer::new(
                    scene,
                    &p.settings,
                    &p.pc,
                    &p.lights,
                    Some(&p.grid),
                    None,
                    Some(&*p.held),
                )),
                eta: p.eta,
            },
        }
    }

    /// `vcm` with the same radius schedule, depth and directly-seen-emitter rule: the same
    /// estimator with recursive (O(1)) weights; only with roulette from the first bounce,
    /// which is what vcm plays.
    fn own_integrator(
        &self,
        sampler: crate::math::SamplerKind,
    ) -> Option<Box<dyn crate::render::Integrator>> {
        self.vcm_settings().map(|settings| {
            Box::new(vcm::Vcm { settings, sampler }) as Box<dyn crate::render::Integrator>
        })
    }

    /// With vcm's tracer, pixel k also hands over light subpath k's light-tracing paths.
    fn trace(
        &self,
        tracer: &mut VcmTracer<'_>,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn PathSink,
    ) {
        match tracer {
            VcmTracer::Recording(t) => t.sample_recorded(raster, sampler, sink),
            VcmTracer::Fast { tracer: ct, eta } => {
                let k = pixel_of(scene, raster);
                for &(pixel, c) in ct.lights.splats_of(k) {
                    sink.record_weighted(pixel, c.as_dvec3(), true);
                }
                for c in ct.lights.claimed_of(k) {
                    self.deliver(scene, *eta, c, sink);
                }
                let l = ct.sample(k, raster, sampler);
                sink.record_weighted(k as u32, l.as_dvec3(), false);
                for c in ct.claimed().as_slice() {
                    self.deliver(scene, *eta, c, sink);
                }
                ct.claimed().clear();
            }
        }
    }

    fn estimate(
        &self,
        tracer: &mut VcmTracer<'_>,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        splats: &mut Vec<(u32, DVec3)>,
    ) -> DVec3 {
        match tracer {
            VcmTracer::Recording(t) => bdpt_estimate(t, raster, sampler, splats),
            VcmTracer::Fast { tracer: ct, .. } => {
                // vcm's own estimate: claimed paths count with vcm's weight.
                let k = pixel_of(scene, raster);
                let lights = ct.lights;
                let light_paths = lights.splats_of(k).iter().copied().chain(
                    (lights.claimed_of(k).iter()).map(|c| (c.path.pixel, c.value * c.weight)),
                );
                for (pixel, c) in light_paths {
                    let c = finite(c.as_dvec3());
                    if c != DVec3::ZERO {
                        splats.push((pixel, c));
                    }
                }
                let mut l = ct.sample(k, raster, sampler).as_dvec3();
                for c in ct.claimed().as_slice() {
                    l += (c.value * c.weight).as_dvec3();
                }
                ct.claimed().clear();
                finite(l)
            }
        }
    }

    fn pdf_unguided(&self, scene: &Scene, pass: &VcmPass<'_>, y: &[Vertex]) -> f64 {
        let eta = match pass {
            VcmPass::Recording(p) => p.eta,
            VcmPass::Fast(p) => p.eta,
        };
        self.technique_densities(scene, eta, y)
            .map_or(0.0, |(_, _, sum)| sum)
    }
}
