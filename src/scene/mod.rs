//! The scene: camera, shapes, materials, lights and the accelerator, immutable after loading and
//! shared by reference across threads. `loader` reads the TOML scene format (DESIGN.md §6).

mod features;
pub mod loader;

pub use features::SceneFeatures;

use crate::bsdf::{Bsdf, ShadingFrame};
use crate::camera::Camera;
use crate::geometry::bvh::{ShapeGeometry, shadow_segment};
use crate::geometry::{Accel, Hit, Ray};
use crate::light::{Light, LightSampler};
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
    pub material: u32,
    /// Index into `Scene::lights` when the shape emits.
    pub light: Option<u32>,
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
    /// Index of the environment light, if any.
    pub environment: Option<usize>,
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
    /// Emitting light of the shape, if any.
    pub light: Option<usize>,
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
            light: info.light.map(|l| l as usize),
            hit,
        })
    }

    /// Whether the straight segment between surface point `hit` and `p1` (normal `n1`, zero for
    /// a point without a surface, error bound `err1`) is free of occluders.
    pub fn visible(&self, hit: &Hit, p1: Vec3, n1: Vec3, err1: Vec3) -> bool {
        let (o, d, t_max) = shadow_segment(hit.p, hit.p_err, hit.ng, p1, err1, n1);
        t_max <= 0.0 || self.accel.unoccluded(o, d, t_max)
    }

    /// Whether a ray leaving surface point `hit` along unit `d` escapes to infinity.
    pub fn escapes(&self, hit: &Hit, d: Vec3) -> bool {
        let r = hit.spawn(d);
        self.accel.unoccluded(r.o, r.d, f32::INFINITY)
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
