//! The noisy sphere of `cargo bench --bench bvh` and `--bench pt_batch` (each includes this
//! file with `#[path = "common/noisy_sphere.rs"] mod noisy_sphere;`).

use glam::Vec3;
use lodestar::geometry::TriangleMesh;

fn displacement(p: Vec3) -> f32 {
    let (x, y, z) = (p.x, p.y, p.z);
    0.1125 * (5.0 * x + 0.3).sin() * (4.0 * y + 1.1).sin() * (6.0 * z + 0.7).sin()
        + 0.0625 * (13.0 * x + 2.0).sin() * (11.0 * y + 0.4).sin() * (12.0 * z + 1.9).sin()
        + 0.0375 * (31.0 * x + 0.9).sin() * (29.0 * y + 2.6).sin() * (27.0 * z + 0.2).sin()
}

/// A noisy sphere: the six faces of a cube, each an equi-angular `grid` x `grid` quad grid,
/// projected to the unit sphere and displaced radially by sums of sinusoid products
/// (12 grid^2 triangles; `grid` = 289 gives `cargo bench --bench bvh`'s 1,002,252).
pub fn noisy_sphere(grid: usize) -> TriangleMesh {
    let n = grid + 1;
    let a: Vec<f32> = (0..n)
        .map(|i| {
            if i == 0 {
                -1.0
            } else if i == n - 1 {
                1.0
            } else {
                (-std::f32::consts::FRAC_PI_4
                    + std::f32::consts::FRAC_PI_2 * i as f32 / grid as f32)
                    .tan()
            }
        })
        .collect();
    let faces: [fn(f32, f32) -> Vec3; 6] = [
        |u, v| Vec3::new(1.0, v, -u),
        |u, v| Vec3::new(-1.0, v, u),
        |u, v| Vec3::new(u, 1.0, -v),
        |u, v| Vec3::new(u, -1.0, v),
        |u, v| Vec3::new(u, v, 1.0),
        |u, v| Vec3::new(-u, v, -1.0),
    ];
    let mut mesh = TriangleMesh::default();
    for (f, face) in faces.iter().enumerate() {
        let base = (f * n * n) as u32;
        for row in 0..n {
            for col in 0..n {
                let p = face(a[col], a[row]).normalize();
                mesh.positions.push(p * (1.0 + displacement(p)));
            }
        }
        for row in 0..grid {
            for col in 0..grid {
                let i = |r: usize, c: usize| base + (r * n + c) as u32;
                let (i00, i10, i01, i11) = (
                    i(row, col),
                    i(row, col + 1),
                    i(row + 1, col),
                    i(row + 1, col + 1),
                );
                mesh.indices.push([i00, i10, i11]);
                mesh.indices.push([i00, i11, i01]);
            }
        }
    }
    mesh
}
