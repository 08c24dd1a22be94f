//! pssmlt and mmlt render pt's image tile by tile, and three deliberate errors of the chains
//! (`mcmc::faults::Faults`) fail the same test:
//! - every large step accepted (a wrong acceptance),
//! - mmlt's normalisation b of one path length doubled,
//! - every splat landing one pixel further along its row.
//!
//! Unlike a test of the image mean (which a chain meets by construction: each mutation splats
//! b's worth of luminance wherever it lands), the per-tile test sees where the chains put
//! their splats. Each side is `SEEDS` independently seeded renders of a 16 x 16 Cornell box;
//! `util::assert_same_image` compares every 4 x 4 tile and channel by Welch's t with a
//! Bonferroni bound, family-wise false-failure rate 1e-4 per comparison (fixed seeds), and
//! then the whole image as one tile (the renders' means, each with its own estimate of b).

use crate::util;

use lodestar::film::Image;
use lodestar::integrators::mcmc::faults::Faults;
use lodestar::integrators::mcmc::mmlt::mmlt_bdpt_settings;
use lodestar::integrators::mcmc::{McmcSettings, Mmlt, Pssmlt, Split};
use lodestar::integrators::paths::Heuristic;
use lodestar::integrators::pt::{PathTracer, PtSettings};
use lodestar::render::{Budget, Integrator, RenderContext};
use lodestar::scene::Scene;

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

fn renders(scene: &Scene, make: &dyn Fn() -> Box<dyn Integrator>, first_seed: u64) -> Vec<Image> {
    (0..SEEDS)
        .map(|s| render_with(scene, make, first_seed + s))
        .collect()
}

fn pt_renders(scene: &Scene) -> Vec<Image> {
    (0..SEEDS)
        .map(|s| util::render(scene, "pt", MAX_DEPTH, &[], PT_SPP, 1000 + s, 2).image)
        .collect()
}

/// Whether `util::assert_same_image` rejects `a` against `b`.
fn rejected(a: &[Image], b: &[Image], what: &str) -> bool {
    std::panic::catch_unwind(|| util::assert_same_image(a, b, BLOCK, what)).is_err()
}

#[test]
fn pssmlt_renders_pt_image_and_its_faults_do_not() {
    let scene = scene();
    let pt = pt_renders(&scene);
    let ok = renders(&scene, &|| pssmlt(Faults::default()), 0);
    util::assert_same_image(&ok, &pt, BLOCK, "pssmlt against pt");
    // The whole image as one tile: the renders' means (b's estimate included) agree.
    util::assert_same_image(&ok, &pt, 16, "pssmlt against pt, image means");
    // With the paths only a continued walk finds (through the glass sphere, the light seen
    // directly) split off to the per-pixel estimate, and kept in the chains.
    for split in [Split::Always, Split::Never] {
        let other = renders(&scene, &|| pssmlt_split(Faults::default(), split), 100);
        util::assert_same_image(
            &other,
            &pt,
            BLOCK,
            &format!("pssmlt ({split:?}) against pt"),
        );
    }
    for (what, faults) in [
        (
            "pssmlt, every large step accepted (control)",
            Faults {
                accept_large: true,
                ..Faults::default()
            },
        ),
        (
            "pssmlt, splats one pixel off (control)",
            Faults {
                shift_splats: true,
                ..Faults::default()
            },
        ),
    ] {
        let wrong = renders(&scene, &|| pssmlt(faults), 0);
        assert!(rejected(&wrong, &pt, what), "{what}: passed");
    }
}

#[test]
fn mmlt_renders_pt_image_and_its_faults_do_not() {
    let scene = scene();
    let pt = pt_renders(&scene);
    let ok = renders(&scene, &|| mmlt(Faults::default()), 0);
    util::assert_same_image(&ok, &pt, BLOCK, "mmlt against pt");
    util::assert_same_image(&ok, &pt, 16, "mmlt against pt, image means");
    for (what, faults) in [
        (
            "mmlt, every large step accepted (control)",
            Faults {
                accept_large: true,
                ..Faults::default()
            },
        ),
        (
            // Group 1: paths of two segments (direct light).
            "mmlt, b of one length doubled (control)",
            Faults {
                double_b: Some(1),
                ..Faults::default()
            },
        ),
        (
            "mmlt, splats one pixel off (control)",
            Faults {
                shift_splats: true,
                ..Faults::default()
            },
        ),
    ] {
        let wrong = renders(&scene, &|| mmlt(faults), 0);
        assert!(rejected(&wrong, &pt, what), "{what}: passed");
    }
}

/// `util::assert_same_image` can see a 10 % change in any one tile: two sets of 40 pt renders
/// (512 spp, 16 x 16, 4 x 4 tiles) pass it, and scaling any one tile of one set by 1.1 fails
/// it (measured: the weakest tile's p = 1.3e-11 against the bound 2.1e-6). With the 20
/// renders a side of the tests above, tiles on the light's edge and one on the floor need
/// 1.2; their controls fail by far more.
#[test]
fn the_tile_test_sees_a_ten_percent_change_in_any_tile() {
    let scene = scene();
    let set = |first: u64| -> Vec<Image> {
        (0..40)
            .map(|s| util::render(&scene, "pt", MAX_DEPTH, &[], PT_SPP, first + s, 2).image)
            .collect()
    };
    let (a, b) = (set(3000), set(4000));
    util::assert_same_image(&a, &b, BLOCK, "pt against pt");
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
