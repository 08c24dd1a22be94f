//! The `lodestar` command line: render, compare, info, integrators.

use clap::{Parser, Subcommand};
use lodestar::error::{Error, Result};
use lodestar::film::Image;
use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::path::MAX_VERTICES;
use lodestar::render::Budget;
use lodestar::scene::{Scene, loader};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "lodestar",
    version,
    about = "A research renderer: path tracing and guided sampling with complete paths"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (the built-in Cornell box when no scene is given).
    Render(RenderArgs),
    /// Compare two EXR images: per-channel means, MSE, RMSE and relMSE (B is the reference).
    Compare { a: PathBuf, b: PathBuf },
    /// Print a scene's counts and features.
    Info { scene: PathBuf },
    /// List the registered integrators.
    Integrators,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (TOML); omit for the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Integrator name (see `lodestar integrators`); default: the scene's, else pt.
    #[arg(long)]
    integrator: Option<String>,
    /// Samples per pixel (passes); default: the scene's.
    #[arg(long, conflicts_with = "time", allow_negative_numbers = true)]
    spp: Option<u64>,
    /// Wall-clock budget in seconds instead of --spp.
    #[arg(long, allow_negative_numbers = true)]
    time: Option<f64>,
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    seed: u64,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, allow_negative_numbers = true)]
    threads: Option<usize>,
    /// Maximum number of path segments; default: the scene's.
    #[arg(long, allow_negative_numbers = true)]
    max_depth: Option<u32>,
    /// Output EXR (default: <scene name>.exr).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Also write an sRGB PNG preview.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Exposure of the PNG preview in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Integrator option key=value (repeatable), e.g. -O strategy=nee.
    #[arg(short = 'O', long = "option")]
    options: Vec<String>,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

fn main() -> ExitCode {
    std::panic::set_hook(Box::new(|info| {
        eprintln!("lodestar: internal error (a bug, please report it): {info}");
    }));
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                let _ = e.print();
                return if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                    ExitCode::from(2)
                } else {
                    ExitCode::SUCCESS
                };
            }
            // One line: clap's first paragraph (the message and e.g. the missing arguments
            // listed under it), without its tips and usage block.
            let text = e.render().to_string();
            let first: Vec<&str> = text
                .lines()
                .map(str::trim)
                .take_while(|l| !l.is_empty())
                .collect();
            let first = first.join(" ");
            let first = first.trim_start_matches("error: ");
            let first = if first.is_empty() {
                "invalid arguments"
            } else {
                first
            };
            eprintln!("lodestar: {first} (see lodestar --help)");
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Compare { a, b } => compare(&a, &b),
        Command::Info { scene } => info(&scene),
        Command::Integrators => {
            for e in integrators::REGISTRY {
                println!("{:<8} {}", e.name, e.summary);
            }
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lodestar: {e}");
            ExitCode::FAILURE
        }
    }
}

fn load_scene(path: Option<&Path>) -> Result<Scene> {
    match path {
        Some(p) => loader::load_file(p),
        None => Ok(Scene::cornell_box()),
    }
}

fn render(args: RenderArgs) -> Result<()> {
    if let Some(t) = args.time
        && !(t.is_finite() && t > 0.0)
    {
        return Err(Error::new(format!(
            "--time must be a positive number of seconds, got {t}"
        )));
    }
    if args.spp == Some(0) {
        return Err(Error::new("--spp must be at least 1"));
    }
    if args.threads == Some(0) {
        return Err(Error::new("--threads must be at least 1"));
    }
    if let Some(d) = args.max_depth
        && (d == 0 || d as usize >= MAX_VERTICES)
    {
        return Err(Error::new(format!(
            "--max-depth must be in [1, {}], got {d}",
            MAX_VERTICES - 1
        )));
    }
    if !args.exposure.is_finite() {
        return Err(Error::new("--exposure must be a finite number"));
    }
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = args
            .scene
            .as_ref()
            .and_then(|p| p.file_stem())
            .map_or("cornell-box".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from(format!("{stem}.exr"))
    });
    // Fail before a long render, not after it.
    for path in std::iter::once(&output).chain(&args.png) {
        lodestar::film::output_dir(path)?;
    }
    let scene = load_scene(args.scene.as_deref())?;
    let name = args
        .integrator
        .clone()
        .unwrap_or_else(|| scene.render.integrator.clone());
    let params = IntegratorParams {
        max_depth: args.max_depth.unwrap_or(scene.render.max_depth),
        options: Options::parse(&args.options)?,
    };
    let budget = match (args.spp, args.time) {
        (_, Some(t)) => Budget::Seconds(t),
        (Some(n), None) => Budget::Spp(n),
        (None, None) => Budget::Spp(scene.render.spp as u64),
    };
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let run = integrators::render_named(
        &scene,
        &name,
        &params,
        budget,
        args.seed,
        threads,
        !args.quiet,
    )?;
    let result = &run.result;

    let mut meta = vec![
        ("integrator".to_string(), run.name.to_string()),
        ("settings".to_string(), run.settings.clone()),
        ("scene".to_string(), scene.source.clone()),
        ("spp".to_string(), result.spp.to_string()),
        ("passes".to_string(), result.passes.to_string()),
        ("seconds".to_string(), format!("{:.3}", result.seconds)),
        ("seed".to_string(), args.seed.to_string()),
        ("threads".to_string(), threads.to_string()),
    ];
    meta.extend(result.stats.iter().cloned());
    result.image.write_exr(&output, &meta)?;
    if let Some(png) = &args.png {
        result.image.write_png(png, args.exposure)?;
    }
    let m = result.image.mean();
    eprintln!(
        "{}: {} spp in {:.2} s with {} ({} threads) -> {}; mean rgb ({:.5}, {:.5}, {:.5})",
        scene.source,
        result.spp,
        result.seconds,
        run.name,
        threads,
        output.display(),
        m.x,
        m.y,
        m.z
    );
    Ok(())
}

fn compare(a: &Path, b: &Path) -> Result<()> {
    let (ia, _) = Image::read_exr(a)?;
    let (ib, _) = Image::read_exr(b)?;
    let c = lodestar::metrics::compare(&ia, &ib)
        .map_err(|e| e.context(format!("{} vs {}", a.display(), b.display())))?;
    println!(
        "mean A  {:.6} {:.6} {:.6}",
        c.mean_a.x, c.mean_a.y, c.mean_a.z
    );
    println!(
        "mean B  {:.6} {:.6} {:.6}",
        c.mean_b.x, c.mean_b.y, c.mean_b.z
    );
    println!("MSE     {:.6e}", c.mse);
    println!("RMSE    {:.6e}", c.rmse);
    println!("relMSE  {:.6e}", c.rel_mse);
    Ok(())
}

fn info(path: &Path) -> Result<()> {
    let s = loader::load_file(path)?;
    let r = s.camera.resolution;
    println!("scene       {}", s.source);
    println!("resolution  {} x {}", r.x, r.y);
    println!(
        "shapes      {} ({} triangles, {} spheres)",
        s.shapes.len(),
        s.triangle_count(),
        s.sphere_count()
    );
    println!("lights      {}", s.lights.len());
    println!("materials   {}", s.materials.len());
    println!("features    {}", s.features);
    println!(
        "defaults    integrator {}, max_depth {}, spp {}",
        s.render.integrator, s.render.max_depth, s.render.spp
    );
    Ok(())
}
