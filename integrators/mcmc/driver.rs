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
//! 4. **direct** (targets with [`Target::has_direct`]: `mmlt`'s paths that no connection
//!    makes, `pssmlt`'s emission that only a continued walk finds): the paths the target flags
//!    [`Contribution::direct`](super::target::Contribution::direct) may leave the chains
//!    (their importance is 0 there, in the bootstrap too) and be estimated per pixel, every
//!    pixel in pass 0 and then each pixel every `direct_every`-th pass (interleaved, on its
//!    own stream); the image adds their per-pixel mean. [`Split::Auto`] decides after the
//!    bootstrap and pass 0's per-pixel samples (taken before the chains start): it keeps
//!    the flagged paths in the chains only when the bootstrap holds them on at least
//!    [`SPLIT_SAMPLES`] samples' worth and its estimate of their part of `b` agrees with
//!    pass 0's within [`SPLIT_Z`] standard errors, that is when the chains start with about
//!    the right share of their time on them (not when the bootstrap holds none of them, or
//!    a few far too bright), nor where neither estimate saw one and the scene has no delta
//!    surface (lights seen directly are in every pixel's first sample).
//!    The statistic `mcmc_direct_split` gives both estimates and the decision.
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

use super::bootstrap::{Bootstrap, SplitEvidence, bootstrap_until, rel_stderr};
use super::chains::{Counters, advance, start_chains};
use super::target::{Faults, McmcSettings, SPLIT_SAMPLES, SPLIT_Z, Split, Target};
use crate::film::Image;
use crate::math::streams::MCMC_DIRECT as DIRECT_KEY;
use crate::math::{IndependentSampler, Sampler, luminance};
use crate::render::{Budget, RenderContext, RenderResult, run_passes_with_snapshots};
use crate::scene::Scene;
use glam::{DVec3, Vec2};
use rayon::prelude::*;
use std::time::Instant;

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

/// The mean of `xs` and its standard error (0 for fewer than two values).
fn mean_stderr(xs: impl ExactSizeIterator<Item = f64>) -> (f64, f64) {
    let n = xs.len() as f64;
    let (s, s2) = xs.fold((0.0, 0.0), |(s, s2), x| (s + x, s2 + x * x));
    if n < 2.0 {
        return (if n > 0.0 { s / n } else { 0.0 }, 0.0);
    }
    let mean = s / n;
    (mean, ((s2 / n - mean * mean).max(0.0) / (n - 1.0)).sqrt())
}

/// The largest share of a time budget the bootstrap takes (it stops after the round that
/// reaches it, with at least one round of every group; `bootstrap::bootstrap_until`).
pub const BOOTSTRAP_TIME_SHARE: f64 = 0.1;

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
    // Under a time budget the bootstrap stops once it has taken its share of it.
    let boot_cap = match budget {
        Budget::Seconds(s) => s * BOOTSTRAP_TIME_SHARE,
        _ => f64::INFINITY,
    };
    let mut boot = bootstrap_until(target, ctx.seed, settings.bootstrap, settings, || {
        (ctx.clock.now() - t0).as_secs_f64() >= boot_cap
    });
    let evidence = SplitEvidence::of(&boot);
    // The per-pixel estimate's first pass, which Split::Auto weighs against the bootstrap.
    let n_pix = (w * h) as usize;
    let mut first = (vec![DVec3::ZERO; n_pix], vec![0; n_pix]);
    let mut direct_seconds = 0.0;
    let first_pass = target.has_direct() && settings.split != Split::Never;
    if first_pass {
        let t = Instant::now();
        let every = settings.direct_every;
        direct_pass(target, ctx.seed, (0, every), w, &mut first.0, &mut first.1);
        direct_seconds += t.elapsed().as_secs_f64();
    }
    let (first_b, first_stderr) =
        mean_stderr(first.0.iter().map(|v| luminance(v.as_vec3()) as f64));
    // Nothing to split where neither estimate saw such a path and no delta surface can make
    // one beyond the lights the camera sees (which the first pass samples in every pixel).
    let none_possible = evidence.b == 0.0 && first_b == 0.0 && !scene.features.specular_surfaces;
    let split = first_pass
        && (settings.split == Split::Always
            || !none_possible
                && (evidence.samples < SPLIT_SAMPLES
                    || evidence.disagrees(first_b, first_stderr, SPLIT_Z)));
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
        direct: if split { first.0 } else { Vec::new() },
        direct_samples: if split { first.1 } else { Vec::new() },
    };
    let pass = |acc: &mut Accumulated, pass: u64| {
        // Pass 0's samples of the split paths were taken before the chains started.
        if !acc.direct.is_empty() && pass > 0 {
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
            format!(
                "{} x {} groups",
                boot.first().map_or(0, |g| g.importance.len()),
                groups
            ),
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
                    "{} (bootstrap: {:.3e} +- {:.1e}, share {:.3e} on {:.1} samples' worth; \
                     first pass: {}; separate_specular={})",
                    if split { "per pixel" } else { "chains" },
                    evidence.b,
                    evidence.stderr,
                    evidence.share,
                    evidence.samples,
                    if first_pass {
                        format!("{first_b:.3e} +- {first_stderr:.1e}")
                    } else {
                        "none".to_string()
                    },
                    match settings.split {
                        Split::Auto => "auto",
                        Split::Always => "true",
                        Split::Never => "false",
                    },
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
