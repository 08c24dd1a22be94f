//! BVH throughput: build time, closest-hit and occlusion rays per second on a ~1M-triangle
//! mesh with incoherent rays, for 1 and 2 threads.
//!
//! The mesh is a noisy sphere (6 cube faces, each an equi-angular 289 x 289 quad grid
//! projected to the unit sphere, radius displaced by sums of sinusoid products: 1,002,252
//! triangles); rays start uniformly in the mesh's bounding box with directions uniform on the
//! sphere. The same mesh and rays are written to (or, if present, read from)
//! `target/bench-data/` in the raw format of `benches/reference/embree_rays.py`, so Embree can
//! trace exactly the same rays:
//!
//! ```text
//! cargo bench --bench bvh                                   # writes target/bench-data/
//! python3 benches/reference/embree_rays.py --data target/bench-data --threads 1
//! ```
//! Environment: `LODESTAR_BENCH_RAYS` (default 2,000,000), `LODESTAR_BENCH_DATA` (directory).

use glam::Vec3;
use lodestar::geometry::bvh::ShapeGeometry;
use lodestar::geometry::{Accel, Ray, TriangleMesh};
use lodestar::math::{IndependentSampler, Sampler, warp};
use lodestar::render::process_cpu_seconds;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[path = "common/noisy_sphere.rs"]
mod noisy_sphere;

/// Cells per cube-face edge of the noisy sphere: 1,002,252 triangles.
const GRID: usize = 289;

fn generate_rays(mesh: &TriangleMesh, count: usize) -> Vec<[f32; 6]> {
    let (lo, hi) = mesh
        .positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let mut rng = IndependentSampler::from_u64(1);
    (0..count)
        .map(|_| {
            let o = lo + (hi - lo) * Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d());
            let d = warp::square_to_uniform_sphere(rng.next_2d());
            [o.x, o.y, o.z, d.x, d.y, d.z]
        })
        .collect()
}

fn write_f32(path: &Path, v: impl Iterator<Item = f32>) {
    let bytes: Vec<u8> = v.flat_map(f32::to_le_bytes).collect();
    std::fs::write(path, bytes).expect("write bench data");
}

fn read_f32(path: &Path) -> Option<Vec<f32>> {
    let b = std::fs::read(path).ok()?;
    Some(
        b.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
    )
}

/// Load the mesh and rays from `dir` if all three files exist, else generate and write them.
fn data(dir: &Path, rays: usize) -> (TriangleMesh, Vec<[f32; 6]>) {
    let (v, t, r) = (
        dir.join("vertices.f32"),
        dir.join("triangles.u32"),
        dir.join("rays.f32"),
    );
    if let (Some(vs), Some(ts), Some(rs)) = (read_f32(&v), std::fs::read(&t).ok(), read_f32(&r))
        && rs.len() / 6 == rays
    {
        let positions = vs
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        let idx: Vec<u32> = ts
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let indices = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let rays = rs
            .chunks_exact(6)
            .map(|c| [c[0], c[1], c[2], c[3], c[4], c[5]])
            .collect();
        println!("loaded mesh and rays from {}", dir.display());
        return (
            TriangleMesh {
                positions,
                normals: None,
                uvs: None,
                grid: None,
                indices,
            },
            rays,
        );
    }
    let mesh = noisy_sphere::noisy_sphere(GRID);
    let rays = generate_rays(&mesh, rays);
    std::fs::create_dir_all(dir).expect("create bench data dir");
    write_f32(&v, mesh.positions.iter().flat_map(|p| p.to_array()));
    std::fs::write(
        &t,
        mesh.indices
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
    .expect("write triangles");
    write_f32(&r, rays.iter().flatten().copied());
    println!("generated mesh and rays into {}", dir.display());
    (mesh, rays)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Run `f` over all rays on `threads` threads; returns (Mrays per wall second, Mrays per CPU
/// second, result count).
fn trace(rays: &[[f32; 6]], threads: usize, f: impl Fn(&Ray) -> bool + Sync) -> (f64, f64, usize) {
    trace_chunks(rays, threads, |chunk| chunk.iter().filter(|r| f(r)).count())
}

/// Run `f` over chunks of 4096 rays on `threads` threads; `f` returns its chunk's result
/// count. Returns what [`trace`] returns.
fn trace_chunks(
    rays: &[[f32; 6]],
    threads: usize,
    f: impl Fn(&[Ray]) -> usize + Sync,
) -> (f64, f64, usize) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let cpu0 = process_cpu_seconds();
    let start = Instant::now();
    let hits: usize = pool.install(|| {
        rays.par_chunks(4096)
            .map(|chunk| {
                let rays: Vec<Ray> = chunk
                    .iter()
                    .map(|r| Ray::new(Vec3::new(r[0], r[1], r[2]), Vec3::new(r[3], r[4], r[5])))
                    .collect();
                f(&rays)
            })
            .sum()
    });
    let wall = start.elapsed().as_secs_f64();
    let cpu = match (cpu0, process_cpu_seconds()) {
        (Some(a), Some(b)) if b > a => b - a,
        _ => wall * threads as f64,
    };
    let m = rays.len() as f64 / 1e6;
    (m / wall, m / cpu, hits)
}

fn main() {
    let rays_n: usize = std::env::var("LODESTAR_BENCH_RAYS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2_000_000);
    let dir = std::env::var_os("LODESTAR_BENCH_DATA").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/bench-data"),
        PathBuf::from,
    );
    let (mesh, rays) = data(&dir, rays_n);
    let tris = mesh.indices.len();
    let shapes = vec![ShapeGeometry::Mesh(mesh)];

    let mut builds = Vec::new();
    let mut accel = None;
    for _ in 0..3 {
        let a = Accel::build(&shapes);
        builds.push(a.build_seconds);
        accel = Some(a);
    }
    let accel = accel.unwrap();
    println!(
        "bvh build: {tris} triangles, median {:.3} s over 3 builds",
        median(builds)
    );

    println!(
        "{:<10} {:>7} {:>12} {:>14} {:>10}",
        "query", "threads", "Mrays/s", "Mrays/CPU-s", "hit frac"
    );
    for threads in [1, 2] {
        let (mut closest, mut closest_cpu) = (Vec::new(), Vec::new());
        let (mut occl, mut occl_cpu) = (Vec::new(), Vec::new());
        let (mut many, mut many_cpu) = (Vec::new(), Vec::new());
        let (mut occl_many, mut occl_many_cpu) = (Vec::new(), Vec::new());
        let (mut hc, mut ho) = (0, 0);
        for _ in 0..3 {
            // The same rays through the interleaved traversal (`intersect_many`,
            // `unoccluded_many`): the same hits, checked below.
            let (m, c, h) = trace_chunks(&rays, threads, |chunk| {
                let mut out = Vec::new();
                accel.intersect_many(chunk, &shapes, &mut out);
                out.iter().filter(|h| h.is_some()).count()
            });
            many.push(m);
            many_cpu.push(c);
            let hm = h;
            let (m, c, h) = trace_chunks(&rays, threads, |chunk| {
                let segments: Vec<_> = chunk.iter().map(|r| (r.o, r.d, f32::INFINITY)).collect();
                let mut out = Vec::new();
                accel.unoccluded_many(&segments, &mut out);
                out.iter().filter(|&&u| !u).count()
            });
            occl_many.push(m);
            occl_many_cpu.push(c);
            let hom = h;
            let (m, c, h) = trace(&rays, threads, |r| accel.intersect(r, &shapes).is_some());
            closest.push(m);
            closest_cpu.push(c);
            hc = h;
            let (m, c, h) = trace(&rays, threads, |r| {
                !accel.unoccluded(r.o, r.d, f32::INFINITY)
            });
            occl.push(m);
            occl_cpu.push(c);
            ho = h;
            assert_eq!(
                (hc, ho),
                (hm, hom),
                "interleaved traversal found other hits"
            );
        }
        let n = rays.len() as f64;
        println!(
            "{:<10} {:>7} {:>12.3} {:>14.3} {:>10.6}",
            "closest",
            threads,
            median(closest),
            median(closest_cpu),
            hc as f64 / n
        );
        println!(
            "{:<10} {:>7} {:>12.3} {:>14.3} {:>10.6}",
            "occlusion",
            threads,
            median(occl),
            median(occl_cpu),
            ho as f64 / n
        );
        println!(
            "{:<10} {:>7} {:>12.3} {:>14.3} {:>10.6}",
            "closest*",
            threads,
            median(many),
            median(many_cpu),
            hc as f64 / n
        );
        println!(
            "{:<10} {:>7} {:>12.3} {:>14.3} {:>10.6}",
            "occlusion*",
            threads,
            median(occl_many),
            median(occl_many_cpu),
            ho as f64 / n
        );
    }
    println!(
        "(medians of 3 runs; * = {} rays interleaved per thread (`intersect_many`); compare \
         with benches/reference/embree_rays.py on the same files)",
        lodestar::geometry::INTERLEAVED_LANES
    );
}
