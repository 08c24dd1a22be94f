//! Shared helpers for whole-renderer tests: build scenes from TOML text, render through the
//! registry on a fixed thread pool, and simple statistics on images.

#![allow(dead_code)]

pub mod guided;

use glam::DVec3;
use lodestar::film::Image;
use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::{Budget, RenderResult};
use lodestar::scene::{Scene, loader};

pub fn scene(toml: &str) -> Scene {
    loader::load_str(toml, "test.toml", None).unwrap_or_else(|e| panic!("test scene: {e}"))
}

/// The Cornell box at a reduced resolution.
pub fn cornell(resolution: u32) -> Scene {
    let text = lodestar::scene::CORNELL_BOX_TOML.replace(
        "resolution = [256, 256]",
        &format!("resolution = [{resolution}, {resolution}]"),
    );
    scene(&text)
}

/// Render with integrator `name`, options `key=value`, on a pool of `threads` threads.
pub fn render(
    scene: &Scene,
    name: &str,
    max_depth: u32,
    options: &[&str],
    spp: u64,
    seed: u64,
    threads: usize,
) -> RenderResult {
    let options =
        Options::parse(&options.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap();
    let params = IntegratorParams { max_depth, options };
    integrators::render_named(scene, name, &params, Budget::Spp(spp), seed, threads, false)
        .unwrap()
        .result
}

/// Per-channel z statistic of "A and B have the same expectation", from pixel differences
/// D_i = A_i - B_i of independent renders: z = sum D_i / sqrt(sum D_i^2). Under the null each
/// D_i has mean zero, so sum D_i^2 / N^2 estimates the variance of the mean difference.
pub fn z_same_mean(a: &Image, b: &Image) -> DVec3 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let (mut s, mut s2) = (DVec3::ZERO, DVec3::ZERO);
    for (x, y) in a.pixels.iter().zip(&b.pixels) {
        let d = x.as_dvec3() - y.as_dvec3();
        s += d;
        s2 += d * d;
    }
    DVec3::new(ratio(s.x, s2.x), ratio(s.y, s2.y), ratio(s.z, s2.z))
}

/// Assert that independent renders `a` and `b` have the same expectation: every channel's
/// [`z_same_mean`] below 4.5 (false-failure rate about 2e-5 for the three channels).
pub fn assert_same_mean(a: &Image, b: &Image, what: &str) {
    let z = z_same_mean(a, b);
    assert!(
        z.abs().max_element() < 4.5,
        "{what}: z = {z}, means {} vs {}",
        a.mean(),
        b.mean()
    );
}

fn ratio(s: f64, s2: f64) -> f64 {
    if s2 == 0.0 { 0.0 } else { s / s2.sqrt() }
}

/// Mean and standard error of the image mean, per channel, treating pixels as independent
/// estimates of the same value (valid when the true image is constant).
pub fn mean_and_stderr(img: &Image) -> (DVec3, DVec3) {
    let n = img.pixels.len() as f64;
    let mean = img.mean();
    let var = img
        .pixels
        .iter()
        .map(|p| {
            let d = p.as_dvec3() - mean;
            d * d
        })
        .sum::<DVec3>()
        / (n - 1.0);
    (mean, (var / n).map(f64::sqrt))
}

/// Assert that `img` is the constant `expected` (per channel): a z-test of the image mean at
/// |z| < 4.5 (false-failure rate below 1e-5), with the f32 resolution of the image (1e-6
/// relative) added to the standard error so that noiseless images compare too.
pub fn assert_constant_image(img: &Image, expected: [f64; 3], label: &str) {
    let (mean, se) = mean_and_stderr(img);
    for (c, e) in expected.into_iter().enumerate() {
        let z = (mean[c] - e) / (se[c] + 1e-6 * e.abs());
        assert!(
            z.abs() < 4.5,
            "{label}: channel {c}: mean {} expected {e} (se {}, z {z})",
            mean[c],
            se[c]
        );
    }
}

/// Welch's t per channel of "the samples `a` and `b` (independent renders' image means) have
/// the same expectation".
pub fn welch_t(a: &[DVec3], b: &[DVec3]) -> DVec3 {
    let stats = |v: &[DVec3]| {
        let m = v.iter().sum::<DVec3>() / v.len() as f64;
        let var = v.iter().map(|x| (*x - m) * (*x - m)).sum::<DVec3>() / (v.len() - 1) as f64;
        (m, var / v.len() as f64)
    };
    let ((ma, va), (mb, vb)) = (stats(a), stats(b));
    let t = (ma - mb) / (va + vb).map(f64::sqrt);
    eprintln!("welch: {ma:?} vs {mb:?}, t {t:?}");
    t
}
