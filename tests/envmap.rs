//! The environment map (`light/envmap.rs`): its radiance against Mitsuba 3's `envmap` at fixed
//! directions, chi-square tests of `sample_li` and `sample_le` against their densities, a
//! constant map against the constant environment, and every integrator family rendering a
//! scene lit by a map, tile by tile. Statistical tests use the chi-square harness
//! (`common/chi2.rs`: its suite-wide false-failure rate) or `util::assert_same_image`
//! (family-wise 1e-4), with fixed seeds.

use crate::common;
use crate::util;

use common::chi2::{self, SphereDomain};
use common::{Failures, close};
use glam::{Mat3, Vec3};
use lodestar::film::Image;
use lodestar::light::{EnvMapLight, Light};
use lodestar::math::Sampler;

const W: usize = 8;
const H: usize = 5;

/// The test map: pixel (x, y) = (1 + x, 1 + 2 y, 0.5 + (x y mod 3)), y = 0 the top row.
fn test_pixels() -> Vec<Vec3> {
    (0..H)
        .flat_map(|y| {
            (0..W).map(move |x| {
                Vec3::new(
                    1.0 + x as f32,
                    1.0 + 2.0 * y as f32,
                    0.5 + ((x * y) % 3) as f32,
                )
            })
        })
        .collect()
}

fn rotation() -> Mat3 {
    Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 30f32.to_radians())
}

/// Mitsuba's conventions (latitude-longitude mapping, pixel centres, the top row on the
/// zenith, bilinear interpolation, `to_world`): lodestar's radiance equals Mitsuba 3's
/// (version 3.9.1) at 12 directions, with and without a rotation, to 1e-5 relative (f32
/// rounding of the coordinates), from `python3 benches/reference/mitsuba_envmap.py`. A map
/// read with the rows' centres (instead of their corners) on the poles, or `u` from
/// `atan2(v.x, v.z)`, differs by 10 % or more at most of them.
#[test]
// The reference values as the script prints them.
#[allow(clippy::excessive_precision)]
fn envmap_radiance_matches_mitsuba() {
    #[rustfmt::skip]
    let reference: &[(&str, [f32; 3], [f32; 3])] = &[
        ("identity", [0.0000000, 1.0000000, 0.0000000], [4.500000e+00, 1.000000e+00, 5.000000e-01]),
        ("identity", [0.0000000, -1.0000000, 0.0000000], [4.500000e+00, 9.000000e+00, 1.000000e+00]),
        ("identity", [0.0000000, 0.0000000, 1.0000000], [4.500000e+00, 5.000000e+00, 1.500000e+00]),
        ("identity", [0.0000000, 0.0000000, -1.0000000], [4.500000e+00, 5.000000e+00, 1.500000e+00]),
        ("identity", [1.0000000, 0.0000000, 0.0000000], [2.500000e+00, 5.000000e+00, 2.000000e+00]),
        ("identity", [-1.0000000, 0.0000000, 0.0000000], [6.500000e+00, 5.000000e+00, 1.000000e+00]),
        ("identity", [0.3030458, 0.5050763, -0.8081220], [1.302395e+00, 3.651715e+00, 5.572761e-01]),
        ("identity", [-0.8017837, -0.2672612, 0.5345225], [5.751331e+00, 5.688949e+00, 1.318534e+00]),
        ("identity", [0.0504305, 0.9985238, 0.0201722], [2.984475e+00, 1.138381e+00, 6.373068e-01]),
        ("identity", [0.7035265, -0.7035265, -0.1005038], [2.319331e+00, 6.987139e+00, 5.108078e-01]),
        ("identity", [-0.2009163, 0.1004581, -0.9744439], [6.312271e+00, 4.743753e+00, 1.920560e+00]),
        ("identity", [0.5773503, 0.5773503, 0.5773503], [3.499999e+00, 3.432694e+00, 1.391828e+00]),
        ("rotated", [0.0000000, 1.0000000, 0.0000000], [2.271462e+00, 2.123125e+00, 1.214006e+00]),
        ("rotated", [0.0000000, -1.0000000, 0.0000000], [6.271462e+00, 7.876874e+00, 1.138836e+00]),
        ("rotated", [0.0000000, 0.0000000, 1.0000000], [4.812564e+00, 4.510490e+00, 1.926249e+00]),
        ("rotated", [0.0000000, 0.0000000, -1.0000000], [2.312052e+00, 5.489509e+00, 7.831203e-01]),
        ("rotated", [1.0000000, 0.0000000, 0.0000000], [2.915030e+00, 5.997435e+00, 1.043877e+00]),
        ("rotated", [-1.0000000, 0.0000000, 0.0000000], [6.915030e+00, 4.002565e+00, 6.273453e-01]),
        ("rotated", [0.3030458, 0.5050763, -0.8081220], [1.456018e+00, 4.521861e+00, 1.303016e+00]),
        ("rotated", [-0.8017837, -0.2672612, 0.5345225], [6.117194e+00, 4.573982e+00, 1.570851e+00]),
        ("rotated", [0.0504305, 0.9985238, 0.0201722], [2.383846e+00, 2.219131e+00, 1.343544e+00]),
        ("rotated", [0.7035265, -0.7035265, -0.1005038], [3.072192e+00, 8.000642e+00, 1.428404e+00]),
        ("rotated", [-0.2009163, 0.1004581, -0.9744439], [3.618460e+00, 5.047421e+00, 1.230393e+00]),
        ("rotated", [0.5773503, 0.5773503, 0.5773503], [3.565538e+00, 3.918652e+00, 1.169364e+00]),
    ];
    let pixels = test_pixels();
    for &(frame, w, expected) in reference {
        let to_world = if frame == "identity" {
            Mat3::IDENTITY
        } else {
            rotation()
        };
        let light = EnvMapLight::new(&pixels, W, H, 1.0, to_world).unwrap();
        let got = light.le(Vec3::from(w));
        let expected = Vec3::from(expected);
        let rel = ((got - expected).abs() / expected).max_element();
        assert!(
            rel < 1e-5,
            "{frame} {w:?}: {got} against Mitsuba's {expected}"
        );
    }
}

/// A map with a bright spot, black cells and a rotation: `sample_li`'s directions follow
/// `pdf_li` (chi-square over the sphere), each sample's density and radiance are `pdf_li`'s and
/// `le`'s at its direction, and emitted rays' directions follow `pdf_le`.
#[test]
fn envmap_sampling_matches_its_densities() {
    let mut pixels = test_pixels();
    for p in pixels.iter_mut().skip(2 * W).take(W / 2) {
        *p = Vec3::ZERO;
    }
    pixels[3 * W + 5] = Vec3::splat(400.0);
    let mut light = EnvMapLight::new(&pixels, W, H, 2.0, rotation()).unwrap();
    light.center = Vec3::new(1.0, -2.0, 0.5);
    light.radius = 3.0;
    let light = Light::EnvMap(light);
    let p = Vec3::new(0.3, 0.2, -0.1);
    let mut fails = Failures::new();
    chi2::spherical(
        "envmap sample_li",
        1_000_000,
        &SphereDomain::full(),
        |s: &mut dyn Sampler| {
            let ls = light.sample_li(p, s.next_2d())?;
            let pdf = light.pdf_li(p, ls.p, ls.n, ls.wi);
            fails.check(close(ls.pdf as f64, pdf as f64, 1e-3, 0.0), || {
                format!("pdf {} != pdf_li {pdf} at {}", ls.pdf, ls.wi)
            });
            fails.check(
                ls.li == light.le(Vec3::ZERO, Vec3::ZERO, ls.wi) && !ls.delta,
                || format!("{ls:?}"),
            );
            Some(ls.wi)
        },
        |w| light.pdf_li(p, Vec3::ZERO, Vec3::ZERO, w) as f64,
    )
    .assert_ok();
    fails.assert_none("envmap sample_li");
    let mut fails = Failures::new();
    chi2::spherical(
        "envmap sample_le directions",
        1_000_000,
        &SphereDomain::full(),
        |s: &mut dyn Sampler| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            let (pp, pd) = light.pdf_le(e.n, e.dir);
            fails.check(
                close(pp as f64, e.pdf_pos as f64, 1e-6, 0.0)
                    && close(pd as f64, e.pdf_dir as f64, 1e-3, 0.0),
                || format!("{e:?} against ({pp}, {pd})"),
            );
            Some(e.dir)
        },
        |w| light.pdf_le(Vec3::ZERO, w).1 as f64,
    )
    .assert_ok();
    fails.assert_none("envmap sample_le");
}

/// A scene of a diffuse sphere on a diffuse floor under the sky, `SKY` replaced by the light.
const SCENE: &str = r#"
[camera]
position = [0, 1.2, 4]
look_at = [0, 0.3, 0]
up = [0, 1, 0]
fov = 45
resolution = [16, 16]

[render]
max_depth = 4

[[material]]
name = "grey"
type = "diffuse"
albedo = [0.6, 0.6, 0.6]

[[material]]
name = "orange"
type = "roughplastic"
albedo = [0.8, 0.4, 0.1]
ior = 1.5
alpha = 0.2

[[shape]]
type = "quad"
origin = [-3, 0, 3]
edge_u = [6, 0, 0]
edge_v = [0, 0, -6]
material = "grey"

[[shape]]
type = "sphere"
center = [0, 0.6, 0]
radius = 0.6
material = "orange"

SKY
"#;

/// Writes the test map to a temporary directory and returns the scene lit by it.
fn envmap_scene(tag: &str, pixels: &[Vec3], extra: &str) -> lodestar::scene::Scene {
    envmap_load(tag, pixels, extra).unwrap_or_else(|e| panic!("{e}"))
}

/// [`envmap_scene`], or the loader's error.
fn envmap_load(tag: &str, pixels: &[Vec3], extra: &str) -> Result<lodestar::scene::Scene, String> {
    let dir = std::env::temp_dir().join(format!("lodestar-envmap-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let img = Image {
        width: W as u32,
        height: H as u32,
        pixels: pixels.to_vec(),
    };
    img.write_exr(&dir.join("sky.exr"), &[]).unwrap();
    let text = SCENE.replace(
        "SKY",
        &format!("[[light]]\ntype = \"envmap\"\nfilename = \"sky.exr\"\n{extra}"),
    );
    let scene = lodestar::scene::loader::load_str(&text, "envmap.toml", Some(&dir));
    std::fs::remove_dir_all(&dir).ok();
    scene.map_err(|e| e.to_string())
}

/// A constant map renders the constant environment's image (pt, tile by tile: the map's
/// importance sampling against uniform sampling); a map twice as bright must fail.
#[test]
fn a_constant_envmap_is_the_constant_environment() {
    let c = Vec3::new(0.8, 0.9, 1.0);
    let map = envmap_scene("constant", &vec![c; W * H], "");
    let env = util::scene(&SCENE.replace(
        "SKY",
        "[[light]]\ntype = \"environment\"\nradiance = [0.8, 0.9, 1.0]",
    ));
    let a = util::seeded_renders(&env, "pt", 4, &[], 64, 5, 1);
    let b = util::seeded_renders(&map, "pt", 4, &[], 64, 5, 11);
    util::assert_same_image(&a, &b, 4, "constant envmap vs environment");
    let brighter = envmap_scene("constant2", &vec![c; W * H], "scale = 2");
    let b2 = util::seeded_renders(&brighter, "pt", 4, &[], 64, 5, 21);
    assert!(util::differs(&a, &b2, 4), "a map twice as bright passes");
}

/// Every integrator family under the (rotated, uneven) test map: bdpt, vcm, guided-bdpt and
/// mmlt render pt's image tile by tile (5 renders a side); pt's images mirrored must fail.
#[test]
fn every_integrator_renders_an_envmap_alike() {
    let scene = envmap_scene(
        "all",
        &test_pixels(),
        "scale = 0.1\ntransform = { rotate = { axis = [1, 2, 3], degrees = 30 } }",
    );
    let pt = util::seeded_renders(&scene, "pt", 4, &[], 256, 5, 1);
    for (name, options, spp) in [
        ("bdpt", &[][..], 64),
        ("vcm", &[][..], 64),
        ("guided-bdpt", &["learn_fraction=0.25"][..], 64),
        // Its default bootstrap (100 000 paths) would be most of its time on so few pixels.
        ("mmlt", &["bootstrap=10000"][..], 256),
    ] {
        let other = util::seeded_renders(&scene, name, 4, options, spp, 5, 31);
        util::assert_same_image(&pt, &other, 4, &format!("{name} vs pt under an envmap"));
    }
    let mirrored: Vec<_> = pt.iter().map(util::mirrored).collect();
    assert!(util::differs(&pt, &mirrored, 4), "mirrored pt passes");
}

/// Bad input: a missing file, a format other than OpenEXR, no file, a scaling transform, a
/// second environment: each an error naming the line (or the file).
#[test]
fn envmap_errors_name_the_problem() {
    let load = |sky: &str| {
        lodestar::scene::loader::load_str(
            &SCENE.replace("SKY", sky),
            "envmap.toml",
            Some(&std::env::temp_dir()),
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
    };
    let e = load("[[light]]\ntype = \"envmap\"\nfilename = \"no-such-lodestar-map.exr\"");
    assert!(
        e.contains("envmap.toml:") && e.contains("no-such-lodestar-map.exr"),
        "{e}"
    );
    let e = load("[[light]]\ntype = \"envmap\"\nfilename = \"sky.hdr\"");
    assert!(e.contains("only OpenEXR"), "{e}");
    let e = load("[[light]]\ntype = \"envmap\"");
    assert!(e.contains("filename"), "{e}");
    let e = envmap_load("err", &test_pixels(), "transform = { scale = 2 }")
        .err()
        .unwrap_or_default();
    assert!(
        e.contains("envmap.toml:") && e.contains("must be a rotation"),
        "{e}"
    );
    let e = envmap_load(
        "two",
        &test_pixels(),
        "\n[[light]]\ntype = \"environment\"\nradiance = [1, 1, 1]",
    )
    .err()
    .unwrap_or_default();
    assert!(e.contains("only one environment light"), "{e}");
}
