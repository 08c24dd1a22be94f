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
