//! Path-tracing throughput at max_depth 8: camera samples per CPU-second (process CPU time, so
//! the figure holds on a shared machine), single-threaded and on all threads, on the built-in
//! Cornell box (the figure compared with Mitsuba 3's `scalar_rgb` path integrator by
//! `benches/reference/mitsuba_cornell.py`), the glossy box and the fog box.
//!
//! ```text
//! cargo bench --bench pt_throughput
//! ```
//! Environment: `LODESTAR_BENCH_SPP` (default 16).

use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::Budget;
use lodestar::scene::{Scene, loader};

fn main() {
    let spp: u64 = std::env::var("LODESTAR_BENCH_SPP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(16);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/");
    let scenes = [
        ("cornell", Scene::cornell_box()),
        (
            "glossy",
            loader::load_file(std::path::Path::new(&format!("{dir}cornell-glossy.toml"))).unwrap(),
        ),
        (
            "fog",
            loader::load_file(std::path::Path::new(&format!("{dir}cornell-fog.toml"))).unwrap(),
        ),
    ];
    println!(
        "{:<8} {:>7} {:>5} {:>10} {:>18} {:>14}",
        "scene", "threads", "spp", "wall s", "samples/CPU-s", "samples/s"
    );
    for (name, scene) in &scenes {
        let pixels = scene.camera.pixel_count() as f64;
        for threads in [1, cores] {
            let (mut rates, mut walls) = (Vec::new(), Vec::new());
            for run in 0..3 {
                let params = IntegratorParams {
                    max_depth: 8,
                    options: Options::default(),
                };
                let run = integrators::render_named(
                    scene,
                    "pt",
                    &params,
                    Budget::Spp(spp),
                    run,
                    threads,
                    false,
                )
                .unwrap();
                let (r, cpu) = (run.result, run.cpu_seconds);
                walls.push(r.seconds);
                rates.push(pixels * spp as f64 / cpu);
            }
            rates.sort_by(f64::total_cmp);
            walls.sort_by(f64::total_cmp);
            println!(
                "{:<8} {:>7} {:>5} {:>10.3} {:>18.0} {:>14.0}",
                name,
                threads,
                spp,
                walls[1],
                rates[1],
                pixels * spp as f64 / walls[1]
            );
        }
    }
    println!("(medians of 3 runs)");
}
