//! The chains of the Metropolis integrators: their starts (each at a bootstrap sample drawn
//! by importance, then on its own stream) and their Metropolis steps with expected-value
//! splats (`driver.rs` says how a pass uses them).

use super::bootstrap::{Bootstrap, bootstrap_key, pick_by_importance};
use super::primary::PrimarySampler;
use super::target::{Contribution, Faults, McmcSettings, Target};
use crate::math::streams::{MCMC_CHAINS as CHAIN_KEY, MCMC_START as START_KEY};
use crate::math::{Sampler, stream_seed};
use glam::DVec3;
use rand::RngExt;
use rayon::prelude::*;

/// One chain: its primary samples and current state.
pub struct Chain {
    /// The chain group (for mmlt, the path length) the chain explores.
    pub group: usize,
    /// The primary samples of the current state, with pending proposals.
    pub sampler: PrimarySampler,
    /// The current state's contribution.
    pub current: Contribution,
    /// The current state's importance (luminance of `current`), always positive.
    pub importance: f64,
    /// Mutations per pass.
    pub mutations: u64,
    /// Splat factor `N_pix b_g / m_g`.
    pub scale: f64,
}

/// Counters of one render.
#[derive(Debug, Default, Clone, Copy)]
pub struct Counters {
    /// Proposals made.
    pub mutations: u64,
    /// Proposals accepted.
    pub accepted: u64,
    /// Large-step proposals.
    pub large: u64,
    /// Large-step proposals accepted.
    pub large_accepted: u64,
    /// Proposals of zero importance (never accepted, nothing splatted for them).
    pub zero_proposals: u64,
    /// Sum of the large steps' importances (independent samples of b).
    pub large_importance: f64,
}

impl Counters {
    pub(super) fn add(&mut self, o: &Counters) {
        self.large_importance += o.large_importance;
        self.mutations += o.mutations;
        self.accepted += o.accepted;
        self.large += o.large;
        self.large_accepted += o.large_accepted;
        self.zero_proposals += o.zero_proposals;
    }
}

/// `target`'s contribution, with the flagged paths left out when they are split off.
fn eval_split<T: Target, S: Sampler>(
    target: &T,
    scratch: &mut T::Scratch<'_>,
    group: usize,
    sampler: &mut S,
    split: bool,
) -> Contribution {
    let c = target.eval(scratch, group, sampler);
    if split && c.direct != glam::DVec3::ZERO {
        c.without_direct()
    } else {
        c
    }
}

/// Chains over all groups after the bootstrap: group g gets `m_g` mutations per pass (of
/// `per_pass`) and `c_g` chains, each started at a bootstrap sample chosen by importance.
#[allow(clippy::too_many_arguments)]
pub fn start_chains<T: Target>(
    target: &T,
    boot: &[Bootstrap],
    seed: u64,
    per_pass: u64,
    pixels: f64,
    s: &McmcSettings,
    split: bool,
) -> Vec<Chain> {
    let b: f64 = boot.iter().map(|g| g.b).sum();
    if b <= 0.0 || !b.is_finite() {
        return Vec::new();
    }
    let mut plan = Vec::new(); // (group, mutations of this chain)
    for (g, bg) in boot.iter().enumerate() {
        if bg.b <= 0.0 {
            continue;
        }
        let m = ((per_pass as f64 * bg.b / b).round() as u64).max(1);
        let c = ((s.chains as f64 * bg.b / b).round() as u64).clamp(1, m);
        for j in 0..c {
            plan.push((g, m / c + u64::from(j < m % c), m));
        }
    }
    plan.into_par_iter()
        .enumerate()
        .map_init(
            || target.scratch(),
            |scratch, (id, (g, mutations, m))| {
                let cdf = &boot[g].importance;
                let u =
                    super::primary::rng(stream_seed(seed, START_KEY, id as u64)).random::<f64>();
                let i = pick_by_importance(cdf, boot[g].b * cdf.len() as f64, u);
                let mut sampler = PrimarySampler::new(
                    bootstrap_key(seed, g, i as u64),
                    target.streams(),
                    s.small_step,
                    s.large_step,
                );
                let current = eval_split(target, scratch, g, &mut sampler, split);
                sampler.accept();
                sampler.reseed(stream_seed(seed, CHAIN_KEY, id as u64));
                Chain {
                    group: g,
                    importance: current.importance(),
                    sampler,
                    current,
                    mutations,
                    scale: pixels * boot[g].b / m as f64,
                }
            },
        )
        .collect()
}

/// `chain.mutations` Metropolis steps; splats go to `splats` (pixel, value). `split`: the
/// flagged paths are left out ([`Split`](super::target::Split)). `faults` are the tests' deliberate errors
/// ([`Faults`]; none in a render).
pub fn advance<T: Target>(
    target: &T,
    scratch: &mut T::Scratch<'_>,
    chain: &mut Chain,
    splats: &mut Vec<(u32, DVec3)>,
    counters: &mut Counters,
    (split, faults): (bool, &Faults),
) {
    for _ in 0..chain.mutations {
        let sampler = &mut chain.sampler;
        sampler.start_iteration();
        let large = sampler.is_large_step();
        let proposal = eval_split(target, scratch, chain.group, sampler, split);
        let ip = proposal.importance();
        let ix = chain.importance;
        // The acceptance and the chain's move (the splats below use `a` either way).
        let (a, accepted) = if faults.accept_large && large && ip > 0.0 {
            sampler.accept();
            ((ip / ix).min(1.0), true)
        } else {
            sampler.metropolis(ix, ip)
        };
        if ip > 0.0 {
            splats.push((proposal.pixel, proposal.value * (a * chain.scale / ip)));
        } else {
            counters.zero_proposals += 1;
        }
        if ix > 0.0 && a < 1.0 {
            let x = &chain.current;
            splats.push((x.pixel, x.value * ((1.0 - a) * chain.scale / ix)));
        }
        counters.mutations += 1;
        if large {
            counters.large += 1;
            counters.large_importance += ip;
        }
        if accepted {
            chain.current = proposal;
            chain.importance = ip;
            counters.accepted += 1;
            counters.large_accepted += u64::from(large);
        }
    }
}
