//! The pass driver of sample-per-pixel integrators ([`render_rows`]): every pass gives each
//! pixel one sample, a row per task, with splats merged in row order; camera samples go to
//! the film directly or through the splatted film (`spread.rs`).

use super::spread::{self, SpreadRow, spread_samples};
use super::{Budget, PixelEstimator, RenderContext, RenderResult, run_passes_with_snapshots};
use crate::dbor::Cascade;
use crate::film::Film;
use crate::math::{
    IndependentSampler, PixelSampler, Sampler, SamplerKind, SobolSampler, Spectrum, is_finite3,
};
use crate::scene::Scene;
use glam::{UVec2, Vec2};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// One row's work for [`render_rows`]: a value for each pixel sample, plus splats (pixel
/// index, value) to any pixel (light tracing, BDPT's t = 1), merged after the pass in row order.
pub trait RowTracer {
    /// One sample of the pixel at jittered raster position `raster`; splats it makes are
    /// kept for [`Self::take_splats`].
    fn sample<S: Sampler>(&mut self, raster: Vec2, sampler: &mut S) -> Spectrum;
    /// [`Self::sample`] for every pixel of a row, in order, into `out` (by default one after
    /// the other; a tracer may trace them together if each value and splat stays the same).
    fn sample_row<S: Sampler>(
        &mut self,
        rasters: &[Vec2],
        samplers: &mut [S],
        out: &mut [Spectrum],
    ) {
        for ((&r, sampler), o) in rasters.iter().zip(samplers).zip(out) {
            *o = self.sample(r, sampler);
        }
    }
    /// Splats made since the last call (none by default).
    fn take_splats(&mut self) -> Vec<(u32, Spectrum)> {
        Vec::new()
    }
}

/// The pass driver of sample-per-pixel integrators: each pass gives every pixel one jittered
/// sample from its own stream (seed, pass, pixel) of the sampler `kind` names, one task per
/// row with a tracer from `new_tracer`; splats are added in row order and scaled by
/// 1 / passes (one light path per pixel and pass), so the image does not depend on the number
/// of threads. Snapshots of `ctx.snapshots` are handed out after the passes that reach their
/// times.
pub fn render_rows<T: RowTracer>(
    ctx: &RenderContext,
    budget: Budget,
    kind: SamplerKind,
    new_tracer: impl Fn() -> T + Sync,
) -> RenderResult {
    match kind {
        SamplerKind::Independent => {
            render_rows_with::<IndependentSampler, T>(ctx, budget, new_tracer)
        }
        SamplerKind::Sobol => render_rows_with::<SobolSampler, T>(ctx, budget, new_tracer),
    }
}

fn render_rows_with<S: PixelSampler, T: RowTracer>(
    ctx: &RenderContext,
    budget: Budget,
    new_tracer: impl Fn() -> T + Sync,
) -> RenderResult {
    let UVec2 { x: w, y: h } = ctx.scene.camera.resolution;
    // Camera samples splatted into the pixels their filter covers (`render/spread.rs`).
    let spread = ctx.scene.camera.splats_samples();
    let mut film = spread::film(w, h, spread);
    let invalid = AtomicU64::new(0);
    let mut cascade = ctx.dbor.then(|| Cascade::new(w, h));
    // Each row's camera samples to spread, kept from pass to pass (`spread_samples` empties
    // them; refilling costs no allocation).
    let mut spreads: Vec<SpreadRow> = (0..h).map(|_| SpreadRow::default()).collect();
    let pass = |film: &mut Film, pass: u64| {
        let mut crows = cascade_rows(&mut cascade, h);
        let splats: Vec<Vec<(u32, Spectrum)>> = film
            .par_rows_mut()
            .zip(crows.par_iter_mut())
            .zip(spreads.par_iter_mut())
            .enumerate()
            .map(|(y, ((row, crow), spread_row))| {
                let mut tracer = new_tracer();
                let mut samplers = Vec::with_capacity(row.len());
                let mut rasters = Vec::with_capacity(row.len());
                for x in 0..row.len() {
                    let index = y as u64 * w as u64 + x as u64;
                    let mut sampler = S::for_pixel(ctx.seed, pass, index);
                    let jitter = sampler.next_2d();
                    rasters.push(Vec2::new(x as f32, y as f32) + jitter);
                    samplers.push(sampler);
                }
                let mut values = vec![Spectrum::ZERO; row.len()];
                tracer.sample_row(&rasters, &mut samplers, &mut values);
                for (x, (acc, l)) in row.iter_mut().zip(values).enumerate() {
                    crate::check::value(crate::check::Technique::named("pixel sample"), l);
                    if is_finite3(l) && l.min_element() >= 0.0 {
                        if spread {
                            let size = (w as usize, h as usize);
                            spread_row.push(&ctx.scene.camera.filter, size, rasters[x], l);
                        } else {
                            *acc += l.as_dvec3();
                        }
                        if let Some(cell) = crow.get_mut(x) {
                            Cascade::splat_into(cell, l);
                        }
                    } else {
                        invalid.fetch_add(1, Ordering::Relaxed);
                    }
                }
                tracer.take_splats()
            })
            .collect();
        drop(crows);
        if spread {
            spread_samples(film, ctx.scene.camera.filter.radius(), &mut spreads);
        }
        let lists: Vec<&[(u32, Spectrum)]> = splats.iter().map(Vec::as_slice).collect();
        invalid.fetch_add(film.add_splat_lists(&lists), Ordering::Relaxed);
        if let Some(c) = &mut cascade {
            for &(p, v) in splats.iter().flatten() {
                c.add(p, v);
            }
        }
    };
    let image = |film: &Film, passes: u64| film.to_image(passes as f64, 1.0 / passes as f64);
    let (passes, seconds) = run_passes_with_snapshots(ctx, budget, &mut film, pass, image);
    let splat_scale = if passes > 0 { 1.0 / passes as f64 } else { 0.0 };
    RenderResult {
        dbor: cascade.map(|c| c.reweighted(passes.max(1) as f64)),
        image: film.to_image(passes as f64, splat_scale),
        spp: passes,
        passes,
        seconds,
        stats: vec![(
            "invalid_samples".to_string(),
            invalid.load(Ordering::Relaxed).to_string(),
        )],
    }
}

/// Render with a per-pixel estimator (no splats), drawing from the sampler `kind` names.
pub fn render_pixel_estimator<E: PixelEstimator>(
    ctx: &RenderContext,
    budget: Budget,
    kind: SamplerKind,
    estimator: &E,
) -> RenderResult {
    struct Rows<'a, E>(&'a E, &'a Scene);
    impl<E: PixelEstimator> RowTracer for Rows<'_, E> {
        fn sample<S: Sampler>(&mut self, raster: Vec2, sampler: &mut S) -> Spectrum {
            self.0.estimate(self.1, raster, sampler)
        }
        fn sample_row<S: Sampler>(
            &mut self,
            rasters: &[Vec2],
            samplers: &mut [S],
            out: &mut [Spectrum],
        ) {
            self.0.estimate_row(self.1, rasters, samplers, out);
        }
    }
    render_rows(ctx, budget, kind, || Rows(estimator, ctx.scene))
}

/// Per-row cells of an optional cascade (empty rows without one), to zip with film rows.
pub fn cascade_rows(
    cascade: &mut Option<Cascade>,
    height: u32,
) -> Vec<&mut [[glam::DVec3; crate::dbor::LAYERS]]> {
    match cascade {
        Some(c) => c.rows_mut().collect(),
        None => (0..height).map(|_| &mut [][..]).collect(),
    }
}
