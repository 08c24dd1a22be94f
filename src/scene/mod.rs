//! The scene: camera, shapes, materials, lights and the accelerator, immutable after loading and
//! shared by reference across threads. `loader` reads the TOML scene format (DESIGN.md §6).

mod features;
pub mod loader;

pub use features::SceneFeatures;

use crate::bsdf::{Bsdf, ShadingFrame};
use crate::camera::Camera;
use crate::geometry::bvh::{ShapeGeometry, shadow_segment};
use crate::geometry::{Accel, Hit, Ray, SHADOW_EPS, offset_origin};
use crate::light::{Light, LightSampler};
use crate::math::Spectrum;
use crate::medium::{HomogeneousMedium, MediumInterface};
use glam::Vec3;

/// The built-in default scene (the same text as `scenes/cornell-box.toml`).
pub const CORNELL_BOX_TOML: &str = include_str!("../../scenes/cornell-box.toml");

#[derive(Debug, Clone)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
}

#[derive(Debug, Clone)]
pub struct ShapeInfo {
    /// Display name (`name` key, or "shape #i (type)").
    pub name: String,
    /// Index of the shape in the scene.
    pub index: u32,
    pub material: u32,
    /// Index into `Scene::lights` when the shape emits.
    pub light: Option<u32>,
    /// Media on either side, when the shape bounds a medium.
    pub interface: Option<MediumInterface>,
    /// An index-matched boundary: media and no material; rays pass straight through.
    pub null: bool,
}

/// `[render]` defaults of a scene file; the command line overrides them.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderDefaults {
    pub max_depth: u32,
    pub spp: u32,
    pub integrator: String,
}

impl Default for RenderDefaults {
    fn default() -> Self {
        RenderDefaults {
            max_depth: 8,
            spp: 16,
            integrator: "pt".to_string(),
        }
    }
}

pub struct Scene {
    /// The scene file, or `<built-in cornell-box>`.
    pub source: String,
    pub camera: Camera,
    pub shapes: Vec<ShapeGeometry>,
    pub shape_info: Vec<ShapeInfo>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    pub light_sampler: LightSampler,
    /// Indices of the lights at infinity (environment, directional, sun): what an escaping
    /// ray can see.
    pub infinite_lights: Vec<usize>,
    pub media: Vec<HomogeneousMedium>,
    /// The world medium, which the camera is in.
    pub camera_medium: Option<u32>,
    pub accel: Accel,
    pub features: SceneFeatures,
    /// Bounding sphere of the geometry.
    pub center: Vec3,
    pub radius: f32,
    pub render: RenderDefaults,
}

/// A surface point with what is needed to scatter there.
pub struct SurfacePoint<'a> {
    pub hit: Hit,
    pub bsdf: &'a Bsdf,
    pub frame: ShadingFrame,
    /// The shape's light, media and whether it is an index-matched boundary (kept by
    /// reference: surface points are built for every ray and should stay small).
    pub info: &'a ShapeInfo,
}

impl SurfacePoint<'_> {
    /// Index of the light the shape emits as, if any.
    #[inline]
    pub fn light(&self) -> Option<usize> {
        self.info.light.map(|l| l as usize)
    }

    /// An index-matched boundary: no scattering, rays continue straight through.
    #[inline]
    pub fn is_null(&self) -> bool {
        self.info.null
    }
}

/// One end of a visibility test: a surface point (normal and position error bound) or a point
/// without a surface (a medium vertex or a point light: zero normal and error).
#[derive(Debug, Clone, Copy)]
pub struct Endpoint {
    pub p: Vec3,
    pub n: Vec3,
    pub err: Vec3,
}

impl Endpoint {
    pub fn surface(hit: &Hit) -> Endpoint {
        Endpoint {
            p: hit.p,
            n: hit.ng,
            err: hit.p_err,
        }
    }

    pub fn point(p: Vec3) -> Endpoint {
        Endpoint {
            p,
            n: Vec3::ZERO,
            err: Vec3::ZERO,
        }
    }
}

/// Transmittance of an unoccluded connection, and the probability that free-flight sampling
/// passes it without scattering (1 without media; it enters MIS densities).
#[derive(Debug, Clone, Copy)]
pub struct Transmittance {
    pub tr: Spectrum,
    pub pass: f32,
    /// (medium, length) of the first and the last medium segment (for path densities).
    pub first: Option<(u32, f32)>,
    pub last: Option<(u32, f32)>,
    /// Medium at the far end (after any index-matched crossings).
    pub end_medium: Option<u32>,
}

impl Scene {
    /// The built-in Cornell box.
    pub fn cornell_box() -> Scene {
        loader::load_str(CORNELL_BOX_TOML, "<built-in cornell-box>", None)
            .expect("the built-in scene is valid")
    }

    pub fn intersect(&self, ray: &Ray) -> Option<SurfacePoint<'_>> {
        let hit = self.accel.intersect(ray, &self.shapes)?;
        let info = &self.shape_info[hit.shape as usize];
        Some(SurfacePoint {
            bsdf: &self.materials[info.material as usize].bsdf,
            frame: ShadingFrame::new(hit.ns, hit.ng),
            info,
            hit,
        })
    }

    /// Medium after leaving surface point `sp` along `d` (transmission or pass-through), given
    /// the medium before.
    #[inline]
    pub fn medium_after(&self, sp: &SurfacePoint, d: Vec3, current: Option<u32>) -> Option<u32> {
        match &sp.info.interface {
            Some(mi) => mi.crossing(d, sp.hit.ng),
            None => current,
        }
    }

    /// Transmittance from `a` to `b` (or from `a` to infinity along unit `dir` when `b` is
    /// `None`), starting in `medium`, through index-matched boundaries; `None` when a surface
    /// blocks the way. Without media this is a single occlusion query.
    pub fn transmittance(
        &self,
        a: &Endpoint,
        b: Option<&Endpoint>,
        dir: Vec3,
        medium: Option<u32>,
    ) -> Option<Transmittance> {
        let (mut o, d, mut remaining) = match b {
            Some(b) => shadow_segment(a.p, a.err, a.n, b.p, b.err, b.n),
            None => (offset_origin(a.p, a.err, a.n, dir), dir, f32::INFINITY),
        };
        let mut out = Transmittance {
            tr: Spectrum::ONE,
            pass: 1.0,
            first: None,
            last: None,
            end_medium: medium,
        };
        if !self.features.media {
            let free = remaining <= 0.0 || self.accel.unoccluded(o, d, remaining);
            return free.then_some(out);
        }
        let segment = |out: &mut Transmittance, m: u32, len: f32| {
            let md = &self.media[m as usize];
            out.tr *= md.tr(len);
            out.pass *= md.pass_probability(len);
            if out.first.is_none() {
                out.first = Some((m, len));
            }
            out.last = Some((m, len));
        };
        let mut medium = medium;
        // Occlusion stops short of the target by the shadow epsilon; attenuation and the
        // free-flight probabilities use the full distance.
        let slack = if remaining.is_finite() {
            remaining * SHADOW_EPS / (1.0 - SHADOW_EPS)
        } else {
            0.0
        };
        // A bounded number of index-matched crossings (closed shapes give two each).
        for _ in 0..64 {
            if remaining <= 0.0 {
                out.end_medium = medium;
                return Some(out);
            }
            let ray = Ray {
                o,
                d,
                t_max: remaining,
            };
            let Some(sp) = self.intersect(&ray) else {
                if let Some(m) = medium {
                    segment(&mut out, m, remaining + slack);
                }
                out.end_medium = medium;
                return Some(out);
            };
            if !sp.is_null() {
                return None;
            }
            if let Some(m) = medium {
                segment(&mut out, m, sp.hit.t);
            }
            medium = self.medium_after(&sp, d, medium);
            let next = offset_origin(sp.hit.p, sp.hit.p_err, sp.hit.ng, d);
            remaining -= (next - o).dot(d);
            o = next;
        }
        None
    }

    pub fn triangle_count(&self) -> usize {
        self.shapes
            .iter()
            .map(|s| {
                if let ShapeGeometry::Mesh(m) = s {
                    m.indices.len()
                } else {
                    0
                }
            })
            .sum()
    }

    pub fn sphere_count(&self) -> usize {
        self.shapes
            .iter()
            .filter(|s| matches!(s, ShapeGeometry::Sphere(_)))
            .count()
    }
}
