//! Unit tests of the BSDF interface: `eval_pdfs` and `eval_pdf` against the separate calls;
//! tinted conductors against their base.

use super::*;
use crate::math::{IndependentSampler, Sampler, warp};

/// `eval_pdfs` is the three separate calls, and `eval_pdf` the first two, bit for bit, for every model, both modes, a
/// tilted shading normal and random direction pairs (reflection and transmission).
#[test]
fn eval_pdfs_and_eval_pdf_match_the_separate_calls() {
    let bsdfs = [
        Bsdf::Black,
        Bsdf::Diffuse {
            albedo: Spectrum::new(0.7, 0.5, 0.2),
        },
        Bsdf::Conductor {
            reflectance: Spectrum::splat(0.9),
        },
        Bsdf::Dielectric { eta: 1.5 },
        Bsdf::rough_conductor(0.3, ConductorFresnel::Constant(Spectrum::splat(0.8))),
        Bsdf::rough_conductor(
            0.05,
            ConductorFresnel::Complex {
                eta: Spectrum::new(0.2, 0.9, 1.1),
                k: Spectrum::new(3.9, 2.4, 2.2),
                scale: Spectrum::ONE,
            },
        ),
        Bsdf::rough_dielectric(1.5, 0.2),
        Bsdf::rough_dielectric(1.0 / 1.33, 0.6),
    ];
    let ng = Vec3::new(0.1, 0.2, 1.0).normalize();
    let frames = [
        ShadingFrame::new(ng, ng),
        ShadingFrame::new(Vec3::new(0.3, -0.1, 1.0).normalize(), ng),
    ];
    let mut rng = IndependentSampler::new(11, 0, 0);
    let mut non_zero = 0;
    for bsdf in &bsdfs {
        for sf in &frames {
            for _ in 0..2000 {
                let wo = warp::square_to_uniform_sphere(rng.next_2d());
                let wi = warp::square_to_uniform_sphere(rng.next_2d());
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let got = bsdf.eval_pdfs(sf, wo, wi, mode);
                    let want = EvalPdfs {
                        f: bsdf.eval(sf, wo, wi, mode),
                        pdf_fwd: bsdf.pdf(sf, wo, wi, TransportMode::Radiance),
                        pdf_rev: bsdf.pdf(sf, wi, wo, TransportMode::Radiance),
                    };
                    assert_eq!(got, want, "{bsdf:?} {mode:?} wo {wo} wi {wi}");
                    let pair = bsdf.eval_pdf(sf, wo, wi, mode);
                    assert_eq!(pair, (want.f, want.pdf_fwd), "{bsdf:?} {mode:?} eval_pdf");
                    assert_eq!(got.pdf_fwd, bsdf.pdf(sf, wo, wi, mode));
                    non_zero += (got.pdf_fwd > 0.0 && got.pdf_rev > 0.0) as usize;
                }
            }
        }
    }
    assert!(non_zero > 10_000, "only {non_zero} pairs with densities");
}

/// A tinted conductor is its base times the texture at the frame's coordinates: value,
/// densities (the base's, both ways), the sample's direction and its weight; and its
/// roulette probability the base's times the texture's largest value.
#[test]
fn tinted_conductors_scale_their_base_by_the_texture() {
    let tint = std::sync::Arc::new(crate::texture::Texture::Checkerboard {
        color0: Spectrum::new(0.9, 0.5, 0.2),
        color1: Spectrum::new(0.1, 0.3, 0.6),
        to_uv: glam::Affine2::IDENTITY,
    });
    let bases = [
        Bsdf::rough_conductor(0.3, ConductorFresnel::Constant(Spectrum::splat(0.8))),
        Bsdf::FresnelConductor {
            eta: Spectrum::new(0.2, 0.9, 1.1),
            k: Spectrum::new(3.9, 2.4, 2.2),
            scale: Spectrum::ONE,
        },
    ];
    let ng = Vec3::new(0.1, 0.2, 1.0).normalize();
    let mut rng = IndependentSampler::new(5, 0, 0);
    for base in bases {
        let tinted = Bsdf::tinted(base.clone(), tint.clone());
        assert!(tinted.is_textured() && tinted.is_delta() == base.is_delta());
        assert_eq!(tinted.continuation(), base.continuation() * 0.9);
        for uv in [Vec2::new(0.2, 0.3), Vec2::new(0.7, 0.2)] {
            let t = tint.eval(uv);
            let sf = ShadingFrame::new(ng, ng).with_uv(uv);
            for _ in 0..200 {
                let wo = warp::square_to_uniform_sphere(rng.next_2d());
                let wi = warp::square_to_uniform_sphere(rng.next_2d());
                let mode = TransportMode::Radiance;
                let (a, b) = (
                    tinted.eval_pdfs(&sf, wo, wi, mode),
                    base.eval_pdfs(&sf, wo, wi, mode),
                );
                assert_eq!((a.f, a.pdf_fwd, a.pdf_rev), (b.f * t, b.pdf_fwd, b.pdf_rev));
                assert_eq!(
                    tinted.eval(&sf, wo, wi, mode),
                    base.eval(&sf, wo, wi, mode) * t
                );
                assert_eq!(tinted.pdf(&sf, wo, wi, mode), base.pdf(&sf, wo, wi, mode));
                let (ul, u) = (rng.next_1d(), rng.next_2d());
                match (
                    tinted.sample(&sf, wo, ul, u, mode),
                    base.sample(&sf, wo, ul, u, mode),
                ) {
                    (Some(a), Some(b)) => {
                        assert_eq!((a.wi, a.pdf, a.delta), (b.wi, b.pdf, b.delta));
                        assert_eq!((a.f, a.weight), (b.f * t, b.weight * t));
                    }
                    (None, None) => {}
                    (a, b) => panic!("tinted {a:?} against base {b:?}"),
                }
            }
        }
    }
}
