//! The acceleration structure: one obvhs compressed wide BVH (`CwBvh`) over every triangle and
//! analytic sphere of the scene, with a Möller-Trumbore triangle test and the robust sphere test;
//! scenes of at most `FLAT_MAX_PRIMS` primitives skip the hierarchy (`geometry/flat.rs`).
//! Meshes laid out as grids (heightfields) are not in it: they are walked cell by cell
//! (`geometry/grid.rs`) before the rest is searched up to their hit.
//!
//! Primitives are copied into BVH order so the traversal closure indexes them directly.
//! Möller-Trumbore is not watertight (obvhs' own note; agreement with Embree was 0.999999 of
//! rays); rays that leak through shared edges are rare and are counted as misses.

use super::flat::{FLAT_MAX_PRIMS, Flat};
use super::grid::GridIndex;
use super::prim::{Prim, SPHERE_TAG, SWAPPED, intersect_prim};
use super::{Hit, Ray, SHADOW_EPS, Sphere, TriangleMesh, gamma, offset_origin};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::{Boundable, BvhBuildParams, aabb::Aabb, cwbvh::CwBvh, ray::RayHit};
use std::time::Duration;

struct Bounds(Aabb);

impl Bounds {
    /// A box padded by a tiny relative margin, so no box has zero extent on any axis (an
    /// axis-aligned quad alone) when obvhs quantises child boxes against their parent's.
    fn padded(mut bb: Aabb) -> Bounds {
        let pad = 1e-6 * bb.min.abs().max(bb.max.abs()).max_element() + 1e-30;
        bb.min -= Vec3A::splat(pad);
        bb.max += Vec3A::splat(pad);
        Bounds(bb)
    }
}

impl Boundable for Bounds {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// What each shape is made of, for building the accelerator and filling in hits.
#[derive(Debug, Clone)]
pub enum ShapeGeometry {
    /// A triangle mesh in world space.
    Mesh(TriangleMesh),
    /// A sphere.
    Sphere(Sphere),
}

impl ShapeGeometry {
    /// Texture coordinates of `hit` on this shape ([`TriangleMesh::tex_coords`],
    /// [`Sphere::tex_coords`]).
    pub fn tex_coords(&self, hit: &Hit) -> Vec2 {
        match self {
            ShapeGeometry::Mesh(m) => m.tex_coords(hit.prim as usize, hit.uv),
            ShapeGeometry::Sphere(s) => s.tex_coords(hit.p),
        }
    }

    /// The derivatives of position by the texture coordinates at `hit`
    /// ([`TriangleMesh::dp_duv`], [`Sphere::dp_duv`]): the tangents a normal map's axes follow
    /// and a bump map's height tilts.
    pub fn dp_duv(&self, hit: &Hit) -> [Vec3; 2] {
        match self {
            ShapeGeometry::Mesh(m) => m.dp_duv(hit.prim as usize),
            ShapeGeometry::Sphere(s) => s.dp_duv(hit.p),
        }
    }
}

/// How the primitives are searched.
pub(super) enum Index {
    /// Every primitive tested (scenes of at most [`FLAT_MAX_PRIMS`] primitives, none included).
    Flat(Flat),
    Bvh(CwBvh),
}

/// The ray-intersection accelerator over a scene's shapes: a compressed-wide BVH (or a flat
/// list for small scenes), with grid meshes walked cell by cell.
pub struct Accel {
    pub(super) index: Index,
    pub(super) prims: Vec<Prim>,
    /// Meshes laid out as grids (heightfields), walked cell by cell instead ([`super::grid`]).
    pub(super) grids: Vec<GridIndex>,
    /// The BVH is built and traversed in coordinates multiplied by this power of two (see
    /// [`bvh_scale`]); primitives and hits stay in world space.
    pub(super) scale: f32,
    /// The CPU has AVX2: batches of rays ([`Accel::intersect_many`]) test nodes eight children
    /// at a time ([`super::node_avx2`]; the same hits bit for bit).
    pub(super) avx2: bool,
    /// Seconds spent building.
    pub build_seconds: f64,
}

impl Accel {
    /// The accelerator over `shapes`: a flat list for small scenes, else a BVH.
    pub fn build(shapes: &[ShapeGeometry]) -> Accel {
        Accel::build_with(shapes, FLAT_MAX_PRIMS, true)
    }

    /// [`Accel::build`], testing every primitive without a hierarchy up to `flat_max` of them,
    /// and walking grid meshes cell by cell if `use_grids` (else their triangles join the rest).
    pub(super) fn build_with(shapes: &[ShapeGeometry], flat_max: usize, use_grids: bool) -> Accel {
        let start = std::time::Instant::now();
        let mut prims = Vec::new();
        let mut bounds = Vec::new();
        let mut grids = Vec::new();
        for (s, shape) in shapes.iter().enumerate() {
            match shape {
                ShapeGeometry::Mesh(m) => {
                    if let Some(grid) = GridIndex::new(m, s as u32).filter(|_| use_grids) {
                        grids.push(grid);
                        continue;
                    }
                    for i in 0..m.indices.len() {
                        // Degenerate triangles can never be hit.
                        let Some(prim) = Prim::triangle(m, s as u32, i) else {
                            continue;
                        };
                        let [p0, p1, p2] = m.triangle(i).map(Vec3A::from);
                        let mut bb = Aabb::from_point(p0);
                        bb.extend(p1).extend(p2);
                        bounds.push(Bounds::padded(bb));
                        prims.push(prim);
                    }
                }
                ShapeGeometry::Sphere(sp) => {
                    let c = Vec3A::from(sp.center);
                    let r = Vec3A::splat(sp.radius);
                    bounds.push(Bounds::padded(Aabb::new(c - r, c + r)));
                    prims.push(Prim {
                        a: c,
                        b: Vec3A::splat(sp.radius),
                        c: Vec3A::ZERO,
                        shape: s as u32,
                        tri: SPHERE_TAG,
                    });
                }
            }
        }
        if prims.len() <= flat_max {
            return Accel {
                index: Index::Flat(Flat::new(&prims)),
                prims,
                grids,
                scale: 1.0,
                avx2: false,
                build_seconds: start.elapsed().as_secs_f64(),
            };
        }
        let scale = bvh_scale(&bounds);
        for b in &mut bounds {
            b.0.min *= scale;
            b.0.max *= scale;
        }
        let mut core = Duration::ZERO;
        let bvh =
            obvhs::cwbvh::builder::build_cwbvh(&bounds, BvhBuildParams::fast_build(), &mut core);
        let ordered = bvh
            .primitive_indices
            .iter()
            .map(|&i| prims[i as usize])
            .collect();
        Accel {
            index: Index::Bvh(bvh),
            prims: ordered,
            grids,
            scale,
            avx2: super::node_avx2::has_avx2(),
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// The same accelerator with batches tested by obvhs' SSE node test (for tests of both).
    #[cfg(test)]
    pub(super) fn without_avx2(mut self) -> Accel {
        self.avx2 = false;
        self
    }

    /// Number of primitives (triangles and spheres), grid meshes' triangles included.
    pub fn primitive_count(&self) -> usize {
        self.prims.len()
            + self
                .grids
                .iter()
                .map(GridIndex::triangle_count)
                .sum::<usize>()
    }

    /// Closest hit along the ray; returns the hit and the barycentrics (b1, b2) for triangles.
    pub fn intersect(&self, ray: &Ray, shapes: &[ShapeGeometry]) -> Option<Hit> {
        count_ray();
        if self.grids.is_empty() {
            return self.intersect_index(ray, shapes);
        }
        // The grids first: their hit shortens the search of the rest.
        let (o, d) = (Vec3A::from(ray.o), canonical_dir(ray.d));
        let inv_d = d.recip();
        let mut nearest = None;
        let mut t_max = ray.t_max;
        for g in &self.grids {
            if !g.may_hit(o, inv_d, t_max) {
                continue;
            }
            if let Some((prim, t, uv)) = g.closest(o, d, t_max) {
                t_max = t;
                nearest = Some((g, prim, t, uv));
            }
        }
        let shorter = Ray { t_max, ..*ray };
        self.intersect_index(&shorter, shapes).or_else(|| {
            let (g, prim, t, uv) = nearest?;
            let shading = |_: &TriangleMesh, i: usize, b: Vec2| g.shading_normal(i, b);
            Some(surface_hit_shaded(&prim, ray, t, uv, shapes, shading))
        })
    }

    /// [`Self::intersect`] among the primitives of the BVH (or flat list) alone.
    fn intersect_index(&self, ray: &Ray, shapes: &[ShapeGeometry]) -> Option<Hit> {
        let bvh = match &self.index {
            Index::Flat(flat) => {
                let (o, d) = (ray.o.into(), canonical_dir(ray.d));
                let (i, t, uv) = flat.closest(&self.prims, o, d, ray.t_max)?;
                return Some(surface_hit(&self.prims[i], ray, t, uv, shapes));
            }
            Index::Bvh(bvh) => bvh,
        };
        let (s, o, d) = (self.scale, Vec3A::from(ray.o), canonical_dir(ray.d));
        let r = obvhs::ray::Ray::new(o * s, d, 0.0, ray.t_max * s);
        let mut hit = RayHit::none();
        let mut best_uv = Vec2::ZERO;
        let prims = &self.prims;
        // obvhs works in scaled distances; primitives are tested in world space (exact
        // conversions: the scale is a power of two).
        let found = bvh.ray_traverse(r, &mut hit, |r, i| {
            let t_max = r.tmax / s;
            let (t, uv) = intersect_prim(&prims[i], o, d, t_max);
            if t < t_max {
                best_uv = uv;
            }
            t * s
        });
        if !found {
            return None;
        }
        let prim = &self.prims[hit.primitive_id as usize];
        Some(surface_hit(prim, ray, hit.t / s, best_uv, shapes))
    }

    /// True if nothing blocks the open segment from `o` along unit `d` up to `dist`.
    pub fn unoccluded(&self, o: Vec3, d: Vec3, dist: f32) -> bool {
        count_ray();
        let (oa, da) = (Vec3A::from(o), canonical_dir(d));
        let inv_d = da.recip();
        let blocked = |g: &GridIndex| g.may_hit(oa, inv_d, dist) && g.occludes(oa, da, dist);
        if self.grids.iter().any(blocked) {
            return false;
        }
        let bvh = match &self.index {
            Index::Flat(flat) => {
                return flat.unoccluded(&self.prims, o.into(), canonical_dir(d), dist);
            }
            Index::Bvh(bvh) => bvh,
        };
        let (s, o, d) = (self.scale, Vec3A::from(o), canonical_dir(d));
        let r = obvhs::ray::Ray::new(o * s, d, 0.0, dist * s);
        let prims = &self.prims;
        bvh.ray_traverse_miss(r, |r, i| intersect_prim(&prims[i], o, d, r.tmax / s).0 * s)
    }
}

thread_local! {
    static RAYS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

#[inline]
pub(super) fn count_ray() {
    RAYS.with(|r| r.set(r.get() + 1));
}

/// Count `n` units of work that is not a ray as that many rays' worth (guided-vcm's merges,
/// whose cost the guider's share must see beside the rays; `integrators/vcm/camera.rs`).
pub fn count_ray_equivalents(n: u64) {
    RAYS.with(|r| r.set(r.get() + n));
}

/// Rays (closest-hit and occlusion) the calling thread has traced so far. Differences of two
/// readings on one thread count the rays of the work in between: a deterministic measure of
/// cost (the guider compares its techniques' costs with it, where wall time would make the
/// image depend on the machine's load).
pub fn rays_traced() -> u64 {
    RAYS.with(|r| r.get())
}

/// The power of two by which BVH coordinates are multiplied: the scene's largest extent
/// becomes about 2^20. obvhs 0.4's node test clamps the ray's entry distance to an absolute
/// 1e-4 (`cwbvh::node::EPSILON`), so in world units it would skip every box within 1e-4 of a
/// ray's origin: rays between surfaces closer than that (all of them in a scene a few
/// millimetres across) missed their hits. Scaled, the blind distance is about 1e-10 of the
/// scene's extent, whatever its units.
fn bvh_scale(bounds: &[Bounds]) -> f32 {
    let mut all = bounds[0].0;
    for b in bounds {
        all = all.union(&b.0);
    }
    scale_for_obvhs(&all)
}

/// The power of two that maps `bounds` (every box and ray origin an obvhs BVH will see) to an
/// extent of about 2^20, for any obvhs BVH (see `bvh_scale`; the guide cache uses it too).
pub fn scale_for_obvhs(bounds: &Aabb) -> f32 {
    let extent = (bounds.max - bounds.min)
        .max_element()
        .max(f32::MIN_POSITIVE);
    let exp = (20 - extent.log2().ceil() as i32).clamp(-100, 100);
    2f32.powi(exp)
}

/// A visibility test between two surface points, each offset off its own surface.
pub fn shadow_segment(
    p0: Vec3,
    err0: Vec3,
    n0: Vec3,
    p1: Vec3,
    err1: Vec3,
    n1: Vec3,
) -> (Vec3, Vec3, f32) {
    let o = offset_origin(p0, err0, n0, p1 - p0);
    let target = if n1 == Vec3::ZERO {
        p1
    } else {
        offset_origin(p1, err1, n1, o - p1)
    };
    let v = target - o;
    let len = v.length();
    (o, v / len, len * (1.0 - SHADOW_EPS))
}

/// obvhs picks the ray octant with `d < 0` (so -0.0 counts as positive) but inverts -0.0 to a
/// large negative number; the two disagree and axis-parallel rays then miss everything.
/// Adding +0.0 turns -0.0 into +0.0 and leaves every other value unchanged.
#[inline]
pub(super) fn canonical_dir(d: Vec3) -> Vec3A {
    Vec3A::from(d) + Vec3A::ZERO
}

pub(super) fn surface_hit(
    prim: &Prim,
    ray: &Ray,
    t: f32,
    uv: Vec2,
    shapes: &[ShapeGeometry],
) -> Hit {
    surface_hit_shaded(prim, ray, t, uv, shapes, TriangleMesh::shading_normal)
}

/// [`surface_hit`] with a triangle's shading normal from `shading(mesh, triangle, (b1, b2))`.
#[inline(always)]
pub(super) fn surface_hit_shaded(
    prim: &Prim,
    ray: &Ray,
    t: f32,
    uv: Vec2,
    shapes: &[ShapeGeometry],
    shading: impl Fn(&TriangleMesh, usize, Vec2) -> Option<Vec3>,
) -> Hit {
    match &shapes[prim.shape as usize] {
        ShapeGeometry::Sphere(s) => {
            let (p, n, p_err) = s.surface_at(ray, t);
            Hit {
                t,
                p,
                p_err,
                ng: n,
                ns: n,
                uv,
                shape: prim.shape,
                prim: 0,
            }
        }
        ShapeGeometry::Mesh(m) => {
            let i = prim.tri & !SWAPPED;
            let (v0, e1, e2) = (Vec3::from(prim.a), Vec3::from(prim.b), Vec3::from(prim.c));
            let p = v0 + uv.x * e1 + uv.y * e2;
            // Error of v0 + u e1 + v e2 (and of the edges themselves), generously bounded.
            let p_err = gamma(8) * (v0.abs() + (uv.x * e1).abs() + (uv.y * e2).abs() + v0.abs());
            // Edges are ordered so that e1 x e2 faces the front side.
            let ng = e1.cross(e2).normalize();
            // Barycentrics (b1, b2) in the mesh's own vertex order.
            let uv = if prim.tri & SWAPPED != 0 {
                Vec2::new(uv.y, uv.x)
            } else {
                uv
            };
            let ns = match shading(m, i as usize, uv) {
                Some(ns) if ns.dot(ng) < 0.0 => -ns,
                Some(ns) => ns,
                None => ng,
            };
            Hit {
                t,
                p,
                p_err,
                ng,
                ns,
                uv,
                shape: prim.shape,
                prim: i,
            }
        }
    }
}

#[cfg(test)]
pub(super) mod tests;
