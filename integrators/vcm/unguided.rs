//! `vcm` as the guider's unguided estimator: vcm's own tracer (recursive weights) in every
//! pass. A [`HeldPaths`] test decides which paths it hands to the sink with their densities
//! from the vertices (`densities.rs`): every path in learning passes, the paths whose
//! structure the cache holds in render passes, none with guiding off; every other path goes
//! to the sink weighted by vcm's own weights.

use super::densities::densities_from_vertices;
use crate::geometry::HashGrid;
use crate::integrators::bdpt::BdptSettings;
use crate::integrators::paths::{self, Vertex};
use crate::integrators::unguided::{HeldPaths, PathSink, Unguided, finite};
use crate::integrators::vcm::{self, CameraTracer, Claimed, LightPaths, Photon, Technique};
use crate::math::{PI, Sampler};
use crate::path::{MAX_VERTICES, Path, Vertex as PathVertex};
use crate::scene::Scene;
use glam::{DVec3, Vec2, Vec3};
use std::sync::Arc;

/// VCM as an unguided estimator: BDPT's techniques and vertex merging, all weighed by the
/// balance heuristic, recursively (vcm's tracer) where the sink takes vcm's weights, from
/// explicit densities where it needs them. Consistent: merging's radius shrinks with the
/// pass, r_i = r_0 (i + 1)^((alpha - 1) / 2). Russian roulette from the first bounce, as vcm
/// plays it (`rr_depth` 1).
pub struct VcmUnguided {
    /// BDPT's depth limit and Russian roulette, with the balance heuristic (for the explicit
    /// densities; `rr_depth` is 1).
    pub settings: BdptSettings,
    /// Initial radius r_0 (`None`: 0.003 x the scene's bounding-sphere radius, as `vcm`).
    pub radius: Option<f32>,
    /// Radius schedule exponent alpha in (0, 1].
    pub alpha: f32,
}

/// The claims test of learning passes: the guider learns from every path, with its densities.
struct Every;

impl HeldPaths for Every {
    fn holds(&self, _: &Scene, _: &[PathVertex], _: &[PathVertex]) -> bool {
        true
    }
}

/// One of guided-vcm's passes: vcm's light subpaths and photon grid, and which paths the sink
/// takes with their densities (`held`; `None`: none).
pub struct VcmPass<'s> {
    settings: vcm::VcmSettings,
    pc: vcm::PassConstants,
    lights: LightPaths<'s>,
    /// The grid's input (kept for its memory).
    points: Vec<(Vec3, Photon)>,
    grid: HashGrid<Photon>,
    held: Option<Arc<dyn HeldPaths>>,
    /// eta = pi r^2 N of the pass.
    eta: f64,
}

/// What traces guided-vcm's samples: vcm's camera tracer over the pass's light subpaths and
/// grid. (Boxed: it keeps its subpath and its structure hash inline.)
pub struct VcmTracer<'s> {
    tracer: Box<CameraTracer<'s, 's>>,
    /// eta = pi r^2 N of the pass.
    eta: f64,
    /// Where a claimed path is laid out for the sink.
    path: Box<Path>,
}

impl VcmUnguided {
    /// vcm's settings for the same estimator.
    fn vcm_settings(&self) -> vcm::VcmSettings {
        let s = &self.settings;
        vcm::VcmSettings {
            max_depth: s.max_depth,
            radius: self.radius,
            alpha: self.alpha,
            connect: true,
            merge: true,
            direct_splats: s.direct_splats,
        }
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
            densities_from_vertices(scene, y, &self.settings, eta, terms, &mut vc, &mut vm)
        })?;
        Some((vc, vm, sum))
    }

    /// Hand a path vcm's tracer claimed to `sink` with f(X) and `p_u` from its vertices (the
    /// claimed value is the technique's unweighted estimate f / p_technique). The sink is
    /// asked first whether vcm's own weight will do (`PathSink::record_if_own_weight`: the
    /// guided density is 0); so is it when the explicit densities do not take the path (a
    /// vertex count past max_depth, a density of 0 where vcm's differs in f32).
    fn deliver(
        &self,
        scene: &Scene,
        eta: f64,
        c: Claimed,
        path: &mut Path,
        sink: &mut dyn PathSink,
    ) {
        let own = (c.value * c.weight).as_dvec3();
        let weighted = |sink: &mut dyn PathSink| sink.record_weighted(c.pixel, own, c.splat);
        c.path_into(path);
        // Most held paths have p_g = 0 at x_1 already: vcm's weight is then theirs.
        if sink.record_if_own_weight(path, own, c.splat) {
            return;
        }
        let Some(y) = paths::from_path(scene, path) else {
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
        sink.record_from_vertices(path, &y, f, p_u, c.splat);
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

    /// A learning pass: every path is claimed and goes to the sink, with its densities where
    /// the sink needs them (`VcmUnguided::deliver`, `PathSink::own_weight_floor`).
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
        let every: Arc<dyn HeldPaths> = Arc::new(Every);
        self.renew_render_pass(scene, seed, stream, ordinal, spent, Some(&every))
    }

    /// Light subpath k from stream `(seed, stream, LIGHT_STREAMS + k)`; the paths `held`
    /// holds are claimed (kept unweighted, `vcm::Claimed`) and handed to the sink with their
    /// densities, every other one goes to it with vcm's weight.
    fn renew_render_pass<'s>(
        &'s self,
        scene: &'s Scene,
        seed: u64,
        stream: u64,
        ordinal: u64,
        spent: Option<VcmPass<'s>>,
        held: Option<&Arc<dyn HeldPaths>>,
    ) -> VcmPass<'s> {
        let settings = self.vcm_settings();
        let pc = vcm::PassConstants::new(&settings, scene, ordinal);
        let mut p = match spent {
            Some(mut p) => {
                p.settings = settings;
                p.pc = pc;
                p.held = held.cloned();
                p
            }
            None => VcmPass {
                settings,
                pc,
                lights: LightPaths::default(),
                points: Vec::new(),
                grid: HashGrid::default(),
                held: held.cloned(),
                eta: 0.0,
            },
        };
        let res = scene.camera.resolution;
        let (rows, row_len) = (res.y.max(1) as usize, res.x as usize);
        let streams = (seed, stream, crate::math::streams::LIGHT_STREAMS);
        let claims = p.held.as_deref();
        p.lights
            .trace(scene, &p.settings, &p.pc, streams, rows, row_len, claims);
        vcm::mergeable_points(&p.lights, &mut p.points);
        p.grid.rebuild(&p.points, p.pc.radius);
        let r = p.pc.radius as f64;
        p.eta = PI as f64 * r * r * scene.camera.pixel_count() as f64;
        p
    }

    fn pass_rays(&self, pass: &VcmPass<'_>) -> u64 {
        pass.lights.rays()
    }

    fn tracer<'s, 'p: 's>(&'s self, scene: &'s Scene, p: &'s VcmPass<'p>) -> VcmTracer<'s> {
        VcmTracer {
            tracer: Box::new(CameraTracer::new(
                scene,
                &p.settings,
                &p.pc,
                &p.lights,
                Some(&p.grid),
                None,
                p.held.as_deref(),
            )),
            eta: p.eta,
            path: Box::default(),
        }
    }

    /// `vcm` with the same radius schedule, depth and directly-seen-emitter rule: the same
    /// estimator without the claims.
    fn own_integrator(
        &self,
        sampler: crate::math::SamplerKind,
    ) -> Option<Box<dyn crate::render::Integrator>> {
        Some(Box::new(vcm::Vcm {
            settings: self.vcm_settings(),
            sampler,
        }))
    }

    /// Pixel k also hands over light subpath k's light-tracing paths.
    fn trace(
        &self,
        tracer: &mut VcmTracer<'_>,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn PathSink,
    ) {
        let VcmTracer {
            tracer: ct,
            eta,
            path,
        } = tracer;
        let k = pixel_of(scene, raster);
        for &(pixel, c) in ct.lights.splats_of(k) {
            sink.record_weighted(pixel, c.as_dvec3(), true);
        }
        for c in ct.lights.claimed_of(k) {
            self.deliver(scene, *eta, c, path, sink);
        }
        ct.dim_floor = sink.own_weight_floor();
        let l = ct.sample(k, raster, sampler);
        sink.record_weighted(k as u32, l.as_dvec3(), false);
        for c in ct.claimed().iter() {
            self.deliver(scene, *eta, c, path, sink);
        }
        for &(pixel, c) in ct.claimed().dim() {
            sink.record_dim(pixel, c.as_dvec3(), false);
        }
        ct.claimed().clear();
    }

    /// vcm's own estimate: claimed paths count with vcm's weight.
    fn estimate(
        &self,
        tracer: &mut VcmTracer<'_>,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        splats: &mut Vec<(u32, DVec3)>,
    ) -> DVec3 {
        let ct = &mut tracer.tracer;
        let k = pixel_of(scene, raster);
        let lights = ct.lights;
        let light_paths = lights
            .splats_of(k)
            .iter()
            .copied()
            .chain((lights.claimed_of(k)).map(|c| (c.pixel, c.value * c.weight)));
        for (pixel, c) in light_paths {
            let c = finite(c.as_dvec3());
            if c != DVec3::ZERO {
                splats.push((pixel, c));
            }
        }
        let mut l = ct.sample(k, raster, sampler).as_dvec3();
        for &(_, c) in ct.claimed().dim() {
            l += c.as_dvec3();
        }
        for c in ct.claimed().iter() {
            l += (c.value * c.weight).as_dvec3();
        }
        ct.claimed().clear();
        finite(l)
    }

    fn pdf_unguided(&self, scene: &Scene, pass: &VcmPass<'_>, y: &[Vertex]) -> f64 {
        self.technique_densities(scene, pass.eta, y)
            .map_or(0.0, |(_, _, sum)| sum)
    }
}
