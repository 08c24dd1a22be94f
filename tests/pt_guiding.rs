//! pt with a learned directional distribution (`-O guiding=sdtree`, `integrators/pt/guiding.rs`):
//! the quadtree's sampling against its density (chi-square, the shared harness: Šidák-corrected
//! α, about 1 % false-failure rate for the whole suite, fixed seeds), the guided renders
//! against pt's (tile-wise Welch tests at a family-wise false-failure rate of 1e-4, fixed
//! seeds), bit-identical images for 1 and 2 threads, and the options' errors.

use crate::common;
use crate::util;

use common::chi2::{self, SphereDomain};
use glam::Vec3;
use lodestar::integrators::pt::sdtree::{DTree, INV_FOUR_PI, SdTree, from_square, to_square};
use lodestar::math::{IndependentSampler, Sampler};

const N: usize = 1_000_000;

/// A tree learned at the origin from directions around `axis` (a sharp lobe, its mirror image
/// at a tenth of the weight, and a uniform floor): three iterations, so the layout is refined.
fn learned_tree(axis: Vec3, seed: u64) -> SdTree {
    let mut tree = SdTree::new(Vec3::ZERO, 1.0);
    let mut s = IndependentSampler::new(seed, 0, 0);
    for _ in 0..3 {
        for _ in 0..200_000 {
            let u = s.next_2d();
            let w = from_square(u);
            let c = w.dot(axis);
            let value = (20.0 * (c - 1.0)).exp() + 0.1 * (20.0 * (-c - 1.0)).exp() + 0.01;
            tree.record(Vec3::ZERO, w, value as f64);
        }
        tree.refine(1);
    }
    tree
}

fn directions(tree: &SdTree) -> &DTree {
    tree.directions_at(Vec3::ZERO).expect("the tree learned")
}

#[test]
fn quadtree_sampling_matches_its_density() {
    for (k, axis) in [Vec3::Z, Vec3::new(0.6, -0.3, -0.74).normalize()]
        .into_iter()
        .enumerate()
    {
        let tree = learned_tree(axis, 3 + k as u64);
        let d = directions(&tree);
        assert!(
            d.nodes() > 20,
            "the layout was refined: {} nodes",
            d.nodes()
        );
        let name = format!("sdtree quadtree #{k}");
        let report = chi2::spherical(
            &name,
            N,
            &SphereDomain::full_around(axis),
            |s: &mut dyn Sampler| {
                let (p, pdf) = d.sample(|| s.next_1d());
                // The density a sample reports is the density evaluated at its point.
                let eval = d.pdf(p);
                assert!((pdf - eval).abs() <= 1e-9 * eval, "{name}: {pdf} != {eval}");
                Some(from_square(p))
            },
            |w| d.pdf(to_square(w)) * INV_FOUR_PI,
        );
        report.assert_ok();
    }
}

/// The harness has power here: the density of a tree learned around another axis is rejected.
#[test]
fn another_trees_density_is_rejected() {
    let (a, b) = (
        learned_tree(Vec3::Z, 3),
        learned_tree(Vec3::new(0.2, 0.0, 1.0).normalize(), 3),
    );
    let (sampled, claimed) = (directions(&a), directions(&b));
    let report = chi2::spherical(
        "sdtree other tree",
        N,
        &SphereDomain::full_around(Vec3::Z),
        |s: &mut dyn Sampler| Some(from_square(sampled.sample(|| s.next_1d()).0)),
        |w| claimed.pdf(to_square(w)) * INV_FOUR_PI,
    );
    assert!(report.rejected());
}

/// pt's continuation where it is guided: BSDF sampling mixed with the tree's directions, at
/// the surface of cornell-glossy that a ray from the eye towards `target` hits (roughness at
/// most `rough`), against the mixture's density (zero where the BSDF is zero: such
/// directions end the path). One test per surface, so that they run in parallel.
fn guided_continuation_matches_the_mixture_density(what: &str, target: Vec3, rough: f32) {
    use lodestar::bsdf::TransportMode;
    use lodestar::geometry::Ray;
    use lodestar::integrators::pt::guiding::Mixture;
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-glossy.toml"
    ))
    .unwrap();
    let scene = util::scene(&text);
    let eye = scene.camera.position;
    let tree = learned_tree(Vec3::new(-0.3, 0.5, 0.8).normalize(), 11);
    let mix = Mixture {
        directions: directions(&tree),
        a: 0.7,
    };
    let sp = scene
        .intersect(&Ray::new(eye, (target - eye).normalize()))
        .unwrap_or_else(|| panic!("{what}: missed"));
    assert!(
        !sp.bsdf.is_delta() && sp.bsdf.roughness() <= rough,
        "{what}: hit the wrong surface"
    );
    let wo = (eye - sp.hit.p).normalize();
    let mode = TransportMode::Radiance;
    let name = format!("sdtree mixture at the {what}");
    let report = chi2::spherical(
        &name,
        N,
        &SphereDomain::full_around(sp.hit.ns),
        |s: &mut dyn Sampler| {
            let bs = mix.sample(&sp, wo, s)?;
            let pdf = mix.pdf(sp.bsdf.pdf(&sp.frame, wo, bs.wi, mode), bs.wi);
            assert!(
                (bs.pdf - pdf).abs() <= 1e-4 * pdf,
                "{name}: {} != {pdf}",
                bs.pdf
            );
            Some(bs.wi)
        },
        |wi| {
            // The BSDF's value and density in one call (bit-identical to `eval` and `pdf`):
            // the integration over the sphere evaluates this density millions of times.
            let (f, pdf_bsdf) = sp.bsdf.eval_pdf(&sp.frame, wo, wi, mode);
            if f == Vec3::ZERO {
                0.0
            } else {
                mix.pdf(pdf_bsdf, wi) as f64
            }
        },
    );
    report.assert_ok();
}

#[test]
fn the_guided_continuation_matches_the_mixture_density_at_a_diffuse_wall() {
    guided_continuation_matches_the_mixture_density("back wall", Vec3::new(0.1, 0.3, -1.0), 1.0);
}

#[test]
fn the_guided_continuation_matches_the_mixture_density_at_rough_metal() {
    guided_continuation_matches_the_mixture_density(
        "rough metal box",
        Vec3::new(-0.35, -0.4, -0.15),
        0.4,
    );
}

#[test]
fn the_guided_continuation_matches_the_mixture_density_at_rough_glass() {
    guided_continuation_matches_the_mixture_density(
        "rough glass sphere",
        Vec3::new(0.4, -0.65, 0.3),
        0.3,
    );
}

/// Guided pt converges to pt's image, tile by tile, in the Cornell box (diffuse walls, a
/// rough and a glass sphere) and in the glossy one.
#[test]
fn guided_pt_converges_to_the_pt_image() {
    for (what, text) in [
        ("cornell-box", lodestar::scene::CORNELL_BOX_TOML.to_string()),
        (
            "cornell-glossy",
            std::fs::read_to_string(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/scenes/cornell-glossy.toml"
            ))
            .unwrap(),
        ),
    ] {
        let scene = util::scene(&text.replace("resolution = [256, 256]", "resolution = [24, 24]"));
        assert_eq!(
            scene.camera.resolution.x, 24,
            "{what}: resolution not replaced"
        );
        let pt = util::seeded_renders(&scene, "pt", 8, &[], 256, 6, 100);
        let guided = util::seeded_renders(&scene, "pt", 8, &["guiding=sdtree"], 256, 6, 200);
        util::assert_same_image(&pt, &guided, 4, what);
    }
}

#[test]
fn guided_pt_is_bit_identical_across_thread_counts() {
    let scene = util::cornell(24);
    let opts = ["guiding=sdtree", "learn_fraction=0.5"];
    let one = util::render(&scene, "pt", 8, &opts, 16, 5, 1);
    let two = util::render(&scene, "pt", 8, &opts, 16, 5, 2);
    assert_eq!(one.image, two.image);
    assert_eq!(util::stat(&one, "learning_passes"), Some("7"));
    assert_eq!(one.spp, 9, "passes after learning");
}

#[test]
fn guiding_options_are_checked() {
    use lodestar::integrators::{IntegratorParams, Options};
    let scene = util::cornell(8);
    for (opts, expect) in [
        (
            vec!["guide_fraction=0.3"],
            "only a setting of pt with guiding=sdtree",
        ),
        (
            vec!["guiding=sdtree", "guide_fraction=1"],
            "expected a number in (0, 1)",
        ),
        (
            vec!["guiding=sdtree", "learn_fraction=nan"],
            "expected a number in (0, 1)",
        ),
        (vec!["guiding=trees"], "expected one of none, sdtree"),
    ] {
        let options =
            Options::parse(&opts.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap();
        let params = IntegratorParams {
            max_depth: 8,
            options,
        };
        let err = lodestar::integrators::render_named(
            &scene,
            "pt",
            &params,
            lodestar::render::Budget::Spp(1),
            0,
            1,
            false,
        )
        .err()
        .unwrap_or_else(|| panic!("{opts:?} was accepted"))
        .to_string();
        assert!(err.contains(expect), "{opts:?}: {err}");
    }
}
