//! Area lights: emissive shapes with radiance on their front side, constant or multiplied by
//! a texture over the surface ([`AreaLight::with_texture`]; sampling stays uniform). Meshes are
//! sampled uniformly by area (a parallelogram, such as a quad, directly: `MeshSampler`);
//! spheres by the cone of directions they subtend (uniform area sampling from inside).
//!
//! A spot area light ([`AreaLight::with_spot`]) scales the radiance by a [`SpotProfile`] of
//! the angle between the emitted direction and the geometric normal; its emitted rays are
//! cosine-weighted within the profile's cone instead of over the hemisphere.

use super::cone::one_minus_cos;
use super::locate::TriangleLocator;
use super::{EmissionSample, LightSample, SpotProfile};
use crate::geometry::{Sphere, TriangleMesh, mesh::MeshSampler};
use crate::math::{Frame, PI, Spectrum, luminance, warp};
use glam::{Vec2, Vec3};

/// The geometry an area light emits from, with what sampling it needs.
#[derive(Debug, Clone)]
pub enum AreaShape {
    /// A triangle mesh, sampled uniformly by area.
    Mesh {
        /// Boxed: sampling reads only `sampler` when the mesh is a parallelogram.
        mesh: Box<TriangleMesh>,
        /// The area-weighted triangle distribution (or the parallelogram) of the mesh.
        sampler: MeshSampler,
    },
    /// A sphere, sampled by the cone of directions it subtends.
    Sphere(Sphere),
}

/// An emissive shape: constant radiance on its front side, optionally shaped by a spot
/// profile.
#[derive(Debug, Clone)]
pub struct AreaLight {
    /// Scene shape that emits.
    pub shape: u32,
    /// Radiance along the normal (everywhere on the front side without a spot profile).
    pub radiance: Spectrum,
    /// The emitting geometry.
    pub geometry: AreaShape,
    /// Angular profile around the geometric normal; `None` for a plain (Lambertian) emitter.
    pub spot: Option<SpotProfile>,
    /// A texture multiplying the radiance over the surface (Mitsuba's textured `radiance`),
    /// looked up at the texture coordinates of the point ([`AreaLight::uv_at`]).
    pub texture: Option<std::sync::Arc<crate::texture::Texture>>,
    /// A textured mesh's triangle search, for the texture coordinates at a point.
    locator: Option<Box<TriangleLocator>>,
}

impl AreaLight {
    /// A plain (Lambertian) emitter of shape `shape`.
    pub fn new(shape: u32, radiance: Spectrum, geometry: AreaShape) -> AreaLight {
        AreaLight {
            shape,
            radiance,
            geometry,
            spot: None,
            texture: None,
            locator: None,
        }
    }

    /// This light with its radiance multiplied by `texture` over the surface (a mesh gets
    /// the triangle search its texture coordinates need, `locate.rs`).
    pub fn with_texture(self, texture: std::sync::Arc<crate::texture::Texture>) -> Self {
        let locator = match &self.geometry {
            AreaShape::Mesh { mesh, .. } => Some(Box::new(TriangleLocator::new(mesh))),
            AreaShape::Sphere(_) => None,
        };
        AreaLight {
            texture: Some(texture),
            locator,
            ..self
        }
    }

    /// The texture coordinates of point `p` of the surface: a sphere's (φ / 2π, θ / π), or
    /// those of the mesh triangle that contains `p` (`TriangleLocator`; a light without a
    /// texture has no search and gets zero).
    pub fn uv_at(&self, p: Vec3) -> Vec2 {
        match (&self.geometry, &self.locator) {
            (AreaShape::Sphere(s), _) => s.tex_coords(p),
            (AreaShape::Mesh { mesh, .. }, Some(locator)) => locator.uv_at(mesh, p),
            (AreaShape::Mesh { .. }, None) => Vec2::ZERO,
        }
    }

    /// Radiance leaving point `p` (normal `n`) along `w`: [`Self::le`] times the texture at
    /// `p`.
    #[inline]
    pub fn le_at(&self, p: Vec3, n: Vec3, w: Vec3) -> Spectrum {
        let le = self.le(n, w);
        match &self.texture {
            Some(t) if le != Spectrum::ZERO => le * t.eval(self.uv_at(p)),
            _ => le,
        }
    }

    /// A spot area light: `le(n, w) = radiance * profile(angle between n and w)` on the front
    /// side. Panics unless the profile's `cone_angle` is at most 90 degrees (see
    /// [`SpotProfile::check_area`]).
    pub fn with_spot(
        shape: u32,
        radiance: Spectrum,
        geometry: AreaShape,
        profile: SpotProfile,
    ) -> AreaLight {
        assert_eq!(
            profile.edge(),
            super::spot::SpotEdge::Smoothstep,
            "spot area lights have the smoothstep edge (their cosine integral is its)"
        );
        if let Err(e) = SpotProfile::check_area(profile.cone_angle(), profile.cone_delta()) {
            panic!("{e}");
        }
        AreaLight {
            spot: Some(profile),
            ..AreaLight::new(shape, radiance, geometry)
        }
    }

    /// Surface area of the emitting geometry.
    pub fn area(&self) -> f32 {
        match &self.geometry {
            AreaShape::Mesh { sampler, .. } => sampler.area,
            AreaShape::Sphere(s) => s.area(),
        }
    }

    /// `area * luminance(radiance) * ∫ profile(theta) cos(theta) dω` (`pi` without a profile),
    /// times the texture's mean luminance (over its texture coordinates: the light sampler's
    /// weight, not exact for a texture the surface does not cover evenly).
    pub fn power(&self) -> f32 {
        let texture = self.texture.as_ref().map_or(1.0, |t| luminance(t.mean()));
        texture
            * match &self.spot {
                None => PI * self.area() * luminance(self.radiance),
                Some(s) => {
                    (self.area() as f64 * luminance(self.radiance) as f64 * s.cosine_integral())
                        as f32
                }
            }
    }

    /// Radiance leaving a point of normal `n` along `w` (zero on the back side), before any
    /// texture ([`Self::le_at`] includes it).
    pub fn le(&self, n: Vec3, w: Vec3) -> Spectrum {
        if n.dot(w) > 0.0 {
            match &self.spot {
                None => self.radiance,
                Some(s) => self.radiance * s.falloff_dir(n, w.normalize()),
            }
        } else {
            Spectrum::ZERO
        }
    }

    /// A point on the light seen from `p` (see [`super::Light::sample_li`]), with its
    /// solid-angle density at `p`.
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let (p_l, n_l, pdf, v, dist) = match &self.geometry {
            AreaShape::Mesh { mesh, sampler } => {
                let (p_l, n_l) = sampler.sample(mesh, u);
                let v = p_l - p;
                let d2 = v.length_squared();
                let dist = d2.sqrt();
                let cos_l = n_l.dot(-v) / dist;
                if cos_l <= 0.0 {
                    return None;
                }
                (p_l, n_l, d2 / (cos_l * sampler.area), v, dist)
            }
            AreaShape::Sphere(s) => {
                let (p_l, n_l, pdf) = sphere_sample_li(s, p, u)?;
                let v = p_l - p;
                (p_l, n_l, pdf, v, v.length())
            }
        };
        if dist == 0.0 || !pdf.is_finite() || pdf <= 0.0 {
            return None;
        }
        let wi = v / dist;
        // Without a spot profile the sample faces p (checked above for meshes): `le` is the
        // radiance.
        let li = match (&self.geometry, &self.spot, &self.texture) {
            (AreaShape::Mesh { .. }, None, None) => self.radiance,
            _ => self.le_at(p_l, n_l, -wi),
        };
        if li == Spectrum::ZERO {
            return None;
        }
        Some(LightSample {
            wi,
            dist,
            p: p_l,
            n: n_l,
            li,
            pdf,
            delta: false,
        })
    }

    /// Solid-angle density at `p` of [`Self::sample_li`] choosing `p_l` (normal `n_l`) along
    /// `wi`.
    pub fn pdf_li(&self, p: Vec3, p_l: Vec3, n_l: Vec3, wi: Vec3) -> f32 {
        match &self.geometry {
            AreaShape::Mesh { sampler, .. } => {
                let d2 = (p_l - p).length_squared();
                let cos_l = n_l.dot(wi).abs();
                if cos_l == 0.0 {
                    0.0
                } else {
                    d2 / (cos_l * sampler.area)
                }
            }
            AreaShape::Sphere(s) => sphere_pdf_li(s, p, p_l, n_l, wi),
        }
    }

    /// An emitted ray: a point uniform by area (by `u_pos`), a cosine-weighted direction on
    /// the front side (by `u_dir`; within the cone with a spot profile).
    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> Option<EmissionSample> {
        let (p, n, pdf_pos) = match &self.geometry {
            AreaShape::Mesh { mesh, sampler } => {
                let (p, n) = sampler.sample(mesh, u_pos);
                (p, n, 1.0 / sampler.area)
            }
            AreaShape::Sphere(s) => {
                let n = warp::square_to_uniform_sphere(u_pos);
                (s.center + s.radius * n, n, 1.0 / s.area())
            }
        };
        let Some(spot) = &self.spot else {
            let local = warp::square_to_cosine_hemisphere(u_dir);
            let pdf_dir = warp::cosine_hemisphere_pdf(local.z);
            if pdf_dir <= 0.0 {
                return None;
            }
            let dir = Frame::from_z(n).to_world(local);
            let le = match &self.texture {
                None => self.radiance,
                Some(t) => self.radiance * t.eval(self.uv_at(p)),
            };
            return Some(EmissionSample {
                p,
                n,
                dir,
                le,
                pdf_pos,
                pdf_dir,
            });
        };
        // Cosine-weighted within the cone: uniform on the disk of radius sin(cone_angle).
        let sin2 = cone_sin2(spot);
        let d = warp::square_to_disk_concentric(u_dir) * sin2.sqrt();
        let cos = (1.0 - d.length_squared()).max(0.0).sqrt();
        let dir = Frame::from_z(n).to_world(Vec3::new(d.x, d.y, cos));
        let le = self.le_at(p, n, dir);
        if cos <= 0.0 || le == Spectrum::ZERO {
            return None; // only on the cone's edge
        }
        Some(EmissionSample {
            p,
            n,
            dir,
            le,
            pdf_pos,
            pdf_dir: cos / (PI * sin2),
        })
    }

    /// (`1 / area`, solid-angle density of `dir` around the normal `n`): cosine-weighted over
    /// the hemisphere, or within the cone for a spot area light.
    pub fn pdf_le(&self, n: Vec3, dir: Vec3) -> (f32, f32) {
        let pdf_dir = match &self.spot {
            None => warp::cosine_hemisphere_pdf(n.dot(dir)),
            Some(spot) => {
                let dir = dir.normalize();
                let cos = n.dot(dir);
                if cos > 0.0 && one_minus_cos(n, dir) <= spot.one_minus_cos_total() {
                    cos / (PI * cone_sin2(spot))
                } else {
                    0.0
                }
            }
        };
        (1.0 / self.area(), pdf_dir)
    }
}

/// `sin^2(cone_angle)` of a profile, from `z = 1 - cos` (no cancellation).
fn cone_sin2(spot: &SpotProfile) -> f32 {
    let z = spot.one_minus_cos_total();
    z * (2.0 - z)
}

/// 1 - cos(theta_max) and cos(theta_max) of the cone a sphere subtends from distance^2 `dc2`,
/// computed without cancellation for distant spheres.
fn cone_of(s: &Sphere, dc2: f32) -> (f32, f32) {
    let sin2 = (s.radius * s.radius / dc2).min(1.0);
    let cos = (1.0 - sin2).max(0.0).sqrt();
    (sin2 / (1.0 + cos), cos)
}

fn sphere_sample_li(s: &Sphere, p: Vec3, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
    let dc2 = (s.center - p).length_squared();
    if dc2 <= s.radius * s.radius {
        // Inside: uniform area sampling, converted to solid angle.
        let n = warp::square_to_uniform_sphere(u);
        let p_l = s.center + s.radius * n;
        let v = p_l - p;
        let d2 = v.length_squared();
        let cos = n.dot(v).abs() / d2.sqrt();
        return (cos > 0.0).then(|| (p_l, n, d2 / (cos * s.area())));
    }
    let (one_minus_cos, cos_max) = cone_of(s, dc2);
    let dc = dc2.sqrt();
    let axis = (s.center - p) / dc;
    // Uniform in the cone (written with 1 - cos, accurate for tiny cones).
    let wi = Frame::from_z(axis).to_world(super::cone::sample_uniform_cone(u, one_minus_cos));
    // The point on the sphere seen along wi (nearest intersection; tangent point on a miss).
    let t = s.intersect(p, wi, f32::INFINITY);
    let t = if t.is_finite() { t } else { dc * cos_max };
    let n = (p + t * wi - s.center).normalize();
    let p_l = s.center + s.radius * n;
    Some((p_l, n, 1.0 / (2.0 * PI * one_minus_cos)))
}

fn sphere_pdf_li(s: &Sphere, p: Vec3, p_l: Vec3, n_l: Vec3, wi: Vec3) -> f32 {
    let dc2 = (s.center - p).length_squared();
    if dc2 <= s.radius * s.radius {
        let d2 = (p_l - p).length_squared();
        let cos = n_l.dot(wi).abs();
        return if cos == 0.0 {
            0.0
        } else {
            d2 / (cos * s.area())
        };
    }
    let (one_minus_cos, _) = cone_of(s, dc2);
    1.0 / (2.0 * PI * one_minus_cos)
}
