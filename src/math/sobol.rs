//! Owen-scrambled Sobol points, padded: the low-discrepancy sampler of `-O sampler=sobol`
//! (pt, bdpt, lt; the camera subpaths of vcm and bpm).
//!
//! A pixel's n-th sample (n = the pass) takes its d-th pair of numbers from the first two
//! dimensions of the Sobol sequence at a shuffled index, each dimension Owen-scrambled with its
//! own seed (Burley 2020, "Practical hash-based Owen scrambling"; pbrt-v4's
//! `PaddedSobolSampler`). So every pair a path draws (pixel jitter, light point, BSDF
//! direction, ...) is stratified over the pixel's samples: the first 2^k samples of any pair
//! form a (0, k, 2)-net, and any prefix is close to one. Pairs are decorrelated from each other
//! by the index shuffle (a nested scramble of the index, which maps the first 2^k indices onto
//! an aligned block of 2^k Sobol points, itself a net), not stratified jointly.
//!
//! Unbiased: for a fixed index every scrambled point is uniform in [0, 1)^2, and the seeds of
//! different pixels and dimensions are decorrelated hashes of (seed, pixel, dimension), so each
//! sample is uniform in the unit hypercube and the estimate's expectation is the integral. The
//! samples of one pixel are not independent (that is the point: their errors cancel), so
//! variances estimated from pass-to-pass spread overstate the error of the mean.
//!
//! Deterministic in (seed, pixel, pass): a render split into passes or across threads draws
//! the same numbers.

use super::Sampler;
use super::rng::{PixelSampler, mix64, stream_seed};

#[cfg(test)]
/// Sobol's first dimension: the van der Corput sequence in base 2 (bits of the index reversed).
#[inline]
fn sobol_dim0(index: u32) -> u32 {
    index.reverse_bits()
}

/// Sobol's second dimension (generator matrix: Pascal's triangle mod 2), by bytes of the
/// index from [`SOBOL1`]: the index is a shuffled, full 32-bit number, where a loop over its
/// bits was most of the sampler's cost.
#[inline]
fn sobol_dim1(index: u32) -> u32 {
    let t = &SOBOL1;
    t[0][(index & 255) as usize]
        ^ t[1][((index >> 8) & 255) as usize]
        ^ t[2][((index >> 16) & 255) as usize]
        ^ t[3][(index >> 24) as usize]
}

/// `SOBOL1[p][b]`: the second dimension's value of the index whose byte p is b (others 0).
static SOBOL1: [[u32; 256]; 4] = sobol1_tables();

const fn sobol1_tables() -> [[u32; 256]; 4] {
    // Column k of the generator matrix (the value of index 1 << k).
    let mut v = [0u32; 32];
    let mut c = 1u32 << 31;
    let mut k = 0;
    while k < 32 {
        v[k] = c;
        c ^= c >> 1;
        k += 1;
    }
    let mut t = [[0u32; 256]; 4];
    let mut p = 0;
    while p < 4 {
        let mut b = 0;
        while b < 256 {
            let mut r = 0;
            let mut bit = 0;
            while bit < 8 {
                if (b >> bit) & 1 != 0 {
                    r ^= v[8 * p + bit];
                }
                bit += 1;
            }
            t[p][b] = r;
            b += 1;
        }
        p += 1;
    }
    t
}

/// [`sobol_dim1`] bit by bit (the recurrence the tables are built from; for tests).
#[cfg(test)]
fn sobol_dim1_by_bits(mut index: u32) -> u32 {
    let mut v = 1u32 << 31;
    let mut r = 0;
    while index != 0 {
        if index & 1 != 0 {
            r ^= v;
        }
        index >>= 1;
        v ^= v >> 1;
    }
    r
}

/// Laine and Karras' hash permutation: output bit k depends only on input bits 0..=k, so on
/// bit-reversed numbers it is a nested (Owen) scramble.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Nested uniform (Owen) scramble of a 32-bit fraction: bit j of the result depends on bits
/// j and above of `x` and on the seed.
#[inline]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The three 32-bit scramble seeds of dimension `dim` (index shuffle, first and second
/// coordinate) from one 64-bit mix of the pixel's key: the key is already a full hash, so one
/// mix per draw decorrelates dimensions (a draw is a few dozen cycles, not a few hundred).
#[inline]
fn dim_seeds(key: u64, dim: u32) -> [u32; 3] {
    let h = mix64(key.wrapping_add((dim as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15)));
    let third = h.wrapping_mul(0xd6e8_feb8_6659_fd93) >> 32;
    [h as u32, (h >> 32) as u32, third as u32]
}

#[inline]
fn to_unit(x: u32) -> f32 {
    // 24 bits: exactly representable and strictly below 1.
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// The padded Owen-scrambled Sobol sampler of one pixel sample (see the module doc).
#[derive(Clone, Debug)]
pub struct SobolSampler {
    /// Hash of (seed, pixel): the root of every dimension's scramble seeds.
    key: u64,
    /// The sample's index among the pixel's samples (the pass), bits reversed.
    rindex: u32,
    /// The next dimension (a 1D draw and a 2D draw each take one).
    dim: u32,
}

impl SobolSampler {
    /// Sample `pass` of pixel `pixel`: the pass-th point of the pixel's scrambled sequence.
    pub fn new(seed: u64, pass: u64, pixel: u64) -> Self {
        SobolSampler {
            key: stream_seed(seed ^ 0x736f_626f_6c00, 0, pixel),
            rindex: (pass as u32).reverse_bits(),
            dim: 0,
        }
    }

    #[inline]
    fn next_dim(&mut self) -> u32 {
        let d = self.dim;
        self.dim += 1;
        d
    }

    /// Dimension `d`'s shuffled Sobol index and the scramble seeds of its two coordinates.
    #[inline]
    fn index_and_seeds(&self, d: u32) -> (u32, u32, u32) {
        let [shuffle, sx, sy] = dim_seeds(self.key, d);
        // `owen_scramble(index, shuffle)` with the index's reversal done once in `new`.
        let i = laine_karras(self.rindex, shuffle).reverse_bits();
        (i, sx, sy)
    }

    /// Dimension `d`'s pair, each Sobol coordinate scrambled (32 bits).
    /// (`owen_scramble(sobol_dim0(i), s)` is `laine_karras(i, s)` reversed: the reversals
    /// cancel.)
    #[inline]
    fn pair(&self, d: u32) -> (u32, u32) {
        let (i, sx, sy) = self.index_and_seeds(d);
        (
            laine_karras(i, sx).reverse_bits(),
            owen_scramble(sobol_dim1(i), sy),
        )
    }

    /// Dimension `d`'s first coordinate alone (32 bits).
    #[inline]
    fn single(&self, d: u32) -> u32 {
        let (i, sx, _) = self.index_and_seeds(d);
        laine_karras(i, sx).reverse_bits()
    }
}

impl PixelSampler for SobolSampler {
    fn for_pixel(seed: u64, pass: u64, pixel: u64) -> Self {
        SobolSampler::new(seed, pass, pixel)
    }
}

impl Sampler for SobolSampler {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let d = self.next_dim();
        to_unit(self.single(d))
    }

    #[inline]
    fn next_2d(&mut self) -> glam::Vec2 {
        let d = self.next_dim();
        let (x, y) = self.pair(d);
        glam::Vec2::new(to_unit(x), to_unit(y))
    }

    /// The 32 scrambled bits on top, 21 hashed bits below them (discrete choices among many
    /// items; the stratification is in the top bits).
    #[inline]
    fn next_f64(&mut self) -> f64 {
        let d = self.next_dim();
        let hi = self.single(d) as f64 * (1.0 / 4_294_967_296.0);
        let lo = (stream_seed(self.key, d as u64, self.rindex as u64) >> 43) as f64;
        hi + lo * (1.0 / (4_294_967_296.0 * 2_097_152.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_unscrambled_dimensions_are_sobols() {
        // The first eight points of Sobol's first two dimensions in index (not Gray-code) order,
        // as eighths.
        let x: Vec<u32> = (0..8).map(|i| sobol_dim0(i) >> 29).collect();
        let y: Vec<u32> = (0..8).map(|i| sobol_dim1(i) >> 29).collect();
        assert_eq!(x, [0, 4, 2, 6, 1, 5, 3, 7]);
        assert_eq!(y, [0, 4, 6, 2, 5, 1, 3, 7]);
        let mut rng = crate::math::IndependentSampler::new(1, 2, 3);
        for _ in 0..10_000 {
            let i = (rng.next_f64() * 4_294_967_296.0) as u32;
            assert_eq!(sobol_dim1(i), sobol_dim1_by_bits(i), "index {i}");
            let (s, x) = (i.rotate_left(7), i.rotate_left(13));
            assert_eq!(
                owen_scramble(sobol_dim0(x), s),
                laine_karras(x, s).reverse_bits()
            );
        }
    }

    /// Every elementary interval of a (0, k, 2)-net holds exactly one of the first 2^k points:
    /// checked for k = 8 on all 9 shapes (2^a x 2^(8-a) boxes), several pixels and dimensions.
    #[test]
    fn the_first_power_of_two_samples_of_every_pair_form_a_net() {
        let k = 8u32;
        let n = 1u32 << k;
        for pixel in [0u64, 7, 12345] {
            for dim in 0..5u32 {
                let pts: Vec<(u32, u32)> = (0..n)
                    .map(|pass| SobolSampler::new(3, pass as u64, pixel).pair(dim))
                    .collect();
                for a in 0..=k {
                    let mut seen = vec![false; n as usize];
                    for &(x, y) in &pts {
                        let cx = if a == 0 { 0 } else { x >> (32 - a) };
                        let cy = if a == k { 0 } else { y >> (32 - (k - a)) };
                        let cell = (cx << (k - a)) | cy;
                        assert!(!seen[cell as usize], "pixel {pixel} dim {dim} shape {a}");
                        seen[cell as usize] = true;
                    }
                }
            }
        }
    }

    /// Uniformity over many pixels at a fixed sample index (the unbiasedness argument): each
    /// coordinate's histogram over 64 bins passes a chi-square test (df 63; the threshold 120
    /// has a false-failure rate below 1e-5 per histogram; fixed seed).
    #[test]
    fn a_fixed_sample_index_is_uniform_across_pixels() {
        for pass in [0u64, 1, 5] {
            for dim in 0..3 {
                let mut hx = [0u32; 64];
                let mut hy = [0u32; 64];
                let m = 64_000;
                for pixel in 0..m {
                    let mut s = SobolSampler::new(9, pass, pixel);
                    for _ in 0..dim {
                        s.next_1d();
                    }
                    let p = s.next_2d();
                    hx[(p.x * 64.0) as usize] += 1;
                    hy[(p.y * 64.0) as usize] += 1;
                }
                for h in [hx, hy] {
                    let e = m as f64 / 64.0;
                    let chi2: f64 = h.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
                    assert!(chi2 < 120.0, "pass {pass} dim {dim}: chi2 {chi2}");
                }
            }
        }
    }

    #[test]
    fn draws_are_in_the_unit_interval_and_reproducible() {
        let draw = |pass| {
            let mut s = SobolSampler::new(1, pass, 42);
            (s.next_1d(), s.next_2d(), s.next_f64())
        };
        assert_eq!(draw(3), draw(3));
        assert_ne!(draw(3), draw(4));
        for pass in 0..1000 {
            let (a, b, c) = draw(pass);
            assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&c));
            assert!((0.0..1.0).contains(&b.x) && (0.0..1.0).contains(&b.y));
        }
    }
}
