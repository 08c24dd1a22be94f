//! Shared helpers for whole-renderer tests: build scenes from TOML text, render through the
//! registry on a fixed thread pool, and simple statistics on images.

#![allow(dead_code)]

pub mod caustics;
pub mod guided;

use glam::DVec3;
use lodestar::film::Image;
use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::{Budget, RenderResult};
use lodestar::scene::{Scene, loader};

pub fn scene(toml: &str) -> Scene {
    loader::load_str(toml, "test.toml", None).unwrap_or_else(|e| panic!("test scene: {e}"))
}

/// A shipped scene (`scenes/NAME.toml`) at `w` x `h` pixels.
pub fn shipped_at(name: &str, w: u32, h: u32) -> Scene {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
    let small: Vec<String> = text
        .lines()
        .map(|l| {
            if l.trim_start().starts_with("resolution =") {
                format!("resolution = [{w}, {h}]")
            } else {
                l.to_string()
            }
        })
        .collect();
    loader::load_str(&small.join("\n"), name, Some(&dir)).unwrap_or_else(|e| panic!("{e}"))
}

/// The Cornell box at a reduced resolution.
pub fn cornell(resolution: u32) -> Scene {
    let text = lodestar::scene::CORNELL_BOX_TOML.replace(
        "resolution = [256, 256]",
        &format!("resolution = [{resolution}, {resolution}]"),
    );
    scene(&text)
}

/// The Cornell box's ceiling light as a checkerboard of 2 x 2 squares (TOML
/// `emission_texture`, multiplying its emission), for [`cornell_light_with`].
pub const CHECKER_EMISSION: &str = "emission_texture = { type = \"checkerboard\", \
     color0 = [1, 1, 1], color1 = [0.2, 0.5, 0.1], scale = [2, 2] }";

/// The Cornell box at `w` x `h` with `extra` added to its light (e.g. [`CHECKER_EMISSION`]).
pub fn cornell_light_with(w: u32, h: u32, extra: &str) -> Scene {
    let text = lodestar::scene::CORNELL_BOX_TOML
        .replace(
            "resolution = [256, 256]",
            &format!("resolution = [{w}, {h}]"),
        )
        .replace(
            "emission = [17, 12, 4]",
            &format!("emission = [17, 12, 4]\n{extra}"),
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

/// The end-of-render statistic `key` of a render, if it reported one.
pub fn stat<'r>(r: &'r RenderResult, key: &str) -> Option<&'r str> {
    r.stats
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
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

/// Means of `block` x `block` pixel tiles (the last row and column of tiles may be smaller).
pub fn block_means(img: &Image, block: u32) -> Vec<DVec3> {
    let (bw, bh) = (img.width.div_ceil(block), img.height.div_ceil(block));
    let mut sums = vec![(DVec3::ZERO, 0u32); (bw * bh) as usize];
    for y in 0..img.height {
        for x in 0..img.width {
            let b = &mut sums[((y / block) * bw + x / block) as usize];
            b.0 += img.pixels[(y * img.width + x) as usize].as_dvec3();
            b.1 += 1;
        }
    }
    sums.into_iter().map(|(s, n)| s / n as f64).collect()
}

/// Welch's two-sided p-value of "two estimates have the same expectation", each given as
/// (mean, squared standard error, degrees of freedom): Student's t with the
/// Welch-Satterthwaite degrees of freedom (at least 1). Without any error, 1 if the means are
/// equal and 0 if not.
pub fn welch_p((ma, va, da): (f64, f64, f64), (mb, vb, db): (f64, f64, f64)) -> f64 {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let se2 = va + vb;
    if se2 == 0.0 {
        return if ma == mb { 1.0 } else { 0.0 };
    }
    let t = (ma - mb) / se2.sqrt();
    let dof = se2 * se2 / (va * va / da + vb * vb / db);
    let st = StudentsT::new(0.0, 1.0, dof.max(1.0)).unwrap();
    2.0 * st.cdf(-t.abs())
}

/// With `LODESTAR_TEST_MARGINS` set, print a comparison's smallest p-value against its
/// threshold (run the tests with `--nocapture`): how far a test passes, and how far its controls
/// fail, when resizing it.
pub fn report_margin(what: &str, p: f64, alpha: f64) {
    if std::env::var_os("LODESTAR_TEST_MARGINS").is_some() {
        eprintln!("margin: {what}: p = {p:.2e}, threshold {alpha:.2e}");
    }
}

/// Assert that two sets of independently seeded renders have the same expected image, tile by
/// tile: for every `block` x `block` tile and channel, Welch's t of the renders' tile means
/// (pixels within one render may be correlated, as in lt and vcm whose light paths splat
/// anywhere, so only the renders are taken as independent), its two-sided p-value from
/// Student's t with the Welch-Satterthwaite degrees of freedom, and a Bonferroni bound over
/// all tiles and channels at a family-wise false-failure rate of 1e-4. Energy moved between
/// tiles fails here even when the whole-image mean agrees.
pub fn assert_same_image(a: &[Image], b: &[Image], block: u32, what: &str) {
    assert!(
        a.len() >= 3 && b.len() >= 3,
        "{what}: need at least 3 renders a side"
    );
    let tiles = |v: &[Image]| v.iter().map(|i| block_means(i, block)).collect::<Vec<_>>();
    let (ta, tb) = (tiles(a), tiles(b));
    let n_tiles = ta[0].len();
    let alpha = 1e-4 / (3 * n_tiles) as f64;
    let stats = |t: &[Vec<DVec3>], i: usize, c: usize| {
        let n = t.len() as f64;
        let m = t.iter().map(|r| r[i][c]).sum::<f64>() / n;
        let var = t.iter().map(|r| (r[i][c] - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, var / n, n - 1.0)
    };
    let mut worst = (1.0f64, 0usize, 0usize, 0.0f64, 0.0f64);
    for i in 0..n_tiles {
        for c in 0..3 {
            let ((ma, va, da), (mb, vb, db)) = (stats(&ta, i, c), stats(&tb, i, c));
            let p = welch_p((ma, va, da), (mb, vb, db));
            if p < worst.0 {
                worst = (p, i, c, ma, mb);
            }
        }
    }
    let (p, i, c, ma, mb) = worst;
    report_margin(what, p, alpha);
    assert!(
        p >= alpha,
        "{what}: tile {i} channel {c} differs: means {ma} vs {mb}, p = {p:.2e} < {alpha:.2e}"
    );
}

/// The Cornell box text at `resolution` with every length multiplied by `scale` and every
/// position then moved by `offset` along each axis (a scene far from the origin).
pub fn transformed_cornell(scale: f64, offset: f64, resolution: u32) -> String {
    let mut out = String::new();
    for line in lodestar::scene::CORNELL_BOX_TOML.lines() {
        let key = line.split('=').next().unwrap_or("").trim();
        let moved = match key {
            "position" | "look_at" | "origin" | "center" => {
                map_numbers(line, |v| v * scale + offset)
            }
            "edge_u" | "edge_v" | "radius" => map_numbers(line, |v| v * scale),
            "transform" => {
                // Scale and translation follow the scene; the rotation does not.
                let (head, rest) = line.split_once("rotate").unwrap();
                let (rot, tail) = rest.split_once("},").unwrap();
                format!(
                    "{}rotate{rot}}},{}",
                    map_numbers(head, |v| v * scale),
                    map_numbers(tail, |v| v * scale + offset)
                )
            }
            _ => line.to_string(),
        };
        out.push_str(&moved);
        out.push('\n');
    }
    out.replace(
        "resolution = [256, 256]",
        &format!("resolution = [{resolution}, {resolution}]"),
    )
}

/// Apply `f` to every number in `text` (keys hold no digits).
fn map_numbers(text: &str, f: impl Fn(f64) -> f64) -> String {
    let mut out = String::new();
    let mut num = String::new();
    let flush = |num: &mut String, out: &mut String| {
        if !num.is_empty() {
            let v: f64 = num.parse().unwrap();
            out.push_str(&format!("{:e}", f(v)));
            num.clear();
        }
    };
    for c in text.chars() {
        let continues = match c {
            '0'..='9' | '.' => true,
            '-' => num.is_empty() || num.ends_with('e'),
            'e' => num.ends_with(|d: char| d.is_ascii_digit()),
            _ => false,
        };
        if continues {
            num.push(c);
        } else {
            flush(&mut num, &mut out);
            out.push(c);
        }
    }
    flush(&mut num, &mut out);
    out
}

/// `seeds` renders of `name` (seeds `seed0`, `seed0 + 1`, ...), each with no invalid sample.
pub fn seeded_renders(
    scene: &Scene,
    name: &str,
    max_depth: u32,
    options: &[&str],
    spp: u64,
    seeds: u64,
    seed0: u64,
) -> Vec<Image> {
    (0..seeds)
        .map(|i| {
            let r = render(scene, name, max_depth, options, spp, seed0 + i, 2);
            for (k, v) in &r.stats {
                if k.starts_with("invalid_") {
                    assert_eq!(v, "0", "{name} (seed {}): {k}", seed0 + i);
                }
            }
            r.image
        })
        .collect()
}

/// The image mirrored left to right: the same mean with energy moved between pixels (the
/// control of the per-tile comparisons).
pub fn mirrored(img: &Image) -> Image {
    let mut out = img.clone();
    for y in 0..img.height {
        for x in 0..img.width {
            out.pixels[(y * img.width + x) as usize] =
                img.pixels[(y * img.width + img.width - 1 - x) as usize];
        }
    }
    out
}

/// Whether [`assert_same_image`] rejects `a` against `b` (for controls that must fail).
pub fn differs(a: &[Image], b: &[Image], block: u32) -> bool {
    std::panic::catch_unwind(|| assert_same_image(a, b, block, "control")).is_err()
}

/// A point light at (0, 0.3, 0), with a 10 cm black shade in front of it: pt can never see a
/// point light directly (a camera ray hits it with probability zero) while lt and bdpt splat
/// it onto its pixel, so the light itself is kept out of view.
pub const POINT_LIGHT: &str = r#"
[[shape]]
name = "shade"
type = "quad"
origin = [-0.05, 0.25, 0.1]
edge_u = [0.1, 0, 0]
edge_v = [0, 0.1, 0]
material = "black"

[[light]]
type = "point"
position = [0, 0.3, 0]
intensity = [2, 2, 2]
"#;

/// How much `f` of a path can change when each vertex position moves within its rounding
/// bound `p_err` (the error of an f32 hit point): the linearised maximum over that box,
/// Σ_j |f(y + e_j) − f(y − e_j)| / 2 over every coordinate j of every vertex, with e_j the
/// bound along j. Tests comparing a value carried through sampling with the same value
/// recomputed from the stored (rounded) vertices allow a multiple of this, not a hand-set
/// relative tolerance.
pub fn rounding_sensitivity(
    y: &[lodestar::integrators::paths::Vertex],
    f: impl Fn(&[lodestar::integrators::paths::Vertex]) -> f64,
) -> f64 {
    let mut moved = y.to_vec();
    let mut total = 0.0;
    for i in 0..y.len() {
        for axis in 0..3 {
            let e = y[i].p_err[axis];
            if e == 0.0 {
                continue;
            }
            moved[i].p[axis] = y[i].p[axis] + e;
            let up = f(&moved);
            moved[i].p[axis] = y[i].p[axis] - e;
            let down = f(&moved);
            moved[i].p[axis] = y[i].p[axis];
            total += (up - down).abs() / 2.0;
        }
    }
    total
}
