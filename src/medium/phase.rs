//! The Henyey-Greenstein phase function.
//!
//! Convention as for BSDFs: `wo` points back along the path, `wi` is the sampled direction.
//! The scattering angle is between the propagation direction `-wo` and `wi`, so `g > 0`
//! scatters forwards (wi close to -wo).

use crate::math::{Frame, INV_4PI};
use glam::{Vec2, Vec3};

/// The Henyey-Greenstein phase function of asymmetry `g`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HenyeyGreenstein {
    /// Mean cosine of the scattering angle, in (-1, 1).
    pub g: f32,
}

impl HenyeyGreenstein {
    /// The phase function of mean cosine `g`.
    pub fn new(g: f32) -> Self {
        HenyeyGreenstein { g }
    }

    /// Phase function value of scattering from propagation direction `-wo` into `wi`; it is
    /// also the solid-angle density of [`Self::sample`].
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        hg(-wo.dot(wi), self.g)
    }

    /// Sample `wi` given `wo`; returns (wi, pdf). The sample weight is exactly 1.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> (Vec3, f32) {
        let g = self.g;
        let cos = if g.abs() < 1e-3 {
            1.0 - 2.0 * u.x
        } else {
            let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
            ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
        };
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let (sin_phi, cos_phi) = crate::math::warp::sin_cos_turn(u.y);
        let local = Vec3::new(sin * cos_phi, sin * sin_phi, cos);
        let wi = Frame::from_z(-wo).to_world(local).normalize();
        // The density of the direction actually returned (after rounding), so that `sample`
        // and `eval` agree exactly even for strongly peaked lobes.
        (wi, self.eval(wo, wi))
    }
}

#[inline]
fn hg(cos: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos;
    INV_4PI * (1.0 - g * g) / (denom * denom.max(0.0).sqrt())
}
