//! `Guided<U, S>`: the one guided integrator, over any unguided estimator U and any seeder S.
//!
//! Schedule: learning for `learn_fraction` of the budget (iteration 0 pure U; then passes of
//! U plus guided samples whose paths the seeder turns into the next cache), then the cache is
//! frozen and the image rendered with it. Each pass gives pixel i the stream (seed, pass, i)
//! for its unguided sample and guided sample j the stream (seed, pass, N_pix + j), with j
//! handled by the row of pixel j mod N_pix, so images do not depend on the thread count.
//!
//! **The guided share (`share = auto`, the default).** At the end of learning the guider
//! decides whether the guided technique pays for itself, from the learning passes that had a
//! cache (the later half of them, whose caches are closest to the final one). For each it
//! knows, pixel by pixel, the mixed estimate and what U alone would have given from the same
//! unguided samples (`f / p_u`), so both variances come from the same samples:
//! `V = Σ_pixels E[X²] − Σ μ²`. Costs are counted in rays (deterministic, unlike wall time,
//! so a render under `--spp` stays reproducible): U's rays; for the mixture also the guided
//! samples' rays and `PG_CANDIDATE_RAYS` per p_g candidate evaluated. Guiding stays on with
//! share α when `V_mix · cost_mix < V_U · cost_U`, and is off otherwise (α = 1: no guided
//! sample and no p_g evaluation, the estimator is U's own). When it is off, the learning
//! passes (each an unbiased estimate of the image) are kept in the image instead of being
//! discarded, unless `--dbor` asked for the re-weighted image of the render passes. The
//! decision is global, not per image region. `share = fixed` always uses α; a loaded cache
//! (no learning) uses α.

use super::cache::{self, GuideCache, RebuildParams};
use super::estimator::{Collector, Estimator, FAILURE_REASONS, RowOutput, Stats};
use super::io;
use super::seeder::{Candidate, LearnPass, LearnRow, Seeder};
use super::{GuidedSettings, Share};
use crate::dbor::Cascade;
use crate::error::Result;
use crate::film::Film;
use crate::geometry::bvh::rays_traced;
use crate::integrators::unguided::Unguided;
use crate::math::{IndependentSampler, Sampler, luminance};
use crate::render::{
    Budget, Integrator, RenderContext, RenderResult, cascade_rows, run_passes_with_snapshots,
};
use crate::scene::Scene;
use glam::{DVec3, UVec2, Vec2};
use rayon::prelude::*;
use std::time::Instant;

/// Render passes draw from streams (seed, RENDER_STREAMS + pass, ...), learning passes from
/// (seed, iteration, ...): a render with a loaded cache repeats the render phase of the run
/// that saved it.
const RENDER_STREAMS: u64 = 1 << 40;
/// Cost of one p_g candidate term in rays (measured: a candidate's factors cost 50-80 ns, a
/// ray in the shipped scenes 150-700 ns; `benches/guided_pg.rs`).
const PG_CANDIDATE_RAYS: f64 = 0.25;

/// The guided integrator over unguided estimator `U` and seeder `S`.
pub struct Guided<U: Unguided, S: Seeder> {
    pub name: &'static str,
    pub unguided: U,
    pub seeder: S,
    pub settings: GuidedSettings,
    /// A cache to render with instead of learning one (tests; `load_guides` sets it too).
    pub cache: Option<GuideCache>,
}

/// Per-pixel luminance of one pass's mixed estimate and of U alone from the same samples.
type PassImages = (Vec<f64>, Vec<f64>);

/// Second moments and costs of one measured learning pass.
struct PassMeasure {
    /// Σ_pixels lum(X)² of the mixed estimate and of U alone.
    m2_mix: f64,
    m2_alone: f64,
    cost_mix: f64,
    cost_alone: f64,
}

/// What the share decision saw.
#[derive(Default)]
struct ShareMeter {
    passes: Vec<PassMeasure>,
    /// Per-pixel sum of lum(mixed) over the measured passes (for Σ μ²).
    sum: Vec<f64>,
}

impl ShareMeter {
    fn add(&mut self, mixed: &[f64], alone: &[f64], stats: &Stats) {
        if self.sum.is_empty() {
            self.sum = vec![0.0; mixed.len()];
        }
        for (s, m) in self.sum.iter_mut().zip(mixed) {
            *s += m;
        }
        self.passes.push(PassMeasure {
            m2_mix: mixed.iter().map(|x| x * x).sum(),
            m2_alone: alone.iter().map(|x| x * x).sum(),
            cost_mix: (stats.rays_u + stats.rays_g) as f64
                + PG_CANDIDATE_RAYS * stats.pg_candidates as f64,
            cost_alone: stats.rays_u as f64,
        });
    }

    /// (guiding pays, V_mix · cost_mix / (V_U · cost_U)); `None` without measured passes.
    fn decide(&self) -> Option<(bool, f64)> {
        let n = self.passes.len();
        if n == 0 {
            return None;
        }
        let mean2: f64 = self
            .sum
            .iter()
            .map(|s| (s / n as f64) * (s / n as f64))
            .sum();
        let late = &self.passes[n / 2..];
        let k = late.len() as f64;
        let avg = |f: fn(&PassMeasure) -> f64| late.iter().map(f).sum::<f64>() / k;
        let v_mix = (avg(|p| p.m2_mix) - mean2).max(0.0);
        let v_alone = (avg(|p| p.m2_alone) - mean2).max(0.0);
        let ratio = (v_mix * avg(|p| p.cost_mix)) / (v_alone * avg(|p| p.cost_alone));
        Some((ratio < 1.0 || !ratio.is_finite() && v_alone > 0.0, ratio))
    }
}

impl<U: Unguided, S: Seeder> Guided<U, S> {
    /// One pass: U per pixel plus the guided samples; returns per-row outputs in row order
    /// and, when `measure`, the pass's per-pixel luminance of the mixed estimate and of U alone.
    #[allow(clippy::too_many_arguments)]
    fn pass(
        &self,
        ctx: &RenderContext,
        est: &Estimator<U>,
        film: &mut Film,
        cascade: &mut Option<Cascade>,
        pass: u64,
        learning: bool,
        measure: bool,
    ) -> (Vec<RowOutput>, Option<PassImages>) {
        let scene = ctx.scene;
        let UVec2 { x: w, .. } = scene.camera.resolution;
        let n_pix = scene.camera.pixel_count() as u64;
        let n_g = est.n_g as u64;
        let mut crows = cascade_rows(cascade, scene.camera.resolution.y);
        let rows = film
            .par_rows_mut()
            .zip(crows.par_iter_mut())
            .enumerate()
            .map(|(y, (row, crow))| {
                let mut out = RowOutput::default();
                let mut tracer = self.unguided.tracer(scene);
                for (x, acc) in row.iter_mut().enumerate() {
                    let index = y as u64 * w as u64 + x as u64;
                    let mut sampler = IndependentSampler::new(ctx.seed, pass, index);
                    let raster = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                    let rays = rays_traced();
                    let mut col = Collector {
                        est,
                        sum: DVec3::ZERO,
                        alone: DVec3::ZERO,
                        learning,
                        measuring: measure,
                        out: &mut out,
                    };
                    self.unguided
                        .trace(&mut tracer, scene, raster, &mut sampler, &mut col);
                    let (sum, alone) = (col.sum, col.alone);
                    *acc += sum;
                    if measure {
                        out.values.push(sum);
                        out.alone.push(alone);
                    }
                    if let Some(cell) = crow.get_mut(x) {
                        Cascade::splat_into(cell, sum.as_vec3());
                    }
                    let rays_g = rays_traced();
                    out.stats.rays_u += rays_g - rays;
                    // Guided samples j = index, index + N, ... below n_g.
                    let mut j = index;
                    while j < n_g {
                        let mut gs = IndependentSampler::new(ctx.seed, pass, n_pix + j);
                        let g = est.guided(&mut gs, learning, &mut out.stats, &mut out.scratch);
                        if let Some(g) = g {
                            out.splats.push((g.pixel, g.value));
                            if learning {
                                let lum = luminance(g.value.as_vec3()) as f64;
                                out.learn.samples.push((g.pixel, lum as f32));
                                let densify = (est.cache.guides[g.guide].neighbours as usize)
                                    < cache::NEIGHBOURS;
                                if let Some(record) = g.record {
                                    out.learn.offer(lum, || Candidate {
                                        record,
                                        pixel: g.pixel,
                                        value: lum,
                                        densify,
                                    });
                                }
                            }
                        }
                        j += n_pix;
                    }
                    out.stats.rays_g += rays_traced() - rays_g;
                }
                out.learn.cut();
                out
            })
            .collect::<Vec<RowOutput>>();
        drop(crows);
        let measured = measure.then(|| {
            let (mut mixed, mut alone) = (vec![0.0f64; n_pix as usize], vec![0.0; n_pix as usize]);
            for (y, r) in rows.iter().enumerate() {
                let row = y * w as usize;
                for (x, (v, a)) in r.values.iter().zip(&r.alone).enumerate() {
                    mixed[row + x] += lum64(*v);
                    alone[row + x] += lum64(*a);
                }
                for &(p, v) in &r.splats {
                    mixed[p as usize] += lum64(v);
                }
                for &(p, v) in &r.alone_splats {
                    alone[p as usize] += lum64(v);
                }
            }
            (mixed, alone)
        });
        for r in &rows {
            film.add_splats64(&r.splats);
            if let Some(c) = cascade {
                for &(p, v) in &r.splats {
                    c.add(p, v.as_vec3());
                }
            }
        }
        (rows, measured)
    }
}

fn lum64(v: DVec3) -> f64 {
    luminance(v.as_vec3()) as f64
}

fn stat(k: &str, v: impl ToString) -> (String, String) {
    (k.to_string(), v.to_string())
}

impl<U: Unguided, S: Seeder> Integrator for Guided<U, S> {
    fn name(&self) -> &'static str {
        self.name
    }

    fn settings(&self) -> String {
        format!("{:?} over {}", self.settings, self.unguided.name())
    }

    /// Load `load_guides` (a wrong version, a truncated file or another scene's cache is an
    /// error) and check that `save_guides` can be written.
    fn prepare(&mut self, scene: &Scene) -> Result<()> {
        if let Some(file) = &self.settings.load_guides {
            self.cache = Some(io::load(scene, file)?);
        }
        if let Some(file) = &self.settings.save_guides {
            crate::film::output_dir(file)?;
        }
        Ok(())
    }

    /// Write the learned cache to `save_guides`.
    fn finish(&mut self, scene: &Scene) -> Result<()> {
        match (&self.settings.save_guides, &self.cache) {
            (Some(file), Some(cache)) => io::save(scene, cache, file),
            _ => Ok(()),
        }
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        let scene = ctx.scene;
        let st = self.settings.clone();
        let start = Instant::now();
        let UVec2 { x: w, y: h } = scene.camera.resolution;
        let mut film = Film::new(w, h);
        // A loaded cache keeps the kernel widths it was saved with.
        let mut cache = self
            .cache
            .take()
            .unwrap_or_else(|| GuideCache::with_widths(st.widths));
        let mut stats = Stats::default();
        let mut learn_passes = 0u64;
        let mut meter = ShareMeter::default();
        // ---- Learning (skipped with a loaded cache) ----
        let learning = cache.is_empty() && st.learn_fraction > 0.0;
        if learning {
            let learn_budget = match budget {
                Budget::Spp(n) if n >= 2 => Some(Budget::Spp(
                    ((n as f64 * st.learn_fraction).round() as u64).max(1),
                )),
                Budget::Spp(_) => None,
                Budget::Seconds(s) => Some(Budget::Seconds(s * st.learn_fraction)),
            };
            if let Some(lb) = learn_budget {
                let mut k = 0u64;
                loop {
                    let est = Estimator::new(scene, &self.unguided, &cache, st.alpha);
                    let measure = st.share == Share::Auto && est.n_g > 0.0;
                    // The learning film averages the learning passes (each an unbiased
                    // estimate); it is what snapshots during learning show.
                    let (rows, measured) =
                        self.pass(ctx, &est, &mut film, &mut None, k, true, measure);
                    let mut pass_stats = Stats::default();
                    for r in &rows {
                        pass_stats.add(&r.stats);
                    }
                    stats.add(&pass_stats);
                    if let Some((mixed, alone)) = measured {
                        meter.add(&mixed, &alone, &pass_stats);
                    }
                    let alpha = est.alpha;
                    let mut learn_rows: Vec<LearnRow> = rows.into_iter().map(|r| r.learn).collect();
                    let records = self.seeder.harvest(LearnPass {
                        scene,
                        iteration: k as u32,
                        alpha,
                        rows: &mut learn_rows,
                    });
                    drop(learn_rows);
                    k += 1;
                    if let Some(snap) = ctx.snapshots {
                        snap.emit_due(k, k, || film.to_image(k as f64, 1.0 / k as f64));
                    }
                    let done = match lb {
                        Budget::Spp(n) => k >= n,
                        Budget::Seconds(s) => start.elapsed().as_secs_f64() >= s,
                    };
                    cache.rebuild(
                        scene,
                        records,
                        RebuildParams {
                            iteration: k as u32,
                            alpha,
                            damping: st.damping,
                            render_mode: done,
                            max_guides: st.max_guides,
                        },
                    );
                    if done {
                        break;
                    }
                }
                learn_passes = k;
            }
        }
        let learn_seconds = start.elapsed().as_secs_f64();
        // ---- The guided share, from what learning measured ----
        let decision = meter.decide();
        let alpha = match decision {
            Some((false, _)) => 1.0,
            _ => st.alpha,
        };
        // Guiding off: the learning passes are U's passes plus unbiased guided ones; keep
        // them (unless the DBOR image of the render passes was asked for).
        let keep_learning = alpha == 1.0 && decision.is_some() && !ctx.dbor;
        let kept = if keep_learning { learn_passes } else { 0 };
        if !keep_learning {
            film.clear();
        }
        // ---- Rendering with the frozen cache ----
        let render_stats = std::cell::RefCell::new(Stats::default());
        let render_budget = match budget {
            Budget::Spp(n) => Budget::Spp(n.saturating_sub(learn_passes).max(1)),
            Budget::Seconds(s) => Budget::Seconds((s - learn_seconds).max(0.0)),
        };
        let est = Estimator::new(scene, &self.unguided, &cache, alpha);
        let mut cascade = ctx.dbor.then(|| Cascade::new(w, h));
        let (passes, render_seconds) = run_passes_with_snapshots(
            ctx,
            render_budget,
            &mut film,
            |film, p| {
                let (rows, _) = self.pass(
                    ctx,
                    &est,
                    film,
                    &mut cascade,
                    RENDER_STREAMS + p,
                    false,
                    false,
                );
                for r in &rows {
                    render_stats.borrow_mut().add(&r.stats);
                }
            },
            |film, passes| {
                let n = (kept + passes).max(1) as f64;
                film.to_image(n, 1.0 / n)
            },
        );
        let rs = render_stats.into_inner();
        let total = (kept + passes).max(1);
        let image = film.to_image(total as f64, 1.0 / total as f64);
        let out_stats = vec![
            stat("guide_paths", cache.len()),
            stat(
                "bytes_per_guide_path",
                format!("{:.0}", cache.bytes_per_path()),
            ),
            stat("learning_iterations", learn_passes),
            stat("learning_seconds", format!("{learn_seconds:.3}")),
            stat("render_seconds", format!("{render_seconds:.3}")),
            stat("unguided_share", format!("{:.3}", est.alpha)),
            stat(
                "share_cost_ratio",
                decision.map_or("-".to_string(), |d| format!("{:.3}", d.1)),
            ),
            stat("learning_passes_kept", kept),
            stat("guided_samples", rs.guided),
            stat(
                "failed_guided_share",
                format!("{:.4}", rs.failed as f64 / rs.guided.max(1) as f64),
            ),
            stat(
                "mean_pg_candidates",
                format!(
                    "{:.2}",
                    rs.pg_candidates as f64 / rs.pg_evaluations.max(1) as f64
                ),
            ),
            stat("pg_evaluations", rs.pg_evaluations),
            stat("invalid_unguided_paths", rs.invalid),
            stat("learning_guided_samples", stats.guided),
            stat(
                &format!("failures_{FAILURE_REASONS}"),
                format!("{:?}", rs.reasons),
            ),
        ];
        self.cache = Some(cache);
        RenderResult {
            dbor: cascade.map(|c| c.reweighted(passes.max(1) as f64)),
            image,
            spp: kept + passes,
            passes: kept + passes,
            seconds: start.elapsed().as_secs_f64(),
            stats: out_stats,
        }
    }
}
