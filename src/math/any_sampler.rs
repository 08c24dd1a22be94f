//! Which sampler a sample-per-pixel integrator draws from, named by an option
//! ([`SamplerKind`]) and chosen at run time ([`AnySampler`]).

use super::rng::{IndependentSampler, Sampler};
use super::sobol::SobolSampler;
use glam::Vec2;

/// Which [`super::PixelSampler`] a sample-per-pixel integrator draws from (option `sampler` of pt,
/// bdpt and lt, of vcm's and bpm's camera subpaths, and of U's samples in the guided
/// integrators' render passes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Independent uniform numbers ([`IndependentSampler`]).
    #[default]
    Independent,
    /// Padded Owen-scrambled Sobol points ([`SobolSampler`]).
    Sobol,
}

/// The sampler [`SamplerKind`] names, chosen at run time (the guided driver's render passes,
/// whose loop is not generic over the sampler): one predictable branch per draw.
pub enum AnySampler {
    /// Independent uniform numbers.
    Independent(IndependentSampler),
    /// Owen-scrambled Sobol points.
    Sobol(SobolSampler),
}

impl AnySampler {
    /// The sampler of kind `kind` for pass `pass` of pixel `pixel`.
    pub fn new(kind: SamplerKind, seed: u64, pass: u64, pixel: u64) -> Self {
        match kind {
            SamplerKind::Independent => {
                AnySampler::Independent(IndependentSampler::new(seed, pass, pixel))
            }
            SamplerKind::Sobol => AnySampler::Sobol(SobolSampler::new(seed, pass, pixel)),
        }
    }
}

impl Sampler for AnySampler {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        match self {
            AnySampler::Independent(s) => s.next_1d(),
            AnySampler::Sobol(s) => s.next_1d(),
        }
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        match self {
            AnySampler::Independent(s) => s.next_2d(),
            AnySampler::Sobol(s) => s.next_2d(),
        }
    }
    #[inline]
    fn next_f64(&mut self) -> f64 {
        match self {
            AnySampler::Independent(s) => s.next_f64(),
            AnySampler::Sobol(s) => s.next_f64(),
        }
    }
    fn start_stream(&mut self, index: u32) {
        match self {
            AnySampler::Independent(s) => s.start_stream(index),
            AnySampler::Sobol(s) => s.start_stream(index),
        }
    }
}
