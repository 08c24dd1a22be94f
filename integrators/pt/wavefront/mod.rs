//! Wavefront pt: a row's paths traced in rounds of one segment, their vertices shaded
//! sixteen at a time in vector registers.
//!
//! Batched pt (`batch.rs`) traces a row's rays together but shades each path on its own.
//! Here each round's closest hits come from [`Scene::intersect_many`] as there, and then the
//! round's paths are shaded in groups of sixteen (`shade.rs`): what a path does at a vertex
//! (next-event estimation, the continuation, roulette, the spawned ray) runs as sixteen-lane
//! operations (`lanes.rs`), with only the table look-ups (material, light, the point
//! on a light), emission and the random numbers done path by path. The round's shadow rays
//! then go through [`Scene::unoccluded_many`] together. The lanes repeat scalar pt's
//! arithmetic operation for operation (`math.rs`) and each path draws from its own sampler in
//! pt's order, so the image is pt's bit for bit (test `wavefront_pt_is_pt_bit_for_bit` in
//! `tests/pt_batch.rs`).
//!
//! The lanes shade surfaces of diffuse (plain or textured: the albedo is looked up path by
//! path), smooth conductor (mirror), smooth dielectric or black materials (checkerboards and
//! one-sided materials included) without normal maps (`shade::in_lanes`), with next-event
//! samples of any light (points on mesh lights and the cone samples of spherical lights
//! computed in the lanes, other lights' samples path by path). A vertex on any other
//! surface (rough and plastic BSDFs, masks, normal or bump maps, null surfaces) is advanced
//! in the gather step by pt's own code, its shadow ray joining the round's batch, and its
//! lane stays idle. The wavefront applies
//! ([`supports`]) to scenes without media, with the `mis` strategy and no `--check`, on
//! x86-64 CPUs with AVX2. `pt -O batch=auto` (the default) takes it there; elsewhere pt is
//! batched or traced one path at a time as `batch.rs` says.
//!
//! **Why the rough BSDFs are not in the lanes.** The lanes' contract is scalar pt's image bit
//! for bit. Beckmann's visible-normal sampler (Mitsuba's default microfacet distribution) is
//! a Newton-bisection search, data-dependent and up to 100 steps, over `erf_inv` and `exp`;
//! `exp` and `ln` come from the system's libm, whose results the lanes cannot repeat bit for
//! bit (glibc picks its FMA variants by CPU), so lanes would first need those functions
//! replaced by polynomials shared with the scalar code, changing every image with a Beckmann
//! surface. GGX samples and evaluates in closed form and could be written in lanes as it is;
//! rough plastic adds its coating tables and lobe choice, and the conductors their complex
//! Fresnel term. What lanes would buy is bounded by the share of this scalar code in a
//! render, measured in `docs/results.md` ("Against Mitsuba 3") beside the share of the
//! splatted film, which runs path by path too.
//!
//! **Two instruction sets, one kernel.** `lanes.rs`, `math.rs` and `shade.rs` are compiled
//! twice, into `avx512` (sixteen lanes in one register) and `avx2` (two registers of
//! eight), each over its own `simd` module (`simd_avx512.rs`, `simd_avx2.rs`) that supplies
//! the lanes' primitive operations. Both repeat the scalar arithmetic, so they give the same
//! image bit for bit; [`Isa::detect`] picks the widest the CPU has, and
//! `pt -O batch=wavefront-avx2` takes the AVX2 kernel on any CPU with AVX2.

use super::round::ROUND;
use super::{PathState, PathTracer, Strategy};
use crate::math::{Sampler, Spectrum};
use crate::scene::Scene;
use glam::Vec2;

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;

/// Paths per kernel call: the lanes of both kernels.
pub const W: usize = 16;

/// The vector instructions a wavefront kernel is compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Isa {
    /// AVX-512F: sixteen f32 lanes per register.
    Avx512,
    /// AVX2: eight f32 lanes per register, two registers per sixteen lanes.
    Avx2,
}

impl Isa {
    /// The widest instruction set the CPU has, `None` without AVX2.
    pub fn detect() -> Option<Isa> {
        [Isa::Avx512, Isa::Avx2]
            .into_iter()
            .find(|isa| isa.on_this_cpu())
    }

    /// Whether the CPU has these instructions.
    pub fn on_this_cpu(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return match self {
            Isa::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            Isa::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
        };
        #[cfg(not(target_arch = "x86_64"))]
        false
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
        assert!(isa.on_this_cpu(), "{isa:?} instructions are not available");
        let paths = PathState::row(scene, rasters);
        ROUND.with_borrow_mut(|b| {
            #[cfg(target_arch = "x86_64")]
            match isa {
                // SAFETY: the CPU has the instructions (checked above).
                Isa::Avx512 => unsafe { avx512::rounds(self, scene, paths, samplers, out, b) },
                Isa::Avx2 => unsafe { avx2::rounds(self, scene, paths, samplers, out, b) },
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
}
