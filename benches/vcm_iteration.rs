//! VCM cost per iteration (N = 512 x 512 light subpaths stored, a hash grid, one camera path
//! per pixel connected and merged) in CPU-seconds, on the Cornell box at 512 x 512 with the
//! tall box a mirror and the glass sphere, at most 10 segments: the configuration SmallVCM's
//! VCM is timed on (about 2.2 CPU-seconds per iteration on these machines; its BPT about 1.3).
//! Also `vcm -O merge=false` (VCM's BDPT), `bpm`, and `bdpt` for scale; the default radius
//! (0.003 x the scene's bounding-sphere radius, about 0.26 % of the box edge, as SmallVCM).
//!
//! ```text
//! cargo bench --bench vcm_iteration
//! ```
//! Environment: `LODESTAR_BENCH_ITERATIONS` (default 2).

mod common;

use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::Budget;

fn main() {
    let iterations: u64 = std::env::var("LODESTAR_BENCH_ITERATIONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2);
    let scene = common::cornell_mirror_512();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "{:<16} {:>7} {:>11} {:>16} {:>12}",
        "integrator", "threads", "iterations", "CPU-s/iteration", "wall-s/iter"
    );
    let runs: [(&str, &[&str]); 4] = [
        ("vcm", &[]),
        ("vcm", &["merge=false"]),
        ("bpm", &[]),
        ("bdpt", &["rr_depth=1"]),
    ];
    for (name, opts) in runs {
        for threads in [1, cores] {
            let options = opts.iter().map(|s| s.to_string()).collect::<Vec<_>>();
            let params = IntegratorParams {
                max_depth: 10,
                options: Options::parse(&options).unwrap(),
            };
            let run = integrators::render_named(
                &scene,
                name,
                &params,
                Budget::Spp(iterations),
                1,
                threads,
                false,
            )
            .unwrap();
            let (r, cpu) = (run.result, run.cpu_seconds);
            let label = format!("{name} {}", opts.join(" "));
            println!(
                "{:<16} {:>7} {:>11} {:>16.3} {:>12.3}",
                label.trim(),
                threads,
                iterations,
                cpu / iterations as f64,
                r.seconds / iterations as f64
            );
        }
    }
}
