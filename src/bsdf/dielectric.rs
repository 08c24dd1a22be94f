//! Smooth dielectric: Fresnel-weighted choice between specular reflection and refraction.

use super::{LocalSample, TransportMode, fresnel};
use crate::math::Spectrum;
use glam::Vec3;

pub(super) fn sample(eta: f32, wo: Vec3, u_lobe: f32, mode: TransportMode) -> Option<LocalSample> {
    let (f_r, cos_t, eta_rel) = fresnel::dielectric(wo.z, eta);
    if u_lobe < f_r {
        return Some(LocalSample::mirror(wo, Spectrum::splat(f_r), f_r));
    }
    // Refraction to the other side: wi = -wo / eta_rel + (cos_i / eta_rel - cos_t) n.
    let sign = wo.z.signum();
    let wi = Vec3::new(-wo.x / eta_rel, -wo.y / eta_rel, -sign * cos_t);
    let t = 1.0 - f_r;
    let mut f = t / wi.z.abs();
    if mode == TransportMode::Radiance {
        f /= eta_rel * eta_rel;
    }
    Some(LocalSample {
        wi,
        f: Spectrum::splat(f),
        pdf: t,
        delta: true,
        transmission: true,
        eta: eta_rel,
    })
}

/// Reflectance of a thin dielectric sheet (Mitsuba's `thindielectric`) at `cos_i`: the
/// interface's Fresnel `R` plus every path that bounces inside the sheet and leaves on the
/// incident side, `R + T^2 R / (1 - R^2) = 2 R / (1 + R)` (`T = 1 - R`, no absorption).
pub(super) fn thin_reflectance(cos_i: f32, eta: f32) -> f32 {
    let r = fresnel::dielectric(cos_i.abs(), eta).0;
    if r < 1.0 { 2.0 * r / (1.0 + r) } else { 1.0 }
}

/// A thin dielectric sheet: specular reflection with [`thin_reflectance`], else straight
/// through (the two refractions cancel; radiance is not scaled).
pub(super) fn thin_sample(eta: f32, wo: Vec3, u_lobe: f32) -> Option<LocalSample> {
    let r = thin_reflectance(wo.z, eta);
    if u_lobe < r {
        return Some(LocalSample::mirror(wo, Spectrum::splat(r), r));
    }
    let wi = -wo;
    let t = 1.0 - r;
    Some(LocalSample {
        wi,
        f: Spectrum::splat(t / wi.z.abs()),
        pdf: t,
        delta: true,
        transmission: true,
        eta: 1.0,
    })
}
