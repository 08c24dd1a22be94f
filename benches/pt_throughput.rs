//! Path-tracing throughput on the built-in Cornell box at max_depth 8: camera samples per
//! CPU-second, single-threaded (the figure compared with Mitsuba 3's `scalar_rgb` path
//! integrator by `benches/reference/mitsuba_cornell.py`) and on all threads.
//!
//! ```text
//! cargo bench --bench pt_throughput
//! ```
//! Environment: `LODESTAR_BENCH_SPP` (default 16).

use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::{Budget, RenderContext};
use lodestar::scene::Scene;

fn main() {
    let spp: u64 = std::env::var("LODESTAR_BENCH_SPP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(16);
    let scene = Scene::cornell_box();
    let pixels = scene.camera.pixel_count() as f64;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "{:<8} {:>7} {:>5} {:>10} {:>18} {:>14}",
        "scene", "threads", "spp", "seconds", "samples/CPU-s", "samples/s"
    );
    for threads in [1, cores] {
        let mut rates = Vec::new();
        let mut wall = Vec::new();
        for run in 0..3 {
            let mut pt = integrators::build(
                "pt",
                &IntegratorParams {
                    max_depth: 8,
                    options: Options::default(),
                },
            )
            .unwrap();
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let ctx = RenderContext {
                scene: &scene,
                seed: run,
                progress: false,
            };
            let r = pool.install(|| pt.render(&ctx, Budget::Spp(spp)));
            wall.push(r.seconds);
            rates.push(pixels * spp as f64 / (r.seconds * threads as f64));
        }
        rates.sort_by(f64::total_cmp);
        wall.sort_by(f64::total_cmp);
        let (rate, secs) = (rates[1], wall[1]);
        println!(
            "{:<8} {:>7} {:>5} {:>10.3} {:>18.0} {:>14.0}",
            "cornell",
            threads,
            spp,
            secs,
            rate,
            pixels * spp as f64 / secs
        );
    }
    println!("(medians of 3 runs; samples/CPU-s assumes the threads were busy the whole time)");
}
