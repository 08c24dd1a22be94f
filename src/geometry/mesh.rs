//! Triangle meshes in world space, and the built-in shapes that are made of them
//! (quad, cube, disk).

use super::Transform;
use super::heightfield::GridLayout;
use crate::math::{Distribution1D, warp};
use glam::{Vec2, Vec3};

/// A triangle mesh in world space: vertex positions, optional shading normals and index
/// triples.
#[derive(Debug, Clone, Default)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (optional; same length as `positions`).
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates (optional; same length as `positions`).
    pub uvs: Option<Vec<Vec2>>,
    /// Vertex indices of each triangle (their winding gives the front side, see
    /// [`Self::geometric_normal`]).
    pub indices: Vec<[u32; 3]>,
    /// How the triangles tile a regular grid, for meshes made as one (heightfields): the
    /// accelerator then walks the grid's cells instead of building a BVH over them.
    pub grid: Option<Box<GridLayout>>,
}

impl TriangleMesh {
    /// Texture coordinates at barycentric coordinates `b = (b1, b2)` of triangle `i`: the
    /// vertices' interpolated, or `b` itself for a mesh without them (as Mitsuba).
    pub fn tex_coords(&self, i: usize, b: Vec2) -> Vec2 {
        match &self.uvs {
            None => b,
            Some(uv) => {
                let [a, p, c] = self.indices[i].map(|k| uv[k as usize]);
                a * (1.0 - b.x - b.y) + p * b.x + c * b.y
            }
        }
    }

    /// The derivatives of position by the two texture coordinates on triangle `i` (Mitsuba's
    /// `dp_du`, `dp_dv`): from the vertices' texture coordinates, or the edges from the first
    /// vertex to the second and third for a mesh without them (where the coordinates are the
    /// barycentrics); zero where the coordinates are degenerate.
    pub fn dp_duv(&self, i: usize) -> [Vec3; 2] {
        let [p0, p1, p2] = self.triangle(i);
        let (dp0, dp1) = (p1 - p0, p2 - p0);
        let Some(uv) = &self.uvs else {
            return [dp0, dp1];
        };
        let [a, b, c] = self.indices[i].map(|k| uv[k as usize]);
        let (d10, d20) = (b - a, c - a);
        let det = d10.x * d20.y - d10.y * d20.x;
        if det == 0.0 || !det.is_finite() {
            return [Vec3::ZERO; 2];
        }
        [
            (dp0 * d20.y - dp1 * d10.y) / det,
            (dp1 * d10.x - dp0 * d20.x) / det,
        ]
    }

    /// The corner positions of triangle `i`.
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[i];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Area of triangle `i`.
    pub fn triangle_area(&self, i: usize) -> f32 {
        let [a, b, c] = self.triangle(i);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        (0..self.indices.len()).map(|i| self.triangle_area(i)).sum()
    }

    /// Geometric normal of triangle `i` from its winding, or from its vertex normals when the
    /// mesh has them and they disagree with the winding (authored normals define the front).
    pub fn geometric_normal(&self, i: usize) -> Vec3 {
        let [a, b, c] = self.triangle(i);
        let ng = (b - a).cross(c - a).normalize_or_zero();
        match &self.normals {
            Some(n) => {
                let [ia, ib, ic] = self.indices[i];
                let sum = n[ia as usize] + n[ib as usize] + n[ic as usize];
                if sum.dot(ng) < 0.0 { -ng } else { ng }
            }
            None => ng,
        }
    }

    /// Interpolated shading normal at barycentrics (b1, b2), or `None` without vertex normals.
    pub fn shading_normal(&self, i: usize, b: Vec2) -> Option<Vec3> {
        Self::interpolate_normal(self.normals.as_ref()?, self.indices[i], b)
    }

    /// The normals `n` of a triangle's vertices `[ia, ib, ic]` interpolated at barycentrics
    /// (b1, b2) and normalised, or `None` where they cancel.
    #[inline]
    pub(crate) fn interpolate_normal(n: &[Vec3], [ia, ib, ic]: [u32; 3], b: Vec2) -> Option<Vec3> {
        let v = n[ia as usize] * (1.0 - b.x - b.y) + n[ib as usize] * b.x + n[ic as usize] * b.y;
        let v = v.normalize_or_zero();
        (v != Vec3::ZERO).then_some(v)
    }

    /// The mesh under `t`: positions, normals and grid mapped, winding flipped where `t`
    /// flips handedness.
    pub fn transformed(mut self, t: &Transform) -> TriangleMesh {
        for p in &mut self.positions {
            *p = t.point(*p);
        }
        if let Some(ns) = &mut self.normals {
            for n in ns.iter_mut() {
                *n = t.normal(*n);
            }
        }
        if t.flips_handedness() {
            for tri in &mut self.indices {
                tri.swap(1, 2);
            }
        }
        if let Some(g) = &mut self.grid {
            g.to_cells *= t.m.inverse();
        }
        self
    }

    /// Axis-aligned parallelogram `origin + s edge_u + t edge_v`, s, t in [0, 1]; front side
    /// along `edge_u x edge_v`.
    pub fn quad(origin: Vec3, edge_u: Vec3, edge_v: Vec3) -> TriangleMesh {
        TriangleMesh {
            positions: vec![
                origin,
                origin + edge_u,
                origin + edge_u + edge_v,
                origin + edge_v,
            ],
            normals: None,
            // Mitsuba's rectangle: (0, 0) at the origin corner, u along edge_u, v along edge_v.
            uvs: Some(vec![
                Vec2::ZERO,
                Vec2::new(1.0, 0.0),
                Vec2::ONE,
                Vec2::new(0.0, 1.0),
            ]),
            grid: None,
            indices: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    /// The cube [-1, 1]^3 with outward-facing triangles.
    pub fn cube() -> TriangleMesh {
        let mut mesh = TriangleMesh::default();
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut n = Vec3::ZERO;
                n[axis] = sign;
                let mut u = Vec3::ZERO;
                u[(axis + 1) % 3] = 2.0;
                let mut v = Vec3::ZERO;
                v[(axis + 2) % 3] = 2.0;
                // Orient so that u x v points along n.
                let (u, v) = if u.cross(v).dot(n) > 0.0 {
                    (u, v)
                } else {
                    (v, u)
                };
                let origin = n - 0.5 * u - 0.5 * v;
                let q = TriangleMesh::quad(origin, u, v);
                mesh.append(&q);
            }
        }
        mesh
    }

    /// A disk of radius 1 in the xy plane, front side +z, as a fan of `segments` triangles.
    pub fn disk(segments: u32) -> TriangleMesh {
        let segments = segments.max(3);
        let mut positions = vec![Vec3::ZERO];
        for k in 0..segments {
            let phi = 2.0 * std::f32::consts::PI * k as f32 / segments as f32;
            positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
        }
        let indices = (0..segments)
            .map(|k| [0, 1 + k, 1 + (k + 1) % segments])
            .collect();
        TriangleMesh {
            positions,
            normals: None,
            uvs: None,
            grid: None,
            indices,
        }
    }

    /// The mesh with its front side turned over: every triangle's winding reversed and its
    /// vertex normals negated.
    pub fn flipped(mut self) -> TriangleMesh {
        for tri in &mut self.indices {
            tri.swap(1, 2);
        }
        if let Some(ns) = &mut self.normals {
            for n in ns.iter_mut() {
                *n = -*n;
            }
        }
        self
    }

    /// Vertex normals as the angle-weighted sum of the normals of the faces around each
    /// vertex (Thürmer and Wüthrich 1998; Mitsuba's rule for meshes without normals). Where
    /// the sum vanishes (the faces fold back on each other) a vertex takes the normal of one of
    /// its faces, and +z when all its faces are degenerate (they are never hit).
    pub fn with_smooth_normals(mut self) -> TriangleMesh {
        let mut sums = vec![glam::DVec3::ZERO; self.positions.len()];
        let mut fallback = vec![glam::DVec3::Z; self.positions.len()];
        for tri in &self.indices {
            let p = tri.map(|i| self.positions[i as usize].as_dvec3());
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let Some(n) = n.try_normalize() else { continue };
            for k in 0..3 {
                fallback[tri[k] as usize] = n;
                let e1 = (p[(k + 1) % 3] - p[k]).try_normalize();
                let e2 = (p[(k + 2) % 3] - p[k]).try_normalize();
                if let (Some(e1), Some(e2)) = (e1, e2) {
                    sums[tri[k] as usize] += n * e1.dot(e2).clamp(-1.0, 1.0).acos();
                }
            }
        }
        let normals = sums
            .iter()
            .zip(&fallback)
            .map(|(n, f)| n.try_normalize().unwrap_or(*f).as_vec3())
            .collect();
        self.normals = Some(normals);
        self
    }

    /// Add `other`'s triangles (shading normals are kept only if neither mesh has any).
    pub fn append(&mut self, other: &TriangleMesh) {
        let base = self.positions.len() as u32;
        self.uvs = match (self.uvs.take(), &other.uvs) {
            (Some(mut a), Some(b)) => {
                a.extend_from_slice(b);
                Some(a)
            }
            (None, Some(b)) if base == 0 => Some(b.clone()),
            _ => None,
        };
        self.positions.extend_from_slice(&other.positions);
        self.indices.extend(
            other
                .indices
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
        match (&mut self.normals, &other.normals) {
            (None, None) => {}
            _ => {
                // Mixed: keep none rather than invent normals.
                self.normals = None;
            }
        }
    }
}

/// Uniform-by-area point sampling over a mesh.
#[derive(Debug, Clone)]
pub struct MeshSampler {
    /// Triangles weighted by their area.
    pub tri_distribution: Distribution1D,
    /// Total area of the mesh.
    pub area: f32,
    /// [`TriangleMesh::geometric_normal`] of every triangle (next-event estimation samples
    /// emitters once per vertex; recomputing cross products there was 3 % of pt's time).
    normals: Vec<Vec3>,
    /// A mesh of two triangles that make a parallelogram (a quad light): sampled as
    /// `origin + u.x edge_u + u.y edge_v`, with no triangle to choose and no square root.
    parallelogram: Option<Parallelogram>,
}

/// Two triangles sharing a diagonal whose midpoints coincide, with the same orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Parallelogram {
    origin: Vec3,
    edge_u: Vec3,
    edge_v: Vec3,
    normal: Vec3,
}

impl Parallelogram {
    /// `mesh` as a parallelogram, if it is one: two triangles with the same geometric normal
    /// sharing an edge (the diagonal) whose midpoint is the midpoint of the two other
    /// corners, to 1e-6 of the mesh's size.
    fn of(mesh: &TriangleMesh, normals: &[Vec3]) -> Option<Parallelogram> {
        let [t0, t1] = mesh.indices[..] else {
            return None;
        };
        if normals[0].dot(normals[1]) < 1.0 - 1e-6 {
            return None;
        }
        let shared: Vec<u32> = t0.iter().copied().filter(|i| t1.contains(i)).collect();
        let [a, b] = shared[..] else {
            return None;
        };
        let other = |t: [u32; 3]| t.into_iter().find(|i| *i != a && *i != b);
        let (c, d) = (other(t0)?, other(t1)?);
        let p = |i: u32| mesh.positions[i as usize];
        let (pa, pb, pc, pd) = (p(a), p(b), p(c), p(d));
        let size = (pa - pc).length() + (pb - pc).length() + (pd - pc).length();
        if size.is_nan() || size <= 0.0 || ((pa + pb) - (pc + pd)).length() > 1e-6 * size {
            return None;
        }
        Some(Parallelogram {
            origin: pc,
            edge_u: pa - pc,
            edge_v: pb - pc,
            normal: normals[0],
        })
    }
}

impl MeshSampler {
    /// The sampler of `mesh`.
    pub fn new(mesh: &TriangleMesh) -> MeshSampler {
        let areas: Vec<f32> = (0..mesh.indices.len())
            .map(|i| mesh.triangle_area(i))
            .collect();
        let area = areas.iter().sum();
        let normals: Vec<Vec3> = (0..mesh.indices.len())
            .map(|i| mesh.geometric_normal(i))
            .collect();
        MeshSampler {
            tri_distribution: Distribution1D::new(&areas),
            area,
            parallelogram: Parallelogram::of(mesh, &normals),
            normals,
        }
    }

    /// Whether the mesh is sampled as one parallelogram.
    pub fn is_parallelogram(&self) -> bool {
        self.parallelogram.is_some()
    }

    /// A point uniform in area: (position, geometric normal). Density 1/area.
    #[inline]
    pub fn sample(&self, mesh: &TriangleMesh, u: Vec2) -> (Vec3, Vec3) {
        if let Some(q) = &self.parallelogram {
            return (q.origin + q.edge_u * u.x + q.edge_v * u.y, q.normal);
        }
        let (tri, _, ux) = self.tri_distribution.sample(u.x);
        let b = warp::square_to_uniform_triangle(Vec2::new(ux, u.y));
        let [a, bb, c] = mesh.triangle(tri);
        let p = a * (1.0 - b.x - b.y) + bb * b.x + c * b.y;
        (p, self.normals[tri])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_normals_of_a_cube_corner_point_along_the_diagonal() {
        let m = TriangleMesh::cube().with_smooth_normals();
        let ns = m.normals.as_ref().unwrap();
        for (p, n) in m.positions.iter().zip(ns) {
            // Every vertex of the cube mesh is a corner; quads are split in two, so a corner's
            // three faces weigh in by the angles of their triangles there (90 or 45 degrees):
            // the normal leans to the faces with the larger angle but stays in the octant.
            assert!((n.length() - 1.0).abs() < 1e-5);
            assert!(n.dot(p.normalize()) > 0.5, "{p} {n}");
        }
        let flipped = TriangleMesh::cube().with_smooth_normals().flipped();
        assert_eq!(flipped.normals.as_ref().unwrap()[0], -ns[0]);
        assert_eq!(flipped.geometric_normal(0), -m.geometric_normal(0));
    }

    #[test]
    fn cube_is_closed_with_outward_normals() {
        let m = TriangleMesh::cube();
        assert_eq!(m.indices.len(), 12);
        assert!((m.area() - 24.0).abs() < 1e-4);
        for i in 0..12 {
            let [a, b, c] = m.triangle(i);
            let centroid = (a + b + c) / 3.0;
            assert!(m.geometric_normal(i).dot(centroid) > 0.0);
        }
    }

    /// A quad, sheared and moved, is sampled as a parallelogram: every point lies in one of
    /// its triangles, with its normal; a kite, a pair of opposite windings and a cube are not.
    #[test]
    fn parallelograms_are_recognised_and_sampled_inside() {
        let (o, u, v) = (
            Vec3::new(0.3, -2.0, 1.0),
            Vec3::new(1.5, 0.2, 0.0),
            Vec3::new(0.4, 0.0, 0.7),
        );
        let quad = TriangleMesh::quad(o, u, v);
        let sampler = MeshSampler::new(&quad);
        assert!(sampler.is_parallelogram());
        let n = quad.geometric_normal(0);
        for k in 0..64 {
            let uv = Vec2::new((k % 8) as f32 / 7.0, (k / 8) as f32 / 7.0);
            let (p, pn) = sampler.sample(&quad, uv);
            assert_eq!(pn, n);
            // On the plane, and inside one of the triangles by its signed barycentrics.
            assert!((p - o).dot(n).abs() < 1e-5, "{p} off the plane");
            let inside = (0..2).any(|t| {
                let [a, b, c] = quad.triangle(t);
                let (e1, e2, w) = (b - a, c - a, p - a);
                let area = e1.cross(e2).dot(n);
                let (l1, l2) = (w.cross(e2).dot(n) / area, e1.cross(w).dot(n) / area);
                l1 >= -1e-5 && l2 >= -1e-5 && l1 + l2 <= 1.0 + 1e-5
            });
            assert!(inside, "{p} outside the quad");
        }
        let mut kite = quad.clone();
        kite.positions[2] += 0.1 * u;
        assert!(!MeshSampler::new(&kite).is_parallelogram());
        let mut flipped = quad.clone();
        flipped.indices[1] = [0, 3, 2];
        assert!(!MeshSampler::new(&flipped).is_parallelogram());
        assert!(!MeshSampler::new(&TriangleMesh::cube()).is_parallelogram());
    }

    #[test]
    fn quad_front_is_u_cross_v() {
        let q = TriangleMesh::quad(
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 0.0),
        );
        assert!((q.geometric_normal(0) - Vec3::Y).length() < 1e-6);
        assert!((q.area() - 4.0).abs() < 1e-5);
    }
}
