//! Unit tests of the BSDF interface: `eval_pdfs` and `eval_pdf` against the separate calls.

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
