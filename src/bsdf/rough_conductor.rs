//! Rough conductor: microfacet (GGX or Beckmann) reflection (Cook-Torrance with Smith masking), two-sided.
//!
//! `f = D(m) G2(wo, wi) F(wo.m) / (4 |cos_o| |cos_i|)` with `m = normalize(wo + wi)`; sampled
//! by visible normals, `pdf = D_wo(m) / (4 wo.m) = G1(wo) D(m) / (4 |cos_o|)`, so the weight
//! is `F G2 / G1(wo) <= F`. A configuration with `wo` below the surface is mirrored through
//! the tangent plane first (two-sided, like the smooth conductor).

use super::microfacet::{Microfacet, Smith, flip_z, reflect};
use super::{ConductorFresnel, LocalSample};
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

/// `(f, pdf)` of the pair, zero unless both are strictly on the same side. `f` is only
/// computed (and otherwise zero) when a Fresnel term is given, so that `pdf` skips it; the
/// support is the same either way.
// `!(x > 0.0)` deliberately rejects NaN as well.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(super) fn eval_pdf(
    mf: Microfacet,
    fr: Option<&ConductorFresnel>,
    wo: Vec3,
    wi: Vec3,
) -> (Spectrum, f32) {
    const ZERO: (Spectrum, f32) = (Spectrum::ZERO, 0.0);
    if !(wo.z * wi.z > 0.0) {
        return ZERO;
    }
    let flip = wo.z < 0.0;
    let (wo, wi) = (flip_z(wo, flip), flip_z(wi, flip));
    let h = wo + wi;
    let len = h.length();
    if !(len > 0.0) {
        return ZERO;
    }
    let m = h / len;
    let wo_m = wo.dot(m);
    if !(wo_m > 0.0) {
        return ZERO;
    }
    let ggx = mf;
    let d = ggx.d(m);
    // f without the Fresnel term (which is in [0, 1]).
    let (g1, g2) = ggx.g1_g2(wo, wi);
    let f_unit = d * g2 / (4.0 * wo.z * wi.z);
    // D_wo(m) / (4 wo.m), with the wo.m cancelled.
    let pdf = g1 * d / (4.0 * wo.z);
    if !(f_unit.is_finite() && pdf.is_finite()) || pdf <= 0.0 {
        return ZERO;
    }
    let f = fr.map_or(Spectrum::ZERO, |fr| fr.eval(wo_m) * f_unit);
    (f, pdf)
}

pub(super) fn sample(
    mf: Microfacet,
    fr: &ConductorFresnel,
    wo: Vec3,
    u: Vec2,
) -> Option<LocalSample> {
    let flip = wo.z < 0.0;
    let wo_up = flip_z(wo, flip);
    let m = mf.sample_visible(wo_up, u)?;
    let wi_up = reflect(wo_up, m);
    if wi_up.z <= 0.0 {
        // Reflected below the surface: single scattering loses this energy.
        return None;
    }
    let wi = flip_z(wi_up, flip);
    let (f, pdf) = eval_pdf(mf, Some(fr), wo, wi);
    LocalSample::glossy_reflection(wi, f, pdf)
}
