//! Lights: emissive shapes (area lights on meshes and spheres, optionally with a spot
//! profile), point and spot lights, and lights at infinity: a constant environment, an
//! environment map (`envmap.rs`), a directional light and a sun disk. Each offers
//! * `sample_li` / `pdf_li`: a direction from a reference point towards the light (next-event
//!   estimation), with the solid-angle density at the reference point (a discrete 1 for delta
//!   lights);
//! * `sample_le` / `pdf_le`: an emitted ray for light paths, with the area density of its
//!   origin (a discrete 1 for point and spot lights) and the solid-angle density of its
//!   direction (a discrete 1 for the directional light);
//! * `le`: radiance emitted from a point with normal `n` towards `w`; for lights at infinity,
//!   the radiance seen by a ray leaving the scene along `w` (see [`Light::le`]).
//!
//! Area lights emit on their front side only (the shape's geometric normal). Lights at
//! infinity (environment, directional, sun) start their emitted rays on a disk of the scene's
//! bounding-sphere radius outside the scene, so they need the scene bounds
//! ([`Light::set_scene_bounds`]) before use. Lights are chosen in proportion to their power by
//! [`LightSampler`]; the densities above do not include that choice.
//!
//! Delta lights (`is_delta`): point, spot and directional; nothing can hit them, `le` is zero
//! and `pdf_li` is zero.

mod area;
mod cone;
mod directional;
mod environment;
mod envmap;
pub mod locate;
mod point;
mod spot;
mod sun;

pub use area::{AreaLight, AreaShape};
pub use directional::DirectionalLight;
pub use environment::EnvironmentLight;
pub use envmap::EnvMapLight;
pub use point::PointLight;
pub use spot::{Projection, SpotEdge, SpotLight, SpotProfile};
pub use sun::SunLight;

use crate::math::{Distribution1D, Spectrum, luminance};
use glam::{Vec2, Vec3};

/// A light of the scene, of any kind.
#[derive(Debug, Clone)]
pub enum Light {
    /// An emissive shape, plain or with a spot profile.
    Area(AreaLight),
    /// A point emitting the same intensity in every direction (delta in position).
    Point(PointLight),
    /// A point light with a cone of emission (delta).
    Spot(SpotLight),
    /// Constant radiance arriving from every direction at infinity.
    Environment(EnvironmentLight),
    /// Radiance at infinity from a latitude-longitude image (Mitsuba's `envmap`).
    EnvMap(EnvMapLight),
    /// Parallel light from one direction at infinity (delta in direction).
    Directional(DirectionalLight),
    /// A disk of small angular radius at infinity (not delta).
    Sun(SunLight),
}

/// A direction towards a light from a reference point.
#[derive(Debug, Clone, Copy)]
pub struct LightSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the light point (infinite for lights at infinity).
    pub dist: f32,
    /// Point on the light (for a finite light; zero for lights at infinity).
    pub p: Vec3,
    /// Light surface normal at `p` (zero for point, spot and infinite lights).
    pub n: Vec3,
    /// Incident radiance (intensity / dist^2 for point and spot lights, irradiance for the
    /// directional light).
    pub li: Spectrum,
    /// Solid-angle density at the reference point; 1 for delta lights.
    pub pdf: f32,
    /// Whether the light is a delta light: `pdf` is then a discrete probability and no BSDF
    /// sample can reach the light.
    pub delta: bool,
}

/// An emitted ray for a light path.
#[derive(Debug, Clone, Copy)]
pub struct EmissionSample {
    /// Origin of the ray on the light (for lights at infinity, on the disk outside the scene).
    pub p: Vec3,
    /// Normal at `p` (zero for point and spot lights; the ray direction for lights at
    /// infinity).
    pub n: Vec3,
    /// Unit direction of travel.
    pub dir: Vec3,
    /// Emitted radiance (intensity along `dir` for point and spot lights, irradiance for the
    /// directional light).
    pub le: Spectrum,
    /// Area density of `p` (1 for point and spot lights: a discrete choice).
    pub pdf_pos: f32,
    /// Solid-angle density of `dir` (1 for the directional light: a discrete choice).
    pub pdf_dir: f32,
}

impl Light {
    /// Point, spot (delta in position) and directional (delta in direction) lights: no ray
    /// can hit them, `le` and `pdf_li` are zero and `sample_li` reports `delta`.
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Light::Point(_) | Light::Spot(_) | Light::Directional(_)
        )
    }

    /// Lights at infinity: environment, environment map, directional and sun. Their
    /// `sample_li` distances are infinite and they need the scene bounds
    /// ([`Light::set_scene_bounds`]).
    pub fn is_infinite(&self) -> bool {
        matches!(
            self,
            Light::Environment(_) | Light::EnvMap(_) | Light::Directional(_) | Light::Sun(_)
        )
    }

    /// Sets the bounding sphere of the scene of the lights at infinity (the disk their emitted
    /// rays start on, and their power); does nothing for the others. Call it once the scene's
    /// geometry is known, before building the [`LightSampler`].
    pub fn set_scene_bounds(&mut self, center: Vec3, radius: f32) {
        match self {
            Light::Environment(l) => (l.center, l.radius) = (center, radius),
            Light::EnvMap(l) => (l.center, l.radius) = (center, radius),
            Light::Directional(l) => (l.center, l.radius) = (center, radius),
            Light::Sun(l) => (l.center, l.radius) = (center, radius),
            Light::Area(_) | Light::Point(_) | Light::Spot(_) => {}
        }
    }

    /// Emitted power (luminance of the RGB flux), used to choose lights. For lights at
    /// infinity, the flux through a disk of the scene's bounding-sphere radius.
    pub fn power(&self) -> f32 {
        match self {
            Light::Area(l) => l.power(),
            Light::Point(l) => 4.0 * crate::math::PI * luminance(l.intensity),
            Light::Spot(l) => l.power(),
            Light::Environment(l) => l.power(),
            Light::EnvMap(l) => l.power(),
            Light::Directional(l) => l.power(),
            Light::Sun(l) => l.power(),
        }
    }

    /// A direction from reference point `p` towards the light from the uniforms `u`, for
    /// next-event estimation (occlusion not tested); `None` when the point drawn sends no
    /// light towards `p` or has zero density.
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Area(l) => l.sample_li(p, u),
            Light::Point(l) => l.sample_li(p),
            Light::Spot(l) => l.sample_li(p),
            Light::Environment(l) => l.sample_li(u),
            Light::EnvMap(l) => l.sample_li(u),
            Light::Directional(l) => Some(l.sample_li()),
            Light::Sun(l) => Some(l.sample_li(u)),
        }
    }

    /// Density of `sample_li` from `p` choosing the light point `p_l` (normal `n_l`) seen along
    /// unit `wi`. For lights at infinity only `wi` matters (the direction from `p` towards the
    /// sky, as for [`Light::le`]). Zero for delta lights.
    pub fn pdf_li(&self, p: Vec3, p_l: Vec3, n_l: Vec3, wi: Vec3) -> f32 {
        match self {
            Light::Area(l) => l.pdf_li(p, p_l, n_l, wi),
            Light::Point(_) | Light::Spot(_) | Light::Directional(_) => 0.0,
            Light::Environment(_) => environment::pdf_li(),
            Light::EnvMap(l) => l.pdf_li(wi),
            Light::Sun(l) => l.pdf_li(wi),
        }
    }

    /// Radiance leaving the light at point `p` with normal `n` in direction `w` (from the light
    /// towards the viewer, e.g. `-ray.d` for a ray that hit an area light); `p` matters only to
    /// a textured area light.
    ///
    /// **Lights at infinity** (environment, sun; any `n`): `w` is the direction of the ray
    /// that escapes the scene, pointing from the scene towards the sky (`ray.d` of the escaped
    /// ray, the same `wi` that `sample_li` returns); the result is the radiance arriving at
    /// the scene from direction `w`, i.e. travelling along `-w`. A sun in direction `s` is
    /// seen by rays with `w` inside its cone around `s`.
    ///
    /// Zero for delta lights (point, spot, directional), which no ray can hit.
    pub fn le(&self, p: Vec3, n: Vec3, w: Vec3) -> Spectrum {
        match self {
            Light::Area(l) => l.le_at(p, n, w),
            Light::Point(_) | Light::Spot(_) | Light::Directional(_) => Spectrum::ZERO,
            Light::Environment(l) => l.radiance,
            Light::EnvMap(l) => l.le(w),
            Light::Sun(l) => l.le(w),
        }
    }

    /// An emitted ray for a light path: its origin from `u_pos`, its direction from `u_dir`;
    /// `None` when the light emits nothing along the ray drawn.
    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> Option<EmissionSample> {
        match self {
            Light::Area(l) => l.sample_le(u_pos, u_dir),
            Light::Point(l) => Some(l.sample_le(u_dir)),
            Light::Spot(l) => l.sample_le(u_dir),
            Light::Environment(l) => Some(l.sample_le(u_pos, u_dir)),
            Light::EnvMap(l) => l.sample_le(u_pos, u_dir),
            Light::Directional(l) => Some(l.sample_le(u_pos)),
            Light::Sun(l) => Some(l.sample_le(u_pos, u_dir)),
        }
    }

    /// (area density of the origin `p`, solid-angle density of the direction of travel
    /// `dir`) of `sample_le`; `n` is the normal at the origin (used by area lights only).
    /// The directional light's direction is a discrete choice: its `pdf_dir` is 1 (for its
    /// own direction; other directions are never produced).
    pub fn pdf_le(&self, n: Vec3, dir: Vec3) -> (f32, f32) {
        match self {
            Light::Area(l) => l.pdf_le(n, dir),
            Light::Point(_) => (1.0, crate::math::warp::uniform_sphere_pdf()),
            Light::Spot(l) => l.pdf_le(dir),
            Light::Environment(l) => l.pdf_le(),
            Light::EnvMap(l) => l.pdf_le(dir),
            Light::Directional(l) => l.pdf_le(),
            Light::Sun(l) => l.pdf_le(dir),
        }
    }
}

/// Chooses a light: the lights at infinity together with probability `n / (n + 1)` for `n`
/// of them (pbrt-v4's share), the others together with the rest (all of it without lights at
/// infinity), each group's share split in proportion to power ([`Light::power`]). A light at
/// infinity's power is its radiance across the whole scene's bounding disc, which next to a
/// small lamp would leave the lamp almost no samples (an environment of radiance 0.1 over a
/// 10 m floor against a spot: 96 % and 4 %), whatever part of the scene each lights. The
/// power of lights at infinity depends on the scene bounds: build the sampler after
/// [`Light::set_scene_bounds`].
#[derive(Debug, Clone)]
pub struct LightSampler {
    distribution: Option<Distribution1D>,
}

impl LightSampler {
    /// The sampler over `lights` (see [`LightSampler`]).
    pub fn new(lights: &[Light]) -> LightSampler {
        if lights.is_empty() {
            return LightSampler { distribution: None };
        }
        LightSampler {
            distribution: Some(Distribution1D::new(&Self::weights(lights))),
        }
    }

    /// The selection weights of `lights` (summing to 1 unless every power is 0).
    fn weights(lights: &[Light]) -> Vec<f32> {
        let n_inf = lights.iter().filter(|l| l.is_infinite()).count();
        let share = |infinite: bool| match (n_inf, lights.len() - n_inf) {
            (0, _) | (_, 0) => 1.0,
            (n, _) if infinite => n as f64 / (n as f64 + 1.0),
            (n, _) => 1.0 / (n as f64 + 1.0),
        };
        let total = |infinite: bool| {
            lights
                .iter()
                .filter(|l| l.is_infinite() == infinite)
                .map(|l| l.power() as f64)
                .sum::<f64>()
        };
        let (t_inf, t_fin) = (total(true), total(false));
        lights
            .iter()
            .map(|l| {
                let (inf, t) = (l.is_infinite(), if l.is_infinite() { t_inf } else { t_fin });
                if t > 0.0 {
                    (share(inf) * l.power() as f64 / t) as f32
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// (light index, probability), or `None` without lights.
    pub fn sample(&self, u: f32) -> Option<(usize, f32)> {
        let d = self.distribution.as_ref()?;
        let (i, pmf, _) = d.sample(u);
        Some((i, pmf))
    }

    /// Probability that [`LightSampler::sample`] chooses light `light` (0 without lights).
    pub fn pmf(&self, light: usize) -> f32 {
        self.distribution.as_ref().map_or(0.0, |d| d.pmf(light))
    }
}
