//! Point light: isotropic intensity from a point (a delta light).

use super::{EmissionSample, LightSample};
use crate::math::{Spectrum, warp};
use glam::{Vec2, Vec3};

/// A point emitting the same intensity in every direction.
#[derive(Debug, Clone)]
pub struct PointLight {
    /// Position of the light.
    pub position: Vec3,
    /// Radiant intensity (W/sr per RGB channel).
    pub intensity: Spectrum,
}

impl PointLight {
    /// The connection from `p` to the light: `intensity / d^2`, a discrete density of 1;
    /// `None` at the light itself.
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let v = self.position - p;
        let d2 = v.length_squared();
        if d2 == 0.0 {
            return None;
        }
        let dist = d2.sqrt();
        Some(LightSample {
            wi: v / dist,
            dist,
            p: self.position,
            n: Vec3::ZERO,
            li: self.intensity / d2,
            pdf: 1.0,
            delta: true,
        })
    }

    /// An emitted ray from the light's position in a direction uniform on the sphere.
    pub fn sample_le(&self, u_dir: Vec2) -> EmissionSample {
        let dir = warp::square_to_uniform_sphere(u_dir);
        EmissionSample {
            p: self.position,
            n: Vec3::ZERO,
            dir,
            le: self.intensity,
            pdf_pos: 1.0,
            pdf_dir: warp::uniform_sphere_pdf(),
        }
    }
}
