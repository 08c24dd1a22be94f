//! Statistical and reference tests of smooth plastic (`Bsdf::Plastic`, a delta lobe beside
//! a diffuse one):
//! * chi-square of the diffuse lobe's directions against `pdf()` with the delta samples
//!   counted as failed draws (`common/chi2.rs`), so that the mass test checks the lobe choice
//!   (`pdf` integrates to `1 - P_s`); each delta sample must be the mirror direction with
//!   `pdf` the lobe probability and `weight` the lobe's value (`delta_value`) over it;
//! * values, densities and weights against Mitsuba 3's `plastic` at fixed directions.

use crate::chi2_bsdf::{N_DIR, reflect, tilted};
use crate::common;

use common::chi2::{self, SphereDomain};
use common::{Failures, MODES, close, close3, dir_around, ng_generic};
use glam::{Vec2, Vec3};
use lodestar::bsdf::{Bsdf, Plastic, ShadingFrame, TransportMode};
use lodestar::math::Sampler;

fn plastic(nonlinear: bool) -> Bsdf {
    Bsdf::Plastic(Box::new(Plastic::new(
        Vec3::new(0.8, 0.5, 0.2),
        Vec3::ONE,
        1.5,
        nonlinear,
    )))
}

/// One chi-square case of smooth plastic (see the module docs).
fn plastic_case(name: &str, bsdf: &Bsdf, sf: &ShadingFrame, wo: Vec3, mode: TransportMode) {
    let ns = sf.frame.n;
    let mut fails = Failures::new();
    let mut deltas = 0usize;
    let report = chi2::spherical(
        name,
        N_DIR,
        &SphereDomain::full_around(sf.ng),
        |s: &mut dyn Sampler| {
            let u_lobe = s.next_1d();
            let u = s.next_2d();
            let smp = bsdf.sample(sf, wo, u_lobe, u, mode)?;
            let wi = smp.wi;
            if smp.delta {
                deltas += 1;
                let p = bsdf.delta_lobe_probability(sf, wo, wi);
                let value = bsdf.delta_value(sf, wo, wi);
                fails.check((wi - reflect(wo, ns)).length() < 1e-5, || {
                    format!("delta sample {wi} is not the mirror direction")
                });
                fails.check(close(smp.pdf as f64, p as f64, 1e-5, 0.0), || {
                    format!("delta pdf {} != lobe probability {p}", smp.pdf)
                });
                if mode == TransportMode::Radiance {
                    fails.check(close3(smp.weight, value / p, 1e-4, 1e-7), || {
                        format!("delta weight {} != value / p {}", smp.weight, value / p)
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
    assert!(deltas > 0, "{name}: the coating was never sampled");
}

#[test]
fn plastic_samples_its_lobes_as_its_densities_say() {
    // `nonlinear` changes the base's value only (`plastic_matches_mitsuba`), not sampling.
    let bsdf = plastic(false);
    for (k, (ns, ng)) in [
        (Vec3::Z, Vec3::Z),
        (tilted(ng_generic(), 15.0), ng_generic()),
    ]
    .into_iter()
    .enumerate()
    {
        let sf = ShadingFrame::new(ns, ng);
        for theta in [10.0, 85.0, 150.0] {
            let wo = dir_around(ng, theta, 30.0);
            let mode = MODES[k % 2];
            plastic_case(
                &format!("plastic frame #{k} wo {theta} deg {mode:?}"),
                &bsdf,
                &sf,
                wo,
                mode,
            );
        }
    }
}

/// Mitsuba 3.9.1's `plastic` (diffuse_reflectance (0.8, 0.5, 0.2), int_ior 1.5, ext_ior 1,
/// nonlinear off and on) at fixed directions: `eval` (its value includes the cosine), `pdf`,
/// and the coating's sample (`sample1` = 0): its probability and weight. Directions as
/// (polar, azimuth) in degrees; Mitsuba's `si.wi` is lodestar's `wo`.
#[test]
fn plastic_matches_mitsuba() {
    let d = |theta: f32, phi: f32| {
        let (t, p) = (theta.to_radians(), phi.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    };
    type Row = ((f32, f32), (f32, f32), [f32; 3], f32, f32, f32);
    let linear: [Row; 3] = [
        (
            (20.0, 0.0),
            (40.0, 120.0),
            [0.196935, 0.123084, 0.049234],
            0.224963,
            0.077415,
            0.520133,
        ),
        (
            (70.0, 10.0),
            (15.0, 200.0),
            [0.215754, 0.134847, 0.053939],
            0.217647,
            0.292120,
            0.585521,
        ),
        (
            (85.0, 0.0),
            (60.0, 90.0),
            [0.049498, 0.030936, 0.012374],
            0.038210,
            0.759920,
            0.806400,
        ),
    ];
    let nonlinear: [[f32; 3]; 3] = [
        [0.151951, 0.070734, 0.022541],
        [0.166471, 0.077493, 0.024695],
        [0.038191, 0.017778, 0.005665],
    ];
    let sf = ShadingFrame::new(Vec3::Z, Vec3::Z);
    for (nl, bsdf) in [(false, plastic(false)), (true, plastic(true))] {
        for (i, &(a, b, f_lin, pdf, p_spec, w_spec)) in linear.iter().enumerate() {
            let (wo, wi) = (d(a.0, a.1), d(b.0, b.1));
            let f = bsdf.eval(&sf, wo, wi, TransportMode::Radiance) * wi.z;
            let want = Vec3::from(if nl { nonlinear[i] } else { f_lin });
            assert!(
                close3(f, want, 2e-4, 1e-6),
                "nonlinear {nl} #{i}: f {f} != {want}"
            );
            let p = bsdf.pdf(&sf, wo, wi, TransportMode::Radiance);
            assert!(
                close(p as f64, pdf as f64, 2e-4, 0.0),
                "#{i}: pdf {p} != {pdf}"
            );
            let s = bsdf
                .sample(&sf, wo, 0.0, Vec2::splat(0.5), TransportMode::Radiance)
                .unwrap();
            assert!(s.delta, "#{i}: u_lobe 0 picks the coating");
            assert!(
                close(s.pdf as f64, p_spec as f64, 2e-4, 0.0),
                "#{i}: {}",
                s.pdf
            );
            assert!(
                close3(s.weight, Vec3::splat(w_spec), 2e-4, 0.0),
                "#{i}: weight {}",
                s.weight
            );
        }
    }
}
