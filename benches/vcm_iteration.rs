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

fn main() {
    let iterations = common::iterations();
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
            let (cpu, wall) = common::time_iterations(&scene, name, opts, iterations, threads)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let label = format!("{name} {}", opts.join(" "));
            println!(
                "{:<16} {:>7} {:>11} {:>16.3} {:>12.3}",
                label.trim(),
                threads,
                iterations,
                cpu,
                wall
            );
        }
    }
}
