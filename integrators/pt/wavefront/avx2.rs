//! The wavefront kernel over sixteen lanes in two AVX registers of eight: the shared kernel
//! files compiled over `simd_avx2.rs` (module doc of `wavefront`).

// The kernel's files are compiled once per instruction set on purpose (module doc of
// `wavefront`), hence `duplicate_mod`.
#[allow(clippy::duplicate_mod)]
#[path = "lanes.rs"]
mod lanes;
#[allow(clippy::duplicate_mod)]
#[path = "math.rs"]
mod math;
#[allow(clippy::duplicate_mod)]
#[path = "shade.rs"]
mod shade;
#[path = "simd_avx2.rs"]
mod simd;
#[cfg(test)]
#[allow(clippy::duplicate_mod)]
#[path = "tests.rs"]
mod tests;

#[cfg(test)]
use super::Isa;
use crate::integrators::pt::round::Round;
use crate::integrators::pt::{PathState, PathTracer};
use crate::math::{Sampler, Spectrum};
use crate::scene::Scene;

/// The instruction set of this kernel (its lane tests run where the CPU has it).
#[cfg(test)]
const ISA: Isa = Isa::Avx2;

/// [`shade::rounds`] compiled for `avx2`.
///
/// # Safety
/// The CPU must have `avx2` ([`super::Isa::on_this_cpu`]).
#[target_feature(enable = "avx2")]
pub(super) unsafe fn rounds<S: Sampler>(
    pt: &PathTracer,
    scene: &Scene,
    paths: Vec<(usize, PathState)>,
    samplers: &mut [S],
    out: &mut [Spectrum],
    b: &mut Round,
) {
    shade::rounds(pt, scene, paths, samplers, out, b);
}
