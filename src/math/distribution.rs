//! Discrete distribution over `n` items proportional to non-negative weights (light power,
//! triangle area), sampled by binary search over the CDF.

/// A discrete distribution over `n` items, proportional to their weights.
#[derive(Debug, Clone)]
pub struct Distribution1D {
    /// cdf[i] = sum of pmf over items < i; cdf.len() == n + 1, cdf[n] == 1.
    cdf: Vec<f32>,
    pmf: Vec<f32>,
    total: f64,
    /// Some item has probability 0 (sampling then skips it).
    has_zero: bool,
}

/// Up to this many items, [`Distribution1D::sample`] counts cdf entries instead of searching.
const SCAN_MAX: usize = 16;

impl Distribution1D {
    /// Weights must be finite and >= 0. If all are zero, the distribution is uniform.
    pub fn new(weights: &[f32]) -> Distribution1D {
        let n = weights.len();
        let total: f64 = weights.iter().map(|&w| w.max(0.0) as f64).sum();
        let pmf: Vec<f32> = if total > 0.0 {
            weights
                .iter()
                .map(|&w| (w.max(0.0) as f64 / total) as f32)
                .collect()
        } else {
            vec![1.0 / n.max(1) as f32; n]
        };
        let mut cdf = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for &p in &pmf {
            acc += p as f64;
            cdf.push(acc as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let has_zero = pmf.contains(&0.0);
        Distribution1D {
            cdf,
            pmf,
            total,
            has_zero,
        }
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// Whether there are no items.
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Sum of the weights the distribution was built from.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of item `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// The first index whose cdf exceeds u, minus one (at most n - 1), by binary search.
    fn search(&self, u: f32) -> usize {
        self.cdf
            .partition_point(|&c| c <= u)
            .saturating_sub(1)
            .min(self.pmf.len() - 1)
    }

    /// [`Self::search`]'s index, counted without branches (the cdf is sorted and cdf[0] = 0):
    /// a choice between a few lights or a quad's two triangles is a coin flip, which a binary
    /// search's branches mispredict half the time.
    fn scan(&self, u: f32) -> usize {
        let n = self.pmf.len();
        self.cdf[1..n].iter().map(|&c| usize::from(c <= u)).sum()
    }

    /// `i`, or the nearest item after it (else before it) of non-zero probability.
    fn skip_zero(&self, mut i: usize) -> usize {
        let n = self.pmf.len();
        if self.has_zero {
            while self.pmf[i] == 0.0 && i + 1 < n {
                i += 1;
            }
            while self.pmf[i] == 0.0 && i > 0 {
                i -= 1;
            }
        }
        i
    }

    /// Sample an item; returns (index, pmf, u remapped to [0,1) within the item's interval).
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let n = self.pmf.len();
        if n == 1 {
            // One light, one triangle: no search (the same result as below).
            return (0, self.pmf[0], u.clamp(0.0, 1.0 - f32::EPSILON));
        }
        let i = if n <= SCAN_MAX {
            self.scan(u)
        } else {
            self.search(u)
        };
        let i = self.skip_zero(i);
        let p = self.pmf[i];
        let u_re = if p > 0.0 {
            ((u - self.cdf[i]) / p).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        (i, p, u_re)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_follows_the_weights() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        assert_eq!(d.sample(0.0).0, 0);
        assert_eq!(d.sample(0.24).0, 0);
        assert_eq!(d.sample(0.26).0, 2);
        assert_eq!(d.sample(0.999_999).0, 2);
        assert!((d.pmf(2) - 0.75).abs() < 1e-6);
        assert_eq!(d.pmf(1), 0.0);
        let (_, _, ur) = d.sample(0.625);
        assert!((ur - 0.5).abs() < 1e-5);
    }

    /// The counting scan of small distributions picks the binary search's item, at and
    /// around every cdf entry (where the two could disagree) and at random points.
    #[test]
    fn the_scan_of_small_distributions_agrees_with_the_search() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        for n in 2..=2 * SCAN_MAX {
            for _ in 0..20 {
                let w: Vec<f32> = (0..n)
                    .map(|_| if next() < 0.2 { 0.0 } else { next() })
                    .collect();
                let d = Distribution1D::new(&w);
                let mut us: Vec<f32> = (0..64).map(|_| next()).collect();
                for &c in &d.cdf {
                    us.extend([c, c.next_down(), c.next_up()].map(|u| u.clamp(0.0, 1.0)));
                }
                for u in us {
                    assert_eq!(d.scan(u), d.search(u), "n {n}, u {u}, cdf {:?}", d.cdf);
                }
            }
        }
    }
}
