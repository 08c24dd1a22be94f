//! Batched pt (`pt -O batch=on`, `integrators/pt/batch.rs`) renders pt's image bit for bit:
//! the same sample streams drawn in the same order, the same radiance summed in the same
//! order, only the rays traced in batches. Any mix-up of samplers between paths, a next-event
//! value added without its shadow ray's answer, or a change in the order of the sums changes
//! bits of the image, so these comparisons are exact.

use crate::util;

use lodestar::integrators::pt::batch::{BatchMode, Tracing};
use lodestar::integrators::pt::{PathTracer, PtSettings, wavefront};
use lodestar::scene::Scene;
use util::render;

/// A shipped scene at 40 x 30 pixels.
fn shipped(name: &str) -> Scene {
    util::shipped_at(name, 40, 30)
}

/// A Mitsuba XML file of the repository (`path` from its root) with `defines`, its film's
/// `width` and `height` changed from (w0, h0) to (w, h) when given.
fn mitsuba(path: &str, defines: &[(&str, &str)], film: Option<(u32, u32, u32, u32)>) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    let mut text = std::fs::read_to_string(&path).unwrap();
    if let Some((w0, h0, w, h)) = film {
        for (key, from, to) in [("width", w0, w), ("height", h0, h)] {
            let old = format!("name=\"{key}\" value=\"{from}\"");
            assert!(text.contains(&old), "{}: no {old}", path.display());
            text = text.replace(&old, &format!("name=\"{key}\" value=\"{to}\""));
        }
    }
    let defines: Vec<(String, String)> = defines
        .iter()
        .map(|&(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let name = path.display().to_string();
    lodestar::scene::loader::load_mitsuba_str(&text, &name, path.parent(), &defines)
        .unwrap_or_else(|e| panic!("{e}"))
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
    assert!(
        e.contains("'batch'") && e.contains("auto, wavefront, wavefront-avx2, on, off"),
        "{e}"
    );
    let e = err("pt", &["batch=on", "guiding=sdtree"]);
    assert!(e.contains("'batch'") && e.contains("sdtree"), "{e}");
    assert!(build("pt", &params(&["batch=auto", "guiding=sdtree"])).is_ok());
    // pssmlt replays primary samples path by path: it has no batch option.
    let e = err("pssmlt", &["batch=on"]);
    assert!(e.contains("'batch'"), "{e}");
}

/// The Cornell box with every vertex kind the wavefront shades (`integrators/pt/wavefront/`):
/// a checkerboard floor, a one-sided panel seen from the back, three lights of different power (the ceiling
/// quad, a disk of twelve triangles on the back wall and a point light, so the light choice
/// and the triangle choice on a light both vary, and one light is a delta light), a glass sphere (refraction, total internal
/// reflection) and a glass heightfield with smooth shading normals (a BVH instead of the flat
/// list, and `ns != ng`).
fn wavefront_box() -> Scene {
    let text = lodestar::scene::CORNELL_BOX_TOML
        .replace("resolution = [256, 256]", "resolution = [40, 30]")
        .replace(
            "name = \"floor\"\ntype = \"quad\"",
            "name = \"floor\"\ntype = \"quad\"\ntiles = [4, 4]\ntile_material = \"red\"",
        );
    let extra = r#"
[[material]]
name = "front only"
type = "diffuse"
albedo = [0.6, 0.7, 0.5]
one_sided = true

[[material]]
name = "textured"
type = "diffuse"
albedo_texture = { type = "checkerboard", color0 = [0.8, 0.4, 0.2], color1 = [0.1, 0.5, 0.7], scale = [5, 3] }

# A textured panel before the back wall.
[[shape]]
name = "textured panel"
type = "quad"
origin = [0.2, -1, -0.5]
edge_u = [0.6, 0, 0]
edge_v = [0, 0.8, 0]
material = "textured"

# A panel facing the back wall: the camera sees its black back.
[[shape]]
name = "panel"
type = "quad"
origin = [-0.7, -1, 0.3]
edge_u = [0, 0.9, 0]
edge_v = [0.5, 0, 0]
material = "front only"

[[shape]]
name = "back light"
type = "disk"
center = [0.5, 0.4, -0.99]
normal = [0, 0, 1]
radius = 0.15
segments = 12
material = "black"
emission = [3, 6, 9]

[[light]]
type = "point"
position = [-0.5, 0.6, 0.4]
intensity = [0.8, 0.6, 0.4]

[[shape]]
name = "glass waves"
type = "heightfield"
size = [0.8, 0.6]
grid = [12, 9]
material = "glass"
waves = [{ amplitude = 0.05, wavelength = 0.3, direction = [1, 0.4], phase = 0.5 }]
transform = { translate = [-0.3, 0.2, 0.2] }
"#;
    util::scene(&format!("{text}\n{extra}"))
}

/// The wavefront's lanes repeat pt's arithmetic and each path draws from its own sampler in
/// pt's order, so its image is pt's bit for bit: on the Cornell box (flat-tested primitives),
/// on `wavefront_box` (a BVH, two mesh lights, one-sided, checkerboard and textured materials,
/// shading normals), on pool (a sun and a sky: lights at infinity, sampled by `Light::sample_li` and
/// found by escaping rays; a heightfield grid) and on dining (mirrors, a spot area light),
/// with independent and Sobol samples, full and cut paths, one and two threads. A lane that mixes up two paths, a select that takes the wrong branch on one lane,
/// or an operation done in another order changes bits of these images. Vertices the lanes do
/// not shade are advanced by pt's own code inside the rounds: the glossy box and ajar (rough
/// BSDFs), Mitsuba's shading scene (a bump map, a textured roughness, an opacity mask, a
/// textured area light) and Veach's MIS scene (rough plastic, spherical lights).
#[test]
fn wavefront_pt_is_pt_bit_for_bit() {
    let pt = PathTracer {
        settings: PtSettings::default(),
    };
    let Some(widest) = wavefront::Isa::detect() else {
        eprintln!(
            "wavefront_pt_is_pt_bit_for_bit: skipped: this CPU has neither AVX-512 nor AVX2, so \
             the wavefront cannot run"
        );
        return;
    };
    // Each kernel the CPU can run: the widest through `batch=wavefront`, and the AVX2 one
    // through `batch=wavefront-avx2` where that is not the same.
    let mut kernels = vec![("batch=wavefront", widest)];
    if widest != wavefront::Isa::Avx2 && wavefront::Isa::Avx2.on_this_cpu() {
        kernels.push(("batch=wavefront-avx2", wavefront::Isa::Avx2));
    }
    for (name, scene) in [
        ("cornell-box", shipped("cornell-box")),
        ("wavefront box", wavefront_box()),
        ("pool", shipped("pool")),
        ("dining", shipped("dining")),
        ("cornell-glossy", shipped("cornell-glossy")),
        ("ajar", shipped("ajar")),
        (
            "shading.xml",
            mitsuba("scenes/mitsuba/shading.xml", &[("res", "48")], None),
        ),
        // Next-event samples on a textured mesh light carry the texture (`Light::sample_li`,
        // not the lanes' constant-radiance mesh sampling).
        (
            "textured light",
            util::cornell_light_with(40, 30, util::CHECKER_EMISSION),
        ),
        (
            "veach_mi",
            mitsuba(
                "scenes/public/lajolla/veach_mi/mi.xml",
                &[],
                Some((768, 512, 48, 32)),
            ),
        ),
    ] {
        assert!(wavefront::supports(&pt, &scene), "{name}");
        assert_eq!(
            BatchMode::Auto.tracing(&pt, &scene),
            Tracing::Wavefront(widest),
            "{name}: auto takes the widest wavefront"
        );
        for (max_depth, sampler) in [(8, "independent"), (3, "independent"), (8, "sobol")] {
            let sampler = format!("sampler={sampler}");
            let one = render(&scene, "pt", max_depth, &["batch=off", &sampler], 4, 9, 2);
            assert!(
                one.image.pixels.iter().any(|p| p.max_element() > 0.0),
                "{name}: a black image proves nothing"
            );
            for &(option, isa) in &kernels {
                let wave = render(&scene, "pt", max_depth, &[option, &sampler], 4, 9, 2);
                let differ = one
                    .image
                    .pixels
                    .iter()
                    .zip(&wave.image.pixels)
                    .filter(|(a, b)| {
                        a.to_array().map(f32::to_bits) != b.to_array().map(f32::to_bits)
                    })
                    .count();
                assert_eq!(
                    differ, 0,
                    "{name}, {isa:?}, max_depth {max_depth}, {sampler}: {differ} pixels differ \
                     from pt's"
                );
                let one_thread = render(&scene, "pt", max_depth, &[option, &sampler], 4, 9, 1);
                assert!(
                    one_thread.image == wave.image,
                    "{name}, {isa:?}: thread count matters"
                );
            }
        }
    }
}

/// Scenes with media, and pt's strategies other than `mis`, keep the batched or one-path
/// tracer; rough BSDFs do not (their vertices are advanced by pt's own code in the rounds).
#[test]
fn the_wavefront_applies_where_its_lanes_shade() {
    let pt = PathTracer {
        settings: PtSettings::default(),
    };
    for name in ["cornell-glossy", "ajar"] {
        assert!(wavefront::supports(&pt, &shipped(name)), "{name}");
    }
    for name in ["cornell-fog", "fog-dragon"] {
        let scene = shipped(name);
        assert!(!wavefront::supports(&pt, &scene), "{name}");
        assert!(!matches!(
            BatchMode::Wavefront(None).tracing(&pt, &scene),
            Tracing::Wavefront(_)
        ));
    }
    let cornell = shipped("cornell-box");
    let nee_only = PathTracer {
        settings: PtSettings {
            strategy: lodestar::integrators::pt::Strategy::Nee,
            ..PtSettings::default()
        },
    };
    assert!(!wavefront::supports(&nee_only, &cornell));
    assert!(wavefront::supports(&pt, &cornell));
    assert_eq!(BatchMode::Off.tracing(&pt, &cornell), Tracing::Single);
    assert_eq!(BatchMode::On.tracing(&pt, &cornell), Tracing::Batched);
}

/// The guider's render passes with guiding off trace pt's rows as pt does
/// (`Unguided::estimate_row`: as a wavefront on the Cornell box and the glossy box, whose
/// rough vertices pt's own code advances in the rounds, one path after the other in fog, or
/// batched where the CPU has neither AVX-512 nor AVX2); each value must be the pixel's own
/// `Unguided::estimate` bit for bit, for both samplers, or guided-pt's image would depend on
/// which tracer ran.
#[test]
fn pt_rows_for_the_guider_are_its_estimates_bit_for_bit() {
    use lodestar::camera::Camera;
    use lodestar::integrators::unguided::Unguided;
    use lodestar::math::sobol::SobolSampler;
    use lodestar::math::{IndependentSampler, Sampler};

    fn rows<S: Sampler>(pt: &PathTracer, scene: &Scene, new: impl Fn(u64) -> S) -> usize {
        let (w, h) = (scene.camera.resolution.x, scene.camera.resolution.y);
        let mut lit = 0;
        for y in 0..h {
            let index = |x: u32| y as u64 * w as u64 + x as u64;
            let mut samplers: Vec<S> = (0..w).map(|x| new(index(x))).collect();
            let rasters: Vec<glam::Vec2> = (samplers.iter_mut().enumerate())
                .map(|(x, s)| Camera::jittered(x as u32, y, s.next_2d()))
                .collect();
            let mut row = vec![glam::DVec3::ZERO; w as usize];
            pt.estimate_row(
                &mut (),
                scene,
                &rasters,
                &mut samplers,
                &mut vec![],
                &mut row,
            );
            for (x, v) in row.iter().enumerate() {
                let mut s = new(index(x as u32));
                let r = Camera::jittered(x as u32, y, s.next_2d());
                let one = pt.estimate(&mut (), scene, r, &mut s, &mut vec![]);
                assert_eq!(
                    v.to_array().map(f64::to_bits),
                    one.to_array().map(f64::to_bits)
                );
                lit += (one.max_element() > 0.0) as usize;
            }
        }
        lit
    }
    let pt = PathTracer {
        settings: PtSettings::default(),
    };
    for name in ["cornell-box", "cornell-glossy", "cornell-fog"] {
        let scene = shipped(name);
        for pass in [0, 5] {
            let lit = rows(&pt, &scene, |i| IndependentSampler::new(7, pass, i));
            assert!(lit > 600, "{name}: {lit} pixels lit of 1200");
            rows(&pt, &scene, |i| SobolSampler::new(7, pass, i));
        }
    }
}
