//! The sink that weighs U's paths for the mixture: each path U reports gets its `p_u` and
//! `p_g` (`Estimator::densities`), its value `f / (p_u + r p_g)` goes to its pixel, and the
//! pass's bookkeeping (the share's measurements, U's own image while learning, coverage
//! classes, outlier candidates) is kept beside it.

use super::cache::Record;
use super::estimator::{Coverage, Estimator, PG_ZERO_VERTICES, RowOutput};
use super::seeder::{Candidate, Source};
use super::{coverage, share};
use crate::integrators::bdpt::Vertex;
use crate::integrators::unguided::{PathSink, Unguided};
use crate::math::{luminance, luminance64};
use crate::path::Path;
use glam::DVec3;

/// Weighs U's paths for the mixture (a [`PathSink`]).
pub struct Collector<'e, 'a, U: Unguided> {
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
    pub classes: bool,
    pub own_image: bool,
    pub learning: bool,
    pub measuring: bool,
    /// What made the sample being traced (the Markov-chain seeder starts chains at
    /// candidates whose unguided stream replays them).
    pub source: Source,
    pub out: &'e mut RowOutput,
}

impl<U: Unguided> PathSink for Collector<'_, '_, U> {
    fn record(&mut self, path: &Path, y: Option<&[Vertex]>, f: DVec3, p_u: f64, splat: bool) {
        if f == DVec3::ZERO || !(p_u > 0.0) {
            return;
        }
        let out = &mut *self.out;
        let d = self
            .est
            .densities(path, y, p_u, &mut out.stats, &mut out.candidates);
        let (p_u, p_g, coverage) = (d.p_u, d.p_g, d.coverage);
        let value = f / self.est.mix(p_u, p_g);
        if !(value.is_finite() && value.min_element() >= 0.0) {
            out.stats.invalid += 1;
            return;
        }
        let lum = luminance64(value);
        if coverage == Coverage::Covered && out.candidates.collect_terms {
            let terms = std::mem::take(&mut out.candidates.terms);
            self.est
                .credit(value, p_u, p_g, &terms, &mut out.responsibility);
            out.candidates.terms = terms;
        }
        out.stats.coverage_paths[coverage as usize] += 1;
        out.stats.coverage_m2[coverage as usize] += lum * lum;
        if coverage == Coverage::Zero {
            let bucket = d.vanished_at.clamp(1, PG_ZERO_VERTICES) - 1;
            out.stats.pg_zero_m2_by_vertex[bucket] += lum * lum;
        }
        if coverage != Coverage::Covered {
            out.uncovered += lum;
        }

        if splat {
            out.splats.push((path.pixel, value));
            if self.classes {
                out.class_splats.push((path.pixel, coverage as u8, lum));
            }
        } else {
            self.sum += value;
            if self.classes {
                self.class_sum[coverage as usize] += lum;
            }
        }
        if self.measuring {
            let v = share::values(luminance64(f), p_u, p_g);
            if splat {
                out.grid_splats.push((path.pixel, v));
            } else {
                for (a, b) in self.grid.iter_mut().zip(v) {
                    *a += b;
                }
            }
        }
        if self.own_image {
            // U's own estimator from the same paths: an unbiased image without the guided
            // samples, kept when the share turns guiding off (`driver.rs`).
            let own = f / p_u;
            if own.is_finite() {
                if splat {
                    out.u_splats.push((path.pixel, own));
                } else {
                    self.u_sum += own;
                }
            }
        }
        if self.learning && path.segments() >= 2 {
            let lum = luminance(value.as_vec3()) as f64;
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
}
