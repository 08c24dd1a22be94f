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

/// Both transport modes, for BSDF tests.
pub const MODES: [lodestar::bsdf::TransportMode; 2] = [
    lodestar::bsdf::TransportMode::Radiance,
    lodestar::bsdf::TransportMode::Importance,
];

/// A generic (not axis-aligned) geometric normal, so the frames are exercised.
pub fn ng_generic() -> Vec3 {
    Vec3::new(0.3, -0.5, 0.8).normalize()
}

/// Direction at polar angle `theta` (degrees, from `n`) and azimuth `phi` (degrees) in the
/// frame of `n`.
pub fn dir_around(n: Vec3, theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    let local = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    lodestar::math::Frame::from_z(n).to_world(local).normalize()
}

/// The checks of a non-delta BSDF sample: its `pdf` and `f` are what `pdf()` and `eval()`
/// give for its direction.
pub fn check_sample_against_eval(
    fails: &mut Failures,
    bsdf: &lodestar::bsdf::Bsdf,
    sf: &lodestar::bsdf::ShadingFrame,
    wo: Vec3,
    smp: &lodestar::bsdf::BsdfSample,
    mode: lodestar::bsdf::TransportMode,
) {
    let wi = smp.wi;
    let pdf = bsdf.pdf(sf, wo, wi, mode);
    let f = bsdf.eval(sf, wo, wi, mode);
    fails.check(close(smp.pdf as f64, pdf as f64, 1e-4, 1e-7), || {
        format!("sample pdf {} != pdf() {pdf} at wi {wi}", smp.pdf)
    });
    fails.check(close3(smp.f, f, 1e-4, 1e-7), || {
        format!("sample f {} != eval() {f} at wi {wi}", smp.f)
    });
}

/// An 8-bit PNG of `width x height` texels (`color`: grey or RGB, row-major `data`) written as
/// `name` in a fresh directory of the temporary directory (`lodestar-{tag}-{pid}`); its path.
pub fn write_png(
    tag: &str,
    name: &str,
    (width, height): (u32, u32),
    color: png::ColorType,
    data: &[u8],
) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("lodestar-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    let mut enc = png::Encoder::new(std::fs::File::create(&path).unwrap(), width, height);
    enc.set_color(color);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header().unwrap().write_image_data(data).unwrap();
    path
}

/// The light-selection probabilities `LightSampler` should give lights of these powers, by
/// its rule written out: the lights at infinity together `n / (n + 1)` for `n` of them when
/// other lights exist (else everything), the others the rest, each group by power.
pub fn light_selection_probs(powers: &[f64], infinite: &[bool]) -> Vec<f64> {
    let n_inf = infinite.iter().filter(|&&i| i).count() as f64;
    let n_fin = infinite.len() as f64 - n_inf;
    let total = |inf: bool| -> f64 {
        powers
            .iter()
            .zip(infinite)
            .filter(|(_, i)| **i == inf)
            .map(|(p, _)| p)
            .sum()
    };
    let share = |inf: bool| {
        if n_inf == 0.0 || n_fin == 0.0 {
            1.0
        } else if inf {
            n_inf / (n_inf + 1.0)
        } else {
            1.0 / (n_inf + 1.0)
        }
    };
    powers
        .iter()
        .zip(infinite)
        .map(|(p, &i)| share(i) * p / total(i))
        .collect()
}
