//! Statistical tests of blended BSDFs (Mitsuba's `blendbsdf`, `bsdf/blend.rs`): chi-square of
//! `sample` against `pdf`, the mixture density, with the per-sample checks of
//! `chi2_microfacet::bsdf_case` (a sample's `f` and `pdf` are `eval()` and `pdf()` at
//! its direction, its weight `f |cos| / pdf`, its flags those of the lobe it took). Blends of
//! a diffuse and a rough conductor (reflection only) and of a rough dielectric and a rough
//! conductor (reflection and transmission), `wo` above and below the surface.
//!
//! Statistics (`common/chi2.rs`): 4 cases, each a chi-square test and a mass check, so 8 of
//! the suite's Sidak-corrected hypothesis tests at level `chi2::alpha()`; fixed seeds.

use crate::chi2_microfacet::{N, bsdf_case, gold};
use crate::common::{dir_around, ng_generic};
use glam::Vec3;
use lodestar::bsdf::{Blend, Bsdf, ConductorFresnel, Distribution, Opacity, ShadingFrame};

fn blend(first: Bsdf, second: Bsdf, weight: f32) -> Bsdf {
    Bsdf::Blend(Box::new(
        Blend::new(first, second, Opacity::Constant(weight)).unwrap(),
    ))
}

#[test]
fn blends_sample_their_mixture_density() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    let diffuse_gold = blend(
        Bsdf::Diffuse {
            albedo: Vec3::new(0.8, 0.6, 0.4),
        },
        Bsdf::rough_conductor(0.2, gold()),
        0.3,
    );
    for theta in [30.0f32, 75.0] {
        let wo = dir_around(ng, theta, 40.0);
        let name = format!("blend of diffuse and GGX gold, wo at {theta} deg");
        bsdf_case(N, &name, &diffuse_gold, &sf, wo, 1.0, 0.2, false);
    }
    let eta = 1.5;
    let glass_metal = blend(
        Bsdf::rough_dielectric(eta, 0.3),
        Bsdf::rough_conductor(0.1, ConductorFresnel::Constant(Vec3::splat(0.9)))
            .with_distribution(Distribution::Beckmann),
        0.5,
    );
    for theta in [40.0f32, 150.0] {
        let wo = dir_around(ng, theta, 70.0);
        let eta_r = if wo.dot(ng) > 0.0 { eta } else { 1.0 / eta };
        let name = format!("blend of rough glass and Beckmann metal, wo at {theta} deg");
        bsdf_case(N, &name, &glass_metal, &sf, wo, eta_r, 0.1, false);
    }
}

/// A blend refuses BSDFs with delta lobes (a mirror, smooth glass, smooth plastic).
#[test]
fn blends_take_smooth_bsdfs_only() {
    let diffuse = Bsdf::Diffuse {
        albedo: Vec3::splat(0.5),
    };
    let mirror = Bsdf::Conductor {
        reflectance: Vec3::ONE,
    };
    assert!(Blend::new(diffuse.clone(), mirror.clone(), Opacity::Constant(0.5)).is_none());
    assert!(Blend::new(mirror, diffuse.clone(), Opacity::Constant(0.5)).is_none());
    let b = Blend::new(diffuse.clone(), diffuse, Opacity::Constant(0.5)).unwrap();
    let b = Bsdf::Blend(Box::new(b));
    assert!(!b.is_delta() && !b.has_delta_lobe());
}
