//! A hold on a render from another thread (the Python module's Ctrl-C and progress
//! callback): the caller asks the render to stop, the pass driver reports its progress.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// A hold on a render from another thread: ask it to stop, read its progress.
///
/// A stopped render returns the image of the passes it finished (at least one per phase), so
/// what it returns is a valid, shorter render; phases with their own loops (the guided
/// integrators' and pt's guiding learning) stop after their iteration under way.
#[derive(Debug, Default)]
pub struct Control {
    stop: AtomicBool,
    /// The fraction of the render phase's budget spent, as f64 bits.
    progress: AtomicU64,
}

impl Control {
    /// Ask the render to stop after the pass under way.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Whether a stop was asked for.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// The fraction of the current pass loop's budget spent, in [0, 1].
    pub fn progress(&self) -> f64 {
        f64::from_bits(self.progress.load(Ordering::Relaxed))
    }

    /// Report progress (the pass driver does; so do drivers of several renders, such as
    /// `bench::run::run_all_controlled`).
    pub fn set_progress(&self, fraction: f64) {
        self.progress
            .store(fraction.clamp(0.0, 1.0).to_bits(), Ordering::Relaxed);
    }
}
