//! BSDFs: what a surface does to light.
//!
//! # Conventions (read before porting from pbrt or Mitsuba)
//! * `wo` points from the surface back along the path being built (towards the camera for
//!   camera paths, towards the light for light paths); `wi` is the direction being sampled or
//!   evaluated. Both point away from the surface and are unit length. (This is pbrt's naming.)
//! * `eval` returns the BSDF value `f(wo, wi)` without the cosine; `pdf` the solid-angle
//!   density of `sample` choosing `wi` given `wo`. A [`BsdfSample`] also carries
//!   `weight = f |cos(wi, ns)| / pdf`.
//! * Delta (specular) lobes: `f` is the lobe's reflectance over `|cos|`, and `pdf` the discrete
//!   probability of picking that lobe, so that `weight` is right; `eval` and `pdf` return zero
//!   for them, as no direction is hit with non-zero density.
//! * [`TransportMode`]: `Radiance` for paths from the camera, `Importance` for paths from
//!   lights. Refraction scales radiance by `1/eta^2` in radiance mode only, and shading normals
//!   get Veach's adjoint correction in importance mode, so BDPT can reuse these BSDFs.
//! * Sidedness: diffuse and conductor surfaces are **two-sided** (they reflect on whichever side
//!   `wo` is, like pbrt and unlike Mitsuba's default). A dielectric's outside is its front side
//!   (the shape's geometric normal). Reflection requires `wo` and `wi` on the same side of both
//!   the shading and the geometric normal; transmission on opposite sides of both. Directions
//!   where the two normals disagree get zero (no light leaks), consistently in sample, eval and
//!   pdf.
//! * Rough (microfacet) BSDFs use GGX or Beckmann with visible-normal sampling (see
//!   [`microfacet`]);
//!   their `eval`, `pdf` and `sample` share one function, so a sample's `f` and `pdf` are
//!   what `eval` and `pdf` return for its direction. Samples that a lobe scatters to the wrong
//!   side of the macro surface are dropped (`None`), and `eval`/`pdf` give them no density.

mod blend;
mod delta;
mod dielectric;
mod diffuse;
mod eval_pdfs;
mod frame;
pub mod fresnel;
mod mask;
pub mod microfacet;
mod plastic;
mod rough_conductor;
mod rough_dielectric;
mod rough_diffuse;
mod rough_plastic;
mod roughness;
mod tinted;

use crate::math::Spectrum;
pub use blend::Blend;
pub use eval_pdfs::EvalPdfs;
pub use frame::ShadingFrame;
use frame::{geometry_agrees, shading_correction};
pub use fresnel::ConductorFresnel;
use glam::{Vec2, Vec3};
pub use mask::{Mask, Opacity};
pub use microfacet::Distribution;
pub use plastic::Plastic;
pub use rough_plastic::RoughPlastic;
pub use roughness::Alpha;

/// Lowest Russian-roulette continuation probability (caps the weight boost at 20x).
pub const MIN_CONTINUATION: f32 = 0.05;

/// What the path being built carries, which decides the non-symmetric factors of a BSDF.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransportMode {
    /// A path from the camera: refraction scales by `1/eta^2`.
    Radiance,
    /// A path from a light: shading normals get Veach's adjoint correction.
    Importance,
}

/// A direction drawn by [`Bsdf::sample`] with its value, density and weight.
#[derive(Debug, Clone, Copy)]
pub struct BsdfSample {
    /// Sampled direction (world space).
    pub wi: Vec3,
    /// BSDF value (no cosine).
    pub f: Spectrum,
    /// Solid-angle density, or the lobe probability for delta lobes.
    pub pdf: f32,
    /// `f |cos(wi, ns)| / pdf`, including the importance-mode shading-normal correction.
    pub weight: Spectrum,
    /// Whether a delta (specular) lobe was sampled: `pdf` is then a discrete probability.
    pub delta: bool,
    /// Whether `wi` crosses the surface (refraction) rather than reflecting.
    pub transmission: bool,
    /// Relative index of refraction crossed (n_wi_side / n_wo_side); 1 for reflection.
    pub eta: f32,
}

/// A BSDF. A closed set of models, dispatched by `match`.
#[derive(Debug, Clone, PartialEq)]
pub enum Bsdf {
    /// Absorbs everything (e.g. the back of an emitter).
    Black,
    /// Lambertian reflection with the given albedo.
    Diffuse {
        /// Diffuse reflectance per channel, in [0, 1].
        albedo: Spectrum,
    },
    /// Lambertian reflection with an albedo looked up in a texture at the point's texture
    /// coordinates (`ShadingFrame::uv`).
    TexturedDiffuse {
        /// Diffuse reflectance per channel, in [0, 1].
        albedo: std::sync::Arc<crate::texture::Texture>,
    },
    /// Rough diffuse reflection (Oren-Nayar with interreflection, Mitsuba 0.6's
    /// `roughdiffuse`), two-sided, of facet roughness `alpha` (Beckmann-style; 0 is Lambert).
    RoughDiffuse {
        /// Reflectance of the facets per channel, in [0, 1].
        albedo: Spectrum,
        /// Roughness.
        alpha: f32,
    },
    /// Smooth conductor: a perfect mirror with an RGB reflectance.
    Conductor {
        /// Reflectance per channel at every angle.
        reflectance: Spectrum,
    },
    /// Smooth conductor with the exact Fresnel reflectance of complex index `eta + i k`
    /// (relative to the outside; Mitsuba's `conductor` with `eta` and `k`): a mirror whose
    /// reflectance rises towards grazing angles.
    FresnelConductor {
        /// Real part of the relative index, per channel.
        eta: Spectrum,
        /// Extinction coefficient, per channel.
        k: Spectrum,
        /// Factor on the reflectance per channel (Mitsuba's `specular_reflectance`).
        scale: Spectrum,
    },
    /// Smooth dielectric interface; `eta` = index inside / index outside (front side).
    Dielectric {
        /// Index inside over index outside.
        eta: f32,
    },
    /// A thin dielectric sheet (Mitsuba's `thindielectric`, e.g. a window pane): specular
    /// reflection with the sheet's reflectance `2 R / (1 + R)` (every internal bounce
    /// included), else straight through; `eta` = index of the sheet over the outside's.
    ThinDielectric {
        /// Index of the sheet over index outside.
        eta: f32,
    },
    /// Rough conductor: GGX microfacet reflection of roughness `alpha` (clamped to at least
    /// [`microfacet::MIN_ALPHA`] when evaluated), two-sided. Build with
    /// [`Bsdf::rough_conductor`].
    RoughConductor {
        /// Roughness (the slope distribution's width), perhaps textured.
        alpha: Alpha,
        /// Reflectance of the microfacets.
        fresnel: ConductorFresnel,
        /// GGX (the default) or Beckmann.
        distribution: Distribution,
    },
    /// Rough dielectric interface (Walter et al. 2007): GGX reflection and transmission of
    /// roughness `alpha`; `eta` = index inside / index outside (front side), as for
    /// [`Bsdf::Dielectric`]. Build with [`Bsdf::rough_dielectric`].
    RoughDielectric {
        /// Index inside over index outside.
        eta: f32,
        /// Roughness, perhaps textured.
        alpha: Alpha,
        /// GGX (the default) or Beckmann.
        distribution: Distribution,
    },
    /// Rough plastic (Mitsuba's `roughplastic`): a rough dielectric coating over a
    /// Lambertian base, two-sided ([`RoughPlastic`]; boxed for its tables).
    RoughPlastic(Box<RoughPlastic>),
    /// Smooth plastic (Mitsuba's `plastic`): a smooth dielectric coating over a Lambertian
    /// base, two-sided ([`Plastic`]): a delta lobe (the coating's mirror reflection) beside a
    /// non-delta one ([`Bsdf::has_delta_lobe`]).
    Plastic(Box<Plastic>),
    /// A BSDF that is only partly there (Mitsuba's `mask`): the wrapped BSDF times the
    /// opacity beside a null lobe that lets the rest of the light through unchanged
    /// ([`Mask`]); delta on the null lobe, like smooth plastic's coating.
    Mask(Box<Mask>),
    /// Two BSDFs without delta lobes mixed by a weight, a number or a texture (Mitsuba's
    /// `blendbsdf`, [`Blend`]).
    Blend(Box<Blend>),
    /// A conductor (smooth or rough) whose value is multiplied per channel by a texture at
    /// the point's texture coordinates (Mitsuba's textured `specular_reflectance`): sampling
    /// and densities are the conductor's. Build with [`Bsdf::tinted`].
    Tinted {
        /// A `Conductor`, `FresnelConductor` or `RoughConductor`.
        base: Box<Bsdf>,
        /// Factor on the value per channel, in [0, 1].
        tint: std::sync::Arc<crate::texture::Texture>,
    },
}

impl Bsdf {
    /// A rough conductor; a constant `alpha` is clamped to at least [`microfacet::MIN_ALPHA`].
    pub fn rough_conductor(alpha: impl Into<Alpha>, fresnel: ConductorFresnel) -> Bsdf {
        Bsdf::RoughConductor {
            alpha: alpha.into(),
            fresnel,
            distribution: Distribution::Ggx,
        }
    }

    /// A rough dielectric; a constant `alpha` is clamped to at least
    /// [`microfacet::MIN_ALPHA`].
    pub fn rough_dielectric(eta: f32, alpha: impl Into<Alpha>) -> Bsdf {
        Bsdf::RoughDielectric {
            eta,
            alpha: alpha.into(),
            distribution: Distribution::Ggx,
        }
    }

    /// The conductor `base` with its value multiplied by `tint` at the point's texture
    /// coordinates ([`Bsdf::Tinted`]).
    pub fn tinted(base: Bsdf, tint: std::sync::Arc<crate::texture::Texture>) -> Bsdf {
        debug_assert!(matches!(
            base,
            Bsdf::Conductor { .. } | Bsdf::FresnelConductor { .. } | Bsdf::RoughConductor { .. }
        ));
        Bsdf::Tinted {
            base: Box::new(base),
            tint,
        }
    }

    /// This BSDF with microfacet distribution `d` (rough BSDFs; others are returned as they
    /// are).
    pub fn with_distribution(self, d: Distribution) -> Bsdf {
        match self {
            Bsdf::Tinted { base, tint } => Bsdf::Tinted {
                base: Box::new(base.with_distribution(d)),
                tint,
            },
            Bsdf::RoughConductor { alpha, fresnel, .. } => Bsdf::RoughConductor {
                alpha,
                fresnel,
                distribution: d,
            },
            Bsdf::RoughDielectric { eta, alpha, .. } => Bsdf::RoughDielectric {
                eta,
                alpha,
                distribution: d,
            },
            other => other,
        }
    }

    /// True if the BSDF only has delta lobes (no direction has a non-zero density).
    #[inline]
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Mask(m) => m.inner_delta,
            Bsdf::Tinted { base, .. } => {
                matches!(
                    **base,
                    Bsdf::Conductor { .. } | Bsdf::FresnelConductor { .. }
                )
            }
            _ => matches!(
                self,
                Bsdf::Conductor { .. }
                    | Bsdf::FresnelConductor { .. }
                    | Bsdf::Dielectric { .. }
                    | Bsdf::ThinDielectric { .. }
            ),
        }
    }

    /// True if the BSDF reads the point's texture coordinates (`ShadingFrame::uv`).
    #[inline]
    pub fn is_textured(&self) -> bool {
        match self {
            Bsdf::TexturedDiffuse { .. } | Bsdf::Tinted { .. } => true,
            Bsdf::RoughPlastic(p) => p.diffuse_texture.is_some(),
            Bsdf::RoughConductor { alpha, .. } | Bsdf::RoughDielectric { alpha, .. } => {
                alpha.is_textured()
            }
            Bsdf::Plastic(p) => p.diffuse_texture.is_some(),
            Bsdf::Mask(m) => m.textured,
            Bsdf::Blend(b) => {
                matches!(b.weight, Opacity::Texture(_))
                    || b.first.is_textured()
                    || b.second.is_textured()
            }
            _ => false,
        }
    }

    /// True if the BSDF's roughness differs between the two tangent directions: it is then
    /// evaluated in a shading frame whose `s` axis follows the surface's `dp/du`
    /// ([`ShadingFrame::with_tangent`]), as Mitsuba's are.
    #[inline]
    pub fn is_anisotropic(&self) -> bool {
        match self {
            Bsdf::RoughConductor { alpha, .. } | Bsdf::RoughDielectric { alpha, .. } => {
                alpha.is_anisotropic()
            }
            Bsdf::Tinted { base, .. } => base.is_anisotropic(),
            Bsdf::Mask(m) => m.inner.is_anisotropic(),
            Bsdf::Blend(b) => b.first.is_anisotropic() || b.second.is_anisotropic(),
            _ => false,
        }
    }

    /// True if the BSDF scatters no light at all.
    pub fn is_black(&self) -> bool {
        matches!(self, Bsdf::Black)
    }

    /// Roughness in [0, 1]: 0 for specular lobes, 1 for diffuse. Microfacet BSDFs give the
    /// "perceptual" roughness `sqrt(alpha)` (the inverse of the usual `alpha = r^2` mapping,
    /// Burley 2012), capped at 1: 0.01 at the minimum alpha 1e-4, 0.32 at alpha 0.1, 1 for
    /// alpha >= 1.
    pub fn roughness(&self) -> f32 {
        match self {
            // Rough plastic: its Lambertian base scatters everywhere.
            Bsdf::Black
            | Bsdf::Diffuse { .. }
            | Bsdf::TexturedDiffuse { .. }
            | Bsdf::RoughDiffuse { .. }
            | Bsdf::RoughPlastic(_)
            | Bsdf::Plastic(_) => 1.0,
            Bsdf::Conductor { .. }
            | Bsdf::FresnelConductor { .. }
            | Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. } => 0.0,
            // A textured roughness: the smoothest it gets.
            Bsdf::RoughConductor { alpha, .. } | Bsdf::RoughDielectric { alpha, .. } => {
                alpha.smallest().sqrt().min(1.0)
            }
            // The base is a conductor, smooth or rough.
            Bsdf::Tinted { base, .. } => base.roughness(),
            Bsdf::Mask(m) => m.inner.roughness(),
            // The smoother of the two.
            Bsdf::Blend(b) => b.first.roughness().min(b.second.roughness()),
        }
    }

    /// Russian-roulette continuation probability of a path leaving this surface: the largest
    /// channel of its reflectance (1 for dielectrics and Fresnel conductors), at least
    /// [`MIN_CONTINUATION`]. It depends on the surface only, not on the directions or the path,
    /// so the density of any complete path, roulette included, can be computed from either end.
    #[inline]
    pub fn continuation(&self) -> f32 {
        let q = match self {
            Bsdf::Black => return 0.0,
            Bsdf::Diffuse { albedo } | Bsdf::RoughDiffuse { albedo, .. } => albedo.max_element(),
            Bsdf::TexturedDiffuse { albedo } => albedo.max(),
            Bsdf::Conductor { reflectance } => reflectance.max_element(),
            Bsdf::RoughConductor {
                fresnel: ConductorFresnel::Constant(r),
                ..
            } => r.max_element(),
            Bsdf::RoughPlastic(p) => p.diffuse_max().max(p.specular.max_element()),
            Bsdf::Plastic(p) => p.max_reflectance(),
            Bsdf::RoughConductor {
                fresnel: ConductorFresnel::Complex { scale, .. },
                ..
            }
            | Bsdf::FresnelConductor { scale, .. } => scale.max_element(),
            // The base's largest reflectance (at most 1) times the texture's largest texel.
            Bsdf::Tinted { base, tint } => tinted::continuation(base, tint),
            Bsdf::Mask(m) => mask::continuation(m),
            Bsdf::Blend(b) => blend::continuation(b),
            Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. }
            | Bsdf::RoughDielectric { .. } => 1.0,
        };
        q.clamp(MIN_CONTINUATION, 1.0)
    }

    /// Sample `wi` given `wo`. `u_lobe` picks a lobe, `u` the direction. `None` if the sample
    /// carries no energy (absorbed, below the surface, or rejected by the normal checks).
    pub fn sample(
        &self,
        sf: &ShadingFrame,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        let wo_l = sf.frame.to_local(wo);
        if wo_l.z == 0.0 {
            return None;
        }
        let s = match self {
            Bsdf::Black => return None,
            Bsdf::Diffuse { albedo } => diffuse::sample(*albedo, wo_l, u)?,
            Bsdf::TexturedDiffuse { albedo } => diffuse::sample(albedo.eval(sf.uv), wo_l, u)?,
            Bsdf::RoughDiffuse { albedo, alpha } => {
                rough_diffuse::sample(*albedo, *alpha, wo_l, u)?
            }
            Bsdf::Conductor { reflectance } => LocalSample::mirror(wo_l, *reflectance, 1.0),
            Bsdf::FresnelConductor { eta, k, scale } => {
                LocalSample::mirror(wo_l, fresnel::conductor(wo_l.z, *eta, *k) * *scale, 1.0)
            }
            Bsdf::Dielectric { eta } => dielectric::sample(*eta, wo_l, u_lobe, mode)?,
            Bsdf::ThinDielectric { eta } => dielectric::thin_sample(*eta, wo_l, u_lobe)?,
            Bsdf::RoughConductor {
                alpha,
                fresnel,
                distribution,
            } => rough_conductor::sample(alpha.microfacet(*distribution, sf.uv), fresnel, wo_l, u)?,
            Bsdf::RoughDielectric {
                eta,
                alpha,
                distribution,
            } => rough_dielectric::sample(
                *eta,
                alpha.microfacet(*distribution, sf.uv),
                wo_l,
                u_lobe,
                u,
                mode,
            )?,
            Bsdf::RoughPlastic(p) => rough_plastic::sample(p, wo_l, u_lobe, u, sf.uv)?,
            Bsdf::Plastic(p) => plastic::sample(p, wo_l, u_lobe, u, sf.uv)?,
            Bsdf::Tinted { base, tint } => {
                return tinted::sample(base, tint, sf, wo, u_lobe, u, mode);
            }
            Bsdf::Mask(m) => return mask::sample(m, sf, wo, u_lobe, u, mode),
            Bsdf::Blend(b) => return blend::sample(b, sf, wo, u_lobe, u, mode),
        };
        let wi = sf.frame.to_world(s.wi);
        if !geometry_agrees(sf, wo, wi, s.transmission) {
            return None;
        }
        let cos = s.wi.z.abs();
        let f = s.f * shading_correction(sf, wo, wi, mode);
        let weight = f * cos / s.pdf;
        if !(weight.is_finite() && s.pdf > 0.0) || weight == Vec3::ZERO {
            return None;
        }
        Some(BsdfSample {
            wi,
            f,
            pdf: s.pdf,
            weight,
            delta: s.delta,
            transmission: s.transmission,
            eta: s.eta,
        })
    }

    /// `f(wo, wi)` without the cosine. Zero for delta lobes.
    pub fn eval(&self, sf: &ShadingFrame, wo: Vec3, wi: Vec3, mode: TransportMode) -> Spectrum {
        let (wo_l, wi_l) = (sf.frame.to_local(wo), sf.frame.to_local(wi));
        let transmission = wo_l.z * wi_l.z < 0.0;
        if !geometry_agrees(sf, wo, wi, transmission) {
            return Spectrum::ZERO;
        }
        let f = match self {
            Bsdf::Tinted { base, tint } => return tinted::eval(base, tint, sf, wo, wi, mode),
            Bsdf::Mask(m) => return mask::eval(m, sf, wo, wi, mode),
            Bsdf::Blend(b) => return blend::eval(b, sf, wo, wi, mode),
            Bsdf::Diffuse { albedo } => diffuse::eval(*albedo, wo_l, wi_l),
            Bsdf::TexturedDiffuse { albedo } => diffuse::eval(albedo.eval(sf.uv), wo_l, wi_l),
            Bsdf::RoughDiffuse { albedo, alpha } => {
                rough_diffuse::eval(*albedo, *alpha, wo_l, wi_l)
            }
            Bsdf::RoughConductor {
                alpha,
                fresnel,
                distribution,
            } => {
                rough_conductor::eval_pdf(
                    alpha.microfacet(*distribution, sf.uv),
                    Some(fresnel),
                    wo_l,
                    wi_l,
                )
                .0
            }
            Bsdf::RoughDielectric {
                eta,
                alpha,
                distribution,
            } => Spectrum::splat(
                rough_dielectric::eval_pdf(
                    *eta,
                    alpha.microfacet(*distribution, sf.uv),
                    wo_l,
                    wi_l,
                    mode,
                )
                .0,
            ),
            Bsdf::RoughPlastic(p) => rough_plastic::eval_pdf(p, wo_l, wi_l, true, sf.uv).0,
            Bsdf::Plastic(p) => plastic::eval_pdf(p, wo_l, wi_l, true, sf.uv).0,
            Bsdf::Black
            | Bsdf::Conductor { .. }
            | Bsdf::FresnelConductor { .. }
            | Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. } => {
                return Spectrum::ZERO;
            }
        };
        f * shading_correction(sf, wo, wi, mode)
    }

    /// Solid-angle density of `sample` producing `wi` from `wo`. Zero for delta lobes.
    pub fn pdf(&self, sf: &ShadingFrame, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
        let (wo_l, wi_l) = (sf.frame.to_local(wo), sf.frame.to_local(wi));
        let transmission = wo_l.z * wi_l.z < 0.0;
        if !geometry_agrees(sf, wo, wi, transmission) {
            return 0.0;
        }
        match self {
            Bsdf::Diffuse { .. } | Bsdf::TexturedDiffuse { .. } | Bsdf::RoughDiffuse { .. } => {
                diffuse::pdf(wo_l, wi_l)
            }
            Bsdf::RoughConductor {
                alpha,
                distribution,
                ..
            } => {
                rough_conductor::eval_pdf(alpha.microfacet(*distribution, sf.uv), None, wo_l, wi_l)
                    .1
            }
            Bsdf::RoughDielectric {
                eta,
                alpha,
                distribution,
            } => {
                rough_dielectric::eval_pdf(
                    *eta,
                    alpha.microfacet(*distribution, sf.uv),
                    wo_l,
                    wi_l,
                    mode,
                )
                .1
            }
            Bsdf::RoughPlastic(p) => rough_plastic::eval_pdf(p, wo_l, wi_l, false, sf.uv).1,
            Bsdf::Plastic(p) => plastic::eval_pdf(p, wo_l, wi_l, false, sf.uv).1,
            Bsdf::Tinted { base, .. } => tinted::pdf(base, sf, wo, wi, mode),
            Bsdf::Mask(m) => mask::pdf(m, sf, wo, wi, mode),
            Bsdf::Blend(b) => blend::pdf(b, sf, wo, wi, mode),
            Bsdf::Black
            | Bsdf::Conductor { .. }
            | Bsdf::FresnelConductor { .. }
            | Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. } => 0.0,
        }
    }
}

/// A sample in the local shading frame, before the checks and corrections of [`Bsdf::sample`].
pub(crate) struct LocalSample {
    pub wi: Vec3,
    pub f: Spectrum,
    pub pdf: f32,
    pub delta: bool,
    pub transmission: bool,
    pub eta: f32,
}

impl LocalSample {
    /// The specular reflection of `wo` (about the local normal) carrying `reflectance`, picked
    /// with discrete probability `probability`.
    pub(crate) fn mirror(wo: Vec3, reflectance: Spectrum, probability: f32) -> LocalSample {
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        LocalSample {
            wi,
            f: reflectance / wi.z.abs(),
            pdf: probability,
            delta: true,
            transmission: false,
            eta: 1.0,
        }
    }

    /// A non-delta reflection to `wi` with value `f` and density `pdf`; `None` without
    /// density.
    pub(crate) fn glossy_reflection(wi: Vec3, f: Spectrum, pdf: f32) -> Option<LocalSample> {
        (pdf > 0.0).then_some(LocalSample {
            wi,
            f,
            pdf,
            delta: false,
            transmission: false,
            eta: 1.0,
        })
    }
}

#[cfg(test)]
mod tests;
