//! Spot lights: the angular profile shared by the point spot light and spot area lights, and
//! the point spot light itself (a delta light).
//!
//! The profile is full strength within `cone_angle - cone_delta` of the axis, zero beyond
//! `cone_angle`, and in between either pbrt's edge,
//! `smoothstep(cos(cone_angle), cos(cone_angle - cone_delta), cos)`, or Mitsuba's, linear in
//! the angle: `(cone_angle - theta) / cone_delta` ([`SpotEdge`]); a hard edge for
//! `cone_delta = 0`. It is evaluated on `z = 1 - cos(theta)` (accurate for narrow cones).
//!
//! A point spot light may project a texture along its cone ([`Projection`], Mitsuba's spot
//! `texture`): the intensity is multiplied by the image by direction. Sampling stays uniform
//! in the cone.

use super::cone::{one_minus_cos, one_minus_cos_deg, sample_uniform_cone, uniform_cone_pdf};
use super::{EmissionSample, LightSample};
use crate::math::{Frame, Spectrum, luminance};
use glam::{Vec2, Vec3};

/// The shape of a spot profile's edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpotEdge {
    /// pbrt's: a smoothstep in the cosine.
    #[default]
    Smoothstep,
    /// Mitsuba's: linear in the angle (point spot lights only).
    LinearAngle,
}

/// Angular falloff of a spot light around its axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpotProfile {
    edge: SpotEdge,
    /// Half-angle of the cone, degrees.
    cone_angle: f32,
    /// Width of the smooth edge inside the cone, degrees.
    cone_delta: f32,
    /// `1 - cos(cone_angle)`: the profile is zero beyond.
    z_end: f32,
    /// `1 - cos(cone_angle - cone_delta)`: the profile is one within.
    z_start: f32,
}

impl Default for SpotProfile {
    /// 30 degrees with a 5 degree edge.
    fn default() -> SpotProfile {
        SpotProfile::new(Self::DEFAULT_CONE_ANGLE, Self::DEFAULT_CONE_DELTA)
    }
}

impl SpotProfile {
    /// Default half-angle of the cone, degrees (pbrt's).
    pub const DEFAULT_CONE_ANGLE: f32 = 30.0;
    /// Default width of the smooth edge, degrees (pbrt's).
    pub const DEFAULT_CONE_DELTA: f32 = 5.0;

    /// The profile of half-angle `cone_angle` with a smooth edge `cone_delta` wide (both in
    /// degrees). Panics unless [`SpotProfile::check`] accepts them.
    pub fn new(cone_angle: f32, cone_delta: f32) -> SpotProfile {
        if let Err(e) = SpotProfile::check(cone_angle, cone_delta) {
            panic!("{e}");
        }
        SpotProfile {
            edge: SpotEdge::Smoothstep,
            cone_angle,
            cone_delta,
            z_end: one_minus_cos_deg(cone_angle),
            z_start: one_minus_cos_deg(cone_angle - cone_delta),
        }
    }

    /// The profile with Mitsuba's edge, linear in the angle (for point spot lights: spot area
    /// lights need [`SpotProfile::cosine_integral`], which only the smoothstep edge has).
    pub fn with_edge(self, edge: SpotEdge) -> SpotProfile {
        SpotProfile { edge, ..self }
    }

    /// The shape of the edge.
    pub fn edge(&self) -> SpotEdge {
        self.edge
    }

    /// Why `(cone_angle, cone_delta)` is not a valid profile, if it is not: `cone_angle` must
    /// be in `(0, 180]` and `cone_delta` in `[0, cone_angle]` (degrees, finite). Spot area
    /// lights further need `cone_angle <= 90` (see [`SpotProfile::check_area`]).
    pub fn check(cone_angle: f32, cone_delta: f32) -> Result<(), String> {
        if !(cone_angle.is_finite() && cone_angle > 0.0 && cone_angle <= 180.0) {
            return Err(format!(
                "cone_angle must be in (0, 180] degrees, got {cone_angle}"
            ));
        }
        if !(cone_delta.is_finite() && cone_delta >= 0.0 && cone_delta <= cone_angle) {
            return Err(format!(
                "cone_delta must be in [0, cone_angle = {cone_angle}] degrees, got {cone_delta}"
            ));
        }
        Ok(())
    }

    /// [`SpotProfile::check`] for a spot area light, which emits on its front side only:
    /// also `cone_angle <= 90`.
    pub fn check_area(cone_angle: f32, cone_delta: f32) -> Result<(), String> {
        SpotProfile::check(cone_angle, cone_delta)?;
        if cone_angle > 90.0 {
            return Err(format!(
                "cone_angle of an area light must be at most 90 degrees, got {cone_angle}"
            ));
        }
        Ok(())
    }

    /// Half-angle of the cone, degrees.
    pub fn cone_angle(&self) -> f32 {
        self.cone_angle
    }

    /// Width of the smooth edge, degrees.
    pub fn cone_delta(&self) -> f32 {
        self.cone_delta
    }

    /// `1 - cos(cone_angle)`: the profile is zero where `1 - cos(theta)` exceeds it.
    pub fn one_minus_cos_total(&self) -> f32 {
        self.z_end
    }

    /// `1 - cos(cone_angle - cone_delta)`: the profile is one where `1 - cos(theta)` is below.
    pub fn one_minus_cos_falloff_start(&self) -> f32 {
        self.z_start
    }

    /// The profile at `z = 1 - cos(theta)`.
    #[inline]
    pub fn falloff_z(&self, z: f32) -> f32 {
        if z > self.z_end {
            0.0
        } else if z <= self.z_start {
            1.0
        } else if self.edge == SpotEdge::LinearAngle {
            // theta = 2 asin(sqrt(z / 2)), accurate for small angles.
            let theta = 2.0 * (0.5 * z).sqrt().min(1.0).asin();
            let t = (self.cone_angle.to_radians() - theta) / self.cone_delta.to_radians();
            t.clamp(0.0, 1.0)
        } else {
            // smoothstep(cos_end, cos_start, cos) with t = (cos - cos_end) / (cos_start -
            // cos_end) = (z_end - z) / (z_end - z_start).
            let t = ((self.z_end - z) / (self.z_end - self.z_start)).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }
    }

    /// The profile at `cos(theta)` (less accurate than [`SpotProfile::falloff_z`] for narrow
    /// cones).
    pub fn falloff(&self, cos_theta: f32) -> f32 {
        self.falloff_z(1.0 - cos_theta)
    }

    /// The profile of unit direction `w` around unit `axis`.
    #[inline]
    pub fn falloff_dir(&self, axis: Vec3, w: Vec3) -> f32 {
        self.falloff_z(one_minus_cos(axis, w))
    }

    /// `∫ profile dω` over the sphere, exactly. Smoothstep edge: `2 pi ((1 - cos_start) +
    /// (cos_start - cos_end) / 2)` (the smoothstep averages 1/2 over its interval) `= pi
    /// (z_start + z_end)`. Linear edge from angle `b` to `c`: `2 pi (1 - (sin c - sin b) /
    /// (c - b))` (integrating `(c - theta) sin(theta)` by parts), `2 pi z_end` when `b = c`.
    pub fn solid_angle_integral(&self) -> f64 {
        use std::f64::consts::PI;
        match self.edge {
            SpotEdge::LinearAngle if self.cone_delta > 0.0 => {
                let c = (self.cone_angle as f64).to_radians();
                let b = ((self.cone_angle - self.cone_delta) as f64).to_radians();
                // (sin c - sin b) / (c - b) = cos((c + b) / 2) sinc((c - b) / 2).
                let h = 0.5 * (c - b);
                2.0 * PI * (1.0 - (0.5 * (c + b)).cos() * h.sin() / h)
            }
            SpotEdge::LinearAngle => 2.0 * PI * self.z_end as f64,
            SpotEdge::Smoothstep => PI * (self.z_start as f64 + self.z_end as f64),
        }
    }

    /// `∫ profile(theta) cos(theta) dω` over the front hemisphere, exactly (for
    /// `cone_angle <= 90`): with `a = cos_end`, `b = cos_start`,
    /// `2 pi [(1 - b^2) / 2 + (b - a) (a / 2 + 0.35 (b - a))]`; `pi` for a plain emitter.
    pub fn cosine_integral(&self) -> f64 {
        let (z_end, z_start) = (self.z_end as f64, self.z_start as f64);
        let a = 1.0 - z_end;
        let w = z_end - z_start; // b - a, without cancellation
        let one_minus_b2 = z_start * (2.0 - z_start);
        2.0 * std::f64::consts::PI * (0.5 * one_minus_b2 + w * (0.5 * a + 0.35 * w))
    }
}

/// A texture a spot light projects along its cone (Mitsuba's spot `texture`): the intensity
/// towards local direction `(x, y, z)` (z along the axis) is multiplied by the texture at
/// `(1/2 + x / (2 z tan θc), 1/2 + y / (2 z tan θc))`, θc the cone's half-angle, so the
/// image fills the square around the cone's circle.
#[derive(Debug, Clone)]
pub struct Projection {
    /// The projected image.
    pub texture: std::sync::Arc<crate::texture::Texture>,
    /// World to the light's frame (local x, y across the image, z along the axis).
    frame: Frame,
    /// `tan θc`.
    uv_factor: f32,
}

impl Projection {
    /// The texture projected by a spot along `direction` of half-angle `cone_angle` (degrees),
    /// the image's u axis along `up x direction` and v along `direction x (up x direction)`
    /// (Mitsuba's `lookat` frame); `None` if `up` is parallel to the direction.
    pub fn new(
        texture: std::sync::Arc<crate::texture::Texture>,
        direction: Vec3,
        up: Vec3,
        cone_angle: f32,
    ) -> Option<Projection> {
        let z = direction.try_normalize()?;
        let x = up.cross(z).try_normalize()?;
        Some(Projection {
            texture,
            frame: Frame {
                s: x,
                t: z.cross(x),
                n: z,
            },
            uv_factor: cone_angle.to_radians().tan(),
        })
    }

    /// The texture's value towards unit `w` (within the cone's forward hemisphere).
    #[inline]
    fn towards(&self, w: Vec3) -> Spectrum {
        let l = self.frame.to_local(w);
        let k = 0.5 / (l.z * self.uv_factor);
        self.texture.eval(Vec2::new(0.5 + l.x * k, 0.5 + l.y * k))
    }
}

/// A point light whose intensity falls off around `direction` by a [`SpotProfile`], perhaps
/// through a projected texture.
#[derive(Debug, Clone)]
pub struct SpotLight {
    /// Position of the light.
    pub position: Vec3,
    /// Intensity on the axis (W/sr per RGB channel).
    pub intensity: Spectrum,
    direction: Vec3,
    profile: SpotProfile,
    /// A texture multiplying the intensity by direction.
    pub projection: Option<Projection>,
}

impl SpotLight {
    /// A spot at `position` pointing along `direction` (normalised here; must be non-zero),
    /// with intensity `intensity` on the axis and the given profile
    /// ([`SpotProfile::default`]: 30 degrees, 5 degree edge).
    pub fn new(
        position: Vec3,
        direction: Vec3,
        intensity: Spectrum,
        profile: SpotProfile,
    ) -> SpotLight {
        let direction = direction.normalize();
        assert!(
            direction.is_finite(),
            "spot light direction must be non-zero"
        );
        SpotLight {
            position,
            intensity,
            direction,
            profile,
            projection: None,
        }
    }

    /// This light projecting `projection` (whose axis should be the light's).
    pub fn with_projection(self, projection: Projection) -> SpotLight {
        SpotLight {
            projection: Some(projection),
            ..self
        }
    }

    /// Unit axis of the cone.
    pub fn direction(&self) -> Vec3 {
        self.direction
    }

    /// The angular falloff around the axis.
    pub fn profile(&self) -> &SpotProfile {
        &self.profile
    }

    /// Intensity emitted along unit `w`.
    pub fn intensity_towards(&self, w: Vec3) -> Spectrum {
        let falloff = self.profile.falloff_dir(self.direction, w);
        match &self.projection {
            Some(p) if falloff > 0.0 => self.intensity * falloff * p.towards(w),
            _ => self.intensity * falloff,
        }
    }

    /// `luminance(I) ∫ profile dω`, times the projected texture's mean luminance (what the
    /// light sampler weighs lights by; the texture's share of the cone is not exact).
    pub fn power(&self) -> f32 {
        let texture = self
            .projection
            .as_ref()
            .map_or(1.0, |p| luminance(p.texture.mean()) as f64);
        (luminance(self.intensity) as f64 * self.profile.solid_angle_integral() * texture) as f32
    }

    /// Towards the spot from `p`; `None` outside the cone (and at the spot itself).
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let v = self.position - p;
        let d2 = v.length_squared();
        if d2 == 0.0 {
            return None;
        }
        let dist = d2.sqrt();
        let wi = v / dist;
        let i = self.intensity_towards(-wi);
        if i == Spectrum::ZERO {
            return None;
        }
        Some(LightSample {
            wi,
            dist,
            p: self.position,
            n: Vec3::ZERO,
            li: i / d2,
            pdf: 1.0,
            delta: true,
        })
    }

    /// A direction uniform in the cone of `cone_angle`; `le` is the intensity along it.
    pub fn sample_le(&self, u_dir: Vec2) -> Option<EmissionSample> {
        let z_end = self.profile.z_end;
        let dir = Frame::from_z(self.direction).to_world(sample_uniform_cone(u_dir, z_end));
        let le = self.intensity_towards(dir);
        if le == Spectrum::ZERO {
            return None; // only on the cone's edge
        }
        Some(EmissionSample {
            p: self.position,
            n: Vec3::ZERO,
            dir,
            le,
            pdf_pos: 1.0,
            pdf_dir: uniform_cone_pdf(z_end),
        })
    }

    /// (1, density of `dir`): uniform in the cone, zero outside.
    pub fn pdf_le(&self, dir: Vec3) -> (f32, f32) {
        let z = one_minus_cos(self.direction, dir.normalize());
        let z_end = self.profile.z_end;
        (
            1.0,
            if z <= z_end {
                uniform_cone_pdf(z_end)
            } else {
                0.0
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `∫ profile dω` by the midpoint rule in theta (fine enough for 1e-6).
    fn numeric_integral(p: &SpotProfile) -> f64 {
        let n = 200_000;
        let mut sum = 0.0;
        for i in 0..n {
            let theta = std::f64::consts::PI * (i as f64 + 0.5) / n as f64;
            let z = (1.0 - theta.cos()) as f32;
            sum += p.falloff_z(z) as f64 * theta.sin();
        }
        2.0 * std::f64::consts::PI * sum * std::f64::consts::PI / n as f64
    }

    #[test]
    fn both_edges_integrate_to_their_closed_forms() {
        for (angle, delta) in [(20.0, 5.0), (30.0, 0.0), (60.0, 45.0), (170.0, 100.0)] {
            for edge in [SpotEdge::Smoothstep, SpotEdge::LinearAngle] {
                let p = SpotProfile::new(angle, delta).with_edge(edge);
                let (exact, numeric) = (p.solid_angle_integral(), numeric_integral(&p));
                assert!(
                    ((exact - numeric) / exact).abs() < 2e-4,
                    "{edge:?} {angle} {delta}: {exact} vs {numeric}"
                );
            }
        }
    }

    /// The projected texture: the axis looks up the image's centre, and a direction at angle
    /// θ towards the frame's x (`up x direction`) looks up u = 1/2 + tan θ / (2 tan θc) (the
    /// image's right edge at the cone's edge); towards its y, v. Beyond the cone nothing is
    /// looked up (the falloff is zero), and the light's power scales by the mean texel.
    #[test]
    fn a_projected_texture_fills_the_square_around_the_cone() {
        use crate::texture::{Bitmap, Texture};
        // 4 x 4 texels valued by column (x) + 10 row (y), nearest lookups.
        let mut b = Bitmap::new(
            4,
            4,
            (0..16)
                .map(|i| Spectrum::splat((i % 4 + 10 * (i / 4)) as f32))
                .collect(),
        );
        b.bilinear = false;
        let texture = std::sync::Arc::new(Texture::Bitmap {
            bitmap: std::sync::Arc::new(b),
            to_uv: glam::Affine2::IDENTITY,
        });
        let (dir, up) = (Vec3::new(0.0, 0.0, -1.0), Vec3::Y);
        let light = SpotLight::new(Vec3::ZERO, dir, Spectrum::ONE, SpotProfile::new(40.0, 0.0))
            .with_projection(Projection::new(texture, dir, up, 40.0).unwrap());
        // The frame: x = up x dir = -X, y = dir x x = +Y: u grows towards -X, v towards +Y.
        let towards = |x: f32, y: f32| light.intensity_towards(Vec3::new(x, y, -1.0).normalize()).x;
        let t = 40f32.to_radians().tan();
        // Centre: u = v = 1/2, texel (2, 2) = 22.
        assert_eq!(towards(0.0, 0.0), 22.0);
        // Three quarters of the way to the edge towards -X: u = 1/2 + 3/8 = 0.875, texel 3;
        // towards +X: u = 0.125, texel 0. The same towards -Y: v = 0.125, row 0.
        assert_eq!(towards(-0.75 * t, 0.0), 23.0);
        assert_eq!(towards(0.75 * t, 0.0), 20.0);
        assert_eq!(towards(0.0, -0.75 * t), 2.0);
        assert_eq!(towards(0.0, 0.75 * t), 32.0);
        // Beyond the cone: nothing.
        assert_eq!(towards(1.2 * t, 0.0), 0.0);
        let plain = SpotLight::new(Vec3::ZERO, dir, Spectrum::ONE, SpotProfile::new(40.0, 0.0));
        assert!((light.power() / plain.power() - 16.5).abs() < 1e-4);
        assert!(Projection::new(light.projection.unwrap().texture, dir, dir, 40.0).is_none());
    }

    #[test]
    fn linear_edge_is_mitsubas() {
        // cutoff 20, beam width 15 (Mitsuba's default 3/4): one inside 15 degrees, 1/2 at
        // 17.5, zero beyond 20.
        let p = SpotProfile::new(20.0, 5.0).with_edge(SpotEdge::LinearAngle);
        let at = |deg: f32| p.falloff(deg.to_radians().cos());
        assert_eq!(at(10.0), 1.0);
        assert!((at(17.5) - 0.5).abs() < 1e-3, "{}", at(17.5));
        assert!((at(19.0) - 0.2).abs() < 1e-3);
        assert_eq!(at(21.0), 0.0);
    }
}
