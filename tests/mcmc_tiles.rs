//! pssmlt and mmlt render pt's image tile by tile, and three deliberate errors of the chains
//! (`mcmc::faults::Faults`) fail the same test:
//! - every large step accepted (a wrong acceptance),
//! - mmlt's normalisation b of one path length doubled,
//! - every splat landing one pixel further along its row.
//!
//! Unlike a test of the image mean (which a chain meets by construction: each mutation splats
//! b's worth of luminance wherever it lands), the per-tile test sees where the chains put
//! their splats. A chain side is `SEEDS` independently seeded renders of a 16 x 16 Cornell
//! box, a control's side as many as its margin needs (each states it); pt's side is the 40
//! renders [`pt_renders`] makes once for all three tests (one of the two sets of
//! [`the_tile_test_sees_a_ten_percent_change_in_any_tile`]). `util::assert_same_image`
//! compares every 4 x 4 tile and channel by Welch's t with a Bonferroni bound, family-wise
//! false-failure rate 1e-4 per comparison (fixed seeds), and then the whole image as one tile
//! (the renders' means, each with its own estimate of b).

use crate::util;

use lodestar::film::Image;
use lodestar::integrators::mcmc::faults::Faults;
use lodestar::integrators::mcmc::mmlt::mmlt_bdpt_settings;
use lodestar::integrators::mcmc::{McmcSettings, Mmlt, Pssmlt, Split};
use lodestar::integrators::paths::Heuristic;
use lodestar::integrators::pt::{PathTracer, PtSettings};
use lodestar::render::{Budget, Integrator, RenderContext};
use lodestar::scene::Scene;
use std::sync::OnceLock;

const SEEDS: u64 = 20;
const BLOCK: u32 = 4;
const MAX_DEPTH: u32 = 5;
/// Mutations per pixel of a chain render.
const SPP: u64 = 128;
/// Samples per pixel of a pt render (the reference side: cheap, so its noise is small).
const PT_SPP: u64 = 512;

fn scene() -> Scene {
    util::cornell(16)
}

fn settings(faults: Faults) -> McmcSettings {
    McmcSettings {
        bootstrap: 20_000,
        chains: 256,
        faults,
        ..McmcSettings::default()
    }
}

fn render_with(scene: &Scene, make: &dyn Fn() -> Box<dyn Integrator>, seed: u64) -> Image {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut integrator = make();
    pool.install(|| {
        integrator
            .render(&RenderContext::new(scene, seed, false), Budget::Spp(SPP))
            .image
    })
}

fn pssmlt(faults: Faults) -> Box<dyn Integrator> {
    pssmlt_split(faults, McmcSettings::default().split)
}

fn pssmlt_split(faults: Faults, split: Split) -> Box<dyn Integrator> {
    Box::new(Pssmlt {
        pt: PathTracer {
            settings: PtSettings {
                max_depth: MAX_DEPTH,
                ..PtSettings::default()
            },
        },
        settings: McmcSettings {
            split,
            ..settings(faults)
        },
    })
}

fn mmlt(faults: Faults) -> Box<dyn Integrator> {
    Box::new(Mmlt {
        bdpt: mmlt_bdpt_settings(MAX_DEPTH, Heuristic::Balance),
        settings: settings(faults),
    })
}

/// `n` renders, seeds `first_seed`, `first_seed + 1`, ...
fn renders(
    scene: &Scene,
    make: &dyn Fn() -> Box<dyn Integrator>,
    first_seed: u64,
    n: u64,
) -> Vec<Image> {
    (0..n)
        .map(|s| render_with(scene, make, first_seed + s))
        .collect()
}

/// `n` pt renders of [`scene`], seeds `first_seed`, `first_seed + 1`, ...
fn pt_set(first_seed: u64, n: u64) -> Vec<Image> {
    let scene = scene();
    (0..n)
        .map(|s| util::render(&scene, "pt", MAX_DEPTH, &[], PT_SPP, first_seed + s, 2).image)
        .collect()
}

/// pt's side of every comparison in this file: 40 renders (seeds 3000 to 3039), made once by
/// whichever test needs them first.
fn pt_renders() -> &'static [Image] {
    static PT: OnceLock<Vec<Image>> = OnceLock::new();
    PT.get_or_init(|| pt_set(3000, 40))
}

/// Whether `util::assert_same_image` rejects `a` against `b`.
fn rejected(a: &[Image], b: &[Image], what: &str) -> bool {
    std::panic::catch_unwind(|| util::assert_same_image(a, b, BLOCK, what)).is_err()
}

/// Each control renders as many seeds as its margin needs; measured against the bound 2.1e-6:
/// every large step accepted, 20 renders, p = 4.4e-12; splats one pixel off, 10 renders,
/// p = 1.5e-10.
#[test]
fn pssmlt_renders_pt_image_and_its_faults_do_not() {
    let scene = scene();
    let pt = pt_renders();
    let ok = renders(&scene, &|| pssmlt(Faults::default()), 0, SEEDS);
    util::assert_same_image(&ok, pt, BLOCK, "pssmlt against pt");
    // The whole image as one tile: the renders' means (b's estimate included) agree.
    util::assert_same_image(&ok, pt, 16, "pssmlt against pt, image means");
    // With the paths only a continued walk finds (through the glass sphere, the light seen
    // directly) split off to the per-pixel estimate, and kept in the chains.
    for split in [Split::Always, Split::Never] {
        let other = renders(
            &scene,
            &|| pssmlt_split(Faults::default(), split),
            100,
            SEEDS,
        );
        util::assert_same_image(&other, pt, BLOCK, &format!("pssmlt ({split:?}) against pt"));
    }
    for (what, faults, n) in [
        (
            "pssmlt, every large step accepted (control)",
            Faults {
                accept_large: true,
                ..Faults::default()
            },
            20,
        ),
        (
            "pssmlt, splats one pixel off (control)",
            Faults {
                shift_splats: true,
                ..Faults::default()
            },
            10,
        ),
    ] {
        let wrong = renders(&scene, &|| pssmlt(faults), 0, n);
        assert!(rejected(&wrong, pt, what), "{what}: passed");
    }
}

/// Each control renders as many seeds as its margin needs; measured against the bound 2.1e-6:
/// every large step accepted, 10 renders, p = 1.0e-11; b of one length doubled, 16 renders,
/// p = 8.8e-12; splats one pixel off, 6 renders, p = 9.0e-19.
#[test]
fn mmlt_renders_pt_image_and_its_faults_do_not() {
    let scene = scene();
    let pt = pt_renders();
    let ok = renders(&scene, &|| mmlt(Faults::default()), 0, SEEDS);
    util::assert_same_image(&ok, pt, BLOCK, "mmlt against pt");
    util::assert_same_image(&ok, pt, 16, "mmlt against pt, image means");
    for (what, faults, n) in [
        (
            "mmlt, every large step accepted (control)",
            Faults {
                accept_large: true,
                ..Faults::default()
            },
            10,
        ),
        (
            // Group 1: paths of two segments (direct light).
            "mmlt, b of one length doubled (control)",
            Faults {
                double_b: Some(1),
                ..Faults::default()
            },
            16,
        ),
        (
            "mmlt, splats one pixel off (control)",
            Faults {
                shift_splats: true,
                ..Faults::default()
            },
            6,
        ),
    ] {
        let wrong = renders(&scene, &|| mmlt(faults), 0, n);
        assert!(rejected(&wrong, pt, what), "{what}: passed");
    }
}

/// `util::assert_same_image` can see a 10 % change in any one tile: two sets of 40 pt renders
/// (512 spp, 16 x 16, 4 x 4 tiles; one of them [`pt_renders`]) pass it, and scaling any one
/// tile of one set by 1.1 fails it (measured: the weakest tile's p = 1.3e-11 against the bound
/// 2.1e-6). With 20 renders a side, tiles on the light's edge and one on the floor need 1.2;
/// the controls above fail by far more.
#[test]
fn the_tile_test_sees_a_ten_percent_change_in_any_tile() {
    let (a, b) = (pt_renders(), pt_set(4000, 40));
    util::assert_same_image(a, &b, BLOCK, "pt against pt");
    let (w, h) = (a[0].width, a[0].height);
    for ty in 0..h / BLOCK {
        for tx in 0..w / BLOCK {
            let scaled: Vec<Image> = a
                .iter()
                .map(|img| {
                    let mut img = img.clone();
                    for y in ty * BLOCK..(ty + 1) * BLOCK {
                        for x in tx * BLOCK..(tx + 1) * BLOCK {
                            img.pixels[(y * w + x) as usize] *= 1.1;
                        }
                    }
                    img
                })
                .collect();
            assert!(
                rejected(&scaled, &b, &format!("tile ({tx}, {ty}) x 1.1 (control)")),
                "a 10 % change in tile ({tx}, {ty}) passed"
            );
        }
    }
}
