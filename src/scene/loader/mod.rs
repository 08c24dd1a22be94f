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
//! filter = { type = "box" } # pixel filter (`filter.rs`): box (default), tent (radius 1 px),
//!                          # gaussian (stddev 0.5 px, radius 4 stddev)
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
//! one_sided = false        # diffuse and conductors: black seen from the back (Mitsuba's
//!                          # BSDFs without twosided); two-sided by default
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
//!                          # disk (center, normal, radius, segments), obj and ply (file,
//!                          # normals = "file" | "faces" | "smooth": see `ShapeDesc::normals`),
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
//!                          # or transform = { matrix = [[1, 0, 0, 0], ...] } (4 rows, affine)
//! flip_normals = false     # meshes: turn the front side over
//! group = "chairs"         # optional: drawn only where an instance of the group places it
//!                          # (`groups.rs`); type = "instance" with group and transform places
//!                          # every member, the instance's transform after the member's own
//!
//! [[light]]
//! type = "point"           # point (position, intensity), spot (position, direction,
//! position = [0, 0.9, 0]   # intensity, cone_angle = 30, cone_delta = 5, cone_edge =
//!                          # "smoothstep" or "linear" (in the angle: Mitsuba's)), environment
//! intensity = [1, 1, 1]    # (radiance), directional (direction of travel, irradiance),
//!                          # sun (direction towards the sun, angle = 0.27 degrees,
//!                          # radiance or irradiance)
//! ```
//! Transforms apply scale, then rotation, then translation. Paths are relative to the scene file.
//!
//! A tiled quad (`tiles = [nu, nv]`, `tile_material = "blue"`) is a checkerboard: the quad cut
//! into `nu` cells along `edge_u` by `nv` along `edge_v`; the cell at `origin` and every cell an
//! even number of steps from it take `material`, the others `tile_material`. It stays one
//! quad (two triangles) whose material follows the checkerboard ([`crate::scene::Checker`]);
//! it cannot emit.
//!
//! Files: this one holds the format (the description structs serde reads, the limits, error
//! positions) and the entry points; `build.rs` assembles a scene from a description,
//! `camera.rs`, `materials.rs`, `lights.rs` and `shapes.rs` turn one kind of table each into
//! scene parts, `mesh_files.rs` reads OBJ and PLY. The second front end, `mitsuba/`, reads
//! Mitsuba 3 XML (files ending in `.xml`) into the same description, so both formats share
//! one builder and its checks.

use super::{Material, RenderDefaults, Scene, SceneFeatures, ShapeInfo};
use crate::bsdf::{Bsdf, ConductorFresnel, Distribution};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::geometry::bvh::ShapeGeometry;
use crate::geometry::heightfield::{Wave, heightfield};
use crate::geometry::mesh::MeshSampler;
use crate::geometry::{Accel, Sphere, Transform, TriangleMesh};
use crate::light::{
    AreaLight, AreaShape, DirectionalLight, EnvMapLight, EnvironmentLight, Light, LightSampler,
    PointLight, Projection, SpotEdge, SpotLight, SpotProfile, SunLight,
};
use crate::math::Frame;
use crate::medium::{HomogeneousMedium, MediumInterface};
use crate::texture::{Texture, Wrap};
use glam::{UVec2, Vec2, Vec3};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

mod blend;
mod build;
mod camera;
mod groups;
mod lights;
mod materials;
use materials::{MaterialDesc, TextureDesc};
mod mesh_files;
mod mitsuba;
mod serialized;
mod shapes;

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
    #[serde(default)]
    filter: Option<Spanned<FilterDesc>>,
}

/// `[camera] filter = { type = "tent", radius = 1 }` (`filter.rs`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilterDesc {
    #[serde(rename = "type")]
    kind: Spanned<String>,
    #[serde(default)]
    radius: Option<Spanned<f32>>,
    #[serde(default)]
    stddev: Option<Spanned<f32>>,
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
    /// The emitted radiance multiplied over the surface by a texture (`emission` then
    /// defaults to [1, 1, 1]; `light::AreaLight::texture`).
    emission_texture: Option<Spanned<materials::TextureDesc>>,
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
    /// Mesh files: `file` (the file's vertex normals, face normals where it has none),
    /// `faces` (face normals only) or `smooth` (the file's vertex normals, or angle-weighted
    /// averages of the face normals where it has none: Mitsuba's rule).
    normals: Option<Spanned<String>>,
    /// `serialized`: which mesh of the file (default 0).
    shape_index: Option<Spanned<i64>>,
    /// Meshes: turn the front side over (winding and normals).
    flip_normals: Option<Spanned<bool>>,
    /// On any shape: it belongs to this group and is drawn only where an `instance` of the
    /// group places it. On an `instance`: the group it draws (under its `transform`).
    group: Option<Spanned<String>>,
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
    /// An affine 4x4 matrix, row by row (the last row 0, 0, 0, 1); excludes the other keys.
    matrix: Option<Spanned<[[f32; 4]; 4]>>,
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
    /// Spot lights: `smoothstep` (pbrt's edge, the default) or `linear` (in the angle,
    /// Mitsuba's).
    cone_edge: Option<Spanned<String>>,
    angle: Option<Spanned<f32>>,
    /// `envmap`: the latitude-longitude image (OpenEXR), relative to the scene's directory.
    filename: Option<Spanned<String>>,
    /// `envmap`: radiance scale (default 1).
    scale: Option<Spanned<f32>>,
    /// `envmap`: the map's orientation (a rotation; Mitsuba's `to_world`).
    transform: Option<Spanned<TransformDesc>>,
    /// `spot`: a texture projected along the cone (`light::Projection`).
    texture: Option<Spanned<materials::TextureDesc>>,
    /// `spot` with `texture`: the direction the image's v axis leans towards (default +y).
    up: Option<V3>,
}

/// Line numbers from byte offsets, and the file name errors are reported against.
struct Source<'a> {
    name: &'a str,
    text: &'a str,
    /// Where each piece of `text` comes from, when it is a Mitsuba scene with its includes
    /// expanded (`mitsuba/include.rs`).
    origins: Option<&'a mitsuba::Origins>,
}

impl Source<'_> {
    /// The 1-based line of byte `offset` in the file it comes from.
    fn line(&self, offset: usize) -> usize {
        if let Some(o) = self.origins.filter(|o| o.any()) {
            return o.locate(offset).1;
        }
        self.text[..offset.min(self.text.len())]
            .bytes()
            .filter(|&b| b == b'\n')
            .count()
            + 1
    }

    /// The name of the file byte `offset` comes from.
    fn file(&self, offset: usize) -> &str {
        match self.origins.filter(|o| o.any()) {
            Some(o) => o.locate(offset).0,
            None => self.name,
        }
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
            self.file(span.start),
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

/// Load a scene file: Mitsuba 3 XML when its name ends in `.xml`, lodestar TOML otherwise.
pub fn load_file(path: &Path) -> Result<Scene> {
    load_file_with(path, &[])
}

/// [`load_file`] with `name = value` definitions for a Mitsuba scene's `$name` parameters
/// (they override its `<default>`s; a TOML scene takes none).
pub fn load_file_with(path: &Path, defines: &[(String, String)]) -> Result<Scene> {
    let name = path.display().to_string();
    if path.is_dir() {
        return Err(Error::new(format!(
            "{name}: cannot read scene file: it is a directory (expected a TOML or Mitsuba XML \
             file)"
        )));
    }
    let bytes = std::fs::read(path)
        .map_err(|e| Error::new(format!("{name}: cannot read scene file: {e}")))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = good.iter().filter(|&&b| b == b'\n').count() + 1;
        let column = good.iter().rev().take_while(|&&b| b != b'\n').count() + 1;
        Error::new(format!(
            "{name}:{line}: the scene file is not UTF-8 text (byte 0x{:02x} at column {column})",
            e.as_bytes()[good.len()]
        ))
    })?;
    if is_mitsuba(path) {
        return load_mitsuba_str(&text, &name, path.parent(), defines);
    }
    if let Some((k, _)) = defines.first() {
        return Err(Error::new(format!(
            "{name}: -D {k}=... defines a Mitsuba XML parameter, but this is a TOML scene"
        )));
    }
    load_str(&text, &name, path.parent())
}

/// Whether `path` names a Mitsuba XML scene (by its extension).
pub fn is_mitsuba(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// Load a Mitsuba 3 XML scene from text (see the `mitsuba` module for the subset read).
pub fn load_mitsuba_str(
    text: &str,
    name: &str,
    dir: Option<&Path>,
    defines: &[(String, String)],
) -> Result<Scene> {
    let (text, origins) = mitsuba::expand_includes(text, name, dir)?;
    let src = Source {
        name,
        text: &text,
        origins: Some(&origins),
    };
    let (desc, sensor_medium) = mitsuba::parse(&src, defines, dir)?;
    let scene = Builder {
        src: &src,
        dir: dir.map(Path::to_path_buf),
    }
    .build(desc)?;
    if let Some((medium, at)) = sensor_medium {
        let found = scene
            .camera_medium
            .map(|m| scene.media[m as usize].name.as_str());
        if found != Some(medium.as_str()) {
            return src.err(
                at,
                format!(
                    "the sensor is said to be in medium '{medium}', but the shapes' interior and exterior media put the camera in {}",
                    found.map_or("no medium".to_string(), |m| format!("'{m}'"))
                ),
            );
        }
    }
    Ok(scene)
}

/// Load a scene from TOML text; `name` is used in error messages, `dir` resolves mesh paths.
pub fn load_str(text: &str, name: &str, dir: Option<&Path>) -> Result<Scene> {
    let src = Source {
        name,
        text,
        origins: None,
    };
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

/// Where an optional key is, if it is present.
impl ShapeDesc {
    /// The keys that describe a shape's geometry, each with where it is given (if it is):
    /// what `Builder::only` checks against the keys a shape type takes.
    fn geometry_keys(&self) -> [(&'static str, Option<std::ops::Range<usize>>); 16] {
        let d = self;
        [
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
            ("normals", at(&d.normals)),
            ("flip_normals", at(&d.flip_normals)),
            ("shape_index", at(&d.shape_index)),
        ]
    }
}

fn at<T>(v: &Option<Spanned<T>>) -> Option<std::ops::Range<usize>> {
    v.as_ref().map(Spanned::span)
}
