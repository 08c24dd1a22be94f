//! Grid meshes (heightfields) traced cell by cell instead of through the BVH.
//!
//! A heightfield's triangles tile a regular grid, two per cell ([`GridLayout`]). [`GridIndex`]
//! walks the cells a ray crosses, row by row in order along the ray and cell by cell within a
//! row, and tests their triangles with the BVH's own primitive test on the same world-space
//! triangles, so a hit (t, barycentrics, triangle) is the one the BVH finds, bit for bit,
//! except for which of two triangles wins an exact tie. The walk is conservative: it maps
//! the ray into cell coordinates and pads every cell and the height range by [`PAD`] cells plus
//! four times the rounding measured on the mesh's own vertices (and a term for the ray's own
//! magnitude), so no cell whose triangles the ray can hit is skipped.
//!
//! Why: a BVH stores each triangle as a 64-byte primitive and adds about a node per two
//! triangles; the walk needs only the mesh's positions, indices and one byte of flags per
//! triangle (about 20 bytes), so pool's 60k-triangle water fits the core's L2 cache, and a
//! ray crossing the water's thin slab visits a few cells instead of descending a tree. A mesh
//! whose triangles do not sit in their cells (a layout that does not match) stays in the BVH.
//! The index keeps its own copy of the vertex normals too: a hit's shading normal is read
//! from it, with the normals asked for as soon as the walk finds the triangle, instead of
//! from the mesh's arrays, which the walk never touches (cold misses on pool's water).

use super::TriangleMesh;
use super::prim::{Prim, intersect_prim};
use glam::{Affine3A, UVec2, Vec2, Vec3, Vec3A};

/// Padding of every cell and of the height range, in cells, beyond the measured rounding.
const PAD: f32 = 1e-3;
/// A layout whose vertices stray further than this (in cells) from their cells is not used.
const MAX_STRAY: f32 = 0.01;

/// Flags per triangle.
const SWAPPED_EDGES: u8 = 1;
const DEGENERATE: u8 = 2;

pub(super) struct GridIndex {
    shape: u32,
    cells: UVec2,
    to_cells: Affine3A,
    /// The padded box every triangle lies in, in cell coordinates (u, h, v).
    lo: Vec3A,
    hi: Vec3A,
    /// Padding of each cell, in cells.
    pad: f32,
    /// Height range of each cell's triangles, padded.
    cell_h: Vec<[f32; 2]>,
    positions: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
    /// The mesh's vertex normals, if it has them: a hit's shading normal is read here, beside
    /// the indices the walk has just read, instead of from the mesh's own arrays.
    normals: Option<Vec<Vec3>>,
    flags: Vec<u8>,
    /// A world-space box around every triangle, for a cheap first test.
    world_lo: Vec3A,
    world_hi: Vec3A,
}

/// What the walk does after a cell: go on with the segment ending at this t, or stop.
enum Next {
    Until(f32),
    Stop,
}

impl GridIndex {
    /// The walk over mesh `m` (shape `shape`), or `None` if it has no grid layout or its
    /// triangles do not lie in their cells.
    pub(super) fn new(m: &TriangleMesh, shape: u32) -> Option<GridIndex> {
        let layout = m.grid.as_deref().copied()?;
        let (nx, nz) = (layout.cells.x as usize, layout.cells.y as usize);
        if nx == 0 || nz == 0 || m.indices.len() != 2 * nx * nz {
            return None;
        }
        let mut flags = Vec::with_capacity(m.indices.len());
        let mut cell_h = vec![[f32::INFINITY, f32::NEG_INFINITY]; nx * nz];
        let mut stray = 0.0f32;
        let (mut world_lo, mut world_hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        for t in 0..m.indices.len() {
            let cell = t / 2;
            let (i, j) = ((cell % nx) as f32, (cell / nx) as f32);
            for p in m.triangle(t).map(Vec3A::from) {
                let q = layout.to_cells.transform_point3a(p);
                let off = (i - q.x).max(q.x - i - 1.0).max(j - q.z).max(q.z - j - 1.0);
                stray = stray.max(off);
                let h = &mut cell_h[cell];
                *h = [h[0].min(q.y), h[1].max(q.y)];
                (world_lo, world_hi) = (world_lo.min(p), world_hi.max(p));
            }
            flags.push(match Prim::triangle(m, shape, t) {
                None => DEGENERATE,
                Some(p) if p.tri != t as u32 => SWAPPED_EDGES,
                Some(_) => 0,
            });
        }
        let h_lo = cell_h.iter().map(|h| h[0]).fold(f32::INFINITY, f32::min);
        let h_hi = cell_h
            .iter()
            .map(|h| h[1])
            .fold(f32::NEG_INFINITY, f32::max);
        if !(stray <= MAX_STRAY && h_lo.is_finite() && h_hi.is_finite()) {
            return None;
        }
        let pad = PAD + 4.0 * stray.max(0.0);
        for h in &mut cell_h {
            *h = [h[0] - pad, h[1] + pad];
        }
        // The world box only rejects rays that pass well clear of every triangle.
        let slack = 1e-4 * (world_hi - world_lo).max_element()
            + 1e-5 * world_lo.abs().max(world_hi.abs()).max_element();
        let index = GridIndex {
            shape,
            cells: layout.cells,
            to_cells: layout.to_cells,
            lo: Vec3A::new(-pad, h_lo - pad, -pad),
            hi: Vec3A::new(nx as f32 + pad, h_hi + pad, nz as f32 + pad),
            pad,
            cell_h,
            positions: m.positions.clone(),
            indices: m.indices.clone(),
            normals: m.normals.clone(),
            flags,
            world_lo: world_lo - Vec3A::splat(slack),
            world_hi: world_hi + Vec3A::splat(slack),
        };
        debug_assert!((0..m.indices.len()).all(|t| {
            let (a, b) = (index.prim(t), Prim::triangle(m, shape, t));
            a.map(|p| (p.a, p.b, p.c, p.tri)) == b.map(|p| (p.a, p.b, p.c, p.tri))
        }));
        Some(index)
    }

    /// [`TriangleMesh::shading_normal`] of triangle `i` from this index's copy of the mesh.
    #[inline]
    pub(super) fn shading_normal(&self, i: usize, b: Vec2) -> Option<Vec3> {
        TriangleMesh::interpolate_normal(self.normals.as_deref()?, self.indices[i], b)
    }

    pub(super) fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Whether `o + t d`, t in (0, t_max), may meet the world box (`inv_d` = 1 / d; any
    /// direction with a zero component is let through to the exact walk).
    #[inline]
    pub(super) fn may_hit(&self, o: Vec3A, inv_d: Vec3A, t_max: f32) -> bool {
        if !inv_d.is_finite() {
            return true;
        }
        let (ta, tb) = ((self.world_lo - o) * inv_d, (self.world_hi - o) * inv_d);
        let t0 = ta.min(tb).max_element().max(0.0);
        let t1 = ta.max(tb).min_element().min(t_max);
        t0 <= t1
    }

    /// Triangle `t` as the BVH stores it ([`Prim::triangle`], the same arithmetic), or `None`
    /// if it is degenerate.
    #[inline]
    fn prim(&self, t: usize) -> Option<Prim> {
        let f = self.flags[t];
        if f & DEGENERATE != 0 {
            return None;
        }
        let [a, b, c] = self.indices[t].map(|k| Vec3A::from(self.positions[k as usize]));
        let (e1, e2) = (b - a, c - a);
        let swapped = f & SWAPPED_EDGES != 0;
        Some(Prim {
            a,
            b: if swapped { e2 } else { e1 },
            c: if swapped { e1 } else { e2 },
            shape: self.shape,
            tri: if swapped {
                t as u32 | Prim::SWAPPED
            } else {
                t as u32
            },
        })
    }

    /// Closest hit of `o + t d` (`d` canonical, as for the BVH), t in (0, `t_max`): the
    /// triangle, t and barycentrics.
    pub(super) fn closest(&self, o: Vec3A, d: Vec3A, t_max: f32) -> Option<(Prim, f32, Vec2)> {
        let mut nearest = None;
        self.walk(o, d, t_max, |cell, mut t_max| {
            for tri in [2 * cell, 2 * cell + 1] {
                let Some(prim) = self.prim(tri) else { continue };
                let (t, uv) = intersect_prim(&prim, o, d, t_max);
                if t < t_max {
                    t_max = t;
                    nearest = Some((prim, t, uv));
                    // Its shading normal is read after the rest of the scene is searched:
                    // ask for the vertices' normals now.
                    if let Some(n) = &self.normals {
                        for k in self.indices[tri] {
                            crate::prefetch::line(&n[k as usize]);
                        }
                    }
                }
            }
            Next::Until(t_max)
        });
        nearest
    }

    /// Whether a triangle blocks `o + t d`, t in (0, `t_max`).
    pub(super) fn occludes(&self, o: Vec3A, d: Vec3A, t_max: f32) -> bool {
        let mut blocked = false;
        self.walk(o, d, t_max, |cell, t_max| {
            for t in [2 * cell, 2 * cell + 1] {
                let Some(prim) = self.prim(t) else { continue };
                if intersect_prim(&prim, o, d, t_max).0 < t_max {
                    blocked = true;
                    return Next::Stop;
                }
            }
            Next::Until(t_max)
        });
        blocked
    }

    /// Calls `visit(cell, t_max)` for every cell whose triangles `o + t d`, t in (0, t_max),
    /// may hit, rows in order along the ray, so that a hit ends the walk at the first row that
    /// starts beyond it.
    fn walk(&self, o: Vec3A, d: Vec3A, t_max: f32, mut visit: impl FnMut(usize, f32) -> Next) {
        let oc = self.to_cells.transform_point3a(o);
        let dc = self.to_cells.transform_vector3a(d);
        // Reciprocals instead of divisions: t is off by an ulp or so, far inside the padding.
        let inv = dc.recip();
        // The segment's part inside the padded box.
        let (mut t0, mut t1) = (0.0f32, t_max);
        for a in 0..3 {
            if dc[a] == 0.0 {
                if oc[a] < self.lo[a] || oc[a] > self.hi[a] {
                    return;
                }
            } else {
                let (ta, tb) = ((self.lo[a] - oc[a]) * inv[a], (self.hi[a] - oc[a]) * inv[a]);
                t0 = max(t0, min(ta, tb));
                t1 = min(t1, max(ta, tb));
            }
        }
        if t0 > t1 || t0.is_nan() || t1.is_nan() {
            return;
        }
        // The ray's cell coordinates round with their magnitude.
        let q = self.pad + 1e-6 * (oc.abs().max_element() + (dc * t1).abs().max_element());
        let (nx, nz) = (self.cells.x as i64, self.cells.y as i64);
        let (v0, v1) = (oc.z + t0 * dc.z, oc.z + t1 * dc.z);
        let j_lo = ((min(v0, v1) - q).floor() as i64).max(0);
        let j_hi = ((max(v0, v1) + q).floor() as i64).min(nz - 1);
        let mut t_max = t_max;
        for k in 0..=(j_hi - j_lo).max(-1) {
            let j = if dc.z >= 0.0 { j_lo + k } else { j_hi - k };
            // Where the ray is within the padded row; rows further along start later.
            let (ta, tb) = slab(t0, min(t1, t_max), j, q, oc.z, dc.z, inv.z);
            if ta > t_max {
                return;
            }
            if ta > tb {
                continue;
            }
            let (ua, ub) = (oc.x + ta * dc.x, oc.x + tb * dc.x);
            let i_lo = ((min(ua, ub) - q).floor() as i64).max(0);
            let i_hi = ((max(ua, ub) + q).floor() as i64).min(nx - 1);
            for c in 0..=(i_hi - i_lo).max(-1) {
                let i = if dc.x >= 0.0 { i_lo + c } else { i_hi - c };
                let cell = (j * nx + i) as usize;
                // Skip the cell if the ray passes above or below its triangles there.
                let (tc0, tc1) = slab(ta, min(tb, t_max), i, q, oc.x, dc.x, inv.x);
                let (h0, h1) = (oc.y + tc0 * dc.y, oc.y + tc1 * dc.y);
                let [lo, hi] = self.cell_h[cell];
                if tc0 > tc1 || max(h0, h1) < lo - q || min(h0, h1) > hi + q {
                    continue;
                }
                match visit(cell, t_max) {
                    Next::Until(t) => t_max = t,
                    Next::Stop => return,
                }
            }
        }
    }
}

/// The part of `[t0, t1]` where the coordinate `o + t d` (`inv` = 1 / d) lies in the cell
/// slab `[k - q, k + 1 + q]`; all of it when `d` is 0.
#[inline(always)]
fn slab(t0: f32, t1: f32, k: i64, q: f32, o: f32, d: f32, inv: f32) -> (f32, f32) {
    if d == 0.0 {
        return (t0, t1);
    }
    let a = (k as f32 - q - o) * inv;
    let b = (k as f32 + 1.0 + q - o) * inv;
    (max(t0, min(a, b)), min(t1, max(a, b)))
}

/// `a.min(b)` for numbers (one instruction; `f32::min`'s NaN rules cost several, and the walk
/// has no NaN: a NaN ray fails the box test).
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::bvh::{Accel, ShapeGeometry};
    use crate::geometry::heightfield::{Wave, heightfield};
    use crate::geometry::{Hit, Ray, Transform};
    use crate::math::{IndependentSampler, Sampler, warp::square_to_uniform_sphere};
    use glam::Vec2;

    /// Two wavy heightfields inside the closed test box: one rotated about a slanted axis and
    /// scaled unevenly, one mirrored (a negative scale turns its winding over), so the walk's
    /// map to cell coordinates is a general affine one.
    fn shapes() -> Vec<ShapeGeometry> {
        let waves = [
            Wave {
                amplitude: 0.08,
                wavelength: 0.5,
                direction: Vec2::new(0.6, 0.8),
                phase: 0.3,
            },
            Wave {
                amplitude: 0.03,
                wavelength: 0.21,
                direction: Vec2::new(-0.8, 0.6),
                phase: 1.1,
            },
        ];
        let field = |res: UVec2, t: Transform| {
            ShapeGeometry::Mesh(heightfield(Vec2::new(1.6, 1.2), res, &waves).transformed(&t))
        };
        let mut shapes = crate::geometry::bvh::tests::closed_box();
        shapes.push(field(
            UVec2::new(40, 30),
            Transform::new(
                Vec3::new(1.0, 1.3, 0.8),
                Vec3::new(1.0, 2.0, 0.5),
                35.0,
                Vec3::ZERO,
            ),
        ));
        shapes.push(field(
            UVec2::new(17, 23),
            Transform::new(
                Vec3::new(-0.7, 0.9, 0.9),
                Vec3::Y,
                10.0,
                Vec3::new(0.1, -0.5, 0.2),
            ),
        ));
        shapes
    }

    /// Every field of the hit, as bits.
    fn key(h: &Hit) -> Vec<u32> {
        let mut k = vec![
            h.t.to_bits(),
            h.uv.x.to_bits(),
            h.uv.y.to_bits(),
            h.shape,
            h.prim,
        ];
        for v in [h.p, h.p_err, h.ng, h.ns] {
            k.extend(v.to_array().map(f32::to_bits));
        }
        k
    }

    /// 30k rays (random origins in the box; directions uniform, a third of them grazing the
    /// first heightfield's plane, some with zero components; a fifth with a finite `t_max`):
    /// the grid walk and the BVH over the same triangles find the same hit, every field bit for
    /// bit, unless two triangles tie in t exactly; occlusion agrees on every segment.
    #[test]
    fn grid_walk_agrees_with_the_bvh_bit_for_bit() {
        let shapes = shapes();
        let walked = Accel::build_with(&shapes, 32, true);
        let bvh = Accel::build_with(&shapes, 32, false);
        assert_eq!(walked.grids.len(), 2, "both heightfields are walked");
        assert!(bvh.grids.is_empty());
        assert_eq!(walked.primitive_count(), bvh.primitive_count());
        let ShapeGeometry::Mesh(m) = &shapes[shapes.len() - 2] else {
            unreachable!()
        };
        let to_world = m.grid.as_ref().unwrap().to_cells.inverse();
        let (u, v) = (
            Vec3::from(to_world.matrix3.x_axis).normalize(),
            Vec3::from(to_world.matrix3.z_axis).normalize(),
        );
        let mut rng = IndependentSampler::new(11, 0, 0);
        let (mut hits, mut ties, mut grid_hits) = (0, 0, 0);
        let n = 30_000;
        for k in 0..n {
            let o = rng.next_2d().extend(rng.next_1d()) * 1.9 - 0.95;
            let mut d = square_to_uniform_sphere(rng.next_2d());
            if k % 3 == 1 {
                let a = rng.next_1d() * std::f32::consts::TAU;
                let tilt = (rng.next_1d() - 0.5) * 0.02;
                d = (a.cos() * u + a.sin() * v + tilt * u.cross(v)).normalize();
            } else if k % 50 == 2 {
                d = [Vec3::X, -Vec3::Y, Vec3::Z, Vec3::new(0.6, 0.0, -0.8)][k / 50 % 4];
            }
            let t_max = if k % 5 == 0 {
                rng.next_1d() * 2.0
            } else {
                f32::INFINITY
            };
            let ray = Ray { o, d, t_max };
            let (a, b) = (
                walked.intersect(&ray, &shapes),
                bvh.intersect(&ray, &shapes),
            );
            match (&a, &b) {
                (Some(a), Some(b)) => {
                    hits += 1;
                    grid_hits += usize::from(a.shape as usize >= shapes.len() - 2);
                    assert_eq!(a.t.to_bits(), b.t.to_bits(), "ray {k}: t differs");
                    if (a.shape, a.prim) == (b.shape, b.prim) {
                        assert_eq!(key(a), key(b), "ray {k}: hit fields differ");
                    } else {
                        ties += 1;
                    }
                }
                (None, None) => {}
                _ => panic!("ray {k}: {a:?} against the BVH's {b:?}"),
            }
            let dist = if t_max.is_finite() { t_max } else { 3.0 };
            assert_eq!(
                walked.unoccluded(o, d, dist),
                bvh.unoccluded(o, d, dist),
                "segment {k}"
            );
        }
        assert!(grid_hits > n / 10, "{grid_hits} hits on the heightfields");
        assert!(ties * 1000 < hits, "{ties} ties in {hits} hits");
    }

    /// A mesh whose triangles are not where its layout says (triangle order shuffled) is not
    /// walked: it stays in the BVH.
    #[test]
    fn a_layout_that_does_not_match_is_not_used() {
        let waves = [];
        let mut m = heightfield(Vec2::new(1.0, 1.0), UVec2::new(8, 8), &waves);
        assert!(GridIndex::new(&m, 0).is_some());
        m.indices.swap(0, 40);
        assert!(GridIndex::new(&m, 0).is_none());
        m.indices.swap(0, 40);
        m.indices.pop();
        assert!(GridIndex::new(&m, 0).is_none());
    }
}
