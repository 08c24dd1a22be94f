//! Bidirectional path tracing: the MIS densities every technique assembles for a path agree
//! with the path's densities computed from scratch (so the weights of all techniques that can
//! produce a path sum to one), and bdpt / lt converge to pt's image.
//!
//! Statistical checks are z-tests at |z| < 4.5 per channel (false-failure rate below 1e-5
//! each) with fixed seeds.

use crate::util;

use glam::Vec2;
use lodestar::integrators::bdpt::{BdptSettings, Tracer};
use lodestar::integrators::paths::{Heuristic, PathTerms, path_terms};
use lodestar::math::{IndependentSampler, Sampler, luminance};
use lodestar::path::MAX_VERTICES;
use lodestar::scene::Scene;
use std::cell::RefCell;
use std::rc::Rc;

fn diffuse_box(res: u32) -> Scene {
    let text = lodestar::scene::CORNELL_BOX_TOML
        .replace("material = \"glass\"", "material = \"white\"")
        .replace(
            "resolution = [256, 256]",
            &format!("resolution = [{res}, {res}]"),
        );
    util::scene(&text)
}

fn scene_file(name: &str, res: u32) -> Scene {
    let text =
        std::fs::read_to_string(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    util::scene(&text.replace(
        "resolution = [256, 256]",
        &format!("resolution = [{res}, {res}]"),
    ))
}

/// For many BDPT samples, every technique's assembled density terms must give the same
/// technique densities as `path_terms` computed from the path alone (relative 1e-4), and
/// the weight bdpt applied plus the other techniques' weights for the same path sum to one.
fn check_densities(name: &str, scene: &Scene) {
    let settings = BdptSettings {
        max_depth: 6,
        rr_depth: 3,
        heuristic: Heuristic::Balance,
        light_tracing: false,
        techniques: Default::default(),
        direct_splats: false,
    };
    let checked = Rc::new(RefCell::new((0usize, Vec::<String>::new())));
    let sink = checked.clone();
    let mut tracer = Tracer::new(scene, &settings);
    tracer.inspector = Some(RefCell::new(Box::new(
        move |path: &[_], s: usize, terms: &PathTerms| {
            let reference = path_terms(scene, path, settings.rr_depth);
            let (mut a, mut b) = ([0.0f64; MAX_VERTICES], [0.0f64; MAX_VERTICES]);
            terms.technique_densities(&mut a);
            reference.technique_densities(&mut b);
            let k = terms.k;
            let mut c = sink.borrow_mut();
            c.0 += 1;
            for i in 0..=k {
                let ok = (a[i] == 0.0 && b[i] == 0.0)
                    || ((a[i] - b[i]).abs() <= 1e-4 * a[i].abs().max(b[i].abs()));
                if !ok && c.1.len() < 5 {
                    c.1.push(format!(
                        "k {k}, technique s {s}: density of s' = {i}: assembled {} vs reference {}",
                        a[i], b[i]
                    ));
                }
            }
            // The weight bdpt applied (from its assembled terms) plus the weights every
            // other technique would give the same path (from the path alone) must make one:
            // a density that the walk caches wrongly for one technique breaks the sum.
            let sum: f64 = terms.weight(s, Heuristic::Balance)
                + (0..=k)
                    .filter(|&i| i != s)
                    .map(|i| reference.weight(i, Heuristic::Balance))
                    .sum::<f64>();
            if b[s] > 0.0 && (sum - 1.0).abs() > 1e-4 && c.1.len() < 5 {
                c.1.push(format!("weights sum to {sum}"));
            }
        },
    )));
    let res = scene.camera.resolution;
    for i in 0..400u64 {
        let mut sampler = IndependentSampler::new(3, 0, i);
        let raster = Vec2::new(
            (i % res.x as u64) as f32,
            (i / res.x as u64 % res.y as u64) as f32,
        ) + sampler.next_2d();
        tracer.sample(raster, &mut sampler);
    }
    drop(tracer);
    let c = checked.borrow();
    assert!(c.0 > 500, "{name}: only {} paths checked", c.0);
    assert!(
        c.1.is_empty(),
        "{name}: {} paths checked; mismatches:\n{}",
        c.0,
        c.1.join("\n")
    );
}

#[test]
fn technique_densities_agree_with_the_reference_diffuse() {
    check_densities("diffuse box", &diffuse_box(20));
}

#[test]
fn technique_densities_agree_with_the_reference_glass() {
    check_densities("cornell-box (glass)", &scene_file("cornell-box.toml", 20));
}

#[test]
fn technique_densities_agree_with_the_reference_fog() {
    check_densities("cornell-fog", &scene_file("cornell-fog.toml", 20));
}

/// bdpt converges to pt's image on the three Cornell boxes: a per-channel z-test of the
/// pixel differences at 32 x 32 (`util::assert_same_mean`), then tile by tile at 16 x 16 over
/// 5 seeded renders each (`util::assert_same_image`: Welch's t per 4 x 4 tile and channel,
/// Bonferroni, family-wise false-failure rate 1e-4; bdpt's light-tracing splats make nearby
/// pixels correlated, which the tiles' means absorb). Control: bdpt's images mirrored left to
/// right (same mean, the red and green walls' light swapped) must fail the tile comparison.
#[test]
fn bdpt_agrees_with_pt() {
    for name in [
        "cornell-box.toml",
        "cornell-glossy.toml",
        "cornell-fog.toml",
    ] {
        let scene = scene_file(name, 32);
        let pt = util::render(&scene, "pt", 6, &[], 256, 1, 2).image;
        let bd = util::render(&scene, "bdpt", 6, &[], 128, 3, 2).image;
        util::assert_same_mean(&bd, &pt, &format!("{name}: bdpt vs pt"));
        let scene = scene_file(name, 16);
        let pt = util::seeded_renders(&scene, "pt", 6, &[], 64, 5, 10);
        let bd = util::seeded_renders(&scene, "bdpt", 6, &[], 32, 5, 20);
        util::assert_same_image(&pt, &bd, 4, &format!("{name}: bdpt vs pt"));
        let flipped: Vec<_> = bd.iter().map(util::mirrored).collect();
        assert!(
            util::differs(&pt, &flipped, 4),
            "{name}: mirrored bdpt passes"
        );
    }
}

/// lt's pixels share light paths, so lt and pt are compared tile by tile over 5 seeded renders
/// each (`util::assert_same_image`, family-wise false-failure rate 1e-4), after the
/// whole-image z test; the control, lt's images mirrored left to right (same mean, energy
/// moved between the red and the green side), must fail the tile comparison.
fn lt_agrees_with_pt(scene: &Scene, what: &str) {
    let pt = util::seeded_renders(scene, "pt", 6, &[], 64, 5, 10);
    let lt = util::seeded_renders(scene, "lt", 6, &[], 64, 5, 20);
    util::assert_same_mean(&lt[0], &pt[0], &format!("{what}: lt vs pt"));
    util::assert_same_image(&pt, &lt, 4, &format!("{what}: lt vs pt"));
    let flipped: Vec<_> = lt.iter().map(util::mirrored).collect();
    assert!(
        util::differs(&pt, &flipped, 4),
        "{what}: mirrored lt passes"
    );
}

/// lt converges where it can (no specular surface seen from the camera).
#[test]
fn lt_agrees_with_pt_on_the_diffuse_box() {
    lt_agrees_with_pt(&diffuse_box(24), "diffuse box");
}

/// lt in a medium: the fog box has no specular surface, so light tracing converges there too.
#[test]
fn lt_agrees_with_pt_in_the_fog_box() {
    lt_agrees_with_pt(&scene_file("cornell-fog.toml", 24), "fog box");
}

/// The two samples that rendered NaN pixels on fog-dragon (seed 0; pass 7, pixel 72965 and
/// pass 28, pixel 30998 of 3M searched): a free flight of length exactly 0 (uniform 0) put
/// a medium vertex on the floor vertex it left, and the zero-length edge gave NaN densities
/// and directions. Both are finite now (`HomogeneousMedium::sample_distance` draws t > 0).
#[test]
fn fog_dragon_samples_that_were_nan_are_finite() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/fog-dragon.toml");
    let scene = lodestar::scene::loader::load_file(&path).unwrap();
    let settings = BdptSettings {
        max_depth: scene.render.max_depth,
        rr_depth: 5,
        heuristic: Heuristic::Balance,
        light_tracing: false,
        techniques: Default::default(),
        direct_splats: false,
    };
    let mut tracer = Tracer::new(&scene, &settings);
    let w = scene.camera.resolution.x as u64;
    for (pass, index) in [(7u64, 72965u64), (28, 30998)] {
        let mut s = IndependentSampler::new(0, pass, index);
        let pixel = glam::Vec2::new((index % w) as f32, (index / w) as f32);
        let v = tracer.sample(pixel + s.next_2d(), &mut s);
        assert!(
            v.is_finite() && v.min_element() >= 0.0,
            "pass {pass} pixel {index}: {v}"
        );
        for (p, c) in tracer.splats.drain(..) {
            assert!(c.is_finite() && c.min_element() >= 0.0, "splat to {p}: {c}");
        }
        assert!(
            v.max_element() > 0.0,
            "the sample no longer reaches the light: not a regression test"
        );
    }
}

/// `-O only=s,t` renders one technique MIS-weighted: over every technique up to the depth
/// limit, the images of one seed sum to a bdpt image (their subpaths are the seed's; only the
/// next-event light samples differ), compared tile by tile with full bdpt over 5 seeds each
/// (`util::assert_same_image`, family-wise false-failure rate 1e-4). Controls, each of which
/// must fail the same comparison: bdpt with one technique's weighted contribution dropped
/// (`-O skip=s,t`): next-event estimation from the first camera vertex (1,2), and the
/// two-segment light-vertex connection (2,2), a small share of the image.
#[test]
fn technique_images_sum_to_bdpt_and_a_dropped_technique_is_caught() {
    let scene = scene_file("cornell-box.toml", 16);
    let depth = 4u32;
    // 128 spp for bdpt and the controls: with roulette from the first bounce (the default)
    // the (2,2) control's missing share is within 32 spp's noise.
    let full = util::seeded_renders(&scene, "bdpt", depth, &[], 128, 5, 100);
    let sums: Vec<_> = (0..5)
        .map(|i| {
            let mut sum = lodestar::film::Image::new(16, 16);
            for k in 1..=depth as usize {
                for t in 1..=k + 1 {
                    let only = format!("only={},{t}", k + 1 - t);
                    let img = util::render(&scene, "bdpt", depth, &[&only], 32, 200 + i, 2).image;
                    for (a, b) in sum.pixels.iter_mut().zip(&img.pixels) {
                        *a += *b;
                    }
                }
            }
            sum
        })
        .collect();
    util::assert_same_image(&full, &sums, 4, "sum of the technique images vs bdpt");
    for skip in ["1,2", "2,2"] {
        let option = format!("skip={skip}");
        let dropped = util::seeded_renders(&scene, "bdpt", depth, &[&option], 128, 5, 300);
        assert!(
            util::differs(&full, &dropped, 4),
            "bdpt without technique ({skip}) passes as bdpt"
        );
    }
}

/// The technique options name what they expect.
#[test]
fn technique_options_are_checked() {
    for (options, expected) in [
        (vec!["only=1"], "expected a technique 's,t'"),
        (vec!["skip=1,0"], "t >= 1 camera vertices"),
        (vec!["only=1,2", "skip=2,2"], "exclude each other"),
    ] {
        let options = lodestar::integrators::Options::parse(
            &options.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
        )
        .unwrap();
        let params = lodestar::integrators::IntegratorParams {
            max_depth: 4,
            options,
        };
        let err = match lodestar::integrators::build("bdpt", &params) {
            Ok(_) => panic!("{expected}: accepted"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains(expected), "{err}");
    }
}

/// Traces `n` samples with the recursive MIS weights and the same samples (same random
/// streams) with the explicit ones; returns the number of non-zero values compared and the
/// mismatches (relative 1e-5 per channel, pixel values and light-tracing splats).
fn recursive_against_explicit(
    scene: &Scene,
    recursive: Heuristic,
    explicit: Heuristic,
    n: u64,
) -> (usize, Vec<String>) {
    let settings = |heuristic| BdptSettings {
        max_depth: scene.render.max_depth.min(12),
        rr_depth: 1,
        heuristic,
        light_tracing: false,
        techniques: Default::default(),
        direct_splats: false,
    };
    let (sr, se) = (settings(recursive), settings(explicit));
    let mut fast = Tracer::new(scene, &sr);
    let mut slow = Tracer::new(scene, &se);
    slow.explicit_weights = true;
    let res = scene.camera.resolution;
    let (mut compared, mut bad) = (0usize, Vec::new());
    let mut same = |what: String, a: glam::Vec3, b: glam::Vec3, bad: &mut Vec<String>| {
        let ok = (a - b).abs().max_element() <= 1e-5 * a.abs().max(b.abs()).max_element() + 1e-30;
        if a.max_element() > 0.0 {
            compared += 1;
        }
        if !ok && bad.len() < 5 {
            bad.push(format!("{what}: recursive {a} vs explicit {b}"));
        }
    };
    for i in 0..n {
        let pixel = Vec2::new(
            (i * 7919 % res.x as u64) as f32,
            (i * 104729 / res.x as u64 % res.y as u64) as f32,
        );
        let mut s1 = IndependentSampler::new(5, 0, i);
        let mut s2 = IndependentSampler::new(5, 0, i);
        let raster = pixel + s1.next_2d();
        s2.next_2d();
        let a = fast.sample(raster, &mut s1);
        let b = slow.sample(raster, &mut s2);
        same(format!("sample {i}"), a, b, &mut bad);
        let (sa, sb) = (
            std::mem::take(&mut fast.splats),
            std::mem::take(&mut slow.splats),
        );
        assert_eq!(sa.len(), sb.len(), "sample {i}: splat counts differ");
        for ((pa, ca), (pb, cb)) in sa.into_iter().zip(sb) {
            assert_eq!(pa, pb, "sample {i}: splat pixels differ");
            same(format!("sample {i} splat"), ca, cb, &mut bad);
        }
    }
    (compared, bad)
}

/// The recursive MIS weights (O(1) per connection, the default with roulette from the first
/// bounce) equal the explicit ones sample by sample, for both heuristics, in scenes with
/// glass, glossy surfaces, fog, a sun, an environment and a point light (every special end
/// of the recursion: hittable and delta lights, next-event estimation, emitter hits at
/// k = 1, medium vertices). Deterministic: the two tracers see the same random numbers.
/// Control: the recursive balance weights against explicit power weights must differ.
#[test]
fn recursive_mis_weights_equal_the_explicit_weights() {
    let point_text = lodestar::scene::CORNELL_BOX_TOML
        .replace("resolution = [256, 256]", "resolution = [24, 24]")
        + util::POINT_LIGHT;
    let scenes = [
        ("cornell-box.toml", scene_file("cornell-box.toml", 24)),
        ("cornell-glossy.toml", scene_file("cornell-glossy.toml", 24)),
        ("cornell-fog.toml", scene_file("cornell-fog.toml", 24)),
        ("pool.toml", scene_file("pool.toml", 24)),
        ("furnace.toml", scene_file("furnace.toml", 24)),
        ("point light", util::scene(&point_text)),
    ];
    for (name, scene) in &scenes {
        for h in [Heuristic::Balance, Heuristic::Power] {
            let (compared, bad) = recursive_against_explicit(scene, h, h, 1500);
            assert!(
                compared > 300,
                "{name} {h:?}: only {compared} values compared"
            );
            assert!(
                bad.is_empty(),
                "{name} {h:?}: {compared} values compared; mismatches:\n{}",
                bad.join("\n")
            );
        }
    }
    let (_, bad) =
        recursive_against_explicit(&scenes[0].1, Heuristic::Balance, Heuristic::Power, 300);
    assert!(
        !bad.is_empty(),
        "control: balance and power weights were not told apart"
    );
}

/// A directly seen emitter that fills its pixel with nothing but vacuum between is left to the
/// camera ray (s = 0; `PathTerms`' module doc): the pixels inside the Cornell box's light
/// (black, so only the paths E L end there) are its radiance exactly in every seed for pt,
/// bdpt and vcm, and bdpt's (1, 1) image is black there, while it splats on every pixel of
/// the light's edges. Before, the light tracer's splats took part of the weight inside the
/// light too, and those pixels varied from seed to seed. Through fog (cornell-fog's cube grown
/// around the view of the light) both techniques stay: its (1, 1) image is not black.
#[test]
fn directly_seen_emitters_are_left_to_the_camera() {
    let scene = scene_file("cornell-box.toml", 128);
    let le = glam::Vec3::new(17.0, 12.0, 4.0);
    let pt = util::render(&scene, "pt", 4, &[], 8, 1, 2).image;
    // Pixels inside the light's image: pt sees only the light there and in the 4 beside.
    let w = scene.camera.resolution.x as usize;
    let h = pt.pixels.len() / w;
    let light: Vec<usize> = (0..pt.pixels.len())
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            (x >= 1 && y >= 1 && x + 1 < w && y + 1 < h)
                && [i, i - 1, i + 1, i - w, i + w]
                    .iter()
                    .all(|&j| pt.pixels[j] == le)
        })
        .collect();
    assert!(light.len() >= 8, "only {} light pixels", light.len());
    for name in ["bdpt", "vcm"] {
        for seed in [1, 2] {
            let img = util::render(&scene, name, 4, &[], 8, seed, 2).image;
            for &i in &light {
                assert_eq!(img.pixels[i], le, "{name}, seed {seed}, pixel {i}");
            }
        }
    }
    // The light tracer's splats stay at the light's edges, where the camera's samples hit or
    // miss it.
    let splats = util::render(&scene, "bdpt", 4, &["only=1,1"], 8, 1, 2).image;
    assert!(light.iter().all(|&i| splats.pixels[i] == glam::Vec3::ZERO));
    let edges = (0..pt.pixels.len())
        .filter(|&i| pt.pixels[i] != le && luminance(pt.pixels[i]) > 2.0)
        .count();
    let edge_splats = (0..pt.pixels.len())
        .filter(|&i| pt.pixels[i] != le && splats.pixels[i] != glam::Vec3::ZERO)
        .count();
    // (Not all: a pixel the light barely touches may get no splat in 8 passes, and one the
    // 3 x 3 test grid finds filled may still have an uncovered sliver.)
    assert!(
        edges > 0 && edge_splats * 2 >= edges,
        "{edges} edge pixels, {edge_splats} with splats"
    );
    // cornell-fog's cube, grown to hold most of the box: the light is seen through it.
    let text = std::fs::read_to_string(format!(
        "{}/scenes/cornell-fog.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let grown = "transform = { scale = [0.98, 0.98, 0.98] }";
    let fog = util::scene(
        &text
            .lines()
            .map(|l| if l.starts_with("transform") { grown } else { l })
            .collect::<Vec<_>>()
            .join("\n")
            .replace("resolution = [256, 256]", "resolution = [32, 32]"),
    );
    let splats = util::render(&fog, "bdpt", 4, &["only=1,1"], 8, 1, 2).image;
    assert!(splats.pixels.iter().any(|&p| p != glam::Vec3::ZERO));
}
