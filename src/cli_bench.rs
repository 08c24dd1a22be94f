//! `lodestar bench`: its arguments, and the command that runs a bench, one `--part` of it, or
//! its report from the parts (`lodestar::bench` does the work).

use crate::{cli_max_depth, parse_defines};
use lodestar::bench::BenchConfig;
use lodestar::error::Result;
use lodestar::metrics::Crop;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Scene file (TOML, or Mitsuba XML ending in .xml).
    #[arg(long)]
    pub scene: PathBuf,
    /// Integrator names, comma-separated; the first is the baseline of the speed-up.
    #[arg(long, value_delimiter = ',', required = true)]
    pub integrators: Vec<String>,
    /// Wall-clock seconds per render (learning included for learning methods).
    #[arg(long, allow_negative_numbers = true)]
    pub time: f64,
    /// Reference EXR of the scene (same resolution).
    #[arg(long)]
    pub reference: PathBuf,
    /// Mitsuba XML scenes: set parameter `$name` (overrides its <default>), repeatable.
    #[arg(short = 'D', long = "define", value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Renders per integrator, seeds seed..seed+runs; the table shows medians.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub runs: u32,
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    pub seed: u64,
    /// Output directory (default: bench-<scene name>); created if missing.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Maximum number of path segments, -1 for no limit; default: the scene's.
    #[arg(long, allow_negative_numbers = true)]
    pub max_depth: Option<i64>,
    /// Measure every error over the pixels [x0, x1) x [y0, y1) only.
    #[arg(long, value_name = "x0,y0,x1,y1")]
    pub crop: Option<String>,
    /// Exposure of the PNG images in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// No line per render on stderr.
    #[arg(short, long)]
    pub quiet: bool,
    /// How camera samples reach the pixels, for every integrator: `sampled` (each counts for
    /// one pixel, drawn from its filter: unbiased) or `splatted` (each spread over every
    /// pixel its filter covers, pixels dividing by their weight sums: Mitsuba's film,
    /// consistent; pt and bdpt).
    #[arg(long, value_parser = ["sampled", "splatted"], default_value = "sampled")]
    pub film: String,
    /// Render only the I-th of N shares of the runs (integrator x seed) into OUT/runs/, for
    /// an array job; build the report afterwards with --from-parts.
    #[arg(long, value_name = "I/N", conflicts_with = "from_parts")]
    pub part: Option<String>,
    /// Build the report from the runs that `--part` benches (same arguments) wrote into these
    /// output directories, instead of rendering.
    #[arg(long, value_name = "DIR", num_args = 1..)]
    pub from_parts: Vec<PathBuf>,
}

pub fn bench(args: BenchArgs) -> Result<()> {
    let crop = args.crop.as_deref().map(Crop::parse).transpose()?;
    let config = BenchConfig {
        out: args
            .out
            .clone()
            .unwrap_or_else(|| lodestar::bench::default_out(&args.scene)),
        scene: args.scene,
        defines: parse_defines(&args.defines)?,
        integrators: args.integrators,
        seconds: args.time,
        reference: args.reference,
        runs: args.runs,
        seed: args.seed,
        threads: args
            .threads
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
        max_depth: cli_max_depth(args.max_depth)?,
        crop,
        exposure: args.exposure,
        verbose: !args.quiet,
        splat_film: args.film == "splatted",
    };
    let prepared = lodestar::bench::prepare(config)?;
    if let Some(text) = &args.part {
        let part = lodestar::parts::Part::parse(text)?;
        let n = lodestar::bench::parts::run_part(&prepared, part)?;
        if !args.quiet {
            eprintln!(
                "part {part}: {n} run(s) written to {}; build the report with --from-parts",
                prepared.config.out.join("runs").display()
            );
        }
        return Ok(());
    }
    let report = if args.from_parts.is_empty() {
        lodestar::bench::bench(&prepared)?
    } else {
        lodestar::bench::bench_from_parts(&prepared, &args.from_parts)?
    };
    out!("{}", report.table);
    if !args.quiet {
        eprintln!("wrote {}", prepared.config.out.join("index.html").display());
    }
    Ok(())
}
