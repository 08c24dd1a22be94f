//! Shared helpers of the integration tests. Each test file pulls this in with `mod common;`,
//! and uses only part of it.
#![allow(dead_code)]

pub mod chi2;

use glam::Vec3;

/// `|a - b| <= rel * max(|a|, |b|) + abs`.
pub fn close(a: f64, b: f64, rel: f64, abs: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + abs
}

/// Component-wise [`close`] on vectors (spectra, directions).
pub fn close3(a: Vec3, b: Vec3, rel: f64, abs: f64) -> bool {
    (0..3).all(|i| close(a[i] as f64, b[i] as f64, rel, abs))
}

/// Collects failed per-sample checks: counts them and keeps the first few messages, so that a
/// test over a million samples reports what went wrong without printing a million lines.
#[derive(Debug, Default)]
pub struct Failures {
    pub count: usize,
    pub first: Vec<String>,
}

impl Failures {
    pub fn new() -> Failures {
        Failures::default()
    }

    /// Records a failure (with a lazily built message) when `ok` is false.
    pub fn check(&mut self, ok: bool, msg: impl FnOnce() -> String) {
        if !ok {
            self.count += 1;
            if self.first.len() < 8 {
                self.first.push(msg());
            }
        }
    }

    /// Panics if more than `allowed` checks failed.
    pub fn assert_at_most(&self, allowed: usize, what: &str) {
        assert!(
            self.count <= allowed,
            "{what}: {} per-sample checks failed (allowed {allowed}); first ones:\n  {}",
            self.count,
            self.first.join("\n  ")
        );
    }

    pub fn assert_none(&self, what: &str) {
        self.assert_at_most(0, what);
    }
}
