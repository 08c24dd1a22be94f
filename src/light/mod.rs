//! Lights: emissive shapes (area lights on meshes and spheres), point lights and a constant
//! environment. Each offers
//! * `sample_li` / `pdf_li`: a direction from a reference point towards the light (next-event
//!   estimation), with the solid-angle density at the reference point (a discrete 1 for delta
//!   lights);
//! * `sample_le` / `pdf_le`: an emitted ray for light paths, with the area density of its
//!   origin (a discrete 1 for point lights) and the solid-angle density of its direction;
//! * `le`: radiance emitted from a point with normal `n` towards `w`.
//!
//! Area lights emit on their front side only (the shape's geometric normal). Lights are chosen
//! in proportion to their power by [`LightSampler`]; the densities above do not include that
//! choice.

mod area;
mod environment;
mod point;

pub use area::{AreaLight, AreaShape};
pub use environment::EnvironmentLight;
pub use point::PointLight;

use crate::math::{Distribution1D, Spectrum, luminance};
use glam::{Vec2, Vec3};

#[derive(Debug, Clone)]
pub enum Light {
    Area(AreaLight),
    Point(PointLight),
    Environment(EnvironmentLight),
}

/// A direction towards a light from a reference point.
#[derive(Debug, Clone, Copy)]
pub struct LightSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the light point (infinite for the environment).
    pub dist: f32,
    /// Point on the light (for a finite light).
    pub p: Vec3,
    /// Light surface normal at `p` (zero for point and environment lights).
    pub n: Vec3,
    /// Incident radiance (or intensity / dist^2 for point lights).
    pub li: Spectrum,
    /// Solid-angle density at the reference point; 1 for delta lights.
    pub pdf: f32,
    pub delta: bool,
}

/// An emitted ray for a light path.
#[derive(Debug, Clone, Copy)]
pub struct EmissionSample {
    pub p: Vec3,
    /// Normal at `p` (zero for point lights; the ray direction for the environment).
    pub n: Vec3,
    /// Unit direction of travel.
    pub dir: Vec3,
    /// Emitted radiance (intensity for point lights).
    pub le: Spectrum,
    /// Area density of `p` (1 for point lights: a discrete choice).
    pub pdf_pos: f32,
    /// Solid-angle density of `dir`.
    pub pdf_dir: f32,
}

impl Light {
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point(_))
    }

    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Environment(_))
    }

    /// Emitted power (luminance of the RGB flux), used to choose lights.
    pub fn power(&self) -> f32 {
        match self {
            Light::Area(l) => l.power(),
            Light::Point(l) => 4.0 * crate::math::PI * luminance(l.intensity),
            Light::Environment(l) => l.power(),
        }
    }

    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Area(l) => l.sample_li(p, u),
            Light::Point(l) => l.sample_li(p),
            Light::Environment(l) => l.sample_li(u),
        }
    }

    /// Density of `sample_li` from `p` choosing the light point `p_l` (normal `n_l`) seen along
    /// unit `wi`. For the environment, only `wi` matters. Zero for delta lights.
    pub fn pdf_li(&self, p: Vec3, p_l: Vec3, n_l: Vec3, wi: Vec3) -> f32 {
        match self {
            Light::Area(l) => l.pdf_li(p, p_l, n_l, wi),
            Light::Point(_) => 0.0,
            Light::Environment(_) => environment::pdf_li(),
        }
    }

    /// Radiance leaving the light at a point with normal `n` in direction `w` (for the
    /// environment: radiance arriving from direction `-w`, any `n`).
    pub fn le(&self, n: Vec3, w: Vec3) -> Spectrum {
        match self {
            Light::Area(l) => l.le(n, w),
            Light::Point(_) => Spectrum::ZERO,
            Light::Environment(l) => l.radiance,
        }
    }

    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> Option<EmissionSample> {
        match self {
            Light::Area(l) => l.sample_le(u_pos, u_dir),
            Light::Point(l) => Some(l.sample_le(u_dir)),
            Light::Environment(l) => Some(l.sample_le(u_pos, u_dir)),
        }
    }

    /// (area density of the origin `p`, solid-angle density of `dir`) of `sample_le`.
    pub fn pdf_le(&self, n: Vec3, dir: Vec3) -> (f32, f32) {
        match self {
            Light::Area(l) => l.pdf_le(n, dir),
            Light::Point(_) => (1.0, crate::math::warp::uniform_sphere_pdf()),
            Light::Environment(l) => l.pdf_le(),
        }
    }
}

/// Chooses a light in proportion to its power.
#[derive(Debug, Clone)]
pub struct LightSampler {
    distribution: Option<Distribution1D>,
}

impl LightSampler {
    pub fn new(lights: &[Light]) -> LightSampler {
        if lights.is_empty() {
            return LightSampler { distribution: None };
        }
        let powers: Vec<f32> = lights.iter().map(|l| l.power()).collect();
        LightSampler {
            distribution: Some(Distribution1D::new(&powers)),
        }
    }

    /// (light index, probability), or `None` without lights.
    pub fn sample(&self, u: f32) -> Option<(usize, f32)> {
        let d = self.distribution.as_ref()?;
        let (i, pmf, _) = d.sample(u);
        Some((i, pmf))
    }

    pub fn pmf(&self, light: usize) -> f32 {
        self.distribution.as_ref().map_or(0.0, |d| d.pmf(light))
    }
}
