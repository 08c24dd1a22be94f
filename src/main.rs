//! The `lodestar` command line: render (with snapshots), bench, compare, info, integrators.

#[macro_use]
mod stdout;
mod cli_bench;
mod cli_render;

use clap::{Parser, Subcommand};
use lodestar::error::{Error, Result};
use lodestar::film::Image;
use lodestar::integrators;
use lodestar::metrics::Crop;
use lodestar::path::{depth_label, parse_max_depth};
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
    Render(Box<cli_render::RenderArgs>),
    /// Equal-time comparison of integrators against a reference: table, CSV, plot, HTML.
    Bench(Box<cli_bench::BenchArgs>),
    /// Compare two EXR images: per-channel means, MSE, RMSE and relMSE (B is the reference).
    Compare {
        a: PathBuf,
        b: PathBuf,
        /// Only the pixels [x0, x1) x [y0, y1).
        #[arg(long, value_name = "x0,y0,x1,y1")]
        crop: Option<String>,
    },
    /// Merge the parts of one render (`render --part I/N`) into its image, weighting each part
    /// by its passes; refuses parts of different renders or a missing or repeated slice.
    Merge {
        /// The parts' EXRs, in any order.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output EXR.
        #[arg(short, long)]
        output: PathBuf,
        /// Also write an sRGB PNG preview.
        #[arg(long)]
        png: Option<PathBuf>,
        /// Exposure of the PNG preview in stops.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        exposure: f32,
    },
    /// Print a scene's counts and features.
    Info {
        scene: PathBuf,
        /// Mitsuba XML scenes: set parameter `$name` (overrides its <default>), repeatable.
        #[arg(short = 'D', long = "define", value_name = "NAME=VALUE")]
        defines: Vec<String>,
    },
    /// List the registered integrators.
    Integrators {
        /// Also list each integrator's options (`-O key=value`) with their defaults.
        #[arg(long)]
        options: bool,
        /// Print docs/integrators.md: every integrator with its option table.
        #[arg(long, conflicts_with = "options")]
        markdown: bool,
    },
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
        Command::Render(args) => cli_render::render(*args),
        Command::Bench(args) => cli_bench::bench(*args),
        Command::Compare { a, b, crop } => compare(&a, &b, crop.as_deref()),
        Command::Merge {
            parts,
            output,
            png,
            exposure,
        } => merge(&parts, &output, png.as_deref(), exposure),
        Command::Info { scene, defines } => info(&scene, &defines),
        Command::Integrators { options, markdown } => {
            let entries = integrators::entries();
            if markdown {
                out!("{}", integrators::option_docs::markdown(&entries));
            } else if options {
                out!("{}", integrators::option_docs::text(&entries));
            } else {
                for e in entries {
                    outln!("{:<12} {}", e.name, e.summary);
                }
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

fn merge(parts: &[PathBuf], output: &Path, png: Option<&Path>, exposure: f32) -> Result<()> {
    if !exposure.is_finite() {
        return Err(Error::new("--exposure must be a finite number"));
    }
    for path in std::iter::once(output).chain(png) {
        lodestar::film::output_dir(path)?;
    }
    let files = parts
        .iter()
        .map(|p| lodestar::parts::PartFile::read(p))
        .collect::<Result<Vec<_>>>()?;
    let (image, meta) = lodestar::parts::merge(&files)?;
    image.write_exr(output, &meta)?;
    if let Some(png) = png {
        image.write_png(png, exposure)?;
    }
    let m = image.mean();
    eprintln!(
        "merged {} parts -> {}; mean rgb ({:.5}, {:.5}, {:.5})",
        files.len(),
        output.display(),
        m.x,
        m.y,
        m.z
    );
    Ok(())
}

pub(crate) fn load_scene(path: Option<&Path>, defines: &[(String, String)]) -> Result<Scene> {
    match path {
        Some(p) => loader::load_file_with(p, defines),
        None if !defines.is_empty() => Err(Error::new(
            "-D defines a Mitsuba XML scene parameter; give the scene file",
        )),
        None => Ok(Scene::cornell_box()),
    }
}

/// `-D name=value` arguments.
pub(crate) fn parse_defines(args: &[String]) -> Result<Vec<(String, String)>> {
    args.iter()
        .map(|a| match a.split_once('=') {
            Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
            _ => Err(Error::new(format!(
                "-D {a}: expected NAME=VALUE (a Mitsuba scene parameter)"
            ))),
        })
        .collect()
}

fn compare(a: &Path, b: &Path, crop: Option<&str>) -> Result<()> {
    let crop = crop.map(Crop::parse).transpose()?;
    let (ia, _) = Image::read_exr(a)?;
    let (ib, _) = Image::read_exr(b)?;
    let c = lodestar::metrics::compare_crop(&ia, &ib, crop)
        .map_err(|e| e.context(format!("{} vs {}", a.display(), b.display())))?;
    outln!(
        "mean A  {:.6} {:.6} {:.6}",
        c.mean_a.x,
        c.mean_a.y,
        c.mean_a.z
    );
    outln!(
        "mean B  {:.6} {:.6} {:.6}",
        c.mean_b.x,
        c.mean_b.y,
        c.mean_b.z
    );
    outln!("MSE     {:.6e}", c.mse);
    outln!("RMSE    {:.6e}", c.rmse);
    outln!("relMSE  {:.6e}", c.rel_mse);
    Ok(())
}

fn info(path: &Path, defines: &[String]) -> Result<()> {
    let s = loader::load_file_with(path, &parse_defines(defines)?)?;
    let r = s.camera.resolution;
    outln!("scene       {}", s.source);
    outln!("resolution  {} x {}", r.x, r.y);
    outln!(
        "shapes      {} ({} triangles, {} spheres)",
        s.shapes.len(),
        s.triangle_count(),
        s.sphere_count()
    );
    outln!("lights      {}", s.lights.len());
    outln!("materials   {}", s.materials.len());
    outln!("features    {}", s.features);
    outln!(
        "defaults    integrator {}, max_depth {}, spp {}",
        s.render.integrator,
        depth_label(s.render.max_depth),
        s.render.spp
    );
    Ok(())
}

/// `--max-depth`: an integer >= 1, or -1 for no limit.
pub(crate) fn cli_max_depth(d: Option<i64>) -> Result<Option<u32>> {
    d.map(|d| parse_max_depth(d).map_err(|e| Error::new(format!("--max-depth {e}"))))
        .transpose()
}
