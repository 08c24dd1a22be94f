//! Statistical tests of the microfacet BSDFs (rough conductor, rough dielectric and rough
//! plastic, GGX and Beckmann) and of the two distributions themselves; the rough plastic's
//! values and densities against Mitsuba 3's.
//!
//! * The distribution: `∫ D(m) cos(theta_m) dm = 1` and `∫ D_wo(m) dm = 1` by cubature, and
//!   chi-square of the visible-normal sampler against `D_wo`.
//! * Each BSDF: chi-square of `sample` against `pdf` over the whole sphere, binned on two
//!   log-warped charts (one per side of the surface, see `chi2::LobeDomain`) so that lobes
//!   down to alpha = 0.05 spread over many bins, for alpha in {0.05, 0.1, 0.3, 0.7, 1} and
//!   incident angles from normal to grazing (85 degrees), `wo` on both sides (inside the
//!   dielectric, below and above its critical angle). Every draw samples in both transport
//!   modes with the same random numbers; per sample, in each mode, the sample's `pdf` and `f`
//!   must equal `pdf()` and `eval()`, `weight == f |cos| / pdf`, the flags and `eta` must be
//!   right, and the two modes must pick the same direction (the sampling does not depend on
//!   the mode, so one chi-square test covers both).
//! * Power: the harness must reject the pdf of the *full* normal distribution
//!   (`D(m) cos(theta_m) / (4 wo.m)`) for a visible-normal sampler, and a transmission pdf
//!   without the `eta^2` of the half-vector Jacobian.
//!
//! Statistics (see `common/chi2.rs`): every chi-square test and mass check runs at the
//! suite's Sidak-corrected level `chi2::alpha()`; this file has 162 of them (70 cases and 2
//! power controls, x 2; Beckmann: the visible-normal sampler at 3 angles, the conductor and
//! the dielectric in 4 and 3 configurations; rough plastic: 9 cases, x 2). Samples per case:
//! 75,000 (`CASE_N`) on 16 x 24 bins per chart (a few hundred expected per bin where the lobe
//! is), which the power controls reject by far (chi2 about 29,000 on 290 degrees of freedom
//! for `D` instead of `D_wo`, about 2,400 on 536 for the Jacobian without `eta^2`); the cases
//! that `chi2_anisotropic.rs` and `chi2_blend.rs` run through [`bsdf_case`] draw [`N`].

use crate::common;

use common::chi2::{self, LobeDomain};
use common::{Failures, MODES, close, close3, dir_around, ng_generic};
use glam::Vec3;
use lodestar::bsdf::Distribution;
use lodestar::bsdf::microfacet::{Ggx, Microfacet, Smith};
use lodestar::bsdf::{Bsdf, ConductorFresnel, RoughPlastic, ShadingFrame, TransportMode, fresnel};
use lodestar::math::Sampler;

/// Samples per chi-square case of [`bsdf_case`] and
/// [`visible_normal_case`], as `chi2_anisotropic.rs` and `chi2_blend.rs` run them.
pub(crate) const N: usize = 150_000;

/// Samples per chi-square case of this file's tests.
const CASE_N: usize = 75_000;

const ALPHAS: [f32; 5] = [0.05, 0.1, 0.3, 0.7, 1.0];

fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Warp strength of the lobe domain for roughness alpha.
pub(crate) fn warp_for(alpha: f32) -> f64 {
    10.0 / (alpha as f64 * alpha as f64)
}

/// The lobe domain for `wo` at a surface with shading normal `ns`: chart 0 around the mirror
/// direction, chart 1 around the macro-refracted direction (`eta_r` = n(other side) /
/// n(side of wo)), or straight through the surface under total internal reflection.
fn lobe_domain(ns: Vec3, wo: Vec3, eta_r: f32, alpha: f32) -> LobeDomain {
    let n = if wo.dot(ns) >= 0.0 { ns } else { -ns };
    let c = wo.dot(n);
    let sin2_t = (1.0 - c * c) / (eta_r * eta_r);
    let axis1 = if sin2_t < 0.99 {
        (-wo / eta_r + (c / eta_r - (1.0 - sin2_t).sqrt()) * n).normalize()
    } else {
        -n
    };
    LobeDomain::new(n, reflect(wo, n), axis1, warp_for(alpha)).with_res(RINGS, PHIS)
}

/// Rings per chart and bins in phi of the lobe domains.
pub(crate) const RINGS: usize = 16;
pub(crate) const PHIS: usize = 24;

/// Relative tolerance of a sample's `f` and `pdf` against `eval()` and `pdf()` at its
/// direction. These are the same function, but `eval()` gets `wi` after a round trip through
/// world space (a few 1e-8 of error). That is amplified only where the Fresnel term of a
/// dielectric is ill-conditioned: near the critical angle, `cos_t` of the refraction of `wo`
/// through the microfacet goes to zero like `sqrt(sin_c^2 - sin^2)`, and `F` and `1 - F`
/// change with it, so a perturbation `e` of `sin^2` changes them by about `e / (2 cos_t^2)`
/// relatively, and `e` reaches several ulps (a few 1e-7) in `f32`.
fn value_tolerance(ns: Vec3, wo: Vec3, wi: Vec3, eta_r: f32) -> f64 {
    let base = 1e-3;
    if eta_r == 1.0 {
        return base;
    }
    let m = if wi.dot(ns) * wo.dot(ns) < 0.0 {
        (wo + eta_r * wi).normalize()
    } else {
        (wo + wi).normalize()
    };
    let (_, cos_t, _) = fresnel::dielectric(wo.dot(m).abs(), eta_r);
    if cos_t == 0.0 {
        return base;
    }
    base + 1e-6 / (cos_t as f64 * cos_t as f64)
}

/// Chi-square of a rough BSDF's sampler against its pdf from `wo` with `samples` samples
/// ([`N`] for the other files' cases, [`CASE_N`] for this file's), with every per-sample
/// check in both modes. `eta_r` is the relative index a transmitted sample must report;
/// `weight_at_most_one`: whether importance-mode weights are bounded by 1 (single-lobe
/// BSDFs; a mixture's are not).
#[allow(clippy::too_many_arguments)]
pub(crate) fn bsdf_case(
    samples: usize,
    name: &str,
    bsdf: &Bsdf,
    sf: &ShadingFrame,
    wo: Vec3,
    eta_r: f32,
    alpha: f32,
    weight_at_most_one: bool,
) {
    let ns = sf.frame.n;
    let aligned = ns == sf.ng;
    let domain = lobe_domain(ns, wo, eta_r, alpha);
    let mut fails = Failures::new();
    // The radiance-mode pdf of the last sample's direction, which the harness asks for next.
    let last = std::cell::Cell::new(None::<(Vec3, f32)>);
    let report = chi2::lobe_spherical(
        name,
        samples,
        &domain,
        |s: &mut dyn Sampler| {
            let (ul, u) = (s.next_1d(), s.next_2d());
            let smps = MODES.map(|mode| bsdf.sample(sf, wo, ul, u, mode));
            fails.check(smps[0].is_some() == smps[1].is_some(), || {
                "one mode sampled, the other did not".to_string()
            });
            let (Some(r), Some(_)) = (smps[0], smps[1]) else {
                return None;
            };
            let wi = r.wi;
            let mut weights = [Vec3::ZERO; 2];
            for (k, mode) in MODES.into_iter().enumerate() {
                let smp = smps[k].unwrap();
                fails.check(smp.wi == wi && smp.transmission == r.transmission, || {
                    format!("modes chose {} and {}", wi, smp.wi)
                });
                let pdf = bsdf.pdf(sf, wo, wi, mode);
                if mode == TransportMode::Radiance {
                    last.set(Some((wi, pdf)));
                }
                let f = bsdf.eval(sf, wo, wi, mode);
                let tol = value_tolerance(ns, wo, wi, eta_r);
                fails.check(close(smp.pdf as f64, pdf as f64, tol, 0.0), || {
                    format!("{mode:?}: sample pdf {} != pdf() {pdf} at wi {wi}", smp.pdf)
                });
                fails.check(close3(smp.f, f, tol, 0.0), || {
                    format!("{mode:?}: sample f {} != eval() {f} at wi {wi}", smp.f)
                });
                // The sample's weight uses the cosine in the local frame; recomputed from the
                // world-space wi it carries an absolute error of a few 1e-8, which matters
                // for grazing wi.
                let cos = wi.dot(ns).abs();
                let w = f * cos / pdf;
                let tol = 1e-3 + 2e-7 / cos as f64;
                fails.check(close3(smp.weight, w, tol, 0.0), || {
                    format!("{mode:?}: weight {} != f |cos| / pdf = {w}", smp.weight)
                });
                fails.check(
                    smp.weight.is_finite() && smp.weight.min_element() > 0.0,
                    || format!("{mode:?}: weight {}", smp.weight),
                );
                // Importance-mode weights are G2 / G1(wo) times F or 1 - F (over the lobe
                // probability): never above 1 without a shading normal.
                if weight_at_most_one && aligned && mode == TransportMode::Importance {
                    fails.check(smp.weight.max_element() <= 1.0 + 1e-4, || {
                        format!("importance weight {} > 1", smp.weight)
                    });
                }
                weights[k] = smp.weight;
                let crosses = wi.dot(ns) * wo.dot(ns) < 0.0;
                let expected_eta = if crosses { eta_r } else { 1.0 };
                fails.check(
                    !smp.delta
                        && smp.transmission == crosses
                        && close(smp.eta as f64, expected_eta as f64, 1e-6, 0.0),
                    || {
                        format!(
                            "flags: delta {} transmission {} (crosses {crosses}) eta {}",
                            smp.delta, smp.transmission, smp.eta
                        )
                    },
                );
                fails.check((wi.length() - 1.0).abs() < 1e-4, || {
                    format!("|wi| = {}", wi.length())
                });
            }
            // Radiance scales transmission by 1 / eta_r^2, reflection not at all.
            let scale = if r.transmission {
                1.0 / (eta_r * eta_r)
            } else {
                1.0
            };
            if aligned {
                fails.check(close3(weights[0], weights[1] * scale, 1e-4, 0.0), || {
                    format!(
                        "radiance weight {} != importance weight {} x {scale}",
                        weights[0], weights[1]
                    )
                });
            }
            Some(wi)
        },
        |wi| match last.get() {
            Some((w, pdf)) if w == wi => pdf as f64,
            _ => bsdf.pdf(sf, wo, wi, TransportMode::Radiance) as f64,
        },
    );
    report.assert_ok();
    fails.assert_none(name);
}

pub(crate) fn gold() -> ConductorFresnel {
    ConductorFresnel::Complex {
        eta: Vec3::new(0.143, 0.374, 1.442),
        k: Vec3::new(3.983, 2.385, 1.603),
        scale: Vec3::ONE,
    }
}

// ------------------------------------------------------------------------------------------
// The distribution
// ------------------------------------------------------------------------------------------

/// `∫ D(m) cos(theta_m) dm = 1` and `∫ D_wo(m) dm = 1` by cubature, for each roughness and
/// four incident angles (the second holds only with the exact Smith Lambda).
fn normalisation(dist: Distribution, alphas: &[f32]) {
    let mut fails = Failures::new();
    for &alpha in alphas {
        let mf = Microfacet::new(dist, alpha);
        // One chart (the upper hemisphere) around +z; chart 1 is empty.
        let domain = LobeDomain::new(Vec3::Z, Vec3::Z, -Vec3::Z, warp_for(alpha)).with_res(12, 16);
        let projected = chi2::integrate_lobe(&domain, |m| (mf.d(m) * m.z.max(0.0)) as f64);
        println!("{dist:?} alpha {alpha}: ∫ D cos = {projected:.6}");
        fails.check(close(projected, 1.0, 0.0, 1e-3), || {
            format!("{dist:?} alpha {alpha}: ∫ D(m) cos = {projected}")
        });
        for theta in [0.0f32, 60.0, 85.0, 89.5] {
            let wo = dir_around(Vec3::Z, theta, 20.0);
            let vis = chi2::integrate_lobe(&domain, |m| mf.d_visible(wo, m) as f64);
            // The same statement as the Smith normalisation ∫ G1 <wo, m> D = cos_o.
            println!("{dist:?} alpha {alpha}, theta_o {theta}: ∫ D_wo = {vis:.6}");
            fails.check(close(vis, 1.0, 0.0, 1e-3), || {
                format!("{dist:?} alpha {alpha}, theta_o {theta}: ∫ D_wo(m) = {vis}")
            });
        }
    }
    fails.assert_none(&format!("{dist:?} normalisation"));
}

/// Chi-square of the visible-normal sampler against `D_wo`, for each roughness, from normal
/// incidence to grazing.
fn visible_normal_sampling(dist: Distribution, alphas: &[f32]) {
    for &alpha in alphas {
        let mf = Microfacet::new(dist, alpha);
        for theta in [0.0f32, 60.0, 85.0] {
            let wo = dir_around(Vec3::Z, theta, 20.0);
            let name = format!("{dist:?} VNDF alpha {alpha}, theta_o {theta}");
            visible_normal_sized(CASE_N, &name, &mf, wo, alpha);
        }
    }
}

/// Chi-square of `mf`'s visible normals for `wo` (local frame) against `D_wo`, on a lobe
/// domain warped for roughness `alpha`; every normal must be unit and above the surface.
pub(crate) fn visible_normal_case(name: &str, mf: &Microfacet, wo: Vec3, alpha: f32) {
    visible_normal_sized(N, name, mf, wo, alpha)
}

/// [`visible_normal_case`] with `samples` samples.
fn visible_normal_sized(samples: usize, name: &str, mf: &Microfacet, wo: Vec3, alpha: f32) {
    let domain = LobeDomain::new(Vec3::Z, Vec3::Z, -Vec3::Z, warp_for(alpha)).with_res(RINGS, PHIS);
    let mut fails = Failures::new();
    chi2::lobe_spherical(
        name,
        samples,
        &domain,
        |s| {
            let m = mf.sample_visible(wo, s.next_2d())?;
            fails.check((m.length() - 1.0).abs() < 1e-4 && m.z > 0.0, || {
                format!("m = {m}")
            });
            Some(m)
        },
        |m| mf.d_visible(wo, m) as f64,
    )
    .assert_ok();
    fails.assert_none(name);
}

#[test]
fn ggx_projected_area_and_visible_normals_integrate_to_one() {
    normalisation(Distribution::Ggx, &[0.01, 0.05, 0.3, 1.0, 2.0]);
}

#[test]
fn ggx_visible_normal_sampling() {
    visible_normal_sampling(Distribution::Ggx, &[0.1, 0.7]);
}

#[test]
fn beckmann_projected_area_and_visible_normals_integrate_to_one() {
    normalisation(Distribution::Beckmann, &[0.05, 0.3, 1.0]);
}

#[test]
fn beckmann_visible_normal_sampling() {
    visible_normal_sampling(Distribution::Beckmann, &[0.3]);
}

#[test]
fn beckmann_rough_bsdfs_sampling_matches_pdf() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    for alpha in [0.1f32, 0.5] {
        let bsdf = Bsdf::rough_conductor(alpha, gold()).with_distribution(Distribution::Beckmann);
        for theta in [45.0f32, 85.0] {
            let wo = dir_around(ng, theta, 40.0);
            let name = format!("Beckmann rough conductor alpha {alpha}, wo at {theta} deg");
            bsdf_case(CASE_N, &name, &bsdf, &sf, wo, 1.0, alpha, true);
        }
    }
    let (eta, alpha) = (1.5f32, 0.3f32);
    let bsdf = Bsdf::rough_dielectric(eta, alpha).with_distribution(Distribution::Beckmann);
    for theta in [45.0f32, 160.0, 95.0] {
        let wo = dir_around(ng, theta, 70.0);
        let eta_r = if wo.dot(ng) > 0.0 { eta } else { 1.0 / eta };
        let name = format!("Beckmann rough dielectric alpha {alpha}, wo at {theta} deg");
        bsdf_case(CASE_N, &name, &bsdf, &sf, wo, eta_r, alpha, true);
    }
}

// ------------------------------------------------------------------------------------------
// Rough conductor
// ------------------------------------------------------------------------------------------

#[test]
fn rough_conductor_sampling_matches_pdf() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    for (i, &alpha) in ALPHAS.iter().enumerate() {
        // Alternate the Fresnel models; the pdf does not depend on them, f does.
        let fresnel = if i % 2 == 0 {
            gold()
        } else {
            ConductorFresnel::Constant(Vec3::new(0.9, 0.6, 0.3))
        };
        let bsdf = Bsdf::rough_conductor(alpha, fresnel);
        // Normal, oblique, grazing, and from below (two-sided).
        for theta in [0.0f32, 45.0, 85.0, 130.0] {
            let wo = dir_around(ng, theta, 40.0);
            let name = format!("rough conductor alpha {alpha}, wo at {theta} deg");
            bsdf_case(CASE_N, &name, &bsdf, &sf, wo, 1.0, alpha, true);
        }
    }
}

// ------------------------------------------------------------------------------------------
// Rough dielectric
// ------------------------------------------------------------------------------------------

fn rough_dielectric_cases(alphas: &[f32]) {
    let eta = 1.5;
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    for &alpha in alphas {
        let bsdf = Bsdf::rough_dielectric(eta, alpha);
        // Outside: normal, oblique, grazing. Inside (theta > 90): 20 degrees from -n (below
        // the critical angle of 41.8 degrees), 50 degrees (beyond it: the smooth interface
        // would reflect everything, the rough one still transmits through tilted facets),
        // and grazing at 85 degrees.
        for theta in [0.0f32, 45.0, 85.0, 160.0, 130.0, 95.0] {
            let wo = dir_around(ng, theta, 70.0);
            let eta_r = if wo.dot(ng) > 0.0 { eta } else { 1.0 / eta };
            let name = format!("rough dielectric alpha {alpha}, wo at {theta} deg");
            bsdf_case(CASE_N, &name, &bsdf, &sf, wo, eta_r, alpha, true);
        }
    }
}

#[test]
fn rough_dielectric_sampling_matches_pdf_smooth_alphas() {
    rough_dielectric_cases(&ALPHAS[..2]);
}

#[test]
fn rough_dielectric_sampling_matches_pdf_rough_alphas() {
    rough_dielectric_cases(&ALPHAS[2..]);
}

/// With a shading normal tilted away from the geometric one, samples whose side of ng
/// contradicts their lobe are dropped; the pdf must lose the same mass.
#[test]
fn rough_bsdfs_with_tilted_shading_normal() {
    let ng = ng_generic();
    let ns = dir_around(ng, 20.0, 0.0);
    let sf = ShadingFrame::new(ns, ng);
    let alpha = 0.3;
    for (theta, phi) in [(60.0f32, 180.0f32), (120.0, 0.0)] {
        let wo = dir_around(ng, theta, phi);
        let conductor = Bsdf::rough_conductor(alpha, gold());
        bsdf_case(
            CASE_N,
            &format!("rough conductor tilted ns, wo at ({theta}, {phi})"),
            &conductor,
            &sf,
            wo,
            1.0,
            alpha,
            true,
        );
        let eta = 1.5;
        let eta_r = if wo.dot(ns) > 0.0 { eta } else { 1.0 / eta };
        bsdf_case(
            CASE_N,
            &format!("rough dielectric tilted ns, wo at ({theta}, {phi})"),
            &Bsdf::rough_dielectric(eta, alpha),
            &sf,
            wo,
            eta_r,
            alpha,
            true,
        );
    }
}

// ------------------------------------------------------------------------------------------
// The harness must be able to fail on microfacet cases
// ------------------------------------------------------------------------------------------

#[test]
fn harness_rejects_wrong_microfacet_pdfs() {
    let ns = Vec3::Z;
    let sf = ShadingFrame::new(ns, ns);
    let mode = TransportMode::Radiance;

    // (1) Conductor sampled by visible normals, checked against the pdf of sampling the full
    // distribution D(m) cos(theta_m) (the pre-2014 scheme): D instead of D_wo.
    let alpha = 0.3;
    let ggx = Ggx::new(alpha);
    let bsdf = Bsdf::rough_conductor(alpha, ConductorFresnel::Constant(Vec3::ONE));
    let wo = dir_around(ns, 70.0, 0.0);
    let domain = lobe_domain(ns, wo, 1.0, alpha);
    let sample =
        |s: &mut dyn Sampler| Some(bsdf.sample(&sf, wo, s.next_1d(), s.next_2d(), mode)?.wi);
    let control = chi2::lobe_spherical("power: VNDF control", CASE_N, &domain, sample, |wi| {
        bsdf.pdf(&sf, wo, wi, mode) as f64
    });
    control.assert_ok();
    let wrong = |wi: Vec3| {
        if wi.z <= 0.0 {
            return 0.0;
        }
        let m = (wo + wi).normalize();
        (ggx.d(m) * m.z / (4.0 * wo.dot(m))) as f64
    };
    let r = chi2::lobe_spherical("power: D instead of D_wo", CASE_N, &domain, sample, wrong);
    println!("{r}");
    assert!(r.chi2_rejects(), "harness missed D instead of D_wo: {r}");

    // The same error, normalised over the successful share so only the shape differs (the
    // two pdfs' integrals are the two runs' masses).
    let (mass, share) = (r.mass, control.mass);
    let r = chi2::lobe_spherical(
        "power: D instead of D_wo, normalised",
        CASE_N,
        &domain,
        sample,
        |wi| wrong(wi) * share / mass,
    );
    println!("{r}");
    assert!(!r.mass_mismatch() && r.chi2_rejects(), "{r}");

    // (2) Rough dielectric from outside: transmission pdf with the Jacobian of the reflection
    // half vector's form but without eta^2 (|ci| / (eta ci + co)^2 instead of
    // |ci| / (ci + co / eta)^2), normalised to the right mass.
    let (eta, alpha) = (1.5f32, 0.3f32);
    let ggx = Ggx::new(alpha);
    let bsdf = Bsdf::rough_dielectric(eta, alpha);
    let wo = dir_around(ns, 30.0, 0.0);
    let domain = lobe_domain(ns, wo, eta, alpha);
    let sample =
        |s: &mut dyn Sampler| Some(bsdf.sample(&sf, wo, s.next_1d(), s.next_2d(), mode)?.wi);
    let right = |wi: Vec3| bsdf.pdf(&sf, wo, wi, mode) as f64;
    let control = chi2::lobe_spherical(
        "power: transmission control",
        CASE_N,
        &domain,
        sample,
        right,
    );
    control.assert_ok();
    let wrong = |wi: Vec3| {
        if wi.z >= 0.0 {
            return right(wi);
        }
        let mut m = (wo + eta * wi).normalize();
        if m.z < 0.0 {
            m = -m;
        }
        let (co, ci) = (wo.dot(m), wi.dot(m));
        if !(co > 0.0 && ci < 0.0) {
            return 0.0;
        }
        let t = 1.0 - fresnel::dielectric(co, eta).0;
        (t * ggx.d_visible(wo, m) * -ci / ((eta * ci + co) * (eta * ci + co))) as f64
    };
    // Unnormalised, the mass check sees it.
    let r = chi2::lobe_spherical(
        "power: transmission Jacobian without eta^2, unnormalised",
        CASE_N,
        &domain,
        sample,
        wrong,
    );
    println!("{r}");
    assert!(r.mass_mismatch(), "{r}");
    // Normalised to the right mass (the two pdfs' integrals are the two runs' masses), the
    // shape test sees it.
    let (mass, share) = (r.mass, control.mass);
    let r = chi2::lobe_spherical(
        "power: transmission Jacobian without eta^2",
        CASE_N,
        &domain,
        sample,
        |wi| wrong(wi) * share / mass,
    );
    println!("{r}");
    assert!(r.chi2_rejects(), "harness missed the wrong Jacobian: {r}");

    // The warped domain itself: a direction maps back to itself.
    let d = lobe_domain(ns, wo, eta, alpha);
    for w in [wo, -wo, Vec3::X, dir_around(ns, 120.0, 33.0)] {
        let x = d.to_param(w).unwrap();
        let (back, _) = d.to_dir(x).unwrap();
        assert!((back - w).length() < 1e-5, "{w} -> {x} -> {back}");
    }
}

// ------------------------------------------------------------------------------------------
// Rough plastic
// ------------------------------------------------------------------------------------------

fn plastic(alpha: f32, dist: Distribution) -> Bsdf {
    Bsdf::RoughPlastic(Box::new(RoughPlastic::new(
        Vec3::new(0.8, 0.4, 0.1),
        Vec3::ONE,
        1.49,
        alpha,
        dist,
        false,
    )))
}

/// Rough plastic (coating lobe by visible normals, or the base by cosine, in a mixture whose
/// probability depends on `wo`): chi-square of `sample` against `pdf`, with `f` and `pdf` of
/// each sample equal to `eval()` and `pdf()`, GGX and Beckmann, normal and oblique incidence
/// and from below (two-sided).
#[test]
fn rough_plastic_sampling_matches_pdf() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    for (dist, alpha) in [
        (Distribution::Ggx, 0.05f32),
        (Distribution::Ggx, 0.3),
        (Distribution::Beckmann, 0.1),
    ] {
        let bsdf = plastic(alpha, dist);
        for theta in [0.0f32, 70.0, 130.0] {
            let wo = dir_around(ng, theta, 40.0);
            let name = format!("rough plastic {dist:?} alpha {alpha}, wo at {theta} deg");
            bsdf_case(CASE_N, &name, &bsdf, &sf, wo, 1.0, alpha, false);
        }
    }
}

/// Rough plastic against Mitsuba 3's own (`roughplastic`, version 3.9.1): `f |cos_i|` and the
/// density at 12 direction pairs for each of GGX 0.2, Beckmann 0.05 and GGX 0.5 (eta 1.5,
/// base (0.8, 0.4, 0.1)), from `python3 benches/reference/mitsuba_roughplastic.py`. The
/// coating's tables are the same quadratures (Gauss-Legendre nodes as Mitsuba's) through
/// each renderer's own visible-normal sampler, so they agree to rounding, not to the last
/// bit: measured within 6.8e-4 relative for the values (asserted 1e-3) and 2.6e-3 for the
/// densities (asserted 5e-3; the density, which decides noise, not the image, differs most
/// at normal incidence, through the lobe-choice weight). A coating transmittance of
/// `1 - reflectance` (Mitsuba 2's choice) puts the value at 80 degrees (GGX 0.2, towards the
/// normal) 12 % above Mitsuba's.
#[test]
// The reference values as the script prints them.
#[allow(clippy::excessive_precision)]
fn rough_plastic_matches_mitsuba() {
    #[rustfmt::skip]
    let reference: &[(&str, f32, f32, f32, f32, f64, f64)] = &[
        ("ggx", 0.2, 0.0, 0.0, 0.0, 2.814512e-01, 4.745127e-01),
        ("ggx", 0.2, 0.0, 30.0, 180.0, 1.855925e-01, 2.772438e-01),
        ("ggx", 0.2, 0.0, 0.0, 180.0, 2.814512e-01, 4.745127e-01),
        ("ggx", 0.2, 0.0, 60.0, 90.0, 9.641904e-02, 1.480735e-01),
        ("ggx", 0.2, 45.0, 0.0, 0.0, 2.034744e-01, 2.944917e-01),
        ("ggx", 0.2, 45.0, 30.0, 180.0, 2.323763e-01, 4.235635e-01),
        ("ggx", 0.2, 45.0, 45.0, 180.0, 2.758388e-01, 5.608943e-01),
        ("ggx", 0.2, 45.0, 60.0, 90.0, 9.373343e-02, 1.407868e-01),
        ("ggx", 0.2, 80.0, 0.0, 0.0, 1.616423e-01, 2.131509e-01),
        ("ggx", 0.2, 80.0, 30.0, 180.0, 1.589127e-01, 2.977171e-01),
        ("ggx", 0.2, 80.0, 80.0, 180.0, 2.836887e+00, 3.998545e+00),
        ("ggx", 0.2, 80.0, 60.0, 90.0, 7.530674e-02, 9.985778e-02),
        ("beckmann", 0.05, 0.0, 0.0, 0.0, 1.525147e+00, 3.082511e+00),
        ("beckmann", 0.05, 0.0, 30.0, 180.0, 2.177964e-01, 2.514839e-01),
        ("beckmann", 0.05, 0.0, 0.0, 180.0, 1.525147e+00, 3.082511e+00),
        ("beckmann", 0.05, 0.0, 60.0, 90.0, 1.194348e-01, 1.451943e-01),
        ("beckmann", 0.05, 45.0, 0.0, 0.0, 2.491646e-01, 2.835428e-01),
        ("beckmann", 0.05, 45.0, 30.0, 180.0, 2.174335e-01, 2.505174e-01),
        ("beckmann", 0.05, 45.0, 45.0, 180.0, 2.435858e+00, 5.117297e+00),
        ("beckmann", 0.05, 45.0, 60.0, 90.0, 1.181342e-01, 1.417714e-01),
        ("beckmann", 0.05, 80.0, 0.0, 0.0, 1.624235e-01, 1.315056e-01),
        ("beckmann", 0.05, 80.0, 30.0, 180.0, 1.404294e-01, 1.138872e-01),
        ("beckmann", 0.05, 80.0, 80.0, 180.0, 7.108725e+01, 1.075992e+02),
        ("beckmann", 0.05, 80.0, 60.0, 90.0, 7.700840e-02, 6.575279e-02),
        ("ggx", 0.5, 0.0, 0.0, 0.0, 1.536348e-01, 3.183099e-01),
        ("ggx", 0.5, 0.0, 30.0, 180.0, 1.286792e-01, 2.686273e-01),
        ("ggx", 0.5, 0.0, 0.0, 180.0, 1.536348e-01, 3.183099e-01),
        ("ggx", 0.5, 0.0, 60.0, 90.0, 6.664865e-02, 1.520862e-01),
        ("ggx", 0.5, 45.0, 0.0, 0.0, 1.425611e-01, 2.943874e-01),
        ("ggx", 0.5, 45.0, 30.0, 180.0, 1.310282e-01, 2.987292e-01),
        ("ggx", 0.5, 45.0, 45.0, 180.0, 1.106317e-01, 2.673697e-01),
        ("ggx", 0.5, 45.0, 60.0, 90.0, 6.272870e-02, 1.412988e-01),
        ("ggx", 0.5, 80.0, 0.0, 0.0, 1.100850e-01, 2.473965e-01),
        ("ggx", 0.5, 80.0, 30.0, 180.0, 1.131625e-01, 3.342446e-01),
        ("ggx", 0.5, 80.0, 80.0, 180.0, 1.898269e-01, 5.039442e-01),
        ("ggx", 0.5, 80.0, 60.0, 90.0, 4.874431e-02, 1.180488e-01),
    ];
    let ng = Vec3::Z;
    let sf = ShadingFrame::new(ng, ng);
    let d = |theta: f32, phi: f32| {
        let (t, p) = (theta.to_radians(), phi.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    };
    let mut worst = [0.0f64; 2];
    for &(dist, alpha, theta_in, theta_out, phi, value, pdf) in reference {
        let dist = if dist == "ggx" {
            Distribution::Ggx
        } else {
            Distribution::Beckmann
        };
        let bsdf = Bsdf::RoughPlastic(Box::new(RoughPlastic::new(
            Vec3::new(0.8, 0.4, 0.1),
            Vec3::ONE,
            1.5,
            alpha,
            dist,
            false,
        )));
        let (wo, wi) = (d(theta_in, 0.0), d(theta_out, phi));
        let mode = TransportMode::Radiance;
        let ours = (bsdf.eval(&sf, wo, wi, mode).x * wi.z) as f64;
        let our_pdf = bsdf.pdf(&sf, wo, wi, mode) as f64;
        for (k, (what, a, b, tolerance)) in
            [("value", ours, value, 1e-3), ("pdf", our_pdf, pdf, 5e-3)]
                .into_iter()
                .enumerate()
        {
            let rel = (a - b).abs() / b;
            worst[k] = worst[k].max(rel);
            assert!(
                rel < tolerance,
                "{dist:?} alpha {alpha}, {theta_in} -> ({theta_out}, {phi}): {what} {a} against Mitsuba's {b}"
            );
        }
    }
    eprintln!(
        "worst relative difference from Mitsuba: value {:.1e}, pdf {:.1e}",
        worst[0], worst[1]
    );
}
