//! Rough diffuse reflection (Mitsuba 0.6's `roughdiffuse`): Oren and Nayar's (1994) model of
//! a surface of V-shaped Lambertian facets, with masking, shadowing and one interreflection
//! between facets, two-sided like the diffuse BSDF. Sampled by the cosine.
//!
//! With `sigma = alpha / sqrt(2)` (Mitsuba's conversion of a Beckmann-style roughness to the
//! facets' slope deviation), `theta_o`, `theta_i` the two polar angles, `a = max`, `b = min` of
//! them, `dphi` the azimuth between the two directions and `k = sigma^2 / (sigma^2 + 0.09)`:
//! * single scattering `rho (C1 + cos(dphi) C2 tan(b) + (1 - |cos(dphi)|) C3 tan((a + b) / 2))`
//!   with `C1 = 1 - sigma^2 / (2 (sigma^2 + 0.33))`, `C2 = 0.45 k sin(a)` where `cos(dphi) >
//!   0`, else `0.45 k (sin(a) - (2 b / pi)^3)`, `C3 = k (4 a b / pi^2)^2 / 8`;
//! * the interreflection `rho^2 0.17 sigma^2 / (sigma^2 + 0.13) (1 - cos(dphi) (2 b / pi)^2)`;
//!
//! both over `pi`. At `alpha = 0` this is Lambert's `rho / pi`; the value is symmetric in the
//! two directions.

use super::{LocalSample, diffuse};
use crate::math::{INV_PI, PI, Spectrum};
use glam::{Vec2, Vec3};

/// `f(wo, wi)`, zero unless both are strictly on one side (local frame).
pub(super) fn eval(rho: Spectrum, alpha: f32, wo: Vec3, wi: Vec3) -> Spectrum {
    if wo.z * wi.z <= 0.0 {
        return Spectrum::ZERO;
    }
    let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
    let sin_o = (1.0 - cos_o * cos_o).max(0.0).sqrt();
    let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
    // cos of the azimuth between the two (0 when either is along the normal).
    let cos_dphi = if sin_o > 1e-4 && sin_i > 1e-4 {
        ((wo.x * wi.x + wo.y * wi.y) / (sin_o * sin_i)).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let sigma2 = alpha * alpha / 2.0;
    let (theta_o, theta_i) = (cos_o.min(1.0).acos(), cos_i.min(1.0).acos());
    let (a, b) = (theta_o.max(theta_i), theta_o.min(theta_i));
    // sin a, sin b, tan b from the direction nearer the normal (b) and the other (a).
    let (sin_a, sin_b, cos_a, cos_b) = if cos_o > cos_i {
        (sin_i, sin_o, cos_i, cos_o)
    } else {
        (sin_o, sin_i, cos_o, cos_i)
    };
    let tan_b = sin_b / cos_b;
    let k = sigma2 / (sigma2 + 0.09);
    let two_b_pi = 2.0 * b / PI;
    let c1 = 1.0 - 0.5 * sigma2 / (sigma2 + 0.33);
    let c2 = 0.45
        * k
        * if cos_dphi > 0.0 {
            sin_a
        } else {
            sin_a - two_b_pi.powi(3)
        };
    let ab = 4.0 * a * b / (PI * PI);
    let c3 = 0.125 * k * ab * ab;
    let c4 = 0.17 * sigma2 / (sigma2 + 0.13);
    let tan_half = (sin_a + sin_b) / (cos_a + cos_b);
    let single = rho * (c1 + cos_dphi * c2 * tan_b + (1.0 - cos_dphi.abs()) * c3 * tan_half);
    let double = rho * rho * (c4 * (1.0 - cos_dphi * two_b_pi * two_b_pi));
    (single + double) * INV_PI
}

/// A cosine-weighted direction on the side of `wo`, with the model's value.
pub(super) fn sample(rho: Spectrum, alpha: f32, wo: Vec3, u: Vec2) -> Option<LocalSample> {
    let mut s = diffuse::sample(Spectrum::ONE, wo, u)?;
    s.f = eval(rho, alpha, wo, s.wi);
    (s.f != Spectrum::ZERO).then_some(s)
}
