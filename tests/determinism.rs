//! An image depends on the seed only: bit-identical for 1 and 2 threads, and for repeated
//! runs; different for another seed.

mod util;

#[test]
fn bit_identical_across_thread_counts() {
    let scene = util::cornell(40);
    let one = util::render(&scene, "pt", 8, &[], 8, 42, 1).image;
    let two = util::render(&scene, "pt", 8, &[], 8, 42, 2).image;
    let three = util::render(&scene, "pt", 8, &[], 8, 42, 3).image;
    assert!(
        one.pixels
            .iter()
            .zip(&two.pixels)
            .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
    );
    assert_eq!(one, three);
    let other_seed = util::render(&scene, "pt", 8, &[], 8, 43, 2).image;
    assert_ne!(one, other_seed);
}

/// Integrators that splat (bdpt's t = 1, lt) merge splats in row order: still bit-identical.
#[test]
fn splatting_integrators_are_bit_identical_across_thread_counts() {
    let scene = util::cornell(24);
    for name in ["bdpt", "lt"] {
        let one = util::render(&scene, name, 6, &[], 4, 9, 1).image;
        let two = util::render(&scene, name, 6, &[], 4, 9, 2).image;
        assert_eq!(one, two, "{name}");
        assert!(one.mean().x > 0.0);
    }
}
