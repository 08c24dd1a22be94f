//! `Guided<U, S>`: the one guided integrator, over any unguided estimator U and any seeder S.
//!
//! Schedule: learning for `learn_fraction` of the budget (iteration 0 pure U; then passes of
//! U plus guided samples whose paths the seeder turns into the next cache), then the cache is
//! frozen and the image rendered with it. Each pass gives pixel i the stream (seed, pass, i)
//! for its unguided sample and guided sample j the stream (seed, pass, N_pix + j), with j
//! handled by the row of pixel j mod N_pix, so images do not depend on the thread count.
//!
//! **The guided share.** With `share = auto` (the default) the render's ratio of guided to
//! unguided samples is chosen at the end of learning from what the learning passes measured
//! (`share.rs`). The learning passes stay in the image, averaged with the render passes by
//! pass count (unless `--dbor` asked for the re-weighted image of the render passes or
//! `keep_learning = false`). Each adds one of two estimates, fixed before its samples are
//! drawn: its mixed estimate (its unguided and guided samples weighed with the cache it ran
//! with) where the learning passes before it chose guiding (or `share = fixed`), else U's own
//! estimate of its unguided samples (each path weighted `f / p_u`, the guided samples left
//! out; a learning pass accumulates both). Every pass is then unbiased given the passes
//! before it, and so is their average over a fixed number of passes. When the share is 0
//! (guiding does not pay, or the cache is empty) the render passes continue U's streams: where
//! every learning pass kept U's own estimate, the image is U's own image of as many passes,
//! sample for sample. When in three
//! learning iterations running every ratio with guided samples loses to U alone by more than
//! 25 % and the cache has stopped growing (by more than 10 % an iteration), learning stops
//! there (unless a cache is to be saved): a scene with nothing to guide costs a few passes,
//! not the learning budget (`share::EarlyStop`). When at the end of the budget the share is
//! undecided (guiding pays by the learning passes as a whole but not by one of their
//! halves), learning goes on until it is decided or has taken `share::EXTENSION` times its
//! budget. A loaded cache renders with the share its learning
//! run chose (saved with it); `share = fixed` uses `alpha`.

use super::cache::{self, GuideCache, RebuildParams, WeightRule};
use super::collector::Collector;
use super::coverage::{self, CoverageVariance};
use super::estimator::{Estimator, RowOutput, Stats};
use super::io;
use super::report::{self, stat};
use super::seeder::{Candidate, Explore, LearnPass, LearnRow, Seeder, Source};
use super::{GuidedSettings, Share, share};
use crate::camera::Camera;
use crate::dbor::Cascade;
use crate::error::Result;
use crate::film::Film;
use crate::geometry::bvh::rays_traced;
use crate::integrators::unguided::{HeldPaths, Unguided, own_row};
use crate::math::{AnySampler, IndependentSampler, Sampler, SamplerKind, luminance, luminance64};
use crate::render::{
    Budget, Integrator, RenderContext, RenderResult, cascade_rows, run_passes_with_snapshots,
};
use crate::scene::Scene;
use glam::UVec2;
use rayon::prelude::*;
use std::sync::Arc;

/// Render passes draw from streams (seed, RENDER_STREAMS + pass, ...), learning passes from
/// (seed, iteration, ...): a render with a loaded cache repeats the render phase of a run
/// that saved it with guiding on. When guiding is off and the learning passes are kept, the
/// render passes go on from the last learning pass's streams instead, (seed, learning
/// passes + pass, ...), so the image is U's own image of the same number of passes, sample
/// for sample: the equal-time comparison with U then differs only in the passes the
/// learning cost. (`math::streams` has the whole layout.)
const RENDER_STREAMS: u64 = crate::math::streams::GUIDED_RENDER_PASSES;

/// The guided integrator over unguided estimator `U` and seeder `S`.
pub struct Guided<U: Unguided, S: Seeder> {
    /// Registry name (`guided-pt`, `guided-bdpt`, `guided-vcm`).
    pub name: &'static str,
    /// The unguided estimator the guided technique is mixed with.
    pub unguided: U,
    /// Where guide paths come from.
    pub seeder: S,
    /// The guider's own settings.
    pub settings: GuidedSettings,
    /// A cache to render with instead of learning one (tests; `load_guides` sets it too).
    pub cache: Option<GuideCache>,
}

/// What a measured pass returns: per pixel, U's luminance under each ratio of `share.rs`;
/// and Σ g(r)² of its guided samples.
type PassGrid = (Vec<[f64; share::N]>, [f64; share::N]);

impl<U: Unguided, S: Seeder> Guided<U, S> {
    /// One pass: U per pixel plus the guided samples; returns per-row outputs in row order
    /// and, when `measure`, the pass's per-pixel luminance of the mixed estimate and of U alone.
    #[allow(clippy::too_many_arguments)]
    fn pass(
        &self,
        ctx: &RenderContext,
        est: &Estimator<U>,
        film: &mut Film,
        own_film: Option<&mut Film>,
        cascade: &mut Option<Cascade>,
        pass: u64,
        measure: bool,
    ) -> (Vec<RowOutput>, Option<PassGrid>) {
        // Learning passes also accumulate U's own image into `own_film`.
        let learning = own_film.is_some();
        let scene = ctx.scene;
        let UVec2 { x: w, .. } = scene.camera.resolution;
        let n_pix = scene.camera.pixel_count() as u64;
        let n_g = est.n_g as u64;
        let plain = n_g == 0 && !learning && !measure;
        let mut crows = cascade_rows(cascade, scene.camera.resolution.y);
        let rows = film
            .par_rows_mut()
            .zip(crows.par_iter_mut())
            .enumerate()
            .map(|(y, (row, crow))| {
                let mut out = RowOutput::default();
                out.candidates.collect_terms =
                    learning && n_g > 0 && self.settings.weights == WeightRule::SecondMoment;
                let mut tracer = est.unguided.tracer(est.scene, &est.pass);
                // Nothing of the guider to evaluate: U's own estimator, as fast as U.
                let plain_row = plain.then(|| {
                    let rays = rays_traced();
                    let seeds = (ctx.seed, pass);
                    let kind = self.settings.sampler;
                    let v = own_row(
                        &self.unguided,
                        &mut tracer,
                        scene,
                        seeds,
                        y as u32,
                        kind,
                        &mut out.splats,
                    );
                    out.stats.rays_u += rays_traced() - rays;
                    v
                });
                for (x, acc) in row.iter_mut().enumerate() {
                    let index = y as u64 * w as u64 + x as u64;
                    // Learning passes draw independent numbers: their outliers and chain
                    // states are replayed from the stream (seed, pass, index).
                    let kind = if learning {
                        SamplerKind::Independent
                    } else {
                        self.settings.sampler
                    };
                    let rays = rays_traced();
                    let (sum, grid) = if let Some(values) = &plain_row {
                        (values[x], [0.0; share::N])
                    } else {
                        let mut sampler = AnySampler::new(kind, ctx.seed, pass, index);
                        let raster = Camera::jittered(x as u32, y as u32, sampler.next_2d());
                        let source = Source::Unguided { pass, index };
                        let mut col = Collector::new(est, &mut out, source, learning, measure);
                        self.unguided
                            .trace(&mut tracer, scene, raster, &mut sampler, &mut col);
                        let (sum, grid, own) = (col.sum, col.grid, col.u_sum);
                        if learning {
                            out.u_pixels.push(own);
                        } else {
                            let classes = col.class_sum;
                            out.class_pixels.push(classes);
                        }
                        (sum, grid)
                    };
                    *acc += sum;
                    if measure {
                        out.grid.push(grid);
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
                        let g = est.guided(
                            &mut gs,
                            learning,
                            &mut out.stats,
                            &mut out.candidates,
                            &mut out.path,
                        );
                        if let Some(g) = g {
                            if out.candidates.collect_terms {
                                let terms = &out.candidates.terms;
                                est.credit(g.value, g.p_u, g.p_g, terms, &mut out.responsibility);
                            }
                            out.splats.push((g.pixel, g.value));
                            if !learning {
                                let lum = luminance64(g.value);
                                out.class_splats
                                    .push((g.pixel, coverage::GUIDED as u8, lum));
                            }
                            if measure {
                                let v = share::values(g.f_lum, g.p_u, g.p_g);
                                for (m, x) in out.guided_m2.iter_mut().zip(v) {
                                    *m += x * x;
                                }
                            }
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
                                        source: Source::Guided,
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
            let mut image = vec![[0.0f64; share::N]; n_pix as usize];
            let mut guided_m2 = [0.0; share::N];
            for (y, r) in rows.iter().enumerate() {
                let row = y * w as usize;
                for (x, v) in r.grid.iter().enumerate() {
                    image[row + x] = *v;
                }
                for (p, v) in &r.grid_splats {
                    for (a, b) in image[*p as usize].iter_mut().zip(v) {
                        *a += b;
                    }
                }
                for (a, b) in guided_m2.iter_mut().zip(r.guided_m2) {
                    *a += b;
                }
            }
            (image, guided_m2)
        });
        if let Some(own) = own_film {
            own.par_rows_mut()
                .zip(rows.par_iter())
                .for_each(|(row, r)| {
                    for (a, b) in row.iter_mut().zip(&r.u_pixels) {
                        *a += *b;
                    }
                });
            for r in &rows {
                own.add_splats64(&r.u_splats);
            }
        }
        for r in &rows {
            // The estimator has left out (and counted) every non-finite value already.
            let dropped = film.add_splats64(&r.splats);
            debug_assert_eq!(dropped, 0);
            if let Some(c) = cascade {
                for &(p, v) in &r.splats {
                    c.add(p, v.as_vec3());
                }
            }
        }
        (rows, measured)
    }
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
            let cache = io::load(scene, file)?;
            // Guided samples follow their guide's length: a guide longer than U's max_depth
            // would add paths that U, and the image asked for, leave out.
            let max_depth = self.unguided.max_depth();
            let longest = cache.guides.iter().map(|g| g.len as u32 - 1).max();
            if let Some(segments) = longest.filter(|&k| k > max_depth) {
                return Err(crate::error::Error::new(format!(
                    "{}: the cache holds guide paths of {segments} segments, more than \
                     max_depth {max_depth}: render with --max-depth {segments} or more, or \
                     learn a cache with this max_depth",
                    file.display()
                )));
            }
            self.cache = Some(cache);
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
        let clock = ctx.clock;
        let start = clock.now();
        let UVec2 { x: w, y: h } = scene.camera.resolution;
        let mut film = Film::new(w, h);
        // A loaded cache keeps the kernel widths it was saved with, and is rendered with even
        // when it holds no guide path (the learning run found nothing worth guiding).
        let loaded = self.settings.load_guides.is_some();
        let mut cache = self
            .cache
            .take()
            .unwrap_or_else(|| GuideCache::with_widths(st.widths));
        cache.manifold.share = st.manifold;
        let mut stats = Stats::default();
        let mut learn_passes = 0u64;
        let mut rebuild_seconds = 0.0;
        let mut meter = share::ShareMeter::default();
        let mut early_stop = share::EarlyStop::default();
        // Per learning pass: its mixed estimate and U's own estimate of its unguided samples,
        // and the kept image, which adds one of the two per pass (see `keep_learning`).
        let mut pass_film = Film::new(w, h);
        let mut pass_own = Film::new(w, h);
        let mut kept_film = Film::new(w, h);
        let mut kept_guided = 0u64;
        // ---- Learning (skipped with a loaded cache) ----
        let learning = !loaded && st.learn_fraction > 0.0;
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
                    let shared = self.unguided.begin_pass(scene, ctx.seed, k, k);
                    let est = Estimator::new(scene, &self.unguided, shared, &cache, st.alpha);
                    let measure = st.share == Share::Auto && est.n_g > 0.0;
                    // Which estimate of this pass the image keeps, fixed before its samples
                    // are drawn: the mixture where the passes so far chose guiding (or the
                    // share is fixed), else U's own.
                    let keep_guided = est.n_g > 0.0
                        && match st.share {
                            Share::Fixed => true,
                            Share::Auto => meter.decide().is_some_and(|d| d.ratio > 0.0),
                        };
                    pass_film.clear();
                    pass_own.clear();
                    let (rows, measured) = self.pass(
                        ctx,
                        &est,
                        &mut pass_film,
                        Some(&mut pass_own),
                        &mut None,
                        k,
                        measure,
                    );
                    // The learning film averages the mixed estimates of the learning passes;
                    // it is what snapshots during learning show.
                    film.add(&pass_film);
                    kept_film.add(if keep_guided { &pass_film } else { &pass_own });
                    kept_guided += u64::from(keep_guided);
                    let mut pass_stats = Stats::default();
                    for r in &rows {
                        pass_stats.add(&r.stats);
                    }
                    pass_stats.rays_u += est.unguided.pass_rays(&est.pass);
                    stats.add(&pass_stats);
                    if let Some((image, guided_m2)) = measured {
                        meter.add(image, guided_m2, est.n_u, &pass_stats);
                    }
                    let alpha = est.alpha;
                    // Each guide's credit, summed in row order (deterministic).
                    let mut second_moment = Vec::new();
                    if rows.iter().any(|r| !r.responsibility.is_empty()) {
                        second_moment = vec![0.0; cache.guides.len()];
                        for r in &rows {
                            for &(l, x) in &r.responsibility {
                                second_moment[l as usize] += x;
                            }
                        }
                    }
                    let mut learn_rows: Vec<LearnRow> = rows.into_iter().map(|r| r.learn).collect();
                    let explore = Explore {
                        seed: ctx.seed,
                        iteration: k as u32,
                        est: &est,
                    };
                    self.seeder.explore(explore, &mut learn_rows);
                    let records = self.seeder.harvest(LearnPass {
                        scene,
                        iteration: k as u32,
                        alpha,
                        rows: &mut learn_rows,
                    });
                    drop(learn_rows);
                    drop(est);
                    k += 1;
                    if let Some(snap) = ctx.snapshots {
                        snap.emit_due(k, k, || film.to_image(k as f64, 1.0 / k as f64));
                    }
                    let (spent, extended) = match lb {
                        Budget::Spp(n) => (k >= n, k as f64 >= share::EXTENSION * n as f64),
                        Budget::Seconds(s) => {
                            let t = (clock.now() - start).as_secs_f64();
                            (t >= s, t >= share::EXTENSION * s)
                        }
                    };
                    // An undecided share (`share::Decision::undecided`) learns on, up to
                    // `share::EXTENSION` times the learning budget.
                    let undecided = spent
                        && !extended
                        && st.share == Share::Auto
                        && meter.decide().is_some_and(|d| d.undecided);
                    let done = spent && !undecided;
                    // Nothing to guide: once three measured iterations of a settled cache
                    // agree that no ratio pays (by a margin), stop learning and render with U
                    // (not when a cache is to be saved: that asks for the whole learning
                    // phase). `share::EarlyStop` has the rule.
                    let hopeless =
                        measure && early_stop.observe(cache.len(), meter.decide().as_ref());
                    if hopeless && !done && st.save_guides.is_none() {
                        break;
                    }
                    let rebuild_start = clock.now();
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
                        &second_moment,
                    );
                    rebuild_seconds += (clock.now() - rebuild_start).as_secs_f64();
                    if done || ctx.stopped() {
                        break;
                    }
                }
                learn_passes = k;
            }
        }
        let learn_seconds = (clock.now() - start).as_secs_f64();
        // ---- The guided share, from what learning measured ----
        let decision = meter.decide();
        if let Some(d) = &decision {
            cache.learned_ratio = Some(d.ratio);
        }
        // A loaded cache renders with the share its learning run chose.
        let ratio = match st.share {
            Share::Auto => decision.as_ref().map(|d| d.ratio).or(cache.learned_ratio),
            Share::Fixed => None,
        };
        let alpha = ratio.map_or(st.alpha, |r| 1.0 / (1.0 + r));
        let (alpha, _, n_g) = Estimator::split(scene, &self.unguided, &cache, alpha);
        // The learning passes stay in the image (averaged with the render passes by pass
        // count) unless the DBOR image of the render passes was asked for or
        // `keep_learning = false`. Each pass adds one of two estimates, chosen before its
        // samples were drawn: the mixture's (unguided and guided samples weighed with the cache
        // the pass ran with) where the passes before it chose guiding, else U's own estimate
        // of its unguided samples (the guided samples left out). Every pass, learning or
        // render, is thus unbiased given all that came before it (its streams are its own, its
        // estimator was fixed by earlier passes), so the average of a fixed number of passes
        // is unbiased, however the share and the cache were chosen. Where guiding stays off
        // throughout, the kept passes are U's own image and the render passes continue U's
        // streams: the image is U's own image of as many passes, sample for sample.
        let keep_learning = st.keep_learning && !ctx.dbor && learn_passes > 0;
        let (kept, first_stream) = match (keep_learning, n_g == 0.0) {
            (true, true) => (learn_passes, learn_passes),
            (true, false) => (learn_passes, RENDER_STREAMS),
            (false, _) => (0, RENDER_STREAMS),
        };
        if keep_learning {
            film = kept_film;
        } else {
            film.clear();
        }
        // ---- Rendering with the frozen cache ----
        let render_stats = std::cell::RefCell::new(Stats::default());
        let class_variance = std::cell::RefCell::new(CoverageVariance::default());
        let render_budget = match budget {
            Budget::Spp(n) => Budget::Spp(n.saturating_sub(learn_passes).max(1)),
            Budget::Seconds(s) => Budget::Seconds((s - learn_seconds).max(0.0)),
        };
        let mut cascade = ctx.dbor.then(|| Cascade::new(w, h));
        // Guiding off: U's own integrator, where it has a faster one (vcm's recursive weights
        // against the explicit ones guided-vcm's estimator needs), renders the passes that
        // remain, on the streams this driver's passes would use; its image is averaged with
        // the kept learning passes by pass count. (Snapshots meanwhile show its passes alone.)
        let own = (n_g == 0.0 && keep_learning)
            .then(|| self.unguided.own_integrator(self.settings.sampler))
            .flatten();
        let mut own_image = None;
        let (passes, render_seconds) = if let Some(mut own) = own {
            let sub = RenderContext {
                first_pass: ctx.first_pass + first_stream,
                ..*ctx
            };
            let r = own.render(&sub, render_budget);
            let kept_image = film.to_image(kept.max(1) as f64, 1.0 / kept.max(1) as f64);
            let total = (kept + r.passes).max(1) as f32;
            let (a, b) = (kept as f32 / total, r.passes as f32 / total);
            let mut image = r.image;
            for (p, q) in image.pixels.iter_mut().zip(&kept_image.pixels) {
                *p = *q * a + *p * b;
            }
            own_image = Some(image);
            (r.passes, r.seconds)
        } else {
            // The spent pass state, refilled by the next pass (`Unguided::renew_pass`).
            let mut spare = None;
            // Render passes need the densities of the paths whose structure the cache holds
            // only (`Collector::needs_densities`): U may trace them with a faster tracer.
            let held = (n_g > 0.0).then(|| Arc::new(cache.held()) as Arc<dyn HeldPaths>);
            run_passes_with_snapshots(
                ctx,
                render_budget,
                &mut film,
                |film, p| {
                    let stream = first_stream + p;
                    let (ordinal, spent) = (learn_passes + p, spare.take());
                    let shared = (self.unguided).renew_render_pass(
                        scene,
                        ctx.seed,
                        stream,
                        ordinal,
                        spent,
                        held.as_ref(),
                    );
                    let est = Estimator::new(scene, &self.unguided, shared, &cache, alpha);
                    let (rows, _) = self.pass(ctx, &est, film, None, &mut cascade, stream, false);
                    for r in &rows {
                        render_stats.borrow_mut().add(&r.stats);
                    }
                    let classes: Vec<_> = rows
                        .iter()
                        .map(|r| (&r.class_pixels[..], &r.class_splats[..]))
                        .collect();
                    class_variance.borrow_mut().add_pass(&classes, w as usize);
                    spare = Some(est.pass);
                },
                |film, passes| {
                    let n = (kept + passes).max(1) as f64;
                    film.to_image(n, 1.0 / n)
                },
            )
        };
        let rs = render_stats.into_inner();
        let class_var = class_variance.into_inner().variances();
        let total = (kept + passes).max(1);
        let image = own_image.unwrap_or_else(|| film.to_image(total as f64, 1.0 / total as f64));
        let mut out_stats = report::stats(&report::Facts {
            cache: &cache,
            learn_passes,
            learn_seconds,
            rebuild_seconds,
            render_seconds,
            alpha,
            decision: decision.as_ref(),
            learning: &stats,
            render: &rs,
            kept,
            kept_guided: if keep_learning { kept_guided } else { 0 },
            class_var,
        });
        out_stats.push(stat("seeder", self.seeder.name()));
        out_stats.extend(self.seeder.stats());
        self.cache = Some(cache);
        RenderResult {
            dbor: cascade.map(|c| c.reweighted(passes.max(1) as f64)),
            image,
            spp: kept + passes,
            passes: kept + passes,
            seconds: (clock.now() - start).as_secs_f64(),
            stats: out_stats,
        }
    }
}
