//! Which triangle of an emitting mesh a surface point lies on, for the texture coordinates of
//! a textured area light at a point (`AreaLight::uv_at`): a small bounding-volume hierarchy
//! over the triangles' boxes, searched for the triangle that contains the point best.
//!
//! "Best" is the barycentric measure `min(b0, b1, b2)` of the point projected onto each
//! candidate's plane: positive inside, the distance (in barycentric units) beyond the nearest
//! edge outside. A point on the mesh lies inside its triangle up to rounding; every
//! triangle whose box, widened by a rounding margin, holds the point is a candidate.

use crate::geometry::TriangleMesh;
use glam::{Vec2, Vec3};

/// Triangles per leaf.
const LEAF: usize = 4;

/// A node: its box, and either two children (`right` the second; the first follows the
/// node) or a leaf's range of `order`.
#[derive(Debug, Clone)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: first index into `order`; inner node: index of the second child.
    start: u32,
    /// Leaf: number of triangles; inner node: 0.
    count: u32,
}

/// The hierarchy over one mesh's triangles.
#[derive(Debug, Clone)]
pub struct TriangleLocator {
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// How far outside a triangle's box a point on it may lie by rounding.
    margin: f32,
}

impl TriangleLocator {
    /// The hierarchy of `mesh` (median splits along the widest axis of the centroids).
    pub fn new(mesh: &TriangleMesh) -> TriangleLocator {
        let n = mesh.indices.len();
        let boxes: Vec<(Vec3, Vec3)> = (0..n)
            .map(|i| {
                let [a, b, c] = mesh.triangle(i);
                (a.min(b).min(c), a.max(b).max(c))
            })
            .collect();
        let (lo, hi) = boxes
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), b| {
                (l.min(b.0), h.max(b.1))
            });
        let scale = if n == 0 {
            0.0
        } else {
            lo.abs()
                .max(hi.abs())
                .max_element()
                .max((hi - lo).max_element())
        };
        let mut locator = TriangleLocator {
            nodes: Vec::with_capacity(2 * n / LEAF + 1),
            order: (0..n as u32).collect(),
            margin: 1e-4 * scale,
        };
        if n > 0 {
            locator.build(&boxes, 0, n);
        }
        locator
    }

    /// Appends the subtree over `order[start..end]`; returns its node index.
    fn build(&mut self, boxes: &[(Vec3, Vec3)], start: usize, end: usize) -> usize {
        let ids = &mut self.order[start..end];
        let (lo, hi) = ids
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &i| {
                (l.min(boxes[i as usize].0), h.max(boxes[i as usize].1))
            });
        let at = self.nodes.len();
        self.nodes.push(Node {
            lo,
            hi,
            start: start as u32,
            count: (end - start) as u32,
        });
        if end - start <= LEAF {
            return at;
        }
        let centre = |i: u32| boxes[i as usize].0 + boxes[i as usize].1;
        let (clo, chi) = ids
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &i| {
                (l.min(centre(i)), h.max(centre(i)))
            });
        let axis = (chi - clo).max_position();
        let mid = (end - start) / 2;
        ids.select_nth_unstable_by(mid, |&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]));
        self.build(boxes, start, start + mid);
        let right = self.build(boxes, start + mid, end);
        self.nodes[at].start = right as u32;
        self.nodes[at].count = 0;
        at
    }

    /// The texture coordinates of point `p` on `mesh` (the mesh this was built from): those
    /// of the candidate triangle that contains `p` best; every triangle is a candidate when
    /// none's box holds `p`.
    pub fn uv_at(&self, mesh: &TriangleMesh, p: Vec3) -> Vec2 {
        let mut best = (f32::NEG_INFINITY, Vec2::ZERO);
        let consider = |i: usize, best: &mut (f32, Vec2)| {
            if let Some((inside, bary)) = containment(mesh, i, p)
                && inside > best.0
            {
                *best = (inside, mesh.tex_coords(i, bary));
            }
        };
        // Median splits: depth about log2(triangles / LEAF), so 64 entries hold any mesh.
        let mut stack = [0usize; 64];
        let mut top = usize::from(!self.nodes.is_empty());
        let m = Vec3::splat(self.margin);
        while top > 0 {
            top -= 1;
            let k = stack[top];
            let node = &self.nodes[k];
            if p.cmplt(node.lo - m).any() || p.cmpgt(node.hi + m).any() {
                continue;
            }
            if node.count > 0 {
                let range = node.start as usize..(node.start + node.count) as usize;
                for &i in &self.order[range] {
                    consider(i as usize, &mut best);
                }
            } else {
                stack[top] = node.start as usize;
                stack[top + 1] = k + 1;
                top += 2;
            }
        }
        if best.0 == f32::NEG_INFINITY {
            (0..mesh.indices.len()).for_each(|i| consider(i, &mut best));
        }
        best.1
    }
}

/// How far inside triangle `i` point `p`, projected onto its plane, lies (`min` of its
/// barycentrics: negative outside), with its barycentrics (b1, b2); `None` for a degenerate
/// triangle.
pub fn containment(mesh: &TriangleMesh, i: usize, p: Vec3) -> Option<(f32, Vec2)> {
    let [a, b, c] = mesh.triangle(i);
    let (e1, e2, d) = (b - a, c - a, p - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if det <= 0.0 {
        return None;
    }
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let bary = Vec2::new(d22 * d1 - d12 * d2, d11 * d2 - d12 * d1) / det;
    Some((bary.x.min(bary.y).min(1.0 - bary.x - bary.y), bary))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{IndependentSampler, Sampler};

    /// A bumpy `k` x `k` grid over [0, 1]^2 (two triangles a cell, heights varying), with
    /// texture coordinates `(x, y)`, and a second copy of it above, turned upside down: two
    /// sheets whose projections overlap, so that a search by projection alone would mix
    /// them up.
    fn sheets(k: usize) -> TriangleMesh {
        let mut positions = Vec::new();
        let mut uvs = Vec::new();
        let mut indices = Vec::new();
        for sheet in 0..2 {
            let base = positions.len() as u32;
            for j in 0..=k {
                for i in 0..=k {
                    let (x, y) = (i as f32 / k as f32, j as f32 / k as f32);
                    let z = 0.05 * (7.0 * x).sin() * (5.0 * y).cos() + sheet as f32 * 0.5;
                    positions.push(Vec3::new(x, y, z));
                    uvs.push(Vec2::new(x, y + sheet as f32));
                }
            }
            let at = |i: usize, j: usize| base + (j * (k + 1) + i) as u32;
            for j in 0..k {
                for i in 0..k {
                    indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                    indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
        TriangleMesh {
            positions,
            normals: None,
            uvs: Some(uvs),
            indices,
            grid: None,
        }
    }

    /// A point drawn on a triangle is given that triangle's texture coordinates (up to the
    /// rounding of a shared edge), on a mesh of thousands of triangles in two overlapping
    /// sheets; so is a point a rounding's width off the mesh's edge.
    #[test]
    fn points_on_the_mesh_get_their_triangles_coordinates() {
        let mesh = sheets(40);
        let locator = TriangleLocator::new(&mesh);
        let mut rng = IndependentSampler::new(5, 0, 0);
        let n = mesh.indices.len();
        for _ in 0..20_000 {
            let i = ((rng.next_1d() * n as f32) as usize).min(n - 1);
            let (mut u, mut v) = (rng.next_1d(), rng.next_1d());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let [a, b, c] = mesh.triangle(i);
            let p = a * (1.0 - u - v) + b * u + c * v;
            let want = mesh.tex_coords(i, Vec2::new(u, v));
            let got = locator.uv_at(&mesh, p);
            assert!(
                (got - want).abs().max_element() < 1e-4,
                "triangle {i}, point {p}: {got} against {want}"
            );
        }
        // A rounding's width beyond the lower sheet's edge: its edge triangle's coordinates,
        // not the upper sheet's above it.
        let got = locator.uv_at(&mesh, Vec3::new(-1e-6, 0.5, 0.0));
        assert!(got.x.abs() < 1e-3 && (got.y - 0.5).abs() < 1e-3, "{got}");
    }
}
