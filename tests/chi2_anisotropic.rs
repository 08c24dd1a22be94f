//! Statistical tests of anisotropic roughness (Mitsuba's `alpha_u`, `alpha_v`): the GGX and
//! Beckmann distributions stretched differently along the two tangents, and the rough
//! conductor and dielectric built on them, in a shading frame turned about its normal.
//!
//! * The distribution: `∫ D(m) cos(theta_m) dm = 1` and `∫ D_wo(m) dm = 1` by cubature for
//!   incident directions off both axes (the second holds only if Smith's Lambda is the one of
//!   the stretched `D` in every azimuth), and Lambda in the two principal planes equal to the
//!   isotropic Lambda of that plane's roughness.
//! * Chi-square of the visible-normal samplers against `D_wo`, and of the BSDFs' `sample`
//!   against `pdf` (with the per-sample checks of `chi2_microfacet::bsdf_case`).
//!
//! Statistics (`common/chi2.rs`): 9 cases, each a chi-square test and a mass check, so 18 of
//! the suite's Sidak-corrected hypothesis tests at level `chi2::alpha()`; fixed seeds.
//! Samples per case: `chi2_microfacet::N`.
//!
//! What the render test adds (`mitsuba_tiles.rs`, `scenes/mitsuba/anisotropic.xml`): the
//! tangent the roughnesses follow is the surface's `dp/du`, as in Mitsuba.

use crate::chi2_microfacet::{N, bsdf_case, gold, visible_normal_case, warp_for};
use crate::common;

use common::chi2::{self, LobeDomain};
use common::{Failures, close, dir_around, ng_generic};
use glam::Vec3;
use lodestar::bsdf::microfacet::{Microfacet, Smith};
use lodestar::bsdf::{Alpha, Bsdf, Distribution, ShadingFrame};

/// (alpha_x, alpha_y) per distribution: one axis near-specular, the other rough.
const ROUGHNESSES: [(Distribution, f32, f32); 2] = [
    (Distribution::Ggx, 0.05, 0.4),
    (Distribution::Beckmann, 0.4, 0.1),
];

#[test]
fn anisotropic_distributions_integrate_to_one() {
    let mut fails = Failures::new();
    for (dist, ax, ay) in ROUGHNESSES {
        let mf = Microfacet::anisotropic(dist, ax, ay);
        let domain =
            LobeDomain::new(Vec3::Z, Vec3::Z, -Vec3::Z, warp_for(ax.min(ay))).with_res(12, 16);
        let projected = chi2::integrate_lobe(&domain, |m| (mf.d(m) * m.z.max(0.0)) as f64);
        fails.check(close(projected, 1.0, 0.0, 1e-3), || {
            format!("{dist:?} ({ax}, {ay}): ∫ D(m) cos = {projected}")
        });
        for (theta, phi) in [(60.0f32, 0.0f32), (60.0, 90.0), (70.0, 35.0), (85.0, 120.0)] {
            let wo = dir_around(Vec3::Z, theta, phi);
            let vis = chi2::integrate_lobe(&domain, |m| mf.d_visible(wo, m) as f64);
            println!("{dist:?} ({ax}, {ay}), wo ({theta}, {phi}): ∫ D_wo = {vis:.6}");
            fails.check(close(vis, 1.0, 0.0, 1e-3), || {
                format!("{dist:?} ({ax}, {ay}), wo ({theta}, {phi}): ∫ D_wo(m) = {vis}")
            });
        }
    }
    fails.assert_none("anisotropic normalisation");
}

#[test]
fn lambda_in_the_principal_planes_is_that_planes_isotropic_lambda() {
    let mut fails = Failures::new();
    for (dist, ax, ay) in ROUGHNESSES {
        let mf = Microfacet::anisotropic(dist, ax, ay);
        for theta in [10.0f32, 45.0, 75.0, 88.0] {
            for (phi, alpha) in [(0.0f32, ax), (90.0, ay), (180.0, ax), (270.0, ay)] {
                let w = dir_around(Vec3::Z, theta, phi);
                let (got, want) = (mf.lambda(w), Microfacet::new(dist, alpha).lambda(w));
                fails.check(close(got as f64, want as f64, 1e-4, 1e-7), || {
                    format!("{dist:?} ({ax}, {ay}) at ({theta}, {phi}): Lambda {got}, isotropic {alpha}: {want}")
                });
            }
        }
    }
    fails.assert_none("Lambda in the principal planes");
}

#[test]
fn anisotropic_visible_normal_sampling() {
    for (dist, ax, ay) in ROUGHNESSES {
        let mf = Microfacet::anisotropic(dist, ax, ay);
        let angles: &[(f32, f32)] = match dist {
            Distribution::Ggx => &[(0.0, 0.0), (60.0, 30.0), (85.0, 100.0)],
            Distribution::Beckmann => &[(50.0, 60.0), (80.0, 10.0)],
        };
        for &(theta, phi) in angles {
            let name = format!("{dist:?} VNDF ({ax}, {ay}), wo ({theta}, {phi})");
            visible_normal_case(&name, &mf, dir_around(Vec3::Z, theta, phi), ax.min(ay));
        }
    }
}

#[test]
fn anisotropic_rough_bsdfs_sampling_matches_pdf() {
    let ng = ng_generic();
    // A frame turned about its normal: the roughnesses follow its tangent, not a fixed axis.
    let sf = ShadingFrame::new(ng, ng).with_tangent(Vec3::new(0.3, -0.8, 0.5));
    for (dist, ax, ay) in ROUGHNESSES {
        let alpha = Alpha::anisotropic(ax, ay);
        let conductor = Bsdf::rough_conductor(alpha.clone(), gold()).with_distribution(dist);
        let wo = dir_around(ng, 60.0, 25.0);
        let name = format!("{dist:?} rough conductor ({ax}, {ay}), wo at 60 deg");
        bsdf_case(N, &name, &conductor, &sf, wo, 1.0, ax.min(ay), true);
    }
    let (eta, (ax, ay)) = (1.5f32, (0.05f32, 0.3f32));
    let dielectric = Bsdf::rough_dielectric(eta, Alpha::anisotropic(ax, ay));
    for theta in [40.0f32, 150.0] {
        let wo = dir_around(ng, theta, 70.0);
        let eta_r = if wo.dot(ng) > 0.0 { eta } else { 1.0 / eta };
        let name = format!("GGX rough dielectric ({ax}, {ay}), wo at {theta} deg");
        bsdf_case(N, &name, &dielectric, &sf, wo, eta_r, ax.min(ay), true);
    }
}
