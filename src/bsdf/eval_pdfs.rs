//! [`Bsdf::eval_pdfs`]: a BSDF's value and its densities in both directions in one call, what
//! a connection between two subpaths needs at each end.

use super::{
    Bsdf, ShadingFrame, TransportMode, diffuse, geometry_agrees, plastic, rough_conductor,
    rough_dielectric, rough_diffuse, rough_plastic, shading_correction,
};
use crate::math::Spectrum;
use glam::Vec3;

/// `f(wo, wi)` and the densities of sampling either direction from the other: what a
/// connection between two subpaths needs at each end (see [`Bsdf::eval_pdfs`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalPdfs {
    /// As [`Bsdf::eval`] (no cosine).
    pub f: Spectrum,
    /// As [`Bsdf::pdf`] of `wi` given `wo`.
    pub pdf_fwd: f32,
    /// As [`Bsdf::pdf`] of `wo` given `wi`.
    pub pdf_rev: f32,
}

impl EvalPdfs {
    /// No value and no density either way: what a delta lobe or an impossible pair of
    /// directions gives.
    pub const ZERO: EvalPdfs = EvalPdfs {
        f: Spectrum::ZERO,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
    };
}

impl Bsdf {
    /// `eval(wo, wi)`, `pdf(wo -> wi)` and `pdf(wi -> wo)` in one call, sharing the frame
    /// transforms and side checks; bit-identical to the three separate calls (densities do
    /// not depend on `mode`). Zero for delta lobes.
    pub fn eval_pdfs(
        &self,
        sf: &ShadingFrame,
        wo: Vec3,
        wi: Vec3,
        mode: TransportMode,
    ) -> EvalPdfs {
        self.eval_with_pdfs(sf, wo, wi, mode, true)
    }

    /// `eval(wo, wi)` and `pdf(wo -> wi)` in one call (next-event estimation's pair), sharing
    /// the frame transforms, side checks and, for the microfacet models, the evaluation
    /// itself; bit-identical to the two separate calls.
    pub fn eval_pdf(
        &self,
        sf: &ShadingFrame,
        wo: Vec3,
        wi: Vec3,
        mode: TransportMode,
    ) -> (Spectrum, f32) {
        let e = self.eval_with_pdfs(sf, wo, wi, mode, false);
        (e.f, e.pdf_fwd)
    }

    /// [`Bsdf::eval_pdfs`], with `pdf_rev` left 0 unless `reverse`.
    #[inline(always)]
    fn eval_with_pdfs(
        &self,
        sf: &ShadingFrame,
        wo: Vec3,
        wi: Vec3,
        mode: TransportMode,
        reverse: bool,
    ) -> EvalPdfs {
        let (wo_l, wi_l) = (sf.frame.to_local(wo), sf.frame.to_local(wi));
        let transmission = wo_l.z * wi_l.z < 0.0;
        if !geometry_agrees(sf, wo, wi, transmission) {
            return EvalPdfs::ZERO;
        }
        let (f, pdf_fwd, pdf_rev) = match self {
            // Both densities (`reverse` only saves work).
            Bsdf::Tinted { base, tint } => {
                return super::tinted::eval_pdfs(base, tint, sf, wo, wi, mode);
            }
            Bsdf::Mask(m) => return super::mask::eval_pdfs(m, sf, wo, wi, mode),
            Bsdf::Blend(b) => return super::blend::eval_pdfs(b, sf, wo, wi, mode),
            Bsdf::TexturedDiffuse { albedo } => (
                diffuse::eval(albedo.eval(sf.uv), wo_l, wi_l),
                diffuse::pdf(wo_l, wi_l),
                if reverse {
                    diffuse::pdf(wi_l, wo_l)
                } else {
                    0.0
                },
            ),
            Bsdf::Diffuse { albedo } => (
                diffuse::eval(*albedo, wo_l, wi_l),
                diffuse::pdf(wo_l, wi_l),
                if reverse {
                    diffuse::pdf(wi_l, wo_l)
                } else {
                    0.0
                },
            ),
            Bsdf::RoughDiffuse { albedo, alpha } => (
                rough_diffuse::eval(*albedo, *alpha, wo_l, wi_l),
                diffuse::pdf(wo_l, wi_l),
                if reverse {
                    diffuse::pdf(wi_l, wo_l)
                } else {
                    0.0
                },
            ),
            Bsdf::RoughConductor {
                alpha,
                fresnel,
                distribution,
            } => {
                let (f, pdf_fwd) = rough_conductor::eval_pdf(
                    alpha.microfacet(*distribution, sf.uv),
                    Some(fresnel),
                    wo_l,
                    wi_l,
                );
                let pdf_rev = if reverse {
                    rough_conductor::eval_pdf(
                        alpha.microfacet(*distribution, sf.uv),
                        None,
                        wi_l,
                        wo_l,
                    )
                    .1
                } else {
                    0.0
                };
                (f, pdf_fwd, pdf_rev)
            }
            Bsdf::RoughDielectric {
                eta,
                alpha,
                distribution,
            } => {
                let (f, pdf_fwd) = rough_dielectric::eval_pdf(
                    *eta,
                    alpha.microfacet(*distribution, sf.uv),
                    wo_l,
                    wi_l,
                    mode,
                );
                let pdf_rev = if reverse {
                    rough_dielectric::eval_pdf(
                        *eta,
                        alpha.microfacet(*distribution, sf.uv),
                        wi_l,
                        wo_l,
                        TransportMode::Radiance,
                    )
                    .1
                } else {
                    0.0
                };
                (Spectrum::splat(f), pdf_fwd, pdf_rev)
            }
            Bsdf::Plastic(p) => {
                let (f, pdf_fwd) = plastic::eval_pdf(p, wo_l, wi_l, true, sf.uv);
                let pdf_rev = if reverse {
                    plastic::eval_pdf(p, wi_l, wo_l, false, sf.uv).1
                } else {
                    0.0
                };
                (f, pdf_fwd, pdf_rev)
            }
            Bsdf::RoughPlastic(p) => {
                let (f, pdf_fwd) = rough_plastic::eval_pdf(p, wo_l, wi_l, true, sf.uv);
                let pdf_rev = if reverse {
                    rough_plastic::eval_pdf(p, wi_l, wo_l, false, sf.uv).1
                } else {
                    0.0
                };
                (f, pdf_fwd, pdf_rev)
            }
            Bsdf::Black
            | Bsdf::Conductor { .. }
            | Bsdf::FresnelConductor { .. }
            | Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. } => {
                return EvalPdfs::ZERO;
            }
        };
        EvalPdfs {
            f: f * shading_correction(sf, wo, wi, mode),
            pdf_fwd,
            pdf_rev,
        }
    }
}
