//! Constant environment: uniform radiance from every direction at infinity. Emission sampling
//! starts rays on a disk of the scene's bounding-sphere radius facing the chosen direction.
//!
//! Directions follow the convention of the lights at infinity (see `Light::le`): `w` points
//! from the scene towards the sky (the escaping ray's direction, `sample_li`'s `wi`); light
//! travels along `-w`.

use super::cone::disk_origin;
use super::{EmissionSample, LightSample};
use crate::math::{PI, Spectrum, luminance, warp};
use glam::{Vec2, Vec3};

/// Uniform radiance arriving from every direction at infinity.
#[derive(Debug, Clone)]
pub struct EnvironmentLight {
    /// Radiance from every direction (W/(m^2 sr) per RGB channel).
    pub radiance: Spectrum,
    /// Bounding sphere of the scene (set when the scene is built).
    pub center: Vec3,
    /// Radius of the scene's bounding sphere.
    pub radius: f32,
}

pub(super) fn pdf_li() -> f32 {
    warp::uniform_sphere_pdf()
}

impl EnvironmentLight {
    /// `4 pi^2 R^2 luminance(L)`: the flux through the scene's bounding disk from every
    /// direction.
    pub fn power(&self) -> f32 {
        4.0 * PI * PI * self.radius * self.radius * luminance(self.radiance)
    }

    /// A direction towards the sky, uniform on the sphere.
    pub fn sample_li(&self, u: Vec2) -> Option<LightSample> {
        let wi = warp::square_to_uniform_sphere(u);
        Some(LightSample {
            wi,
            dist: f32::INFINITY,
            p: Vec3::ZERO,
            n: Vec3::ZERO,
            li: self.radiance,
            pdf: pdf_li(),
            delta: false,
        })
    }

    /// An emitted ray: a direction uniform on the sphere (by `u_dir`), its origin uniform on
    /// the bounding disk facing it (by `u_pos`).
    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> EmissionSample {
        // Direction of travel is -w where w is the direction towards the environment.
        let w = warp::square_to_uniform_sphere(u_dir);
        let p = disk_origin(self.center, self.radius, w, u_pos);
        let (pdf_pos, pdf_dir) = self.pdf_le();
        EmissionSample {
            p,
            n: -w,
            dir: -w,
            le: self.radiance,
            pdf_pos,
            pdf_dir,
        }
    }

    /// (area density of the origin on the disk, solid-angle density of the direction) of
    /// [`Self::sample_le`]: both uniform.
    pub fn pdf_le(&self) -> (f32, f32) {
        (
            1.0 / (PI * self.radius * self.radius),
            warp::uniform_sphere_pdf(),
        )
    }
}
