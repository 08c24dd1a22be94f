//! Scene files: TOML, strict. Unknown keys, wrong types, dangling references and out-of-range
//! numbers are errors of the form `FILE:LINE: what is wrong, and what was expected`.
//!
//! ```toml
//! world_medium = "haze"    # optional: a medium filling the world (the camera is in it)
//!
//! [camera]                 # pinhole
//! position = [0, 0, 3.9]
//! look_at = [0, 0, 0]
//! up = [0, 1, 0]
//! fov = 39.3077            # degrees, vertical axis, in (0, 180)
//! resolution = [256, 256]
//!
//! [render]                 # defaults; the command line overrides them
//! max_depth = 8            # maximum number of path segments
//! spp = 16
//! integrator = "pt"
//!
//! [[material]]
//! name = "white"
//! type = "diffuse"         # diffuse (albedo), conductor (reflectance: a mirror),
//! albedo = [0.73, 0.73, 0.73] # dielectric (ior), roughconductor (alpha and reflectance, or
//!                          # alpha, eta and k), roughdielectric (alpha, ior), black
//!
//! [[medium]]               # homogeneous
//! name = "haze"
//! sigma_a = [0.01, 0.01, 0.01]
//! sigma_s = [0.1, 0.1, 0.1]
//! g = 0.0                  # Henyey-Greenstein, in (-1, 1)
//!
//! [[shape]]
//! type = "quad"            # quad (origin, edge_u, edge_v, optional tiles = [nu, nv] with
//!                          # tile_material), cube, sphere (center, radius),
//!                          # disk (center, normal, radius, segments), obj (file),
//!                          # heightfield (size, grid, waves = [{ amplitude, wavelength,
//!                          # direction = [x, z], phase }])
//! origin = [-1, -1, -1]
//! edge_u = [0, 0, 2]       # front side along edge_u x edge_v
//! edge_v = [2, 0, 0]
//! material = "white"       # omit with interior/exterior for an index-matched boundary
//! emission = [17, 12, 4]   # optional: makes the shape an area light (front side only)
//! cone_angle = 30          # optional with emission: an area spot light (degrees, half-angle;
//! cone_delta = 5           # smooth edge width)
//! interior = "fog"         # optional media inside / outside (unnamed side: the world medium)
//! transform = { scale = [1, 1, 1], rotate = { axis = [0, 1, 0], degrees = 0 }, translate = [0, 0, 0] }
//!
//! [[light]]
//! type = "point"           # point (position, intensity), spot (position, direction,
//! position = [0, 0.9, 0]   # intensity, cone_angle = 30, cone_delta = 5), environment
//! intensity = [1, 1, 1]    # (radiance), directional (direction of travel, irradiance),
//!                          # sun (direction towards the sun, angle = 0.27 degrees,
//!                          # radiance or irradiance)
//! ```
//! Transforms apply scale, then rotation, then translation. Paths are relative to the scene file.
//!
//! A tiled quad (`tiles = [nu, nv]`, `tile_material = "blue"`) is a checkerboard: the quad cut
//! into `nu` cells along `edge_u` by `nv` along `edge_v`; the cell at `origin` and every cell an
//! even number of steps from it take `material`, the others `tile_material`. It becomes two
//! shapes, named after the shape with ` (tiles)` appended to the second; it cannot emit.

use super::{Material, RenderDefaults, Scene, SceneFeatures, ShapeInfo};
use crate::bsdf::{Bsdf, ConductorFresnel};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::geometry::bvh::ShapeGeometry;
use crate::geometry::heightfield::{Wave, heightfield};
use crate::geometry::mesh::MeshSampler;
use crate::geometry::{Accel, Sphere, Transform, TriangleMesh};
use crate::light::{
    AreaLight, AreaShape, DirectionalLight, EnvironmentLight, Light, LightSampler, PointLight,
    SpotLight, SpotProfile, SunLight,
};
use crate::math::Frame;
use crate::medium::{HomogeneousMedium, MediumInterface};
use glam::{UVec2, Vec2, Vec3};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// Largest accepted |coordinate| of any point of the scene (vertices after their transform,
/// sphere bounds, camera, point and spot lights). Beyond it f32 ray tracing means nothing and
/// extents, areas and BVH bounds overflow to infinity.
pub const MAX_COORDINATE: f32 = 1e12;

/// Accepted range of each |component| of a transform's `scale`: keeps the normal matrix (the
/// inverse transpose) and the triangle areas finite and non-zero.
pub const SCALE_RANGE: (f32, f32) = (1e-9, 1e9);

/// Most triangles a scene may have, all shapes together (2^24, about 16.8 million). Loading
/// and the BVH take about 350 bytes per triangle at peak, so this bounds the memory of
/// loading at about 6 GB; beyond it the loader says so instead of dying of an allocation
/// failure.
pub const MAX_TRIANGLES: usize = 1 << 24;

/// The unit vector along `v`, for any finite non-zero `v` (`Vec3::normalize` overflows or
/// underflows for lengths beyond about 1e19 or below 1e-19).
fn unit_vector(v: Vec3) -> Option<Vec3> {
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    (v / m).try_normalize()
}

/// Whether every coordinate of `p` is finite and within [`MAX_COORDINATE`].
fn in_bounds(p: Vec3) -> bool {
    p.abs().max_element() <= MAX_COORDINATE
}

type V3 = Spanned<[f32; 3]>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneDesc {
    /// Medium filling the world (and containing the camera).
    world_medium: Option<Spanned<String>>,
    camera: Spanned<CameraDesc>,
    #[serde(default)]
    render: Option<RenderDesc>,
    #[serde(default)]
    material: Vec<Spanned<MaterialDesc>>,
    #[serde(default)]
    medium: Vec<Spanned<MediumDesc>>,
    #[serde(default)]
    shape: Vec<Spanned<ShapeDesc>>,
    #[serde(default)]
    light: Vec<Spanned<LightDesc>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    position: V3,
    look_at: V3,
    #[serde(default)]
    up: Option<V3>,
    fov: Spanned<f32>,
    resolution: Spanned<[u32; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderDesc {
    max_depth: Option<Spanned<i64>>,
    spp: Option<Spanned<u32>>,
    integrator: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDesc {
    name: Spanned<String>,
    #[serde(rename = "type")]
    kind: Spanned<String>,
    albedo: Option<V3>,
    reflectance: Option<V3>,
    ior: Option<Spanned<f32>>,
    alpha: Option<Spanned<f32>>,
    eta: Option<V3>,
    k: Option<V3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MediumDesc {
    name: Spanned<String>,
    sigma_a: V3,
    sigma_s: V3,
    g: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WaveDesc {
    amplitude: f32,
    wavelength: f32,
    direction: [f32; 2],
    #[serde(default)]
    phase: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeDesc {
    #[serde(rename = "type")]
    kind: Spanned<String>,
    name: Option<String>,
    material: Option<Spanned<String>>,
    emission: Option<V3>,
    transform: Option<Spanned<TransformDesc>>,
    origin: Option<V3>,
    edge_u: Option<V3>,
    edge_v: Option<V3>,
    center: Option<V3>,
    normal: Option<V3>,
    radius: Option<Spanned<f32>>,
    segments: Option<Spanned<u32>>,
    file: Option<Spanned<String>>,
    size: Option<Spanned<[f32; 2]>>,
    grid: Option<Spanned<[u32; 2]>>,
    waves: Option<Spanned<Vec<WaveDesc>>>,
    /// Quads: a checkerboard of `tiles[0]` x `tiles[1]` cells alternating `material` and
    /// `tile_material`.
    tiles: Option<Spanned<[u32; 2]>>,
    tile_material: Option<Spanned<String>>,
    interior: Option<Spanned<String>>,
    exterior: Option<Spanned<String>>,
    /// With `emission`: an area spot light whose radiance falls off with the angle to the normal.
    cone_angle: Option<Spanned<f32>>,
    cone_delta: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(
    untagged,
    expecting = "'scale' must be a number or an array of three numbers"
)]
enum ScaleDesc {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RotateDesc {
    axis: [f32; 3],
    degrees: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformDesc {
    scale: Option<Spanned<ScaleDesc>>,
    rotate: Option<Spanned<RotateDesc>>,
    translate: Option<V3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDesc {
    #[serde(rename = "type")]
    kind: Spanned<String>,
    position: Option<V3>,
    intensity: Option<V3>,
    radiance: Option<V3>,
    irradiance: Option<V3>,
    direction: Option<V3>,
    cone_angle: Option<Spanned<f32>>,
    cone_delta: Option<Spanned<f32>>,
    angle: Option<Spanned<f32>>,
}

/// Line numbers from byte offsets, and the file name errors are reported against.
struct Source<'a> {
    name: &'a str,
    text: &'a str,
}

impl Source<'_> {
    fn line(&self, offset: usize) -> usize {
        self.text[..offset.min(self.text.len())]
            .bytes()
            .filter(|&b| b == b'\n')
            .count()
            + 1
    }

    /// The key of the `key = value` whose value encloses `offset`, from the text before it on
    /// its line: `fov` in `fov = "wide"`, `axis` in `rotate = { axis = [0, "y", 0] }`.
    fn key_before(&self, offset: usize) -> Option<&str> {
        let text = self.text.get(..offset)?;
        let line = &text[text.rfind('\n').map_or(0, |i| i + 1)..];
        let key = line[..line.rfind('=')?].trim_end();
        let key = key
            .rsplit(|c: char| c.is_whitespace() || c == '{' || c == ',')
            .next()?;
        (!key.is_empty()).then_some(key)
    }

    fn err<T>(&self, span: std::ops::Range<usize>, msg: impl std::fmt::Display) -> Result<T> {
        Err(Error::new(format!(
            "{}:{}: {}",
            self.name,
            self.line(span.start),
            msg
        )))
    }

    fn finite3(&self, v: &V3, key: &str) -> Result<Vec3> {
        let a = *v.get_ref();
        if a.iter().any(|x| !x.is_finite()) {
            return self.err(
                v.span(),
                format!("'{key}' must be three finite numbers, got {a:?}"),
            );
        }
        Ok(Vec3::from(a))
    }

    fn in_unit_range(&self, v: &V3, key: &str) -> Result<Vec3> {
        let c = self.finite3(v, key)?;
        if c.min_element() < 0.0 || c.max_element() > 1.0 {
            return self.err(
                v.span(),
                format!(
                    "'{key}' must lie in [0, 1] per channel, got {:?}",
                    v.get_ref()
                ),
            );
        }
        Ok(c)
    }

    fn non_negative3(&self, v: &V3, key: &str) -> Result<Vec3> {
        let c = self.finite3(v, key)?;
        if c.min_element() < 0.0 {
            return self.err(
                v.span(),
                format!("'{key}' must be >= 0 per channel, got {:?}", v.get_ref()),
            );
        }
        Ok(c)
    }

    fn required<'b, T>(
        &self,
        v: &'b Option<T>,
        span: std::ops::Range<usize>,
        key: &str,
        what: &str,
    ) -> Result<&'b T> {
        match v {
            Some(v) => Ok(v),
            None => self.err(span, format!("{what} needs the key '{key}'")),
        }
    }
}

/// Load a scene file.
pub fn load_file(path: &Path) -> Result<Scene> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::new(format!("{}: cannot read scene file: {e}", path.display())))?;
    let name = path.display().to_string();
    load_str(&text, &name, path.parent())
}

/// Load a scene from TOML text; `name` is used in error messages, `dir` resolves mesh paths.
pub fn load_str(text: &str, name: &str, dir: Option<&Path>) -> Result<Scene> {
    let src = Source { name, text };
    let desc: SceneDesc = toml::from_str(text).map_err(|e| {
        let mut msg = e.message().trim().replace('\n', " ");
        // serde's value errors ("invalid type: ...", "invalid length 2, ...") omit the key.
        if let Some(key) = e
            .span()
            .filter(|_| msg.starts_with("invalid "))
            .and_then(|s| src.key_before(s.start))
        {
            msg = format!("'{key}': {msg}");
        }
        match e.span() {
            Some(s) => Error::new(format!("{name}:{}: {msg}", src.line(s.start))),
            None => Error::new(format!("{name}: {msg}")),
        }
    })?;
    Builder {
        src: &src,
        dir: dir.map(Path::to_path_buf),
    }
    .build(desc)
}

struct Builder<'a> {
    src: &'a Source<'a>,
    dir: Option<PathBuf>,
}

impl Builder<'_> {
    fn build(&self, desc: SceneDesc) -> Result<Scene> {
        let src = self.src;
        let camera = self.camera(&desc.camera)?;
        let render = self.render(desc.render.as_ref())?;

        // Materials, by name.
        let mut materials = Vec::new();
        let mut by_name: HashMap<String, u32> = HashMap::new();
        for m in &desc.material {
            let name = m.get_ref().name.get_ref().clone();
            if by_name.contains_key(&name) {
                return src.err(
                    m.get_ref().name.span(),
                    format!("material '{name}' is defined twice"),
                );
            }
            let bsdf = self.material(m)?;
            by_name.insert(name.clone(), materials.len() as u32);
            materials.push(Material { name, bsdf });
        }
        let mut black = None;

        // Media, by name.
        let mut media: Vec<HomogeneousMedium> = Vec::new();
        for m in &desc.medium {
            let d = m.get_ref();
            let name = d.name.get_ref().clone();
            if media.iter().any(|x| x.name == name) {
                return src.err(d.name.span(), format!("medium '{name}' is defined twice"));
            }
            let sigma_a = src.non_negative3(&d.sigma_a, "sigma_a")?;
            let sigma_s = src.non_negative3(&d.sigma_s, "sigma_s")?;
            let g = match &d.g {
                Some(g) => {
                    let v = *g.get_ref();
                    if !(v > -1.0 && v < 1.0) {
                        return src.err(g.span(), format!("'g' must be in (-1, 1), got {v}"));
                    }
                    v
                }
                None => 0.0,
            };
            media.push(HomogeneousMedium::new(name, sigma_a, sigma_s, g));
        }
        let medium_ref = |r: &Spanned<String>| -> Result<u32> {
            match media.iter().position(|m| &m.name == r.get_ref()) {
                Some(i) => Ok(i as u32),
                None => {
                    let known: Vec<&str> = media.iter().map(|m| m.name.as_str()).collect();
                    let known = if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    };
                    src.err(
                        r.span(),
                        format!("unknown medium '{}' (defined: {known})", r.get_ref()),
                    )
                }
            }
        };
        let world_medium = desc.world_medium.as_ref().map(&medium_ref).transpose()?;

        // Shapes, and area lights for emissive ones.
        let mut shapes = Vec::new();
        let mut shape_info = Vec::new();
        let mut lights = Vec::new();
        let mut triangles = 0usize;
        for (i, s) in desc.shape.iter().enumerate() {
            let d = s.get_ref();
            let label = d
                .name
                .clone()
                .unwrap_or_else(|| format!("shape #{} ({})", i + 1, d.kind.get_ref()));
            // A tiled quad is two shapes (one per material); every other shape is one.
            let parts = match self.tiled_quad(s)? {
                Some([even, odd]) => vec![
                    (even, d.material.as_ref(), label.clone()),
                    (odd, d.tile_material.as_ref(), format!("{label} (tiles)")),
                ],
                None => vec![(self.shape(s)?, d.material.as_ref(), label)],
            };
            for (geometry, _, label) in &parts {
                if let ShapeGeometry::Mesh(m) = geometry {
                    triangles += m.indices.len();
                    if triangles > MAX_TRIANGLES {
                        return src.err(
                            s.span(),
                            format!("{label} brings the scene to {triangles} triangles; at most {MAX_TRIANGLES} (2^24) are supported"),
                        );
                    }
                }
                let outside = match geometry {
                    ShapeGeometry::Mesh(m) => m.positions.iter().copied().find(|&p| !in_bounds(p)),
                    ShapeGeometry::Sphere(sp) => [sp.center - sp.radius, sp.center + sp.radius]
                        .into_iter()
                        .find(|&p| !in_bounds(p)),
                };
                if let Some(p) = outside {
                    return src.err(
                        s.span(),
                        format!("{label} reaches {p} (after its transform); every point of a shape must lie within +-{MAX_COORDINATE:e} per axis"),
                    );
                }
            }
            let emission = match &d.emission {
                Some(e) => Some((self.src.non_negative3(e, "emission")?, e.span())),
                None => None,
            };
            // Media on either side; an unnamed side is the world medium.
            let interface = match (&d.interior, &d.exterior) {
                (None, None) => None,
                (inside, outside) => Some(MediumInterface {
                    inside: inside
                        .as_ref()
                        .map(&medium_ref)
                        .transpose()?
                        .or(world_medium),
                    outside: outside
                        .as_ref()
                        .map(&medium_ref)
                        .transpose()?
                        .or(world_medium),
                }),
            };
            let null = d.material.is_none() && emission.is_none() && interface.is_some();
            if let (None, Some(c)) = (&emission, d.cone_angle.as_ref().or(d.cone_delta.as_ref())) {
                return src.err(c.span(), "'cone_angle' and 'cone_delta' make an emissive shape a spot light; this shape has no 'emission'");
            }
            for (geometry, material, label) in parts {
                let material = match material {
                    Some(m) => match by_name.get(m.get_ref()) {
                        Some(&id) => id,
                        None => {
                            let known: Vec<&str> =
                                materials.iter().map(|m| m.name.as_str()).collect();
                            return src.err(
                                m.span(),
                                format!(
                                    "unknown material '{}' (defined: {})",
                                    m.get_ref(),
                                    if known.is_empty() {
                                        "none".to_string()
                                    } else {
                                        known.join(", ")
                                    }
                                ),
                            );
                        }
                    },
                    None if emission.is_some() || null => *black.get_or_insert_with(|| {
                        materials.push(Material {
                            name: "<black>".into(),
                            bsdf: Bsdf::Black,
                        });
                        materials.len() as u32 - 1
                    }),
                    None => {
                        return src.err(
                        s.span(),
                        format!("{label} needs a 'material' (or an 'emission', or 'interior'/'exterior' media for an index-matched boundary)"),
                    );
                    }
                };
                let shape_id = shapes.len() as u32;
                let light = match emission {
                    Some((le, _)) if le != Vec3::ZERO => {
                        let area = match &geometry {
                            ShapeGeometry::Mesh(m) => AreaShape::Mesh {
                                sampler: MeshSampler::new(m),
                                mesh: m.clone(),
                            },
                            ShapeGeometry::Sphere(sp) => AreaShape::Sphere(*sp),
                        };
                        let light = if d.cone_angle.is_some() || d.cone_delta.is_some() {
                            let profile =
                                self.spot_profile(&d.cone_angle, &d.cone_delta, s.span(), true)?;
                            AreaLight::with_spot(shape_id, le, area, profile)
                        } else {
                            AreaLight::new(shape_id, le, area)
                        };
                        let power = light.power();
                        if !power.is_finite() {
                            return src.err(
                                d.emission.as_ref().map_or(s.span(), |e| e.span()),
                                format!("{label}: the emitted power (emission x area) overflows to {power}; lower 'emission' or the shape's size"),
                            );
                        }
                        lights.push(Light::Area(light));
                        Some(lights.len() as u32 - 1)
                    }
                    _ => None,
                };
                shapes.push(geometry);
                shape_info.push(ShapeInfo {
                    index: shape_id,
                    name: label,
                    material,
                    light,
                    interface,
                    null,
                });
            }
        }

        let mut environment = false;
        let n_shape_lights = lights.len();
        for l in &desc.light {
            let light = self.light(l)?;
            if matches!(light, Light::Environment(_)) {
                if environment {
                    return src.err(l.span(), "only one environment light is allowed");
                }
                environment = true;
            }
            lights.push(light);
        }

        // Bounding sphere of the geometry (the camera if there is none).
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for s in &shapes {
            match s {
                ShapeGeometry::Mesh(m) => {
                    for p in &m.positions {
                        lo = lo.min(*p);
                        hi = hi.max(*p);
                    }
                }
                ShapeGeometry::Sphere(sp) => {
                    lo = lo.min(sp.center - sp.radius);
                    hi = hi.max(sp.center + sp.radius);
                }
            }
        }
        let (center, radius) = if lo.x <= hi.x {
            (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-6))
        } else {
            (camera.position, 1.0)
        };
        for l in &mut lights {
            l.set_scene_bounds(center, radius);
        }
        // Lights are chosen in proportion to their power; that of lights at infinity grows
        // with the scene's bounding sphere, so check it now.
        for (l, d) in lights[n_shape_lights..].iter().zip(&desc.light) {
            let power = l.power();
            if !power.is_finite() {
                return src.err(
                    d.span(),
                    format!("the light's power overflows to {power}; lower its 'intensity', 'radiance' or 'irradiance' (or the scene's size, for lights at infinity)"),
                );
            }
        }

        let uses_media = world_medium.is_some()
            || shape_info.iter().any(|s| {
                s.interface
                    .is_some_and(|i| i.inside.is_some() || i.outside.is_some())
            });
        let infinite_lights: Vec<usize> = (0..lights.len())
            .filter(|&i| lights[i].is_infinite())
            .collect();
        let features = SceneFeatures {
            media: uses_media,
            delta_lights: lights.iter().any(|l| l.is_delta()),
            specular_surfaces: shape_info
                .iter()
                .any(|s| materials[s.material as usize].bsdf.is_delta()),
            environment: !infinite_lights.is_empty(),
            emissive_geometry: lights.iter().any(|l| matches!(l, Light::Area(_))),
        };
        let accel = Accel::build(&shapes);
        let light_count = lights.len();
        let mut scene = Scene {
            source: src.name.to_string(),
            light_sampler: LightSampler::new(&lights),
            camera,
            shapes,
            shape_info,
            materials,
            lights,
            infinite_lights,
            media,
            world_medium,
            camera_medium: world_medium,
            light_media: vec![world_medium; light_count],
            accel,
            features,
            center,
            radius,
            render,
        };
        scene.locate_media();
        Ok(scene)
    }

    /// Reject keys that are present but not `allowed` for this type, at the line of the first.
    fn only(
        &self,
        what: &str,
        keys: &[(&str, Option<std::ops::Range<usize>>)],
        allowed: &[&str],
    ) -> Result<()> {
        for (key, span) in keys {
            if let (Some(span), false) = (span, allowed.contains(key)) {
                return self.src.err(
                    span.clone(),
                    format!("{what} does not take the key '{key}'"),
                );
            }
        }
        Ok(())
    }

    fn light(&self, l: &Spanned<LightDesc>) -> Result<Light> {
        let src = self.src;
        let d = l.get_ref();
        let span = l.span();
        let kind = d.kind.get_ref().as_str();
        let what = format!("light of type '{kind}'");
        let keys = [
            ("position", at(&d.position)),
            ("intensity", at(&d.intensity)),
            ("radiance", at(&d.radiance)),
            ("irradiance", at(&d.irradiance)),
            ("direction", at(&d.direction)),
            ("cone_angle", at(&d.cone_angle)),
            ("cone_delta", at(&d.cone_delta)),
            ("angle", at(&d.angle)),
        ];
        let allowed: &[&str] = match kind {
            "point" => &["position", "intensity"],
            "spot" => &[
                "position",
                "intensity",
                "direction",
                "cone_angle",
                "cone_delta",
            ],
            "environment" => &["radiance"],
            "directional" => &["direction", "irradiance"],
            "sun" => &["direction", "angle", "radiance", "irradiance"],
            other => {
                return src.err(d.kind.span(), format!("unknown light type '{other}' (expected point, spot, environment, directional or sun)"));
            }
        };
        self.only(&what, &keys, allowed)?;
        let position = || -> Result<Vec3> {
            let v = src.required(&d.position, span.clone(), "position", &what)?;
            let p = src.finite3(v, "position")?;
            if !in_bounds(p) {
                return src.err(
                    v.span(),
                    format!("'position' must lie within +-{MAX_COORDINATE:e} per axis, got {p}"),
                );
            }
            Ok(p)
        };
        let direction = || -> Result<Vec3> {
            let v = src.required(&d.direction, span.clone(), "direction", &what)?;
            let dir = src.finite3(v, "direction")?;
            match unit_vector(dir) {
                Some(d) => Ok(d),
                None => src.err(v.span(), "'direction' must be non-zero"),
            }
        };
        Ok(match kind {
            "point" => Light::Point(PointLight {
                position: position()?,
                intensity: src.non_negative3(
                    src.required(&d.intensity, span.clone(), "intensity", &what)?,
                    "intensity",
                )?,
            }),
            "spot" => {
                let intensity = src.non_negative3(
                    src.required(&d.intensity, span.clone(), "intensity", &what)?,
                    "intensity",
                )?;
                let profile =
                    self.spot_profile(&d.cone_angle, &d.cone_delta, span.clone(), false)?;
                Light::Spot(SpotLight::new(
                    position()?,
                    direction()?,
                    intensity,
                    profile,
                ))
            }
            "environment" => Light::Environment(EnvironmentLight {
                radiance: src.non_negative3(
                    src.required(&d.radiance, span.clone(), "radiance", &what)?,
                    "radiance",
                )?,
                center: Vec3::ZERO,
                radius: 1.0,
            }),
            "directional" => Light::Directional(DirectionalLight::new(
                direction()?,
                src.non_negative3(
                    src.required(&d.irradiance, span.clone(), "irradiance", &what)?,
                    "irradiance",
                )?,
            )),
            "sun" => {
                let angle = match &d.angle {
                    Some(a) => {
                        SunLight::check_angle(*a.get_ref())
                            .or_else(|e| src.err(a.span(), format!("'angle': {e}")))?;
                        *a.get_ref()
                    }
                    None => SunLight::DEFAULT_ANGLE,
                };
                match (&d.radiance, &d.irradiance) {
                    (Some(r), None) => Light::Sun(SunLight::new(
                        direction()?,
                        angle,
                        src.non_negative3(r, "radiance")?,
                    )),
                    (None, Some(e)) => Light::Sun(SunLight::from_irradiance(
                        direction()?,
                        angle,
                        src.non_negative3(e, "irradiance")?,
                    )),
                    _ => {
                        return src.err(
                            span,
                            "a sun light needs exactly one of 'radiance' and 'irradiance'",
                        );
                    }
                }
            }
            _ => unreachable!("light types are checked above"),
        })
    }

    /// A spot profile from optional `cone_angle` / `cone_delta` keys (degrees).
    fn spot_profile(
        &self,
        angle: &Option<Spanned<f32>>,
        delta: &Option<Spanned<f32>>,
        span: std::ops::Range<usize>,
        area: bool,
    ) -> Result<SpotProfile> {
        let a = angle
            .as_ref()
            .map_or(SpotProfile::DEFAULT_CONE_ANGLE, |a| *a.get_ref());
        let d = delta
            .as_ref()
            .map_or(SpotProfile::DEFAULT_CONE_DELTA.min(a), |d| *d.get_ref());
        let check = if area {
            SpotProfile::check_area(a, d)
        } else {
            SpotProfile::check(a, d)
        };
        if let Err(e) = check {
            let at = angle.as_ref().or(delta.as_ref()).map_or(span, |s| s.span());
            return self.src.err(at, format!("spot cone: {e}"));
        }
        Ok(SpotProfile::new(a, d))
    }

    fn camera(&self, c: &Spanned<CameraDesc>) -> Result<Camera> {
        let src = self.src;
        let d = c.get_ref();
        let position = src.finite3(&d.position, "position")?;
        let look_at = src.finite3(&d.look_at, "look_at")?;
        for (p, v, key) in [
            (position, &d.position, "position"),
            (look_at, &d.look_at, "look_at"),
        ] {
            if !in_bounds(p) {
                return src.err(
                    v.span(),
                    format!(
                        "camera '{key}' must lie within +-{MAX_COORDINATE:e} per axis, got {p}"
                    ),
                );
            }
        }
        let up = match &d.up {
            Some(u) => src.finite3(u, "up")?,
            None => Vec3::Y,
        };
        // Unit length whatever its magnitude (zero stays zero and is rejected below).
        let up = unit_vector(up).unwrap_or(Vec3::ZERO);
        let fov = *d.fov.get_ref();
        if !(fov > 0.0 && fov < 180.0) {
            return src.err(
                d.fov.span(),
                format!("'fov' must be in (0, 180) degrees, got {fov}"),
            );
        }
        let [w, h] = *d.resolution.get_ref();
        if w == 0 || h == 0 || w > 16384 || h > 16384 {
            return src.err(
                d.resolution.span(),
                format!("'resolution' must be two integers in [1, 16384] (at most 2^28 pixels), got [{w}, {h}]"),
            );
        }
        let forward = look_at - position;
        // `Camera::new` normalises `look_at - position`: its length must not underflow.
        let Some(forward) = forward.try_normalize() else {
            return src.err(
                d.look_at.span(),
                format!(
                    "'look_at' must differ from 'position' (by more than 1e-18), got {look_at} and {position}"
                ),
            );
        };
        if forward.cross(up).length_squared() < 1e-10 {
            return src.err(
                d.up.as_ref().map_or(c.span(), |u| u.span()),
                "'up' must not be zero or parallel to the viewing direction",
            );
        }
        Ok(Camera::new(position, look_at, up, fov, UVec2::new(w, h)))
    }

    fn render(&self, r: Option<&RenderDesc>) -> Result<RenderDefaults> {
        let mut out = RenderDefaults::default();
        let Some(r) = r else { return Ok(out) };
        if let Some(d) = &r.max_depth {
            match crate::path::parse_max_depth(*d.get_ref()) {
                Ok(v) => out.max_depth = v,
                Err(e) => return self.src.err(d.span(), format!("'max_depth' {e}")),
            }
        }
        if let Some(s) = &r.spp {
            if *s.get_ref() == 0 {
                return self.src.err(s.span(), "'spp' must be at least 1");
            }
            out.spp = *s.get_ref();
        }
        if let Some(i) = &r.integrator {
            let registry = crate::integrators::REGISTRY;
            if !registry.iter().any(|e| e.name == i.get_ref()) {
                let names: Vec<&str> = registry.iter().map(|e| e.name).collect();
                return self.src.err(
                    i.span(),
                    format!(
                        "unknown integrator '{}' (available: {})",
                        i.get_ref(),
                        names.join(", ")
                    ),
                );
            }
            out.integrator = i.get_ref().clone();
        }
        Ok(out)
    }

    fn material(&self, m: &Spanned<MaterialDesc>) -> Result<Bsdf> {
        let src = self.src;
        let d = m.get_ref();
        let kind = d.kind.get_ref().as_str();
        let what = format!("material '{}' of type '{kind}'", d.name.get_ref());
        let span = m.span();
        let keys = [
            ("albedo", at(&d.albedo)),
            ("reflectance", at(&d.reflectance)),
            ("ior", at(&d.ior)),
            ("alpha", at(&d.alpha)),
            ("eta", at(&d.eta)),
            ("k", at(&d.k)),
        ];
        let allowed: &[&str] = match kind {
            "diffuse" => &["albedo"],
            "conductor" => &["reflectance"],
            "dielectric" => &["ior"],
            "roughconductor" => &["alpha", "reflectance", "eta", "k"],
            "roughdielectric" => &["alpha", "ior"],
            "black" => &[],
            other => {
                return src.err(d.kind.span(), format!("unknown material type '{other}' (expected diffuse, conductor, dielectric, roughconductor, roughdielectric or black)"));
            }
        };
        self.only(&what, &keys, allowed)?;
        let ior = || -> Result<f32> {
            let ior = src.required(&d.ior, span.clone(), "ior", &what)?;
            let eta = *ior.get_ref();
            if !(eta.is_finite() && eta > 0.0) {
                return src.err(
                    ior.span(),
                    format!("'ior' must be a finite number > 0, got {eta}"),
                );
            }
            Ok(eta)
        };
        let alpha = || -> Result<f32> {
            let a = src.required(&d.alpha, span.clone(), "alpha", &what)?;
            let v = *a.get_ref();
            if !(v > 0.0 && v <= 1.0) {
                return src.err(
                    a.span(),
                    format!("'alpha' (GGX roughness) must be in (0, 1], got {v}"),
                );
            }
            Ok(v)
        };
        Ok(match kind {
            "diffuse" => Bsdf::Diffuse {
                albedo: src
                    .in_unit_range(src.required(&d.albedo, span, "albedo", &what)?, "albedo")?,
            },
            "conductor" => Bsdf::Conductor {
                reflectance: src.in_unit_range(
                    src.required(&d.reflectance, span, "reflectance", &what)?,
                    "reflectance",
                )?,
            },
            "dielectric" => Bsdf::Dielectric { eta: ior()? },
            "roughconductor" => {
                let fresnel = match (&d.reflectance, &d.eta, &d.k) {
                    (Some(r), None, None) => ConductorFresnel::Constant(src.in_unit_range(r, "reflectance")?),
                    (None, Some(eta), Some(k)) => {
                        let e = src.finite3(eta, "eta")?;
                        if e.min_element() <= 0.0 {
                            return src.err(eta.span(), "'eta' must be > 0 per channel");
                        }
                        ConductorFresnel::Complex { eta: e, k: src.non_negative3(k, "k")? }
                    }
                    _ => return src.err(span, format!("{what} needs either 'reflectance' (constant) or both 'eta' and 'k' (complex ior)")),
                };
                Bsdf::rough_conductor(alpha()?, fresnel)
            }
            "roughdielectric" => {
                let eta = ior()?;
                if eta == 1.0 {
                    let at = d.ior.as_ref().map_or(span, |i| i.span());
                    return src.err(at, "'ior' = 1 is no interface at all; use a shape with media and no material (an index-matched boundary) instead");
                }
                Bsdf::rough_dielectric(eta, alpha()?)
            }
            "black" => Bsdf::Black,
            _ => unreachable!("material types are checked above"),
        })
    }

    fn transform(&self, t: Option<&Spanned<TransformDesc>>) -> Result<Transform> {
        let src = self.src;
        let Some(t) = t else {
            return Ok(Transform::IDENTITY);
        };
        let d = t.get_ref();
        let scale = match &d.scale {
            None => Vec3::ONE,
            Some(s) => {
                let v = match s.get_ref() {
                    ScaleDesc::Uniform(x) => Vec3::splat(*x),
                    ScaleDesc::PerAxis(a) => Vec3::from(*a),
                };
                let (lo, hi) = SCALE_RANGE;
                if !v.is_finite() || v.abs().min_element() < lo || v.abs().max_element() > hi {
                    return src.err(
                        s.span(),
                        format!("'scale' must be finite with every |component| in [{lo:e}, {hi:e}], got {v}"),
                    );
                }
                v
            }
        };
        let (axis, degrees) = match &d.rotate {
            None => (Vec3::Y, 0.0),
            Some(r) => {
                let a = Vec3::from(r.get_ref().axis);
                let deg = r.get_ref().degrees;
                let (Some(a), true) = (unit_vector(a), deg.is_finite()) else {
                    return src.err(
                        r.span(),
                        "'rotate' needs a finite non-zero 'axis' and finite 'degrees'",
                    );
                };
                (a, deg)
            }
        };
        let translate = match &d.translate {
            Some(v) => src.finite3(v, "translate")?,
            None => Vec3::ZERO,
        };
        Ok(Transform::new(scale, axis, degrees, translate))
    }

    /// The two checkerboard halves of a quad with `tiles` and `tile_material`, or `None` for
    /// any other shape (whose keys [`Self::shape`] checks).
    fn tiled_quad(&self, s: &Spanned<ShapeDesc>) -> Result<Option<[ShapeGeometry; 2]>> {
        let src = self.src;
        let d = s.get_ref();
        if d.kind.get_ref() != "quad" || (d.tiles.is_none() && d.tile_material.is_none()) {
            return Ok(None);
        }
        let (Some(tiles), Some(_)) = (&d.tiles, &d.tile_material) else {
            let (present, missing) = if d.tiles.is_some() {
                ("tiles", "tile_material")
            } else {
                ("tile_material", "tiles")
            };
            let at = at(&d.tiles).or(at(&d.tile_material)).unwrap_or(s.span());
            return src.err(
                at,
                format!("a tiled quad's '{present}' needs '{missing}' too (a checkerboard of 'material' and 'tile_material')"),
            );
        };
        let [nu, nv] = *tiles.get_ref();
        if !(1..=1024).contains(&nu) || !(1..=1024).contains(&nv) {
            return src.err(
                tiles.span(),
                format!("'tiles' must be two integers in [1, 1024], got [{nu}, {nv}]"),
            );
        }
        if let Some(e) = &d.emission {
            return src.err(
                e.span(),
                "a tiled quad cannot emit ('emission' with 'tiles')",
            );
        }
        if d.material.is_none() {
            return src.err(
                s.span(),
                "a tiled quad needs a 'material' (for the cell at 'origin') beside 'tile_material'",
            );
        }
        // The quad itself (its keys, edges and transform) is checked by `shape`.
        let ShapeGeometry::Mesh(quad) = self.shape(s)? else {
            unreachable!("a quad is a mesh")
        };
        let [o, a, _, b] = [0, 1, 2, 3].map(|i| quad.positions[i]);
        let (mut u, mut v, mut tiles) = (a - o, b - o, [nu, nv]);
        // A mirroring transform turns the front side over: keep it by swapping the edges.
        if u.cross(v).dot(quad.geometric_normal(0)) < 0.0 {
            (u, v, tiles) = (v, u, [nv, nu]);
        }
        let half = |parity| ShapeGeometry::Mesh(TriangleMesh::tiled_quad(o, u, v, tiles, parity));
        Ok(Some([half(0), half(1)]))
    }

    fn shape(&self, s: &Spanned<ShapeDesc>) -> Result<ShapeGeometry> {
        let src = self.src;
        let d = s.get_ref();
        let span = s.span();
        let kind = d.kind.get_ref().as_str();
        let what = format!("shape of type '{kind}'");
        let t = self.transform(d.transform.as_ref())?;
        let keys = [
            ("origin", at(&d.origin)),
            ("edge_u", at(&d.edge_u)),
            ("edge_v", at(&d.edge_v)),
            ("center", at(&d.center)),
            ("normal", at(&d.normal)),
            ("radius", at(&d.radius)),
            ("segments", at(&d.segments)),
            ("file", at(&d.file)),
            ("size", at(&d.size)),
            ("grid", at(&d.grid)),
            ("waves", at(&d.waves)),
            ("tiles", at(&d.tiles)),
            ("tile_material", at(&d.tile_material)),
        ];
        let allowed: &[&str] =
            match kind {
                "quad" => &["origin", "edge_u", "edge_v", "tiles", "tile_material"],
                "cube" => &[],
                "sphere" => &["center", "radius"],
                "disk" => &["center", "normal", "radius", "segments"],
                "obj" => &["file"],
                "heightfield" => &["size", "grid", "waves"],
                other => return src.err(
                    d.kind.span(),
                    format!(
                        "unknown shape type '{other}' (expected quad, cube, sphere, disk, heightfield or obj)"
                    ),
                ),
            };
        self.only(&what, &keys, allowed)?;
        let radius = |default: f32| -> Result<f32> {
            match &d.radius {
                None => Ok(default),
                Some(r) => {
                    let v = *r.get_ref();
                    if !(v.is_finite() && v > 0.0) {
                        return src.err(
                            r.span(),
                            format!("'radius' must be a finite number > 0, got {v}"),
                        );
                    }
                    Ok(v)
                }
            }
        };
        let opt3 = |v: &Option<V3>, key: &str, default: Vec3| -> Result<Vec3> {
            match v {
                Some(v) => src.finite3(v, key),
                None => Ok(default),
            }
        };
        Ok(match kind {
            "quad" => {
                let o = opt3(&d.origin, "origin", Vec3::new(-1.0, -1.0, 0.0))?;
                let u = opt3(&d.edge_u, "edge_u", Vec3::new(2.0, 0.0, 0.0))?;
                let v = opt3(&d.edge_v, "edge_v", Vec3::new(0.0, 2.0, 0.0))?;
                if u.cross(v).length_squared() == 0.0 {
                    return src.err(
                        span,
                        "'edge_u' and 'edge_v' of a quad must be non-zero and not parallel",
                    );
                }
                ShapeGeometry::Mesh(TriangleMesh::quad(o, u, v).transformed(&t))
            }
            "cube" => ShapeGeometry::Mesh(TriangleMesh::cube().transformed(&t)),
            "sphere" => {
                let c = opt3(&d.center, "center", Vec3::ZERO)?;
                let r = radius(1.0)?;
                let Some(scale) = t.uniform_scale() else {
                    return src.err(
                        d.transform.as_ref().map_or(span, |t| t.span()),
                        "an analytic sphere's transform must scale uniformly",
                    );
                };
                ShapeGeometry::Sphere(Sphere {
                    center: t.point(c),
                    radius: r * scale,
                })
            }
            "disk" => {
                let c = opt3(&d.center, "center", Vec3::ZERO)?;
                let n = opt3(&d.normal, "normal", Vec3::Z)?;
                let Some(n) = unit_vector(n) else {
                    return src.err(
                        d.normal.as_ref().unwrap().span(),
                        "'normal' must be non-zero",
                    );
                };
                let r = radius(1.0)?;
                let segments = d.segments.as_ref().map_or(64, |s| *s.get_ref());
                if !(3..=100_000).contains(&segments) {
                    return src.err(
                        d.segments.as_ref().unwrap().span(),
                        "'segments' must be in [3, 100000]",
                    );
                }
                let f = Frame::from_z(n);
                let mut m = TriangleMesh::disk(segments);
                for p in &mut m.positions {
                    *p = c + f.to_world(*p * r);
                }
                ShapeGeometry::Mesh(m.transformed(&t))
            }
            "obj" => {
                let file = src.required(&d.file, span, "file", &what)?;
                let path = match &self.dir {
                    Some(dir) => dir.join(file.get_ref()),
                    None => PathBuf::from(file.get_ref()),
                };
                let mesh = load_obj(&path).or_else(|e| {
                    src.err(
                        file.span(),
                        format!("cannot load mesh '{}': {e}", path.display()),
                    )
                })?;
                ShapeGeometry::Mesh(mesh.transformed(&t))
            }
            "heightfield" => {
                let size = match &d.size {
                    Some(sz) => {
                        let [x, z] = *sz.get_ref();
                        if !(x.is_finite() && z.is_finite() && x > 0.0 && z > 0.0) {
                            return src.err(
                                sz.span(),
                                format!("'size' must be two finite numbers > 0, got [{x}, {z}]"),
                            );
                        }
                        Vec2::new(x, z)
                    }
                    None => Vec2::splat(2.0),
                };
                let grid = match &d.grid {
                    Some(g) => {
                        let [x, z] = *g.get_ref();
                        if !(1..=4096).contains(&x) || !(1..=4096).contains(&z) {
                            return src.err(
                                g.span(),
                                format!("'grid' must be two integers in [1, 4096], got [{x}, {z}]"),
                            );
                        }
                        if 2 * x as usize * z as usize > MAX_TRIANGLES {
                            return src.err(
                                g.span(),
                                format!("'grid' = [{x}, {z}] makes {} triangles; a scene may have at most {MAX_TRIANGLES} (2^24)", 2 * x as usize * z as usize),
                            );
                        }
                        UVec2::new(x, z)
                    }
                    None => UVec2::new(128, 128),
                };
                let mut waves = Vec::new();
                if let Some(ws) = &d.waves {
                    for (k, w) in ws.get_ref().iter().enumerate() {
                        let dir = Vec2::from(w.direction);
                        let ok = w.amplitude.is_finite()
                            && w.phase.is_finite()
                            && w.wavelength.is_finite()
                            && w.wavelength > 0.0
                            && dir.is_finite()
                            && dir.length_squared() > 0.0;
                        if !ok {
                            return src.err(ws.span(), format!("wave #{}: needs finite 'amplitude' and 'phase', 'wavelength' > 0 and a non-zero 'direction'", k + 1));
                        }
                        waves.push(Wave {
                            amplitude: w.amplitude,
                            wavelength: w.wavelength,
                            direction: dir.normalize(),
                            phase: w.phase,
                        });
                    }
                }
                ShapeGeometry::Mesh(heightfield(size, grid, &waves).transformed(&t))
            }
            _ => unreachable!("shape types are checked above"),
        })
    }
}

/// Where an optional key is, if it is present.
fn at<T>(v: &Option<Spanned<T>>) -> Option<std::ops::Range<usize>> {
    v.as_ref().map(Spanned::span)
}

/// Load every model of an OBJ file into one mesh, with vertex normals when all models have them.
fn load_obj(path: &Path) -> std::result::Result<TriangleMesh, String> {
    if !path.is_file() {
        return Err("no such file".to_string());
    }
    let (models, _materials) =
        tobj::load_obj(path, &tobj::GPU_LOAD_OPTIONS).map_err(|e| e.to_string())?;
    let mut mesh = TriangleMesh {
        normals: Some(Vec::new()),
        ..Default::default()
    };
    for m in &models {
        let m = &m.mesh;
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2])),
        );
        if m.normals.len() == m.positions.len() {
            if let Some(ns) = &mut mesh.normals {
                ns.extend(
                    m.normals
                        .chunks_exact(3)
                        .map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero()),
                );
            }
        } else {
            mesh.normals = None;
        }
        mesh.indices.extend(
            m.indices
                .chunks_exact(3)
                .map(|c| [c[0] + base, c[1] + base, c[2] + base]),
        );
    }
    if mesh.indices.is_empty() {
        return Err("the file has no triangles".to_string());
    }
    if mesh.positions.iter().any(|p| !p.is_finite()) {
        return Err("the file has non-finite vertex positions".to_string());
    }
    if mesh
        .indices
        .iter()
        .flatten()
        .any(|&i| i as usize >= mesh.positions.len())
    {
        return Err("a face refers to a vertex that does not exist".to_string());
    }
    if let Some(ns) = &mesh.normals
        && ns.iter().any(|n| *n == Vec3::ZERO || !n.is_finite())
    {
        mesh.normals = None;
    }
    Ok(mesh)
}
