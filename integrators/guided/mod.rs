//! `guided-pt` — selective guided sampling with complete paths (Reibold et al. 2018), mixed
//! with path tracing.
//!
//! Every pass runs one `pt` camera path per pixel (the unguided technique U) and, once the
//! cache holds guide paths, `(1 − α) / α` guided paths per pixel (spec §4). Every complete path
//! X either side forms adds `f(X) / (n_u p_u(X) + n_g p_g(X))` to the pixel of x_1 (the balance
//! heuristic over pt's two techniques and the guided one, DESIGN.md §3); guided samples are
//! splatted there. Learning (a share of the budget): iteration 0 is pure pt and seeds the
//! cache with outliers (`learn.rs`), later iterations mix, record outliers and rebuild the
//! cache (`cache.rs`); then the image is cleared, the cache frozen and the render runs.
//!
//! | option          | type          | default | meaning |
//! |-----------------|---------------|---------|---------|
//! | max_depth       | integer >= 1  | 8       | maximum number of segments (`--max-depth`) |
//! | rr_depth        | integer >= 1  | 5       | pt's Russian roulette start |
//! | alpha           | (0, 1]        | 0.5     | unguided share once the cache is non-empty (`--alpha`) |
//! | learn_fraction  | [0, 1)        | 0.1     | share of the budget spent learning (`--learn-fraction`) |
//! | max_guides      | integer >= 1  | 100000  | cache capacity; the lightest guide paths go first (`--max-guides`) |
//! | intake          | integer >= 1  | 100     | outliers kept per worker (band of rows) and iteration |
//! | kernel_width    | number > 0    | 3       | factor on the conditional Gaussians' standard deviations (1: the spec's; `cache.rs`) |
//! | first_width     | number > 0    | 2       | factor on the first-vertex kernel's width (1: the spec's) |
//! | save_guides     | path          | —       | write the learned cache (`--save-guides`) |
//! | load_guides     | path          | —       | start from a saved cache and skip learning (`--load-guides`) |
//!
//! ```text
//! lodestar render scenes/pool.toml --integrator guided-pt --time 60 -O alpha=0.5
//! ```
//!
//! **Where it stops helping (measured on `pool`, 30 s).** The direct caustic (camera, water,
//! floor, water, sun: five vertices) is guided well. About 70 % of the second moment left in
//! the image comes from pt paths of six to nine vertices (the caustic seen after one or more
//! further diffuse bounces) whose p_g is 0. For a third of that second moment, no guide path
//! of the path's structure covers x_1. For half, the candidates that do cover x_1 lose the path
//! at x_3, the vertex after the first diffuse one, where each guide follows its own
//! neighbours' narrow Gaussian. Wider kernels and a wide mixture component left the variance
//! where it was. A BSDF branch at diffuse vertices made most of those paths' p_g non-zero,
//! but not comparable to p_u, and the variance moved within its noise. More guide paths of the
//! full structure (7.7k instead of 2.7k) raised it. Such paths need the specular suffix guided
//! on its own (closing note of issue 6).

// `!(x > 0.0)` deliberately rejects NaN with the invalid values; the small dense linear
// algebra reads best with explicit indices.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod cache;
pub mod contribution;
pub mod gaussian;
pub mod io;
pub mod kernel;
pub mod learn;
pub mod sampler;

use super::IntegratorParams;
use super::bdpt::{self, Vertex};
use super::pt::{PathRecorder, PathTracer, PtSettings};
use crate::dbor::Cascade;
use crate::error::{Error, Result};
use crate::film::Film;
use crate::math::{IndependentSampler, Sampler, Spectrum, luminance};
use crate::path::{MAX_VERTICES, Path};
use crate::render::{
    Budget, Integrator, RenderContext, RenderResult, cascade_rows, run_passes_with_snapshots,
};
use crate::scene::Scene;
use cache::{GuideCache, KernelWidths, RebuildParams, Record};
use glam::{DVec3, UVec2, Vec2};
use learn::{OutlierCascade, TRUST_THRESHOLD};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Workers (bands of rows) that each keep `intake` outliers per learning iteration.
pub const WORKERS: usize = 4;
/// Render passes draw from streams (seed, RENDER_STREAMS + pass, ...), learning passes from
/// (seed, iteration, ...): a render with a loaded cache repeats the render phase of the run
/// that saved it.
const RENDER_STREAMS: u64 = 1 << 40;
/// Candidates a row keeps for the outlier test (the largest C).
const ROW_CANDIDATES: usize = 48;

#[derive(Debug, Clone, PartialEq)]
pub struct GuidedSettings {
    pub pt: PtSettings,
    pub alpha: f64,
    pub learn_fraction: f64,
    pub max_guides: usize,
    pub intake: usize,
    pub damping: f64,
    pub widths: KernelWidths,
    pub save_guides: Option<PathBuf>,
    pub load_guides: Option<PathBuf>,
}

impl Default for GuidedSettings {
    fn default() -> Self {
        GuidedSettings {
            pt: PtSettings::default(),
            alpha: 0.5,
            learn_fraction: 0.1,
            max_guides: 100_000,
            intake: 100,
            damping: 0.5,
            widths: KernelWidths::default(),
            save_guides: None,
            load_guides: None,
        }
    }
}

pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let o = &params.options;
    let rr_depth = o.get("rr_depth", 5u32, "an integer >= 1")?;
    let alpha = o.get("alpha", 0.5f64, "a number in (0, 1]")?;
    let learn_fraction = o.get("learn_fraction", 0.1f64, "a number in [0, 1)")?;
    let max_guides = o.get("max_guides", 100_000usize, "an integer >= 1")?;
    let intake = o.get("intake", 100usize, "an integer >= 1")?;
    let default_widths = KernelWidths::default();
    let kernel_width = o.get("kernel_width", default_widths.regression, "a number > 0")?;
    let first_width = o.get("first_width", default_widths.first_vertex, "a number > 0")?;
    let save = o.get("save_guides", String::new(), "a file path")?;
    let load = o.get("load_guides", String::new(), "a file path")?;
    let bad = |key: &str, expected: &str, got: String| {
        Err(Error::new(format!(
            "option '{key}': expected {expected}, got {got}"
        )))
    };
    if rr_depth == 0 {
        return bad("rr_depth", "an integer >= 1", "0".into());
    }
    if !(alpha > 0.0 && alpha <= 1.0) {
        return bad("alpha", "a number in (0, 1]", alpha.to_string());
    }
    if !(0.0..1.0).contains(&learn_fraction) {
        return bad(
            "learn_fraction",
            "a number in [0, 1)",
            learn_fraction.to_string(),
        );
    }
    if max_guides == 0 {
        return bad("max_guides", "an integer >= 1", "0".into());
    }
    if intake == 0 {
        return bad("intake", "an integer >= 1", "0".into());
    }
    for (key, v) in [("kernel_width", kernel_width), ("first_width", first_width)] {
        if !(v > 0.0 && v.is_finite()) {
            return bad(key, "a number > 0", v.to_string());
        }
    }
    for key in ["kernel_width", "first_width"] {
        if !load.is_empty() && o.has(key) {
            return Err(Error::new(format!(
                "option '{key}' has no effect with load_guides: a loaded cache keeps the \
                 kernel widths it was learned with"
            )));
        }
    }
    let path = |s: String| (!s.is_empty()).then(|| PathBuf::from(s));
    Ok(Box::new(GuidedPt {
        settings: GuidedSettings {
            pt: PtSettings {
                max_depth: params.max_depth,
                rr_depth,
                ..PtSettings::default()
            },
            alpha,
            learn_fraction,
            max_guides,
            intake,
            widths: KernelWidths {
                regression: kernel_width,
                first_vertex: first_width,
            },
            save_guides: path(save),
            load_guides: path(load),
            ..GuidedSettings::default()
        },
        cache: None,
    }))
}

pub struct GuidedPt {
    pub settings: GuidedSettings,
    /// A cache to render with instead of learning one (tests; `load_guides` sets it too).
    pub cache: Option<GuideCache>,
}

/// Counters of one or more passes.
#[derive(Debug, Clone, Copy, Default)]
pub struct Stats {
    pub guided: u64,
    pub failed: u64,
    /// Failures by reason: off the image, missed / wrong vertex, structure (mode), scatter,
    /// occluded medium target, zero contribution.
    pub reasons: [u64; 6],
    pub pg_evaluations: u64,
    pub pg_candidates: u64,
}

impl Stats {
    fn add(&mut self, o: &Stats) {
        self.guided += o.guided;
        self.failed += o.failed;
        self.pg_evaluations += o.pg_evaluations;
        self.pg_candidates += o.pg_candidates;
        for (a, b) in self.reasons.iter_mut().zip(o.reasons) {
            *a += b;
        }
    }
}

/// One outlier candidate of a learning pass.
struct Candidate {
    record: Record,
    pixel: u32,
    value: f64,
    /// A guided sample of a guide path with fewer than `NEIGHBOURS` neighbours: recorded
    /// whatever its trust, to densify sparse regions of the cache (spec §6.3a).
    densify: bool,
}

/// What one row of a pass produces besides its pixels.
#[derive(Default)]
struct RowOutput {
    splats: Vec<(u32, Spectrum)>,
    /// (pixel, luminance of the contribution) of every sample, while learning.
    samples: Vec<(u32, f32)>,
    candidates: Vec<Candidate>,
    stats: Stats,
    /// BVH candidates of p_g evaluations (reused).
    scratch: Vec<u32>,
    /// Smallest value among the kept candidates once the list has been cut (a smaller one
    /// cannot enter it).
    candidate_floor: f64,
}

/// The estimator of one pass: cache, split and densities.
pub struct Estimator<'a> {
    pub scene: &'a Scene,
    pub pt: PathTracer,
    pub cache: &'a GuideCache,
    /// Unguided share α of this pass (1 with an empty cache).
    pub alpha: f64,
    /// Camera paths per pass (one per pixel) and guided paths per pass.
    pub n_u: f64,
    pub n_g: f64,
}

impl<'a> Estimator<'a> {
    pub fn new(scene: &'a Scene, pt: PtSettings, cache: &'a GuideCache, alpha: f64) -> Self {
        let alpha = if cache.is_empty() { 1.0 } else { alpha };
        let n_u = scene.camera.pixel_count() as f64;
        Estimator {
            scene,
            pt: PathTracer { settings: pt },
            cache,
            alpha,
            n_u,
            n_g: (n_u * (1.0 - alpha) / alpha).round(),
        }
    }

    /// pt's `pdf_unguided` of BDPT vertices `y`.
    pub fn p_u(&self, y: &[Vertex]) -> f64 {
        let s = &self.pt.settings;
        let k = y.len() - 1;
        if k > s.max_depth as usize {
            return 0.0;
        }
        let mut p = [0.0f64; MAX_VERTICES];
        bdpt::path_terms(self.scene, y, s.rr_depth).technique_densities(&mut p);
        p[0] + if k >= 2 { p[1] } else { 0.0 }
    }

    /// p_g of `path` (0 without evaluation when the cache holds no path of its structure).
    /// `scratch` holds the BVH candidates (reused across calls, no allocation per path).
    pub fn p_g(
        &self,
        path: &Path,
        y: Option<&[Vertex]>,
        stats: &mut Stats,
        scratch: &mut Vec<u32>,
    ) -> f64 {
        if self.cache.is_empty() {
            return 0.0;
        }
        // The hash alone (no allocation) rejects every path whose structure the cache lacks.
        match kernel::signature(self.scene, path, MAX_VERTICES) {
            Some(sig) if self.cache.holds(sig) => {}
            _ => return 0.0,
        }
        let Some((sig, nodes)) = kernel::structure(self.scene, path, MAX_VERTICES) else {
            return 0.0;
        };
        let owned;
        let y = match y {
            Some(y) => y,
            None => match bdpt::from_path(self.scene, path) {
                Some(v) => {
                    owned = v;
                    &owned
                }
                None => return 0.0,
            },
        };
        let (p, n) = self.cache.pdf(self.scene, y, sig, &nodes, scratch);
        stats.pg_evaluations += 1;
        stats.pg_candidates += n as u64;
        p
    }

    /// The denominator of a contribution, `(n_u p_u + n_g p_g) / N_pix`: densities are
    /// image-wide and a pixel's measurement carries the factor N_pix (one camera path per pixel
    /// and pass gives the usual `f / p_u`).
    pub fn mix(&self, p_u: f64, p_g: f64) -> f64 {
        p_u + (self.n_g / self.n_u) * p_g
    }

    /// One guided sample from stream `sampler`: (pixel, value) of a success.
    pub fn guided(
        &self,
        sampler: &mut impl Sampler,
        want_record: bool,
        stats: &mut Stats,
        scratch: &mut Vec<u32>,
    ) -> Option<(u32, Spectrum, Option<Record>, usize)> {
        stats.guided += 1;
        let g = match sampler::sample_path(self.scene, self.cache, sampler) {
            Ok(g) => g,
            Err(e) => {
                stats.failed += 1;
                stats.reasons[e as usize] += 1;
                return None;
            }
        };
        let y = bdpt::from_path(self.scene, &g.path)?;
        let k = y.len() - 1;
        let last_delta = matches!(
            y[k].kind,
            bdpt::Kind::Light { light } if self.scene.lights[light].is_delta()
        );
        let visible = if last_delta {
            (1u64 << (k - 1)) - 1
        } else {
            u64::MAX
        };
        let f = contribution::contribution(self.scene, &y, visible);
        if f == Spectrum::ZERO {
            stats.failed += 1;
            stats.reasons[5] += 1;
            return None;
        }
        let p_u = self.p_u(&y);
        let p_g = self.p_g(&g.path, Some(&y), stats, scratch);
        let mix = self.mix(p_u, p_g);
        if !(mix > 0.0) {
            stats.failed += 1;
            return None;
        }
        let value = f / mix as f32;
        let record = want_record.then(|| Record {
            vertices: g.path.vertices().to_vec(),
            f: luminance(f),
            p_u,
            c: luminance(f) as f64 / (self.alpha * p_u + (1.0 - self.alpha) * p_g),
        });
        Some((g.path.pixel, value, record, g.guide))
    }
}

/// Collects pt's paths and weighs them for the mixture.
struct Collector<'e, 'a> {
    est: &'e Estimator<'a>,
    sum: DVec3,
    learning: bool,
    out: &'e mut RowOutput,
}

impl PathRecorder for Collector<'_, '_> {
    fn record(&mut self, path: &Path, _technique: usize, density: f64, other: f64) {
        let p_u = density + other;
        if path.f == Spectrum::ZERO || !(p_u > 0.0) {
            return;
        }
        let p_g = self
            .est
            .p_g(path, None, &mut self.out.stats, &mut self.out.scratch);
        let mix = self.est.mix(p_u, p_g);
        let value = path.f.as_dvec3() / mix;
        if !value.is_finite() {
            return;
        }
        self.sum += value;
        if self.learning && path.segments() >= 2 {
            let lum = luminance(value.as_vec3());
            self.out.samples.push((path.pixel, lum));
            let alpha = self.est.alpha;
            offer_candidate(self.out, lum as f64, || Candidate {
                record: Record {
                    vertices: path.vertices().to_vec(),
                    f: luminance(path.f),
                    p_u,
                    c: luminance(path.f) as f64 / (alpha * p_u + (1.0 - alpha) * p_g),
                },
                pixel: path.pixel,
                value: lum as f64,
                densify: false,
            });
        }
    }
}

/// Keep a candidate among the row's `ROW_CANDIDATES` largest values; `make` (which copies
/// the path) only runs for a value that can still make it.
fn offer_candidate(out: &mut RowOutput, value: f64, make: impl FnOnce() -> Candidate) {
    if value <= out.candidate_floor {
        return;
    }
    let list = &mut out.candidates;
    list.push(make());
    if list.len() >= 2 * ROW_CANDIDATES {
        list.sort_by(|a, b| b.value.total_cmp(&a.value));
        list.truncate(ROW_CANDIDATES);
        out.candidate_floor = list[ROW_CANDIDATES - 1].value;
    }
}

impl GuidedPt {
    /// One pass: pt per pixel plus the guided samples; returns per-row outputs in row order.
    fn pass(
        &self,
        ctx: &RenderContext,
        est: &Estimator,
        film: &mut Film,
        cascade: &mut Option<Cascade>,
        pass: u64,
        learning: bool,
    ) -> Vec<RowOutput> {
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
                let mut out = RowOutput {
                    candidate_floor: f64::NEG_INFINITY,
                    ..RowOutput::default()
                };
                for (x, acc) in row.iter_mut().enumerate() {
                    let index = y as u64 * w as u64 + x as u64;
                    let mut sampler = IndependentSampler::new(ctx.seed, pass, index);
                    let raster = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                    let mut col = Collector {
                        est,
                        sum: DVec3::ZERO,
                        learning,
                        out: &mut out,
                    };
                    est.pt
                        .li_recorded(scene, raster, &mut sampler, Some(&mut col));
                    let sum = col.sum;
                    *acc += sum;
                    if let Some(cell) = crow.get_mut(x) {
                        Cascade::splat_into(cell, sum.as_vec3());
                    }
                    // Guided samples j = index, index + N, ... below n_g.
                    let mut j = index;
                    while j < n_g {
                        let mut gs = IndependentSampler::new(ctx.seed, pass, n_pix + j);
                        if let Some((pixel, value, record, guide)) =
                            est.guided(&mut gs, learning, &mut out.stats, &mut out.scratch)
                        {
                            out.splats.push((pixel, value));
                            if learning {
                                let lum = luminance(value);
                                out.samples.push((pixel, lum));
                                let densify = (est.cache.guides[guide].neighbours as usize)
                                    < cache::NEIGHBOURS;
                                if let Some(record) = record {
                                    offer_candidate(&mut out, lum as f64, || Candidate {
                                        record,
                                        pixel,
                                        value: lum as f64,
                                        densify,
                                    });
                                }
                            }
                        }
                        j += n_pix;
                    }
                }
                out.candidates.sort_by(|a, b| b.value.total_cmp(&a.value));
                out.candidates.truncate(ROW_CANDIDATES);
                out
            })
            .collect::<Vec<RowOutput>>();
        drop(crows);
        for r in &rows {
            film.add_splats(&r.splats);
            if let Some(c) = cascade {
                for &(p, v) in &r.splats {
                    c.add(p, v);
                }
            }
        }
        rows
    }

    /// Outliers of a learning pass: trust against the cascade, the `intake` largest C per
    /// worker (band of rows).
    fn outliers(
        &self,
        scene: &Scene,
        rows: &mut [RowOutput],
        cascade: &mut OutlierCascade,
        alpha: f64,
        iteration: u32,
    ) -> Vec<Record> {
        let n_pix = scene.camera.pixel_count() as f64;
        let total: f64 = rows
            .iter()
            .flat_map(|r| r.samples.iter())
            .map(|s| s.1 as f64)
            .sum();
        let mean = total / n_pix;
        if !(mean > 0.0) {
            return Vec::new();
        }
        let norm = |v: f64| v / (alpha * mean);
        for r in rows.iter() {
            for &(pixel, lum) in &r.samples {
                cascade.add(pixel, norm(lum as f64));
            }
        }
        let h = rows.len();
        let mut records = Vec::new();
        for w in 0..WORKERS {
            let (a, b) = (w * h / WORKERS, (w + 1) * h / WORKERS);
            let mut pool: Vec<Candidate> = Vec::new();
            for r in &mut rows[a..b] {
                pool.extend(r.candidates.drain(..).filter(|c| {
                    c.densify
                        || cascade.trust(c.pixel, norm(c.value), iteration + 1) <= TRUST_THRESHOLD
                }));
            }
            pool.sort_by(|x, y| y.record.c.total_cmp(&x.record.c));
            pool.truncate(self.settings.intake);
            records.extend(pool.into_iter().map(|c| c.record));
        }
        records
    }
}

fn stat(k: &str, v: impl ToString) -> (String, String) {
    (k.to_string(), v.to_string())
}

impl Integrator for GuidedPt {
    fn name(&self) -> &'static str {
        "guided-pt"
    }

    fn settings(&self) -> String {
        format!("{:?}", self.settings)
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
            .unwrap_or_else(|| GuideCache::with_widths(self.settings.widths));
        let mut stats = Stats::default();
        let mut learn_passes = 0u64;
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
                let mut cascade = OutlierCascade::new(w, h);
                let mut k = 0u64;
                loop {
                    let est = Estimator::new(scene, st.pt.clone(), &cache, st.alpha);
                    // The learning film averages the learning passes (each an unbiased
                    // estimate); it is what snapshots during learning show.
                    let mut rows = self.pass(ctx, &est, &mut film, &mut None, k, true);
                    for r in &rows {
                        stats.add(&r.stats);
                    }
                    let alpha = est.alpha;
                    let records = self.outliers(scene, &mut rows, &mut cascade, alpha, k as u32);
                    drop(rows);
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
        // ---- Rendering with the frozen cache ----
        film.clear();
        let render_stats = std::cell::RefCell::new(Stats::default());
        let render_budget = match budget {
            Budget::Spp(n) => Budget::Spp(n.saturating_sub(learn_passes).max(1)),
            Budget::Seconds(s) => Budget::Seconds((s - learn_seconds).max(0.0)),
        };
        let est = Estimator::new(scene, st.pt.clone(), &cache, st.alpha);
        let mut cascade = ctx.dbor.then(|| Cascade::new(w, h));
        let (passes, render_seconds) = run_passes_with_snapshots(
            ctx,
            render_budget,
            &mut film,
            |film, p| {
                let rows = self.pass(ctx, &est, film, &mut cascade, RENDER_STREAMS + p, false);
                for r in &rows {
                    render_stats.borrow_mut().add(&r.stats);
                }
            },
            |film, passes| film.to_image(passes as f64, 1.0 / passes.max(1) as f64),
        );
        let rs = render_stats.into_inner();
        let image = film.to_image(passes as f64, 1.0 / passes.max(1) as f64);
        let out_stats = vec![
            stat("guide_paths", cache.len()),
            stat(
                "bytes_per_guide_path",
                format!("{:.0}", cache.bytes_per_path()),
            ),
            stat("learning_iterations", learn_passes),
            stat("learning_seconds", format!("{learn_seconds:.3}")),
            stat("render_seconds", format!("{render_seconds:.3}")),
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
            stat("learning_guided_samples", stats.guided),
            stat(
                "failures_offimage_miss_structure_scatter_occluded_zero",
                format!("{:?}", rs.reasons),
            ),
        ];
        self.cache = Some(cache);
        RenderResult {
            dbor: cascade.map(|c| c.reweighted(passes.max(1) as f64)),
            image,
            spp: passes,
            passes,
            seconds: start.elapsed().as_secs_f64(),
            stats: out_stats,
        }
    }
}
