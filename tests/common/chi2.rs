//! Chi-square goodness-of-fit harness for sampling routines, in the style of Mitsuba 3's
//! `ChiSquareTest` and pbrt-v4's `bsdfs_test`.
//!
//! A test draws `N` samples from a sampling routine, histograms them on a regular grid over a
//! 2D parameter domain, and compares the histogram with the counts expected from the routine's
//! density, integrated numerically over every bin. Three domains are offered:
//! * [`spherical`]: directions, binned on a (z, phi) grid around an axis, with
//!   `z = 1 - cos(theta)`. The area element is `dz dphi`, so the solid-angle density needs no
//!   Jacobian. A [`SphereDomain`] can be the whole sphere (`z` in `[0, 2]`) or a cap
//!   (`z` in `[0, z_max]`) around any axis, which keeps the bins fine for small lights (a
//!   distant sphere, a small quad); `z` is computed as `sin^2 / (1 + cos)` near the axis, so
//!   caps down to `1 - cos(theta_max) ~ 1e-9` bin without cancellation.
//! * [`planar`]: points in a rectangle (area density), for point samplers and, later, 2D
//!   guiding kernels.
//! * [`discrete`]: indices with given probabilities (light selection, triangle choice).
//!
//! Every case makes two separate checks (see [`Report::problems`]):
//! * **Shape**: Pearson's test of the histogram of the successful samples against
//!   `successes * (bin mass / total mass)`, i.e. the sample distribution conditional on
//!   success.
//! * **Mass**: the pdf's integral over the domain must equal the share of successful samples
//!   (`None` = absorbed, below the horizon, back-facing light), within the binomial noise at
//!   level alpha plus [`MASS_TOL`] for the integration error. Kept apart from the shape test
//!   so that the integration error (a few 1e-5 of mass) is not mistaken for failed samples
//!   when almost none fail.
//! * Also: no sample may fall outside the domain or be non-finite, and at most a share
//!   [`ZERO_PDF_SHARE`] of the samples may sit where the pdf is zero (rounding on an edge).
//!
//! Sampler closures get a `&mut dyn Sampler` (an `IndependentSampler::new(SEED, 0, i)` with
//! `i` derived from the case name), so any sampling routine can be wrapped; per-sample checks
//! (the pdf a sample reports against `pdf()`, weights) belong in the test's closure, where a
//! `common::Failures` collects them.
//!
//! # Statistics
//! * The expected count of a bin is proportional to the integral of the pdf over the bin, by
//!   adaptive Simpson cubature: every bin is first split into 4 x 4 cells ([`MIN_DEPTH`]),
//!   then each cell compares a 3 x 3 and a 5 x 5 Simpson estimate and splits in four until
//!   they agree to a tolerance that totals [`INTEGRATION_TOL`] of probability mass over the
//!   domain, at most [`MAX_DEPTH`] levels deep; this resolves the discontinuities of
//!   silhouettes and horizons. A feature thinner than the initial cells (a light seen almost
//!   edge-on) can slip between the points, so before a bin is blamed, bins whose count is
//!   more than 3 sigma off are integrated again starting from 64 x 64 cells. Grazing views
//!   that are thinner still need a domain fitted to them.
//! * Cells with expected count below [`MIN_EXPECTED`] (5) are pooled, Mitsuba's rule: sorted by
//!   expected count, the smallest cells are merged into one pool until it reaches 5.
//! * Pearson's statistic `sum (O - E)^2 / E` is compared with a chi-square distribution of
//!   `cells - 1` degrees of freedom (statrs); the test rejects when the p-value is below
//!   [`alpha()`].
//! * **False-failure rate.** Every hypothesis test of the suite (each chi-square test, each
//!   mass check, each binomial test) uses the Sidak-corrected level
//!   `alpha = 1 - (1 - 0.01)^(1 / SUITE_TESTS)` = 1.90e-5, with [`SUITE_TESTS`] = 530 an
//!   upper bound on the number of such tests in all test files that use this harness
//!   (`chi2_bsdf.rs` has 133, `chi2_lights.rs` 50, `chi2_microfacet.rs` 162,
//!   `bsdf_energy.rs` 81, `chi2_phase.rs` 22, `chi2_lights_spot.rs` 35 including its power
//!   controls, `chi2_anisotropic.rs` 18, `chi2_blend.rs` 8, `pt_guiding.rs` 10, `envmap.rs`
//!   4, counting a case's chi-square test and mass check as two: 523). Under the null
//!   hypothesis (every sampler matches its pdf) the probability that *any* test of the suite
//!   fails is then at most 1 % (Sidak is exact for independent tests and conservative
//!   otherwise, and 523 < 530 tests only lowers it). The
//!   seeds are fixed, so a run is reproducible: a correct sampler either always passes or,
//!   with probability <= 1 % over the choice of seed, always fails. When you add tests and the
//!   suite would exceed [`SUITE_TESTS`] hypothesis tests, raise the constant.
//! * **Power.** With `N` = 1e6 samples on 20 x 40 bins (1,000-2,500 expected per bin), a
//!   cosine-weighted sampler checked against the normalised pdf `cos (1 + 0.1 cos) / c` gives
//!   chi2 ~ 940 on 399 dof (p ~ 1e-41), and losing 0.5 % of the samples fails the mass check
//!   (tolerance ~ 8e-4 there). Smooth shape errors of 1-3 % can pass: the test is for
//!   bugs (wrong Jacobians, wrong normalisation, wrong lobe choice), not for percent-level
//!   bias. `chi2_bsdf.rs` keeps tests asserting that the harness rejects mismatched pairs.

use glam::{DVec2, DVec3, Vec2, Vec3};
use lodestar::math::{IndependentSampler, Sampler};
use statrs::distribution::{Binomial, ChiSquared, ContinuousCDF, DiscreteCDF, Normal};
use std::f64::consts::PI;
use std::fmt;

/// Seed of every test stream; the stream index is derived from the case name.
pub const SEED: u64 = 0x6c6f_6465_6368_6932;
/// Family-wise false-failure rate of the whole suite.
pub const FAMILY_ALPHA: f64 = 0.01;
/// Upper bound on the number of hypothesis tests in the suite (see the module doc).
pub const SUITE_TESTS: usize = 530;
/// Cells expected to hold fewer samples than this are pooled (Mitsuba's rule).
pub const MIN_EXPECTED: f64 = 5.0;
/// Total probability mass the numerical integration may be off by, over a whole domain.
pub const INTEGRATION_TOL: f64 = 2e-4;
/// Number of times every bin is split in four before the adaptive integration starts.
pub const MIN_DEPTH: u32 = 2;
/// Maximum number of times a bin is split in four by the adaptive integration.
pub const MAX_DEPTH: u32 = 10;
/// How many bins that disagree with their samples are re-integrated more finely.
pub const REFINE_BINS: usize = 100;
/// Allowance of the mass check on top of the binomial noise, for the integration error.
pub const MASS_TOL: f64 = 5e-4;
/// Share of samples that may land where the pdf evaluates to exactly zero (rounding on the
/// boundary of a support, e.g. a sample exactly on a triangle edge). More is a failure.
pub const ZERO_PDF_SHARE: f64 = 1e-5;

/// Per-test significance level, Sidak-corrected so the suite's false-failure rate is 1 %.
pub fn alpha() -> f64 {
    1.0 - (1.0 - FAMILY_ALPHA).powf(1.0 / SUITE_TESTS as f64)
}

/// Two-sided standard-normal quantile for [`alpha()`].
fn z_alpha() -> f64 {
    Normal::new(0.0, 1.0)
        .unwrap()
        .inverse_cdf(1.0 - 0.5 * alpha())
}

/// Stream index of a test case: FNV-1a of its name, so every named case has its own stream.
pub fn case_index(name: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in name.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// The sampler of a named test case: `IndependentSampler::new(SEED, 0, case_index(name))`.
pub fn sampler_for(name: &str) -> IndependentSampler {
    IndependentSampler::new(SEED, 0, case_index(name))
}

// ------------------------------------------------------------------------------------------
// Pearson's test with pooling
// ------------------------------------------------------------------------------------------

#[derive(Debug, Clone, Copy)]
pub struct Pearson {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Cells after pooling.
    pub cells: usize,
    /// Cells that went into the pool.
    pub pooled: usize,
}

/// Pearson's chi-square test of observed against expected counts (same total), pooling the
/// cells with expected count below [`MIN_EXPECTED`] as Mitsuba does.
pub fn pearson(observed: &[f64], expected: &[f64]) -> Pearson {
    assert_eq!(observed.len(), expected.len());
    let mut idx: Vec<usize> = (0..expected.len()).collect();
    idx.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_e, mut pool_o, mut pooled) = (0.0, 0.0, 0usize);
    let (mut statistic, mut cells) = (0.0, 0usize);
    for i in idx {
        let (o, e) = (observed[i], expected[i].max(0.0));
        if e < MIN_EXPECTED || (pooled > 0 && pool_e < MIN_EXPECTED) {
            pool_e += e;
            pool_o += o;
            pooled += 1;
        } else {
            statistic += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pooled > 0 {
        if pool_e > 0.0 {
            statistic += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
            cells += 1;
        } else if pool_o > 0.0 {
            // Samples where nothing at all was expected.
            statistic = f64::INFINITY;
            cells += 1;
        }
    }
    let dof = cells.saturating_sub(1);
    let p_value = if !statistic.is_finite() {
        0.0
    } else if dof == 0 {
        if statistic == 0.0 { 1.0 } else { 0.0 }
    } else {
        ChiSquared::new(dof as f64).unwrap().sf(statistic)
    };
    Pearson {
        statistic,
        dof,
        p_value,
        cells,
        pooled,
    }
}

// ------------------------------------------------------------------------------------------
// Binomial test
// ------------------------------------------------------------------------------------------

/// Two-sided exact binomial p-value of `k` successes in `n` trials with probability `p`
/// (doubled smaller tail, capped at 1).
pub fn binomial_p_value(k: u64, n: u64, p: f64) -> f64 {
    if p <= 0.0 {
        return if k == 0 { 1.0 } else { 0.0 };
    }
    if p >= 1.0 {
        return if k == n { 1.0 } else { 0.0 };
    }
    let b = Binomial::new(p, n).unwrap();
    let lower = b.cdf(k);
    let upper = if k == 0 { 1.0 } else { b.sf(k - 1) };
    (2.0 * lower.min(upper)).min(1.0)
}

/// Panics unless `k` successes in `n` trials are consistent with probability `p` at level
/// [`alpha()`].
pub fn assert_binomial(name: &str, k: u64, n: u64, p: f64) {
    let pv = binomial_p_value(k, n, p);
    println!(
        "{name}: binomial k = {k} of n = {n} (share {:.6}), expected p = {p:.6}, p-value {pv:.4}",
        k as f64 / n as f64
    );
    assert!(
        pv >= alpha(),
        "{name}: {k} of {n} (share {:.6}) is inconsistent with probability {p:.6}: \
         p-value {pv:.3e} < alpha {:.3e}",
        k as f64 / n as f64,
        alpha()
    );
}

// ------------------------------------------------------------------------------------------
// Reports
// ------------------------------------------------------------------------------------------

/// Everything a chi-square case measured, and the verdicts.
#[derive(Debug, Clone)]
pub struct Report {
    pub name: String,
    /// Samples drawn.
    pub samples: usize,
    /// Samples that produced a value (in or outside the domain).
    pub successes: usize,
    /// Successful samples outside the domain, or not finite (always a failure).
    pub outside: usize,
    /// Samples at which the pdf evaluated to zero (or was not finite / negative).
    pub zero_pdf: usize,
    /// How many `zero_pdf` samples are tolerated.
    pub zero_pdf_allowed: usize,
    /// Integral of the pdf over the domain.
    pub mass: f64,
    pub pearson: Pearson,
    /// The cells that deviate most (index, observed, expected), for the failure message.
    /// Index `bins` is the outside cell.
    pub worst: Vec<(usize, f64, f64)>,
}

/// The `k` cells with the largest `(O - E)^2 / max(E, 1)`.
fn worst_cells(observed: &[f64], expected: &[f64], k: usize) -> Vec<(usize, f64, f64)> {
    let mut v: Vec<(usize, f64, f64)> = (0..observed.len())
        .map(|i| (i, observed[i], expected[i]))
        .collect();
    let score = |&(_, o, e): &(usize, f64, f64)| (o - e) * (o - e) / e.max(1.0);
    v.sort_by(|a, b| score(b).total_cmp(&score(a)));
    v.truncate(k);
    v
}

impl Report {
    pub fn share(&self) -> f64 {
        self.successes as f64 / self.samples as f64
    }

    /// True if Pearson's test rejects the pdf at level [`alpha()`].
    pub fn chi2_rejects(&self) -> bool {
        self.pearson.p_value < alpha()
    }

    /// Allowed |mass - share|: the binomial noise of the share at level alpha plus
    /// [`MASS_TOL`] for the integration.
    pub fn mass_tolerance(&self) -> f64 {
        let q = self.mass.clamp(0.0, 1.0);
        z_alpha() * (q * (1.0 - q) / self.samples as f64).sqrt() + MASS_TOL
    }

    /// True if the pdf's total mass differs from the share of successful samples.
    pub fn mass_mismatch(&self) -> bool {
        let d = (self.mass - self.share()).abs();
        d.is_nan() || d > self.mass_tolerance()
    }

    /// Every reason to reject; empty if the case passes.
    pub fn problems(&self) -> Vec<String> {
        let mut p = Vec::new();
        if self.outside > 0 {
            p.push(format!(
                "{} samples fell outside the domain (or were not finite)",
                self.outside
            ));
        }
        if self.zero_pdf > self.zero_pdf_allowed {
            p.push(format!(
                "{} samples landed where the pdf is zero (allowed {})",
                self.zero_pdf, self.zero_pdf_allowed
            ));
        }
        if self.mass_mismatch() {
            p.push(format!(
                "pdf integrates to {:.6} but {:.6} of the samples succeeded (tolerance {:.2e})",
                self.mass,
                self.share(),
                self.mass_tolerance()
            ));
        }
        if self.chi2_rejects() {
            p.push(format!(
                "chi-square rejects: statistic {:.1} on {} dof, p-value {:.3e} < alpha {:.3e}",
                self.pearson.statistic,
                self.pearson.dof,
                self.pearson.p_value,
                alpha()
            ));
        }
        p
    }

    /// True if any check rejects.
    pub fn rejected(&self) -> bool {
        !self.problems().is_empty()
    }

    /// Prints the report and panics if any check rejects.
    pub fn assert_ok(&self) {
        println!("{self}");
        let p = self.problems();
        assert!(
            p.is_empty(),
            "{}: {}\n{self}\nworst cells (index, observed, expected): {:?}",
            self.name,
            p.join("; "),
            self.worst
        );
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "{}: N = {}, share ok = {:.6}, pdf mass = {:.6}, chi2 = {:.1} on {} dof \
             ({} cells pooled), p = {:.4}, outside = {}, zero-pdf = {}",
            self.name,
            self.samples,
            self.share(),
            self.mass,
            self.pearson.statistic,
            self.pearson.dof,
            self.pearson.pooled,
            self.pearson.p_value,
            self.outside,
            self.zero_pdf
        )
    }
}

// ------------------------------------------------------------------------------------------
// The generic 2D test
// ------------------------------------------------------------------------------------------

/// A rectangle of parameters, cut into `res[0] x res[1]` bins.
#[derive(Debug, Clone, Copy)]
pub struct Rect {
    pub min: DVec2,
    pub max: DVec2,
    pub res: [usize; 2],
}

impl Rect {
    pub fn new(min: DVec2, max: DVec2, res: [usize; 2]) -> Rect {
        assert!(max.x > min.x && max.y > min.y && res[0] > 0 && res[1] > 0);
        Rect { min, max, res }
    }

    /// Bin of `x`, or `None` outside (a relative 1e-9 of slack at the edges).
    fn bin(&self, x: DVec2) -> Option<usize> {
        let size = self.max - self.min;
        let u = (x - self.min) / size;
        let slack = 1e-9;
        if !(u.x >= -slack && u.x <= 1.0 + slack && u.y >= -slack && u.y <= 1.0 + slack) {
            return None;
        }
        let i = ((u.x * self.res[0] as f64) as usize).min(self.res[0] - 1);
        let j = ((u.y * self.res[1] as f64) as usize).min(self.res[1] - 1);
        Some(i * self.res[1] + j)
    }

    fn bins(&self) -> usize {
        self.res[0] * self.res[1]
    }
}

/// What one draw produced, in parameter space.
pub enum Draw {
    /// The sampler returned nothing.
    Failed,
    /// A sample that is not finite or not in the domain.
    Outside,
    /// A sample at `x`, where the pdf (evaluated at the exact sample) is `pdf`.
    At { x: DVec2, pdf: f64 },
}

/// The core test: draw `samples` times, histogram over `rect`, integrate `density` (a density
/// with respect to `dx dy` on the rectangle) over each bin, and run Pearson's test with one
/// extra cell for failed draws.
pub fn run(
    name: &str,
    samples: usize,
    rect: &Rect,
    mut draw: impl FnMut(&mut dyn Sampler) -> Draw,
    density: impl Fn(DVec2) -> f64,
) -> Report {
    let mut sampler = sampler_for(name);
    let mut hist = vec![0u64; rect.bins()];
    let (mut successes, mut outside, mut zero_pdf) = (0usize, 0usize, 0usize);
    for _ in 0..samples {
        match draw(&mut sampler) {
            Draw::Failed => {}
            Draw::Outside => {
                successes += 1;
                outside += 1;
            }
            Draw::At { x, pdf } => {
                successes += 1;
                match rect.bin(x) {
                    Some(b) => hist[b] += 1,
                    None => outside += 1,
                }
                if !(pdf > 0.0 && pdf.is_finite()) {
                    zero_pdf += 1;
                }
            }
        }
    }
    let n = samples as f64;
    let mut masses = integrate_bins(rect, &density);
    let total: f64 = masses.iter().sum();
    let scale = if total > 0.0 {
        (successes - outside) as f64 / total
    } else {
        0.0
    };
    // Before blaming the sampler, make sure the integration is not what disagrees: a thin
    // feature (the sliver of a light seen edge-on) can slip between the cubature points.
    // Bins off by more than 3 sigma are integrated again on a 16 x finer grid (the worst
    // REFINE_BINS of them). This only makes the expected counts more accurate.
    let mut suspicious: Vec<(usize, f64)> = (0..rect.bins())
        .map(|b| {
            let (o, e) = (hist[b] as f64, masses[b] * scale);
            (b, (o - e) * (o - e) / e.max(1.0))
        })
        .filter(|&(_, score)| score > 9.0)
        .collect();
    suspicious.sort_by(|a, b| b.1.total_cmp(&a.1));
    for &(b, _) in suspicious.iter().take(REFINE_BINS) {
        masses[b] = integrate_bin(rect, &density, b, MIN_DEPTH + 4);
    }
    finish(
        name,
        samples,
        successes,
        outside,
        zero_pdf,
        (ZERO_PDF_SHARE * n) as usize,
        &hist,
        &masses,
    )
}

/// Builds the report: Pearson's test of the histogram's shape (expected counts
/// `in-domain successes * bin mass / total mass`, plus a cell for samples outside the domain
/// that expects none), and the numbers for the mass check.
#[allow(clippy::too_many_arguments)]
fn finish(
    name: &str,
    samples: usize,
    successes: usize,
    outside: usize,
    zero_pdf: usize,
    zero_pdf_allowed: usize,
    hist: &[u64],
    masses: &[f64],
) -> Report {
    let mass: f64 = masses.iter().sum();
    let in_domain = (successes - outside) as f64;
    let scale = if mass > 0.0 { in_domain / mass } else { 0.0 };
    let mut observed: Vec<f64> = hist.iter().map(|&c| c as f64).collect();
    let mut expected: Vec<f64> = masses.iter().map(|&m| m * scale).collect();
    observed.push(outside as f64);
    expected.push(0.0);
    Report {
        name: name.to_string(),
        samples,
        successes,
        outside,
        zero_pdf,
        zero_pdf_allowed,
        mass,
        pearson: pearson(&observed, &expected),
        worst: worst_cells(&observed, &expected, 8),
    }
}

/// Integral of `f` over every bin of `rect` (row-major, as [`Rect::bin`]).
pub fn integrate_bins(rect: &Rect, f: &impl Fn(DVec2) -> f64) -> Vec<f64> {
    (0..rect.bins())
        .map(|b| integrate_bin(rect, f, b, MIN_DEPTH))
        .collect()
}

/// Integral of `f` over bin `b`, every bin split at least `min_depth` times.
fn integrate_bin(rect: &Rect, f: &impl Fn(DVec2) -> f64, b: usize, min_depth: u32) -> f64 {
    let size = (rect.max - rect.min) / DVec2::new(rect.res[0] as f64, rect.res[1] as f64);
    let (i, j) = (b / rect.res[1], b % rect.res[1]);
    let lo = rect.min + size * DVec2::new(i as f64, j as f64);
    // Tolerance per bin; the tolerances of a bin's sub-cells add up to about this.
    let tol = INTEGRATION_TOL / rect.bins() as f64;
    adaptive(f, lo, lo + size, tol, 0, min_depth)
}

/// Integral of `f` over the whole rectangle.
pub fn integrate(rect: &Rect, f: &impl Fn(DVec2) -> f64) -> f64 {
    integrate_bins(rect, f).iter().sum()
}

/// (3 x 3 Simpson, 5 x 5 composite Simpson) estimates of the integral over a cell.
fn simpson(f: &impl Fn(DVec2) -> f64, lo: DVec2, hi: DVec2) -> (f64, f64) {
    const W5: [f64; 5] = [1.0, 4.0, 2.0, 4.0, 1.0];
    const W3: [f64; 5] = [1.0, 0.0, 4.0, 0.0, 1.0];
    let h = (hi - lo) / 4.0;
    let (mut fine, mut coarse) = (0.0, 0.0);
    for i in 0..5 {
        for j in 0..5 {
            let v = f(lo + h * DVec2::new(i as f64, j as f64));
            let v = if v.is_finite() { v } else { 0.0 };
            fine += W5[i] * W5[j] * v;
            coarse += W3[i] * W3[j] * v;
        }
    }
    let area = (hi.x - lo.x) * (hi.y - lo.y);
    (coarse * area / 36.0, fine * area / 144.0)
}

fn adaptive(
    f: &impl Fn(DVec2) -> f64,
    lo: DVec2,
    hi: DVec2,
    tol: f64,
    depth: u32,
    min_depth: u32,
) -> f64 {
    // Always split `min_depth` times, so a feature between the points of one 5 x 5 grid is
    // not missed by two agreeing estimates.
    if depth >= min_depth {
        let (coarse, fine) = simpson(f, lo, hi);
        if (fine - coarse).abs() <= tol || depth >= MAX_DEPTH {
            return fine;
        }
    }
    let mid = 0.5 * (lo + hi);
    // Along a discontinuity the number of cells doubles per level, so halving the tolerance
    // keeps the bin's total error near `tol`.
    let t = 0.5 * tol;
    let (d, m) = (depth + 1, min_depth);
    let (x0y1, x1y0) = (DVec2::new(lo.x, mid.y), DVec2::new(mid.x, lo.y));
    adaptive(f, lo, mid, t, d, m)
        + adaptive(f, x1y0, DVec2::new(hi.x, mid.y), t, d, m)
        + adaptive(f, x0y1, DVec2::new(mid.x, hi.y), t, d, m)
        + adaptive(f, mid, hi, t, d, m)
}

// ------------------------------------------------------------------------------------------
// Directions
// ------------------------------------------------------------------------------------------

/// Directions in a cap `1 - cos(theta) <= z_max` around an axis (the whole sphere for
/// `z_max = 2`), binned on a (z, phi) grid with `z = 1 - cos(theta)`.
#[derive(Debug, Clone, Copy)]
pub struct SphereDomain {
    pub s: DVec3,
    pub t: DVec3,
    pub n: DVec3,
    pub z_max: f64,
    /// Bins in z and in phi.
    pub res: [usize; 2],
    /// Samples with `z_max < z <= z_max (1 + edge_slack)` count as on the cap's edge (binned
    /// in the last ring, pdf evaluated at `z_max (1 - edge_slack)`). For caps whose edge is a silhouette that
    /// f32 sampling code can only place to a few ulps (tiny distant lights); 0 by default.
    pub edge_slack: f64,
}

impl SphereDomain {
    /// The whole sphere, theta measured from +z, 20 x 40 bins.
    pub fn full() -> SphereDomain {
        SphereDomain::around(Vec3::Z, 2.0)
    }

    /// The whole sphere, theta measured from `axis`.
    pub fn full_around(axis: Vec3) -> SphereDomain {
        SphereDomain::around(axis, 2.0)
    }

    /// The cap `1 - cos(theta) <= z_max` around `axis`, 20 x 40 bins.
    pub fn around(axis: Vec3, z_max: f64) -> SphereDomain {
        let n = axis.as_dvec3().normalize();
        // Duff et al. 2017, in f64.
        let sign = 1f64.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = DVec3::new(b, sign + n.y * n.y * a, -n.y);
        SphereDomain {
            s,
            t,
            n,
            z_max: z_max.min(2.0),
            res: [20, 40],
            edge_slack: 0.0,
        }
    }

    /// The cap seen from `p` of a ball (`center`, `radius`), widened by 5 % so that the
    /// ball's silhouette lies inside the domain; the whole sphere if `p` is in the ball.
    pub fn covering_ball(p: Vec3, center: Vec3, radius: f64) -> SphereDomain {
        let d = center.as_dvec3() - p.as_dvec3();
        let d2 = d.length_squared();
        if d2 <= radius * radius * 1.0001 {
            return SphereDomain::full();
        }
        let sin2 = radius * radius / d2;
        let z = sin2 / (1.0 + (1.0 - sin2).sqrt());
        SphereDomain::around(d.as_vec3(), 1.05 * z)
    }

    /// The exact cap a ball (`center`, `radius`) subtends from `p` (outside the ball).
    pub fn ball_cap(p: Vec3, center: Vec3, radius: f64) -> SphereDomain {
        let d = center.as_dvec3() - p.as_dvec3();
        let sin2 = radius * radius / d.length_squared();
        assert!(sin2 < 1.0, "the point is inside the ball");
        SphereDomain::around(d.as_vec3(), sin2 / (1.0 + (1.0 - sin2).sqrt()))
    }

    pub fn with_edge_slack(mut self, rel: f64) -> SphereDomain {
        self.edge_slack = rel;
        self
    }

    pub fn with_res(mut self, nz: usize, nphi: usize) -> SphereDomain {
        self.res = [nz, nphi];
        self
    }

    /// (z, phi) of a direction (normalised here), or `None` if it is not finite or zero.
    pub fn to_param(self, w: Vec3) -> Option<DVec2> {
        let w = w.as_dvec3();
        let len = w.length();
        if !(len.is_finite() && len > 0.0) {
            return None;
        }
        let w = w / len;
        let (x, y, c) = (w.dot(self.s), w.dot(self.t), w.dot(self.n));
        let z = if c > 0.5 {
            (x * x + y * y) / (1.0 + c)
        } else {
            1.0 - c
        };
        let mut phi = y.atan2(x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        Some(DVec2::new(z, phi))
    }

    /// Direction of (z, phi).
    pub fn to_dir(self, x: DVec2) -> Vec3 {
        let (z, phi) = (x.x.clamp(0.0, 2.0), x.y);
        let sin_theta = (z * (2.0 - z)).max(0.0).sqrt();
        let w = self.s * (sin_theta * phi.cos())
            + self.t * (sin_theta * phi.sin())
            + self.n * (1.0 - z);
        w.as_vec3()
    }

    pub fn rect(&self) -> Rect {
        Rect::new(DVec2::ZERO, DVec2::new(self.z_max, 2.0 * PI), self.res)
    }
}

/// Chi-square test of a direction sampler against its solid-angle density over `domain`.
/// `sample` returns `None` for a failed draw; `pdf` must be zero outside `domain`.
pub fn spherical(
    name: &str,
    samples: usize,
    domain: &SphereDomain,
    mut sample: impl FnMut(&mut dyn Sampler) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> Report {
    let rect = domain.rect();
    run(
        name,
        samples,
        &rect,
        |s| match sample(s) {
            None => Draw::Failed,
            Some(w) => match domain.to_param(w) {
                None => Draw::Outside,
                Some(mut x) => {
                    let z_max = domain.z_max;
                    if x.x > z_max && x.x <= z_max * (1.0 + domain.edge_slack) {
                        x.x = z_max;
                        let inside =
                            domain.to_dir(DVec2::new(z_max * (1.0 - domain.edge_slack), x.y));
                        Draw::At {
                            x,
                            pdf: pdf(inside),
                        }
                    } else {
                        Draw::At { x, pdf: pdf(w) }
                    }
                }
            },
        },
        |x| pdf(domain.to_dir(x)),
    )
}

/// Integral of a solid-angle density over `domain`.
pub fn integrate_sphere(domain: &SphereDomain, pdf: impl Fn(Vec3) -> f64) -> f64 {
    integrate(&domain.rect(), &|x| pdf(domain.to_dir(x)))
}

// ------------------------------------------------------------------------------------------
// Points in a rectangle
// ------------------------------------------------------------------------------------------

/// Chi-square test of a point sampler against its area density on the rectangle
/// `[min, max]`, with `res` bins. `pdf` must be zero outside the rectangle.
pub fn planar(
    name: &str,
    samples: usize,
    min: Vec2,
    max: Vec2,
    res: [usize; 2],
    mut sample: impl FnMut(&mut dyn Sampler) -> Option<Vec2>,
    pdf: impl Fn(Vec2) -> f64,
) -> Report {
    let rect = Rect::new(min.as_dvec2(), max.as_dvec2(), res);
    run(
        name,
        samples,
        &rect,
        |s| match sample(s) {
            None => Draw::Failed,
            Some(p) if !p.is_finite() => Draw::Outside,
            Some(p) => Draw::At {
                x: p.as_dvec2(),
                pdf: pdf(p),
            },
        },
        |x| pdf(x.as_vec2()),
    )
}

// ------------------------------------------------------------------------------------------
// Discrete choices
// ------------------------------------------------------------------------------------------

/// Chi-square test of a sampler of indices in `0..probs.len()` against `probs` (which may sum
/// to less than 1 if draws can fail). No sample may pick an index of probability zero.
pub fn discrete(
    name: &str,
    samples: usize,
    probs: &[f64],
    mut sample: impl FnMut(&mut dyn Sampler) -> Option<usize>,
) -> Report {
    let mut sampler = sampler_for(name);
    let mut hist = vec![0u64; probs.len()];
    let (mut successes, mut outside, mut zero_pdf) = (0usize, 0usize, 0usize);
    for _ in 0..samples {
        if let Some(i) = sample(&mut sampler) {
            successes += 1;
            if i < probs.len() {
                hist[i] += 1;
                if probs[i].is_nan() || probs[i] <= 0.0 {
                    zero_pdf += 1;
                }
            } else {
                outside += 1;
            }
        }
    }
    finish(name, samples, successes, outside, zero_pdf, 0, &hist, probs)
}

// ------------------------------------------------------------------------------------------
// Narrow lobes: two log-warped charts
// ------------------------------------------------------------------------------------------

/// Directions binned for narrow lobes on both sides of a surface (glossy reflection and
/// transmission), where a regular (z, phi) grid would put a whole lobe in one ring.
///
/// The sphere is split by the plane normal to `n` into the side `n` points to (chart 0) and
/// the other side (chart 1). Each chart is parametrised over the *whole* sphere around its
/// own axis (`axes[k].n`, which should lie on the chart's side) by `(s, phi)`, `s` in [0, 1],
/// with `z = 1 - cos(theta) = 2 ((1 + a)^s - 1) / a`: rings spaced logarithmically, the first
/// one `~ 2 ln(1 + a) / (a res)` wide in z. A direction belongs to the chart of its side
/// only; the other chart gives it density zero. On the rectangle `[0, 2] x [0, 2 pi]`,
/// chart 0 has `x = s` and chart 1 `x = 2 - s`, so that both charts meet at `x = 1` at the
/// antipodes of their axes, which lie on the other side, where both densities are zero (no
/// jump for the cubature). The density per `dx dphi` is the solid-angle density times
/// `dz/ds`.
#[derive(Debug, Clone, Copy)]
pub struct LobeDomain {
    pub n: DVec3,
    pub axes: [SphereDomain; 2],
    /// Warp strength `a` (> 0); `a ~ 10 / alpha^2` resolves a GGX lobe of roughness alpha.
    a: f64,
    /// `ln(1 + a)`.
    ln_1p_a: f64,
    /// Rings per chart and bins in phi.
    pub res: [usize; 2],
}

impl LobeDomain {
    /// Charts around `axis0` (on the side of `n`) and `axis1` (the other side), 24 rings per
    /// chart, 36 bins in phi.
    pub fn new(n: Vec3, axis0: Vec3, axis1: Vec3, a: f64) -> LobeDomain {
        assert!(a > 0.0);
        LobeDomain {
            n: n.as_dvec3().normalize(),
            axes: [
                SphereDomain::around(axis0, 2.0),
                SphereDomain::around(axis1, 2.0),
            ],
            a,
            ln_1p_a: a.ln_1p(),
            res: [24, 36],
        }
    }

    pub fn with_res(mut self, rings: usize, nphi: usize) -> LobeDomain {
        self.res = [rings, nphi];
        self
    }

    pub fn rect(&self) -> Rect {
        Rect::new(
            DVec2::ZERO,
            DVec2::new(2.0, 2.0 * PI),
            [2 * self.res[0], self.res[1]],
        )
    }

    /// Chart of a direction: 0 on the side of `n` (or on the plane), 1 on the other.
    fn chart(&self, w: DVec3) -> usize {
        if w.dot(self.n) >= 0.0 { 0 } else { 1 }
    }

    /// `(z, dz/ds)` at `s`.
    fn z_of_s(&self, s: f64) -> (f64, f64) {
        let e = (s * self.ln_1p_a).exp_m1();
        (2.0 * e / self.a, 2.0 * self.ln_1p_a * (1.0 + e) / self.a)
    }

    fn s_of_z(&self, z: f64) -> f64 {
        (0.5 * self.a * z).ln_1p() / self.ln_1p_a
    }

    /// Parameters of a direction, `None` if it is not finite or zero.
    pub fn to_param(self, w: Vec3) -> Option<DVec2> {
        let wd = w.as_dvec3();
        if !(wd.length() > 0.0 && wd.is_finite()) {
            return None;
        }
        let k = self.chart(wd);
        let zp = self.axes[k].to_param(w)?;
        let s = self.s_of_z(zp.x).clamp(0.0, 1.0);
        Some(DVec2::new(if k == 0 { s } else { 2.0 - s }, zp.y))
    }

    /// Direction at parameters `x`, with its chart and `dz/ds`; `None` if the direction is
    /// not on the side of that chart (density zero there).
    pub fn to_dir(self, x: DVec2) -> Option<(Vec3, f64)> {
        let (k, s) = if x.x <= 1.0 { (0, x.x) } else { (1, 2.0 - x.x) };
        let (z, dz_ds) = self.z_of_s(s.clamp(0.0, 1.0));
        let w = self.axes[k].to_dir(DVec2::new(z, x.y));
        if self.chart(w.as_dvec3()) != k {
            return None;
        }
        Some((w, dz_ds))
    }

    /// Density per `dx dphi` of a solid-angle density.
    pub fn density(&self, pdf: &impl Fn(Vec3) -> f64, x: DVec2) -> f64 {
        match self.to_dir(x) {
            Some((w, j)) => pdf(w) * j,
            None => 0.0,
        }
    }
}

/// Chi-square test of a direction sampler against its solid-angle density, binned on a
/// [`LobeDomain`] (the whole sphere; no sample can fall outside it unless it is not finite).
pub fn lobe_spherical(
    name: &str,
    samples: usize,
    domain: &LobeDomain,
    mut sample: impl FnMut(&mut dyn Sampler) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> Report {
    run(
        name,
        samples,
        &domain.rect(),
        |s| match sample(s) {
            None => Draw::Failed,
            Some(w) => match domain.to_param(w) {
                None => Draw::Outside,
                Some(x) => Draw::At { x, pdf: pdf(w) },
            },
        },
        |x| domain.density(&pdf, x),
    )
}

/// Integral of a solid-angle density (or any function of direction) over the sphere, with
/// the cubature on a [`LobeDomain`].
pub fn integrate_lobe(domain: &LobeDomain, f: impl Fn(Vec3) -> f64) -> f64 {
    integrate(&domain.rect(), &|x| domain.density(&f, x))
}
