//! Batched pt (`pt -O batch=on`, `integrators/pt/batch.rs`) renders pt's image bit for bit:
//! the same sample streams drawn in the same order, the same radiance summed in the same
//! order, only the rays traced in batches. Any mix-up of samplers between paths, a next-event
//! value added without its shadow ray's answer, or a change in the order of the sums changes
//! bits of the image, so these comparisons are exact.

mod util;

use lodestar::integrators::pt::batch::BatchMode;
use lodestar::scene::Scene;
use util::render;

/// A shipped scene at 40 x 30 pixels.
fn shipped(name: &str) -> Scene {
    util::shipped_at(name, 40, 30)
}

#[test]
fn batched_pt_is_pt_bit_for_bit() {
    // Flat-tested primitives (the Cornell boxes), BVHs (ajar, dining), heightfield grids and
    // an environment (pool); a glossy box; max_depth 8 and 3 (paths cut at the limit).
    for name in ["cornell-box", "cornell-glossy", "ajar", "dining", "pool"] {
        let scene = shipped(name);
        assert!(BatchMode::On.applies(&scene), "{name}: batch=on applies");
        for max_depth in [8, 3] {
            let one = render(&scene, "pt", max_depth, &["batch=off"], 3, 7, 2);
            let batched = render(&scene, "pt", max_depth, &["batch=on"], 3, 7, 2);
            assert!(
                one.image.pixels.iter().any(|p| p.max_element() > 0.0),
                "{name}: a black image proves nothing"
            );
            assert!(
                one.image == batched.image,
                "{name}, max_depth {max_depth}: batched pt differs from pt"
            );
            let one_thread = render(&scene, "pt", max_depth, &["batch=on"], 3, 7, 1);
            assert!(
                one_thread.image == batched.image,
                "{name}: thread count matters"
            );
        }
    }
}

/// Media (shadow rays cross boundaries one segment at a time) keep pt's tracer under
/// `batch=on`; the shipped scenes with a BVH are small enough that `auto` never batches them
/// (their BVHs stay in the caches, where batches cost more than they save), and `auto`
/// batches the flat-tested Cornell box where the CPU has AVX (packets of rays).
#[test]
fn batching_applies_where_it_pays() {
    let fog = shipped("cornell-fog");
    assert!(!BatchMode::On.applies(&fog));
    let one = render(&fog, "pt", 8, &["batch=off"], 2, 3, 2);
    let on = render(&fog, "pt", 8, &["batch=on"], 2, 3, 2);
    assert!(one.image == on.image);
    for name in ["ajar", "dining", "pool", "fog-dragon"] {
        let scene = shipped(name);
        assert!(!BatchMode::Auto.applies(&scene), "{name}");
        assert!(!BatchMode::Off.applies(&scene), "{name}");
    }
    let cornell = shipped("cornell-box");
    #[cfg(target_arch = "x86_64")]
    let packets = std::arch::is_x86_feature_detected!("avx");
    #[cfg(not(target_arch = "x86_64"))]
    let packets = false;
    assert_eq!(BatchMode::Auto.applies(&cornell), packets);
    assert!(!BatchMode::Off.applies(&cornell));
}

#[test]
fn batch_option_errors_name_the_option() {
    use lodestar::integrators::{IntegratorParams, Options, build};
    let params = |items: &[&str]| IntegratorParams {
        max_depth: 8,
        options: Options::parse(&items.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap(),
    };
    let err = |name: &str, items: &[&str]| match build(name, &params(items)) {
        Ok(_) => panic!("{name} {items:?} should be rejected"),
        Err(e) => e.to_string(),
    };
    let e = err("pt", &["batch=sometimes"]);
    assert!(e.contains("'batch'") && e.contains("auto, on, off"), "{e}");
    let e = err("pt", &["batch=on", "guiding=sdtree"]);
    assert!(e.contains("'batch'") && e.contains("sdtree"), "{e}");
    assert!(build("pt", &params(&["batch=auto", "guiding=sdtree"])).is_ok());
    // pssmlt replays primary samples path by path: it has no batch option.
    let e = err("pssmlt", &["batch=on"]);
    assert!(e.contains("'batch'"), "{e}");
}
