//! Point light: isotropic intensity from a point (a delta light).

use super::{EmissionSample, LightSample};
use crate::math::{Spectrum, warp};
use glam::{Vec2, Vec3};

#[derive(Debug, Clone)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity (W/sr per RGB channel).
    pub intensity: Spectrum,
}

impl PointLight {
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
