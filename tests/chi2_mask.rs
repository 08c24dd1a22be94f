//! Statistical tests of opacity masks (`Bsdf::Mask`, Mitsuba's `mask`):
//! * chi-square of the wrapped BSDF's directions against the mask's `pdf()` with every delta
//!   sample (the null lobe, and a wrapped BSDF's own delta lobes) counted as a failed draw
//!   (`common/chi2.rs`), so that the mass test checks the lobe choice: `pdf` integrates to
//!   the opacity times the wrapped BSDF's non-delta share;
//! * each delta sample: straight on (the null lobe) or the wrapped BSDF's delta direction,
//!   its `weight` the value over the probability that the path algebra uses
//!   (`delta_value / delta_lobe_probability`), and for the null lobe alone `pdf = 1 - a`;
//! * opacity read from a texture at the point, and a one-sided wrapped BSDF seen from the
//!   back (nothing but the null lobe).

use crate::chi2_bsdf::{N_DIR, reflect};
use crate::common;

use common::chi2::{self, SphereDomain};
use common::{Failures, MODES, close, close3, dir_around, ng_generic};
use glam::{Affine2, Vec2, Vec3};
use lodestar::bsdf::{Bsdf, Mask, Opacity, Plastic, ShadingFrame, TransportMode};
use lodestar::math::Sampler;
use lodestar::texture::Texture;
use std::sync::Arc;

/// One chi-square case (see the module docs); `null_share`: the probability of the null lobe.
fn mask_case(
    name: &str,
    bsdf: &Bsdf,
    sf: &ShadingFrame,
    wo: Vec3,
    mode: TransportMode,
    null_share: f32,
) {
    let ns = sf.frame.n;
    let mut fails = Failures::new();
    let (mut nulls, mut draws) = (0usize, 0usize);
    let report = chi2::spherical(
        name,
        N_DIR,
        &SphereDomain::full_around(sf.ng),
        |s: &mut dyn Sampler| {
            draws += 1;
            let u_lobe = s.next_1d();
            let u = s.next_2d();
            let smp = bsdf.sample(sf, wo, u_lobe, u, mode)?;
            let wi = smp.wi;
            if smp.delta {
                let straight = (wi + wo).length() < 1e-6;
                if straight {
                    nulls += 1;
                    if !matches!(bsdf, Bsdf::Mask(m) if matches!(m.inner, Bsdf::ThinDielectric { .. }))
                    {
                        fails.check(close(smp.pdf as f64, null_share as f64, 1e-5, 0.0), || {
                            format!("null lobe pdf {} != 1 - a = {null_share}", smp.pdf)
                        });
                    }
                } else {
                    fails.check((wi - reflect(wo, ns)).length() < 1e-5, || {
                        format!("delta sample {wi} is neither straight on nor the mirror direction")
                    });
                }
                let p = bsdf.delta_lobe_probability(sf, wo, wi);
                let value = bsdf.delta_value(sf, wo, wi);
                if mode == TransportMode::Radiance {
                    fails.check(close3(smp.weight, value / p, 1e-4, 1e-7), || {
                        format!(
                            "delta weight {} != value / p {} (p = {p})",
                            smp.weight,
                            value / p
                        )
                    });
                }
                return None;
            }
            common::check_sample_against_eval(&mut fails, bsdf, sf, wo, &smp, mode);
            Some(wi)
        },
        |wi| bsdf.pdf(sf, wo, wi, mode) as f64,
    );
    report.assert_ok();
    fails.assert_none(name);
    // The null lobe's share, binomial: 6 standard deviations (false failure below 1e-8).
    let share = nulls as f64 / draws as f64;
    let q = null_share as f64;
    let sd = (q * (1.0 - q) / draws as f64).sqrt();
    assert!(
        (share - q).abs() <= 6.0 * sd + 1e-9,
        "{name}: null lobe taken in {share} of the samples, expected {q}"
    );
}

fn mask(inner: Bsdf, opacity: Opacity, one_sided: bool) -> Bsdf {
    Bsdf::Mask(Box::new(Mask::new(inner, opacity, one_sided)))
}

#[test]
fn masks_sample_their_lobes_as_their_densities_say() {
    let diffuse = Bsdf::Diffuse {
        albedo: Vec3::new(0.8, 0.5, 0.2),
    };
    let plastic = Bsdf::Plastic(Box::new(Plastic::new(
        Vec3::new(0.8, 0.5, 0.2),
        Vec3::ONE,
        1.5,
        false,
    )));
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    // A checkerboard of opacities 0.9 and 0.3: the lookup at the point decides.
    let checker = Opacity::Texture(Arc::new(Texture::Checkerboard {
        color0: Vec3::splat(0.9),
        color1: Vec3::new(0.5, 0.2, 0.4),
        to_uv: Affine2::IDENTITY,
    }));
    let lum = 0.2126 * 0.5 + 0.7152 * 0.2 + 0.0722 * 0.4;
    let cases: [(&str, Bsdf, Vec2, f32); 5] = [
        (
            "diffuse, opacity 0.6",
            mask(diffuse.clone(), Opacity::Constant(0.6), false),
            Vec2::ZERO,
            0.4,
        ),
        (
            "diffuse, textured opacity 0.9",
            mask(diffuse.clone(), checker.clone(), false),
            Vec2::splat(0.25),
            0.1,
        ),
        (
            "rough gold, textured opacity (its luminance)",
            mask(
                Bsdf::rough_conductor(
                    0.3,
                    lodestar::bsdf::ConductorFresnel::Constant(Vec3::new(1.0, 0.8, 0.3)),
                ),
                checker,
                false,
            ),
            Vec2::new(0.75, 0.25),
            1.0 - lum,
        ),
        (
            "smooth plastic, opacity 0.7",
            mask(plastic, Opacity::Constant(0.7), false),
            Vec2::ZERO,
            0.3,
        ),
        (
            "thin dielectric, opacity 0.5",
            mask(
                Bsdf::ThinDielectric { eta: 1.5 },
                Opacity::Constant(0.5),
                false,
            ),
            Vec2::ZERO,
            0.5,
        ),
    ];
    for (k, (name, bsdf, uv, null_share)) in cases.into_iter().enumerate() {
        let sf = sf.with_uv(uv);
        let wo = dir_around(ng, [20.0, 70.0, 130.0][k % 3], 40.0);
        let mode = MODES[k % 2];
        // The thin sheet's straight transmission joins the null lobe's direction.
        let share = if name.starts_with("thin") {
            let cos = wo.dot(ng).abs();
            let r = thin_reflectance(cos, 1.5);
            null_share + 0.5 * (1.0 - r)
        } else {
            null_share
        };
        mask_case(
            &format!("mask over {name}, {mode:?}"),
            &bsdf,
            &sf,
            wo,
            mode,
            share,
        );
    }
}

/// A thin sheet's reflectance `2 R / (1 + R)` (`bsdf/dielectric.rs`), R the Fresnel
/// reflectance of unpolarised light at cosine `cos` for relative index `eta`.
fn thin_reflectance(cos: f32, eta: f32) -> f32 {
    let sin2_t = (1.0 - cos * cos) / (eta * eta);
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos - eta * cos_t) / (cos + eta * cos_t);
    let rp = (eta * cos - cos_t) / (eta * cos + cos_t);
    let r = 0.5 * (rs * rs + rp * rp);
    2.0 * r / (1.0 + r)
}

#[test]
fn a_one_sided_masked_bsdf_absorbs_its_share_from_the_back() {
    let ng = ng_generic();
    let sf = ShadingFrame::new(ng, ng);
    let bsdf = mask(
        Bsdf::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        Opacity::Constant(0.8),
        true,
    );
    let back = dir_around(-ng, 30.0, 10.0);
    let other = dir_around(-ng, 50.0, 200.0);
    assert_eq!(
        bsdf.eval(&sf, back, other, TransportMode::Radiance),
        Vec3::ZERO
    );
    assert_eq!(bsdf.pdf(&sf, back, other, TransportMode::Radiance), 0.0);
    // The wrapped BSDF's share (u_lobe < 0.8) is absorbed, the rest goes straight through.
    for u_lobe in [0.0, 0.5, 0.79] {
        let s = bsdf.sample(&sf, back, u_lobe, Vec2::splat(0.3), TransportMode::Radiance);
        assert!(s.is_none(), "u_lobe {u_lobe}: {s:?}");
    }
    for u_lobe in [0.8, 0.9, 0.99] {
        let s = bsdf
            .sample(&sf, back, u_lobe, Vec2::splat(0.3), TransportMode::Radiance)
            .expect("the null lobe");
        assert!(s.delta && (s.wi + back).length() < 1e-6 && s.weight == Vec3::ONE);
        assert!((s.pdf - 0.2).abs() < 1e-6);
        assert!((bsdf.delta_lobe_probability(&sf, back, s.wi) - 0.2).abs() < 1e-6);
    }
    // From the front the wrapped BSDF is there.
    let front = dir_around(ng, 30.0, 10.0);
    let s = bsdf
        .sample(&sf, front, 0.1, Vec2::splat(0.3), TransportMode::Radiance)
        .expect("the diffuse lobe");
    assert!(!s.delta && (s.pdf - 0.8 * s.wi.dot(ng) / std::f32::consts::PI).abs() < 1e-6);
}
