//! `lodestar render`: its arguments, the render, and what it writes and reports.

use crate::{cli_max_depth, load_scene, parse_defines};
use lodestar::error::{Error, Result};
use lodestar::integrators::{self, IntegratorParams, Options, RunSettings};
use lodestar::render::Budget;
use lodestar::snapshot::{self, Snapshot, Snapshots};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub(crate) struct RenderArgs {
    /// Scene file: lodestar TOML, or Mitsuba 3 XML (`.xml`); omit for the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Mitsuba XML scenes: set parameter `$name` (overrides its <default>), repeatable.
    #[arg(short = 'D', long = "define", value_name = "NAME=VALUE")]
    defines: Vec<String>,
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
    /// Maximum number of path segments, -1 for no limit; default: the scene's.
    #[arg(long, allow_negative_numbers = true)]
    max_depth: Option<i64>,
    /// How camera samples reach the pixels: `sampled` (each counts for one pixel, drawn from
    /// its filter: unbiased) or `splatted` (each spread over every pixel its filter covers,
    /// pixels dividing by their weight sums: Mitsuba's film, consistent; pt and bdpt).
    #[arg(long, value_parser = ["sampled", "splatted"], default_value = "sampled")]
    film: String,
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
    /// Also write the image at these elapsed seconds, e.g. 5,10,20,40: out.t0005.exr beside
    /// out.exr (and out.t0005.png beside --png).
    #[arg(long, value_name = "SECONDS,...")]
    snapshots: Option<String>,
    /// guided-pt, guided-bdpt: unguided share once the cache holds guide paths (-O alpha=).
    #[arg(long, allow_negative_numbers = true)]
    alpha: Option<f64>,
    /// guided-pt, guided-bdpt: share of the budget spent learning (-O learn_fraction=).
    #[arg(long, allow_negative_numbers = true)]
    learn_fraction: Option<f64>,
    /// guided-pt, guided-bdpt: guide-path cache capacity (-O max_guides=).
    #[arg(long, allow_negative_numbers = true)]
    max_guides: Option<u64>,
    /// guided-pt, guided-bdpt: write the learned guide-path cache to this file (-O save_guides=).
    #[arg(long)]
    save_guides: Option<PathBuf>,
    /// guided-pt, guided-bdpt: render with this saved cache instead of learning one (-O load_guides=).
    #[arg(long)]
    load_guides: Option<PathBuf>,
    /// guided-pt, guided-bdpt: where guide paths come from, `outliers` or `mcmc` (-O seeder=).
    #[arg(long)]
    seeder: Option<String>,
    /// Also write the image re-weighted by Zirr et al.'s firefly cascade (b = 8, kappa = 32)
    /// as out.dbor.exr beside out.exr (biased; the plain sum of the cascade is the image).
    #[arg(long)]
    dbor: bool,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
    /// Render only slice I of N of the --spp passes (1 <= I <= N), for merging with
    /// `lodestar merge`; e.g. --part 3/8.
    #[arg(long, value_name = "I/N")]
    part: Option<String>,
    /// Validate every sample value, splat, technique density and MIS weight while rendering
    /// (finite, non-negative, weights in [0, 1]); print the violations per technique at the
    /// end and exit with an error when there were any.
    #[arg(long)]
    check: bool,
}

impl RenderArgs {
    /// `-O` options plus the guided-sampling flags as options.
    fn all_options(&self) -> Vec<String> {
        let mut o = self.options.clone();
        let path = |p: &PathBuf| p.to_string_lossy().into_owned();
        let flags: [(&str, Option<String>); 6] = [
            ("alpha", self.alpha.map(|v| v.to_string())),
            ("learn_fraction", self.learn_fraction.map(|v| v.to_string())),
            ("max_guides", self.max_guides.map(|v| v.to_string())),
            ("save_guides", self.save_guides.as_ref().map(path)),
            ("load_guides", self.load_guides.as_ref().map(path)),
            ("seeder", self.seeder.clone()),
        ];
        for (k, v) in flags {
            if let Some(v) = v {
                o.push(format!("{k}={v}"));
            }
        }
        o
    }
}

/// `lodestar render`.
pub(crate) fn render(args: RenderArgs) -> Result<()> {
    let (max_depth, snapshot_times) = check_render_args(&args)?;
    let output = output_path(&args);
    // Fail before a long render, not after it.
    for path in std::iter::once(&output).chain(&args.png) {
        lodestar::film::output_dir(path)?;
    }
    let defines = parse_defines(&args.defines)?;
    let mut scene = load_scene(args.scene.as_deref(), &defines)?;
    scene.camera.splat_samples = args.film == "splatted";
    let name = args
        .integrator
        .clone()
        .unwrap_or_else(|| scene.render.integrator.clone());
    let params = IntegratorParams {
        max_depth: max_depth.unwrap_or(scene.render.max_depth),
        options: Options::parse(&args.all_options())?,
    };
    let budget = match (args.spp, args.time) {
        (_, Some(t)) => Budget::Seconds(t),
        (Some(n), None) => Budget::Spp(n),
        (None, None) => Budget::Spp(scene.render.spp as u64),
    };
    let part = match &args.part {
        Some(text) => Some(part_plan(&args, text, &name, &params, &defines, budget)?),
        None => None,
    };
    let (budget, first_pass) = match &part {
        Some(plan) => (
            Budget::Spp(plan.passes.end - plan.passes.start),
            plan.passes.start,
        ),
        None => (budget, 0),
    };
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let base_meta = |name: &str| {
        vec![
            ("integrator".to_string(), name.to_string()),
            ("scene".to_string(), scene.source.clone()),
            ("seed".to_string(), args.seed.to_string()),
            ("threads".to_string(), threads.to_string()),
        ]
    };
    let sink = |s: &Snapshot| write_snapshot(&args, &output, base_meta(&name), s);
    let snapshots = Snapshots::new(&snapshot_times, &sink)?;
    let run_settings = RunSettings {
        dbor: args.dbor,
        seed: args.seed,
        threads,
        progress: !args.quiet,
        snapshots: (!snapshot_times.is_empty()).then_some(&snapshots),
        first_pass,
        control: None,
        clock: None,
    };
    if args.check {
        lodestar::check::enable();
    }
    let run = integrators::render_named_with(&scene, &name, &params, budget, &run_settings)?;
    let missed = snapshots.finish()?;
    let result = &run.result;
    let mut meta = base_meta(run.name);
    meta.extend([
        ("settings".to_string(), run.settings.clone()),
        ("spp".to_string(), result.spp.to_string()),
        ("passes".to_string(), result.passes.to_string()),
        ("seconds".to_string(), format!("{:.3}", result.seconds)),
    ]);
    meta.extend(result.stats.iter().cloned());
    meta.extend(part.map(|p| p.meta).unwrap_or_default());
    write_render(&args, &output, &run, &meta)?;
    let m = result.image.mean();
    let summary = format!(
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
    report_render(&args, &run, &summary, &missed)
}

/// `render`'s arguments checked on their own: the depth limit asked for and the snapshot
/// times.
fn check_render_args(args: &RenderArgs) -> Result<(Option<u32>, Vec<f64>)> {
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
    if args.film == "splatted" && (args.dbor || args.part.is_some()) {
        return Err(Error::new(
            "--film splatted: each pixel divides by its own weight sum, which neither --dbor's \
             cascade nor a --part slice (merged as an average) keeps",
        ));
    }
    let max_depth = cli_max_depth(args.max_depth)?;
    if !args.exposure.is_finite() {
        return Err(Error::new("--exposure must be a finite number"));
    }
    let snapshot_times = match &args.snapshots {
        Some(text) => snapshot::parse_times(text)?,
        None => Vec::new(),
    };
    if let (Some(t), Some(last)) = (args.time, snapshot_times.iter().copied().reduce(f64::max))
        && last > t
    {
        return Err(Error::new(format!(
            "--snapshots: {last} s is beyond --time {t}"
        )));
    }
    Ok((max_depth, snapshot_times))
}

/// `--output`, or the scene's file stem (`cornell-box` for the built-in scene) with `.exr`.
fn output_path(args: &RenderArgs) -> PathBuf {
    args.output.clone().unwrap_or_else(|| {
        let stem = args
            .scene
            .as_ref()
            .and_then(|p| p.file_stem())
            .map_or("cornell-box".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from(format!("{stem}.exr"))
    })
}

/// The slice of the passes `--part` asks for, and what its header must record.
fn part_plan(
    args: &RenderArgs,
    text: &str,
    name: &str,
    params: &IntegratorParams,
    defines: &[(String, String)],
    budget: Budget,
) -> Result<lodestar::parts::Plan> {
    integrators::check_parts(name, &params.options)?;
    let total = match budget {
        Budget::Spp(n) => Some(n),
        Budget::Seconds(_) => None,
    };
    let mut scene_bytes = match &args.scene {
        Some(p) => std::fs::read(p)
            .map_err(|e| Error::new(format!("{}: cannot read: {e}", p.display())))?,
        None => lodestar::scene::CORNELL_BOX_TOML.as_bytes().to_vec(),
    };
    // Parameters change the scene as much as its text does.
    for (k, v) in defines {
        scene_bytes.extend(format!("\0-D {k}={v}").bytes());
    }
    lodestar::parts::plan(
        text,
        total,
        args.dbor || args.snapshots.is_some(),
        &scene_bytes,
    )
}

/// One snapshot's EXR (and PNG) beside the output, its header `meta` and the snapshot's own.
fn write_snapshot(
    args: &RenderArgs,
    output: &Path,
    mut meta: Vec<(String, String)>,
    s: &Snapshot,
) -> Result<()> {
    meta.extend([
        ("spp".to_string(), s.spp.to_string()),
        ("passes".to_string(), s.passes.to_string()),
        ("seconds".to_string(), format!("{:.3}", s.seconds)),
        ("snapshot_time".to_string(), s.time.to_string()),
    ]);
    s.image
        .write_exr(&snapshot::snapshot_path(output, s.time), &meta)?;
    if let Some(png) = &args.png {
        s.image
            .write_png(&snapshot::snapshot_path(png, s.time), args.exposure)?;
    }
    Ok(())
}

/// The render's EXR with header `meta`, its DBOR image (`--dbor`) and PNG (`--png`).
fn write_render(
    args: &RenderArgs,
    output: &Path,
    run: &integrators::NamedRender,
    meta: &[(String, String)],
) -> Result<()> {
    let result = &run.result;
    result.image.write_exr(output, meta)?;
    if args.dbor {
        let Some(dbor) = &result.dbor else {
            return Err(Error::new(format!(
                "--dbor: integrator '{}' keeps no firefly cascade",
                run.name
            )));
        };
        let mut m = meta.to_vec();
        m.push((
            "dbor".to_string(),
            "Zirr et al. 2018, b = 8, kappa = 32".to_string(),
        ));
        dbor.write_exr(&output.with_extension("dbor.exr"), &m)?;
    }
    if let Some(png) = &args.png {
        result.image.write_png(png, args.exposure)?;
    }
    Ok(())
}

/// What the user reads after a render: its statistics, the `summary` line, snapshots it
/// ended before, samples left out, and `--check`'s report.
fn report_render(
    args: &RenderArgs,
    run: &integrators::NamedRender,
    summary: &str,
    missed: &[f64],
) -> Result<()> {
    let result = &run.result;
    if !result.stats.is_empty() && !args.quiet {
        let s: Vec<String> = result
            .stats
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        eprintln!("stats: {}", s.join(", "));
    }
    eprintln!("{summary}");
    if !missed.is_empty() {
        let list: Vec<String> = missed.iter().map(|t| t.to_string()).collect();
        eprintln!(
            "note: the render ended before snapshot time(s) {} s",
            list.join(", ")
        );
    }
    let invalid: u64 = result
        .stats
        .iter()
        .filter(|(k, _)| k.starts_with("invalid_"))
        .filter_map(|(_, v)| v.parse::<u64>().ok())
        .sum();
    if invalid > 0 && !args.check {
        eprintln!(
            "warning: {invalid} samples were non-finite or negative and left out of the image; \
             --check lists the techniques that made them"
        );
    }
    if args.check {
        return check_report(run.name);
    }
    Ok(())
}

/// `--check`: print what was checked and every violation; an error when there were any.
fn check_report(integrator: &str) -> Result<()> {
    let (checked, violations) = lodestar::check::report();
    let total: u64 = violations.iter().map(|v| v.2.count).sum();
    eprintln!("check: {integrator}: {checked} quantities checked, {total} violations");
    for (technique, kind, tally) in &violations {
        eprintln!(
            "check: {integrator}: {technique}: {kind}: {} (first {})",
            tally.count, tally.first
        );
    }
    if total > 0 {
        return Err(Error::new(format!(
            "--check: {total} violations in {integrator} (listed above)"
        )));
    }
    Ok(())
}
