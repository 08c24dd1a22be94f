//! What an unguided estimator offers to a technique mixed with it (DESIGN.md §3, §5).
//!
//! An [`Unguided`] estimator (pt, bdpt) traces one sample per pixel and pass and reports every
//! complete path it forms to a [`PathSink`], with the path's measurement contribution f(X)
//! and `p_u(X)`, the sum of the densities of all its own techniques for that path. It can also
//! evaluate `p_u` for any path (`pdf_unguided`), including paths another technique made. With
//! these two, a second technique (the guider, `integrators::guided`) forms the balance
//! heuristic over both, `f / (n_u p_u + n_g p_g)`, for every path either side finds, without
//! knowing how the estimator works.
//!
//! | estimator | techniques summed in `p_u` |
//! |-----------|----------------------------|
//! | `pt`      | the continuation hitting the emitter (s = 0) and next-event estimation (s = 1) |
//! | `bdpt`    | every (s, t) split (`paths::path_terms`) |
//! | `vcm`     | every (s, t) split, and merging at every non-delta surface vertex with the pass's radius (`vcm/densities.rs`) |
//!
//! Samples of pt and bdpt are independent; vcm's share the light subpaths of their pass
//! (traced once per pass by `begin_pass`), so everything that traces or weighs is given the
//! pass's state (`Unguided::Pass`).
//!
//! Where the sink needs the densities of only some paths (the guider's render passes: those
//! whose structure its cache holds, a [`HeldPaths`] test), an estimator may trace the pass
//! with a faster tracer that hands every other path over weighted by its own techniques
//! (`Unguided::renew_render_pass`): vcm's tracer weighs with its recursive weights and hands
//! over with their densities only the paths the test holds (in learning passes, every path).
//!
//! This module holds the traits and what any estimator or the guider uses with them alone
//! ([`own_row`], `finite`); it stands on the path algebra (`integrators/paths/`) only. Each
//! estimator implements the traits in its own folder: `pt/unguided.rs` (on `PathTracer`),
//! `bdpt/unguided.rs` (`bdpt::BdptUnguided`) and `vcm/unguided.rs` (`vcm::VcmUnguided`).

use super::paths::Vertex;
use crate::camera::Camera;
use crate::math::sobol::SobolSampler;
use crate::math::{IndependentSampler, Sampler, SamplerKind};
use crate::path::{Path, Vertex as PathVertex};
use crate::scene::Scene;
use glam::{DVec3, Vec2};
use std::sync::Arc;

/// Which paths a sink needs the densities of, beyond those of learning (the guider's render
/// passes: the paths whose structure its cache holds, which the guided technique could make
/// too). Every other path takes U's own weights.
pub trait HeldPaths: Send + Sync {
    /// Whether the path `head` followed by `tail` reversed (camera first, ending on an
    /// emitter) is held.
    fn holds(&self, scene: &Scene, head: &[PathVertex], tail: &[PathVertex]) -> bool;

    /// A necessary condition for [`Self::holds`], cheap enough to ask of every path: whether
    /// some held structure's hash (`paths::structure`) agrees with `h` in its low
    /// `HeldKey::BITS` bits (the only bits that count). A tracer that keeps the two sides'
    /// partial hashes asks this first and [`Self::holds`] only when it passes.
    fn may_hold_hash(&self, h: u64) -> bool {
        let _ = h;
        true
    }
}

/// Receives the complete paths of one unguided sample.
pub trait PathSink {
    /// `path` runs camera first to an emitter; its `pixel` is where x_1 projects. `y` is the
    /// same path as BDPT vertices when the estimator has them (else the sink converts `path`
    /// if it needs them). `f` is f(X) (We included, f64 end to end), `p_u` the sum of the
    /// estimator's technique densities for the path (image-wide, one sample of each technique
    /// per pixel; equal to `pdf_unguided`). `splat`: the path lands in another pixel than the
    /// one traced.
    fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, splat: bool);

    /// Whether the sink needs the densities of the path `head` followed by `tail` reversed
    /// (camera first) before the estimator has assembled them. An estimator whose own MIS
    /// weights are cheaper than its densities (bdpt's and vcm's recursive weights: O(1)
    /// against O(k) per path) asks this first, and hands a path the sink declines to
    /// [`PathSink::record_weighted`], weighted by its own techniques alone. The default
    /// takes every path with its densities.
    fn needs_densities(&mut self, _head: &[Vertex], _tail: &[Vertex]) -> bool {
        true
    }

    /// [`PathSink::record`] of a path whose `p_u` U computed from `y` itself
    /// (`pdf_unguided`), so the sink need not recompute it.
    fn record_from_vertices(&mut self, path: &Path, y: &[Vertex], f: DVec3, p_u: f64, splat: bool) {
        self.record(path, Some(y), f, p_u, splat);
    }

    /// A path accepted by [`PathSink::needs_densities`], before the estimator assembles its
    /// densities: when the sink can tell from `path` alone that the path needs no more than
    /// the estimator's own weights (vcm: the guided density is 0 because no guide path's
    /// first-vertex kernel reaches x_1), it books `value`, the path's contribution under those
    /// weights (`splat` as in `record`), and returns true; otherwise the estimator goes on to
    /// [`PathSink::record_from_vertices`]. The default books nothing.
    fn record_if_own_weight(&mut self, path: &Path, value: DVec3, splat: bool) -> bool {
        let _ = (path, value, splat);
        false
    }

    /// The luminance at or below which a path needs neither its vertices nor its densities
    /// (read before each sample): the sink books such a path at the estimator's own weight,
    /// one path at a time, by [`PathSink::record_dim`]. An estimator whose paths are many
    /// and cheap to weigh (vcm's merges) hands those below it over so; the default,
    /// -infinity, takes none.
    fn own_weight_floor(&mut self) -> f64 {
        f64::NEG_INFINITY
    }

    /// A path of luminance at or below [`PathSink::own_weight_floor`] (read before the
    /// sample that formed it): `value` is its contribution under the estimator's own weights,
    /// for `pixel` (`splat` as in `record`).
    fn record_dim(&mut self, pixel: u32, value: DVec3, splat: bool) {
        let _ = (pixel, value, splat);
        unreachable!("a sink with an own-weight floor takes the paths below it");
    }

    /// A path declined by [`PathSink::needs_densities`]: `value` is its contribution under
    /// the estimator's own weights, `f / p_u`, for `pixel` (`splat` as in `record`).
    fn record_weighted(&mut self, pixel: u32, value: DVec3, splat: bool) {
        let _ = (pixel, value, splat);
        unreachable!("a sink that declines densities takes the weighted paths too");
    }
}

/// An unbiased estimator a guided technique can be mixed with.
pub trait Unguided: Sync + Send {
    /// Per-thread state (subpath buffers), made once per row.
    type Tracer<'s>
    where
        Self: 's;
    /// What one pass's samples share (vcm: the light subpaths and the merging grid; `()` for
    /// pt and bdpt).
    type Pass<'s>: Sync
    where
        Self: 's;

    /// Registry name of the estimator alone (`pt`, `bdpt`, `vcm`).
    fn name(&self) -> &'static str;
    /// Maximum number of path segments of the paths the estimator forms.
    fn max_depth(&self) -> u32;
    /// The shared state of a pass: `stream` is the pass's random-stream index, `ordinal` its
    /// position among the passes of the render (0, 1, ...; vcm's radius shrinks with it).
    fn begin_pass<'s>(
        &'s self,
        scene: &'s Scene,
        seed: u64,
        stream: u64,
        ordinal: u64,
    ) -> Self::Pass<'s>;
    /// [`Unguided::begin_pass`] in the memory of an earlier pass's state, `spent` (if any):
    /// the same state as a fresh one (vcm refills its light subpaths and grid in place).
    fn renew_pass<'s>(
        &'s self,
        scene: &'s Scene,
        seed: u64,
        stream: u64,
        ordinal: u64,
        spent: Option<Self::Pass<'s>>,
    ) -> Self::Pass<'s> {
        drop(spent);
        self.begin_pass(scene, seed, stream, ordinal)
    }
    /// A pass of the guider's render phase, whose sink needs the densities of the paths
    /// `held` holds only (`None`: of none) and takes every other one weighted
    /// (`PathSink::record_weighted`); the default is [`Unguided::renew_pass`]. vcm traces it
    /// with its own tracer.
    #[allow(clippy::too_many_arguments)]
    fn renew_render_pass<'s>(
        &'s self,
        scene: &'s Scene,
        seed: u64,
        stream: u64,
        ordinal: u64,
        spent: Option<Self::Pass<'s>>,
        held: Option<&Arc<dyn HeldPaths>>,
    ) -> Self::Pass<'s> {
        let _ = held;
        self.renew_pass(scene, seed, stream, ordinal, spent)
    }
    /// Per-thread state for tracing samples of `pass` (one per row).
    fn tracer<'s, 'p: 's>(&'s self, scene: &'s Scene, pass: &'s Self::Pass<'p>)
    -> Self::Tracer<'s>;
    /// One sample through raster position `raster`; every path it forms goes to `sink`.
    fn trace(
        &self,
        tracer: &mut Self::Tracer<'_>,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn PathSink,
    );
    /// U's own estimate of the pixel at `raster` (its own MIS weights, nothing recorded):
    /// what the guider renders with when it has no guided samples to mix in. Splats
    /// (light-tracing paths) are pushed to `splats`.
    fn estimate(
        &self,
        tracer: &mut Self::Tracer<'_>,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        splats: &mut Vec<(u32, DVec3)>,
    ) -> DVec3;
    /// [`Self::estimate`] for the pixels of a row, `rasters[i]` drawn with `samplers[i]`,
    /// into `out`: by default one after the other. An estimator may trace the row together
    /// as long as each value stays `estimate`'s bit for bit (pt: batched, or as a wavefront).
    fn estimate_row<S: Sampler>(
        &self,
        tracer: &mut Self::Tracer<'_>,
        scene: &Scene,
        rasters: &[Vec2],
        samplers: &mut [S],
        splats: &mut Vec<(u32, DVec3)>,
        out: &mut [DVec3],
    ) {
        for ((&r, sampler), o) in rasters.iter().zip(samplers).zip(out) {
            *o = self.estimate(tracer, scene, r, sampler, splats);
        }
    }
    /// Sum over the estimator's techniques of their densities for path `y` (camera first,
    /// a light last) in pass `pass`; 0 for paths it cannot form (longer than `max_depth`).
    fn pdf_unguided(&self, scene: &Scene, pass: &Self::Pass<'_>, y: &[Vertex]) -> f64;
    /// Rays the pass's shared work took (vcm: its light subpaths), counted with U's cost.
    fn pass_rays(&self, _pass: &Self::Pass<'_>) -> u64 {
        0
    }
    /// U's own integrator with the same settings and `sampler` for its pixel samples, to
    /// render with when guiding is off, where it is faster than the guider's passes of U
    /// alone (`None`: those passes).
    fn own_integrator(
        &self,
        _sampler: crate::math::SamplerKind,
    ) -> Option<Box<dyn crate::render::Integrator>> {
        None
    }
    /// Samples of each technique per pass (n_u): one per pixel.
    fn samples_per_pass(&self, scene: &Scene) -> f64 {
        scene.camera.pixel_count() as f64
    }
}

/// `v` if finite and non-negative, else 0 (as the pass drivers drop invalid samples).
pub(crate) fn finite(v: DVec3) -> DVec3 {
    if v.is_finite() && v.min_element() >= 0.0 {
        v
    } else {
        DVec3::ZERO
    }
}

/// U's own estimates of row `y`, pixel i's sample drawn from the stream (seed, pass, i) of
/// sampler `kind` (first its jitter, as U's driver draws it), traced together where U can
/// (`Unguided::estimate_row`: pt as a wavefront): what the guider renders when it has no
/// guided samples to mix in.
pub fn own_row<U: Unguided>(
    unguided: &U,
    tracer: &mut U::Tracer<'_>,
    scene: &Scene,
    (seed, pass): (u64, u64),
    y: u32,
    kind: SamplerKind,
    splats: &mut Vec<(u32, DVec3)>,
) -> Vec<DVec3> {
    /// With the sampler's own type, as U's driver has it (the same numbers as
    /// `AnySampler`'s, without a dispatch per number).
    fn with<U: Unguided, S: Sampler>(
        unguided: &U,
        tracer: &mut U::Tracer<'_>,
        scene: &Scene,
        y: u32,
        splats: &mut Vec<(u32, DVec3)>,
        sampler: impl Fn(u64) -> S,
    ) -> Vec<DVec3> {
        let w = scene.camera.resolution.x;
        let mut samplers: Vec<S> = (0..w)
            .map(|x| sampler(y as u64 * w as u64 + x as u64))
            .collect();
        let rasters: Vec<Vec2> = (samplers.iter_mut().enumerate())
            .map(|(x, s)| Camera::jittered(x as u32, y, s.next_2d()))
            .collect();
        let mut values = vec![DVec3::ZERO; w as usize];
        unguided.estimate_row(tracer, scene, &rasters, &mut samplers, splats, &mut values);
        values
    }
    match kind {
        SamplerKind::Independent => with(unguided, tracer, scene, y, splats, |i| {
            IndependentSampler::new(seed, pass, i)
        }),
        SamplerKind::Sobol => with(unguided, tracer, scene, y, splats, |i| {
            SobolSampler::new(seed, pass, i)
        }),
    }
}
