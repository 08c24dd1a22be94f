//! The primitives the BVH's leaves hold: triangles stored as a vertex and two edges (ordered
//! so that `e1 x e2` is the front side) and spheres, and their ray intersection. The BVH
//! (`bvh.rs`), its flattened leaves (`flat.rs`) and the per-mesh grids (`grid.rs`) share them.

use super::{Sphere, TriangleMesh};
use glam::{Vec2, Vec3A};

/// `Prim::tri` of a sphere.
pub(super) const SPHERE_TAG: u32 = u32::MAX;
/// Set in `Prim::tri` when the edges were swapped so that `e1 x e2` points to the front side.
pub(super) const SWAPPED: u32 = 1 << 31;

/// A primitive in BVH order: a triangle (v0, e1, e2) or a sphere (center in `a`, radius in `b.x`).
/// Triangle edges are ordered so that `e1 x e2` is the front-side normal, so a hit needs no
/// access to the mesh unless it has vertex normals.
#[derive(Debug, Clone, Copy)]
pub(super) struct Prim {
    pub(super) a: Vec3A,
    pub(super) b: Vec3A,
    pub(super) c: Vec3A,
    pub(super) shape: u32,
    /// Triangle index within its mesh (with `SWAPPED`), or `SPHERE_TAG`.
    pub(super) tri: u32,
}

impl Prim {
    pub(super) const SWAPPED: u32 = SWAPPED;

    /// Triangle `i` of mesh `m` (shape `shape`), or `None` if it is degenerate (never hit).
    pub(super) fn triangle(m: &TriangleMesh, shape: u32, i: usize) -> Option<Prim> {
        let [p0, p1, p2] = m.triangle(i).map(Vec3A::from);
        let (e1, e2) = (p1 - p0, p2 - p0);
        if e1.cross(e2).length_squared() == 0.0 {
            return None;
        }
        let front = Vec3A::from(m.geometric_normal(i));
        let (b, c, tri) = if e1.cross(e2).dot(front) >= 0.0 {
            (e1, e2, i as u32)
        } else {
            (e2, e1, i as u32 | SWAPPED)
        };
        Some(Prim {
            a: p0,
            b,
            c,
            shape,
            tri,
        })
    }
}

#[inline]
pub(super) fn intersect_prim(p: &Prim, o: Vec3A, d: Vec3A, t_max: f32) -> (f32, Vec2) {
    if p.tri == SPHERE_TAG {
        let s = Sphere {
            center: p.a.into(),
            radius: p.b.x,
        };
        return (s.intersect(o.into(), d.into(), t_max), Vec2::ZERO);
    }
    // Möller-Trumbore, comparing the scaled barycentrics with det and dividing only on a hit.
    let pvec = d.cross(p.c);
    let det = p.b.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return (f32::INFINITY, Vec2::ZERO);
    }
    let tvec = o - p.a;
    let u_det = tvec.dot(pvec);
    let qvec = tvec.cross(p.b);
    let v_det = d.dot(qvec);
    let t_det = p.c.dot(qvec);
    // With det > 0: 0 <= u_det, 0 <= v_det, u_det + v_det <= det, 0 < t_det < t_max det;
    // det < 0 flips every inequality, so compare the products with |det| after a sign flip.
    let (sign, abs_det) = (det.signum(), det.abs());
    let (u_s, v_s, t_s) = (u_det * sign, v_det * sign, t_det * sign);
    if u_s < 0.0 || v_s < 0.0 || u_s + v_s > abs_det || t_s <= 0.0 {
        return (f32::INFINITY, Vec2::ZERO);
    }
    let inv_det = 1.0 / det;
    let t = t_det * inv_det;
    if t < t_max {
        (t, Vec2::new(u_det * inv_det, v_det * inv_det))
    } else {
        (f32::INFINITY, Vec2::ZERO)
    }
}
