//! Directional light: parallel light of irradiance `E` travelling along one direction (a delta
//! in direction, at infinity). Emission sampling starts rays on a disk of the scene's
//! bounding-sphere radius, outside the scene and perpendicular to the direction, as the
//! environment light does.

use super::cone::disk_origin;
use super::{EmissionSample, LightSample};
use crate::math::{PI, Spectrum, luminance};
use glam::{Vec2, Vec3};

/// Parallel light from one direction at infinity.
#[derive(Debug, Clone)]
pub struct DirectionalLight {
    /// Irradiance on a surface perpendicular to the light (W/m^2 per RGB channel).
    pub irradiance: Spectrum,
    /// Bounding sphere of the scene (set when the scene is built, see
    /// [`super::Light::set_scene_bounds`]).
    pub center: Vec3,
    /// Radius of the scene's bounding sphere.
    pub radius: f32,
    direction: Vec3,
}

impl DirectionalLight {
    /// Light travelling along `direction` (normalised here; must be non-zero) with
    /// irradiance `irradiance`. The scene bounds start as the unit sphere at the origin.
    pub fn new(direction: Vec3, irradiance: Spectrum) -> DirectionalLight {
        let direction = direction.normalize();
        assert!(
            direction.is_finite(),
            "directional light direction must be non-zero"
        );
        DirectionalLight {
            irradiance,
            center: Vec3::ZERO,
            radius: 1.0,
            direction,
        }
    }

    /// Unit direction the light travels in (from the light into the scene).
    pub fn direction(&self) -> Vec3 {
        self.direction
    }

    /// `luminance(E) pi R^2`: the flux through the scene's bounding disk.
    pub fn power(&self) -> f32 {
        luminance(self.irradiance) * PI * self.radius * self.radius
    }

    /// The one direction towards the light, with the irradiance as `li` and a discrete
    /// density of 1.
    pub fn sample_li(&self) -> LightSample {
        LightSample {
            wi: -self.direction,
            dist: f32::INFINITY,
            p: Vec3::ZERO,
            n: Vec3::ZERO,
            li: self.irradiance,
            pdf: 1.0,
            delta: true,
        }
    }

    /// A ray along the direction from a point uniform on the bounding disk; `le` is the
    /// irradiance, `pdf_dir` a discrete 1.
    pub fn sample_le(&self, u_pos: Vec2) -> EmissionSample {
        let p = disk_origin(self.center, self.radius, -self.direction, u_pos);
        let (pdf_pos, pdf_dir) = self.pdf_le();
        EmissionSample {
            p,
            n: self.direction,
            dir: self.direction,
            le: self.irradiance,
            pdf_pos,
            pdf_dir,
        }
    }

    /// (`1 / (pi R^2)`, 1): the direction is a discrete choice.
    pub fn pdf_le(&self) -> (f32, f32) {
        (1.0 / (PI * self.radius * self.radius), 1.0)
    }
}
