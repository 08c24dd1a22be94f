//! Which samples become guide paths (spec §6.3a): a brightness cascade over 4 x 4-pixel
//! blocks with base 2 and 10 levels counts, per block, how many samples of similar brightness
//! the learning iterations have produced. A sample's normalised weight `c` (its `C = f / (α
//! p_u + (1 − α) p_g)` over the mean pixel value) is split between the two levels around it
//! so that it counts exactly once; its *trust* is the count of the other samples in levels ℓ −
//! 1 .. ℓ + 1 of its block per iteration so far. A sample with trust <= 0.25 is an outlier (a
//! contribution few similar samples back up); each worker keeps the 100 largest per iteration.
//!
//! Deviation from the reference code, for images independent of the thread count: trust is
//! evaluated after the whole iteration has been splatted (minus the sample's own count), and
//! the "workers" are fixed bands of rows, not threads.

/// Levels of the cascade; level i holds samples around brightness 2^i.
pub const LEVELS: usize = 10;
/// Side of a block, in pixels.
pub const BLOCK: u32 = 4;
/// Outliers have at most this many similar samples per iteration in their block.
pub const TRUST_THRESHOLD: f64 = 0.25;

/// Per block of the image and brightness level, the count of samples seen so far.
pub struct OutlierCascade {
    width: u32,
    blocks_x: u32,
    counts: Vec<f64>,
}

/// Count shares of a sample of normalised brightness `c`: (level, share) pairs adding to 1.
pub fn count_shares(c: f64) -> [(usize, f64); 2] {
    if !(c >= 1.0) {
        return [(0, 1.0), (0, 0.0)];
    }
    let i = c.log2().floor() as usize;
    if i >= LEVELS - 1 {
        return [(LEVELS - 1, 1.0), (LEVELS - 1, 0.0)];
    }
    let s = (1u64 << i) as f64;
    // Value split w_lo = (s/c - 1/b) / (1 - 1/b) with b = 2; counts = value share / scale.
    let w_lo = 2.0 * s / c - 1.0;
    [(i, w_lo * c / s), (i + 1, (1.0 - w_lo) * c / (2.0 * s))]
}

impl OutlierCascade {
    /// An empty cascade over an image of `width` x `height` pixels.
    pub fn new(width: u32, height: u32) -> OutlierCascade {
        let blocks_x = width.div_ceil(BLOCK);
        let blocks_y = height.div_ceil(BLOCK);
        OutlierCascade {
            width,
            blocks_x,
            counts: vec![0.0; (blocks_x * blocks_y) as usize * LEVELS],
        }
    }

    fn block(&self, pixel: u32) -> usize {
        let (x, y) = (pixel % self.width, pixel / self.width);
        ((y / BLOCK) * self.blocks_x + x / BLOCK) as usize
    }

    /// Count a sample of normalised brightness `c` in `pixel`'s block, split over the two
    /// levels around it.
    pub fn add(&mut self, pixel: u32, c: f64) {
        let b = self.block(pixel) * LEVELS;
        for (level, share) in count_shares(c) {
            self.counts[b + level] += share;
        }
    }

    /// Samples of similar brightness to `c` in its block per iteration, the sample itself
    /// excluded, after `iterations` iterations have been added.
    pub fn trust(&self, pixel: u32, c: f64, iterations: u32) -> f64 {
        let b = self.block(pixel) * LEVELS;
        let l = if c >= 1.0 {
            (c.log2().floor() as usize).min(LEVELS - 1)
        } else {
            0
        };
        let (lo, hi) = (l.saturating_sub(1), (l + 1).min(LEVELS - 1));
        let mut n: f64 = self.counts[b + lo..=b + hi].iter().sum();
        for (level, share) in count_shares(c) {
            if (lo..=hi).contains(&level) {
                n -= share;
            }
        }
        n.max(0.0) / iterations.max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_sample_counts_once() {
        for c in [0.0, 0.3, 1.0, 1.5, 2.0, 3.7, 100.0, 511.0, 512.0, 1e6] {
            let s = count_shares(c);
            assert!((s[0].1 + s[1].1 - 1.0).abs() < 1e-12, "{c}: {s:?}");
            assert!(s[0].1 >= 0.0 && s[1].1 >= 0.0);
        }
        // Exactly on a level: all of it there.
        assert_eq!(count_shares(4.0)[0], (2, 1.0));
    }

    #[test]
    fn trust_counts_similar_samples_of_the_block_only() {
        let mut c = OutlierCascade::new(16, 16);
        for _ in 0..8 {
            c.add(0, 1.5); // block 0, dim
        }
        c.add(5, 300.0); // block 1, bright
        c.add(1, 300.0); // block 0, bright: alone at its brightness
        assert_eq!(c.trust(1, 300.0, 1), 0.0);
        assert!((c.trust(0, 1.5, 2) - 3.5).abs() < 1e-12);
        assert_eq!(c.trust(5, 300.0, 1), 0.0);
    }
}
