//! The integrator registry: every algorithm by name, with a one-line summary and a
//! constructor. The CLI's `--integrator`, a scene's `[render] integrator`, the EXR metadata
//! and the tests all go through this table.

pub mod bdpt;
pub mod guided;
pub mod mcmc;
pub mod option_docs;
pub mod options;
pub mod paths;
pub mod pt;
pub mod unguided;
pub mod vcm;

use crate::error::{Error, Result};
use crate::math::SamplerKind;
use crate::render::Integrator;
pub use options::{Options, Spec};

/// Settings every integrator receives: the depth limit plus `key=value` options
/// (`-O key=value` on the command line), each checked by the integrator that reads it.
pub struct IntegratorParams {
    /// Maximum number of path segments.
    pub max_depth: u32,
    /// The `-O key=value` options; a key the integrator does not read is an error.
    pub options: Options,
}

impl IntegratorParams {
    /// Option `sampler` of pt, bdpt, lt, vcm and bpm: `independent` (default) or `sobol`
    /// ([`crate::math::sobol`]).
    pub fn sampler(&self) -> Result<SamplerKind> {
        options::sampler(&self.options.declared(&[&[options::SAMPLER]]))
    }
}

/// An integrator by name: the built-in ones in [`REGISTRY`], others added by [`register`].
#[derive(Clone, Copy)]
pub struct Entry {
    /// The name `--integrator` takes (`pt`, `guided-bdpt`, ...).
    pub name: &'static str,
    /// One line on what the integrator computes, for `lodestar integrators`.
    pub summary: &'static str,
    /// Builds the integrator from its parameters; an option value it cannot use is an error.
    pub build: fn(&IntegratorParams) -> Result<Box<dyn Integrator>>,
    /// The integrator's options: the tables of [`Spec`]s it reads through (where two declare
    /// a name the first stands); `option_docs` lists them.
    pub options: &'static [&'static [Spec]],
    /// Whether the integrator (its name, with these options) can render one `--part` slice of
    /// a render (`crate::parts`); the error says why not. [`splittable`] and
    /// [`not_splittable`] serve most.
    pub parts: fn(&str, &Options) -> Result<()>,
    /// Whether the integrator (its name, with these options) renders with camera samples
    /// splatted into the pixels their filter covers (`--film splatted`,
    /// `Camera::splat_samples`): those whose camera samples all go through the pass driver
    /// (`render::render_rows`). [`splats_camera_samples`] and [`samples_filters_only`] serve
    /// most.
    pub splat_film: fn(&str, &Options) -> Result<()>,
    /// The largest `--max-depth` it renders: `None` for any, [`STORED_PATHS`] for integrators
    /// that keep whole paths (the Markov chains' states, guide paths); [`build`] checks it.
    pub max_depth: Option<u32>,
}

/// [`Entry::max_depth`] of an integrator that stores whole paths ([`crate::path::Path`]).
pub const STORED_PATHS: Option<u32> = Some(crate::path::MAX_VERTICES as u32 - 1);

/// [`Entry::parts`] of an integrator whose passes depend on the seed and the global pass
/// index alone: any slice of the passes can be rendered on its own.
pub fn splittable(_: &str, _: &Options) -> Result<()> {
    Ok(())
}

/// [`Entry::parts`] of an integrator that cannot render a slice of the passes on its own.
pub fn not_splittable(name: &str, _: &Options) -> Result<()> {
    Err(Error::new(format!(
        "--part: integrator '{name}' cannot be split"
    )))
}

/// [`Entry::splat_film`] of an integrator whose camera samples all go through the pass
/// driver.
pub fn splats_camera_samples(_: &str, _: &Options) -> Result<()> {
    Ok(())
}

/// [`Entry::splat_film`] of an integrator that accumulates camera samples itself: each
/// counts for one pixel, drawn from its filter.
pub fn samples_filters_only(name: &str, _: &Options) -> Result<()> {
    Err(Error::new(format!(
        "--film splatted: integrator '{name}' counts each camera sample for one pixel drawn \
         from its filter (the default film); pt and bdpt splat them"
    )))
}

/// Whether integrator `name` with `options` renders with splatted camera samples (its
/// [`Entry::splat_film`]); an unknown name is an error as in [`build`].
pub fn check_splat_film(name: &str, options: &Options) -> Result<()> {
    (entry(name)?.splat_film)(name, options)
}

/// Whether integrator `name` with `options` can render a `--part` slice (its
/// [`Entry::parts`]); an unknown name is an error as in [`build`].
pub fn check_parts(name: &str, options: &Options) -> Result<()> {
    (entry(name)?.parts)(name, options)
}

/// The entry named `name`; an unknown name is an error that lists the valid ones.
fn entry(name: &str) -> Result<Entry> {
    let all = entries();
    all.iter().find(|e| e.name == name).copied().ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|e| e.name).collect();
        Error::new(format!(
            "unknown integrator '{name}' (available: {})",
            names.join(", ")
        ))
    })
}

/// Integrators registered at run time by code outside the crate ([`register`]).
static REGISTERED: std::sync::RwLock<Vec<Entry>> = std::sync::RwLock::new(Vec::new());

/// Add an integrator written outside the crate (`examples/bsdf_pt/` shows one): from then on
/// [`build`], [`render_named`], `lodestar::bench` and everything else that takes an integrator
/// by name know it. A name already taken is an error.
pub fn register(entry: Entry) -> Result<()> {
    let mut registered = REGISTERED.write().unwrap_or_else(|e| e.into_inner());
    if REGISTRY
        .iter()
        .chain(registered.iter())
        .any(|e| e.name == entry.name)
    {
        return Err(Error::new(format!(
            "cannot register integrator '{}': the name is taken",
            entry.name
        )));
    }
    registered.push(entry);
    Ok(())
}

/// Every integrator: the built-in ones in registry order, then those [`register`]ed.
pub fn entries() -> Vec<Entry> {
    let registered = REGISTERED.read().unwrap_or_else(|e| e.into_inner());
    REGISTRY.iter().chain(registered.iter()).copied().collect()
}

/// The built-in integrators, in the order `lodestar integrators` lists them.
pub static REGISTRY: &[Entry] = &[
    Entry {
        name: "pt",
        summary: "path tracing: next-event estimation and BSDF sampling combined by MIS, Russian roulette",
        build: pt::build,
        options: &[pt::OPTIONS],
        parts: pt::check_parts,
        splat_film: pt::check_splat_film,
        max_depth: None,
    },
    Entry {
        name: "lt",
        summary: "light tracing: light subpaths connected to the camera and splatted",
        build: bdpt::build_lt,
        options: &[bdpt::LT_OPTIONS],
        parts: splittable,
        splat_film: samples_filters_only,
        max_depth: None,
    },
    Entry {
        name: "guided-pt",
        summary: "selective guided sampling with complete guide paths (Reibold et al. 2018), mixed with pt",
        build: guided::build_pt,
        options: guided::options::PT_OPTIONS,
        parts: guided::check_parts,
        splat_film: samples_filters_only,
        max_depth: STORED_PATHS,
    },
    Entry {
        name: "guided-bdpt",
        summary: "selective guided sampling with complete guide paths, mixed with bdpt (balance heuristic over all techniques)",
        build: guided::build_bdpt,
        options: guided::options::BDPT_OPTIONS,
        parts: guided::check_parts,
        splat_film: samples_filters_only,
        max_depth: STORED_PATHS,
    },
    Entry {
        name: "guided-vcm",
        summary: "selective guided sampling with complete guide paths, mixed with vcm (bdpt's techniques and merging, explicit balance weights; consistent)",
        build: guided::build_vcm,
        options: guided::options::VCM_OPTIONS,
        parts: not_splittable,
        splat_film: samples_filters_only,
        max_depth: STORED_PATHS,
    },
    Entry {
        name: "bdpt",
        summary: "bidirectional path tracing: all (s, t) techniques, full MIS, media",
        build: bdpt::build,
        options: &[bdpt::OPTIONS],
        parts: splittable,
        splat_film: splats_camera_samples,
        max_depth: None,
    },
    Entry {
        name: "pssmlt",
        summary: "primary-sample-space Metropolis light transport over pt (Kelemen et al. 2002)",
        build: mcmc::build_pssmlt,
        options: mcmc::PSSMLT_OPTIONS,
        parts: mcmc::check_parts,
        splat_film: samples_filters_only,
        max_depth: None,
    },
    Entry {
        name: "mmlt",
        summary: "multiplexed Metropolis light transport over bdpt's techniques (Hachisuka et al. 2014)",
        build: mcmc::build_mmlt,
        options: mcmc::MMLT_OPTIONS,
        parts: mcmc::check_parts,
        splat_film: samples_filters_only,
        max_depth: STORED_PATHS,
    },
    Entry {
        name: "vcm",
        summary: "vertex connection and merging: BDPT's techniques plus photon merging, MIS, shrinking radius",
        build: vcm::build,
        options: &[vcm::OPTIONS],
        parts: splittable,
        splat_film: samples_filters_only,
        max_depth: None,
    },
    Entry {
        name: "bpm",
        summary: "bidirectional photon mapping: vcm's merging techniques alone, MIS, shrinking radius",
        build: vcm::build_bpm,
        options: &[vcm::BPM_OPTIONS],
        parts: splittable,
        splat_film: samples_filters_only,
        max_depth: None,
    },
];

/// Build an integrator by name; an unknown name lists the valid ones, and an option that
/// the integrator does not read is an error.
pub fn build(name: &str, params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let e = entry(name)?;
    if let Some(most) = e.max_depth
        && params.max_depth > most
    {
        return Err(Error::new(format!(
            "{name} stores whole paths of at most {} vertices, so max_depth must be at most \
             {most}; got {}",
            most + 1,
            crate::path::depth_label(params.max_depth)
        )));
    }
    let integrator = (e.build)(params)?;
    params.options.check_all_used(name)?;
    Ok(integrator)
}

/// The outcome of [`render_named`].
pub struct NamedRender {
    /// The image, sample counts, seconds and statistics of the render.
    pub result: crate::render::RenderResult,
    /// Process CPU seconds the render took (wall seconds times threads where unavailable).
    pub cpu_seconds: f64,
    /// Registry name of the integrator, for metadata.
    pub name: &'static str,
    /// The integrator's settings ([`Integrator::settings`]), for metadata.
    pub settings: String,
}

/// How [`render_named_with`] runs: seed, threads, progress bar and snapshots.
#[derive(Clone, Copy)]
pub struct RunSettings<'a> {
    /// Root seed of the random streams (`RenderContext::seed`).
    pub seed: u64,
    /// Size of the thread pool.
    pub threads: usize,
    /// Draw a progress bar on stderr.
    pub progress: bool,
    /// Images at given elapsed seconds; the clock starts when the integrator starts rendering.
    pub snapshots: Option<&'a crate::snapshot::Snapshots<'a>>,
    /// Also produce the DBOR-re-weighted image (`RenderResult::dbor`).
    pub dbor: bool,
    /// Global index of the first pass (`--part`; see `RenderContext::first_pass`).
    pub first_pass: u64,
    /// A hold on the render from another thread: stop, progress (`RenderContext::control`).
    pub control: Option<&'a crate::render::Control>,
    /// The clock budgets are read from (`None`: the machine's; `RenderContext::clock`). The
    /// snapshots must run on the same clock.
    pub clock: Option<&'a dyn crate::clock::Clock>,
}

/// Build integrator `name` and render `scene` with it on a pool of `threads` threads: what
/// the command line, the benchmarks and the tests all do.
pub fn render_named(
    scene: &crate::scene::Scene,
    name: &str,
    params: &IntegratorParams,
    budget: crate::render::Budget,
    seed: u64,
    threads: usize,
    progress: bool,
) -> Result<NamedRender> {
    let run = RunSettings {
        seed,
        threads,
        progress,
        snapshots: None,
        dbor: false,
        first_pass: 0,
        control: None,
        clock: None,
    };
    render_named_with(scene, name, params, budget, &run)
}

/// [`render_named`] with snapshots: any registered integrator, by name.
pub fn render_named_with(
    scene: &crate::scene::Scene,
    name: &str,
    params: &IntegratorParams,
    budget: crate::render::Budget,
    run: &RunSettings,
) -> Result<NamedRender> {
    let mut integrator = build(name, params)?;
    if scene.camera.splat_samples {
        check_splat_film(name, &params.options)?;
    }
    let threads = run.threads;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::new(format!("cannot start {threads} threads: {e}")))?;
    let ctx = crate::render::RenderContext {
        scene,
        seed: run.seed,
        progress: run.progress,
        snapshots: run.snapshots,
        dbor: run.dbor,
        first_pass: run.first_pass,
        control: run.control,
        clock: run.clock.unwrap_or(crate::clock::system()),
    };
    integrator.prepare(scene)?;
    let cpu0 = crate::render::process_cpu_seconds();
    let result = pool.install(|| {
        if let Some(s) = run.snapshots {
            s.start_clock();
        }
        integrator.render(&ctx, budget)
    });
    integrator.finish(scene)?;
    let cpu_seconds = match (cpu0, crate::render::process_cpu_seconds()) {
        (Some(a), Some(b)) if b > a => b - a,
        _ => result.seconds * threads as f64,
    };
    Ok(NamedRender {
        result,
        cpu_seconds,
        name: integrator.name(),
        settings: integrator.settings(),
    })
}
