//! The stress suite: scenes built to break renderers, rendered by every integrator.
//!
//! Every case must load, render without a panic, and give an image with no NaN, infinite or
//! negative pixel and no invalid sample; where the answer is known (scaled scenes, scaled
//! lights, a vanishing medium) the image must also agree with it. The images are small and
//! the sample counts low: these are tests of robustness, with agreement checked where the
//! noise allows (z tests with the false-failure rates stated at each).

use crate::util;
use util::stat;

use lodestar::film::Image;
use lodestar::scene::{Scene, loader};
use std::path::{Path, PathBuf};

/// Every integrator, with options that keep the Markov-chain bootstraps small.
const INTEGRATORS: [(&str, &[&str]); 9] = [
    ("pt", &[]),
    ("lt", &[]),
    ("bdpt", &[]),
    ("vcm", &[]),
    ("bpm", &[]),
    ("guided-pt", &["learn_fraction=0.5"]),
    ("guided-bdpt", &["learn_fraction=0.5"]),
    ("pssmlt", &["bootstrap=2000", "chains=16"]),
    ("mmlt", &["bootstrap=2000", "chains=16"]),
];

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lodestar-stress-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn load(text: &str, dir: Option<&Path>) -> Scene {
    loader::load_str(text, "stress.toml", dir).unwrap_or_else(|e| panic!("stress scene: {e}"))
}

/// Render `scene` with every integrator; each image must be finite and non-negative with no
/// invalid sample. Returns the images by integrator.
fn robust(scene: &Scene, label: &str, spp: u64, max_depth: u32) -> Vec<(&'static str, Image)> {
    INTEGRATORS
        .iter()
        .map(|&(name, options)| {
            let r = util::render(scene, name, max_depth, options, spp, 7, 2);
            let bad = r
                .image
                .pixels
                .iter()
                .position(|p| !(p.is_finite() && p.min_element() >= 0.0));
            assert!(
                bad.is_none(),
                "{label}: {name}: pixel {bad:?} = {:?}",
                bad.map(|i| r.image.pixels[i])
            );
            for key in ["invalid_samples", "invalid_unguided_paths"] {
                if let Some(v) = stat(&r, key) {
                    assert_eq!(v, "0", "{label}: {name}: {key}");
                }
            }
            (name, r.image)
        })
        .collect()
}

/// The Cornell box at `resolution` with every length multiplied by `s`.
fn scaled_cornell(s: f64, resolution: u32) -> String {
    util::transformed_cornell(s, 0.0, resolution)
}

/// The Cornell box scaled by 1e-4 and by 1e4 renders the same image (radiance does not
/// depend on the unit of length): pt and bdpt tile by tile over seeds against the unscaled
/// box (family-wise false-failure rate 1e-4 per comparison), every integrator robust.
#[test]
fn cornell_box_scaled_by_1e_minus_4_and_1e4() {
    let base = load(&scaled_cornell(1.0, 16), None);
    for s in [1e-4, 1e4] {
        let scene = load(&scaled_cornell(s, 16), None);
        robust(&scene, &format!("cornell x {s}"), 4, 8);
        for name in ["pt", "bdpt"] {
            let renders = |sc: &Scene| -> Vec<Image> {
                (0..5)
                    .map(|seed| util::render(sc, name, 8, &[], 64, 100 + seed, 2).image)
                    .collect()
            };
            util::assert_same_image(
                &renders(&base),
                &renders(&scene),
                4,
                &format!("{name}: cornell x {s}"),
            );
        }
    }
}

/// Guided sampling is unit-free: guided-pt with a fixed share on the Cornell box scaled by 1e-6
/// and 1e-3 traces the same paths as on the unscaled box (same seed), so its image agrees to
/// 1e-4 (f32 rounding), with guide paths installed and candidates found for p_g. Before the
/// guide cache's BVH was scaled, obvhs skipped every kernel box within 1e-4 of the camera at
/// 1e-6: p_g was 0 for every path, guided samples were over-weighted and the image 78 % too
/// bright.
#[test]
fn guided_sampling_in_a_box_a_micrometre_across() {
    let render = |s: f64| {
        let scene = load(&scaled_cornell(s, 24), None);
        util::render(&scene, "guided-pt", 6, &["share=fixed"], 32, 1, 2)
    };
    let base = render(1.0);
    for s in [1e-3, 1e-6] {
        let r = render(s);
        let (a, b) = (r.image.mean(), base.image.mean());
        assert!(
            ((a - b).abs() / b).max_element() < 1e-4,
            "scale {s}: mean {a:?} vs unscaled {b:?}"
        );
        for key in ["guide_paths", "mean_pg_candidates"] {
            let v: f64 = stat(&r, key).unwrap().parse().unwrap();
            assert!(v > 1.0, "scale {s}: {key} = {v}");
        }
    }
}

/// Lights of radiance 1e-6 and 1e8: with the same seed, pt, lt, bdpt, vcm and bpm trace the
/// same paths, so the image scales exactly with the light (to 1e-4 of f32 rounding).
#[test]
fn lights_of_radiance_1e_minus_6_and_1e8() {
    let base_text = scaled_cornell(1.0, 16);
    let base = load(&base_text, None);
    for k in [1e-6f64, 1e8] {
        let text = base_text.replace(
            "emission = [17, 12, 4]",
            &format!("emission = [{:e}, {:e}, {:e}]", 17.0 * k, 12.0 * k, 4.0 * k),
        );
        let scene = load(&text, None);
        let images = robust(&scene, &format!("light x {k}"), 4, 8);
        for (name, img) in images {
            if !["pt", "lt", "bdpt", "vcm", "bpm"].contains(&name) {
                continue;
            }
            let options = INTEGRATORS.iter().find(|e| e.0 == name).unwrap().1;
            let reference = util::render(&base, name, 8, options, 4, 7, 2).image;
            let (a, b) = (img.mean() / k, reference.mean());
            let rel = ((a - b) / b).abs().max_element();
            assert!(rel < 1e-4, "{name}: light x {k}: mean/k {a} vs {b}");
        }
    }
}

/// A medium of sigma_t 1e-6 is as good as none (pt's mean within 4.5 sigma of the fogless
/// box's, false-failure rate 1e-5); one of sigma_t 1e4 (a fog cube that is nearly a solid)
/// renders robustly.
#[test]
fn media_of_sigma_t_1e_minus_6_and_1e4() {
    let fog = |sigma: f64| {
        format!(
            "{}\n[[medium]]\nname = \"fog\"\nsigma_a = [{a:e}, {a:e}, {a:e}]\nsigma_s = [{s:e}, {s:e}, {s:e}]\ng = 0.5\n\n[[shape]]\ntype = \"cube\"\ninterior = \"fog\"\ntransform = {{ scale = [0.4, 0.4, 0.4], translate = [0.3, -0.3, 0.3] }}\n",
            scaled_cornell(1.0, 16),
            a = 0.3 * sigma,
            s = 0.7 * sigma
        )
    };
    let thin = load(&fog(1e-6), None);
    let clear = load(&scaled_cornell(1.0, 16), None);
    robust(&thin, "sigma_t 1e-6", 4, 8);
    util::assert_same_mean(
        &util::render(&thin, "pt", 8, &[], 256, 1, 2).image,
        &util::render(&clear, "pt", 8, &[], 256, 2, 2).image,
        "sigma_t 1e-6 vs no medium",
    );
    robust(&load(&fog(1e4), None), "sigma_t 1e4", 2, 8);
}

/// Glass of ior 1.0001 and 4, rough surfaces of alpha 1e-4 and 1.
#[test]
fn extreme_ior_and_roughness() {
    let base = scaled_cornell(1.0, 16);
    for ior in ["1.0001", "4"] {
        let text = base.replace("ior = 1.5", &format!("ior = {ior}"));
        assert_ne!(text, base);
        robust(&load(&text, None), &format!("ior {ior}"), 4, 8);
    }
    for alpha in ["1e-4", "1"] {
        let text = base.replace(
            "[[material]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.5",
            &format!("[[material]]\nname = \"glass\"\ntype = \"roughdielectric\"\nior = 1.5\nalpha = {alpha}\n\n[[material]]\nname = \"metal\"\ntype = \"roughconductor\"\nalpha = {alpha}\nreflectance = [0.9, 0.9, 0.9]"),
        ).replacen("material = \"white\"\ntransform", "material = \"metal\"\ntransform", 1);
        assert!(text.contains("roughdielectric") && text.contains("\"metal\"\ntransform"));
        robust(&load(&text, None), &format!("alpha {alpha}"), 4, 8);
    }
}

/// A camera inside the glass sphere, and a camera grazing the floor.
#[test]
fn camera_inside_glass_and_grazing() {
    let base = scaled_cornell(1.0, 16);
    let inside = base.replace(
        "position = [0e0, 0e0, 3.9e0]",
        "position = [0.45, -0.6, 0.35]",
    );
    assert_ne!(inside, base);
    robust(&load(&inside, None), "camera in glass", 4, 8);
    let grazing = base
        .replace(
            "position = [0e0, 0e0, 3.9e0]",
            "position = [0, -0.99999, 3.9]",
        )
        .replace("look_at = [0e0, 0e0, 0e0]", "look_at = [0, -0.99999, 0]");
    assert_ne!(grazing, base);
    robust(&load(&grazing, None), "grazing camera", 4, 8);
}

/// 16384 x 1 and 1 x 1 images.
#[test]
fn extreme_image_shapes() {
    let base = scaled_cornell(1.0, 16);
    for (w, h) in [(16384, 1), (1, 1)] {
        let text = base.replace("resolution = [16, 16]", &format!("resolution = [{w}, {h}]"));
        let spp = if w == 1 { 64 } else { 1 };
        robust(&load(&text, None), &format!("{w} x {h}"), spp, 8);
    }
}

/// Zero-area and degenerate triangles (collinear, repeated vertices, one emitting),
/// coincident surfaces with different materials.
#[test]
fn degenerate_and_coincident_geometry() {
    let dir = temp_dir("degenerate");
    std::fs::write(
        dir.join("bad.obj"),
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 0 0 0\nv 1e-30 0 0\nv 0 1e-30 0\n\
         f 1 2 3\nf 1 1 4\nf 1 5 4\nf 1 6 7\nf 1 2 4\n",
    )
    .unwrap();
    let base = scaled_cornell(1.0, 16);
    let text = format!(
        "{base}\n[[shape]]\ntype = \"obj\"\nfile = \"bad.obj\"\nmaterial = \"white\"\n\
         transform = {{ scale = 0.3, translate = [0, 0, 0.5] }}\n\n\
         [[shape]]\nname = \"degenerate lamp\"\ntype = \"obj\"\nfile = \"bad.obj\"\nmaterial = \"white\"\n\
         emission = [5, 5, 5]\ntransform = {{ scale = 0.2, translate = [-0.5, 0.5, 0] }}\n\n\
         [[shape]]\ntype = \"quad\"\norigin = [-1, -1, -1]\nedge_u = [2, 0, 0]\nedge_v = [0, 2, 0]\nmaterial = \"red\"\n"
    );
    let scene = load(&text, Some(&dir));
    robust(&scene, "degenerate and coincident", 4, 8);
    std::fs::remove_dir_all(&dir).unwrap();
}
