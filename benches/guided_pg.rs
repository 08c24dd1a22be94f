//! Cost of the guided density `p_g(X)` against cache size, and bytes per guide path.
//!
//! Guide-path caches of 1k, 10k and 100k paths are installed from paths pt forms in the pool
//! scene (the structures and spatial spread of real caches; equal weights), then `p_g` is
//! evaluated for the same fixed set of pt paths against each. Prints CPU nanoseconds per
//! evaluation (the query of the path's structure's BVH over first-vertex kernels, the exact
//! first-vertex test of each box it yields, and the products of every surviving candidate;
//! paths whose structure the cache does not hold cost a hash lookup and are counted too), the
//! mean number of candidates (guides whose first-vertex kernel holds x_1), and the bytes per
//! guide path for path lengths 3 to 8.
//!
//! Then the cost of guiding BDPT: CPU nanoseconds per BDPT sample (one camera and one light
//! subpath, every connection) plain, in recording mode with an empty cache (the sink's
//! overhead alone), and with the 10k cache (p_g of every path whose structure the cache
//! holds), once querying the first-vertex BVH for every such path and once per distinct x_1
//! and structure (every technique with t >= 2 shares the camera ray's hit): p_g evaluations,
//! BVH queries and candidates per sample.
//!
//! ```text
//! cargo bench --bench guided_pg
//! ```
//! Environment: `LODESTAR_BENCH_SCENE` (default scenes/pool.toml).

use lodestar::integrators::bdpt::{BdptSettings, BdptUnguided, Tracer};
use lodestar::integrators::guided::Estimator;
use lodestar::integrators::guided::cache::{GuideCache, Install};
use lodestar::integrators::guided::collector::Collector;
use lodestar::integrators::guided::estimator::RowOutput;
use lodestar::integrators::guided::kernel;
use lodestar::integrators::paths::{self, Heuristic};
use lodestar::integrators::pt::{PathRecorder, PathTracer, PtSettings};
use lodestar::math::{IndependentSampler, Sampler, luminance};
use lodestar::path::{MAX_VERTICES, Path};
use lodestar::render::process_cpu_seconds;
use lodestar::scene::{Scene, loader};

struct Keep(Vec<Install>);

impl PathRecorder for Keep {
    fn record(&mut self, path: &Path, _: glam::DVec3, _: usize, density: f64, other: f64) {
        if path.segments() >= 2 && path.f != glam::Vec3::ZERO {
            self.0.push((
                path.vertices().to_vec(),
                luminance(path.f) as f64,
                density + other,
                1.0,
                0,
            ));
        }
    }
}

fn pt_paths(scene: &Scene, want: usize, seed: u64) -> Vec<Install> {
    let pt = PathTracer {
        settings: PtSettings::default(),
    };
    let mut keep = Keep(Vec::new());
    let res = scene.camera.resolution;
    let mut i = 0u64;
    while keep.0.len() < want {
        // Raster positions uniform over the image (in scan order, the first 1k paths would
        // all come from the top rows).
        let mut s = IndependentSampler::new(seed, 0, i);
        let raster = s.next_2d() * glam::Vec2::new(res.x as f32, res.y as f32);
        pt.li_recorded(scene, raster, &mut s, Some(&mut keep));
        i += 1;
    }
    keep.0.truncate(want);
    keep.0
}

fn main() {
    let file = std::env::var("LODESTAR_BENCH_SCENE").unwrap_or("scenes/pool.toml".into());
    let scene = loader::load_file(std::path::Path::new(&file)).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2)
    });
    let all = pt_paths(&scene, 100_000, 1);
    let queries: Vec<Path> = pt_paths(&scene, 20_000, 2)
        .into_iter()
        .map(|(v, ..)| {
            let mut p = Path::default();
            for x in v {
                p.push(x);
            }
            p
        })
        .collect();
    let prepared: Vec<_> = queries
        .iter()
        .filter_map(|p| {
            let y = paths::from_path(&scene, p)?;
            let (sig, nodes) = kernel::structure(&scene, p, MAX_VERTICES)?;
            Some((y, sig, nodes))
        })
        .collect();
    println!("scene {file}: {} query paths", prepared.len());
    println!(
        "{:>8} {:>12} {:>14} {:>12} {:>10}",
        "guides", "build s", "ns per p_g", "candidates", "p_g > 0"
    );
    for n in [1_000usize, 10_000, 100_000] {
        let mut installs: Vec<Install> = all.iter().take(n).cloned().collect();
        for e in &mut installs {
            e.3 = 1.0 / n as f64;
        }
        let t0 = process_cpu_seconds().unwrap_or(0.0);
        let mut cache = GuideCache::default();
        cache.install(&scene, installs, 20);
        let build = process_cpu_seconds().unwrap_or(0.0) - t0;
        let mut scratch = Vec::new();
        let (mut candidates, mut nonzero, mut sink) = (0usize, 0usize, 0.0f64);
        let rounds = 3;
        let t1 = process_cpu_seconds().unwrap_or(0.0);
        for _ in 0..rounds {
            for (y, sig, nodes) in &prepared {
                let (p, c) = cache.pdf(&scene, y, *sig, nodes, &mut scratch);
                candidates += c;
                nonzero += (p > 0.0) as usize;
                sink += p;
            }
        }
        let secs = process_cpu_seconds().unwrap_or(0.0) - t1;
        let evals = (rounds * prepared.len()) as f64;
        println!(
            "{:>8} {:>12.2} {:>14.0} {:>12.2} {:>10.3}   (checksum {sink:.3e})",
            cache.len(),
            build,
            secs * 1e9 / evals,
            candidates as f64 / evals,
            nonzero as f64 / evals
        );
    }
    println!("bytes per guide path by length (vertices incl. camera):");
    for len in 3..=8 {
        println!("  {len}: {}", GuideCache::bytes_for_length(len));
    }
    bdpt_cost(&scene, &all);
}

/// CPU ns per BDPT sample: plain, recording without and with a 10k cache (BVH per path or
/// per x_1).
fn bdpt_cost(scene: &Scene, all: &[Install]) {
    let settings = BdptSettings {
        max_depth: 8,
        rr_depth: 5,
        heuristic: Heuristic::Balance,
        light_tracing: false,
        techniques: Default::default(),
        direct_splats: false,
    };
    let u = BdptUnguided {
        settings: settings.clone(),
    };
    let n = 10_000usize;
    let mut installs: Vec<Install> = all.iter().take(n).cloned().collect();
    for e in &mut installs {
        e.3 = 1.0 / n as f64;
    }
    let mut cache = GuideCache::default();
    cache.install(scene, installs, 20);
    let empty = GuideCache::default();
    let res = scene.camera.resolution;
    let samples = 40_000u64;
    let raster =
        |s: &mut IndependentSampler| s.next_2d() * glam::Vec2::new(res.x as f32, res.y as f32);
    println!("BDPT samples ({samples}, max_depth 8), CPU ns per sample:");
    // Plain BDPT.
    let mut tracer = Tracer::new(scene, &settings);
    let t0 = process_cpu_seconds().unwrap_or(0.0);
    let mut sink = glam::Vec3::ZERO;
    for i in 0..samples {
        let mut s = IndependentSampler::new(3, 0, i);
        let r = raster(&mut s);
        sink += tracer.sample(r, &mut s);
        tracer.splats.clear();
    }
    let plain = process_cpu_seconds().unwrap_or(0.0) - t0;
    println!(
        "  {:<34} {:>8.0}   (checksum {:.3e})",
        "plain bdpt",
        plain * 1e9 / samples as f64,
        sink.x
    );
    for (label, cache, no_reuse) in [
        ("recording, empty cache", &empty, false),
        ("10k guides, BVH query per path", &cache, true),
        ("10k guides, BVH query per x_1", &cache, false),
    ] {
        let est = Estimator::new(scene, &u, (), cache, 0.5);
        let mut out = RowOutput::default();
        out.candidates.no_reuse = no_reuse;
        let mut tracer = Tracer::new(scene, &settings);
        let t0 = process_cpu_seconds().unwrap_or(0.0);
        let mut sum = glam::DVec3::ZERO;
        for i in 0..samples {
            let mut s = IndependentSampler::new(3, 0, i);
            let r = raster(&mut s);
            let mut col = Collector {
                est: &est,
                sum: glam::DVec3::ZERO,
                grid: Default::default(),
                u_sum: glam::DVec3::ZERO,
                class_sum: Default::default(),
                classes: true,
                own_image: false,
                learning: false,
                measuring: false,
                source: lodestar::integrators::guided::seeder::Source::Guided,
                out: &mut out,
            };
            tracer.sample_recorded(r, &mut s, &mut col);
            sum += col.sum;
        }
        let secs = process_cpu_seconds().unwrap_or(0.0) - t0;
        let st = &out.stats;
        println!(
            "  {:<34} {:>8.0}   p_g evaluations {:.3}, BVH queries {:.3}, candidates {:.1} per sample (checksum {:.3e})",
            label,
            secs * 1e9 / samples as f64,
            st.pg_evaluations as f64 / samples as f64,
            st.bvh_queries as f64 / samples as f64,
            st.pg_candidates as f64 / samples as f64,
            sum.x
        );
    }
}
