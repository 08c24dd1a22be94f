//! The scenes shipped in `scenes/` load, with the features their descriptions promise, and
//! render (at a reduced resolution, a few samples, with pt and bdpt) to finite, non-negative,
//! non-black images. The white furnace renders to its analytic value.

use crate::util;

use lodestar::geometry::bvh::ShapeGeometry;
use lodestar::light::Light;
use lodestar::scene::Scene;
use lodestar::scene::loader::{load_file, load_str};
use std::path::{Path, PathBuf};

fn load(name: &str) -> lodestar::scene::Scene {
    load_file(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(name),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn scene_files() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

/// A scene file with its `resolution` line replaced by `[w, h]` and `text_edits` applied
/// (each `(from, to)` must occur in the file).
fn load_edited(path: &Path, w: u32, h: u32, text_edits: &[(&str, &str)]) -> Scene {
    let mut text = std::fs::read_to_string(path).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("resolution = "))
        .expect("a resolution line")
        .to_string();
    text = text.replacen(&line, &format!("resolution = [{w}, {h}]"), 1);
    for (from, to) in text_edits {
        assert!(text.contains(from), "{}: no {from:?}", path.display());
        text = text.replacen(from, to, 1);
    }
    load_str(&text, &path.display().to_string(), path.parent()).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_scene_loads() {
    let files = scene_files();
    for path in &files {
        load_file(path).unwrap_or_else(|e| panic!("{e}"));
    }
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    for expected in [
        "ajar",
        "cornell-box",
        "cornell-fog",
        "cornell-glossy",
        "dining",
        "fog-dragon",
        "furnace",
        "pool",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "scenes/{expected}.toml is missing"
        );
    }
}

/// Every scene at 1/4 of its resolution: pt with 2 samples per pixel and bdpt with 1 give
/// finite, non-negative images that are not black. (A broken light, camera or material that
/// blackens a scene fails here; the NaN check covers every estimator path the scenes reach.)
#[test]
fn every_scene_renders_without_nan() {
    for path in scene_files() {
        let full = load_file(&path).unwrap();
        let (w, h) = (full.camera.resolution.x / 4, full.camera.resolution.y / 4);
        let scene = load_edited(&path, w, h, &[]);
        let depth = scene.render.max_depth;
        for (integrator, spp) in [("pt", 2), ("bdpt", 1)] {
            let image = util::render(&scene, integrator, depth, &[], spp, 1, 2).image;
            let label = format!("{} with {integrator}", path.display());
            assert!(
                image
                    .pixels
                    .iter()
                    .all(|p| p.is_finite() && p.min_element() >= 0.0),
                "{label}: a pixel is NaN, infinite or negative"
            );
            let mean = image.mean();
            assert!(mean.max_element() > 1e-3, "{label}: black image ({mean})");
        }
    }
}

/// scenes/furnace.toml: lossless objects in a constant environment render to the environment's
/// radiance in every pixel (the value its header states). pt and bdpt are each z-tested per
/// channel on the image mean at |z| < 4.5 (false-failure rate below 1e-5 per channel, seeds
/// fixed); pt is nearly noiseless here (only its NEE/BSDF MIS split varies between samples).
#[test]
fn furnace_renders_to_its_analytic_value() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/furnace.toml");
    let scene = load_edited(&path, 64, 64, &[]);
    let environment = scene
        .lights
        .iter()
        .find_map(|l| match l {
            Light::Environment(e) => Some(e.radiance),
            _ => None,
        })
        .expect("an environment light");
    assert_eq!(
        environment.to_array(),
        [0.3, 0.5, 0.7],
        "the header's value"
    );
    let expected = environment.as_dvec3().to_array();
    let depth = scene.render.max_depth;
    let pt = util::render(&scene, "pt", depth, &[], 4, 3, 2).image;
    util::assert_constant_image(&pt, expected, "furnace, pt");
    let bdpt = util::render(&scene, "bdpt", depth, &[], 4, 3, 2).image;
    util::assert_constant_image(&bdpt, expected, "furnace, bdpt");
}

/// scenes/ajar.toml: with the door shut the near room is black (no light leaks through the
/// geometry), and ajar it is lit.
#[test]
fn ajar_is_lit_only_through_the_door() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ajar.toml");
    let open = "rotate = { axis = [0, 1, 0], degrees = -8 }, translate = [0.8574, 1.048, -2.2002]";
    let shut = "rotate = { axis = [0, 1, 0], degrees = 0 }, translate = [0.85, 1.048, -2.135]";
    for (door, lit) in [(open, true), (shut, false)] {
        let scene = load_edited(&path, 40, 30, &[(open, door)]);
        let image = util::render(&scene, "bdpt", scene.render.max_depth, &[], 4, 5, 2).image;
        let mean = image.mean();
        if lit {
            assert!(mean.x > 0.05, "ajar: too dark ({mean})");
        } else {
            assert_eq!(mean.max_element(), 0.0, "shut door: light leaks ({mean})");
        }
    }
}

/// scenes/pool.toml: the basin is tiled in two materials (half the cells each), the water is a
/// dielectric heightfield of ior 1.33, the sun has a finite disk, and the sky is on.
#[test]
fn pool_has_tiles_water_and_a_finite_sun() {
    let scene = load("pool.toml");
    let material = |name: &str| {
        scene
            .shape_info
            .iter()
            .find(|s| s.name == name)
            .map(|s| scene.materials[s.material as usize].name.as_str())
            .unwrap_or_else(|| panic!("no shape '{name}'"))
    };
    assert_eq!(material("pool floor"), "tile white");
    let floor = scene
        .shape_info
        .iter()
        .find(|s| s.name == "pool floor")
        .unwrap();
    let odd = floor.checker.expect("the floor is a checkerboard").odd;
    assert_eq!(scene.materials[odd as usize].name, "tile blue");
    assert_eq!(material("water surface"), "water");
    let water = &scene
        .materials
        .iter()
        .find(|m| m.name == "water")
        .unwrap()
        .bsdf;
    assert!(water.is_delta());
    assert!(
        scene
            .lights
            .iter()
            .any(|l| matches!(l, Light::Sun(_)) && !l.is_delta())
    );
    assert!(scene.features.environment && scene.features.specular_surfaces);
    assert!(
        !scene.features.delta_lights,
        "lights seen through water must be finite"
    );
}

/// scenes/fog-dragon.toml: fog fills a box around the glass bunny, whose inside is clear; the
/// only light is an area spot light (finite, seen through the glass) outside the fog, in vacuum
/// like the camera (light subpaths of lt and bdpt start in vacuum).
#[test]
fn fog_dragon_has_fog_outside_a_clear_glass_bunny() {
    let scene = load("fog-dragon.toml");
    assert!(scene.features.media);
    assert_eq!(scene.camera_medium, None);
    let bunny = scene.shape_info.iter().find(|s| s.name == "bunny").unwrap();
    let interface = bunny.interface.expect("media on both sides");
    let fog = interface.outside.expect("fog around the bunny") as usize;
    assert!(scene.media[fog].sigma_t.min_element() > 0.0);
    let inside = interface.inside.expect("a clear medium") as usize;
    assert_eq!(scene.media[inside].sigma_t.max_element(), 0.0);
    assert!(scene.materials[bunny.material as usize].bsdf.is_delta());
    assert_eq!(scene.lights.len(), 1);
    assert!(matches!(scene.lights[0], Light::Area(_)) && !scene.features.delta_lights);
    // The fog volume holds the bunny but neither the light nor the camera.
    let volume = scene
        .shape_info
        .iter()
        .position(|s| s.name == "fog volume")
        .unwrap();
    let ShapeGeometry::Mesh(m) = &scene.shapes[volume] else {
        panic!("the fog volume is a cube")
    };
    let top = m.positions.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    let front = m.positions.iter().map(|p| p.z).fold(f32::MIN, f32::max);
    let spot = scene
        .shape_info
        .iter()
        .position(|s| s.name == "spot")
        .unwrap();
    let ShapeGeometry::Mesh(light) = &scene.shapes[spot] else {
        panic!("the spot light is a quad")
    };
    assert!(light.positions.iter().all(|p| p.y > top));
    assert!(scene.camera.position.z > front);
}

#[test]
fn the_built_in_scene_is_the_cornell_box_file() {
    let file = load("cornell-box.toml");
    let built_in = lodestar::scene::Scene::cornell_box();
    assert_eq!(file.triangle_count(), built_in.triangle_count());
    assert_eq!(file.camera.resolution, built_in.camera.resolution);
}

/// The fog volume must reach below the floor: a boundary in the floor's plane makes medium
/// tracking ambiguous (a cross-check against Mitsuba found the floor under the fog 12 % too dark
/// when the two coincided).

#[test]
fn cornell_fog_volume_contains_the_floor() {
    let scene = load("cornell-fog.toml");
    assert!(scene.features.media && !scene.features.specular_surfaces);
    let fog = scene
        .shape_info
        .iter()
        .position(|s| s.null)
        .expect("an index-matched fog cube");
    let ShapeGeometry::Mesh(m) = &scene.shapes[fog] else {
        panic!("the fog volume is a cube mesh")
    };
    let bottom = m
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f32::INFINITY, f32::min);
    let top = m
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f32::NEG_INFINITY, f32::max);
    assert!(bottom < -1.0005 && bottom > -1.01, "bottom {bottom}");
    assert!((top - 0.2).abs() < 1e-4, "top {top}");
}

#[test]
fn cornell_glossy_has_rough_materials() {
    let scene = load("cornell-glossy.toml");
    let rough = scene
        .materials
        .iter()
        .filter(|m| m.bsdf.roughness() > 0.0 && m.bsdf.roughness() < 1.0)
        .count();
    assert_eq!(rough, 2);
    assert!(!scene.features.specular_surfaces);
}

/// The public scenes of `scenes/public/` load as published; Bitterli's Cornell box in its
/// Mitsuba 0.6 file is the same scene as in its Mitsuba 3 file (materials, shapes, lights and
/// the camera's rays), which checks the 0.x upgrade on a file written by someone else.
#[test]
fn public_scenes_load_as_published() {
    let v3 = load("public/bitterli-cornell-box/scene_v3.xml");
    let v06 = load("public/bitterli-cornell-box/scene_v0.6.xml");
    let bsdfs = |s: &Scene| {
        s.materials
            .iter()
            .map(|m| m.bsdf.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(bsdfs(&v3), bsdfs(&v06));
    assert_eq!(v3.shapes.len(), v06.shapes.len());
    assert_eq!(v3.lights.len(), v06.lights.len());
    assert_eq!(v3.camera.resolution, v06.camera.resolution);
    for r in [glam::Vec2::new(0.5, 0.5), glam::Vec2::new(700.2, 300.7)] {
        let (a, b) = (v3.camera.generate_ray(r), v06.camera.generate_ray(r));
        assert!((a.o - b.o).abs().max_element() < 1e-5, "{a:?} {b:?}");
        assert!((a.d - b.d).abs().max_element() < 1e-5, "{a:?} {b:?}");
    }
    let spheres = load("public/okapi-cornell-spheres/scene.xml");
    assert!(
        spheres.features.specular_surfaces,
        "the spheres are glass and a mirror"
    );
    assert_eq!(spheres.lights.len(), 1);
}

/// The scenes of Tzu-Mao Li's lajolla renderer (`scenes/public/lajolla/`, MIT) load as
/// published, with what their files say: Veach's multiple-importance test (four rough-plastic
/// plates lit by five spheres, direct lighting), the material-preview object in a
/// near-specular rough dielectric under an environment map, a Gaussian filter of σ 0.75.
#[test]
fn lajolla_scenes_load_as_published() {
    use lodestar::filter::FilterKind;
    let mi = load("public/lajolla/veach_mi/mi.xml");
    assert_eq!(mi.lights.len(), 5);
    assert_eq!(
        mi.materials
            .iter()
            .filter(|m| matches!(m.bsdf, lodestar::bsdf::Bsdf::RoughPlastic(_)))
            .count(),
        4
    );
    assert_eq!(mi.render.max_depth, 2, "the direct integrator: one bounce");
    let preview = load("public/lajolla/matpreview/matpreview.xml");
    assert!(preview.features.environment);
    assert!(
        preview
            .materials
            .iter()
            .any(|m| matches!(m.bsdf, lodestar::bsdf::Bsdf::RoughDielectric { .. }))
    );
    let filter = load("public/lajolla/pixel_filter_test/pixel_filter_test.xml");
    assert_eq!(
        filter.camera.filter.kind(),
        FilterKind::Gaussian { stddev: 0.75 }
    );
    assert_eq!(filter.camera.resolution, glam::UVec2::new(640, 480));
    for s in ["cbox/cbox.xml", "disney_bsdf_test/simple_sphere.xml"] {
        let scene = load(&format!("public/lajolla/{s}"));
        assert_eq!(scene.lights.len(), 1, "{s}");
    }
}
