//! Batched pt (`pt -O batch=on`) against pt one path at a time (`batch=off`) on scenes whose
//! BVH grows past the caches: the Cornell box's walls and light around a noisy sphere of 49k
//! to 1M triangles (`noisy_sphere.rs`, written as a binary PLY into
//! `target/bench-data/pt-batch/`), 128 x 128, max_depth 8, one thread. Camera samples per
//! CPU-second, medians of interleaved rounds; the two images must be equal bit for bit (the
//! bench stops otherwise). `batch=auto` picks the batched tracer from `BATCH_MIN_BYTES` up.
//!
//! ```text
//! cargo bench --bench pt_batch
//! ```
//! Environment: `LODESTAR_BENCH_SPP` (default 16), `LODESTAR_BENCH_ROUNDS` (default 3).

use lodestar::geometry::TriangleMesh;
use lodestar::geometry::interleaved::BATCH_MIN_BYTES;
use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::Budget;
use lodestar::scene::{Scene, loader};
use std::io::Write;
use std::path::Path;

#[path = "common/noisy_sphere.rs"]
mod noisy_sphere;

fn env(key: &str, default: u64) -> u64 {
    std::env::var(key)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// `mesh` as a binary little-endian PLY.
fn write_ply(path: &Path, mesh: &TriangleMesh) {
    let mut out = Vec::new();
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.indices.len()
    )
    .unwrap();
    for p in &mesh.positions {
        out.extend(p.to_array().iter().flat_map(|c| c.to_le_bytes()));
    }
    for t in &mesh.indices {
        out.push(3);
        out.extend(t.iter().flat_map(|&i| (i as i32).to_le_bytes()));
    }
    std::fs::write(path, out).expect("write the bench mesh");
}

/// The built-in Cornell box with its tall box and glass sphere replaced by `ply`.
fn scene(ply: &Path) -> Scene {
    let mut text = lodestar::scene::CORNELL_BOX_TOML.replace("[256, 256]", "[128, 128]");
    let cut = text
        .find("[[shape]]\nname = \"tall box\"")
        .expect("the box's shapes");
    text.truncate(cut);
    text += &format!(
        "[[shape]]\nname = \"noisy sphere\"\ntype = \"ply\"\nfile = \"{}\"\nmaterial = \"white\"\n\
         transform = {{ scale = 0.8, translate = [0, -0.15, 0] }}\n",
        ply.display()
    );
    loader::load_str(&text, "pt_batch scene", None).expect("the bench scene loads")
}

fn main() {
    let spp = env("LODESTAR_BENCH_SPP", 16);
    let rounds = env("LODESTAR_BENCH_ROUNDS", 3) as usize;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench-data/pt-batch");
    std::fs::create_dir_all(&dir).expect("create the bench data directory");
    println!(
        "{:>10} {:>8} {:>6} {:>16} {:>16} {:>7}",
        "triangles", "BVH MB", "auto", "off samples/CPU-s", "on samples/CPU-s", "on/off"
    );
    for grid in [64, 100, 160, 289] {
        let ply = dir.join(format!("noisy-sphere-{grid}.ply"));
        let mesh = noisy_sphere::noisy_sphere(grid);
        if !ply.is_file() {
            write_ply(&ply, &mesh);
        }
        let scene = scene(&ply);
        let pixels = scene.camera.pixel_count() as f64 * spp as f64;
        let (mut rates, mut images) = ([Vec::new(), Vec::new()], [None, None]);
        for round in 0..rounds {
            for (k, mode) in ["off", "on"].into_iter().enumerate() {
                let params = IntegratorParams {
                    max_depth: 8,
                    options: Options::parse(&[format!("batch={mode}")]).unwrap(),
                };
                let run = integrators::render_named(
                    &scene,
                    "pt",
                    &params,
                    Budget::Spp(spp),
                    round as u64,
                    1,
                    false,
                )
                .unwrap();
                rates[k].push(pixels / run.cpu_seconds);
                if round == 0 {
                    images[k] = Some(run.result.image);
                }
            }
        }
        assert!(
            images[0] == images[1],
            "batched pt differs from pt on {grid}"
        );
        let [off, on] = rates.map(|mut r| {
            r.sort_by(f64::total_cmp);
            r[r.len() / 2]
        });
        println!(
            "{:>10} {:>8.1} {:>6} {:>16.0} {:>16.0} {:>7.2}",
            mesh.indices.len(),
            scene.accel.bvh_bytes() as f64 / (1 << 20) as f64,
            if scene.accel.batches_pay() {
                "on"
            } else {
                "off"
            },
            off,
            on,
            on / off
        );
    }
    println!(
        "(medians of {rounds} interleaved rounds, {spp} spp, one thread; auto batches from {} MB)",
        BATCH_MIN_BYTES >> 20
    );
}
