//! Heightfields: a grid mesh over a rectangle in the xz plane (centred on the origin) whose
//! height is a sum of sine waves, with analytic smooth normals. Water surfaces are made with it.
//! The mesh records its grid ([`GridLayout`]) so the accelerator can walk its cells
//! (`grid.rs`) instead of putting its triangles in the BVH.

use super::TriangleMesh;
use glam::{Affine3A, UVec2, Vec2, Vec3};

/// A mesh whose triangles tile a regular grid: cell (i, j) of `cells.x` by `cells.y` holds
/// triangles `2 (j cells.x + i)` and `2 (j cells.x + i) + 1`, and maps by `to_cells` into
/// the box `[i, i + 1] x [h0, h1] x [j, j + 1]` of cell coordinates (u, h, v), h being the
/// height in the same units as u.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridLayout {
    /// Number of cells along u and v.
    pub cells: UVec2,
    /// World space to cell coordinates (kept up to date by [`TriangleMesh::transformed`]).
    pub to_cells: Affine3A,
}

/// One term `amplitude * sin(2 pi / wavelength * (direction . (x, z)) + phase)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wave {
    /// Peak height of the wave.
    pub amplitude: f32,
    /// Distance between crests.
    pub wavelength: f32,
    /// Unit direction of travel in the xz plane.
    pub direction: Vec2,
    /// Phase in radians.
    pub phase: f32,
}

/// Height and gradient (dh/dx, dh/dz) at (x, z).
pub fn height(waves: &[Wave], x: f32, z: f32) -> (f32, Vec2) {
    let mut h = 0.0;
    let mut grad = Vec2::ZERO;
    for w in waves {
        let k = 2.0 * std::f32::consts::PI / w.wavelength;
        let arg = k * w.direction.dot(Vec2::new(x, z)) + w.phase;
        h += w.amplitude * arg.sin();
        grad += w.amplitude * k * arg.cos() * w.direction;
    }
    (h, grad)
}

/// A `size.x` by `size.y` (x by z) grid of `resolution` quads, two triangles each, front side +y.
pub fn heightfield(size: Vec2, resolution: UVec2, waves: &[Wave]) -> TriangleMesh {
    let (nx, nz) = (resolution.x as usize + 1, resolution.y as usize + 1);
    let mut positions = Vec::with_capacity(nx * nz);
    let mut normals = Vec::with_capacity(nx * nz);
    for j in 0..nz {
        for i in 0..nx {
            let x = (i as f32 / resolution.x as f32 - 0.5) * size.x;
            let z = (j as f32 / resolution.y as f32 - 0.5) * size.y;
            let (h, g) = height(waves, x, z);
            positions.push(Vec3::new(x, h, z));
            normals.push(Vec3::new(-g.x, 1.0, -g.y).normalize());
        }
    }
    let mut indices = Vec::with_capacity(2 * (nx - 1) * (nz - 1));
    for j in 0..nz - 1 {
        for i in 0..nx - 1 {
            let v = |i: usize, j: usize| (j * nx + i) as u32;
            // (+z edge) x (+x edge) = +y: front side up.
            indices.push([v(i, j), v(i, j + 1), v(i + 1, j)]);
            indices.push([v(i + 1, j), v(i, j + 1), v(i + 1, j + 1)]);
        }
    }
    // x = (i / rx - 0.5) size.x, so u = x rx / size.x + rx / 2 (and h scaled like u).
    let (su, sv) = (resolution.x as f32 / size.x, resolution.y as f32 / size.y);
    let to_cells = Affine3A::from_cols(
        Vec3::new(su, 0.0, 0.0).into(),
        Vec3::new(0.0, su, 0.0).into(),
        Vec3::new(0.0, 0.0, sv).into(),
        Vec3::new(0.5 * resolution.x as f32, 0.0, 0.5 * resolution.y as f32).into(),
    );
    TriangleMesh {
        positions,
        normals: Some(normals),
        uvs: None,
        indices,
        grid: Some(Box::new(GridLayout {
            cells: resolution,
            to_cells,
        })),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_up_and_follows_the_waves() {
        let waves = [Wave {
            amplitude: 0.1,
            wavelength: 0.5,
            direction: Vec2::new(0.6, 0.8),
            phase: 0.3,
        }];
        let m = heightfield(Vec2::new(2.0, 1.0), UVec2::new(40, 20), &waves);
        assert_eq!(m.indices.len(), 2 * 40 * 20);
        for i in 0..m.indices.len() {
            let [a, b, c] = m.triangle(i);
            assert!((b - a).cross(c - a).y > 0.0);
        }
        // Normal from finite differences of the height.
        let (x, z, e) = (0.3, -0.2, 1e-3);
        let (_, g) = height(&waves, x, z);
        let fd = Vec2::new(
            (height(&waves, x + e, z).0 - height(&waves, x - e, z).0) / (2.0 * e),
            (height(&waves, x, z + e).0 - height(&waves, x, z - e).0) / (2.0 * e),
        );
        assert!((g - fd).length() < 1e-2, "{g} vs {fd}");
        // Surface area against the integral of sqrt(1 + |grad h|^2) over the rectangle.
        let n = 400;
        let mut integral = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let x = ((i as f32 + 0.5) / n as f32 - 0.5) * 2.0;
                let z = ((j as f32 + 0.5) / n as f32 - 0.5) * 1.0;
                integral += (1.0 + height(&waves, x, z).1.length_squared() as f64).sqrt() * 2.0
                    / (n * n) as f64;
            }
        }
        let rel = (m.area() as f64 - integral).abs() / integral;
        assert!(rel < 0.02, "mesh area {} vs integral {integral}", m.area());
    }
}
