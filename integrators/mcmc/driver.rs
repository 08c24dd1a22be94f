//! The Metropolis driver shared by `pssmlt` and `mmlt`: bootstrap, chains, passes, splats.
//!
//! A [`Target`] maps primary samples to a contribution on the image, in one or more groups
//! (pssmlt: one; mmlt: one per path length). The driver
//! 1. **bootstraps** each group from `bootstrap` independent samples: their mean importance
//!    `b_g` (importance = luminance of the contribution) is the group's normalisation, and
//!    the samples are kept as candidate chain starts;
//! 2. **allots** every pass `N_pix` mutations (one per pixel, so `--spp` counts mutations per
//!    pixel) to the groups in proportion to `b_g`, deterministically (`m_g`, at least one per
//!    group with `b_g > 0`), spread over `c_g` chains, each started at a bootstrap sample
//!    drawn in proportion to its importance (a start from the stationary distribution, so no
//!    start-up bias) and then continued on its own stream;
//! 3. **mutates**: each step proposes a large step (probability `large_step`) or a small
//!    step, accepts with `a = min(1, I(y) / I(x))`, and splats both states with expected
//!    values: `a f(y) / I(y)` and `(1 − a) f(x) / I(x)`, times `N_pix b_g / m_g`. Chains
//!    start at states of positive importance and never accept a proposal of zero importance
//!    (or NaN), so a state of zero importance does not occur; nothing is clamped.
//!
//! 4. **direct** (targets with [`Target::has_direct`], `mmlt`'s lights seen through specular
//!    chains): when asked ([`Split`]), the paths the target flags
//!    [`Contribution::direct`] leave the chains (their importance is 0 there, in the
//!    bootstrap too) and are estimated per pixel, every pixel in pass 0 and then each pixel
//!    every `direct_every`-th pass (interleaved, on its own stream); the image adds their
//!    per-pixel mean.
//!
//! A group whose bootstrap found no contribution (`b_g = 0`, e.g. a path length the 100k
//! samples never lit) gets no chains and adds nothing to the image: the estimator is
//! consistent in the bootstrap size, not unbiased for a finite one (as pbrt's MMLT, which
//! also starts chains by the bootstrap's distribution). The render's statistics list each
//! group's `b_g`.
//!
//! The image after P passes is the splat sum over P. Every chain owns its streams and its
//! splats are added in chain order, so the image is bit-identical for any thread count.
//! The bootstrap counts against a time budget.

pub use super::faults::Faults;
use super::primary::{PrimarySampler, SmallStep};
use crate::film::Image;
use crate::math::{IndependentSampler, Sampler, luminance, stream_seed};
use crate::render::{Budget, RenderContext, RenderResult, run_passes_with_snapshots};
use crate::scene::Scene;
use glam::{DVec3, Vec2};
use rand::RngExt;
use rayon::prelude::*;
use std::time::Instant;

// Stream keys of the bootstrap, the chain starts and the chains (far from render passes).
use crate::math::streams::{
    MCMC_BOOTSTRAP as BOOTSTRAP_KEY, MCMC_CHAINS as CHAIN_KEY, MCMC_DIRECT as DIRECT_KEY,
    MCMC_START as START_KEY,
};

/// A contribution to the image: the pixel it lands in and its RGB value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contribution {
    /// Row-major index of the pixel.
    pub pixel: u32,
    /// The path's contribution f / p to that pixel, in pixel units.
    pub value: DVec3,
    /// The path is one [`Target::direct`] estimates per pixel when the driver splits them
    /// off ([`Split`]).
    pub direct: bool,
}

impl Contribution {
    /// Nothing: zero value (importance 0) in pixel 0.
    pub const ZERO: Contribution = Contribution {
        pixel: 0,
        value: DVec3::ZERO,
        direct: false,
    };

    /// The chain's target density (up to b): luminance, 0 for invalid values.
    pub fn importance(&self) -> f64 {
        let v = self.value;
        if v.is_finite() && v.min_element() >= 0.0 {
            luminance(v.as_vec3()) as f64
        } else {
            0.0
        }
    }
}

/// What a chain explores: a deterministic function of the primary samples.
pub trait Target: Sync {
    /// Per-thread scratch (subpath buffers).
    type Scratch<'s>
    where
        Self: 's;
    /// Fresh scratch for one thread.
    fn scratch(&self) -> Self::Scratch<'_>;
    /// Sampler streams the target reads (`Sampler::start_stream`).
    fn streams(&self) -> u32;
    /// Number of chain groups, each with its own normalisation.
    fn groups(&self) -> usize;
    /// Group `group`'s contribution for the sampler's numbers (read from the start).
    fn eval<S: Sampler>(
        &self,
        scratch: &mut Self::Scratch<'_>,
        group: usize,
        sampler: &mut S,
    ) -> Contribution;
    /// Whether [`Target::direct`] can estimate the paths flagged
    /// [`Contribution::direct`] per pixel, so the driver may leave them out of the chains.
    fn has_direct(&self) -> bool {
        false
    }
    /// One sample at `raster` of the paths flagged [`Contribution::direct`] (pixel units).
    fn direct<S: Sampler>(
        &self,
        _scratch: &mut Self::Scratch<'_>,
        _raster: Vec2,
        _sampler: &mut S,
    ) -> DVec3 {
        DVec3::ZERO
    }
}

/// Options of the Metropolis integrators.
#[derive(Debug, Clone, PartialEq)]
pub struct McmcSettings {
    /// Bootstrap samples per group (default 100 000).
    pub bootstrap: u64,
    /// Number of chains over all groups (default 1024).
    pub chains: u64,
    /// Probability of a large step (default 0.3).
    pub large_step: f64,
    /// The kernel of small steps (default Kelemen's, sizes 1/1024 to 1/64).
    pub small_step: SmallStep,
    /// Whether the paths a target flags [`Contribution::direct`] leave the chains for a
    /// per-pixel estimate (default [`Split::Never`]; only for targets with
    /// [`Target::has_direct`]).
    pub split: Split,
    /// A pixel's samples of [`Target::direct`] come every this many passes, after pass 0
    /// which samples every pixel (default 4).
    pub direct_every: u64,
    /// Deliberate errors for the tests' negative controls (none by default; no option sets
    /// them).
    pub faults: Faults,
}

impl Default for McmcSettings {
    fn default() -> Self {
        McmcSettings {
            bootstrap: 100_000,
            chains: 1024,
            large_step: 0.3,
            small_step: SmallStep::default(),
            split: Split::Never,
            direct_every: 4,
            faults: Faults::default(),
        }
    }
}

/// Whether the paths a target flags [`Contribution::direct`] are estimated per pixel
/// ([`Target::direct`]) instead of by the chains.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Split {
    /// Never: the chains explore every path.
    Never,
    /// Always (for targets with [`Target::has_direct`]).
    Always,
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
}

impl SplitEvidence {
    /// The evidence of every group's bootstrap.
    pub fn of(boot: &[Bootstrap]) -> SplitEvidence {
        let (mut all, mut sum, mut sum2) = (0.0, 0.0, 0.0);
        for g in boot {
            for (&x, &d) in g.importance.iter().zip(&g.direct) {
                all += x;
                if d {
                    sum += x;
                    sum2 += x * x;
                }
            }
        }
        SplitEvidence {
            share: if all > 0.0 { sum / all } else { 0.0 },
            samples: if sum2 > 0.0 { sum * sum / sum2 } else { 0.0 },
        }
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
    if split && c.direct {
        Contribution::ZERO
    } else {
        c
    }
}

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
    fn add(&mut self, o: &Counters) {
        self.large_importance += o.large_importance;
        self.mutations += o.mutations;
        self.accepted += o.accepted;
        self.large += o.large;
        self.large_accepted += o.large_accepted;
        self.zero_proposals += o.zero_proposals;
    }
}

/// The bootstrap of one group: `b_g` and the importance of every sample.
pub struct Bootstrap {
    /// Mean importance of the bootstrap samples: the group's normalisation `b_g`.
    pub b: f64,
    /// Importance of each bootstrap sample, by sample index (chain starts are drawn from it).
    pub importance: Vec<f64>,
    /// Whether each sample's path is flagged [`Contribution::direct`].
    pub direct: Vec<bool>,
}

impl Bootstrap {
    /// Leave the flagged samples out (they are estimated per pixel): their importance is 0
    /// and `b` the mean of the rest (over every sample).
    pub fn without_direct(&mut self) {
        for (x, &d) in self.importance.iter_mut().zip(&self.direct) {
            if d {
                *x = 0.0;
            }
        }
        self.b = self.importance.iter().sum::<f64>() / self.importance.len().max(1) as f64;
    }
}

/// The key of bootstrap sample `i` of group `g`.
pub fn bootstrap_key(seed: u64, group: usize, i: u64) -> u64 {
    stream_seed(seed, BOOTSTRAP_KEY + group as u64, i)
}

/// Evaluate `n` independent samples of every group.
pub fn bootstrap<T: Target>(target: &T, seed: u64, n: u64, s: &McmcSettings) -> Vec<Bootstrap> {
    (0..target.groups())
        .map(|g| {
            let (importance, direct): (Vec<f64>, Vec<bool>) = (0..n)
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
                        (c.importance(), c.direct)
                    },
                )
                .unzip();
            let b = importance.iter().sum::<f64>() / n.max(1) as f64;
            Bootstrap {
                b,
                importance,
                direct,
            }
        })
        .collect()
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

/// `chain.mutations` Metropolis steps; splats go to `splats` (pixel, value). `split`: the
/// flagged paths are left out ([`Split`]). `faults` are the tests' deliberate errors
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

/// The splat sums of each group and what refines its normalisation.
struct Accumulated {
    sums: Vec<Vec<DVec3>>,
    per_group: Vec<Counters>,
    /// Per-pixel sums of [`Target::direct`] and their sample counts (empty without).
    direct: Vec<DVec3>,
    direct_samples: Vec<u32>,
}

impl Accumulated {
    /// b_g from the bootstrap and every large step so far (both are independent samples).
    fn b(&self, boot: &[Bootstrap], g: usize) -> f64 {
        let (c, n) = (&self.per_group[g], boot[g].importance.len() as f64);
        (boot[g].b * n + c.large_importance) / (n + c.large as f64)
    }

    /// The image after `passes` passes: each group's splats rescaled from its bootstrap b_g
    /// (which the splats carry) to the refined one.
    fn image(&self, boot: &[Bootstrap], w: u32, h: u32, passes: u64, faults: &Faults) -> Image {
        let mut px = vec![DVec3::ZERO; (w * h) as usize];
        for ((p, d), &n) in px.iter_mut().zip(&self.direct).zip(&self.direct_samples) {
            if n > 0 {
                *p += *d / n as f64;
            }
        }
        for (g, sums) in self.sums.iter().enumerate() {
            if sums.is_empty() || boot[g].b <= 0.0 {
                continue;
            }
            let scale = self.b(boot, g) * faults.b_factor(g) / boot[g].b / passes.max(1) as f64;
            for (p, s) in px.iter_mut().zip(sums) {
                *p += *s * scale;
            }
        }
        Image {
            width: w,
            height: h,
            pixels: px.into_iter().map(|p| p.as_vec3()).collect(),
        }
    }
}

/// Pass `pass`'s samples of [`Target::direct`]: every pixel in pass 0, then each pixel
/// every `every`-th pass (interleaved over the image), added to `sums` and counted in
/// `samples` (each pixel on its own stream, so nothing depends on the thread count).
fn direct_pass<T: Target>(
    target: &T,
    seed: u64,
    (pass, every): (u64, u64),
    width: u32,
    sums: &mut [DVec3],
    samples: &mut [u32],
) {
    let w = width as usize;
    sums.par_chunks_mut(w)
        .zip(samples.par_chunks_mut(w))
        .enumerate()
        .for_each_init(
            || target.scratch(),
            |scratch, (y, (row, counts))| {
                for (x, (sum, count)) in row.iter_mut().zip(counts).enumerate() {
                    let pixel = (y * w + x) as u64;
                    if pass > 0 && !(pixel + pass).is_multiple_of(every) {
                        continue;
                    }
                    *count += 1;
                    let mut sampler = IndependentSampler::new(seed, DIRECT_KEY + pass, pixel);
                    let raster = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                    let v = target.direct(scratch, raster, &mut sampler);
                    // A non-finite sample is dropped (as pt's film drops one), not spread.
                    if v.is_finite() {
                        *sum += v;
                    }
                }
            },
        );
}

/// Render `target` with Metropolis chains under `budget` (passes of `N_pix` mutations).
pub fn render<T: Target>(
    target: &T,
    settings: &McmcSettings,
    ctx: &RenderContext,
    budget: Budget,
) -> RenderResult {
    let scene: &Scene = ctx.scene;
    let (w, h) = (scene.camera.resolution.x, scene.camera.resolution.y);
    let pixels = scene.camera.pixel_count() as f64;
    let t0 = ctx.clock.now();
    let mut boot = bootstrap(target, ctx.seed, settings.bootstrap, settings);
    let evidence = SplitEvidence::of(&boot);
    let split = target.has_direct() && settings.split == Split::Always;
    if split {
        boot.iter_mut().for_each(Bootstrap::without_direct);
    }
    let mut chains = start_chains(
        target,
        &boot,
        ctx.seed,
        pixels as u64,
        pixels,
        settings,
        split,
    );
    let boot_seconds = (ctx.clock.now() - t0).as_secs_f64();
    let budget = match budget {
        Budget::Seconds(s) => Budget::Seconds((s - boot_seconds).max(0.0)),
        b => b,
    };
    let groups = boot.len();
    let mut acc = Accumulated {
        sums: (0..groups)
            .map(|g| {
                if chains.iter().any(|c| c.group == g) {
                    vec![DVec3::ZERO; (w * h) as usize]
                } else {
                    Vec::new()
                }
            })
            .collect(),
        per_group: vec![Counters::default(); groups],
        direct: if split {
            vec![DVec3::ZERO; (w * h) as usize]
        } else {
            Vec::new()
        },
        direct_samples: if split {
            vec![0; (w * h) as usize]
        } else {
            Vec::new()
        },
    };
    let mut direct_seconds = 0.0;
    let pass = |acc: &mut Accumulated, pass: u64| {
        if !acc.direct.is_empty() {
            let t = Instant::now();
            direct_pass(
                target,
                ctx.seed,
                (pass, settings.direct_every),
                w,
                &mut acc.direct,
                &mut acc.direct_samples,
            );
            direct_seconds += t.elapsed().as_secs_f64();
        }
        let out: Vec<(Vec<(u32, DVec3)>, Counters)> = chains
            .par_iter_mut()
            .map_init(
                || target.scratch(),
                |scratch, chain| {
                    let mut splats = Vec::with_capacity(2 * chain.mutations as usize);
                    let mut c = Counters::default();
                    advance(
                        target,
                        scratch,
                        chain,
                        &mut splats,
                        &mut c,
                        (split, &settings.faults),
                    );
                    (splats, c)
                },
            )
            .collect();
        for (chain, (splats, c)) in chains.iter().zip(&out) {
            let sums = &mut acc.sums[chain.group];
            for &(p, v) in splats {
                let n = sums.len();
                sums[settings.faults.pixel(p, n)] += v;
            }
            acc.per_group[chain.group].add(c);
        }
    };
    let image = |acc: &Accumulated, passes: u64| acc.image(&boot, w, h, passes, &settings.faults);
    let (passes, seconds) = run_passes_with_snapshots(ctx, budget, &mut acc, pass, image);
    let mut c = Counters::default();
    for g in &acc.per_group {
        c.add(g);
    }
    let b: f64 = (0..groups).map(|g| acc.b(&boot, g)).sum();
    let b_boot: f64 = boot.iter().map(|g| g.b).sum();
    let rate = |a: u64, n: u64| if n > 0 { a as f64 / n as f64 } else { 0.0 };
    let image = acc.image(&boot, w, h, passes, &settings.faults);
    let mut stats = vec![
        ("mcmc_b".to_string(), format!("{b:.6e}")),
        ("mcmc_b_bootstrap".to_string(), format!("{b_boot:.6e}")),
        (
            "mcmc_b_per_group".to_string(),
            (0..groups)
                .map(|g| format!("{:.3e}", acc.b(&boot, g)))
                .collect::<Vec<_>>()
                .join(" "),
        ),
        (
            "mcmc_b_bootstrap_rel_stderr".to_string(),
            format!("{:.3e}", rel_stderr(&boot)),
        ),
        (
            "mcmc_bootstrap".to_string(),
            format!("{} x {} groups", settings.bootstrap, groups),
        ),
        (
            "mcmc_bootstrap_seconds".to_string(),
            format!("{boot_seconds:.3}"),
        ),
        ("mcmc_chains".to_string(), chains.len().to_string()),
        (
            "mcmc_direct_split".to_string(),
            if !target.has_direct() {
                "none".to_string()
            } else {
                format!(
                    "{} (bootstrap share {:.3e} on {:.1} samples' worth)",
                    if split { "per pixel" } else { "chains" },
                    evidence.share,
                    evidence.samples
                )
            },
        ),
        ("mcmc_mutations".to_string(), c.mutations.to_string()),
        (
            "mcmc_acceptance".to_string(),
            format!("{:.4}", rate(c.accepted, c.mutations)),
        ),
        (
            "mcmc_large_step_acceptance".to_string(),
            format!("{:.4}", rate(c.large_accepted, c.large)),
        ),
        (
            "mcmc_zero_proposals".to_string(),
            c.zero_proposals.to_string(),
        ),
    ];
    if !acc.direct.is_empty() {
        // The share of the image's luminance the per-pixel estimate gives.
        let direct: DVec3 = acc
            .direct
            .iter()
            .zip(&acc.direct_samples)
            .map(|(d, &n)| if n > 0 { *d / n as f64 } else { DVec3::ZERO })
            .sum::<DVec3>()
            / pixels;
        let all = luminance(image.mean().as_vec3()) as f64;
        let share = if all > 0.0 {
            luminance(direct.as_vec3()) as f64 / all
        } else {
            0.0
        };
        stats.push(("mcmc_direct_share".to_string(), format!("{share:.4e}")));
        stats.push((
            "mcmc_direct_seconds".to_string(),
            format!("{direct_seconds:.3}"),
        ));
    }
    RenderResult {
        image,
        spp: passes,
        passes,
        seconds: seconds + boot_seconds,
        stats,
        dbor: None,
    }
}

/// Relative standard error of the bootstrap's total b (groups are independent).
fn rel_stderr(boot: &[Bootstrap]) -> f64 {
    let (mut b, mut var) = (0.0, 0.0);
    for g in boot {
        let n = g.importance.len() as f64;
        let m2 = g.importance.iter().map(|x| x * x).sum::<f64>() / n;
        var += (m2 - g.b * g.b).max(0.0) / n;
        b += g.b;
    }
    if b > 0.0 { var.sqrt() / b } else { 0.0 }
}
