//! The scene: camera, shapes, materials, lights and the accelerator, immutable after loading and
//! shared by reference across threads. `loader` reads the TOML scene format (DESIGN.md §6).

mod coverage;
mod features;
pub mod loader;
mod normal_map;

pub use features::SceneFeatures;
pub use normal_map::{NormalMap, bumped_normal, perturbed_normal};

use crate::bsdf::{Bsdf, ShadingFrame};
use crate::camera::Camera;
use crate::geometry::bvh::{ShapeGeometry, shadow_segment};
use crate::geometry::{Accel, Hit, Ray, SHADOW_EPS, offset_origin};
use crate::light::{EmissionSample, Light, LightSampler};
use crate::math::Spectrum;
use crate::medium::{HomogeneousMedium, MediumInterface};
use glam::Vec3;

/// The built-in default scene (the same text as `scenes/cornell-box.toml`).
pub const CORNELL_BOX_TOML: &str = include_str!("../../scenes/cornell-box.toml");

/// A named material: the BSDF of the surfaces that use it.
#[derive(Debug, Clone)]
pub struct Material {
    /// The name the scene file gives it.
    pub name: String,
    /// The scattering function.
    pub bsdf: Bsdf,
    /// Black when seen from the back of the shape (against its geometric normal), like
    /// Mitsuba's BSDFs without `twosided`; reflecting BSDFs are two-sided otherwise.
    pub one_sided: bool,
    /// A texture that turns the shading normal (Mitsuba's `normalmap` and `bumpmap`,
    /// `normal_map.rs`).
    pub normal_map: Option<NormalMap>,
}

/// What a one-sided material is from the back.
static BLACK: Bsdf = Bsdf::Black;

/// What the scene says about a shape beyond its geometry: material, emission, media.
#[derive(Debug, Clone)]
pub struct ShapeInfo {
    /// Display name (`name` key, or "shape #i (type)").
    pub name: String,
    /// Index of the shape in the scene.
    pub index: u32,
    /// Index into [`Scene::materials`] (on a checkerboard, that of the even tiles).
    pub material: u32,
    /// Index into `Scene::lights` when the shape emits.
    pub light: Option<u32>,
    /// Media on either side, when the shape bounds a medium.
    pub interface: Option<MediumInterface>,
    /// An index-matched boundary: media and no material; rays pass straight through.
    pub null: bool,
    /// A quad tiled in two materials: `material` on the even tiles, the checker's on the odd.
    pub checker: Option<Checker>,
}

impl ShapeInfo {
    /// The material at point `p` of the shape.
    #[inline]
    pub fn material_at(&self, p: Vec3) -> u32 {
        match &self.checker {
            None => self.material,
            Some(c) => c.material_at(p, self.material),
        }
    }
}

/// A quad tiled in two materials (a scene file's `tiles` with `tile_material`): the point
/// `origin + s edge_u + t edge_v` lies in tile `(floor(s nu), floor(t nv))`, which takes the
/// shape's material when `i + j` is even and `odd` otherwise. One quad instead of a mesh per
/// colour keeps the tiles out of the accelerator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checker {
    /// The corner of the quad that tile (0, 0) starts at.
    pub origin: Vec3,
    /// `s = du . (p - origin)`, `t = dv . (p - origin)` (rows of the inverse of the edges).
    pub du: Vec3,
    /// See `du`.
    pub dv: Vec3,
    /// Number of tiles along `edge_u` and `edge_v`.
    pub tiles: [u32; 2],
    /// Material index of the odd tiles.
    pub odd: u32,
}

impl Checker {
    /// The checkerboard of `tiles` on the parallelogram `origin + s edge_u + t edge_v`, or
    /// `None` if the edges are parallel.
    pub fn new(
        origin: Vec3,
        edge_u: Vec3,
        edge_v: Vec3,
        tiles: [u32; 2],
        odd: u32,
    ) -> Option<Checker> {
        let m = glam::Mat3::from_cols(edge_u, edge_v, edge_u.cross(edge_v));
        if !m.determinant().is_normal() {
            return None;
        }
        let inv = m.inverse();
        Some(Checker {
            origin,
            du: inv.row(0),
            dv: inv.row(1),
            tiles,
            odd,
        })
    }

    /// The material at `p`, `even` being the shape's own.
    #[inline]
    pub fn material_at(&self, p: Vec3, even: u32) -> u32 {
        let q = p - self.origin;
        let tile = |d: Vec3, n: u32| ((d.dot(q) * n as f32).floor() as i64).clamp(0, n as i64 - 1);
        if (tile(self.du, self.tiles[0]) + tile(self.dv, self.tiles[1])) % 2 == 0 {
            even
        } else {
            self.odd
        }
    }
}

/// `[render]` defaults of a scene file; the command line overrides them.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderDefaults {
    /// Maximum number of path segments (`--max-depth`).
    pub max_depth: u32,
    /// Samples per pixel (`--spp`).
    pub spp: u32,
    /// Registry name of the integrator (`--integrator`).
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

/// A loaded scene, immutable and shared by reference across the render's threads.
pub struct Scene {
    /// The scene file, or `<built-in cornell-box>`.
    pub source: String,
    /// The pinhole camera and the image resolution.
    pub camera: Camera,
    /// Geometry of every shape, indexed like `shape_info` and by `Hit::shape`.
    pub shapes: Vec<ShapeGeometry>,
    /// Material, emission and media of every shape.
    pub shape_info: Vec<ShapeInfo>,
    /// Materials, indexed by `ShapeInfo::material`.
    pub materials: Vec<Material>,
    /// Every light: emissive shapes and the point, spot, environment, directional and sun
    /// lights.
    pub lights: Vec<Light>,
    /// Chooses a light for next-event estimation and light subpaths, with its pmf.
    pub light_sampler: LightSampler,
    /// Indices of the lights at infinity (environment, directional, sun): what an escaping
    /// ray can see.
    pub infinite_lights: Vec<usize>,
    /// Participating media, indexed by the medium ids of interfaces and vertices.
    pub media: Vec<HomogeneousMedium>,
    /// The medium filling the world outside every medium boundary (`world_medium`).
    pub world_medium: Option<u32>,
    /// The medium the camera is in (`medium_at` its position).
    pub camera_medium: Option<u32>,
    /// Per light, the medium its emitted rays start in, for lights whose shape is not itself a
    /// medium boundary (see `light_medium`).
    pub light_media: Vec<Option<u32>>,
    /// The ray-intersection accelerator over `shapes` (a BVH, or a flat list for small
    /// scenes).
    pub accel: Accel,
    /// What the scene contains, so integrators can skip work it does not need.
    pub features: SceneFeatures,
    /// Bounding sphere of the geometry.
    pub center: Vec3,
    /// Radius of the bounding sphere (lights at infinity emit across a disc of this radius).
    pub radius: f32,
    /// The scene file's `[render]` defaults.
    pub render: RenderDefaults,
    /// Per pixel, whether an emitter fills it (`coverage.rs`), computed on first use.
    pub filled_pixels: std::sync::OnceLock<Vec<bool>>,
}

/// A surface point with what is needed to scatter there.
pub struct SurfacePoint<'a> {
    /// The ray's closest hit: position, normals, error bound, shape.
    pub hit: Hit,
    /// The BSDF at the hit (black on the back of a one-sided material).
    pub bsdf: &'a Bsdf,
    /// The shading frame around the shading normal, with the geometric normal.
    pub frame: ShadingFrame,
    /// The shape's light, media and whether it is an index-matched boundary (kept by
    /// reference: surface points are built for every ray and should stay small).
    pub info: &'a ShapeInfo,
    /// The material at the hit (`info.material` unless the shape is a checkerboard).
    pub material: u32,
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
    /// Position.
    pub p: Vec3,
    /// Geometric normal (zero off surfaces): the side the shadow ray is offset to.
    pub n: Vec3,
    /// Per-axis bound on the error of `p`.
    pub err: Vec3,
}

impl Endpoint {
    /// The endpoint at a surface hit.
    pub fn surface(hit: &Hit) -> Endpoint {
        Endpoint {
            p: hit.p,
            n: hit.ng,
            err: hit.p_err,
        }
    }

    /// An endpoint without a surface (medium vertex, point light).
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
    /// Per-channel transmittance, the product of `exp(-sigma_t d)` over the medium segments.
    pub tr: Spectrum,
    /// Probability that free-flight sampling crosses every medium segment without a
    /// collision.
    pub pass: f32,
    /// (medium, length) of the first medium segment (for path densities).
    pub first: Option<(u32, f32)>,
    /// (medium, length) of the last medium segment.
    pub last: Option<(u32, f32)>,
    /// Medium at the far end (after any index-matched crossings).
    pub end_medium: Option<u32>,
}

impl Transmittance {
    /// A connection with nothing in the way (no medium, no crossing), ending in `medium`:
    /// what [`Scene::transmittance`] gives a free connection in a scene without media.
    #[inline]
    pub fn unblocked(medium: Option<u32>) -> Transmittance {
        Transmittance {
            tr: Spectrum::ONE,
            pass: 1.0,
            first: None,
            last: None,
            end_medium: medium,
        }
    }
}

impl Scene {
    /// The built-in Cornell box.
    pub fn cornell_box() -> Scene {
        loader::load_str(CORNELL_BOX_TOML, "<built-in cornell-box>", None)
            .expect("the built-in scene is valid")
    }

    /// The closest surface point along `ray` within its extent, if any.
    pub fn intersect(&self, ray: &Ray) -> Option<SurfacePoint<'_>> {
        let hit = self.accel.intersect(ray, &self.shapes)?;
        Some(self.surface_point(hit, ray))
    }

    /// Closest hits of `rays` into `out` (`out[i]` for `rays[i]`): what [`Self::intersect`]
    /// finds, ray for ray and bit for bit, with the traversals interleaved where the
    /// accelerator supports it ([`crate::geometry::interleaved`]); [`Self::surface_point`]
    /// turns a hit into the surface point `intersect` returns.
    pub fn intersect_many(&self, rays: &[Ray], out: &mut Vec<Option<Hit>>) {
        self.accel.intersect_many(rays, &self.shapes, out);
    }

    /// For each shadow query `(o, d, dist)` of [`Self::shadow_query`], whether nothing blocks
    /// it: what [`Self::transmittance`] finds in a scene without media, query for query.
    pub fn unoccluded_many(&self, queries: &[(Vec3, Vec3, f32)], out: &mut Vec<bool>) {
        self.accel.unoccluded_many(queries, out);
        for (free, &(_, _, dist)) in out.iter_mut().zip(queries) {
            *free |= dist <= 0.0; // as `transmittance`: nothing to test
        }
    }

    /// The open segment [`Self::transmittance`] tests from `a` to `b` (or from `a` to
    /// infinity along unit `dir`): (origin, unit direction, length).
    #[inline(always)]
    pub fn shadow_query(&self, a: &Endpoint, b: Option<&Endpoint>, dir: Vec3) -> (Vec3, Vec3, f32) {
        match b {
            Some(b) => shadow_segment(a.p, a.err, a.n, b.p, b.err, b.n),
            None => (offset_origin(a.p, a.err, a.n, dir), dir, f32::INFINITY),
        }
    }

    /// The surface point of `hit`, found along `ray`.
    #[inline(always)]
    pub fn surface_point(&self, mut hit: Hit, ray: &Ray) -> SurfacePoint<'_> {
        let info = &self.shape_info[hit.shape as usize];
        let material_id = info.material_at(hit.p);
        let material = &self.materials[material_id as usize];
        let back = material.one_sided && ray.d.dot(hit.ng) > 0.0;
        let shape = &self.shapes[hit.shape as usize];
        let uv = if material.bsdf.is_textured() || material.normal_map.is_some() {
            shape.tex_coords(&hit)
        } else {
            glam::Vec2::ZERO
        };
        if let Some(map) = &material.normal_map {
            // The hit carries the perturbed normal on, so that whatever reads `hit.ns` (cosines,
            // stored paths) sees the frame the BSDF is evaluated in.
            hit.ns = map.shading_normal(uv, hit.ns, hit.ng, shape.dp_duv(&hit));
        }
        let mut frame = ShadingFrame::new(hit.ns, hit.ng).with_uv(uv);
        if material.bsdf.is_anisotropic() {
            frame = frame.with_tangent(shape.dp_duv(&hit)[0]);
        }
        SurfacePoint {
            bsdf: if back { &BLACK } else { &material.bsdf },
            frame,
            info,
            material: material_id,
            hit,
        }
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

    /// The medium containing point `p`: the medium on the near side of the first medium
    /// boundary met along a ray from `p` (surfaces without media are passed through), or the
    /// world medium when no boundary is met. Three fixed directions vote, so a ray slipping
    /// through a crack between two triangles cannot decide alone. Used once per light and for
    /// the camera at load time, not per sample.
    pub fn medium_at(&self, p: Vec3) -> Option<u32> {
        if !self.features.media {
            return None;
        }
        const DIRS: [Vec3; 3] = [
            Vec3::new(0.267_261_24, 0.534_522_5, 0.801_783_7),
            Vec3::new(-0.872_871_5, 0.218_217_9, -0.436_435_8),
            Vec3::new(0.301_511_34, -0.904_534_03, 0.301_511_34),
        ];
        let votes = DIRS.map(|d| self.first_boundary_side(p, d));
        if votes[1] == votes[2] {
            votes[1]
        } else {
            votes[0]
        }
    }

    /// Medium on the near side of the first medium boundary along the ray from `p` in `d`.
    fn first_boundary_side(&self, p: Vec3, d: Vec3) -> Option<u32> {
        let mut o = p;
        // A bounded number of crossings of surfaces without media.
        for _ in 0..1024 {
            let ray = Ray {
                o,
                d,
                t_max: f32::INFINITY,
            };
            let Some(sp) = self.intersect(&ray) else {
                break;
            };
            if let Some(mi) = &sp.info.interface {
                return mi.crossing(-d, sp.hit.ng);
            }
            o = offset_origin(sp.hit.p, sp.hit.p_err, sp.hit.ng, d);
        }
        self.world_medium
    }

    /// The medium a ray emitted by `light` at a point with normal `n` along `d` starts in: the
    /// side `d` leaves into when the emitting shape bounds media, else the medium around the
    /// light (`light_media`).
    pub fn light_medium(&self, light: usize, n: Vec3, d: Vec3) -> Option<u32> {
        if let Light::Area(a) = &self.lights[light]
            && let Some(mi) = &self.shape_info[a.shape as usize].interface
        {
            return mi.crossing(d, n);
        }
        self.light_media[light]
    }

    /// Whether light paths can leave `light` at all: a light at infinity seen through a world
    /// medium is infinitely far inside it and attenuated to nothing (as camera paths find when
    /// they escape), so light paths from it are not started.
    pub fn light_reaches_scene(&self, light: usize) -> bool {
        !(self.lights[light].is_infinite() && self.world_medium.is_some())
    }

    /// The start of a light subpath (BDPT, vcm): a light chosen by power and a point and
    /// direction of emission from it, from three uniforms drawn in that order; with the light's
    /// index and selection pmf. `None` when no light path starts: no light, a light that does
    /// not reach the scene, or an emission sample of zero density or value.
    pub fn sample_emission(
        &self,
        sampler: &mut impl crate::math::Sampler,
    ) -> Option<(usize, f32, EmissionSample)> {
        let u_light = sampler.next_1d();
        let (u_pos, u_dir) = (sampler.next_2d(), sampler.next_2d());
        let (light, pmf) = self.light_sampler.sample(u_light)?;
        if !self.light_reaches_scene(light) {
            return None;
        }
        let e = self.lights[light].sample_le(u_pos, u_dir)?;
        if e.pdf_pos <= 0.0 || e.pdf_dir <= 0.0 || e.le == Spectrum::ZERO {
            return None;
        }
        Some((light, pmf, e))
    }

    /// Fill `camera_medium` and `light_media` by `medium_at` (after the accelerator is built).
    pub(crate) fn locate_media(&mut self) {
        self.camera_medium = self.medium_at(self.camera.position);
        let media: Vec<Option<u32>> = (0..self.lights.len())
            .map(|i| {
                let l = &self.lights[i];
                if l.is_infinite() {
                    return self.world_medium;
                }
                match l.sample_le(glam::Vec2::splat(0.5), glam::Vec2::splat(0.5)) {
                    Some(e) if e.n != Vec3::ZERO => {
                        let err = crate::geometry::gamma(8) * e.p.abs();
                        self.medium_at(offset_origin(e.p, err, e.n, e.dir))
                    }
                    Some(e) => self.medium_at(e.p),
                    None => self.world_medium,
                }
            })
            .collect();
        self.light_media = media;
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
        let (mut o, d, mut remaining) = self.shadow_query(a, b, dir);
        let mut out = Transmittance::unblocked(medium);
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
        // A bounded number of index-matched crossings (closed shapes give two each). Rays
        // reach the target, so that a medium boundary crossed within the shadow epsilon of it
        // still decides the medium the segment ends in; a surface there does not block.
        for _ in 0..64 {
            let to_target = remaining + slack;
            if to_target <= 0.0 {
                out.end_medium = medium;
                return Some(out);
            }
            let ray = Ray {
                o,
                d,
                t_max: to_target,
            };
            let blocker = self
                .intersect(&ray)
                .filter(|sp| sp.is_null() || sp.hit.t < remaining);
            let Some(sp) = blocker else {
                if let Some(m) = medium {
                    segment(&mut out, m, to_target);
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

    /// Number of triangles over all meshes.
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

    /// Number of spheres.
    pub fn sphere_count(&self) -> usize {
        self.shapes
            .iter()
            .filter(|s| matches!(s, ShapeGeometry::Sphere(_)))
            .count()
    }
}
