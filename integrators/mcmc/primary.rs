//! Primary sample space (Kelemen et al. 2002): a Markov chain's state is the infinite vector of
//! uniform numbers an integrator consumes, and a mutation perturbs that vector.
//!
//! [`PrimarySampler`] is a [`Sampler`] whose numbers are the chain's current proposal. It
//! mutates lazily: a dimension is brought up to date only when the integrator reads it, by
//! applying every step it missed since it was last read (a large step replaces it by a fresh
//! uniform). The steps the chain's state took while the dimension went unread become part of
//! the state before the proposal's own step is applied, so rejecting a proposal restores the
//! state's caught-up value, not the value from before those steps: the chain is then the one
//! that mutates every dimension at every step (as Mitsuba's PSSMLT sampler does). Restoring
//! the older value instead (pbrt-v3's `MLTSampler`) redraws the unread steps at every
//! proposal, and where a dimension matters in one region of path space and not in another,
//! the chain gets a fresh try at re-entering with each proposal and over-visits the region
//! (test `lazy_small_steps_keep_the_target_distribution`, Gaussian steps: 0.70 of the weight
//! in a region that holds 0.50 of the integral, where this sampler gives 0.50). Rejecting
//! a proposal restores exactly the dimensions that proposal touched.
//!
//! Dimensions are numbered per stream: number `i` of stream `s` is dimension `i * S + s` of
//! `S` streams (`Sampler::start_stream`), so BDPT's camera walk, light walk and connections
//! each keep their own dimensions when another part draws more or fewer numbers.
//!
//! Small steps, both symmetric (so the Metropolis ratio is the ratio of contributions):
//! - `Kelemen`: `±s2 · exp(−ln(s2/s1) · u)`, sizes from s1 to s2 (defaults 1/1024, 1/64); a
//!   dimension that missed `n` steps takes all `n` of them, one by one (as Mitsuba's PSSMLT
//!   does; at most what eager mutation of every dimension would cost). Taking fewer (a cap
//!   of 16, say) is not the chain that mutates every dimension: a dimension
//!   left unread while the chain is elsewhere stops drifting and comes back near the value
//!   the target favoured when it was last read.
//! - `Gaussian`: normal of deviation `sigma` (default 0.01); `n` missed steps are one step of
//!   deviation `sigma · sqrt(n)`, exactly their sum.
//!
//! Values wrap around [0, 1).

use crate::math::Sampler;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

/// The small-step kernel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SmallStep {
    /// Kelemen's exponential step between sizes s1 and s2.
    Kelemen {
        /// Smallest step size.
        s1: f64,
        /// Largest step size.
        s2: f64,
    },
    /// A normal step of this deviation.
    Gaussian {
        /// Standard deviation of the step.
        sigma: f64,
    },
}

/// Kelemen's default smallest step.
pub const S1: f64 = 1.0 / 1024.0;
/// Kelemen's default largest step.
pub const S2: f64 = 1.0 / 64.0;
/// The Gaussian step's default deviation.
pub const SIGMA: f64 = 0.01;

impl Default for SmallStep {
    fn default() -> Self {
        SmallStep::Kelemen { s1: S1, s2: S2 }
    }
}

// PCG stream selectors of a chain's initial state and of its continuation (`reseed`).
use crate::math::streams::{PCG_CHAIN as CHAIN_STREAM, PCG_INITIAL as INITIAL_STREAM};

#[derive(Debug, Clone, Copy, Default)]
struct Dim {
    value: f64,
    /// 1 + the iteration at which `value` was last brought up to date (0: never read).
    stamp: u64,
    /// The state's value and stamp before the current proposal touched it.
    backup_value: f64,
    backup_stamp: u64,
}

/// Dimension `index` of stream `stream` out of `streams`.
#[inline]
pub fn dimension(stream: u32, index: u32, streams: u32) -> usize {
    index as usize * streams as usize + stream as usize
}

/// The primary samples of one Markov chain.
pub struct PrimarySampler {
    rng: Pcg32,
    dims: Vec<Dim>,
    /// Iteration of the current proposal (0: the initial state, drawn as a large step).
    iteration: u64,
    last_large: u64,
    large: bool,
    small: SmallStep,
    p_large: f64,
    streams: u32,
    stream: u32,
    index: u32,
}

impl PrimarySampler {
    /// A chain whose initial state is fresh uniforms from `key`'s stream, drawn in the order
    /// the first evaluation reads them (so a bootstrap sample made with the same key is
    /// reproduced exactly by the chain's first evaluation).
    pub fn new(key: u64, streams: u32, small: SmallStep, p_large: f64) -> PrimarySampler {
        PrimarySampler {
            rng: Pcg32::new(key, INITIAL_STREAM),
            dims: Vec::new(),
            iteration: 0,
            last_large: 0,
            large: true,
            small,
            p_large,
            streams: streams.max(1),
            stream: 0,
            index: 0,
        }
    }

    /// Start over as `PrimarySampler::new(key, ..)` would, keeping the dimension buffer
    /// (the bootstrap evaluates many fresh states with one sampler per thread).
    pub fn reset(&mut self, key: u64) {
        self.rng = Pcg32::new(key, INITIAL_STREAM);
        self.dims.clear();
        self.iteration = 0;
        self.last_large = 0;
        self.large = true;
        self.stream = 0;
        self.index = 0;
    }

    /// A chain (one stream) whose initial state begins with `prefix` (dimensions 0, 1, ...)
    /// and continues with fresh uniforms from `key`'s stream: a chain started at a sample
    /// another sampler made, replayed from the numbers that sampler drew.
    pub fn with_prefix(prefix: &[f64], key: u64, small: SmallStep, p_large: f64) -> Self {
        let mut s = PrimarySampler::new(key, 1, small, p_large);
        s.dims = prefix
            .iter()
            .map(|&v| Dim {
                value: wrap(v),
                stamp: 1,
                backup_value: wrap(v),
                backup_stamp: 1,
            })
            .collect();
        s
    }

    /// Continue the chain with numbers from `key`'s stream (after its initial state was
    /// reproduced from a bootstrap key that other chains may share).
    pub fn reseed(&mut self, key: u64) {
        self.rng = Pcg32::new(key, CHAIN_STREAM);
    }

    /// Start the next proposal: a large step with probability `p_large`, else a small step.
    pub fn start_iteration(&mut self) {
        self.iteration += 1;
        self.large = self.rng.random::<f64>() < self.p_large;
        self.stream = 0;
        self.index = 0;
    }

    /// Restart reading the current proposal from its first dimension (the first evaluation
    /// of a state, or a replay).
    pub fn restart(&mut self) {
        self.stream = 0;
        self.index = 0;
    }

    /// A uniform number from the chain's own generator, not a dimension of its state (the
    /// acceptance test).
    pub fn uniform(&mut self) -> f64 {
        self.rng.random::<f64>()
    }

    /// Whether the current proposal is a large step.
    pub fn is_large_step(&self) -> bool {
        self.large
    }

    /// The proposal becomes the chain's state.
    pub fn accept(&mut self) {
        if self.large {
            self.last_large = self.iteration;
        }
    }

    /// The chain stays in its state: every dimension the proposal touched gets its value back.
    pub fn reject(&mut self) {
        for d in &mut self.dims {
            if d.stamp == self.iteration + 1 {
                d.value = d.backup_value;
                d.stamp = d.backup_stamp;
            }
        }
        self.iteration -= 1;
    }

    /// The Metropolis–Hastings decision on the proposal just evaluated: accept with
    /// probability `a = min(1, proposal / current)` (1 from a state of no importance; a
    /// proposal of no importance is never accepted), by [`Self::accept`] or [`Self::reject`].
    /// Both small steps are symmetric and a large step is an independent draw, so this ratio
    /// is the whole acceptance. The one step of every chain here: `pssmlt`, `mmlt` and the
    /// guided integrators' chain seeder (`guided/chains.rs`). Returns (a, accepted).
    pub fn metropolis(&mut self, current: f64, proposal: f64) -> (f64, bool) {
        let a = if current > 0.0 {
            (proposal / current).min(1.0)
        } else {
            1.0
        };
        let accepted = proposal > 0.0 && (a >= 1.0 || self.uniform() < a);
        if accepted {
            self.accept();
        } else {
            self.reject();
        }
        (a, accepted)
    }

    /// The values of the first `n` dimensions as the integrator reads them (the state after
    /// `accept`; dimensions never read are 0).
    pub fn values(&self) -> Vec<f32> {
        let mut v = Vec::new();
        self.values_into(&mut v);
        v
    }

    /// [`Self::values`] into `out` (its buffer reused).
    pub fn values_into(&self, out: &mut Vec<f32>) {
        out.clear();
        out.extend(self.dims.iter().map(|d| to_f32(d.value)));
    }

    /// Number of sampler streams the primary samples are split into.
    pub fn streams(&self) -> u32 {
        self.streams
    }

    fn ensure_ready(&mut self, i: usize) {
        if i >= self.dims.len() {
            self.dims.resize(i + 1, Dim::default());
        }
        let it = self.iteration;
        let d = self.dims[i];
        if d.stamp == it + 1 {
            return; // already read in this proposal
        }
        // The dimension's value in the chain's state: a dimension never read, or not read
        // since the last accepted large step, holds that step's fresh uniform.
        let (mut base, mut stamp) = (d.value, d.stamp);
        if stamp < self.last_large + 1 {
            base = self.rng.random::<f64>();
            stamp = self.last_large + 1;
        }
        let value = if stamp == it + 1 {
            base // the initial state (iteration 0 is its large step)
        } else if self.large {
            self.rng.random::<f64>()
        } else {
            // The n - 1 small steps the state took since this dimension was last read become
            // part of the state (the value a rejection restores), then the proposal's own step.
            let n = it + 1 - stamp;
            if n > 1 {
                base = wrap(base + self.small_steps(n - 1));
                stamp = it;
            }
            wrap(base + self.small_steps(1))
        };
        self.dims[i] = Dim {
            value,
            stamp: it + 1,
            backup_value: base,
            backup_stamp: stamp,
        };
    }

    /// The sum of `n` small steps: one normal step of `sigma sqrt(n)` (exactly their sum), or
    /// `n` Kelemen steps one by one.
    fn small_steps(&mut self, n: u64) -> f64 {
        match self.small {
            SmallStep::Gaussian { sigma } => sigma * (n as f64).sqrt() * self.normal(),
            SmallStep::Kelemen { s1, s2 } => {
                let mut sum = 0.0;
                for _ in 0..n {
                    let step = s2 * (-(s2 / s1).ln() * self.rng.random::<f64>()).exp();
                    sum += if self.rng.random::<f64>() < 0.5 {
                        step
                    } else {
                        -step
                    };
                }
                sum
            }
        }
    }

    /// A standard normal number (Box-Muller).
    fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.rng.random::<f64>(); // (0, 1]
        let u2 = self.rng.random::<f64>();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

impl Sampler for PrimarySampler {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let i = dimension(self.stream, self.index, self.streams);
        self.index += 1;
        self.ensure_ready(i);
        to_f32(self.dims[i].value)
    }

    fn start_stream(&mut self, index: u32) {
        debug_assert!(index < self.streams);
        self.stream = index.min(self.streams - 1);
        self.index = 0;
    }
}

/// Reads fixed primary samples (a recorded state) with [`PrimarySampler`]'s dimension order;
/// dimensions past the recording read 0.5.
pub struct ReplaySampler<'v> {
    values: &'v [f32],
    streams: u32,
    stream: u32,
    index: u32,
}

impl<'v> ReplaySampler<'v> {
    /// A sampler reading `values`, laid out in `streams` streams (at least 1).
    pub fn new(values: &'v [f32], streams: u32) -> ReplaySampler<'v> {
        ReplaySampler {
            values,
            streams: streams.max(1),
            stream: 0,
            index: 0,
        }
    }
}

impl Sampler for ReplaySampler<'_> {
    fn next_1d(&mut self) -> f32 {
        let i = dimension(self.stream, self.index, self.streams);
        self.index += 1;
        self.values.get(i).copied().unwrap_or(0.5)
    }

    fn start_stream(&mut self, index: u32) {
        self.stream = index.min(self.streams - 1);
        self.index = 0;
    }
}

/// `x` wrapped into [0, 1).
fn wrap(x: f64) -> f64 {
    let w = x - x.floor();
    if w >= 1.0 { 0.0 } else { w }
}

/// A value in [0, 1) as the f32 the integrator reads (rounding never reaches 1).
#[inline]
fn to_f32(v: f64) -> f32 {
    (v as f32).min(1.0 - f32::EPSILON / 2.0)
}

/// Seeds a standalone generator (tests, chain selection).
pub fn rng(key: u64) -> Pcg32 {
    Pcg32::seed_from_u64(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rejecting restores exactly the previous state's values; accepting keeps the proposal's.
    #[test]
    fn reject_restores_and_accept_keeps() {
        for small in [SmallStep::default(), SmallStep::Gaussian { sigma: 0.01 }] {
            let mut s = PrimarySampler::new(7, 2, small, 0.3);
            let read = |s: &mut PrimarySampler| -> Vec<f32> {
                s.restart();
                let mut v: Vec<f32> = (0..5).map(|_| s.next_1d()).collect();
                s.start_stream(1);
                v.extend((0..3).map(|_| s.next_1d()));
                v
            };
            let x0 = read(&mut s);
            for it in 0..200 {
                s.start_iteration();
                let x1 = read(&mut s);
                assert!(x1.iter().all(|v| (0.0..1.0).contains(v)));
                if !s.is_large_step() {
                    // Small steps stay close (modulo wrapping) in every dimension.
                    for (a, b) in x0.iter().zip(&x1) {
                        let d = (a - b).abs();
                        assert!(d.min(1.0 - d) < 0.2, "{a} {b}");
                    }
                }
                if it % 2 == 0 {
                    s.reject();
                    assert_eq!(read(&mut s), x0, "rejected proposal {it}");
                } else {
                    s.accept();
                    assert_eq!(read(&mut s), x1);
                    break;
                }
            }
        }
    }

    /// A dimension read only now and then receives its missed steps: after many small steps
    /// its value has moved, and the replay of the stored values reads the same numbers.
    #[test]
    fn lazy_dimensions_and_replay() {
        let mut s = PrimarySampler::new(3, 3, SmallStep::Gaussian { sigma: 0.01 }, 0.0);
        s.next_1d();
        s.start_stream(2);
        let first = s.next_1d();
        for _ in 0..400 {
            s.start_iteration();
            s.next_1d();
            s.accept();
        }
        s.start_iteration();
        s.next_1d();
        s.start_stream(2);
        let later = s.next_1d();
        s.accept();
        assert_ne!(first, later);
        let values = s.values();
        let mut r = ReplaySampler::new(&values, 3);
        let a = r.next_1d();
        r.start_stream(2);
        assert_eq!(r.next_1d(), later);
        s.restart();
        assert_eq!(s.next_1d(), a);
    }
}
