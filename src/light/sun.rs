//! Sun: a distant disk of small angular radius and constant radiance, at infinity. Not a delta
//! light: a ray leaving the scene in a direction inside the sun's cone sees its radiance, and
//! `sample_li` samples the cone uniformly. Emission sampling picks a direction in the cone and
//! starts the ray on a disk of the scene's bounding-sphere radius, outside the scene and
//! perpendicular to it, as the environment light does.

use super::cone::{
    cone_solid_angle, disk_origin, one_minus_cos, one_minus_cos_deg, sample_uniform_cone,
    uniform_cone_pdf,
};
use super::{EmissionSample, LightSample};
use crate::math::{Frame, PI, Spectrum, luminance};
use glam::{Vec2, Vec3};

/// A disk of small angular radius and constant radiance at infinity.
#[derive(Debug, Clone)]
pub struct SunLight {
    /// Radiance of the disk (W/(m^2 sr) per RGB channel).
    pub radiance: Spectrum,
    /// Bounding sphere of the scene (set when the scene is built, see
    /// [`super::Light::set_scene_bounds`]).
    pub center: Vec3,
    /// Radius of the scene's bounding sphere.
    pub radius: f32,
    direction_to_sun: Vec3,
    /// Angular radius (half-angle), degrees.
    angle: f32,
    /// `1 - cos(angle)`.
    z_max: f32,
}

impl SunLight {
    /// Default angular radius of the sun, degrees (the real sun's is 0.265).
    pub const DEFAULT_ANGLE: f32 = 0.27;

    /// A sun in unit direction `direction_to_sun` (normalised here; must be non-zero) of
    /// angular radius `angle` degrees (half-angle, in `(0, 90]`), radiance `radiance`.
    pub fn new(direction_to_sun: Vec3, angle: f32, radiance: Spectrum) -> SunLight {
        if let Err(e) = SunLight::check_angle(angle) {
            panic!("{e}");
        }
        let direction_to_sun = direction_to_sun.normalize();
        assert!(
            direction_to_sun.is_finite(),
            "sun direction must be non-zero"
        );
        SunLight {
            radiance,
            center: Vec3::ZERO,
            radius: 1.0,
            direction_to_sun,
            angle,
            z_max: one_minus_cos_deg(angle),
        }
    }

    /// The sun whose irradiance on a surface facing it is `irradiance`:
    /// `L = E / (pi sin^2(angle))` (the cosine-weighted solid angle of the cone; about `E`
    /// over the solid angle for a small sun).
    pub fn from_irradiance(direction_to_sun: Vec3, angle: f32, irradiance: Spectrum) -> SunLight {
        if let Err(e) = SunLight::check_angle(angle) {
            panic!("{e}");
        }
        let s = (angle as f64).to_radians().sin();
        let radiance = (irradiance.as_dvec3() / (std::f64::consts::PI * s * s)).as_vec3();
        SunLight::new(direction_to_sun, angle, radiance)
    }

    /// Why `angle` (degrees) is not a valid angular radius, if it is not: it must be in
    /// `(0, 90]`.
    pub fn check_angle(angle: f32) -> Result<(), String> {
        if angle.is_finite() && angle > 0.0 && angle <= 90.0 {
            Ok(())
        } else {
            Err(format!(
                "sun angle (angular radius) must be in (0, 90] degrees, got {angle}"
            ))
        }
    }

    /// Unit direction from the scene towards the sun's centre.
    pub fn direction_to_sun(&self) -> Vec3 {
        self.direction_to_sun
    }

    /// Angular radius, degrees.
    pub fn angle(&self) -> f32 {
        self.angle
    }

    /// Solid angle of the sun's disk, `2 pi (1 - cos(angle))`.
    pub fn solid_angle(&self) -> f32 {
        cone_solid_angle(self.z_max)
    }

    /// Irradiance on a surface facing the sun: `L pi sin^2(angle)`.
    pub fn irradiance(&self) -> Spectrum {
        self.radiance * (PI * self.z_max * (2.0 - self.z_max))
    }

    /// Is unit `w` (from the scene towards the sky) inside the sun's cone?
    #[inline]
    fn inside(&self, w: Vec3) -> bool {
        one_minus_cos(self.direction_to_sun, w.normalize()) <= self.z_max
    }

    /// `luminance(L)` times the solid angle times `pi R^2`.
    pub fn power(&self) -> f32 {
        luminance(self.radiance) * self.solid_angle() * PI * self.radius * self.radius
    }

    /// Radiance seen by a ray escaping the scene along `w`: `L` inside the cone, else zero.
    pub fn le(&self, w: Vec3) -> Spectrum {
        if self.inside(w) {
            self.radiance
        } else {
            Spectrum::ZERO
        }
    }

    fn cone_pdf(&self) -> f32 {
        uniform_cone_pdf(self.z_max)
    }

    /// A direction uniform in the cone.
    pub fn sample_li(&self, u: Vec2) -> LightSample {
        let wi = Frame::from_z(self.direction_to_sun).to_world(sample_uniform_cone(u, self.z_max));
        LightSample {
            wi,
            dist: f32::INFINITY,
            p: Vec3::ZERO,
            n: Vec3::ZERO,
            li: self.radiance,
            pdf: self.cone_pdf(),
            delta: false,
        }
    }

    /// Density of `sample_li` along `wi` (from the scene towards the sky).
    pub fn pdf_li(&self, wi: Vec3) -> f32 {
        if self.inside(wi) {
            self.cone_pdf()
        } else {
            0.0
        }
    }

    /// A direction uniform in the cone (reversed: travelling into the scene) from a point
    /// uniform on the bounding disk perpendicular to it.
    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> EmissionSample {
        let w =
            Frame::from_z(self.direction_to_sun).to_world(sample_uniform_cone(u_dir, self.z_max));
        let p = disk_origin(self.center, self.radius, w, u_pos);
        EmissionSample {
            p,
            n: -w,
            dir: -w,
            le: self.radiance,
            pdf_pos: 1.0 / (PI * self.radius * self.radius),
            pdf_dir: self.cone_pdf(),
        }
    }

    /// (`1 / (pi R^2)`, density of the direction of travel `dir`).
    pub fn pdf_le(&self, dir: Vec3) -> (f32, f32) {
        (1.0 / (PI * self.radius * self.radius), self.pdf_li(-dir))
    }
}
