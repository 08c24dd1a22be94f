//! Rough dielectric interface (Walter et al. 2007, "Microfacet Models for Refraction through
//! Rough Surfaces") with the GGX distribution, sampled by visible normals.
//!
//! Everything is computed with `wo` mirrored into the upper hemisphere of the shading frame;
//! `eta_r` is then the index of the lower side over that of `wo`'s side (`eta` when `wo` is
//! outside, `1 / eta` inside). With `ci = wi.m`, `co = wo.m` (the microfacet `m` faces `wo`):
//! * Reflection (`wi` on `wo`'s side): `m = normalize(wo + wi)`,
//!   `f = F(co) D G2 / (4 |cos_o| |cos_i|)`, `pdf = F(co) D_wo(m) / (4 co)`.
//! * Transmission: generalised half vector `m = ±normalize(wo + eta_r wi)` (turned to the
//!   upper side), valid when `co > 0 > ci`;
//!   `f = (1 - F(co)) D G2 |ci| co / (|cos_o| |cos_i| (ci + co / eta_r)^2)` in importance mode,
//!   divided by `eta_r^2` in radiance mode (the same convention as the smooth dielectric),
//!   `pdf = (1 - F(co)) D_wo(m) |ci| / (ci + co / eta_r)^2` (the Jacobian of the refraction
//!   half vector, `|dm / dwi|`).
//! * Sampling: visible normal `m`, then reflection with probability `F(co)` (always under
//!   total internal reflection), refraction otherwise; samples that end on the wrong side of
//!   the macro surface are dropped (`None`), and `eval`/`pdf` give no density there either.
//!   The sample's `f` and `pdf` come from the same function as `eval`/`pdf`.
//! * The importance-mode weight of either lobe is `G2 / G1(wo) <= 1`.
//!
//! `eta == 1` makes transmission a delta lobe (`wi = -wo` for every `m`), which has no
//! density: transmitted samples are dropped. The loader should use a smooth dielectric (or no
//! interface) for index-matched boundaries.

use super::microfacet::{Microfacet, Smith, flip_z, reflect, refract};
use super::{LocalSample, TransportMode, fresnel};
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

/// `(f, pdf)` of the pair (scalar: a dielectric is colourless).
// `!(x > 0.0)` deliberately rejects NaN as well.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(super) fn eval_pdf(
    eta: f32,
    mf: Microfacet,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> (f32, f32) {
    if wo.z == 0.0 || wi.z == 0.0 || wo.z.is_nan() || wi.z.is_nan() {
        return (0.0, 0.0);
    }
    let flip = wo.z < 0.0;
    let eta_r = if flip { 1.0 / eta } else { eta };
    let (wo, wi) = (flip_z(wo, flip), flip_z(wi, flip));
    let ggx = mf;
    let (f, pdf) = if wi.z > 0.0 {
        let h = wo + wi;
        let len = h.length();
        if !(len > 0.0) {
            return (0.0, 0.0);
        }
        let m = h / len;
        let co = wo.dot(m);
        if !(co > 0.0) {
            return (0.0, 0.0);
        }
        let fr = fresnel::dielectric(co, eta_r).0;
        let d = ggx.d(m);
        let (g1, g2) = ggx.g1_g2(wo, wi);
        let f = fr * d * g2 / (4.0 * wo.z * wi.z);
        let pdf = fr * g1 * d / (4.0 * wo.z);
        (f, pdf)
    } else {
        let h = wo + eta_r * wi;
        let len = h.length();
        if !(len > 0.0) {
            return (0.0, 0.0);
        }
        let mut m = h / len;
        if m.z < 0.0 {
            m = -m;
        }
        let (co, ci) = (wo.dot(m), wi.dot(m));
        // wo must see the front of the facet and wi leave through its back.
        if !(co > 0.0 && ci < 0.0) || m.z <= 0.0 {
            return (0.0, 0.0);
        }
        let fr = fresnel::dielectric(co, eta_r).0;
        let t = 1.0 - fr;
        if t <= 0.0 {
            return (0.0, 0.0);
        }
        let d = ggx.d(m);
        let denom = (ci + co / eta_r) * (ci + co / eta_r);
        let jacobian = -ci / denom;
        let (g1, g2) = ggx.g1_g2(wo, wi);
        let mut f = t * d * g2 * co * jacobian / (wo.z * -wi.z);
        if mode == TransportMode::Radiance {
            f /= eta_r * eta_r;
        }
        // D_wo(m) (`Smith::d_visible`) with G1 and D already at hand.
        let visible = g1 * co * d / wo.z;
        let visible = if visible.is_finite() { visible } else { 0.0 };
        let pdf = t * visible * jacobian;
        (f, pdf)
    };
    if !(f.is_finite() && pdf.is_finite()) || pdf <= 0.0 || f < 0.0 {
        return (0.0, 0.0);
    }
    (f, pdf)
}

#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(super) fn sample(
    eta: f32,
    mf: Microfacet,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
    mode: TransportMode,
) -> Option<LocalSample> {
    let flip = wo.z < 0.0;
    let eta_r = if flip { 1.0 / eta } else { eta };
    let wo_up = flip_z(wo, flip);
    let m = mf.sample_visible(wo_up, u)?;
    let co = wo_up.dot(m);
    if !(co > 0.0) {
        return None;
    }
    let (fr, cos_t, _) = fresnel::dielectric(co, eta_r);
    let (wi_up, transmission) = if u_lobe < fr {
        let wi = reflect(wo_up, m);
        if wi.z <= 0.0 {
            return None;
        }
        (wi, false)
    } else {
        let wi = refract(wo_up, m, co, cos_t, eta_r);
        if wi.z >= 0.0 {
            return None;
        }
        (wi.normalize(), true)
    };
    let wi = flip_z(wi_up, flip);
    let (f, pdf) = eval_pdf(eta, mf, wo, wi, mode);
    if pdf <= 0.0 {
        return None;
    }
    Some(LocalSample {
        wi,
        f: Spectrum::splat(f),
        pdf,
        delta: false,
        transmission,
        eta: if transmission { eta_r } else { 1.0 },
    })
}
