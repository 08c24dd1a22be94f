//! [`Bsdf::Tinted`]: a conductor whose value is multiplied by a texture at the point.
//!
//! Each function evaluates the base conductor and applies the tint. They are kept out of
//! line on purpose: a `Bsdf` method that called itself for the base would be recursive, and
//! the compiler does not inline recursive functions, so every integrator's BSDF evaluation
//! would pay a call for a variant few scenes use.

use super::{Bsdf, BsdfSample, EvalPdfs, ShadingFrame, TransportMode};
use crate::math::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// The base's value times the tint.
#[inline(never)]
pub(super) fn eval(
    base: &Bsdf,
    tint: &Texture,
    sf: &ShadingFrame,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> Spectrum {
    base.eval(sf, wo, wi, mode) * tint.eval(sf.uv)
}

/// The base's value and densities, the value times the tint.
#[inline(never)]
pub(super) fn eval_pdfs(
    base: &Bsdf,
    tint: &Texture,
    sf: &ShadingFrame,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> EvalPdfs {
    let e = base.eval_pdfs(sf, wo, wi, mode);
    EvalPdfs {
        f: e.f * tint.eval(sf.uv),
        ..e
    }
}

/// The base's sample, its value and weight times the tint (`None` where the tint is black).
#[inline(never)]
pub(super) fn sample(
    base: &Bsdf,
    tint: &Texture,
    sf: &ShadingFrame,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
    mode: TransportMode,
) -> Option<BsdfSample> {
    let mut s = base.sample(sf, wo, u_lobe, u, mode)?;
    let t = tint.eval(sf.uv);
    (s.f, s.weight) = (s.f * t, s.weight * t);
    (s.weight != Vec3::ZERO).then_some(s)
}

/// The base's density (the tint does not change sampling).
#[inline(never)]
pub(super) fn pdf(base: &Bsdf, sf: &ShadingFrame, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
    base.pdf(sf, wo, wi, mode)
}

/// The base's continuation probability times the texture's largest texel.
#[inline(never)]
pub(super) fn continuation(base: &Bsdf, tint: &Texture) -> f32 {
    base.continuation() * tint.max()
}
