//! Runs an equal-time comparison: every integrator renders the scene for the same wall-clock
//! budget with each seed (seeds interleaved, so a slow spell of a shared machine spreads over
//! all integrators), and each render is compared with the reference at the final time and at
//! the snapshot times `T / 32, T / 16, T / 8, T / 4, T / 2` (its error-against-time curve).
//! Nothing here is integrator-specific: any name in the registry runs through
//! `integrators::render_named_with`.

use super::{BenchConfig, Prepared};
use crate::error::Result;
use crate::film::Image;
use crate::integrators::{self, IntegratorParams, RunSettings};
use crate::metrics::{Comparison, compare_crop};
use crate::render::Budget;
use crate::snapshot::{Snapshot, Snapshots};
use std::sync::Mutex;

/// One render of the bench: integrator (index into the list) and seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Job {
    /// Index of the integrator in the bench's list.
    pub integrator: usize,
    /// The render's seed.
    pub seed: u64,
}

/// Every run of the bench, in the order one machine renders them (seeds interleaved so that
/// a slow spell of a shared machine spreads over all integrators).
pub fn jobs(c: &BenchConfig) -> Vec<Job> {
    let mut out = Vec::new();
    for seed in c.seed..c.seed + c.runs as u64 {
        for integrator in 0..c.integrators.len() {
            out.push(Job { integrator, seed });
        }
    }
    out
}

/// Fractions of the time budget at which curve points are taken (plus the final image).
pub const CURVE_FRACTIONS: [f64; 5] = [1.0 / 32.0, 1.0 / 16.0, 1.0 / 8.0, 1.0 / 4.0, 1.0 / 2.0];

/// One point of an error-against-time curve.
#[derive(Debug, Clone, Copy)]
pub struct CurvePoint {
    /// Elapsed seconds on the render clock.
    pub seconds: f64,
    /// Samples per pixel in the snapshot image.
    pub spp: u64,
    /// Passes in the snapshot image.
    pub passes: u64,
    /// The snapshot image against the reference.
    pub error: Comparison,
}

/// One render of one integrator with one seed.
#[derive(Debug, Clone)]
pub struct Run {
    /// The render's seed.
    pub seed: u64,
    /// Seconds the render took, learning included.
    pub seconds: f64,
    /// Samples per pixel of the final image.
    pub spp: u64,
    /// Passes of the final image.
    pub passes: u64,
    /// The final image against the reference.
    pub error: Comparison,
    /// Snapshot points in time order, ending with the final image.
    pub curve: Vec<CurvePoint>,
    /// The render's end-of-render statistics (`key`, `value`), as `lodestar render` prints
    /// them: guide paths, acceptance rates, failure counts...
    pub stats: Vec<(String, String)>,
}

/// All runs of one integrator, and the image of its first run.
#[derive(Debug, Clone)]
pub struct IntegratorRuns {
    /// The entry as the bench lists it (`name` or `name:key=value:...`).
    pub name: String,
    /// The integrator's settings, as its EXR header records them.
    pub settings: String,
    /// One run per seed, in seed order.
    pub runs: Vec<Run>,
    /// The final image of the first run.
    pub image: Image,
    /// Per-pixel variance at the budget, estimated without the reference from the final images
    /// of the runs (seeds): the mean over pairs of `MSE(I_i, I_j) / 2` (NaN with one run).
    /// For an unbiased integrator it is its expected MSE; the MSE against a reference adds
    /// the reference's own noise (and bias), which biases speed-ups towards 1.
    pub variance: f64,
    /// EXR metadata of the first run's image.
    pub metadata: Vec<(String, String)>,
}

/// One finished render: which integrator (index in the bench's list), its run, final image
/// and the entry and settings that name it.
pub struct Rendered {
    /// Index of the integrator in the bench's list.
    pub index: usize,
    /// Seed, time, sample counts, errors and statistics of the render.
    pub run: Run,
    /// The final image.
    pub image: Image,
    /// The entry that names the integrator.
    pub name: String,
    /// The integrator's settings.
    pub settings: String,
}

/// Render every integrator `runs` times (seeds `seed .. seed + runs`).
pub fn run_all(p: &Prepared) -> Result<Vec<IntegratorRuns>> {
    run_all_controlled(p, None)
}

/// [`run_all`] held by `control` (the Python module): the fraction of renders done is its
/// progress, and a stop asked for ends the bench, with an error, after the render under way.
pub fn run_all_controlled(
    p: &Prepared,
    control: Option<&crate::render::Control>,
) -> Result<Vec<IntegratorRuns>> {
    let c = &p.config;
    let jobs = jobs(c);
    let total = jobs.len();
    let mut done = Vec::new();
    for job in jobs {
        if control.is_some_and(|c| c.stopped()) {
            return Err(crate::Error::new("the bench was stopped"));
        }
        done.push(render_job(p, job)?);
        if let Some(c) = control {
            c.set_progress(done.len() as f64 / total as f64);
        }
    }
    assemble(p, done)
}

/// Render one job of the bench's list (an integrator and a seed).
pub fn render_job(p: &Prepared, job: Job) -> Result<Rendered> {
    let c = &p.config;
    let entry = &c.integrators[job.integrator];
    let (run, image, name, settings) = render_one(p, entry, job.seed)?;
    if c.verbose {
        eprintln!(
            "{name} seed {}: {} spp in {:.2} s, MSE {:.4e}",
            job.seed, run.spp, run.seconds, run.error.mse
        );
    }
    Ok(Rendered {
        index: job.integrator,
        run,
        image,
        name,
        settings,
    })
}

/// Group renders by integrator (in the bench's order, runs by seed): the first run's image and
/// metadata stand for the integrator, and the seed-pair variance comes from all final images.
pub fn assemble(p: &Prepared, mut done: Vec<Rendered>) -> Result<Vec<IntegratorRuns>> {
    let c = &p.config;
    done.sort_by_key(|r| (r.index, r.run.seed));
    let mut all: Vec<IntegratorRuns> = Vec::new();
    let mut finals: Vec<Vec<Image>> = Vec::new();
    let mut last = None;
    for r in done {
        if last != Some(r.index) {
            last = Some(r.index);
            let metadata = metadata(p, &r.name, &r.settings, &r.run);
            finals.push(vec![r.image.clone()]);
            all.push(IntegratorRuns {
                name: r.name,
                settings: r.settings,
                runs: vec![r.run],
                image: r.image,
                metadata,
                variance: f64::NAN,
            });
        } else {
            finals.last_mut().expect("pushed above").push(r.image);
            all.last_mut().expect("pushed above").runs.push(r.run);
        }
    }
    for (r, images) in all.iter_mut().zip(&finals) {
        r.variance = seed_pair_variance(images, c.crop)?;
    }
    Ok(all)
}

/// Mean over all pairs of images of `MSE(I_i, I_j) / 2`: for independent renders with the
/// same expectation, an unbiased estimate of the per-pixel variance (NaN for fewer than two).
pub fn seed_pair_variance(images: &[Image], crop: Option<crate::metrics::Crop>) -> Result<f64> {
    let (mut sum, mut pairs) = (0.0, 0usize);
    for i in 0..images.len() {
        for j in i + 1..images.len() {
            sum += compare_crop(&images[i], &images[j], crop)?.mse / 2.0;
            pairs += 1;
        }
    }
    Ok(if pairs == 0 {
        f64::NAN
    } else {
        sum / pairs as f64
    })
}

fn render_one(p: &Prepared, name: &str, seed: u64) -> Result<(Run, Image, String, String)> {
    let c = &p.config;
    let points = Mutex::new(Vec::new());
    let sink = |s: &Snapshot| {
        let error = compare_crop(s.image, &p.reference, c.crop)?;
        points.lock().unwrap().push(CurvePoint {
            seconds: s.seconds,
            spp: s.spp,
            passes: s.passes,
            error,
        });
        Ok(())
    };
    let times: Vec<f64> = CURVE_FRACTIONS.iter().map(|f| f * c.seconds).collect();
    let snapshots = Snapshots::new(&times, &sink)?;
    let (registry_name, options) = super::split_entry(name)?;
    let params = IntegratorParams {
        max_depth: p.max_depth,
        options,
    };
    let settings = RunSettings {
        dbor: false,
        seed,
        threads: c.threads,
        progress: false,
        snapshots: Some(&snapshots),
        first_pass: 0,
        control: None,
        clock: None,
    };
    let named = integrators::render_named_with(
        &p.scene,
        registry_name,
        &params,
        Budget::Seconds(c.seconds),
        &settings,
    )?;
    snapshots.finish()?;
    drop(snapshots);
    let r = named.result;
    let error = compare_crop(&r.image, &p.reference, c.crop)?;
    let mut curve: Vec<CurvePoint> = points.into_inner().unwrap_or_else(|e| e.into_inner());
    // One pass may cross several snapshot times: keep one point per image.
    curve.dedup_by_key(|q| q.passes);
    curve.retain(|q| q.passes < r.passes);
    curve.push(CurvePoint {
        seconds: r.seconds,
        spp: r.spp,
        passes: r.passes,
        error,
    });
    let run = Run {
        seed,
        seconds: r.seconds,
        spp: r.spp,
        passes: r.passes,
        error,
        curve,
        stats: r.stats,
    };
    // The entry (with its options) names the row, so two settings of one integrator differ.
    Ok((run, r.image, name.to_string(), named.settings))
}

/// The EXR header of a bench image: integrator entry, settings, scene, spp, passes, seconds,
/// seed and threads.
pub fn metadata(p: &Prepared, name: &str, settings: &str, run: &Run) -> Vec<(String, String)> {
    vec![
        ("integrator".to_string(), name.to_string()),
        ("settings".to_string(), settings.to_string()),
        ("scene".to_string(), p.scene.source.clone()),
        ("spp".to_string(), run.spp.to_string()),
        ("passes".to_string(), run.passes.to_string()),
        ("seconds".to_string(), format!("{:.3}", run.seconds)),
        ("seed".to_string(), run.seed.to_string()),
        ("threads".to_string(), p.config.threads.to_string()),
    ]
}
