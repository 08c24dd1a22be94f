//! Equal-time comparison of every registered integrator (the first registry entry, `pt`, is
//! the speed-up baseline) on a short fixed set of scenes, through the same code as
//! `lodestar bench`; prints one table per scene and writes the full report (CSV, plot, images,
//! `index.html`) to `target/equal_time/<scene>/`.
//!
//! ```text
//! cargo bench --bench equal_time
//! ```
//!
//! | variable | default | meaning |
//! |---|---|---|
//! | `LODESTAR_BENCH_SECONDS` | 2 | wall-clock seconds per render |
//! | `LODESTAR_BENCH_RUNS` | 1 | seeds per integrator (medians reported) |
//! | `LODESTAR_BENCH_REFERENCE_SPP` | 1024 | spp of a reference rendered with `pt` when the scene has none |
//!
//! A scene's reference is `scenes/references/<scene>.exr` when it exists; otherwise one is
//! rendered once and kept as `target/equal_time/<scene>.reference-<spp>spp.exr`, rendered
//! again when the scene file is newer.

use lodestar::bench::{self, BenchConfig};
use lodestar::film::Image;
use lodestar::integrators::{self, IntegratorParams, Options, REGISTRY};
use lodestar::render::Budget;
use lodestar::scene::loader;
use std::path::{Path, PathBuf};

const SCENES: [&str; 2] = ["cornell-box", "cornell-glossy"];

fn env<T: std::str::FromStr>(key: &str, default: T) -> T {
    std::env::var(key)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let seconds: f64 = env("LODESTAR_BENCH_SECONDS", 2.0);
    let runs: u32 = env("LODESTAR_BENCH_RUNS", 1);
    let reference_spp: u64 = env("LODESTAR_BENCH_REFERENCE_SPP", 1024);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out_root = root.join("target/equal_time");
    std::fs::create_dir_all(&out_root).expect("cannot create target/equal_time");
    let names: Vec<String> = REGISTRY.iter().map(|e| e.name.to_string()).collect();
    for stem in SCENES {
        let scene_file = root.join(format!("scenes/{stem}.toml"));
        let reference = reference_for(&scene_file, &out_root, stem, reference_spp, threads);
        let config = BenchConfig {
            scene: scene_file,
            defines: Vec::new(),
            integrators: names.clone(),
            seconds,
            reference,
            runs,
            seed: 0,
            out: out_root.join(stem),
            threads,
            max_depth: None,
            crop: None,
            exposure: 0.0,
            verbose: false,
            splat_film: false,
        };
        let prepared = bench::prepare(config).unwrap_or_else(|e| panic!("{stem}: {e}"));
        let report = bench::bench(&prepared).unwrap_or_else(|e| panic!("{stem}: {e}"));
        print!("{}", report.table);
        println!("({})\n", prepared.config.out.join("index.html").display());
    }
    println!("{seconds} s per render, {runs} run(s), {threads} threads; medians over runs");
}

/// The scene's shipped reference, or a cached `pt` render of `spp` samples per pixel.
fn reference_for(scene: &Path, out_root: &Path, stem: &str, spp: u64, threads: usize) -> PathBuf {
    let shipped = scene.with_file_name(format!("references/{stem}.exr"));
    if shipped.is_file() {
        return shipped;
    }
    let cached = out_root.join(format!("{stem}.reference-{spp}spp.exr"));
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    if cached.is_file() && modified(&cached) >= modified(scene) {
        return cached;
    }
    eprintln!(
        "rendering a {spp} spp reference of {stem} (kept in {})",
        cached.display()
    );
    let s = loader::load_file(scene).unwrap_or_else(|e| panic!("{e}"));
    let params = IntegratorParams {
        max_depth: s.render.max_depth,
        options: Options::default(),
    };
    let run = integrators::render_named(&s, "pt", &params, Budget::Spp(spp), 7919, threads, false)
        .unwrap_or_else(|e| panic!("{e}"));
    let image: &Image = &run.result.image;
    image
        .write_exr(&cached, &[("spp".to_string(), spp.to_string())])
        .unwrap_or_else(|e| panic!("{e}"));
    cached
}
