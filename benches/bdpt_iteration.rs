//! BDPT cost per iteration (a camera and a light subpath per pixel) in CPU-seconds, on the
//! Cornell box at 512 x 512 with the tall box a mirror and the glass sphere, at most 10
//! segments: the configuration SmallVCM's BPT is timed on (about 1.3 CPU-seconds per
//! iteration on these machines). Also pt and lt on the same scene for scale.
//!
//! ```text
//! cargo bench --bench bdpt_iteration
//! ```
//! Environment: `LODESTAR_BENCH_ITERATIONS` (default 2); `LODESTAR_BENCH_INTEGRATORS`, a
//! comma-separated subset of `bdpt,pt,lt` (default all three); `LODESTAR_BENCH_THREADS`, a
//! comma-separated list of thread counts (default `1,<cores>`).

mod common;

fn main() {
    let iterations = common::iterations();
    let scene = common::cornell_mirror_512();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let list = |key: &str, default: String| std::env::var(key).unwrap_or(default);
    let names = list("LODESTAR_BENCH_INTEGRATORS", "bdpt,pt,lt".to_string());
    let thread_counts: Vec<usize> = list("LODESTAR_BENCH_THREADS", format!("1,{cores}"))
        .split(',')
        .map(|s| match s.trim().parse() {
            Ok(n) if n >= 1 => n,
            _ => {
                eprintln!(
                    "LODESTAR_BENCH_THREADS: expected comma-separated integers >= 1, got '{s}'"
                );
                std::process::exit(2);
            }
        })
        .collect();
    println!(
        "{:<6} {:>7} {:>11} {:>16} {:>12}",
        "integr", "threads", "iterations", "CPU-s/iteration", "wall-s/iter"
    );
    for name in names.split(',').map(str::trim) {
        for &threads in &thread_counts {
            let (cpu, wall) = common::time_iterations(&scene, name, &[], iterations, threads)
                .unwrap_or_else(|e| {
                    eprintln!("LODESTAR_BENCH_INTEGRATORS: {e}");
                    std::process::exit(2);
                });
            println!(
                "{:<6} {:>7} {:>11} {:>16.3} {:>12.3}",
                name, threads, iterations, cpu, wall
            );
        }
    }
}
