//! `lodestar bench`: run time against error. Every integrator named (any registry entry,
//! including learning methods, whose learning counts against the same budget) renders the
//! scene for the same wall-clock time, with seeds `seed .. seed + runs`; each image is
//! compared with a reference on linear radiance (MSE, RMSE, relMSE, optionally over a crop).
//!
//! | setting | default | meaning |
//! |---|---|---|
//! | `integrators` | required | registry names, each optionally with options as `name:key=value:key=value` (e.g. `guided-pt:seeder=mcmc`); the first is the baseline of the speed-up |
//! | `seconds` | required | wall-clock budget per render |
//! | `reference` | required | EXR of the scene's converged image, same resolution |
//! | `runs` | 1 | seeds per integrator; the report gives medians |
//! | `seed` | 0 | first seed |
//! | `crop` | whole image | `[x0, x1) x [y0, y1)` for every metric |
//! | `max_depth` | the scene's | path segments |
//!
//! Outputs in the directory `out`: `report.csv`, `curves.csv` and `stats.csv` (every run's
//! end-of-render statistics) ([`report`]), `curves.svg`
//! ([`plot`]), `images/<integrator>.exr|.png|.error.png` of the first run plus
//! `images/reference.png` ([`colormap`]), and `index.html` ([`html`]), which shows it all
//! offline. [`run`] renders; [`report`] computes the rows and writes the numbers; [`parts`]
//! spreads the runs over machines (`--part I/N`) and gathers them back (`--from-parts`).

pub mod colormap;
pub mod html;
pub mod parts;
pub mod plot;
pub mod report;
pub mod run;

use crate::error::{Error, Result};
use crate::film::Image;
use crate::integrators::{self, IntegratorParams, Options};
use crate::metrics::Crop;
use crate::scene::{Scene, loader};
use std::path::{Path, PathBuf};

/// What to bench (see the module documentation).
#[derive(Debug, Clone)]
pub struct BenchConfig {
    /// The scene file.
    pub scene: PathBuf,
    /// Mitsuba XML scene parameters (`-D name=value`), overriding the scene's `<default>`s.
    pub defines: Vec<(String, String)>,
    /// Integrator entries, `name` or `name:key=value:...`; the first is the speed-ups'
    /// baseline.
    pub integrators: Vec<String>,
    /// Wall-clock budget of each render, learning included.
    pub seconds: f64,
    /// EXR of the scene's converged image, at the scene's resolution.
    pub reference: PathBuf,
    /// Renders per integrator, with seeds `seed .. seed + runs`.
    pub runs: u32,
    /// Seed of the first run.
    pub seed: u64,
    /// Output directory (report, curves, plot, images, page).
    pub out: PathBuf,
    /// Size of each render's thread pool.
    pub threads: usize,
    /// Maximum number of path segments (`None`: the scene's).
    pub max_depth: Option<u32>,
    /// The pixel rectangle every metric is computed over (`None`: the whole image).
    pub crop: Option<Crop>,
    /// Exposure of the PNG images in stops.
    pub exposure: f32,
    /// One line per render on stderr.
    pub verbose: bool,
    /// Camera samples splatted into the pixels their filter covers (`--film splatted`,
    /// `Camera::splat_samples`), for every integrator of the bench.
    pub splat_film: bool,
}

/// A checked configuration with its scene and reference loaded.
pub struct Prepared {
    /// The configuration, checked.
    pub config: BenchConfig,
    /// The loaded scene.
    pub scene: Scene,
    /// The loaded reference image.
    pub reference: Image,
    /// The depth limit every render uses: the configuration's, else the scene's.
    pub max_depth: u32,
}

/// Check everything that can be checked before rendering: the numbers, the integrator names,
/// the scene, the reference (readable, same resolution as the scene), the crop, and that the
/// output directory can be created. Nothing is written.
pub fn prepare(config: BenchConfig) -> Result<Prepared> {
    let c = &config;
    if !(c.seconds.is_finite() && c.seconds > 0.0) {
        return Err(Error::new(format!(
            "--time must be a positive number of seconds, got {}",
            c.seconds
        )));
    }
    if c.runs == 0 {
        return Err(Error::new("--runs must be at least 1"));
    }
    if c.threads == 0 {
        return Err(Error::new("--threads must be at least 1"));
    }
    if !c.exposure.is_finite() {
        return Err(Error::new("--exposure must be a finite number"));
    }
    if c.integrators.is_empty() {
        return Err(Error::new("--integrators: name at least one integrator"));
    }
    for (i, name) in c.integrators.iter().enumerate() {
        if c.integrators[..i].contains(name) {
            return Err(Error::new(format!(
                "--integrators: '{name}' is listed twice"
            )));
        }
    }
    if c.max_depth == Some(0) {
        return Err(Error::new(
            "--max-depth must be at least 1 (or -1 for no limit)",
        ));
    }
    let mut scene = loader::load_file_with(&c.scene, &c.defines)?;
    scene.camera.splat_samples = c.splat_film;
    let max_depth = c.max_depth.unwrap_or(scene.render.max_depth);
    for entry in &c.integrators {
        let (name, options) = split_entry(entry).map_err(|e| e.context("--integrators"))?;
        if c.splat_film {
            integrators::check_splat_film(name, &options)
                .map_err(|e| e.context("--integrators"))?;
        }
        let params = IntegratorParams { max_depth, options };
        integrators::build(name, &params).map_err(|e| e.context("--integrators"))?;
    }
    let (reference, _) = Image::read_exr(&c.reference)?;
    let res = scene.camera.resolution;
    if (reference.width, reference.height) != (res.x, res.y) {
        return Err(Error::new(format!(
            "{}: reference is {}x{}, but scene {} renders {}x{}",
            c.reference.display(),
            reference.width,
            reference.height,
            c.scene.display(),
            res.x,
            res.y
        )));
    }
    if let Some(crop) = c.crop {
        crop.check_inside(res.x, res.y)?;
    }
    let parent = c.out.parent().filter(|p| !p.as_os_str().is_empty());
    if c.out.exists() && !c.out.is_dir() {
        return Err(Error::new(format!(
            "--out {}: exists and is not a directory",
            c.out.display()
        )));
    }
    if let Some(p) = parent
        && !p.is_dir()
    {
        return Err(Error::new(format!(
            "--out {}: directory '{}' does not exist",
            c.out.display(),
            p.display()
        )));
    }
    Ok(Prepared {
        config,
        scene,
        reference,
        max_depth,
    })
}

/// The outcome of a bench: every run, and the table as printed.
pub struct BenchReport {
    /// Every integrator's runs, in the order of the configuration.
    pub results: Vec<run::IntegratorRuns>,
    /// The table `lodestar bench` prints: one row of medians per integrator.
    pub table: String,
}

/// Render everything and write the outputs into `config.out` (created if missing).
pub fn bench(p: &Prepared) -> Result<BenchReport> {
    bench_controlled(p, None)
}

/// [`bench()`] held by `control` (see [`run::run_all_controlled`]).
pub fn bench_controlled(
    p: &Prepared,
    control: Option<&crate::render::Control>,
) -> Result<BenchReport> {
    let results = run::run_all_controlled(p, control)?;
    report_from(p, results)
}

/// The report of a bench whose runs were rendered by `--part`s, read from their output
/// directories (see [`parts`]).
pub fn bench_from_parts(p: &Prepared, dirs: &[PathBuf]) -> Result<BenchReport> {
    let results = run::assemble(p, parts::collect(p, dirs)?)?;
    report_from(p, results)
}

fn report_from(p: &Prepared, results: Vec<run::IntegratorRuns>) -> Result<BenchReport> {
    write_outputs(p, &results)?;
    let table = report::table(&p.scene.source, &report::median_rows(&results));
    Ok(BenchReport { results, table })
}

/// Write the report, curves, plot, images and page.
pub fn write_outputs(p: &Prepared, results: &[run::IntegratorRuns]) -> Result<()> {
    let c = &p.config;
    let images = c.out.join("images");
    std::fs::create_dir_all(&images)
        .map_err(|e| Error::new(format!("--out {}: cannot create: {e}", images.display())))?;
    let scene = p.scene.source.as_str();
    report::write_report_csv(&c.out.join("report.csv"), scene, results)?;
    report::write_curves_csv(&c.out.join("curves.csv"), scene, results)?;
    report::write_stats_csv(&c.out.join("stats.csv"), scene, results)?;
    let title = format!("{scene}: MSE against time");
    plot::write_svg(&c.out.join("curves.svg"), &title, results)?;
    p.reference
        .write_png(&images.join("reference.png"), c.exposure)?;
    let mut listed = Vec::new();
    for ir in results {
        let file = |suffix: &str| format!("images/{}{suffix}", file_stem(&ir.name));
        let (exr, png, err) = (file(".exr"), file(".png"), file(".error.png"));
        ir.image.write_exr(&c.out.join(&exr), &ir.metadata)?;
        ir.image.write_png(&c.out.join(&png), c.exposure)?;
        colormap::write_error_png(&c.out.join(&err), &ir.image, &p.reference)?;
        listed.push((ir.name.clone(), png, err, exr));
    }
    let medians = report::median_rows(results);
    let runs = report::run_rows(results);
    let crop = c.crop.map_or("whole image".to_string(), |k| {
        format!("crop [{}, {}) x [{}, {})", k.x0, k.x1, k.y0, k.y1)
    });
    let settings = format!(
        "{} s per render, {} run(s) with seeds {}..{}, {} thread(s), max depth {}, {crop}, reference {}",
        c.seconds,
        c.runs,
        c.seed,
        c.seed + c.runs as u64 - 1,
        c.threads,
        p.max_depth,
        c.reference.display()
    );
    let page = html::page(&html::Page {
        scene,
        settings: &settings,
        medians: &medians,
        runs: &runs,
        plot: "curves.svg",
        reference_png: "images/reference.png",
        images: &listed,
    });
    report::write_text(&c.out.join("index.html"), &page)
}

/// The default output directory: `bench-<scene stem>`.
pub fn default_out(scene: &Path) -> PathBuf {
    let stem = scene
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    PathBuf::from(format!("bench-{stem}"))
}

/// An `--integrators` entry `name[:key=value]...` as the registry name and its options.
pub fn split_entry(entry: &str) -> Result<(&str, Options)> {
    let mut parts = entry.split(':');
    let name = parts.next().unwrap_or_default();
    let options: Vec<String> = parts.map(str::to_string).collect();
    Ok((name, Options::parse(&options)?))
}

/// A file name for an entry's images (`:` and `=` replaced).
pub fn file_stem(entry: &str) -> String {
    entry.replace([':', '='], "_")
}
