//! The integrator interface and the shared pass driver.
//!
//! An [`Integrator`] renders passes into a film until a [`Budget`] is spent. The driver
//! ([`run_passes`], [`run_passes_with_snapshots`]) owns the loop, the budget, the progress bar
//! and snapshots (the current image at given elapsed seconds, see [`crate::snapshot`]);
//! integrators that estimate one value per pixel implement [`PixelEstimator`] and get the
//! whole render from [`render_pixel_estimator`] (the row driver, `render/rows.rs`).
//! Randomness comes from one counter-based stream per (seed, pass, pixel), and each pixel is
//! accumulated by exactly one task, so the image is bit-identical for any number of threads
//! (and with or without snapshots).

use crate::clock::Clock;
pub use crate::control::Control;
use crate::film::Image;
use crate::math::{Sampler, Spectrum};
use crate::scene::Scene;
use crate::snapshot::Snapshots;
use glam::Vec2;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::time::Duration;

mod rows;
mod spread;

pub use rows::{RowTracer, cascade_rows, render_pixel_estimator, render_rows};

/// How much work a render may do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Budget {
    /// This many passes (for per-pixel estimators: samples per pixel).
    Spp(u64),
    /// Passes until this many wall-clock seconds have elapsed (the pass under way finishes).
    Seconds(f64),
}

/// What every integrator gets to render with.
pub struct RenderContext<'a> {
    /// The scene to render.
    pub scene: &'a Scene,
    /// Root seed of the counter-based random streams, one per (seed, pass, pixel).
    pub seed: u64,
    /// Draw a progress bar on stderr (hidden when stderr is not a terminal).
    pub progress: bool,
    /// Images to hand out at given elapsed seconds (none when `None`); the pass driver does
    /// it for integrators that use it, see [`crate::snapshot`] for integrators with their own
    /// loop.
    pub snapshots: Option<&'a Snapshots<'a>>,
    /// Keep Zirr et al.'s firefly cascade ([`crate::dbor`]) and return its re-weighted image
    /// in `RenderResult::dbor` (`--dbor`).
    pub dbor: bool,
    /// Global index of the first pass (`--part`): the pass driver numbers passes from here,
    /// so a slice of a render draws the same random numbers as those passes of the whole.
    pub first_pass: u64,
    /// A caller's hold on the render under way (the Python module's Ctrl-C and progress
    /// callback): the pass driver reports its progress there and ends the render after the
    /// pass under way once a stop is asked for.
    pub control: Option<&'a Control>,
    /// The clock time budgets are read from ([`crate::clock`]: the machine's, or a test's).
    pub clock: &'a dyn Clock,
}

impl<'a> RenderContext<'a> {
    /// A context without snapshots.
    pub fn new(scene: &'a Scene, seed: u64, progress: bool) -> RenderContext<'a> {
        RenderContext {
            scene,
            seed,
            progress,
            snapshots: None,
            dbor: false,
            first_pass: 0,
            control: None,
            clock: crate::clock::system(),
        }
    }

    /// Whether the caller asked the render to stop (see [`Control`]).
    pub fn stopped(&self) -> bool {
        self.control.is_some_and(Control::stopped)
    }
}

/// The outcome of a render.
#[derive(Debug, Clone)]
pub struct RenderResult {
    /// The rendered image: the estimate of every pixel's measurement.
    pub image: Image,
    /// Samples per pixel (camera paths per pixel for per-pixel estimators).
    pub spp: u64,
    /// Passes the image averages (this render's own; learning passes kept in the image
    /// count).
    pub passes: u64,
    /// Seconds the render took on the context's clock, learning and set-up included.
    pub seconds: f64,
    /// Named counters and settings, also written into the EXR header.
    pub stats: Vec<(String, String)>,
    /// The DBOR-re-weighted image, when the context asked for it and the integrator keeps
    /// a cascade.
    pub dbor: Option<Image>,
}

/// A rendering algorithm, registered by name in `integrators/mod.rs`.
pub trait Integrator: Send {
    /// Registry name (`pt`, `bdpt`, ...).
    fn name(&self) -> &'static str;
    /// Settings in a human-readable form, for logs and EXR metadata.
    fn settings(&self) -> String;
    /// Render `ctx.scene` until `budget` is spent and return the image with its statistics.
    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult;
    /// Called before `render` with the scene: load and check inputs (default: nothing).
    fn prepare(&mut self, _scene: &Scene) -> crate::error::Result<()> {
        Ok(())
    }
    /// Called after `render`: write outputs other than the image (default: nothing).
    fn finish(&mut self, _scene: &Scene) -> crate::error::Result<()> {
        Ok(())
    }
}

/// Estimates the measurement of one pixel from one sample stream (a camera path).
pub trait PixelEstimator: Sync {
    /// One sample of pixel `pixel`'s value; `raster` is the jittered raster position.
    fn estimate<S: Sampler>(&self, scene: &Scene, raster: Vec2, sampler: &mut S) -> Spectrum;

    /// [`Self::estimate`] for each raster position of a row with its sampler, into `out`
    /// (by default one after the other; an estimator may trace them together, as long as
    /// each value is the one `estimate` gives).
    fn estimate_row<S: Sampler>(
        &self,
        scene: &Scene,
        rasters: &[Vec2],
        samplers: &mut [S],
        out: &mut [Spectrum],
    ) {
        for ((&r, sampler), o) in rasters.iter().zip(samplers).zip(out) {
            *o = self.estimate(scene, r, sampler);
        }
    }
}

/// Run `pass(i)` for i = 0, 1, ... until the budget is spent; returns (passes, seconds).
/// No snapshots: see [`run_passes_with_snapshots`].
pub fn run_passes(progress: bool, budget: Budget, mut pass: impl FnMut(u64)) -> (u64, f64) {
    // Without snapshots the image closure is never called.
    drive(
        crate::clock::system(),
        progress,
        None,
        None,
        0,
        budget,
        &mut (),
        |_, i| pass(i),
        |_, _| Image::new(0, 0),
    )
}

/// [`run_passes`] over a render state `S` (typically the film) that also hands out snapshots:
/// after each pass, when a snapshot time of `ctx.snapshots` is due, `image(state, passes)`
/// gives the current image (spp = passes). Time spent on snapshots does not count against a
/// [`Budget::Seconds`]. Returns (passes, seconds).
pub fn run_passes_with_snapshots<S>(
    ctx: &RenderContext,
    budget: Budget,
    state: &mut S,
    pass: impl FnMut(&mut S, u64),
    image: impl Fn(&S, u64) -> Image,
) -> (u64, f64) {
    drive(
        ctx.clock,
        ctx.progress,
        ctx.snapshots,
        ctx.control,
        ctx.first_pass,
        budget,
        state,
        pass,
        image,
    )
}

/// The pass loop: passes `first`, `first + 1`, ... The budget clock starts here and excludes
/// time paused for snapshots. A stop asked for through `control` ends it after at least one
/// pass.
#[allow(clippy::too_many_arguments)]
fn drive<S>(
    clock: &dyn Clock,
    progress: bool,
    snapshots: Option<&Snapshots>,
    control: Option<&Control>,
    first: u64,
    budget: Budget,
    state: &mut S,
    mut pass: impl FnMut(&mut S, u64),
    image: impl Fn(&S, u64) -> Image,
) -> (u64, f64) {
    let start = clock.now();
    let paused = || snapshots.map_or(Duration::ZERO, |s| s.paused());
    let paused_at_start = paused();
    let elapsed = || {
        (clock.now() - start)
            .saturating_sub(paused() - paused_at_start)
            .as_secs_f64()
    };
    let bar = progress_bar(progress, budget);
    let mut passes = 0u64;
    loop {
        let done = match budget {
            Budget::Spp(n) => passes >= n,
            Budget::Seconds(s) => passes > 0 && elapsed() >= s,
        };
        if done || (passes > 0 && control.is_some_and(Control::stopped)) {
            break;
        }
        pass(state, first + passes);
        passes += 1;
        if let Some(snaps) = snapshots {
            let state = &*state;
            snaps.emit_due(passes, passes, || image(state, passes));
        }
        let fraction = match budget {
            Budget::Spp(n) => passes as f64 / n as f64,
            Budget::Seconds(s) => elapsed() / s,
        };
        bar.set_position(match budget {
            Budget::Spp(_) => passes,
            Budget::Seconds(_) => (fraction * 1000.0).min(1000.0) as u64,
        });
        if let Some(c) = control {
            c.set_progress(fraction);
        }
    }
    bar.finish_and_clear();
    (passes, elapsed())
}

/// CPU seconds (user + system, all threads) this process has used so far, from
/// `/proc/self/stat` on Linux; `None` elsewhere. Benchmarks report work per CPU-second with it,
/// which stays meaningful on a machine shared with other jobs.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (in parentheses): utime is the 12th, stime the 13th.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

fn progress_bar(progress: bool, budget: Budget) -> ProgressBar {
    if !progress {
        return ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
    }
    let (len, template) = match budget {
        Budget::Spp(n) => (n, "{elapsed_precise} [{bar:40}] {pos}/{len} spp, eta {eta}"),
        Budget::Seconds(_) => (
            1000,
            "{elapsed_precise} [{bar:40}] {percent}% of the time budget",
        ),
    };
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::SamplerKind;

    #[test]
    fn spp_budget_runs_exactly_that_many_passes() {
        let mut seen = Vec::new();
        let (passes, _) = run_passes(false, Budget::Spp(5), |p| seen.push(p));
        assert_eq!(passes, 5);
        assert_eq!(seen, vec![0, 1, 2, 3, 4]);
    }

    /// A time budget runs at least one pass, starts every pass before the budget is spent,
    /// and stops at the first pass boundary after it: on a clock where each pass takes 7 ms,
    /// a 30 ms budget runs passes starting at 0, 7, 14, 21 and 28 ms, and reports 35 ms.
    #[test]
    fn time_budget_stops_after_the_pass_that_spends_it() {
        let clock = crate::clock::ManualClock::default();
        let scene = small_scene();
        let ctx = RenderContext {
            clock: &clock,
            ..RenderContext::new(&scene, 0, false)
        };
        let mut starts = Vec::new();
        let (passes, seconds) = run_passes_with_snapshots(
            &ctx,
            Budget::Seconds(0.03),
            &mut (),
            |_, _| {
                starts.push(clock.now().as_millis());
                clock.advance(Duration::from_millis(7));
            },
            |_, _| Image::new(1, 1),
        );
        assert_eq!(starts, [0, 7, 14, 21, 28]);
        assert_eq!((passes, seconds), (5, 0.035));
        // A budget the first pass spends at once still runs that pass.
        let (passes, _) = run_passes_with_snapshots(
            &ctx,
            Budget::Seconds(1e-9),
            &mut (),
            |_, _| clock.advance(Duration::from_millis(1)),
            |_, _| Image::new(1, 1),
        );
        assert_eq!(passes, 1);
    }

    /// A tracer whose value depends on the sample stream, with a splat per pixel.
    struct Noise(Vec<(u32, Spectrum)>, u32);
    impl RowTracer for Noise {
        fn sample<S: Sampler>(&mut self, raster: Vec2, sampler: &mut S) -> Spectrum {
            let v = sampler.next_1d();
            self.0
                .push((self.1 - 1 - raster.x as u32, Spectrum::splat(v)));
            Spectrum::new(v, raster.y, 1.0)
        }
        fn take_splats(&mut self) -> Vec<(u32, Spectrum)> {
            std::mem::take(&mut self.0)
        }
    }

    fn small_scene() -> Scene {
        let text = crate::scene::CORNELL_BOX_TOML
            .replace("resolution = [256, 256]", "resolution = [8, 6]");
        crate::scene::loader::load_str(&text, "test.toml", None).unwrap()
    }

    /// Snapshots are the images an spp budget of their pass count gives, and taking them
    /// changes nothing in the final image.
    #[test]
    fn render_rows_snapshots_are_the_images_of_shorter_renders() {
        let scene = small_scene();
        let w = scene.camera.resolution.x;
        let render = |ctx: &RenderContext, spp| {
            render_rows(ctx, Budget::Spp(spp), SamplerKind::Independent, || {
                Noise(Vec::new(), w)
            })
        };
        let plain = render(&RenderContext::new(&scene, 3, false), 40);
        let taken = std::sync::Mutex::new(Vec::new());
        let sink = |s: &crate::snapshot::Snapshot| {
            taken
                .lock()
                .unwrap()
                .push((s.passes, s.spp, s.image.clone()));
            Ok(())
        };
        // Times so small that every pass crosses one until they run out.
        let times: Vec<f64> = (1..=5).map(|k| k as f64 * 1e-9).collect();
        let snaps = Snapshots::new(&times, &sink).unwrap();
        snaps.start_clock();
        let ctx = RenderContext {
            snapshots: Some(&snaps),
            ..RenderContext::new(&scene, 3, false)
        };
        let with = render(&ctx, 40);
        assert_eq!(with.image, plain.image);
        let taken = taken.lock().unwrap().clone();
        assert!(!taken.is_empty());
        for (passes, spp, image) in taken {
            assert_eq!(passes, spp);
            let shorter = render(&RenderContext::new(&scene, 3, false), passes);
            assert_eq!(image, shorter.image, "snapshot after {passes} passes");
        }
    }

    /// A stop asked for through `Control` ends the loop after the pass under way (and never
    /// before the first), and the loop reports its progress there.
    #[test]
    fn control_stops_the_pass_loop_and_reads_its_progress() {
        let scene = small_scene();
        let control = Control::default();
        let ctx = RenderContext {
            control: Some(&control),
            ..RenderContext::new(&scene, 0, false)
        };
        let (passes, _) = run_passes_with_snapshots(
            &ctx,
            Budget::Spp(100),
            &mut (),
            |_, i| {
                if i == 2 {
                    control.stop();
                }
            },
            |_, _| Image::new(1, 1),
        );
        assert_eq!(passes, 3);
        assert_eq!(control.progress(), 0.03);
        // Stopped before it starts: one pass all the same.
        let (passes, _) = run_passes_with_snapshots(
            &ctx,
            Budget::Spp(100),
            &mut (),
            |_, _| {},
            |_, _| Image::new(1, 1),
        );
        assert_eq!(passes, 1);
        assert!(ctx.stopped());
    }

    /// Time spent in the snapshot sink is not charged to a seconds budget: with 5 ms passes
    /// and a sink that takes 60 ms (after the first pass, when the snapshot is due), a 50 ms
    /// budget still runs ten passes and reports 50 ms.
    #[test]
    fn snapshot_time_is_paused_out_of_the_budget() {
        let clock = crate::clock::ManualClock::default();
        let sink = |_: &crate::snapshot::Snapshot| {
            clock.advance(Duration::from_millis(60));
            Ok(())
        };
        let snaps = Snapshots::with_clock(&[1e-9], &sink, &clock).unwrap();
        let scene = small_scene();
        let ctx = RenderContext {
            snapshots: Some(&snaps),
            clock: &clock,
            ..RenderContext::new(&scene, 0, false)
        };
        let mut n = 0u64;
        let (passes, seconds) = run_passes_with_snapshots(
            &ctx,
            Budget::Seconds(0.05),
            &mut n,
            |n, _| {
                *n += 1;
                clock.advance(Duration::from_millis(5));
            },
            |_, _| Image::new(1, 1),
        );
        assert_eq!((passes, n), (10, 10));
        assert_eq!(seconds, 0.05);
        assert_eq!(clock.now(), Duration::from_millis(110));
    }
}
