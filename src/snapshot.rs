//! Snapshots: the image of a render as it stands at given elapsed seconds, for
//! error-against-time curves (`lodestar render --snapshots 5,10,20`, `lodestar bench`).
//!
//! A [`Snapshots`] holds the times (seconds, ascending), a clock and a sink. The clock starts
//! when the integrator's `render` is called (`integrators::render_named_with` starts it), so a
//! learning phase counts; the time spent producing and handing out a snapshot (building the
//! image, writing a file, computing an error) is paused out of both the snapshot clock and the
//! pass driver's time budget, so a render with snapshots does as much work as one without.
//!
//! **Integrators using the pass driver** (`render::render_rows`, or
//! `render::run_passes_with_snapshots` with a closure producing the current image) get
//! snapshots for free: after every pass the driver calls [`Snapshots::emit_due`].
//!
//! **An integrator with its own loop** (a learning phase followed by rendering) calls
//! `if let Some(s) = ctx.snapshots { s.emit_due(passes, spp, || current_image()) }` after each
//! unit of work; the closure runs only when a time is due. During learning it may hand out its
//! learning image (or skip the call: missed times are emitted, late, at the next call). When it
//! hands the render phase to `run_passes_with_snapshots`, the clock keeps running, so the
//! render-phase snapshots are measured from the start of learning.
//!
//! A snapshot is taken after the pass that crosses its time, so its `seconds` (the actual
//! elapsed time, recorded in the files and used for curves) is at or after its scheduled
//! `time`; one pass may cross several times, which then get the same image.
//!
//! File names: [`snapshot_path`] puts `out.t0005.exr` beside `out.exr` (seconds zero-padded to
//! four digits, with a fraction only when the time has one: `out.t0002.5.exr`).

use crate::clock::Clock;
use crate::error::{Error, Result};
use crate::film::Image;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

/// One snapshot handed to the sink.
#[derive(Debug)]
pub struct Snapshot<'a> {
    /// Index of the scheduled time in [`Snapshots::times`].
    pub index: usize,
    /// The scheduled time (seconds).
    pub time: f64,
    /// Elapsed seconds on the render clock when the snapshot was taken (>= `time`).
    pub seconds: f64,
    /// Passes in the snapshot image.
    pub passes: u64,
    /// Samples per pixel in the snapshot image.
    pub spp: u64,
    /// The image at that time.
    pub image: &'a Image,
}

/// The sink: called in time order from the thread that drives the render.
pub type SnapshotSink<'a> = dyn Fn(&Snapshot) -> Result<()> + Sync + 'a;

/// Snapshot times, the render clock and the sink.
pub struct Snapshots<'a> {
    times: Vec<f64>,
    sink: &'a SnapshotSink<'a>,
    clock: &'a dyn Clock,
    state: Mutex<State>,
}

struct State {
    start: Duration,
    paused: Duration,
    next: usize,
    error: Option<Error>,
}

impl<'a> Snapshots<'a> {
    /// Times must be finite and positive; they are sorted and duplicates dropped. The clock
    /// is the machine's.
    pub fn new(times: &[f64], sink: &'a SnapshotSink<'a>) -> Result<Snapshots<'a>> {
        Snapshots::with_clock(times, sink, crate::clock::system())
    }

    /// [`Snapshots::new`] on `clock` (the render's, `RenderContext::clock`).
    pub fn with_clock(
        times: &[f64],
        sink: &'a SnapshotSink<'a>,
        clock: &'a dyn Clock,
    ) -> Result<Snapshots<'a>> {
        if let Some(t) = times.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
            return Err(Error::new(format!(
                "--snapshots: times must be positive numbers of seconds, got {t}"
            )));
        }
        let mut times = times.to_vec();
        times.sort_by(f64::total_cmp);
        times.dedup();
        Ok(Snapshots {
            times,
            sink,
            clock,
            state: Mutex::new(State {
                start: clock.now(),
                paused: Duration::ZERO,
                next: 0,
                error: None,
            }),
        })
    }

    /// The scheduled times, ascending.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Restart the clock (and the schedule): called when the integrator starts rendering.
    pub fn start_clock(&self) {
        let mut s = self.lock();
        s.start = self.clock.now();
        s.paused = Duration::ZERO;
        s.next = 0;
    }

    /// Seconds since the clock started, without the time spent on snapshots.
    pub fn elapsed(&self) -> f64 {
        let s = self.lock();
        (self.clock.now() - s.start)
            .saturating_sub(s.paused)
            .as_secs_f64()
    }

    /// Total time spent on snapshots so far (the pass driver subtracts it from its budget).
    pub fn paused(&self) -> Duration {
        self.lock().paused
    }

    /// Hand every snapshot whose time has come to the sink, with the image from `image`
    /// (called once, and only when a time is due). After a sink error no more snapshots are
    /// taken and [`Snapshots::finish`] returns the error.
    pub fn emit_due(&self, passes: u64, spp: u64, image: impl FnOnce() -> Image) {
        let mut s = self.lock();
        let seconds = (self.clock.now() - s.start)
            .saturating_sub(s.paused)
            .as_secs_f64();
        if s.error.is_some() || s.next >= self.times.len() || self.times[s.next] > seconds {
            return;
        }
        let t0 = self.clock.now();
        let image = image();
        while s.next < self.times.len() && self.times[s.next] <= seconds {
            let snapshot = Snapshot {
                index: s.next,
                time: self.times[s.next],
                seconds,
                passes,
                spp,
                image: &image,
            };
            s.next += 1;
            if let Err(e) = (self.sink)(&snapshot) {
                s.error = Some(e);
                s.next = self.times.len();
            }
        }
        s.paused += self.clock.now() - t0;
    }

    /// After the render: the sink's error if it failed, else the times never reached.
    pub fn finish(&self) -> Result<Vec<f64>> {
        let s = self.lock();
        match &s.error {
            Some(e) => Err(e.clone()),
            None => Ok(self.times[s.next.min(self.times.len())..].to_vec()),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        // A panic inside the sink poisons the lock; the state itself stays consistent.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Parse a comma-separated list of seconds (`5,10,20,40`).
pub fn parse_times(text: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(|s| {
            let t: f64 = s.trim().parse().map_err(|_| {
                Error::new(format!(
                    "--snapshots: expected comma-separated seconds like 5,10,20, got '{text}'"
                ))
            })?;
            if t.is_finite() && t > 0.0 {
                Ok(t)
            } else {
                Err(Error::new(format!(
                    "--snapshots: times must be positive numbers of seconds, got {t}"
                )))
            }
        })
        .collect()
}

/// `dir/out.t0005.exr` for `dir/out.exr` at 5 s (`out.t0002.5.exr` at 2.5 s).
pub fn snapshot_path(output: &Path, time: f64) -> PathBuf {
    let stem = output.file_stem().unwrap_or_default().to_string_lossy();
    let whole = time.trunc();
    let mut tag = format!("t{:04}", whole as u64);
    if time != whole {
        // Up to millisecond precision, trailing zeros dropped.
        let frac = format!("{:.3}", time - whole);
        tag.push_str(frac.trim_start_matches('0').trim_end_matches('0'));
    }
    let name = match output.extension() {
        Some(ext) => format!("{stem}.{tag}.{}", ext.to_string_lossy()),
        None => format!("{stem}.{tag}"),
    };
    output.with_file_name(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_names() {
        let p = |o: &str, t: f64| snapshot_path(Path::new(o), t).display().to_string();
        assert_eq!(p("out.exr", 5.0), "out.t0005.exr");
        assert_eq!(p("dir/out.exr", 40.0), "dir/out.t0040.exr");
        assert_eq!(p("a/b.png", 2.5), "a/b.t0002.5.png");
        assert_eq!(p("b.exr", 0.25), "b.t0000.25.exr");
        assert_eq!(p("b.exr", 12345.0), "b.t12345.exr");
        assert_eq!(p("noext", 1.0), "noext.t0001");
    }

    #[test]
    fn parse_lists() {
        assert_eq!(parse_times("5, 10,20,40").unwrap(), [5.0, 10.0, 20.0, 40.0]);
        for bad in ["", "5,,10", "x", "0", "-1", "nan", "inf"] {
            assert!(parse_times(bad).is_err(), "{bad}");
        }
        let sink = |_: &Snapshot| Ok(());
        assert!(Snapshots::new(&[1.0, f64::NAN], &sink).is_err());
        assert_eq!(
            Snapshots::new(&[2.0, 1.0, 2.0], &sink).unwrap().times(),
            [1.0, 2.0]
        );
    }

    /// Times due together share one image; the image closure runs only when a time is due;
    /// sink time is paused out of the clock; a sink error stops snapshots and is reported.
    #[test]
    fn emission_schedule() {
        let clock = crate::clock::ManualClock::default();
        let seen = Mutex::new(Vec::new());
        let sink = |s: &Snapshot| {
            seen.lock()
                .unwrap()
                .push((s.index, s.time, s.seconds, s.passes));
            clock.advance(Duration::from_millis(30)); // paused out
            Ok(())
        };
        let snaps = Snapshots::with_clock(&[0.01, 0.02, 10.0], &sink, &clock).unwrap();
        snaps.start_clock();
        clock.advance(Duration::from_millis(5));
        snaps.emit_due(1, 1, || panic!("nothing is due yet"));
        clock.advance(Duration::from_millis(20));
        let mut calls = 0;
        snaps.emit_due(2, 2, || {
            calls += 1;
            Image::new(1, 1)
        });
        assert_eq!(calls, 1);
        let seen = seen.lock().unwrap().clone();
        // Both due times are handed out together, at 25 ms on the render's clock.
        assert_eq!(seen.len(), 2);
        assert_eq!((seen[0].0, seen[1].0, seen[0].3), (0, 1, 2));
        assert_eq!((seen[0].2, seen[1].2), (0.025, 0.025), "{seen:?}");
        // Sink time is not on the render's clock.
        assert_eq!(snaps.paused(), Duration::from_millis(60));
        assert_eq!(snaps.elapsed(), 0.025);
        assert_eq!(snaps.finish().unwrap(), [10.0]);

        let failing = |_: &Snapshot| Err(Error::new("disk full"));
        let clock = crate::clock::ManualClock::default();
        let snaps = Snapshots::with_clock(&[1e-9, 2e-9], &failing, &clock).unwrap();
        clock.advance(Duration::from_millis(1));
        snaps.emit_due(1, 1, || Image::new(1, 1));
        snaps.emit_due(2, 2, || panic!("no snapshots after an error"));
        assert_eq!(snaps.finish().unwrap_err().message(), "disk full");
    }
}
