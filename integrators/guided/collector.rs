//! The sink that weighs U's paths for the mixture: each path U reports gets its `p_u` and
//! `p_g` (`Estimator::densities`), its value `f / (p_u + r p_g)` goes to its pixel, and the
//! pass's bookkeeping (the share's measurements, U's own image while learning, coverage
//! classes, outlier candidates) is kept beside it.

use super::cache::Record;
use super::candidates::{Candidate, Source};
use super::estimator::{Coverage, Estimator, PG_ZERO_VERTICES, RowOutput};
use super::{coverage, kernel, share};
use crate::integrators::paths::{Kind, Vertex};
use crate::integrators::unguided::{PathSink, Unguided};
use crate::math::{luminance, luminance64};
use crate::path::{MAX_VERTICES, Path, VertexKind};
use glam::DVec3;

/// Weighs U's paths for the mixture (a [`PathSink`]).
pub struct Collector<'e, 'a, U: Unguided> {
    /// The pass's estimator: cache, split and densities.
    pub est: &'e Estimator<'a, U>,
    /// This pixel's value (paths that land in it).
    pub sum: DVec3,
    /// What U's sample adds to this pixel under each ratio, while measuring the share.
    pub grid: [f64; share::N],
    /// U's own estimate of this pixel (paths weighted `f / p_u`), accumulated (with U's
    /// splats in `out.u_splats`) when `own_image` is set: in the learning passes.
    pub u_sum: DVec3,
    /// This pixel's luminance by coverage class (`coverage.rs`), and the splats' in
    /// `out.class_splats`, kept when `classes` is set: in the render passes.
    pub class_sum: [f64; coverage::CLASSES],
    /// Keep the luminance by coverage class (render passes).
    pub classes: bool,
    /// Keep U's own estimate (learning passes).
    pub own_image: bool,
    /// A learning pass: every path's densities are recorded and outlier candidates kept.
    pub learning: bool,
    /// The share is being measured: keep each path's value under every ratio.
    pub measuring: bool,
    /// What made the sample being traced (the Markov-chain seeder starts chains at
    /// candidates whose unguided stream replays them).
    pub source: Source,
    /// The row's output: splats, learning data, counters.
    pub out: &'e mut RowOutput,
}

impl<'e, 'a, U: Unguided> Collector<'e, 'a, U> {
    /// A collector for one sample of a pass: while `learning`, U's own image and the outlier
    /// candidates are kept (coverage classes otherwise); while `measuring`, the share's grid.
    pub fn new(
        est: &'e Estimator<'a, U>,
        out: &'e mut RowOutput,
        source: Source,
        learning: bool,
        measuring: bool,
    ) -> Self {
        Collector {
            est,
            sum: DVec3::ZERO,
            grid: [0.0; share::N],
            u_sum: DVec3::ZERO,
            class_sum: Default::default(),
            classes: !learning,
            own_image: learning,
            learning,
            measuring,
            source,
            out,
        }
    }
}

impl<U: Unguided> PathSink for Collector<'_, '_, U> {
    fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, splat: bool) {
        self.weigh(path, y, f, p_u, true, splat);
    }

    fn record_from_vertices(&mut self, path: &Path, y: &[Vertex], f: DVec3, p_u: f64, splat: bool) {
        self.weigh(path, Some(y), f, p_u, false, splat);
    }

    /// Outside learning only the paths the guided technique could also make need their
    /// densities (to add `r p_g` to the denominator): those whose structure the cache holds.
    /// Every other path's value is U's own `f / p_u`, which U's own weights give. While
    /// learning every path may become a guide path, which records its densities.
    fn needs_densities(&mut self, head: &[Vertex], tail: &[Vertex]) -> bool {
        if self.learning {
            return true;
        }
        if self.est.n_g == 0.0 {
            return false;
        }
        // A held structure ends on an emitter, with as many vertices as some guide path.
        let last = tail.first().or(head.last());
        let Some(&Vertex {
            kind: Kind::Light { light },
            ..
        }) = last
        else {
            return false;
        };
        if !self
            .est
            .cache
            .may_hold(head.len() + tail.len(), light as u32)
        {
            return false;
        }
        let path_vertex = crate::integrators::paths::path_vertex;
        kernel::signature_of_split(self.est.scene, head, tail, MAX_VERTICES, path_vertex)
            .is_some_and(|sig| self.est.cache.holds(sig))
    }

    /// A held path whose x_1 lies outside every first-vertex kernel of its structure has
    /// p_g = 0 (the candidates' query, kept for the path's densities should it find any): its
    /// value is U's own, and U's explicit densities are not needed. In a learning pass every
    /// path with p_g = 0 (all of them before the first cache) is booked so, unless it is
    /// bright enough to join its row's outlier candidates, whose records need `p_u`.
    fn record_if_own_weight(&mut self, path: &Path, value: DVec3, splat: bool) -> bool {
        let est = self.est;
        if !self.learning && est.n_g == 0.0 {
            return false;
        }
        let coverage = if est.n_g == 0.0 {
            Coverage::NotHeld
        } else {
            let Some(x1) = path.vertices().get(1) else {
                return false;
            };
            match kernel::signature(est.scene, path, MAX_VERTICES) {
                Some(sig) if est.cache.holds(sig) => {
                    let out = &mut *self.out;
                    let medium = matches!(x1.kind, VertexKind::Medium { .. });
                    let first = (x1.p, x1.n, medium);
                    if !(out.candidates)
                        .at(est.cache, est.scene, sig, first, &mut out.stats)
                        .is_empty()
                    {
                        return false;
                    }
                    Coverage::Zero
                }
                // Outside learning U's own weights took these paths (`needs_densities`).
                Some(_) | None if self.learning => Coverage::NotHeld,
                _ => return false,
            }
        };
        let learn = self.learning && path.segments() >= 2;
        let lum32 = luminance(value.as_vec3()) as f64;
        if learn && self.out.learn.would_keep(lum32) {
            return false;
        }
        self.book_own(path.pixel, splat, value, coverage, learn);
        true
    }

    /// Before the first cache every path of a learning pass has p_g = 0, and one too dim to
    /// join its row's candidates needs no vertices.
    fn own_weight_floor(&mut self) -> f64 {
        if self.learning && self.est.n_g == 0.0 {
            self.out.learn.floor()
        } else {
            f64::NEG_INFINITY
        }
    }

    /// Every such path has more than two vertices (U hands those of two over weighted).
    fn record_dim(&mut self, pixel: u32, value: DVec3, splat: bool) {
        debug_assert!(self.learning && self.est.n_g == 0.0);
        self.book_own(pixel, splat, value, Coverage::NotHeld, true);
    }

    fn record_weighted(&mut self, pixel: u32, value: DVec3, splat: bool) {
        debug_assert!(
            !self.learning,
            "learning records every path with its densities"
        );
        if value == DVec3::ZERO {
            return;
        }
        if !(value.is_finite() && value.min_element() >= 0.0) {
            self.out.stats.invalid += 1;
            return;
        }
        // p_g = 0: the same value under every ratio.
        let ratios = self.measuring.then(|| [luminance64(value); share::N]);
        self.add(pixel, splat, value, Coverage::NotHeld, ratios, value);
    }
}

impl<U: Unguided> Collector<'_, '_, U> {
    /// Book a path of p_g = 0 at U's own weight (`value`) in `coverage`, and (`learn`) as a
    /// learning sample, as [`Self::weigh`] books it from its densities.
    fn book_own(&mut self, pixel: u32, splat: bool, value: DVec3, coverage: Coverage, learn: bool) {
        if value == DVec3::ZERO {
            return;
        }
        if !(value.is_finite() && value.min_element() >= 0.0) {
            self.out.stats.invalid += 1;
            return;
        }
        let lum = luminance64(value);
        if coverage == Coverage::Zero {
            self.out.stats.pg_evaluations += 1;
            self.out.stats.pg_zero_m2_by_vertex[0] += lum * lum;
        }
        // p_g = 0: the same value under every ratio.
        let ratios = self.measuring.then_some([lum; share::N]);
        self.add(pixel, splat, value, coverage, ratios, value);
        if learn {
            let lum32 = luminance(value.as_vec3());
            self.out.learn.samples.push((pixel, lum32));
        }
    }

    /// Weigh a path U reported (`recompute`: whether its `p_u` is to be recomputed from
    /// its vertices, see `Estimator::densities`) and book it.
    fn weigh(
        &mut self,
        path: &Path,
        y: Option<&[Vertex]>,
        f: DVec3,
        p_u: f64,
        recompute: bool,
        splat: bool,
    ) {
        if f == DVec3::ZERO || !(p_u > 0.0) {
            return;
        }
        let out = &mut *self.out;
        let d =
            (self.est).densities_with(path, y, p_u, recompute, &mut out.stats, &mut out.candidates);
        let (p_u, p_g, coverage) = (d.p_u, d.p_g, d.coverage);
        let value = f / self.est.mix(p_u, p_g);
        if !(value.is_finite() && value.min_element() >= 0.0) {
            out.stats.invalid += 1;
            return;
        }
        if coverage == Coverage::Covered && out.candidates.collect_terms {
            let terms = std::mem::take(&mut out.candidates.terms);
            self.est
                .credit(value, p_u, p_g, &terms, &mut out.responsibility);
            out.candidates.terms = terms;
        }
        if coverage == Coverage::Zero {
            let lum = luminance64(value);
            let bucket = d.vanished_at.clamp(1, PG_ZERO_VERTICES) - 1;
            out.stats.pg_zero_m2_by_vertex[bucket] += lum * lum;
        }
        let ratios = self
            .measuring
            .then(|| share::values(luminance64(f), p_u, p_g));
        self.add(path.pixel, splat, value, coverage, ratios, f / p_u);
        if self.learning && path.segments() >= 2 {
            let lum = luminance(value.as_vec3()) as f64;
            let out = &mut *self.out;
            out.learn.samples.push((path.pixel, lum as f32));
            let (est, source) = (self.est, self.source);
            out.learn.offer(lum, || {
                let f_lum = luminance64(f);
                Candidate {
                    record: Record {
                        vertices: path.vertices().to_vec(),
                        f: f_lum,
                        p_u,
                        c: est.c(f_lum, p_u, p_g),
                    },
                    pixel: path.pixel,
                    value: lum,
                    densify: false,
                    source,
                }
            });
        }
    }

    /// Book a valid path's `value` (under the mixture) for `pixel`: the image, its coverage
    /// class, the share's measurements (`ratios`: its luminance under each ratio, while
    /// measuring) and U's own image (`own` = f / p_u, while learning).
    fn add(
        &mut self,
        pixel: u32,
        splat: bool,
        value: DVec3,
        coverage: Coverage,
        ratios: Option<[f64; share::N]>,
        own: DVec3,
    ) {
        let out = &mut *self.out;
        let lum = luminance64(value);
        out.stats.coverage_paths[coverage as usize] += 1;
        out.stats.coverage_m2[coverage as usize] += lum * lum;
        if coverage != Coverage::Covered {
            out.uncovered += lum;
        }
        if splat {
            out.splats.push((pixel, value));
            if self.classes {
                out.class_splats.push((pixel, coverage as u8, lum));
            }
        } else {
            self.sum += value;
            if self.classes {
                self.class_sum[coverage as usize] += lum;
            }
        }
        if let Some(v) = ratios {
            if splat {
                out.grid_splats.push((pixel, v));
            } else {
                for (a, b) in self.grid.iter_mut().zip(v) {
                    *a += b;
                }
            }
        }
        if self.own_image {
            // U's own estimator from the same paths: an unbiased image without the guided
            // samples, kept when the share turns guiding off (`driver.rs`).
            if own.is_finite() {
                if splat {
                    out.u_splats.push((pixel, own));
                } else {
                    self.u_sum += own;
                }
            }
        }
    }
}
