//! `--check`: validate every sample value, splat, technique density and MIS weight while
//! rendering.
//!
//! Integrators report what they compute through [`value`], [`density`] and [`weight`], each
//! labelled with a [`Technique`]. With checking off (the default) every call is one relaxed
//! atomic load. With it on ([`enable`]), each report is counted and each violation is tallied
//! per technique and kind:
//!
//! * a value (a pixel sample, a splat, a technique's contribution) must be finite and have no
//!   negative channel;
//! * a density must be finite and non-negative;
//! * an MIS weight must lie in [0, 1] (up to 1e-6 of rounding).
//!
//! [`report`] lists the tallies; `lodestar render --check` prints them after the render and
//! exits with status 3 when any violation occurred. The tallies are process-wide: one render
//! per process is what the command line does.

use crate::math::Spectrum;
use std::collections::BTreeMap;
use std::fmt;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

static ENABLED: AtomicBool = AtomicBool::new(false);
static CHECKED: AtomicU64 = AtomicU64::new(0);
static VIOLATIONS: Mutex<BTreeMap<(Technique, Kind), Tally>> = Mutex::new(BTreeMap::new());

/// What produced a checked quantity: an integrator's technique, with BDPT's (s, t) where it
/// has one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Technique {
    /// The integrator's or technique's name.
    pub name: &'static str,
    /// BDPT's (s, t), where the technique has one.
    pub s: Option<(u32, u32)>,
}

impl Technique {
    /// A technique known by name alone.
    pub const fn named(name: &'static str) -> Technique {
        Technique { name, s: None }
    }

    /// BDPT technique `s` light vertices, `t` camera vertices.
    pub const fn st(name: &'static str, s: usize, t: usize) -> Technique {
        Technique {
            name,
            s: Some((s as u32, t as u32)),
        }
    }
}

impl fmt::Display for Technique {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self.s {
            Some((s, t)) => write!(f, "{} (s={s}, t={t})", self.name),
            None => write!(f, "{}", self.name),
        }
    }
}

/// What a violation is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// A value that is not finite or has a negative channel.
    Value,
    /// A density that is not finite or is negative.
    Density,
    /// An MIS weight outside [0, 1].
    Weight,
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(match self {
            Kind::Value => "value not finite or negative",
            Kind::Density => "density not finite or negative",
            Kind::Weight => "MIS weight outside [0, 1]",
        })
    }
}

/// Count and first offending value of one kind of violation.
#[derive(Debug, Clone, Copy)]
pub struct Tally {
    /// Number of violations.
    pub count: u64,
    /// The first offending value.
    pub first: f64,
}

/// Turn checking on (and clear earlier tallies).
pub fn enable() {
    reset();
    ENABLED.store(true, Ordering::Relaxed);
}

/// Turn checking off (tallies are kept).
pub fn disable() {
    ENABLED.store(false, Ordering::Relaxed);
}

/// Whether checking is on.
#[inline]
pub fn enabled() -> bool {
    ENABLED.load(Ordering::Relaxed)
}

/// Clear the count of checked quantities and every tally.
pub fn reset() {
    CHECKED.store(0, Ordering::Relaxed);
    VIOLATIONS.lock().unwrap_or_else(|e| e.into_inner()).clear();
}

#[cold]
fn violation(t: Technique, kind: Kind, v: f64) {
    let mut map = VIOLATIONS.lock().unwrap_or_else(|e| e.into_inner());
    map.entry((t, kind))
        .and_modify(|e| e.count += 1)
        .or_insert(Tally { count: 1, first: v });
}

/// A sample value, splat or contribution: finite, no negative channel.
#[inline]
pub fn value(t: Technique, v: Spectrum) {
    if enabled() {
        CHECKED.fetch_add(1, Ordering::Relaxed);
        if !(v.is_finite() && v.min_element() >= 0.0) {
            let bad = if v.is_finite() {
                v.min_element()
            } else {
                f32::NAN
            };
            violation(t, Kind::Value, bad as f64);
        }
    }
}

/// A density: finite and non-negative.
#[inline]
pub fn density(t: Technique, p: f64) {
    if enabled() {
        CHECKED.fetch_add(1, Ordering::Relaxed);
        if !(p.is_finite() && p >= 0.0) {
            violation(t, Kind::Density, p);
        }
    }
}

/// An MIS weight: in [0, 1].
#[inline]
pub fn weight(t: Technique, w: f64) {
    if enabled() {
        CHECKED.fetch_add(1, Ordering::Relaxed);
        if !((0.0..=1.0 + 1e-6).contains(&w)) {
            violation(t, Kind::Weight, w);
        }
    }
}

/// Quantities checked so far, and every violation by technique and kind.
pub fn report() -> (u64, Vec<(Technique, Kind, Tally)>) {
    let map = VIOLATIONS.lock().unwrap_or_else(|e| e.into_inner());
    (
        CHECKED.load(Ordering::Relaxed),
        map.iter().map(|(&(t, k), &v)| (t, k, v)).collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn violations_are_tallied_by_technique_and_kind() {
        enable();
        let t = Technique::st("bdpt", 2, 3);
        weight(t, 0.5);
        weight(t, 1.5);
        weight(t, f64::NAN);
        density(Technique::named("pt nee"), -1.0);
        value(
            Technique::named("sample"),
            Spectrum::new(1.0, f32::INFINITY, 0.0),
        );
        value(Technique::named("sample"), Spectrum::new(1.0, 0.0, 0.0));
        disable();
        weight(t, 7.0); // not counted when off
        let (checked, v) = report();
        assert!(checked >= 6, "{checked}");
        let find = |t: Technique, k: Kind| v.iter().find(|e| e.0 == t && e.1 == k).map(|e| e.2);
        assert_eq!(find(t, Kind::Weight).unwrap().count, 2);
        assert_eq!(find(t, Kind::Weight).unwrap().first, 1.5);
        assert_eq!(
            find(Technique::named("pt nee"), Kind::Density)
                .unwrap()
                .count,
            1
        );
        assert_eq!(
            find(Technique::named("sample"), Kind::Value).unwrap().count,
            1
        );
        assert_eq!(v.len(), 3);
        assert_eq!(format!("{t}"), "bdpt (s=2, t=3)");
    }
}
