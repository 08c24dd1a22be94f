//! Chi-square test of Henyey-Greenstein phase sampling against its density, for several g
//! (isotropic, forward, strongly forward, backward) and incident directions, with the shared
//! harness (`common/chi2.rs`; Šidák-corrected α, about 1 % false-failure rate for the whole
//! suite, fixed seeds). The domain is the sphere around the propagation direction, so strong
//! forward peaks are resolved by the (1 - cos) binning.

use crate::common;

use common::chi2::{self, SphereDomain};
use glam::Vec3;
use lodestar::math::Sampler;
use lodestar::medium::HenyeyGreenstein;

const N: usize = 1_000_000;

#[test]
fn henyey_greenstein_sampling_matches_its_density() {
    let wos = [Vec3::Z, Vec3::new(0.3, -0.8, 0.52).normalize()];
    for g in [0.0f32, 0.3, 0.8, -0.6, 0.95] {
        for (k, &wo) in wos.iter().enumerate() {
            let hg = HenyeyGreenstein::new(g);
            let name = format!("hg g={g} wo#{k}");
            let report = chi2::spherical(
                &name,
                N,
                &SphereDomain::full_around(-wo),
                |s: &mut dyn Sampler| {
                    let (wi, pdf) = hg.sample(wo, s.next_2d());
                    // The sampled density is the phase function (weight exactly 1).
                    let eval = hg.eval(wo, wi);
                    assert!(
                        (pdf - eval).abs() <= 1e-4 * eval,
                        "{name}: pdf {pdf} != eval {eval}"
                    );
                    Some(wi)
                },
                |wi| hg.eval(wo, wi) as f64,
            );
            report.assert_ok();
        }
    }
}

/// The harness has power here: a phase density with the wrong g is rejected.
#[test]
fn a_wrong_g_is_rejected() {
    let (sampled, claimed) = (HenyeyGreenstein::new(0.5), HenyeyGreenstein::new(0.45));
    let wo = Vec3::Z;
    let report = chi2::spherical(
        "hg wrong g",
        N,
        &SphereDomain::full_around(-wo),
        |s: &mut dyn Sampler| Some(sampled.sample(wo, s.next_2d()).0),
        |wi| claimed.eval(wo, wi) as f64,
    );
    assert!(report.rejected());
}
