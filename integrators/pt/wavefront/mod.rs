//! Wavefront pt: a row's paths traced in rounds of one segment, their vertices shaded
//! sixteen at a time in vector registers.
//!
//! Batched pt (`batch.rs`) traces a row's rays together but shades each path on its own.
//! Here each round's closest hits come from [`Scene::intersect_many`] as there, and then the
//! round's paths are shaded in groups of sixteen (`shade.rs`): what a path does at a vertex
//! (next-event estimation, the continuation, roulette, the spawned ray) runs as sixteen-lane
//! operations (`lanes.rs`, AVX-512), with only the table look-ups (material, light, the point
//! on a light), emission and the random numbers done path by path. The round's shadow rays
//! then go through [`Scene::unoccluded_many`] together. The lanes repeat scalar pt's
//! arithmetic operation for operation (`math.rs`) and each path draws from its own sampler in
//! pt's order, so the image is pt's bit for bit (test `wavefront_pt_is_pt_bit_for_bit` in
//! `tests/pt_batch.rs`).
//!
//! The lanes shade surfaces of diffuse (plain or textured: the albedo is looked up path by
//! path), smooth conductor (mirror), smooth dielectric or black materials (checkerboards and
//! one-sided materials included) without normal maps (`shade::in_lanes`), with next-event
//! samples of any light. A vertex on any other surface (rough and plastic BSDFs, masks,
//! normal or bump maps, null surfaces) is advanced in the gather step by pt's own code,
//! its shadow ray joining the round's batch, and its lane stays idle. The wavefront applies
//! ([`supports`]) to scenes without media, with the `mis` strategy and no `--check`, on
//! x86-64 CPUs with AVX-512. `pt -O batch=auto` (the default) takes it there; elsewhere pt is
//! batched or traced one path at a time as `batch.rs` says.

#[cfg(target_arch = "x86_64")]
mod lanes;
#[cfg(target_arch = "x86_64")]
mod math;
#[cfg(target_arch = "x86_64")]
mod shade;
#[cfg(all(test, target_arch = "x86_64"))]
mod tests;

use super::round::{ROUND, Round};
use super::{PathState, PathTracer, Strategy};
use crate::math::{Sampler, Spectrum};
use crate::scene::Scene;
use glam::Vec2;

/// The vector instructions the kernel is compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Isa {
    /// AVX-512: sixteen f32 lanes per register.
    Avx512,
}

impl Isa {
    /// What the CPU has, `None` without AVX-512.
    pub fn detect() -> Option<Isa> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Some(Isa::Avx512);
        }
        None
    }
}

/// Whether the wavefront can trace `scene` for `pt` (module doc): no media, and options the
/// lanes follow.
pub fn supports(pt: &PathTracer, scene: &Scene) -> bool {
    !scene.features.media && pt.settings.strategy == Strategy::Mis && !crate::check::enabled()
}

impl PathTracer {
    /// [`Self::li`] for the rasters of a row, each with its own sampler, into `out`: the same
    /// values bit for bit (module doc). `scene` must be one [`supports`] accepts, `isa` one
    /// the CPU has.
    pub fn li_row_wavefront<S: Sampler>(
        &self,
        scene: &Scene,
        rasters: &[Vec2],
        samplers: &mut [S],
        out: &mut [Spectrum],
        isa: Isa,
    ) {
        assert!(supports(self, scene), "the wavefront does not apply here");
        assert_eq!(
            Isa::detect(),
            Some(isa),
            "{isa:?} instructions are not available"
        );
        let paths = PathState::row(scene, rasters);
        ROUND.with_borrow_mut(|b| {
            #[cfg(target_arch = "x86_64")]
            match isa {
                // SAFETY: the CPU has AVX-512F (checked above); nothing else is required.
                Isa::Avx512 => unsafe { self.rounds_avx512(scene, paths, samplers, out, b) },
            }
            #[cfg(not(target_arch = "x86_64"))]
            unreachable!(
                "{isa:?} without x86-64: {} paths, {} samplers, {} outputs, {} rays",
                paths.len(),
                samplers.len(),
                out.len(),
                b.rays.len()
            );
        });
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn rounds_avx512<S: Sampler>(
        &self,
        scene: &Scene,
        paths: Vec<(usize, PathState)>,
        samplers: &mut [S],
        out: &mut [Spectrum],
        b: &mut Round,
    ) {
        self.wavefront_rounds(scene, paths, samplers, out, b);
    }

    /// The rounds of [`Self::li_row_wavefront`] until every path of `paths` has ended.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn wavefront_rounds<S: Sampler>(
        &self,
        scene: &Scene,
        mut paths: Vec<(usize, PathState)>,
        samplers: &mut [S],
        out: &mut [Spectrum],
        b: &mut Round,
    ) {
        while !paths.is_empty() {
            b.trace(scene, &paths);
            for (c, (group, hits)) in paths
                .chunks_mut(lanes::W)
                .zip(b.hits.chunks_mut(lanes::W))
                .enumerate()
            {
                self.shade_lanes(
                    scene,
                    group,
                    hits,
                    samplers,
                    c * lanes::W,
                    &mut b.alive,
                    &mut b.deferred,
                    &mut b.owner,
                );
            }
            b.settle(scene, &mut paths, out);
        }
    }
}
