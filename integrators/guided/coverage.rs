//! Where the render's variance sits: the image's per-pass variance split by the coverage
//! class of the paths that make it up (`variance_by_coverage`).
//!
//! A path's squared contribution (`unguided_second_moment_by_coverage`) counts its mean too:
//! direct light, sampled well by every technique, has a large second moment and almost no
//! variance. This account measures variance. Every render pass is an independent estimate of
//! the image, so for each pixel and each class c (U's paths whose structure the cache does
//! not hold, those with p_g = 0, those the guided technique covers, and the guided samples
//! themselves) the pass's luminance from that class, X_c, is one draw; over the passes,
//! Var(X_c) = E\[X_c²\] − E\[X_c\]², summed over the pixels, is what the class adds to the
//! image's error (up to the covariances between classes; `class_variance_over_total`, Σ_c
//! Var(X_c) / Var(Σ_c X_c), says how far they matter: 1 when the classes are independent).

/// One row of a pass as the accumulator reads it: per pixel of the row the luminance of each
/// class, and (pixel, class, luminance) of the row's splatted paths and guided samples
/// (`RowOutput::class_pixels`, `RowOutput::class_splats`).
pub type ClassRow<'r> = (&'r [[f64; CLASSES]], &'r [(u32, u8, f64)]);

/// The classes: U's paths by [`super::estimator::Coverage`], then the guided samples.
pub const CLASSES: usize = 4;
/// Index of the guided samples among the classes.
pub const GUIDED: usize = 3;
/// Names of the classes in the render's statistics.
pub const CLASS_NAMES: [&str; CLASSES] = ["structure_not_held", "pg_zero", "covered", "guided"];

/// Per pixel, Σ and Σ² over passes of each class's luminance and of their total.
#[derive(Default)]
pub struct CoverageVariance {
    s1: Vec<[f64; CLASSES + 1]>,
    s2: Vec<[f64; CLASSES + 1]>,
    pass: Vec<[f64; CLASSES]>,
    passes: u64,
}

impl CoverageVariance {
    /// Add one pass from its rows (row y covers pixels y w .. y w + w − 1); rows without
    /// class values (a pass that evaluated no densities) are skipped.
    pub fn add_pass(&mut self, rows: &[ClassRow], w: usize) {
        if rows.iter().all(|(pixels, _)| pixels.is_empty()) {
            return;
        }
        let n_pix = rows.len() * w;
        if self.s1.len() != n_pix {
            *self = CoverageVariance {
                s1: vec![[0.0; CLASSES + 1]; n_pix],
                s2: vec![[0.0; CLASSES + 1]; n_pix],
                pass: vec![[0.0; CLASSES]; n_pix],
                passes: 0,
            };
        }
        for (y, (pixels, _)) in rows.iter().enumerate() {
            for (x, v) in pixels.iter().enumerate() {
                self.pass[y * w + x] = *v;
            }
        }
        for (_, splats) in rows {
            for &(p, c, lum) in splats.iter() {
                self.pass[p as usize][c as usize] += lum;
            }
        }
        for ((s1, s2), x) in self.s1.iter_mut().zip(&mut self.s2).zip(&mut self.pass) {
            let total: f64 = x.iter().sum();
            for (c, v) in x.iter().chain([&total]).enumerate() {
                s1[c] += v;
                s2[c] += v * v;
            }
            *x = [0.0; CLASSES];
        }
        self.passes += 1;
    }

    /// Σ over pixels of each class's per-pass variance, and of the total's (index
    /// [`CLASSES`]); `None` before two passes.
    pub fn variances(&self) -> Option<[f64; CLASSES + 1]> {
        if self.passes < 2 {
            return None;
        }
        let n = self.passes as f64;
        let mut var = [0.0; CLASSES + 1];
        for (s1, s2) in self.s1.iter().zip(&self.s2) {
            for c in 0..=CLASSES {
                // The unbiased sample variance of the pixel's per-pass values.
                var[c] += ((s2[c] - s1[c] * s1[c] / n) / (n - 1.0)).max(0.0);
            }
        }
        Some(var)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two pixels, three passes, splats across rows: the variances of hand-computed per-pass
    /// values (a misplaced splat, a class index off by one or a biased variance fails it).
    #[test]
    fn variances_of_known_passes() {
        let mut acc = CoverageVariance::default();
        // Image 1 x 2 (two rows of one pixel). Pass values per pixel and class:
        //   pixel 0: class 0 = 1, 2, 6; class 3 = 0, 0, 3 (a splat from row 1)
        //   pixel 1: class 2 = 4, 4, 4 (constant: no variance); class 1 = 0, 2, 0 (splat)
        let passes = [
            (
                vec![[1.0, 0.0, 0.0, 0.0]],
                vec![[0.0, 0.0, 4.0, 0.0]],
                vec![],
            ),
            (
                vec![[2.0, 0.0, 0.0, 0.0]],
                vec![[0.0, 0.0, 4.0, 0.0]],
                vec![(1u32, 1u8, 2.0)],
            ),
            (
                vec![[6.0, 0.0, 0.0, 0.0]],
                vec![[0.0, 0.0, 4.0, 0.0]],
                vec![(0, 3, 3.0)],
            ),
        ];
        for (p0, p1, splats) in passes {
            acc.add_pass(&[(&p0, &[]), (&p1, &splats)], 1);
        }
        let var = |xs: [f64; 3]| {
            let m = xs.iter().sum::<f64>() / 3.0;
            xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / 2.0
        };
        let v = acc.variances().unwrap();
        let expect = [
            var([1.0, 2.0, 6.0]),
            var([0.0, 2.0, 0.0]),
            0.0,
            var([0.0, 0.0, 3.0]),
            var([1.0, 2.0, 9.0]) + var([4.0, 6.0, 4.0]),
        ];
        for (a, b) in v.iter().zip(expect) {
            assert!((a - b).abs() < 1e-12, "{v:?} against {expect:?}");
        }
    }

    #[test]
    fn needs_two_passes() {
        let mut acc = CoverageVariance::default();
        assert!(acc.variances().is_none());
        acc.add_pass(&[(&[[1.0; CLASSES]], &[])], 1);
        assert!(acc.variances().is_none());
    }
}
