//! The path tracer's three ways of reaching emitters (MIS, BSDF sampling only, next-event
//! estimation only) estimate the same image. Checked on the Cornell box (glass sphere,
//! diffuse walls, area light) with independent seeds, per channel, by the z statistic of the
//! pixel differences (`util::z_same_mean`) at |z| < 4.5: false-failure rate below 1e-5 per
//! comparison, fixed seeds.

use crate::util;

#[test]
fn mis_bsdf_and_nee_agree_on_the_cornell_box() {
    let scene = util::cornell(48);
    for max_depth in [2, 8] {
        let mis = util::render(&scene, "pt", max_depth, &["strategy=mis"], 256, 1, 2).image;
        let bsdf = util::render(&scene, "pt", max_depth, &["strategy=bsdf"], 256, 2, 2).image;
        let nee = util::render(&scene, "pt", max_depth, &["strategy=nee"], 256, 3, 2).image;
        for (name, other) in [("bsdf", &bsdf), ("nee", &nee)] {
            util::assert_same_mean(
                &mis,
                other,
                &format!("max_depth {max_depth}: mis vs {name}"),
            );
        }
    }
}

/// The test above must be able to fail: a render with a different depth limit is a different
/// image, and the statistic sees it.
#[test]
fn the_agreement_statistic_detects_a_different_image() {
    let scene = util::cornell(48);
    let a = util::render(&scene, "pt", 3, &[], 256, 1, 2).image;
    let b = util::render(&scene, "pt", 4, &[], 256, 2, 2).image;
    assert!(util::z_same_mean(&a, &b).abs().max_element() > 10.0);
}

/// max_depth counts segments: with 1, only emitters seen directly (the light quad shows its
/// radiance exactly, everything else is black).
#[test]
fn max_depth_one_shows_only_directly_visible_emitters() {
    let scene = util::cornell(64);
    let img = util::render(&scene, "pt", 1, &[], 4, 1, 2).image;
    let le = glam::Vec3::new(17.0, 12.0, 4.0);
    let mut lit = 0;
    for p in &img.pixels {
        if *p != glam::Vec3::ZERO {
            lit += 1;
            // Pixels on the light's border are partly covered.
            assert!(p.cmple(le * 1.0001).all(), "{p}");
        }
    }
    assert!(lit > 0 && lit < img.pixels.len() / 20, "{lit} lit pixels");
    // Fully covered pixels show exactly Le.
    assert!(
        img.pixels
            .iter()
            .filter(|p| (**p - le).length() < 1e-4)
            .count()
            > 10
    );
}

/// The same agreement on the glossy Cornell box (GGX rough conductor and rough dielectric):
/// BSDF `eval`/`pdf` must match what `sample` does for MIS to be unbiased.
#[test]
fn mis_bsdf_and_nee_agree_on_the_glossy_cornell_box() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-glossy.toml"
    ))
    .unwrap()
    .replace("resolution = [256, 256]", "resolution = [48, 48]");
    let scene = util::scene(&text);
    let mis = util::render(&scene, "pt", 6, &["strategy=mis"], 256, 1, 2).image;
    let bsdf = util::render(&scene, "pt", 6, &["strategy=bsdf"], 256, 2, 2).image;
    let nee = util::render(&scene, "pt", 6, &["strategy=nee"], 256, 3, 2).image;
    for (name, other) in [("bsdf", &bsdf), ("nee", &nee)] {
        util::assert_same_mean(&mis, other, &format!("glossy: mis vs {name}"));
    }
}
