//! Pixel reconstruction filters: `box` (the default), `tent` and `gaussian`, as Mitsuba 3
//! defines them, normalised to unit integral.
//!
//! Pixel (x, y) measures `I = ∫ f(r - c) L(r) dr` over raster positions r, with `c` the
//! pixel's centre (x + 0.5, y + 0.5) and `f` the filter: the box of one pixel is the plain
//! pixel integral. Every filter is separable, `f(d) = f1(d.x) f1(d.y)`.
//!
//! As in Mitsuba, a pixel sees the image only: near the border its filter is cut at the
//! image's edge and renormalised, `I = ∫_image f(r - c) L(r) dr / N_c` with
//! `N_c = ∫_image f(r - c) dr` (1 wherever the filter lies inside the image).
//!
//! * **Camera samples** are drawn from the filter itself (filter importance sampling, as in
//!   pbrt-v4): the ray of a sample in pixel c goes through `c + d` with `d ~ f / N_c` on the
//!   image ([`Filter::sample_1d_within`] per axis), and the sample counts for pixel c with
//!   weight 1.
//! * **Splats** (light tracing, bdpt's and vcm's t = 1, guided samples, mmlt's t = 1) land at
//!   a raster position r that no pixel chose: [`Filter::pick`] sends each to one pixel c, with
//!   probability `f(r - c) / W(r)` and weight `W(r) = Σ_c f(r - c)`, so that every pixel gets
//!   `f(r - c)` times the contribution in expectation, one splat per contribution; the camera
//!   divides by the pixel's `N_c` and drops splats off the image.
//!
//! Profiles (`f1`, before normalisation): box 1 on [-1/2, 1/2]; tent `1 - |x| / R` (Mitsuba's
//! `radius` R, default 1); Gaussian `exp(-x² / 2σ²) - exp(-R² / 2σ²)` on |x| < R = 4σ
//! (Mitsuba's `stddev` σ, default 0.5, so R = 2). The tent and Gaussian are held as a
//! piecewise-linear table (the tent exactly, in two segments; the Gaussian in 256), and both
//! the sampling and the splat weights use the table, so the two sides measure the same
//! filter.

use glam::Vec2;

/// Which filter, with its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FilterKind {
    /// One pixel (radius 1/2).
    Box,
    /// `max(0, 1 - |x| / radius)` per axis.
    Tent {
        /// Radius in pixels (Mitsuba's default 1).
        radius: f32,
    },
    /// `exp(-x² / 2σ²) - exp(-R² / 2σ²)` per axis, R = 4σ.
    Gaussian {
        /// σ in pixels (Mitsuba's default 0.5).
        stddev: f32,
    },
}

/// Segments of the Gaussian's table.
const GAUSSIAN_SEGMENTS: usize = 256;

/// A pixel filter (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Filter {
    kind: FilterKind,
    radius: f64,
    /// The 1-D profile at `values.len()` evenly spaced points on [-radius, radius],
    /// normalised to unit integral (piecewise linear between them); empty for the box.
    values: Box<[f64]>,
    /// Integral of the profile from -radius to each of those points.
    cdf: Box<[f64]>,
    /// The spacing of those points (0 for the box).
    segment: f64,
    /// `1 / segment` (0 for the box): [`Filter::eval_1d`] multiplies by it rather than
    /// divide by `segment`, the same number where the spacing is a power of two (Mitsuba's
    /// default tent and Gaussian: 1 and 1/64 px).
    inv_segment: f64,
}

impl Default for Filter {
    fn default() -> Filter {
        Filter::new(FilterKind::Box)
    }
}

impl Filter {
    /// The filter `kind` (parameters must be positive and finite; the loaders check).
    pub fn new(kind: FilterKind) -> Filter {
        let (radius, profile): (f64, Vec<f64>) = match kind {
            FilterKind::Box => (0.5, Vec::new()),
            FilterKind::Tent { radius } => (radius as f64, vec![0.0, 1.0, 0.0]),
            FilterKind::Gaussian { stddev } => {
                let (s, r) = (stddev as f64, 4.0 * stddev as f64);
                let g = |x: f64| (-x * x / (2.0 * s * s)).exp();
                let n = GAUSSIAN_SEGMENTS;
                let v = (0..=n)
                    .map(|i| {
                        let x = -r + 2.0 * r * i as f64 / n as f64;
                        (g(x) - g(r)).max(0.0)
                    })
                    .collect();
                (r, v)
            }
        };
        let mut values = profile;
        let mut cdf = Vec::new();
        let segment = if values.is_empty() {
            0.0
        } else {
            2.0 * radius / (values.len() - 1) as f64
        };
        if !values.is_empty() {
            cdf.push(0.0);
            for w in values.windows(2) {
                cdf.push(cdf.last().unwrap() + 0.5 * (w[0] + w[1]) * segment);
            }
            let total = *cdf.last().unwrap();
            values.iter_mut().for_each(|v| *v /= total);
            cdf.iter_mut().for_each(|c| *c /= total);
        }
        Filter {
            kind,
            radius,
            values: values.into(),
            cdf: cdf.into(),
            segment,
            inv_segment: if segment > 0.0 { 1.0 / segment } else { 0.0 },
        }
    }

    /// Which filter this is.
    pub fn kind(&self) -> FilterKind {
        self.kind
    }

    /// Whether this is the box of one pixel (camera samples and splats stay in their pixel).
    pub fn is_box(&self) -> bool {
        self.values.is_empty()
    }

    /// Radius of the support in pixels, per axis.
    pub fn radius(&self) -> f32 {
        self.radius as f32
    }

    /// How far beyond the image a camera sample of a border pixel can look, in pixels.
    pub fn margin(&self) -> f32 {
        (self.radius - 0.5).max(0.0) as f32
    }

    /// The normalised 1-D profile at `x` (pixels from the centre).
    pub fn eval_1d(&self, x: f64) -> f64 {
        if self.is_box() {
            return if x.abs() <= 0.5 { 1.0 } else { 0.0 };
        }
        let t = (x + self.radius) * self.inv_segment;
        if !(0.0..(self.values.len() - 1) as f64).contains(&t) {
            return 0.0;
        }
        // In range, so the (cheaper) 32-bit conversion truncates as the 64-bit one would.
        let i = t as u32 as usize;
        let a = t - i as f64;
        self.values[i] * (1.0 - a) + self.values[i + 1] * a
    }

    /// The normalised filter at offset `d` from a pixel's centre.
    pub fn eval(&self, d: Vec2) -> f64 {
        self.eval_1d(d.x as f64) * self.eval_1d(d.y as f64)
    }

    /// An offset from a pixel's centre with density [`Filter::eval_1d`], for `u` in [0, 1).
    pub fn sample_1d(&self, u: f64) -> f64 {
        if self.is_box() {
            return u - 0.5;
        }
        let h = self.segment;
        // The segment holding u: cdf[i] <= u < cdf[i + 1].
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .clamp(1, self.cdf.len() - 1)
            - 1;
        let (a, b) = (self.values[i], self.values[i + 1]);
        let rest = (u - self.cdf[i]).max(0.0);
        // Solve a t + (b - a) t² / 2h = rest for t in [0, h] (stable for a = 0 or a = b).
        let disc = (a * a + 2.0 * (b - a) * rest / h).max(0.0);
        let t = if rest > 0.0 {
            2.0 * rest / (a + disc.sqrt())
        } else {
            0.0
        };
        -self.radius + (i as f64 * h + t.min(h))
    }

    /// [`Filter::sample_1d`] on both axes.
    pub fn sample(&self, u: Vec2) -> Vec2 {
        Vec2::new(
            self.sample_1d(u.x as f64) as f32,
            self.sample_1d(u.y as f64) as f32,
        )
    }

    /// Integral of the normalised 1-D profile from `-radius` to `x`.
    pub fn cdf_1d(&self, x: f64) -> f64 {
        if x <= -self.radius {
            return 0.0;
        }
        if x >= self.radius {
            return 1.0;
        }
        if self.is_box() {
            return x + 0.5;
        }
        let h = self.segment;
        let t = (x + self.radius) / h;
        let i = (t as usize).min(self.values.len() - 2);
        let d = x + self.radius - i as f64 * h;
        let (a, b) = (self.values[i], self.values[i + 1]);
        self.cdf[i] + a * d + (b - a) * d * d / (2.0 * h)
    }

    /// The profile's integral over offsets in `[lo, hi]`: 1 when the filter lies inside.
    pub fn mass_1d(&self, lo: f64, hi: f64) -> f64 {
        if lo <= -self.radius && hi >= self.radius {
            1.0
        } else {
            (self.cdf_1d(hi) - self.cdf_1d(lo)).max(0.0)
        }
    }

    /// An offset with density [`Filter::eval_1d`] restricted to `[lo, hi]` (and renormalised),
    /// for `u` in [0, 1): [`Filter::sample_1d`] itself when the filter lies inside.
    pub fn sample_1d_within(&self, u: f64, lo: f64, hi: f64) -> f64 {
        if lo <= -self.radius && hi >= self.radius {
            return self.sample_1d(u);
        }
        let (a, b) = (self.cdf_1d(lo), self.cdf_1d(hi));
        self.sample_1d(a + u * (b - a)).clamp(lo, hi)
    }

    /// One axis of [`Filter::pick`]: the pixel column (or row) i, chosen with probability
    /// `f1(x - i - 1/2) / W1(x)`, `W1(x)` and the number `u` rescaled for reuse.
    fn pick_1d(&self, x: f64, u: f64) -> Option<(i64, f64, f64)> {
        let lo = (x - 0.5 - self.radius).ceil() as i64;
        let hi = (x - 0.5 + self.radius).floor() as i64;
        let w = |i: i64| self.eval_1d(x - (i as f64 + 0.5));
        let total: f64 = (lo..=hi).map(w).sum();
        if total <= 0.0 {
            return None;
        }
        let mut acc = 0.0;
        for i in lo..=hi {
            let p = w(i) / total;
            if p > 0.0 && (u < acc + p || i == hi) {
                return Some((i, total, ((u - acc) / p).clamp(0.0, 1.0 - f64::EPSILON)));
            }
            acc += p;
        }
        None
    }

    /// The pixel (column, row) a splat at raster position `raster` goes to, for `u` in
    /// [0, 1), and its weight `W(raster)`: pixel c with probability `f(raster - c) / W`.
    /// The pixel may lie outside the image (the caller drops the splat then).
    pub fn pick(&self, raster: Vec2, u: f32) -> Option<((i64, i64), f64)> {
        let (x, wx, u) = self.pick_1d(raster.x as f64, u as f64)?;
        let (y, wy, _) = self.pick_1d(raster.y as f64, u)?;
        Some(((x, y), wx * wy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filters() -> Vec<Filter> {
        vec![
            Filter::new(FilterKind::Tent { radius: 1.0 }),
            Filter::new(FilterKind::Tent { radius: 1.7 }),
            Filter::new(FilterKind::Gaussian { stddev: 0.5 }),
        ]
    }

    #[test]
    fn profiles_have_unit_integral_and_mitsubas_shape() {
        for f in filters() {
            let n = 200_000;
            let r = f.radius;
            let h = 2.0 * r / n as f64;
            let integral: f64 = (0..n)
                .map(|i| f.eval_1d(-r + (i as f64 + 0.5) * h) * h)
                .sum();
            assert!((integral - 1.0).abs() < 1e-6, "{:?}: {integral}", f.kind());
        }
        // Tent: exactly 1 - |x| / R, normalised by R.
        let t = Filter::new(FilterKind::Tent { radius: 1.0 });
        assert!((t.eval_1d(0.25) - 0.75).abs() < 1e-12);
        // Gaussian: Mitsuba's shape within the table's interpolation (256 segments on 2 px).
        let g = Filter::new(FilterKind::Gaussian { stddev: 0.5 });
        let m = |x: f64| (-2.0 * x * x).exp() - (-8.0f64).exp();
        let ratio = g.eval_1d(0.0) / m(0.0);
        for x in [0.1, 0.37, 0.8, 1.3, 1.9] {
            assert!((g.eval_1d(x) / ratio - m(x)).abs() < 2e-4, "{x}");
        }
    }

    /// Sampling inverts the table's CDF: the fraction of samples below x is the integral.
    #[test]
    fn samples_follow_the_profile() {
        for f in filters() {
            let n = 100_000;
            let xs: Vec<f64> = (0..n)
                .map(|i| f.sample_1d((i as f64 + 0.5) / n as f64))
                .collect();
            assert!(xs.windows(2).all(|w| w[0] <= w[1]), "not monotone");
            let r = f.radius;
            for q in [-0.9, -0.5, -0.1, 0.0, 0.3, 0.77] {
                let x = q * r;
                let below = xs.iter().filter(|&&s| s < x).count() as f64 / n as f64;
                let m = 100_000;
                let h = (x + r) / m as f64;
                let cdf: f64 = (0..m)
                    .map(|i| f.eval_1d(-r + (i as f64 + 0.5) * h) * h)
                    .sum();
                assert!(
                    (below - cdf).abs() < 2e-5,
                    "{:?} at {x}: {below} vs {cdf}",
                    f.kind()
                );
            }
        }
    }

    /// Cut at [lo, hi], sampling follows the profile renormalised to the cut: the fraction of
    /// samples below x is (C(x) - C(lo)) / (C(hi) - C(lo)), every sample lies in the cut, the
    /// mass is that denominator, and an uncut filter samples as before.
    #[test]
    fn samples_within_a_cut_follow_the_renormalised_profile() {
        for f in filters() {
            let r = f.radius;
            let (lo, hi) = (-0.3 * r, 2.0 * r);
            let n = 100_000;
            let xs: Vec<f64> = (0..n)
                .map(|i| f.sample_1d_within((i as f64 + 0.5) / n as f64, lo, hi))
                .collect();
            assert!(xs.iter().all(|&x| (lo..=hi).contains(&x)));
            let m = 100_000;
            let integral = |a: f64, b: f64| -> f64 {
                let h = (b - a) / m as f64;
                (0..m)
                    .map(|i| f.eval_1d(a + (i as f64 + 0.5) * h) * h)
                    .sum()
            };
            let mass = integral(lo, r);
            assert!((f.mass_1d(lo, hi) - mass).abs() < 1e-6, "{:?}", f.kind());
            for q in [-0.2, 0.0, 0.3, 0.77] {
                let x = q * r;
                let below = xs.iter().filter(|&&s| s < x).count() as f64 / n as f64;
                let want = integral(lo, x) / mass;
                assert!(
                    (below - want).abs() < 3e-5,
                    "{:?} at {x}: {below} vs {want}",
                    f.kind()
                );
            }
            for u in [0.0, 0.3, 0.999] {
                assert_eq!(f.sample_1d_within(u, -r - 1.0, r), f.sample_1d(u));
            }
            assert_eq!(f.mass_1d(-r, r + 3.0), 1.0);
        }
    }

    /// A splat's expected weight in pixel c is f(r - c), for every c around r.
    #[test]
    fn picks_give_each_pixel_its_filter_weight() {
        for f in filters() {
            for r in [
                Vec2::new(10.3, 7.9),
                Vec2::new(3.5, 3.5),
                Vec2::new(0.02, 5.99),
            ] {
                let n = 20_000;
                let mut got = std::collections::HashMap::new();
                for i in 0..n {
                    let u = (i as f32 + 0.5) / n as f32;
                    let (c, w) = f.pick(r, u).unwrap();
                    *got.entry(c).or_insert(0.0) += w / n as f64;
                }
                let mut total = 0.0;
                for (&(x, y), &g) in &got {
                    let want = f.eval(r - Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    assert!(
                        (g - want).abs() < 2e-3 * want.max(0.1),
                        "{r} ({x},{y}): {g} vs {want}"
                    );
                    total += want;
                }
                // Every pixel of weight was reached: what the picks missed is below the
                // probability one of the 20 000 stratified numbers stands for.
                let lo = (r - f.radius() - 1.0).floor();
                let mut all = 0.0;
                for y in lo.y as i64..lo.y as i64 + 2 * f.radius() as i64 + 4 {
                    for x in lo.x as i64..lo.x as i64 + 2 * f.radius() as i64 + 4 {
                        all += f.eval(r - Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    }
                }
                assert!(
                    (all - total).abs() < 1.0 / n as f64,
                    "{r}: missed {}",
                    all - total
                );
            }
        }
    }
}
