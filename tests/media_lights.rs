//! Lights and cameras inside media: a point light, an area light and the camera inside a fog
//! box render the same image with pt, lt, bdpt and vcm (light subpaths start in the medium
//! that contains the light; the camera's medium is found where it stands, not assumed to be
//! the world's). Before the fix, light subpaths started in vacuum and lt, bdpt and vcm
//! rendered the fog-wrapped light too bright.
//!
//! Each comparison is tile by tile over independently seeded renders
//! (`util::assert_same_image`, family-wise false-failure rate 1e-4 per comparison), with
//! every render free of invalid samples.

use crate::util;

use lodestar::film::Image;
use lodestar::scene::Scene;
use util::{POINT_LIGHT, assert_same_image, render, scene};

const BOX: &str = r#"
[camera]
position = [0, 0, 3.9]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov = 39.3077
resolution = [24, 24]

[[material]]
name = "white"
type = "diffuse"
albedo = [0.73, 0.73, 0.73]

[[material]]
name = "red"
type = "diffuse"
albedo = [0.65, 0.05, 0.05]

[[material]]
name = "black"
type = "black"

[[shape]]
type = "quad"
origin = [-1, -1, -1]
edge_u = [0, 0, 2]
edge_v = [2, 0, 0]
material = "white"

[[shape]]
type = "quad"
origin = [-1, -1, -1]
edge_u = [2, 0, 0]
edge_v = [0, 2, 0]
material = "white"

[[shape]]
type = "quad"
origin = [-1, -1, -1]
edge_u = [0, 2, 0]
edge_v = [0, 0, 2]
material = "red"

[[medium]]
name = "fog"
sigma_a = [0.3, 0.5, 0.8]
sigma_s = [0.9, 0.7, 0.5]
g = 0.3
"#;

/// The fog box: a cube of half-size 0.6 around (0, 0.1, 0), or a larger one that also holds
/// the camera.
const FOG_AROUND_LIGHT: &str = r#"
[[shape]]
name = "fog box"
type = "cube"
interior = "fog"
transform = { scale = [0.6, 0.6, 0.6], translate = [0, 0.1, 0] }
"#;

const FOG_AROUND_CAMERA: &str = r#"
[[shape]]
name = "fog box"
type = "cube"
interior = "fog"
transform = { scale = [0.95, 0.95, 2.4], translate = [0, 0, 1.5] }
"#;

/// A 20 cm square facing down, at y = 0.3 (inside either fog box).
const AREA_LIGHT: &str = r#"
[[shape]]
name = "lamp"
type = "quad"
origin = [-0.1, 0.3, -0.1]
edge_u = [0.2, 0, 0]
edge_v = [0, 0, 0.2]
material = "black"
emission = [40, 40, 40]
"#;

const SEEDS: u64 = 5;

fn renders(scene: &Scene, name: &str, spp: u64) -> Vec<Image> {
    (0..SEEDS)
        .map(|seed| {
            let r = render(scene, name, 6, &[], spp, 1000 + seed, 2);
            let invalid = r
                .stats
                .iter()
                .find(|(k, _)| k == "invalid_samples")
                .map(|(_, v)| v.clone());
            assert_eq!(invalid.as_deref(), Some("0"), "{name}: invalid samples");
            r.image
        })
        .collect()
}

fn agree(toml: &str, label: &str) {
    let s = scene(toml);
    let reference = renders(&s, "pt", 256);
    for (name, spp) in [("lt", 64), ("bdpt", 64), ("vcm", 64)] {
        let other = renders(&s, name, spp);
        assert_same_image(&reference, &other, 6, &format!("{label}: pt vs {name}"));
    }
}

#[test]
fn point_light_inside_fog_agrees_across_integrators() {
    agree(
        &format!("{BOX}{FOG_AROUND_LIGHT}{POINT_LIGHT}"),
        "point light in fog",
    );
}

#[test]
fn area_light_inside_fog_agrees_across_integrators() {
    agree(
        &format!("{BOX}{FOG_AROUND_LIGHT}{AREA_LIGHT}"),
        "area light in fog",
    );
}

#[test]
fn camera_and_light_inside_fog_agree_across_integrators() {
    let text = format!("{BOX}{FOG_AROUND_CAMERA}{POINT_LIGHT}")
        .replace("position = [0, 0, 3.9]", "position = [0, 0, 2.5]");
    let s = scene(&text);
    assert_eq!(s.camera_medium, Some(0), "the camera stands in the fog");
    agree(&text, "camera and light in fog");
}

#[test]
fn media_are_located_at_the_lights_and_the_camera() {
    let s = scene(&format!("{BOX}{FOG_AROUND_LIGHT}{POINT_LIGHT}{AREA_LIGHT}"));
    assert_eq!(s.camera_medium, None, "camera outside the fog box");
    assert_eq!(s.light_media, vec![Some(0), Some(0)]);
    // A world medium fills whatever no boundary encloses.
    let world = format!("world_medium = \"fog\"\n{BOX}{POINT_LIGHT}");
    let s = scene(&world);
    assert_eq!(
        (s.camera_medium, s.light_media.clone()),
        (Some(0), vec![Some(0)])
    );
}

/// The control: the comparison must see a light just outside the fog (what lt saw before the
/// fix, when its light subpaths started in vacuum) against pt's render of the light inside.
#[test]
fn control_light_outside_the_fog_for_one_side_fails() {
    let inside = scene(&format!("{BOX}{FOG_AROUND_LIGHT}{POINT_LIGHT}"));
    let outside = scene(
        &format!("{BOX}{FOG_AROUND_LIGHT}{POINT_LIGHT}")
            .replace("translate = [0, 0.1, 0]", "translate = [0, -0.35, 0]"),
    );
    let a = renders(&inside, "pt", 256);
    let b = renders(&outside, "lt", 64);
    let failed = std::panic::catch_unwind(|| assert_same_image(&a, &b, 6, "control")).is_err();
    assert!(failed, "moving the light out of the fog must be detected");
}
