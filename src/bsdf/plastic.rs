//! Smooth plastic (Mitsuba's `plastic`): a smooth dielectric coating over a Lambertian base,
//! two-sided like the diffuse BSDF (the scene loaders make it one-sided where Mitsuba's is).
//! The one BSDF with both a delta lobe and a non-delta lobe (see [`Bsdf::has_delta_lobe`]).
//!
//! In the local frame, with `eta` = index inside / index outside and `F(cos)` the dielectric
//! Fresnel reflectance:
//! * the coating reflects specularly, `F(cos_o)` times the specular reflectance: a Dirac lobe,
//!   which `eval` and `pdf` leave out, `sample` picks and [`Bsdf::delta_value`] gives;
//! * the base is seen through the coating twice: `rho / (1 - F_dr) (1 - F(cos_o)) (1 -
//!   F(cos_i)) / (pi eta^2)`, `F_dr` the coating's diffuse reflectance from inside (the fit
//!   Mitsuba 3 evaluates, `fresnel_diffuse_reflectance(1 / eta)`: Egan and Hilgeman's
//!   polynomial for relative indices below 1); with `nonlinear`, `rho / (1 - rho F_dr)`.
//!
//! Sampling picks the coating with probability `P_s = F(cos_o) w / (F(cos_o) w + (1 -
//! F(cos_o)) (1 - w))`, `w` the specular reflectance's mean over the sum of both means (as
//! Mitsuba), else a cosine-weighted direction; `pdf` is that direction's density times `1 -
//! P_s`, and the delta lobe's probability is `P_s`.
//!
//! [`Bsdf::has_delta_lobe`]: super::Bsdf::has_delta_lobe
//! [`Bsdf::delta_value`]: super::Bsdf::delta_value

use super::microfacet::flip_z;
use super::{LocalSample, diffuse, fresnel};
use crate::math::{INV_PI, Spectrum};
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// A smooth plastic's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Plastic {
    /// Reflectance of the Lambertian base.
    pub diffuse: Spectrum,
    /// The base's reflectance as a texture, in place of `diffuse`.
    pub diffuse_texture: Option<Arc<Texture>>,
    /// Scale of the coating's reflection.
    pub specular: Spectrum,
    /// Index inside over index outside.
    pub eta: f32,
    /// Whether the base's reflectance enters the interreflection sum (module docs).
    pub nonlinear: bool,
    /// `F_dr`: the coating's diffuse reflectance from inside.
    fdr_int: f32,
    /// `w`: the specular reflectance's share of both means.
    specular_weight: f32,
}

/// The diffuse Fresnel reflectance of an interface of relative index `eta` below 1 (Egan and
/// Hilgeman 1973, the fit Mitsuba 3 uses there).
fn diffuse_fresnel_below_one(eta: f32) -> f32 {
    0.0636 / eta + (eta * (eta * -1.4399 + 0.7099) + 0.6681)
}

/// The same for `eta` at or above 1 (d'Eon and Irving 2011, Mitsuba 3's fit there).
fn diffuse_fresnel_above_one(eta: f32) -> f32 {
    let x = 1.0 / eta;
    0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 + x * -1.36881))))
}

/// Mitsuba 3's `fresnel_diffuse_reflectance(eta)`.
pub fn diffuse_fresnel(eta: f32) -> f32 {
    if eta < 1.0 {
        diffuse_fresnel_below_one(eta)
    } else {
        diffuse_fresnel_above_one(eta)
    }
}

impl Plastic {
    /// A smooth plastic with base reflectance `diffuse`, coating scale `specular`, relative
    /// index `eta`.
    pub fn new(diffuse: Spectrum, specular: Spectrum, eta: f32, nonlinear: bool) -> Plastic {
        Plastic {
            diffuse,
            diffuse_texture: None,
            specular,
            eta,
            nonlinear,
            fdr_int: diffuse_fresnel(1.0 / eta),
            specular_weight: specular_weight(diffuse.element_sum() / 3.0, specular),
        }
    }

    /// The plastic with its base's reflectance looked up in `texture`; the lobe choice takes
    /// the texture's mean, as Mitsuba's does.
    pub fn with_diffuse_texture(mut self, texture: Arc<Texture>) -> Plastic {
        self.specular_weight = specular_weight(texture.mean().element_sum() / 3.0, self.specular);
        self.diffuse_texture = Some(texture);
        self
    }

    /// The base's reflectance at texture coordinates `uv`.
    #[inline]
    fn diffuse_at(&self, uv: Vec2) -> Spectrum {
        base_reflectance(self.diffuse, &self.diffuse_texture, uv)
    }

    /// The largest reflectance of either lobe anywhere (for roulette).
    pub fn max_reflectance(&self) -> f32 {
        let d = match &self.diffuse_texture {
            Some(t) => t.max(),
            None => self.diffuse.max_element(),
        };
        d.max(self.specular.max_element())
    }

    /// `P_s`: the probability of sampling the coating's reflection for `cos_o` > 0.
    fn p_specular(&self, cos_o: f32) -> f32 {
        let f = fresnel::dielectric(cos_o, self.eta).0;
        let w = self.specular_weight;
        let (s, d) = (f * w, (1.0 - f) * (1.0 - w));
        if s + d > 0.0 { s / (s + d) } else { 0.0 }
    }
}

/// A plastic base's reflectance at `uv`: `texture` there if it has one, else `diffuse`
/// (smooth and rough plastic alike).
#[inline]
pub(super) fn base_reflectance(
    diffuse: Spectrum,
    texture: &Option<Arc<Texture>>,
    uv: Vec2,
) -> Spectrum {
    match texture {
        Some(t) => t.eval(uv),
        None => diffuse,
    }
}

/// `w`, the coating's share in the lobe choice, from the base's mean reflectance `d` and the
/// coating's scale (Mitsuba's `specular_sampling_weight`; smooth and rough plastic alike).
pub(super) fn specular_weight(d: f32, specular: Spectrum) -> f32 {
    let s = specular.element_sum() / 3.0;
    if d + s > 0.0 { s / (d + s) } else { 0.5 }
}

/// `(f, pdf)` of the base's lobe for the pair in the local frame at texture coordinates
/// `uv`, zero unless both are strictly on one side; `f` only when `value`.
// `!(x > 0.0)` deliberately rejects NaN as well.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(super) fn eval_pdf(p: &Plastic, wo: Vec3, wi: Vec3, value: bool, uv: Vec2) -> (Spectrum, f32) {
    if !(wo.z * wi.z > 0.0) {
        return (Spectrum::ZERO, 0.0);
    }
    let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
    let pdf = (1.0 - p.p_specular(cos_o)) * diffuse::pdf(wo, wi);
    if !(pdf > 0.0) {
        return (Spectrum::ZERO, 0.0);
    }
    let f = if value {
        let rho = p.diffuse_at(uv);
        let rho = if p.nonlinear {
            rho / (Spectrum::ONE - rho * p.fdr_int)
        } else {
            rho / (1.0 - p.fdr_int)
        };
        let (f_o, f_i) = (
            fresnel::dielectric(cos_o, p.eta).0,
            fresnel::dielectric(cos_i, p.eta).0,
        );
        rho * (INV_PI * (1.0 - f_o) * (1.0 - f_i) / (p.eta * p.eta))
    } else {
        Spectrum::ZERO
    };
    (f, pdf)
}

/// The coating's mirror reflection with probability `P_s`, else a cosine-weighted direction
/// on `wo`'s side.
pub(super) fn sample(p: &Plastic, wo: Vec3, u_lobe: f32, u: Vec2, uv: Vec2) -> Option<LocalSample> {
    let cos_o = wo.z.abs();
    let p_s = p.p_specular(cos_o);
    if u_lobe < p_s {
        let value = p.specular * fresnel::dielectric(cos_o, p.eta).0;
        return Some(LocalSample::mirror(wo, value, p_s));
    }
    let flip = wo.z < 0.0;
    let wi = flip_z(
        diffuse::sample(Spectrum::ONE, flip_z(wo, flip), u)?.wi,
        flip,
    );
    let (f, pdf) = eval_pdf(p, wo, wi, true, uv);
    LocalSample::glossy_reflection(wi, f, pdf)
}

/// The probability of the coating's reflection taking `wo` to `wi` (`wi` its mirror
/// direction): `P_s` for a reflection, 0 across the surface.
pub(super) fn delta_probability(p: &Plastic, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z * wi.z > 0.0 {
        p.p_specular(wo.z.abs())
    } else {
        0.0
    }
}

/// `f |cos|` of the coating's reflection with the Dirac left out: `F(cos_o)` times the
/// specular reflectance (0 across the surface).
pub(super) fn delta_value(p: &Plastic, wo: Vec3, wi: Vec3) -> Spectrum {
    if wo.z * wi.z > 0.0 {
        p.specular * fresnel::dielectric(wo.z.abs(), p.eta).0
    } else {
        Spectrum::ZERO
    }
}
