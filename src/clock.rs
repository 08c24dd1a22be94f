//! The time a render is budgeted by: the machine's monotonic clock in every render, and a
//! clock advanced by hand in tests, so that what a time budget does (how many passes fit,
//! when a snapshot is due, how learning splits the budget) can be tested without sleeping and
//! without depending on the machine's speed.
//!
//! The pass driver (`render::run_passes_with_snapshots`), snapshots ([`crate::snapshot`]) and
//! the integrators' learning phases read the [`Clock`] of their `RenderContext`.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// A monotonic clock: the time since some fixed instant of its own.
pub trait Clock: Send + Sync {
    /// The time elapsed since the clock's fixed instant; never decreases.
    fn now(&self) -> Duration;
}

/// The machine's monotonic clock ([`Instant`]).
pub struct SystemClock {
    start: Instant,
}

impl Clock for SystemClock {
    fn now(&self) -> Duration {
        self.start.elapsed()
    }
}

/// The machine's clock, shared by every render.
pub fn system() -> &'static SystemClock {
    static CLOCK: OnceLock<SystemClock> = OnceLock::new();
    CLOCK.get_or_init(|| SystemClock {
        start: Instant::now(),
    })
}

/// A clock that stands still until [`ManualClock::advance`] moves it (tests: a pass "takes"
/// exactly what the test says).
#[derive(Debug, Default)]
pub struct ManualClock {
    nanos: AtomicU64,
}

impl ManualClock {
    /// Move the clock forward by `by`.
    pub fn advance(&self, by: Duration) {
        self.nanos.fetch_add(by.as_nanos() as u64, Ordering::SeqCst);
    }
}

impl Clock for ManualClock {
    fn now(&self) -> Duration {
        Duration::from_nanos(self.nanos.load(Ordering::SeqCst))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manual_clock_moves_only_when_advanced() {
        let c = ManualClock::default();
        assert_eq!(c.now(), Duration::ZERO);
        c.advance(Duration::from_millis(5));
        c.advance(Duration::from_millis(7));
        assert_eq!(c.now(), Duration::from_millis(12));
        let s = system();
        let (a, b) = (s.now(), s.now());
        assert!(b >= a);
    }
}
