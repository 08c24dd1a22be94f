//! The bootstrap of the Markov-chain integrators: `n` independent samples of every chain
//! group, whose mean importance is the group's normalisation `b_g` and which are kept as the
//! chains' candidate starts; what they hold of the paths a target can estimate per pixel
//! ([`SplitEvidence`]).

use super::primary::PrimarySampler;
use super::target::{McmcSettings, Target};
use crate::math::stream_seed;
use crate::math::streams::MCMC_BOOTSTRAP as BOOTSTRAP_KEY;
use rayon::prelude::*;

/// The bootstrap of one group: `b_g` and the importance of every sample.
pub struct Bootstrap {
    /// Mean importance of the bootstrap samples: the group's normalisation `b_g`.
    pub b: f64,
    /// Importance of each bootstrap sample, by sample index (chain starts are drawn from it).
    pub importance: Vec<f64>,
    /// Importance of each sample without its
    /// [`Contribution::direct`](super::target::Contribution::direct) part.
    pub rest: Vec<f64>,
}

impl Bootstrap {
    /// Leave the flagged samples out (they are estimated per pixel): their importance is 0
    /// and `b` the mean of the rest (over every sample).
    pub fn without_direct(&mut self) {
        self.importance.copy_from_slice(&self.rest);
        self.b = self.importance.iter().sum::<f64>() / self.importance.len().max(1) as f64;
    }
}

/// The key of bootstrap sample `i` of group `g`.
pub fn bootstrap_key(seed: u64, group: usize, i: u64) -> u64 {
    stream_seed(seed, BOOTSTRAP_KEY + group as u64, i)
}

/// Evaluate `n` independent samples of every group.
pub fn bootstrap<T: Target>(target: &T, seed: u64, n: u64, s: &McmcSettings) -> Vec<Bootstrap> {
    bootstrap_until(target, seed, n, s, || false)
}

/// The rounds the bootstrap is taken in: after each, every group holds the same number of
/// samples, and [`bootstrap_until`] may stop.
pub const BOOTSTRAP_ROUNDS: u64 = 16;

/// [`bootstrap`], taken in [`BOOTSTRAP_ROUNDS`] rounds of `n / BOOTSTRAP_ROUNDS` samples of
/// every group (sample `i` of group `g` from the same key either way), stopping after the first
/// round after which `stop()` holds: under a time budget, the bootstrap's share of it
/// (`mmlt` keeps one group per path length, and at a large maximum depth all `n` of every
/// group could take the whole budget). With every round taken the result is [`bootstrap`]'s
/// bit for bit.
pub fn bootstrap_until<T: Target>(
    target: &T,
    seed: u64,
    n: u64,
    s: &McmcSettings,
    stop: impl Fn() -> bool,
) -> Vec<Bootstrap> {
    let groups = target.groups();
    let mut importance = vec![Vec::new(); groups];
    let mut rest = vec![Vec::new(); groups];
    let per_round = n.div_ceil(BOOTSTRAP_ROUNDS).max(1);
    let mut taken = 0;
    while taken < n {
        let range = taken..(taken + per_round).min(n);
        for g in 0..groups {
            let (imp, res): (Vec<f64>, Vec<f64>) = range
                .clone()
                .into_par_iter()
                .map_init(
                    || {
                        let sampler =
                            PrimarySampler::new(0, target.streams(), s.small_step, s.large_step);
                        (target.scratch(), sampler)
                    },
                    |(scratch, sampler), i| {
                        sampler.reset(bootstrap_key(seed, g, i));
                        let c = target.eval(scratch, g, sampler);
                        (c.importance(), c.without_direct().importance())
                    },
                )
                .unzip();
            importance[g].extend(imp);
            rest[g].extend(res);
        }
        taken = range.end;
        if stop() {
            break;
        }
    }
    importance
        .into_iter()
        .zip(rest)
        .map(|(importance, rest)| Bootstrap {
            b: importance.iter().sum::<f64>() / importance.len().max(1) as f64,
            importance,
            rest,
        })
        .collect()
}

/// What the bootstrap holds of the flagged paths (a statistic of the render,
/// `mcmc_direct_split`). Chains start at bootstrap samples drawn by importance, so a region of
/// the image that the bootstrap holds on a handful of samples (or on none) starts a number of
/// chains far from its share, which large steps correct only slowly.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SplitEvidence {
    /// Their share of the bootstrap's total importance.
    pub share: f64,
    /// The effective number of bootstrap samples their importance rests on (`(Σ I)² / Σ I²`).
    pub samples: f64,
    /// Their part of `b` (the sum over groups of their mean importance per sample).
    pub b: f64,
    /// The standard error of `b`.
    pub stderr: f64,
}

impl SplitEvidence {
    /// The evidence of every group's bootstrap.
    pub fn of(boot: &[Bootstrap]) -> SplitEvidence {
        let (mut all, mut sum, mut sum2) = (0.0, 0.0, 0.0);
        let (mut b, mut var) = (0.0, 0.0);
        for g in boot {
            let (mut s, mut s2) = (0.0, 0.0);
            for (&x, &r) in g.importance.iter().zip(&g.rest) {
                all += x;
                // The flagged part's importance (luminance is linear in the value).
                let d = (x - r).max(0.0);
                s += d;
                s2 += d * d;
            }
            let n = g.importance.len() as f64;
            if n > 1.0 {
                let mean = s / n;
                b += mean;
                var += (s2 / n - mean * mean).max(0.0) / (n - 1.0);
            }
            sum += s;
            sum2 += s2;
        }
        SplitEvidence {
            share: if all > 0.0 { sum / all } else { 0.0 },
            samples: if sum2 > 0.0 { sum * sum / sum2 } else { 0.0 },
            b,
            stderr: var.sqrt(),
        }
    }

    /// Whether a per-pixel estimate `direct` (with standard error `stderr`) of the same
    /// part of `b` disagrees with the bootstrap's by more than `z` standard errors.
    pub fn disagrees(&self, direct: f64, stderr: f64, z: f64) -> bool {
        (direct - self.b).abs() > z * (stderr * stderr + self.stderr * self.stderr).sqrt()
    }
}

/// Index i with probability `w[i] / total` for a uniform `u` (a linear scan: once per chain).
pub fn pick_by_importance(w: &[f64], total: f64, u: f64) -> usize {
    let target = u * total;
    let mut acc = 0.0;
    let mut last = 0;
    for (i, &x) in w.iter().enumerate() {
        if x > 0.0 {
            acc += x;
            last = i;
            if acc > target {
                return i;
            }
        }
    }
    last
}

/// Relative standard error of the bootstrap's total b (groups are independent).
pub(super) fn rel_stderr(boot: &[Bootstrap]) -> f64 {
    let (mut b, mut var) = (0.0, 0.0);
    for g in boot {
        let n = g.importance.len() as f64;
        let m2 = g.importance.iter().map(|x| x * x).sum::<f64>() / n;
        var += (m2 - g.b * g.b).max(0.0) / n;
        b += g.b;
    }
    if b > 0.0 { var.sqrt() / b } else { 0.0 }
}
