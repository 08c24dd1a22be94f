//! An integrator outside the crate (`integrator.rs`): registered by name, rendered alone and
//! guided.
//!
//! ```text
//! cargo run --release --example bsdf_pt -- [SCENE.toml] [SPP]
//! ```
//!
//! renders SCENE (default: the built-in Cornell box) with `bsdf-pt` and `guided-bsdf-pt` at
//! SPP samples per pixel (default 16) and writes `bsdf-pt.exr` and `guided-bsdf-pt.exr`.

mod integrator;

use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::Budget;
use lodestar::scene::{Scene, loader};
use std::path::Path;
use std::process::ExitCode;

fn run() -> lodestar::Result<()> {
    integrator::register()?;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = match args.first() {
        Some(p) => loader::load_file(Path::new(p))?,
        None => Scene::cornell_box(),
    };
    let spp = match args.get(1) {
        Some(s) => s
            .parse()
            .map_err(|_| lodestar::Error::new(format!("SPP: expected an integer, got '{s}'")))?,
        None => 16,
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    for name in ["bsdf-pt", "guided-bsdf-pt"] {
        let params = IntegratorParams {
            max_depth: scene.render.max_depth,
            options: Options::parse(&[])?,
        };
        let r =
            integrators::render_named(&scene, name, &params, Budget::Spp(spp), 0, threads, true)?;
        let out = format!("{name}.exr");
        r.result.image.write_exr(Path::new(&out), &[])?;
        println!(
            "{name}: {} spp in {:.2} s, mean {:.4} -> {out}",
            r.result.spp,
            r.result.seconds,
            r.result.image.mean().element_sum() / 3.0
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
