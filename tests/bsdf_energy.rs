//! Reciprocity and energy of the microfacet BSDFs.
//!
//! * Reciprocity, for random direction pairs and for pairs made by sampling: rough conductor
//!   and rough dielectric reflection satisfy `f(wo, wi) == f(wi, wo)`. Transmission between
//!   indices `n_wo` (side of wo) and `n_wi` satisfies the generalised reciprocity
//!   `f(wo, wi) / n_wi^2 == f(wi, wo) / n_wo^2` in **importance** mode, where `f` is the plain
//!   Walter et al. BTDF without the radiance scaling. In radiance mode `f` carries an extra
//!   `(n_wo / n_wi)^2` (the `1 / eta^2` of `dielectric.rs`), which turns the relation into
//!   `f(wo, wi) / n_wo^2 == f(wi, wo) / n_wi^2` (the radiance BTDF of light going from wi to
//!   wo, Veach's thesis eq. 5.14); and the two modes are adjoint:
//!   `f_importance(wo, wi) == f_radiance(wi, wo)`. All three are checked (the shading normal
//!   equals the geometric one: Veach's shading-normal correction is deliberately
//!   non-reciprocal).
//! * White furnace: the directional albedo `E(wo) = ∫ f |cos| dwi` of the rough conductor with
//!   `Constant(1)` reflectance, and of the rough dielectric in importance mode (reflection +
//!   transmission), estimated as the mean of the BSDF's own sample weights (failed samples
//!   count as 0), and independently by cubature of `eval` over the sphere. Asserted, per
//!   configuration: every weight is in [0, 1] (importance weights are `G2 / G1(wo)`); the
//!   estimate is at most `1 + z s / sqrt(N)` (one-sided); the estimate agrees with the
//!   cubature within `z s / sqrt(N) + 2e-3` (two-sided); the cubature is at most
//!   `1 + 1e-3`; at alpha 0.05 the albedo is at least 0.99 (normal incidence); the energy
//!   lost by single scattering at alpha 1 lies in the band printed in the table.
//!   `s` is the sample standard deviation of the weights and `z` the normal quantile at the
//!   suite's Sidak level `chi2::alpha()` (CLT with N = 200,000 bounded weights); these are
//!   2 hypothesis tests per configuration, 80 in this file, counted in `chi2::SUITE_TESTS`.
//! * Near-specular safety: alpha 0 (clamped to 1e-4) and tiny alphas give finite `f`, `pdf`
//!   and weights everywhere, including the exact mirror and refraction directions.

use crate::common;

use common::chi2::{self, LobeDomain};
use common::{Failures, MODES, close, dir_around, ng_generic};
use glam::Vec3;
use lodestar::bsdf::microfacet::MIN_ALPHA;
use lodestar::bsdf::{
    Alpha, Bsdf, ConductorFresnel, Distribution, ShadingFrame, TransportMode, fresnel,
};
use lodestar::math::{Sampler, warp};
use statrs::distribution::{ContinuousCDF, Normal};

const ALPHAS: [f32; 5] = [0.05, 0.1, 0.3, 0.7, 1.0];
/// Samples per white-furnace estimate.
const N_FURNACE: usize = 200_000;
const ETA: f32 = 1.5;

fn random_dir(s: &mut dyn Sampler) -> Vec3 {
    warp::square_to_uniform_sphere(s.next_2d())
}

fn gold() -> ConductorFresnel {
    ConductorFresnel::Complex {
        eta: Vec3::new(0.143, 0.374, 1.442),
        k: Vec3::new(3.983, 2.385, 1.603),
        scale: Vec3::ONE,
    }
}

/// Relative tolerance of comparing `f` at a pair with `f` at the swapped pair: the half
/// vector is computed from different sums, so it differs by rounding; that matters only
/// where the dielectric Fresnel term is ill-conditioned, near the critical angle, where
/// `cos_t` of the refraction through the microfacet goes to zero and `F` changes by about
/// `e / (2 cos_t^2)` relatively for a perturbation `e` of `sin^2`; `e` reaches several ulps
/// (a few 1e-7) in `f32`, as `cos_t^2 = 1 - (1 - cos_o^2) / eta^2` cancels.
fn swap_tolerance(n: Vec3, wo: Vec3, wi: Vec3, eta_r: f32) -> f64 {
    let base = 1e-4;
    let transmission = wo.dot(n) * wi.dot(n) < 0.0;
    let m = if transmission {
        (wo + eta_r * wi).normalize()
    } else {
        (wo + wi).normalize()
    };
    let (_, cos_t, _) = fresnel::dielectric(wo.dot(m).abs(), eta_r);
    let c = if transmission {
        cos_t.min(wi.dot(m).abs()).min(wo.dot(m).abs())
    } else {
        cos_t
    };
    if c == 0.0 {
        return base;
    }
    base + 1e-6 / (c as f64 * c as f64)
}

// ------------------------------------------------------------------------------------------
// Reciprocity
// ------------------------------------------------------------------------------------------

/// Direction pairs: half uniformly random, half with wi sampled from the BSDF (so that the
/// narrow lobes are hit), both modes.
fn pairs(bsdf: &Bsdf, sf: &ShadingFrame, name: &str, count: usize) -> Vec<(Vec3, Vec3)> {
    let mut s = chi2::sampler_for(name);
    let mut v = Vec::with_capacity(count);
    while v.len() < count {
        let wo = random_dir(&mut s);
        if v.len() % 2 == 0 {
            v.push((wo, random_dir(&mut s)));
        } else if let Some(smp) =
            bsdf.sample(sf, wo, s.next_1d(), s.next_2d(), TransportMode::Radiance)
        {
            v.push((wo, smp.wi));
        }
    }
    v
}

#[test]
fn rough_conductor_is_reciprocal() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    let mut fails = Failures::new();
    let mut nonzero = 0;
    for alpha in [0.05f32, 0.3, 1.0] {
        for fresnel in [gold(), ConductorFresnel::Constant(Vec3::new(0.9, 0.6, 0.3))] {
            let bsdf = Bsdf::rough_conductor(alpha, fresnel);
            for (wo, wi) in pairs(&bsdf, &sf, &format!("conductor recip {alpha}"), 20_000) {
                for mode in MODES {
                    let (a, b) = (bsdf.eval(&sf, wo, wi, mode), bsdf.eval(&sf, wi, wo, mode));
                    fails.check(
                        (0..3).all(|c| close(a[c] as f64, b[c] as f64, 1e-4, 0.0)),
                        || format!("alpha {alpha} {mode:?}: f(wo, wi) = {a} != f(wi, wo) = {b}"),
                    );
                    let pdf = bsdf.pdf(&sf, wo, wi, mode);
                    fails.check((a != Vec3::ZERO) == (pdf > 0.0), || {
                        format!("alpha {alpha}: eval {a} and pdf {pdf} disagree on the support")
                    });
                    fails.check(a.is_finite() && a.min_element() >= 0.0, || format!("f {a}"));
                    nonzero += (a != Vec3::ZERO) as usize;
                }
            }
        }
    }
    fails.assert_none("rough conductor reciprocity");
    assert!(nonzero > 100_000, "{nonzero} non-zero pairs");
}

#[test]
fn rough_dielectric_reflection_and_transmission_reciprocity() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    let mut fails = Failures::new();
    let (mut refl, mut trans) = (0usize, 0usize);
    let imp = TransportMode::Importance;
    let rad = TransportMode::Radiance;
    for alpha in [0.05f32, 0.3, 1.0] {
        let bsdf = Bsdf::rough_dielectric(ETA, alpha);
        for (wo, wi) in pairs(&bsdf, &sf, &format!("dielectric recip {alpha}"), 40_000) {
            // Indices on the sides of wo and wi (outside = front of ng = 1).
            let n_of = |w: Vec3| if w.dot(ng) > 0.0 { 1.0 } else { ETA };
            let (n_wo, n_wi) = (n_of(wo), n_of(wi));
            let eta_r = n_wi / n_wo;
            let transmission = n_wo != n_wi;
            // n(other side) / n(side of wo), for both lobes.
            let eta_across = if wo.dot(ng) > 0.0 { ETA } else { 1.0 / ETA };
            debug_assert!(!transmission || eta_r == eta_across);
            let tol = swap_tolerance(ng, wo, wi, eta_across);
            let f = |mode, a, b| bsdf.eval(&sf, a, b, mode).x as f64;
            let (fi, fi_rev) = (f(imp, wo, wi), f(imp, wi, wo));
            let (fr, fr_rev) = (f(rad, wo, wi), f(rad, wi, wo));
            for v in [fi, fi_rev, fr, fr_rev] {
                fails.check(v.is_finite() && v >= 0.0, || format!("f = {v}"));
            }
            let pdf = bsdf.pdf(&sf, wo, wi, rad);
            fails.check(
                (fr != 0.0) == (pdf > 0.0) && (fi != 0.0) == (pdf > 0.0),
                || format!("alpha {alpha}: eval {fr} / {fi} and pdf {pdf} disagree on the support"),
            );
            if fr == 0.0 && fr_rev == 0.0 {
                continue;
            }
            let (n_wo2, n_wi2) = ((n_wo * n_wo) as f64, (n_wi * n_wi) as f64);
            if transmission {
                trans += 1;
                fails.check(close(fi / n_wi2, fi_rev / n_wo2, tol, 0.0), || {
                    format!(
                        "alpha {alpha}: importance f(wo, wi) / n_wi^2 = {} != f(wi, wo) / n_wo^2 \
                         = {} (n_wo {n_wo}, wo {wo}, wi {wi})",
                        fi / n_wi2,
                        fi_rev / n_wo2
                    )
                });
                fails.check(close(fr / n_wo2, fr_rev / n_wi2, tol, 0.0), || {
                    format!(
                        "alpha {alpha}: radiance f(wo, wi) / n_wo^2 = {} != f(wi, wo) / n_wi^2 = {}",
                        fr / n_wo2,
                        fr_rev / n_wi2
                    )
                });
            } else {
                refl += 1;
                for (a, b, m) in [(fi, fi_rev, imp), (fr, fr_rev, rad)] {
                    fails.check(close(a, b, tol, 0.0), || {
                        format!(
                            "alpha {alpha} {m:?}: reflection f(wo, wi) = {a} != f(wi, wo) = {b}"
                        )
                    });
                }
            }
            // Adjoint: importance f(wo, wi) is radiance f(wi, wo), for both lobes.
            fails.check(close(fi, fr_rev, tol, 0.0), || {
                format!(
                    "alpha {alpha}: importance f(wo, wi) = {fi} != radiance f(wi, wo) = {fr_rev}"
                )
            });
        }
    }
    fails.assert_none("rough dielectric reciprocity");
    println!("{refl} reflection and {trans} transmission pairs with f > 0");
    assert!(refl > 20_000 && trans > 20_000);
}

// ------------------------------------------------------------------------------------------
// White furnace
// ------------------------------------------------------------------------------------------

/// One-sided normal quantile at the suite's per-test level.
fn z_one_sided() -> f64 {
    Normal::new(0.0, 1.0)
        .unwrap()
        .inverse_cdf(1.0 - chi2::alpha())
}

/// Two-sided normal quantile at the suite's per-test level.
fn z_two_sided() -> f64 {
    Normal::new(0.0, 1.0)
        .unwrap()
        .inverse_cdf(1.0 - 0.5 * chi2::alpha())
}

#[derive(Debug, Clone, Copy)]
struct Albedo {
    /// Mean of the sample weights (failed samples count 0).
    mc: f64,
    /// Standard error of `mc`.
    se: f64,
    /// Cubature of `eval |cos|` over the sphere.
    quad: f64,
    max_weight: f64,
}

/// Albedo of `bsdf` seen from `wo` in `mode` (luminance-free: the first channel; the tests use
/// colourless BSDFs).
fn albedo(name: &str, bsdf: &Bsdf, sf: &ShadingFrame, wo: Vec3, alpha: f32) -> Albedo {
    let mode = TransportMode::Importance;
    let mut s = chi2::sampler_for(name);
    let (mut sum, mut sum2, mut max_weight) = (0.0f64, 0.0f64, 0.0f64);
    let mut fails = Failures::new();
    for _ in 0..N_FURNACE {
        let (ul, u) = (s.next_1d(), s.next_2d());
        let w = match bsdf.sample(sf, wo, ul, u, mode) {
            Some(smp) => {
                fails.check(
                    smp.weight.is_finite()
                        && smp.weight.x == smp.weight.y
                        && smp.weight.x == smp.weight.z,
                    || format!("weight {}", smp.weight),
                );
                smp.weight.x as f64
            }
            None => 0.0,
        };
        sum += w;
        sum2 += w * w;
        max_weight = max_weight.max(w);
    }
    fails.assert_none(name);
    let n = N_FURNACE as f64;
    let mc = sum / n;
    let var = (sum2 / n - mc * mc).max(0.0) * n / (n - 1.0);
    let ns = sf.frame.n;
    let side = if wo.dot(ns) >= 0.0 { ns } else { -ns };
    let c = wo.dot(side);
    let eta_r = match bsdf {
        Bsdf::RoughDielectric { eta, .. } => {
            if wo.dot(ns) > 0.0 {
                *eta
            } else {
                1.0 / eta
            }
        }
        _ => 1.0,
    };
    let sin2_t = (1.0 - c * c) / (eta_r * eta_r);
    let axis1 = if sin2_t < 0.99 {
        (-wo / eta_r + (c / eta_r - (1.0 - sin2_t).sqrt()) * side).normalize()
    } else {
        -side
    };
    let domain = LobeDomain::new(
        side,
        2.0 * c * side - wo,
        axis1,
        10.0 / (alpha as f64 * alpha as f64),
    )
    .with_res(12, 18);
    let quad = chi2::integrate_lobe(&domain, |wi| {
        (bsdf.eval(sf, wo, wi, mode).x * wi.dot(ns).abs()) as f64
    });
    Albedo {
        mc,
        se: (var / n).sqrt(),
        quad,
        max_weight,
    }
}

/// Asserts the furnace checks of one configuration and returns the albedo.
fn furnace_case(name: &str, bsdf: &Bsdf, sf: &ShadingFrame, wo: Vec3, alpha: f32) -> Albedo {
    let a = albedo(name, bsdf, sf, wo, alpha);
    println!(
        "{name}: MC albedo {:.5} ± {:.5} (1 s.e.), cubature {:.5}, max weight {:.5}",
        a.mc, a.se, a.quad, a.max_weight
    );
    assert!(
        a.max_weight <= 1.0 + 1e-5,
        "{name}: a weight exceeds 1: {a:?}"
    );
    let upper = 1.0 + z_one_sided() * a.se;
    assert!(
        a.mc <= upper,
        "{name}: albedo {} above 1 beyond noise ({upper}): {a:?}",
        a.mc
    );
    assert!(
        a.quad <= 1.0 + 1e-3,
        "{name}: cubature albedo above 1: {a:?}"
    );
    let tol = z_two_sided() * a.se + 2e-3;
    assert!(
        (a.mc - a.quad).abs() <= tol,
        "{name}: sampled albedo {} and cubature {} differ by more than {tol}",
        a.mc,
        a.quad
    );
    a
}

const FURNACE_THETAS: [f32; 4] = [0.0, 45.0, 75.0, 89.0];

#[test]
fn rough_conductor_white_furnace() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    let mut table = Vec::new();
    for &alpha in &ALPHAS {
        let bsdf = Bsdf::rough_conductor(alpha, ConductorFresnel::Constant(Vec3::ONE));
        let row: Vec<Albedo> = FURNACE_THETAS
            .iter()
            .map(|&theta| {
                let wo = dir_around(ng, theta, 30.0);
                let name = format!("conductor furnace alpha {alpha}, theta {theta}");
                furnace_case(&name, &bsdf, &sf, wo, alpha)
            })
            .collect();
        table.push((alpha, row));
    }
    println!("\nRough conductor, Constant(1): energy lost by single scattering, 1 - E(wo)");
    println!("(MC mean of weights, N = {N_FURNACE}; cubature in brackets)");
    print!("alpha  ");
    for t in FURNACE_THETAS {
        print!("| theta_o {t:>4}      ");
    }
    println!();
    for (alpha, row) in &table {
        print!("{alpha:<6} ");
        for a in row {
            print!("| {:.4} [{:.4}] ", 1.0 - a.mc, 1.0 - a.quad);
        }
        println!();
    }
    let loss = |alpha: f32, k: usize| {
        let row = &table.iter().find(|(a, _)| *a == alpha).unwrap().1;
        1.0 - row[k].mc
    };
    // Nearly no loss for a smooth surface at normal incidence.
    assert!(loss(0.05, 0) <= 0.01, "alpha 0.05 loses {}", loss(0.05, 0));
    // Away from grazing, the single-scattering loss grows with alpha. At 89 degrees it does
    // not (measured 6.4 % at alpha 0.05, 3.0 % at 0.3, 7.1 % at 1): a narrow lobe around a
    // grazing mirror direction loses its lower part below the horizon and is shadowed
    // (G2 / G1(wo) ~ 1/2 when wi is as grazing as wo), while the visible normals of a rough
    // surface seen at grazing lean towards wo and send wi upwards.
    for (k, theta) in FURNACE_THETAS.iter().enumerate().take(3) {
        for w in ALPHAS.windows(2) {
            assert!(
                loss(w[1], k) > loss(w[0], k) + 3e-3,
                "loss does not grow with alpha at theta {theta}"
            );
        }
    }
    // Closed form at alpha = 1, normal incidence: D = 1 / pi is uniform, wi = reflect(n, m)
    // leaves the surface only for theta_m < 45 degrees, G2 / G1(wo) = G1(wi) =
    // 2 cos_i / (1 + cos_i), so E = ∫_0^{pi/4} G1(2 t) sin(2 t) dt = ∫_0^1 c / (1 + c) dc =
    // 1 - ln 2 = 0.3069: GGX at alpha 1 loses 69 % at normal incidence (at least half of the
    // light is reflected into the surface). Checked against the cubature (deterministic)
    // and the sampled estimate (at the suite's level).
    let exact = 1.0 - std::f64::consts::LN_2;
    let a1 = table.iter().find(|(a, _)| *a == 1.0).unwrap().1[0];
    assert!(
        (a1.quad - exact).abs() < 1e-3,
        "cubature {} vs 1 - ln 2",
        a1.quad
    );
    let tol = z_two_sided() * a1.se;
    assert!(
        (a1.mc - exact).abs() <= tol,
        "sampled {} vs 1 - ln 2 (tol {tol})",
        a1.mc
    );
    // Measured (the table): alpha 0.3 loses 12 % at normal incidence, alpha 1 69 %.
    assert!((0.10..=0.15).contains(&loss(0.3, 0)), "{}", loss(0.3, 0));
}

#[test]
fn rough_dielectric_white_furnace_importance() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    // Outside at normal incidence and 75 degrees; inside 20 degrees from -n (below the
    // critical angle) and 60 degrees (beyond it).
    let thetas = [0.0f32, 75.0, 160.0, 120.0];
    println!("\nRough dielectric eta {ETA}, importance mode: 1 - (R + T) albedo");
    let mut rows = Vec::new();
    for &alpha in &ALPHAS {
        let bsdf = Bsdf::rough_dielectric(ETA, alpha);
        let row: Vec<Albedo> = thetas
            .iter()
            .map(|&theta| {
                let wo = dir_around(ng, theta, 30.0);
                let name = format!("dielectric furnace alpha {alpha}, theta {theta}");
                furnace_case(&name, &bsdf, &sf, wo, alpha)
            })
            .collect();
        rows.push((alpha, row));
    }
    for (alpha, row) in &rows {
        print!("alpha {alpha:<5}");
        for (a, t) in row.iter().zip(thetas) {
            print!("| theta {t:>5}: {:.4} [{:.4}] ", 1.0 - a.mc, 1.0 - a.quad);
        }
        println!();
    }
    // Close to 1 at small alpha, from outside and from inside below the critical angle.
    let first = &rows[0].1;
    assert!(first[0].mc >= 0.99 && first[2].mc >= 0.99, "{first:?}");
}

// ------------------------------------------------------------------------------------------
// Near-specular safety and the trait-like queries
// ------------------------------------------------------------------------------------------

#[test]
fn tiny_alpha_is_numerically_safe() {
    let ng = ng_generic();
    let mut s = chi2::sampler_for("tiny alpha");
    let mut fails = Failures::new();
    let mut count = 0usize;
    for alpha in [0.0f32, MIN_ALPHA, 1e-3, -1.0, f32::NAN] {
        for bsdf in [
            Bsdf::rough_conductor(alpha, gold()),
            // The variants as written (unclamped alpha), with Beckmann microfacets.
            Bsdf::RoughConductor {
                alpha: Alpha::Constant(alpha),
                fresnel: ConductorFresnel::Constant(Vec3::ONE),
                distribution: Distribution::Beckmann,
            },
            Bsdf::rough_dielectric(ETA, alpha),
            Bsdf::RoughDielectric {
                eta: ETA,
                alpha: Alpha::Constant(alpha),
                distribution: Distribution::Beckmann,
            },
        ] {
            for ns in [ng, dir_around(ng, 15.0, 0.0)] {
                let sf = ShadingFrame::new(ns, ng);
                let mut wos: Vec<Vec3> = (0..2000).map(|_| random_dir(&mut s)).collect();
                wos.extend([
                    ns,
                    -ns,
                    dir_around(ns, 89.99, 10.0),
                    dir_around(ns, 90.01, 10.0),
                ]);
                for wo in wos {
                    // The exact mirror and (macro) refraction directions, and a random one.
                    let c = wo.dot(ns);
                    let mirror = 2.0 * c * ns - wo;
                    let eta_r = if c > 0.0 { ETA } else { 1.0 / ETA };
                    let sin2 = (1.0 - c * c) / (eta_r * eta_r);
                    let mut wis = vec![mirror, random_dir(&mut s), -wo];
                    if sin2 < 1.0 {
                        wis.push(
                            (-wo / eta_r
                                + (c.abs() / eta_r - (1.0 - sin2).sqrt()) * ns * c.signum())
                            .normalize(),
                        );
                    }
                    for mode in MODES {
                        for &wi in &wis {
                            let f = bsdf.eval(&sf, wo, wi, mode);
                            let pdf = bsdf.pdf(&sf, wo, wi, mode);
                            fails.check(
                                f.is_finite()
                                    && f.min_element() >= 0.0
                                    && pdf.is_finite()
                                    && pdf >= 0.0,
                                || format!("{bsdf:?}: f {f} pdf {pdf} at wo {wo} wi {wi}"),
                            );
                        }
                        if let Some(smp) = bsdf.sample(&sf, wo, s.next_1d(), s.next_2d(), mode) {
                            count += 1;
                            fails.check(
                                smp.f.is_finite()
                                    && smp.pdf.is_finite()
                                    && smp.pdf > 0.0
                                    && smp.weight.is_finite()
                                    && smp.weight.min_element() >= 0.0
                                    && smp.wi.is_finite(),
                                || format!("{bsdf:?}: sample {smp:?} from wo {wo}"),
                            );
                        }
                    }
                }
            }
        }
    }
    fails.assert_none("tiny alpha");
    assert!(count > 50_000, "{count}");
    // At the minimum alpha a conductor is a mirror: the sampled direction is the mirror one
    // and the weight (G2 / G1 ~ 1) is the reflectance.
    let sf = ShadingFrame::new(ng, ng);
    let bsdf = Bsdf::rough_conductor(0.0, ConductorFresnel::Constant(Vec3::splat(0.8)));
    let wo = dir_around(ng, 60.0, 10.0);
    for _ in 0..1000 {
        let smp = bsdf
            .sample(&sf, wo, s.next_1d(), s.next_2d(), TransportMode::Radiance)
            .unwrap();
        let mirror = 2.0 * wo.dot(ng) * ng - wo;
        // GGX has heavy tails (P(theta_m > x) ~ alpha^2 / x^2 = 4e-6 for x = 0.05).
        assert!((smp.wi - mirror).length() < 0.1, "{} vs {mirror}", smp.wi);
        assert!((smp.weight - Vec3::splat(0.8)).abs().max_element() < 1e-3);
    }
}

#[test]
fn roughness_and_flags() {
    let sf = ShadingFrame::new(Vec3::Z, Vec3::Z);
    for alpha in [0.0f32, 1e-4, 0.01, 0.1, 0.49, 1.0, 4.0, f32::NAN] {
        for bsdf in [
            Bsdf::rough_conductor(alpha, gold()),
            Bsdf::RoughDielectric {
                eta: ETA,
                alpha: Alpha::Constant(alpha),
                distribution: Distribution::Ggx,
            },
        ] {
            let r = bsdf.roughness();
            assert!((0.0..=1.0).contains(&r), "{bsdf:?}: roughness {r}");
            assert!(!bsdf.is_delta() && !bsdf.is_black());
            // (At alpha 4 most normal-incidence reflections go below the surface.)
            let smp = (0..100)
                .find_map(|i| {
                    let u = glam::Vec2::new(0.3, i as f32 / 100.0);
                    bsdf.sample(&sf, Vec3::Z, 0.5, u, TransportMode::Radiance)
                })
                .unwrap();
            assert!(!smp.delta);
        }
    }
    assert_eq!(Bsdf::rough_conductor(0.49, gold()).roughness(), 0.7);
    assert_eq!(Bsdf::rough_dielectric(ETA, 4.0).roughness(), 1.0);
    assert_eq!(Bsdf::rough_dielectric(ETA, 0.0).roughness(), 0.01);
    // The constructors clamp, the variants are what they say.
    assert_eq!(
        Bsdf::rough_dielectric(ETA, 0.0),
        Bsdf::RoughDielectric {
            eta: ETA,
            alpha: Alpha::Constant(MIN_ALPHA),
            distribution: Distribution::Ggx,
        }
    );
}
