//! Lambertian reflection, two-sided: cosine-weighted sampling on the side of `wo`.

use super::LocalSample;
use crate::math::{INV_PI, Spectrum, warp};
use glam::{Vec2, Vec3};

pub(super) fn sample(albedo: Spectrum, wo: Vec3, u: Vec2) -> Option<LocalSample> {
    let mut wi = warp::square_to_cosine_hemisphere(u);
    if wi.z <= 0.0 {
        return None;
    }
    let pdf = warp::cosine_hemisphere_pdf(wi.z);
    if wo.z < 0.0 {
        wi.z = -wi.z;
    }
    Some(LocalSample {
        wi,
        f: albedo * INV_PI,
        pdf,
        delta: false,
        transmission: false,
        eta: 1.0,
    })
}

pub(super) fn eval(albedo: Spectrum, wo: Vec3, wi: Vec3) -> Spectrum {
    if wo.z * wi.z > 0.0 {
        albedo * INV_PI
    } else {
        Spectrum::ZERO
    }
}

pub(super) fn pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z * wi.z > 0.0 {
        warp::cosine_hemisphere_pdf(wi.z.abs())
    } else {
        0.0
    }
}
