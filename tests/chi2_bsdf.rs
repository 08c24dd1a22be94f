//! Statistical tests of the BSDFs' sampling routines against their densities.
//!
//! * Diffuse: chi-square over the sphere of directions (see `common/chi2.rs`) for several
//!   `wo` on both sides, both transport modes, with the shading normal equal to the geometric
//!   one and tilted away from it; per sample, the reported `pdf` and `f` must match `pdf()` and
//!   `eval()`, and `weight == f |cos| / pdf`. Plus reciprocity.
//! * Delta BSDFs (conductor, dielectric): a density over directions does not exist, so the
//!   tests check the laws of reflection and refraction, the Fresnel choice between the lobes
//!   (exact binomial test at the suite's corrected alpha), the lobe probabilities and weights,
//!   total internal reflection, and that `eval` and `pdf` are zero.
//! * The harness itself: it must reject deliberately mismatched sampler/pdf pairs.

use crate::common;

use common::chi2::{self, SphereDomain};
use common::{Failures, MODES, close, close3, dir_around, ng_generic};
use glam::{DVec2, Vec2, Vec3};
use lodestar::bsdf::{Bsdf, ShadingFrame, TransportMode, fresnel};
use lodestar::math::{Sampler, warp};
use std::f32::consts::PI;

/// Samples per chi-square case over directions.
pub(crate) const N_DIR: usize = 1_000_000;
/// Samples per (BSDF, wo) configuration of the delta BSDFs.
const N_DELTA: usize = 200_000;

/// A shading normal tilted by `deg` degrees from `ng` (towards the frame's s axis).
pub(crate) fn tilted(ng: Vec3, deg: f32) -> Vec3 {
    dir_around(ng, deg, 0.0)
}

// ------------------------------------------------------------------------------------------
// Diffuse
// ------------------------------------------------------------------------------------------

/// One chi-square case of the diffuse BSDF, with all per-sample checks.
fn diffuse_case(name: &str, sf: &ShadingFrame, wo: Vec3, mode: TransportMode) {
    let bsdf = Bsdf::Diffuse {
        albedo: Vec3::new(0.8, 0.5, 0.2),
    };
    let ns = sf.frame.n;
    let mut fails = Failures::new();
    let report = chi2::spherical(
        name,
        N_DIR,
        &SphereDomain::full_around(sf.ng),
        |s: &mut dyn Sampler| {
            let u_lobe = s.next_1d();
            let u = s.next_2d();
            let smp = bsdf.sample(sf, wo, u_lobe, u, mode)?;
            let wi = smp.wi;
            let pdf = bsdf.pdf(sf, wo, wi, mode);
            let f = bsdf.eval(sf, wo, wi, mode);
            fails.check(close(smp.pdf as f64, pdf as f64, 1e-3, 1e-6), || {
                format!("sample pdf {} != pdf() {} at wi {wi}", smp.pdf, pdf)
            });
            fails.check(close3(smp.f, f, 1e-3, 1e-7), || {
                format!("sample f {} != eval() {} at wi {wi}", smp.f, f)
            });
            let w = f * wi.dot(ns).abs() / pdf;
            fails.check(close3(smp.weight, w, 1e-3, 1e-6), || {
                format!("weight {} != f |cos| / pdf = {w} at wi {wi}", smp.weight)
            });
            fails.check(!smp.delta && !smp.transmission && smp.eta == 1.0, || {
                format!(
                    "flags: delta {} transmission {} eta {}",
                    smp.delta, smp.transmission, smp.eta
                )
            });
            fails.check((wi.length() - 1.0).abs() < 1e-4, || {
                format!("|wi| = {}", wi.length())
            });
            fails.check(
                wi.dot(ns) * wo.dot(ns) > 0.0 && wi.dot(sf.ng) * wo.dot(sf.ng) > 0.0,
                || format!("wi {wi} not on the side of wo {wo} of both normals"),
            );
            Some(wi)
        },
        |wi| bsdf.pdf(sf, wo, wi, mode) as f64,
    );
    report.assert_ok();
    fails.assert_none(name);
}

/// Polar angles (degrees from ng) of wo: above, grazing, and below (the diffuse BSDF is
/// two-sided).
const WO_THETAS: [f32; 6] = [0.0, 35.0, 75.0, 88.0, 130.0, 178.0];

fn diffuse_aligned(mode: TransportMode) {
    for (k, ng) in [Vec3::Z, ng_generic()].into_iter().enumerate() {
        let sf = ShadingFrame::new(ng, ng);
        for &theta in &WO_THETAS {
            let wo = dir_around(ng, theta, 40.0 + 25.0 * k as f32);
            diffuse_case(
                &format!("diffuse {mode:?} ns == ng #{k}, wo at {theta} deg"),
                &sf,
                wo,
                mode,
            );
        }
    }
}

#[test]
fn diffuse_aligned_radiance() {
    diffuse_aligned(TransportMode::Radiance);
}

#[test]
fn diffuse_aligned_importance() {
    diffuse_aligned(TransportMode::Importance);
}

/// Shading normal tilted by 25 degrees: samples below the geometric horizon are rejected, so
/// the successful share is below one and the pdf must lose the same mass. The wo include ones
/// on different sides of ns and ng (phi = 180 at 80 degrees puts wo above ng but below ns).
fn diffuse_tilted(mode: TransportMode) {
    let ng = ng_generic();
    let ns = tilted(ng, 25.0);
    let sf = ShadingFrame::new(ns, ng);
    for (theta, phi) in [
        (0.0, 0.0),
        (50.0, 0.0),
        (50.0, 180.0),
        (80.0, 180.0),
        (80.0, 90.0),
        (120.0, 0.0),
        (110.0, 0.0),
    ] {
        let wo = dir_around(ng, theta, phi);
        diffuse_case(
            &format!("diffuse {mode:?} tilted ns, wo at ({theta}, {phi}) deg"),
            &sf,
            wo,
            mode,
        );
    }
}

#[test]
fn diffuse_tilted_radiance() {
    diffuse_tilted(TransportMode::Radiance);
}

#[test]
fn diffuse_tilted_importance() {
    diffuse_tilted(TransportMode::Importance);
}

/// Random directions on the sphere for the deterministic checks.
fn random_dir(s: &mut dyn Sampler) -> Vec3 {
    warp::square_to_uniform_sphere(s.next_2d())
}

#[test]
fn diffuse_is_reciprocal_and_eval_matches_pdf_support() {
    let albedo = Vec3::new(0.8, 0.5, 0.2);
    let bsdf = Bsdf::Diffuse { albedo };
    let ng = ng_generic();
    let mut s = chi2::sampler_for("diffuse reciprocity");
    let mut fails = Failures::new();
    let mut nonzero = 0;
    for (ns, modes) in [
        (ng, &MODES[..]),
        // Importance mode with a shading normal is deliberately not reciprocal (Veach's
        // adjoint correction), so only radiance mode is checked there.
        (tilted(ng, 25.0), &MODES[..1]),
    ] {
        let sf = ShadingFrame::new(ns, ng);
        for &mode in modes {
            for _ in 0..100_000 {
                let (wo, wi) = (random_dir(&mut s), random_dir(&mut s));
                let (a, b) = (bsdf.eval(&sf, wo, wi, mode), bsdf.eval(&sf, wi, wo, mode));
                fails.check(close3(a, b, 1e-6, 0.0), || {
                    format!("{mode:?}: eval(wo, wi) = {a} != eval(wi, wo) = {b}")
                });
                let pdf = bsdf.pdf(&sf, wo, wi, mode);
                fails.check((a != Vec3::ZERO) == (pdf > 0.0), || {
                    format!("{mode:?}: eval {a} and pdf {pdf} disagree on the support")
                });
                if a != Vec3::ZERO {
                    nonzero += 1;
                    fails.check(close3(a, albedo / PI, 1e-6, 0.0), || {
                        format!("{mode:?}: eval {a} != albedo / pi")
                    });
                }
            }
        }
    }
    fails.assert_none("diffuse reciprocity");
    assert!(nonzero > 50_000, "too few non-zero pairs: {nonzero}");
}

#[test]
fn diffuse_tilted_importance_weight_has_adjoint_correction() {
    // In importance mode with ns != ng, f gains |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|).
    let bsdf = Bsdf::Diffuse { albedo: Vec3::ONE };
    let ng = ng_generic();
    let sf = ShadingFrame::new(tilted(ng, 25.0), ng);
    let ns = sf.frame.n;
    let wo = dir_around(ng, 40.0, 30.0);
    let mut s = chi2::sampler_for("diffuse adjoint correction");
    let mut fails = Failures::new();
    for _ in 0..10_000 {
        let (ul, u) = (s.next_1d(), s.next_2d());
        let (Some(r), Some(i)) = (
            bsdf.sample(&sf, wo, ul, u, TransportMode::Radiance),
            bsdf.sample(&sf, wo, ul, u, TransportMode::Importance),
        ) else {
            continue;
        };
        let wi = r.wi;
        let corr = wo.dot(ns).abs() * wi.dot(ng).abs() / (wo.dot(ng).abs() * wi.dot(ns).abs());
        fails.check(close3(i.weight, r.weight * corr, 1e-4, 1e-7), || {
            format!(
                "importance weight {} != radiance weight {} x {corr}",
                i.weight, r.weight
            )
        });
        fails.check(close3(r.weight, Vec3::ONE, 1e-4, 0.0), || {
            format!("radiance weight {} != albedo", r.weight)
        });
    }
    fails.assert_none("diffuse adjoint correction");
}

#[test]
fn black_absorbs_everything() {
    let sf = ShadingFrame::new(Vec3::Z, Vec3::Z);
    let mut s = chi2::sampler_for("black");
    for _ in 0..1000 {
        let (wo, wi) = (random_dir(&mut s), random_dir(&mut s));
        for mode in MODES {
            assert!(
                Bsdf::Black
                    .sample(&sf, wo, s.next_1d(), s.next_2d(), mode)
                    .is_none()
            );
            assert_eq!(Bsdf::Black.eval(&sf, wo, wi, mode), Vec3::ZERO);
            assert_eq!(Bsdf::Black.pdf(&sf, wo, wi, mode), 0.0);
        }
    }
}

// ------------------------------------------------------------------------------------------
// Conductor
// ------------------------------------------------------------------------------------------

pub(crate) fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

#[test]
fn conductor_is_a_mirror() {
    let reflectance = Vec3::new(0.9, 0.6, 0.3);
    let bsdf = Bsdf::Conductor { reflectance };
    let ng = ng_generic();
    let mut s = chi2::sampler_for("conductor");
    let mut fails = Failures::new();
    let mut count = 0;
    for ns in [ng, tilted(ng, 20.0)] {
        let sf = ShadingFrame::new(ns, ng);
        for _ in 0..20_000 {
            let wo = random_dir(&mut s);
            for mode in MODES {
                let Some(smp) = bsdf.sample(&sf, wo, s.next_1d(), s.next_2d(), mode) else {
                    // Only allowed when the mirrored direction crosses the geometric horizon.
                    let wr = reflect(wo, ns);
                    fails.check(ns != ng && wr.dot(ng) * wo.dot(ng) <= 0.0, || {
                        format!("no sample for wo {wo} although the mirror direction is valid")
                    });
                    continue;
                };
                count += 1;
                let wi = smp.wi;
                fails.check(close3(wi, reflect(wo, ns), 0.0, 1e-5), || {
                    format!("wi {wi} is not the mirror of wo {wo}")
                });
                fails.check(smp.delta && !smp.transmission && smp.pdf == 1.0, || {
                    format!("flags/pdf: {smp:?}")
                });
                // weight = reflectance, corrected in importance mode for shading normals.
                let corr = if mode == TransportMode::Importance && ns != ng {
                    wo.dot(ns).abs() * wi.dot(ng).abs() / (wo.dot(ng).abs() * wi.dot(ns).abs())
                } else {
                    1.0
                };
                fails.check(close3(smp.weight, reflectance * corr, 1e-4, 1e-6), || {
                    format!("weight {} != reflectance x {corr}", smp.weight)
                });
                // f |cos| / pdf == weight; f carries 1 / |cos| computed in the local frame, so
                // allow for the f32 rounding of cos near grazing.
                let cos = wi.dot(ns).abs();
                fails.check(
                    close3(smp.f * cos, smp.weight, 1e-4 + 1e-7 / cos as f64, 0.0),
                    || format!("f {} x |cos| {cos} != weight {}", smp.f, smp.weight),
                );
                fails.check(
                    bsdf.eval(&sf, wo, wi, mode) == Vec3::ZERO
                        && bsdf.pdf(&sf, wo, wi, mode) == 0.0,
                    || "delta eval/pdf not zero at the mirror direction".to_string(),
                );
            }
        }
    }
    fails.assert_none("conductor");
    assert!(count > 60_000);
}

// ------------------------------------------------------------------------------------------
// Dielectric
// ------------------------------------------------------------------------------------------

/// Samples a dielectric `N_DELTA` times from `wo` in both modes (same random numbers), checks
/// every sample, and tests the reflection count against the Fresnel reflectance.
fn dielectric_case(eta: f32, n: Vec3, wo: Vec3, expect_tir: bool) {
    let name = format!("dielectric eta {eta}, wo.n = {:.4}", wo.dot(n));
    let bsdf = Bsdf::Dielectric { eta };
    let sf = ShadingFrame::new(n, n);
    let cos_o = wo.dot(n);
    let (f_r, cos_t, eta_rel) = fresnel::dielectric(cos_o, eta);
    let outside = cos_o > 0.0;
    // n_t / n_i: eta leaving the outside, 1 / eta leaving the inside.
    let eta_expected = if outside { eta } else { 1.0 / eta };
    assert!(close(eta_rel as f64, eta_expected as f64, 1e-6, 0.0));
    assert_eq!(
        f_r == 1.0,
        expect_tir,
        "{name}: F = {f_r}, TIR expected: {expect_tir}"
    );
    let wo_tan = wo - cos_o * n;
    let mut s = chi2::sampler_for(&name);
    let mut fails = Failures::new();
    let mut reflections = 0u64;
    for _ in 0..N_DELTA {
        let (ul, u) = (s.next_1d(), s.next_2d());
        let mut chosen = None;
        for mode in MODES {
            let Some(smp) = bsdf.sample(&sf, wo, ul, u, mode) else {
                fails.check(false, || format!("{mode:?}: no sample (u_lobe {ul})"));
                continue;
            };
            let wi = smp.wi;
            // Both modes make the same choice from the same numbers.
            match chosen {
                None => chosen = Some(smp.transmission),
                Some(t) => fails.check(t == smp.transmission, || "modes disagree".to_string()),
            }
            fails.check(smp.delta, || "not delta".to_string());
            fails.check((wi.length() - 1.0).abs() < 1e-5, || {
                format!("|wi| = {}", wi.length())
            });
            fails.check(
                bsdf.eval(&sf, wo, wi, mode) == Vec3::ZERO && bsdf.pdf(&sf, wo, wi, mode) == 0.0,
                || "delta eval/pdf not zero".to_string(),
            );
            let cos_i = wi.dot(n);
            if !smp.transmission {
                // (a) law of reflection, (c) pdf = F, (d) weight = F |cos| / (F |cos|) = 1.
                fails.check(close3(wi, reflect(wo, n), 0.0, 1e-5), || {
                    format!("reflection {wi} is not the mirror of {wo}")
                });
                fails.check(close(smp.pdf as f64, f_r as f64, 1e-6, 0.0), || {
                    format!("reflection pdf {} != F {f_r}", smp.pdf)
                });
                fails.check(smp.eta == 1.0, || format!("reflection eta {}", smp.eta));
                fails.check(close3(smp.weight, Vec3::ONE, 1e-5, 0.0), || {
                    format!("{mode:?} reflection weight {} != 1", smp.weight)
                });
                fails.check(
                    close3(smp.f * cos_i.abs() / smp.pdf, smp.weight, 1e-5, 0.0),
                    || "reflection f |cos| / pdf != weight".to_string(),
                );
            } else {
                // (a) Snell: sin_t = sin_i / eta_rel, in the plane of incidence, other side.
                fails.check(cos_i * cos_o < 0.0, || {
                    format!("refraction {wi} on the side of wo")
                });
                let wi_tan = wi - cos_i * n;
                fails.check(close3(wi_tan, -wo_tan / eta_expected, 0.0, 2e-6), || {
                    format!(
                        "Snell: tangential part {wi_tan} != -{wo_tan} / {eta_expected} \
                         (sin_t {} vs sin_i / eta {})",
                        wi_tan.length(),
                        wo_tan.length() / eta_expected
                    )
                });
                fails.check(close(cos_i.abs() as f64, cos_t as f64, 0.0, 1e-6), || {
                    format!("|cos_t| {} != Fresnel's {cos_t}", cos_i.abs())
                });
                // (c) pdf = 1 - F.
                fails.check(close(smp.pdf as f64, (1.0 - f_r) as f64, 1e-6, 0.0), || {
                    format!("transmission pdf {} != 1 - F {}", smp.pdf, 1.0 - f_r)
                });
                fails.check(
                    close(smp.eta as f64, eta_expected as f64, 1e-6, 0.0),
                    || format!("transmission eta {} != {eta_expected}", smp.eta),
                );
                // (d) weight 1 in importance mode, 1 / eta_rel^2 in radiance mode.
                let w = match mode {
                    TransportMode::Importance => 1.0,
                    TransportMode::Radiance => 1.0 / (eta_expected * eta_expected),
                };
                fails.check(close3(smp.weight, Vec3::splat(w), 1e-5, 0.0), || {
                    format!("{mode:?} transmission weight {} != {w}", smp.weight)
                });
                fails.check(
                    close3(smp.f * cos_i.abs() / smp.pdf, smp.weight, 1e-4, 0.0),
                    || "transmission f |cos| / pdf != weight".to_string(),
                );
            }
        }
        if chosen == Some(false) {
            reflections += 1;
        }
    }
    fails.assert_none(&name);
    // (b) the choice follows the Fresnel reflectance.
    chi2::assert_binomial(&name, reflections, N_DELTA as u64, f_r as f64);
}

#[test]
fn dielectric_from_outside() {
    let n = ng_generic();
    for eta in [1.5, 1.33, 1.0 / 1.5] {
        // Outside, never TIR (for eta < 1 the outside is the denser medium: TIR beyond
        // asin(eta) = 41.8 degrees, tested below).
        for theta in [0.0, 30.0, 60.0, 80.0, 89.0] {
            let tir = eta < 1.0 && theta > 41.82;
            dielectric_case(eta, n, dir_around(n, theta, 70.0), tir);
        }
    }
}

#[test]
fn dielectric_from_inside_and_total_internal_reflection() {
    let n = ng_generic();
    for eta in [1.5f32, 1.33] {
        // Critical angles: 41.81 deg (1.5), 48.75 deg (1.33).
        let critical = (1.0 / eta).asin().to_degrees();
        for theta in [0.0, 20.0, 40.0, 45.0, 50.0, 70.0, 89.0] {
            let wo = dir_around(-n, theta, 200.0);
            dielectric_case(eta, n, wo, theta > critical);
        }
    }
    // Just below and above the critical angle of glass.
    let critical = (1.0f32 / 1.5).asin().to_degrees();
    dielectric_case(1.5, n, dir_around(-n, critical - 0.5, 10.0), false);
    dielectric_case(1.5, n, dir_around(-n, critical + 0.5, 10.0), true);
}

#[test]
fn dielectric_with_shading_normal_never_leaks() {
    // With ns != ng the lobes are chosen with the Fresnel term of ns, and samples whose side of
    // ng contradicts the lobe (reflection through the surface, transmission that stays) are
    // dropped rather than leaking light.
    let eta = 1.5;
    let bsdf = Bsdf::Dielectric { eta };
    let ng = ng_generic();
    let ns = tilted(ng, 20.0);
    let sf = ShadingFrame::new(ns, ng);
    let mut s = chi2::sampler_for("dielectric tilted");
    let mut fails = Failures::new();
    let (mut some, mut none) = (0, 0);
    for _ in 0..100_000 {
        let wo = random_dir(&mut s);
        let (ul, u) = (s.next_1d(), s.next_2d());
        for mode in MODES {
            let Some(smp) = bsdf.sample(&sf, wo, ul, u, mode) else {
                none += 1;
                continue;
            };
            some += 1;
            let (f_r, _, _) = fresnel::dielectric(wo.dot(ns), eta);
            let lobe_p = if smp.transmission { 1.0 - f_r } else { f_r };
            fails.check(close(smp.pdf as f64, lobe_p as f64, 1e-5, 1e-7), || {
                format!("pdf {} != lobe probability {lobe_p}", smp.pdf)
            });
            let crosses_ng = smp.wi.dot(ng) * wo.dot(ng) < 0.0;
            let crosses_ns = smp.wi.dot(ns) * wo.dot(ns) < 0.0;
            fails.check(
                crosses_ng == smp.transmission && crosses_ns == smp.transmission,
                || {
                    format!(
                        "{mode:?}: wo {wo} wi {} transmission {}",
                        smp.wi, smp.transmission
                    )
                },
            );
            fails.check(
                smp.weight.is_finite() && smp.weight.min_element() > 0.0,
                || format!("weight {}", smp.weight),
            );
        }
    }
    fails.assert_none("dielectric tilted");
    assert!(some > 150_000 && none > 0, "{some} samples, {none} dropped");
}

// ------------------------------------------------------------------------------------------
// The harness must be able to fail
// ------------------------------------------------------------------------------------------

fn cosine_sampler(s: &mut dyn Sampler) -> Option<Vec3> {
    Some(warp::square_to_cosine_hemisphere(s.next_2d()))
}

#[test]
fn harness_rejects_mismatched_pdfs() {
    let domain = SphereDomain::full();
    let cos_pdf = |w: Vec3| (w.z.max(0.0) / PI) as f64;

    // Control: the matching pair passes.
    chi2::spherical("power: control", N_DIR, &domain, cosine_sampler, cos_pdf).assert_ok();

    // The perturbation (1 + 0.1 cos theta), normalised: only the chi-square test can see it.
    let norm = 1.0 + 0.1 * 2.0 / 3.0;
    let r = chi2::spherical("power: shape", N_DIR, &domain, cosine_sampler, |w| {
        cos_pdf(w) * (1.0 + 0.1 * w.z.max(0.0) as f64) / norm
    });
    println!("{r}");
    assert!(!r.mass_mismatch(), "{r}");
    assert!(
        r.chi2_rejects(),
        "harness missed a normalised shape error: {r}"
    );

    // The perturbation of the brief, unnormalised: (1 + 0.1 cos theta).
    let r = chi2::spherical("power: unnormalised", N_DIR, &domain, cosine_sampler, |w| {
        cos_pdf(w) * (1.0 + 0.1 * w.z.max(0.0) as f64)
    });
    println!("{r}");
    assert!(r.mass_mismatch() && r.chi2_rejects(), "{r}");

    // Uniform hemisphere pdf for a cosine sampler.
    let r = chi2::spherical("power: uniform", N_DIR, &domain, cosine_sampler, |w| {
        if w.z > 0.0 {
            1.0 / (2.0 * PI as f64)
        } else {
            0.0
        }
    });
    assert!(r.chi2_rejects(), "{r}");

    // Right shape, but 0.5 % of the draws silently fail: the mass check must see it.
    let r = chi2::spherical(
        "power: lost mass",
        N_DIR,
        &domain,
        |s| {
            let w = cosine_sampler(s);
            if s.next_1d() < 0.005 { None } else { w }
        },
        cos_pdf,
    );
    println!("{r}");
    // The shape is right, so only the mass check can see it.
    assert!(r.mass_mismatch() && r.rejected(), "{r}");

    // Samples where the pdf is zero (a sampler leaking below the horizon).
    let r = chi2::spherical(
        "power: leak",
        N_DIR,
        &domain,
        |s| {
            let w = cosine_sampler(s)?;
            if s.next_1d() < 0.001 {
                Some(-w)
            } else {
                Some(w)
            }
        },
        cos_pdf,
    );
    println!("{r}");
    assert!(r.rejected() && r.zero_pdf > 0, "{r}");
}

#[test]
fn harness_rejects_mismatched_planar_and_discrete() {
    let (lo, hi) = (Vec2::ZERO, Vec2::new(2.0, 1.0));
    let sample = |s: &mut dyn Sampler| Some(s.next_2d() * Vec2::new(2.0, 1.0));
    chi2::planar(
        "power: planar control",
        N_DIR,
        lo,
        hi,
        [32, 32],
        sample,
        |_| 0.5,
    )
    .assert_ok();
    // A +-10 % linear tilt, normalised.
    let r = chi2::planar("power: planar tilt", N_DIR, lo, hi, [32, 32], sample, |p| {
        0.5 * (1.0 + 0.1 * (p.x as f64 - 1.0))
    });
    println!("{r}");
    assert!(r.chi2_rejects() && !r.mass_mismatch(), "{r}");

    let probs = [0.1, 0.2, 0.3, 0.4];
    let pick = |s: &mut dyn Sampler| {
        let u = s.next_1d() as f64;
        Some(if u < 0.1 {
            0
        } else if u < 0.3 {
            1
        } else if u < 0.6 {
            2
        } else {
            3
        })
    };
    chi2::discrete("power: discrete control", N_DIR, &probs, pick).assert_ok();
    let r = chi2::discrete("power: discrete", N_DIR, &[0.1, 0.2, 0.305, 0.395], pick);
    assert!(r.chi2_rejects(), "{r}");
    let r = chi2::discrete("power: discrete zero", N_DIR, &[0.0, 0.3, 0.3, 0.4], pick);
    assert!(r.rejected(), "{r}");
}

#[test]
fn statistics_helpers_are_right() {
    // Binomial: the centre has p-value 1, a 5-sigma deviation is rejected.
    assert_eq!(chi2::binomial_p_value(500, 1000, 0.5), 1.0);
    assert!(chi2::binomial_p_value(580, 1000, 0.5) < 1e-6);
    assert!(
        chi2::binomial_p_value(0, 1000, 0.0) == 1.0 && chi2::binomial_p_value(1, 1000, 0.0) == 0.0
    );
    // Pearson on exact counts: statistic 0, p = 1; a known value: chi2 = 4 on 1 dof.
    let p = chi2::pearson(&[10.0, 20.0, 30.0], &[10.0, 20.0, 30.0]);
    assert_eq!((p.statistic, p.dof), (0.0, 2));
    assert!((p.p_value - 1.0).abs() < 1e-12);
    let p = chi2::pearson(&[60.0, 40.0], &[50.0, 50.0]);
    assert!((p.statistic - 4.0).abs() < 1e-12 && p.dof == 1);
    assert!((p.p_value - 0.045_500_263_9).abs() < 1e-8, "{}", p.p_value);
    // Pooling: the cells under 5 merge.
    let p = chi2::pearson(&[1.0, 2.0, 3.0, 100.0], &[2.0, 2.0, 2.0, 100.0]);
    assert_eq!((p.pooled, p.cells, p.dof), (3, 2, 1));
    // The integration resolves a discontinuity: a disk's indicator over a square.
    let rect = chi2::Rect::new(DVec2::splat(-1.0), DVec2::splat(1.0), [8, 8]);
    let area = chi2::integrate(&rect, &|x: DVec2| if x.length() < 0.8 { 1.0 } else { 0.0 });
    assert!((area - std::f64::consts::PI * 0.64).abs() < 1e-4, "{area}");
    // Alpha: Sidak for a 1 % family rate.
    let a = chi2::alpha();
    assert!((1.0 - (1.0 - a).powi(chi2::SUITE_TESTS as i32) - 0.01).abs() < 1e-9);
}

// ------------------------------------------------------------------------------------------
// Thin dielectric
// ------------------------------------------------------------------------------------------

/// A thin dielectric sheet from both sides and from normal to grazing incidence, in both
/// modes: every sample is the mirror direction or straight through (`wi = -wo`), a delta
/// sample of weight 1 whose `pdf` is `delta_lobe_probability`, with `eta` 1 (no radiance
/// scaling); the reflection count follows `2 R / (1 + R)` (binomial test at the suite's
/// level, as the dielectric's), and that reflectance is Mitsuba 3's `thindielectric`'s
/// (`python3 benches/reference/mitsuba_thindielectric.py`, bisection to 1e-7; asserted to
/// 1e-5).
#[test]
fn thin_dielectric_reflects_as_mitsuba() {
    #[rustfmt::skip]
    let reference: &[(f32, f32, f64)] = &[
        (1.5, 0.0, 0.0769231),
        (1.5, 30.0, 0.0797345),
        (1.5, 60.0, 0.1637675),
        (1.5, 80.0, 0.5587709),
        (1.5, 89.0, 0.9496819),
        (1.33, 0.0, 0.0393297),
        (1.33, 30.0, 0.0413519),
        (1.33, 60.0, 0.1116499),
        (1.33, 80.0, 0.5151266),
        (1.33, 89.0, 0.9451736),
    ];
    let n = ng_generic();
    let sf = ShadingFrame::new(n, n);
    for &(eta, theta, r_mitsuba) in reference {
        let bsdf = Bsdf::ThinDielectric { eta };
        for side in [1.0f32, -1.0] {
            let wo = dir_around(side * n, theta, 25.0);
            let name = format!("thin dielectric eta {eta}, theta {theta}, side {side}");
            let mirror = 2.0 * wo.dot(n) * n - wo;
            let mut s = chi2::sampler_for(&name);
            let mut fails = Failures::new();
            let mut reflections = 0u64;
            let n_samples = N_DELTA / 4;
            for _ in 0..n_samples {
                let (ul, u) = (s.next_1d(), s.next_2d());
                for mode in MODES {
                    let Some(smp) = bsdf.sample(&sf, wo, ul, u, mode) else {
                        fails.check(false, || format!("{mode:?}: no sample"));
                        continue;
                    };
                    let reflected = !smp.transmission;
                    let expected = if reflected { mirror } else { -wo };
                    fails.check((smp.wi - expected).length() < 1e-5, || {
                        format!("{mode:?}: wi {} expected {expected}", smp.wi)
                    });
                    let p = bsdf.delta_lobe_probability(&sf, wo, smp.wi);
                    fails.check(
                        smp.delta
                            && smp.eta == 1.0
                            && close(smp.pdf as f64, p as f64, 1e-6, 0.0)
                            && close3(smp.weight, Vec3::ONE, 1e-4, 0.0),
                        || format!("{mode:?}: {smp:?}, lobe probability {p}"),
                    );
                    if mode == TransportMode::Radiance && reflected {
                        reflections += 1;
                    }
                }
            }
            fails.assert_none(&name);
            let r = bsdf.delta_lobe_probability(&sf, wo, mirror) as f64;
            assert!(
                (r - r_mitsuba).abs() < 1e-5,
                "{name}: reflectance {r} against Mitsuba's {r_mitsuba}"
            );
            chi2::assert_binomial(&name, reflections, n_samples as u64, r);
        }
    }
}

// ------------------------------------------------------------------------------------------
// Rough diffuse (Oren-Nayar)
// ------------------------------------------------------------------------------------------

/// The rough diffuse model: cosine-sampled (each sample's `f` and `pdf` are `eval`'s and
/// `pdf`'s, its weight `f |cos| / pdf`, to 1e-3: `eval` sees the direction after a round trip
/// through world space, which moves a grazing cosine by 1e-5 relative), reciprocal (`f(wo, wi) = f(wi, wo)` over random
/// pairs, to 1e-5), Lambert's `rho / pi` at alpha 1e-4 (to 1e-4), brighter towards the light
/// than away from it at grazing angles (the facets' retro-reflection: `f(wo, wo)` above
/// 1.2 `f(wo, mirror of wo)` at 70 degrees, alpha 0.5), and with a white albedo about as
/// much reflected as received: the directional albedo at 0-80 degrees for alpha 0.2-1 within
/// [0.75, 1.05] (measured 0.83-1.014, 100 000 samples each, standard error below 1e-3; the
/// model, interreflection term included, is not exactly energy-conserving: 1.4 % above 1 at
/// 80 degrees for alpha 0.2). A value missing its 1 / pi, or a C1 term of the wrong sign, is
/// far outside.
#[test]
fn rough_diffuse_is_reciprocal_lambertian_when_smooth_and_retro_reflective() {
    let n = ng_generic();
    let sf = ShadingFrame::new(n, n);
    let rho = Vec3::new(0.8, 0.5, 0.2);
    let mut s = chi2::sampler_for("rough diffuse");
    let mut fails = Failures::new();
    for alpha in [0.2f32, 0.6, 1.0] {
        let bsdf = Bsdf::RoughDiffuse { albedo: rho, alpha };
        for _ in 0..2000 {
            let wo = warp::square_to_uniform_sphere(s.next_2d());
            let wi = warp::square_to_uniform_sphere(s.next_2d());
            let mode = TransportMode::Radiance;
            let (a, b) = (bsdf.eval(&sf, wo, wi, mode), bsdf.eval(&sf, wi, wo, mode));
            fails.check(close3(a, b, 1e-5, 1e-7), || {
                format!("alpha {alpha}: {a} vs {b}")
            });
            if let Some(smp) = bsdf.sample(&sf, wo, s.next_1d(), s.next_2d(), mode) {
                let f = bsdf.eval(&sf, wo, smp.wi, mode);
                let pdf = bsdf.pdf(&sf, wo, smp.wi, mode);
                let w = f * smp.wi.dot(n).abs() / pdf;
                fails.check(
                    close3(smp.f, f, 1e-3, 0.0)
                        && close(smp.pdf as f64, pdf as f64, 1e-3, 0.0)
                        && close3(smp.weight, w, 1e-3, 0.0)
                        && !smp.delta,
                    || format!("alpha {alpha}: {smp:?} against f {f}, pdf {pdf}"),
                );
            }
        }
    }
    fails.assert_none("rough diffuse");
    let smooth = Bsdf::RoughDiffuse {
        albedo: rho,
        alpha: 1e-4,
    };
    for theta in [0.0f32, 40.0, 80.0] {
        let (wo, wi) = (dir_around(n, theta, 10.0), dir_around(n, 55.0, 200.0));
        let f = smooth.eval(&sf, wo, wi, TransportMode::Radiance);
        assert!(close3(f, rho / PI, 1e-4, 0.0), "{f} against {}", rho / PI);
    }
    let rough = Bsdf::RoughDiffuse {
        albedo: rho,
        alpha: 0.5,
    };
    let wo = dir_around(n, 70.0, 0.0);
    let mirror = 2.0 * wo.dot(n) * n - wo;
    let (back, forward) = (
        rough.eval(&sf, wo, wo, TransportMode::Radiance).x,
        rough.eval(&sf, wo, mirror, TransportMode::Radiance).x,
    );
    assert!(
        back > 1.2 * forward,
        "retro-reflection {back} against forward {forward}"
    );
    for alpha in [0.2f32, 0.6, 1.0] {
        let white = Bsdf::RoughDiffuse {
            albedo: Vec3::ONE,
            alpha,
        };
        for theta in [0.0f32, 45.0, 80.0] {
            let wo = dir_around(n, theta, 30.0);
            let n_samples = 100_000;
            let mut sum = 0.0f64;
            for _ in 0..n_samples {
                if let Some(b) =
                    white.sample(&sf, wo, s.next_1d(), s.next_2d(), TransportMode::Radiance)
                {
                    sum += b.weight.x as f64;
                }
            }
            let albedo = sum / n_samples as f64;
            assert!(
                (0.75..=1.05).contains(&albedo),
                "alpha {alpha}, {theta} deg: albedo {albedo}"
            );
        }
    }
}

/// The smooth conductor with a complex index (gold's `eta` and `k`): every sample is the
/// mirror direction, a delta sample of density 1 whose weight is the exact Fresnel reflectance
/// per channel, from both sides; that reflectance is Mitsuba 3's `conductor`'s with the same
/// `eta` and `k` at 0-89 degrees (`python3 benches/reference/mitsuba_conductor.py`; asserted
/// to 1e-5, f32 rounding).
#[test]
// The reference values as the script prints them.
#[allow(clippy::excessive_precision)]
fn fresnel_conductor_reflects_as_mitsuba() {
    #[rustfmt::skip]
    let reference: &[(f32, [f32; 3])] = &[
        (0.0, [0.9666874, 0.8025370, 0.3240339]),
        (30.0, [0.9664249, 0.8021569, 0.3260911]),
        (60.0, [0.9622195, 0.8048942, 0.3711082]),
        (80.0, [0.9632167, 0.8759332, 0.5917102]),
        (89.0, [0.9946344, 0.9846019, 0.9390444]),
    ];
    let (eta, k) = (
        Vec3::new(0.143, 0.374, 1.442),
        Vec3::new(3.983, 2.385, 1.603),
    );
    let bsdf = Bsdf::FresnelConductor {
        eta,
        k,
        scale: Vec3::ONE,
    };
    let n = ng_generic();
    let sf = ShadingFrame::new(n, n);
    for &(theta, expected) in reference {
        for side in [1.0f32, -1.0] {
            let wo = dir_around(side * n, theta, 60.0);
            let mirror = 2.0 * wo.dot(n) * n - wo;
            for mode in MODES {
                let smp = bsdf
                    .sample(&sf, wo, 0.3, Vec2::new(0.2, 0.7), mode)
                    .unwrap_or_else(|| panic!("{theta} deg: no sample"));
                assert!((smp.wi - mirror).length() < 1e-5 && smp.delta && smp.pdf == 1.0);
                assert!(
                    close3(smp.weight, Vec3::from(expected), 1e-5, 0.0),
                    "{theta} deg, side {side}, {mode:?}: {} against Mitsuba's {expected:?}",
                    smp.weight
                );
                assert_eq!(bsdf.delta_lobe_probability(&sf, wo, mirror), 1.0);
            }
        }
    }
}
