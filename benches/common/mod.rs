//! Shared by the iteration benchmarks: the scene SmallVCM's BPT and VCM are timed on.

use lodestar::scene::{CORNELL_BOX_TOML, Scene, loader};

/// The Cornell box at 512 x 512 with the tall box a mirror (reflectance 0.95) and the glass
/// sphere, lit by its area light.
pub fn cornell_mirror_512() -> Scene {
    let text = CORNELL_BOX_TOML
        .replace("resolution = [256, 256]", "resolution = [512, 512]")
        .replace(
            "name = \"black\"\ntype = \"black\"",
            "name = \"black\"\ntype = \"black\"\n\n[[material]]\nname = \"mirror\"\ntype = \"conductor\"\nreflectance = [0.95, 0.95, 0.95]",
        )
        .replace(
            "type = \"cube\"\nmaterial = \"white\"",
            "type = \"cube\"\nmaterial = \"mirror\"",
        );
    let scene = loader::load_str(&text, "cornell-mirror-512", None).unwrap();
    assert!(scene.features.specular_surfaces);
    scene
}

/// `LODESTAR_BENCH_ITERATIONS` (default 2).
pub fn iterations() -> u64 {
    std::env::var("LODESTAR_BENCH_ITERATIONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2)
}

/// Render `iterations` passes of integrator `name` with `options` (`key=value`) at most 10
/// segments on `threads` threads: (CPU-seconds, wall-seconds) per iteration.
pub fn time_iterations(
    scene: &Scene,
    name: &str,
    options: &[&str],
    iterations: u64,
    threads: usize,
) -> lodestar::error::Result<(f64, f64)> {
    use lodestar::integrators::{self, IntegratorParams, Options};
    let options: Vec<String> = options.iter().map(|s| s.to_string()).collect();
    let params = IntegratorParams {
        max_depth: 10,
        options: Options::parse(&options)?,
    };
    let run = integrators::render_named(
        scene,
        name,
        &params,
        lodestar::render::Budget::Spp(iterations),
        1,
        threads,
        false,
    )?;
    let n = iterations as f64;
    Ok((run.cpu_seconds / n, run.result.seconds / n))
}
