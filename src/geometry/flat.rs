//! The accelerator of small scenes: no hierarchy, every primitive tested, triangles four at a
//! time.
//!
//! A scene of a few dozen primitives (the Cornell boxes, SmallVCM's box) gains nothing from a
//! BVH: a ray visits most of its leaves anyway, and decoding compressed nodes costs more than
//! testing the triangles they hold. Here the triangles are stored as structure-of-arrays groups
//! of four lanes (`v0`, `e1`, `e2` per axis, in `Vec4`s) and tested with the same Möller-Trumbore
//! arithmetic as [`super::bvh`]'s scalar test, operation for operation, so a lane reports
//! bit for bit the distance and barycentrics the scalar test would. Spheres are tested one by
//! one. [`super::Accel::build`] picks this below [`FLAT_MAX_PRIMS`] primitives.

use super::bvh::{Prim, SPHERE_TAG, intersect_prim};
use glam::{Vec2, Vec3A, Vec4};

/// Scenes with at most this many primitives are tested without a hierarchy.
/// Measured (pt, one thread, bit-identical images): the Cornell box's 25 primitives render
/// 11 % faster than through the BVH, SmallVCM's 22 primitives 5 % faster under bdpt, ajar's 87
/// primitives 38 % slower.
pub const FLAT_MAX_PRIMS: usize = 32;

/// Four triangles, one per lane: vertex `a`, edges `b` and `c` (as in [`Prim`]). Unused lanes
/// hold zero edges, whose determinant is zero: they never report a hit.
#[derive(Debug, Clone, Copy)]
struct Group {
    a: [Vec4; 3],
    b: [Vec4; 3],
    c: [Vec4; 3],
}

/// Every primitive of a small scene: triangles in groups of four, then spheres.
#[derive(Debug, Clone)]
pub struct Flat {
    groups: Vec<Group>,
    /// Index into the accelerator's primitive list of each triangle lane (`u32::MAX`: unused).
    lanes: Vec<u32>,
    /// Indices of the spheres in the primitive list.
    spheres: Vec<u32>,
}

/// The per-lane test: a mask of hits with `0 < t < t_max` and the lanes' `t`, `u`, `v`.
struct LaneHits {
    mask: u32,
    t: Vec4,
    u: Vec4,
    v: Vec4,
}

impl Flat {
    pub fn new(prims: &[Prim]) -> Flat {
        let (mut groups, mut lanes, mut spheres) = (Vec::new(), Vec::new(), Vec::new());
        let tris: Vec<u32> = (0..prims.len() as u32)
            .filter(|&i| {
                let sphere = prims[i as usize].tri == SPHERE_TAG;
                if sphere {
                    spheres.push(i);
                }
                !sphere
            })
            .collect();
        for chunk in tris.chunks(4) {
            let mut g = Group {
                a: [Vec4::ZERO; 3],
                b: [Vec4::ZERO; 3],
                c: [Vec4::ZERO; 3],
            };
            for (lane, &i) in chunk.iter().enumerate() {
                let p = &prims[i as usize];
                for axis in 0..3 {
                    g.a[axis][lane] = p.a[axis];
                    g.b[axis][lane] = p.b[axis];
                    g.c[axis][lane] = p.c[axis];
                }
            }
            groups.push(g);
            lanes.extend(chunk.iter().copied());
            lanes.extend(std::iter::repeat_n(u32::MAX, 4 - chunk.len()));
        }
        Flat {
            groups,
            lanes,
            spheres,
        }
    }

    /// The closest primitive along `o + t d` with `t < t_max`: its index in the primitive list,
    /// `t` and barycentrics.
    pub fn closest(
        &self,
        prims: &[Prim],
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
    ) -> Option<(usize, f32, Vec2)> {
        let mut best: Option<(usize, f32, Vec2)> = None;
        let mut t_best = t_max;
        for (gi, g) in self.groups.iter().enumerate() {
            let hits = g.test(o, d, t_best);
            if hits.mask == 0 {
                continue;
            }
            for lane in 0..4 {
                // Strictly closer only, as the scalar test's `t < t_max`.
                if hits.mask & (1 << lane) != 0 && hits.t[lane] < t_best {
                    t_best = hits.t[lane];
                    let uv = Vec2::new(hits.u[lane], hits.v[lane]);
                    best = Some((self.lanes[4 * gi + lane] as usize, t_best, uv));
                }
            }
        }
        for &i in &self.spheres {
            let (t, uv) = intersect_prim(&prims[i as usize], o, d, t_best);
            if t < t_best {
                t_best = t;
                best = Some((i as usize, t, uv));
            }
        }
        best
    }

    /// True if no primitive is hit along `o + t d` with `0 < t < t_max`.
    pub fn unoccluded(&self, prims: &[Prim], o: Vec3A, d: Vec3A, t_max: f32) -> bool {
        self.groups.iter().all(|g| g.test(o, d, t_max).mask == 0)
            && self
                .spheres
                .iter()
                .all(|&i| intersect_prim(&prims[i as usize], o, d, t_max).0 >= t_max)
    }
}

/// `p x q` for lanes, written as glam's `Vec3A::cross` computes each component (no fused
/// operations), so each lane's value is the scalar test's.
#[inline(always)]
fn cross(p: [Vec4; 3], q: [Vec4; 3]) -> [Vec4; 3] {
    [
        p[1] * q[2] - p[2] * q[1],
        p[2] * q[0] - p[0] * q[2],
        p[0] * q[1] - p[1] * q[0],
    ]
}

/// `p . q` for lanes in glam's `Vec3A::dot` order: `(x x' + y y') + z z'`.
#[inline(always)]
fn dot(p: [Vec4; 3], q: [Vec4; 3]) -> Vec4 {
    (p[0] * q[0] + p[1] * q[1]) + p[2] * q[2]
}

impl Group {
    /// Möller-Trumbore on four lanes, exactly [`super::bvh`]'s scalar test per lane.
    #[inline(always)]
    fn test(&self, o: Vec3A, d: Vec3A, t_max: f32) -> LaneHits {
        let ds = [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)];
        let pvec = cross(ds, self.c);
        let det = dot(self.b, pvec);
        let tvec = [
            Vec4::splat(o.x) - self.a[0],
            Vec4::splat(o.y) - self.a[1],
            Vec4::splat(o.z) - self.a[2],
        ];
        let u_det = dot(tvec, pvec);
        let qvec = cross(tvec, self.b);
        let v_det = dot(ds, qvec);
        let t_det = dot(self.c, qvec);
        let (sign, abs_det) = (det.signum(), det.abs());
        let (u_s, v_s, t_s) = (u_det * sign, v_det * sign, t_det * sign);
        let usable = det.cmpne(Vec4::ZERO) & det.is_finite_mask();
        let inside = u_s.cmpge(Vec4::ZERO)
            & v_s.cmpge(Vec4::ZERO)
            & (u_s + v_s).cmple(abs_det)
            & t_s.cmpgt(Vec4::ZERO);
        let mut mask = (usable & inside).bitmask();
        if mask == 0 {
            return LaneHits {
                mask,
                t: Vec4::ZERO,
                u: Vec4::ZERO,
                v: Vec4::ZERO,
            };
        }
        let inv_det = Vec4::ONE / det;
        let t = t_det * inv_det;
        mask &= t.cmplt(Vec4::splat(t_max)).bitmask();
        LaneHits {
            mask,
            t,
            u: u_det * inv_det,
            v: v_det * inv_det,
        }
    }
}
