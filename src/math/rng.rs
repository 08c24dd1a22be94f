//! Random numbers. Every sample draws from its own counter-based stream, keyed by
//! (seed, pass, index), so an image never depends on which thread drew which sample.
//! Integrators take `&mut impl Sampler`, so Markov-chain samplers can later substitute
//! primary-sample-space streams without touching the tracing code.

use glam::Vec2;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

/// A source of uniform numbers in [0, 1).
pub trait Sampler {
    /// The next uniform number in [0, 1).
    fn next_1d(&mut self) -> f32;
    /// The next two uniform numbers (one 2D point for stratified samplers).
    fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        let y = self.next_1d();
        Vec2::new(x, y)
    }
    /// A uniform number in [0, 1) with at least 48 bits of resolution (discrete choices among
    /// many items, where `next_1d`'s 24 bits would skew the probabilities: with 100k items an
    /// f32 uniform gives some items 168 / 2^24 and others 167 / 2^24).
    fn next_f64(&mut self) -> f64 {
        let hi = self.next_1d() as f64;
        let lo = self.next_1d() as f64;
        hi + lo * (1.0 / (1u64 << 24) as f64)
    }
    /// Switch to stream `index` of a sample: Markov-chain samplers keep each stream's
    /// dimensions apart (camera walk, light walk, connections), so a change in the number of
    /// numbers one part draws does not shift the next part's; independent samplers ignore it.
    fn start_stream(&mut self, _index: u32) {}
}

/// A sampler the pass driver builds for sample `pass` of pixel `pixel` (the pixel's own
/// stream, so images do not depend on which thread drew which sample).
pub trait PixelSampler: Sampler + Send {
    /// The sampler of pass `pass` of pixel `pixel` under render seed `seed`.
    fn for_pixel(seed: u64, pass: u64, pixel: u64) -> Self;
}

/// SplitMix64 finaliser: a bijective 64-bit mix.
#[inline]
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The 64-bit key of stream (seed, pass, index); distinct inputs give decorrelated keys.
#[inline]
pub fn stream_seed(seed: u64, pass: u64, index: u64) -> u64 {
    mix64(mix64(mix64(seed ^ 0x6c6f_6465_7374_6172) ^ pass) ^ index)
}

/// PCG32 stream seeded from (seed, pass, index).
pub struct IndependentSampler {
    rng: Pcg32,
}

impl IndependentSampler {
    /// The stream keyed by (seed, pass, index).
    pub fn new(seed: u64, pass: u64, index: u64) -> Self {
        let key = stream_seed(seed, pass, index);
        IndependentSampler {
            rng: Pcg32::new(key, mix64(key ^ 0x5851_f42d_4c95_7f2d)),
        }
    }

    /// A stream seeded from one number (not keyed like the render's streams).
    pub fn from_u64(seed: u64) -> Self {
        IndependentSampler {
            rng: Pcg32::seed_from_u64(seed),
        }
    }
}

impl PixelSampler for IndependentSampler {
    fn for_pixel(seed: u64, pass: u64, pixel: u64) -> Self {
        IndependentSampler::new(seed, pass, pixel)
    }
}

impl Sampler for IndependentSampler {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        self.rng.random::<f32>()
    }
    /// 53 bits.
    #[inline]
    fn next_f64(&mut self) -> f64 {
        self.rng.random::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f32> = (0..4)
            .map({
                let mut s = IndependentSampler::new(1, 2, 3);
                move |_| s.next_1d()
            })
            .collect();
        let b: Vec<f32> = (0..4)
            .map({
                let mut s = IndependentSampler::new(1, 2, 3);
                move |_| s.next_1d()
            })
            .collect();
        let c: Vec<f32> = (0..4)
            .map({
                let mut s = IndependentSampler::new(1, 2, 4);
                move |_| s.next_1d()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!(a.iter().all(|&x| (0.0..1.0).contains(&x)));
    }
}
