//! Participating media against analytic answers, and the path tracer's strategies against
//! each other in media. Statistical checks are z-tests at |z| < 4.5 (false-failure rate below
//! 1e-5 each), with fixed seeds.

use crate::util;

use glam::{Vec2, Vec3};
use lodestar::scene::Endpoint;

/// A slab 0.5 thick (z in [-0.25, 0.25]) of a purely absorbing medium between the camera and
/// an emitter facing it.
fn slab_scene(sigma_a: [f32; 3]) -> String {
    format!(
        r#"
[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 20
resolution = [24, 24]
[[medium]]
name = "ink"
sigma_a = [{}, {}, {}]
sigma_s = [0, 0, 0]
[[shape]]
type = "cube"
interior = "ink"
transform = {{ scale = [3, 3, 0.25] }}
[[shape]]
type = "quad"
origin = [-5, -5, -2]
edge_u = [10, 0, 0]
edge_v = [0, 10, 0]
emission = [1, 2, 3]
"#,
        sigma_a[0], sigma_a[1], sigma_a[2]
    )
}

#[test]
fn transmittance_through_an_absorbing_slab_is_exp_of_minus_sigma_t_d() {
    let sigma = [0.5f32, 1.5, 3.0];
    let scene = util::scene(&slab_scene(sigma));
    // The query itself, from in front of the slab to the emitter.
    let a = Endpoint::point(Vec3::new(0.1, 0.2, 1.0));
    let b = Endpoint::point(Vec3::new(0.1, 0.2, -1.0));
    let t = scene
        .transmittance(&a, Some(&b), Vec3::NEG_Z, None)
        .expect("only index-matched boundaries in between");
    for (c, sigma_c) in sigma.iter().enumerate() {
        let expected = (-sigma_c * 0.5f32).exp();
        assert!(
            (t.tr[c] - expected).abs() < 1e-3 * expected,
            "channel {c}: {} vs {expected}",
            t.tr[c]
        );
    }
    // Rendered: every pixel sees the emitter through the slab (free-flight sampling picks a
    // channel and weights by the channel-averaged density, so each channel stays unbiased).
    let img = util::render(&scene, "pt", 4, &[], 64, 1, 2).image;
    let expected: [f64; 3] =
        std::array::from_fn(|c| (c as f64 + 1.0) * (-(sigma[c] as f64) * 0.5).exp());
    util::assert_constant_image(&img, expected, "absorbing slab");
}

/// A segment that leaves the slab just before its end (within the shadow epsilon of the
/// target, which occlusion does not test) still ends outside the medium: bdpt's vertices
/// rebuilt from a path (`from_path`) take their media from `end_medium`, and vcm's weights
/// disagreed with the densities from scratch on a floor vertex 2e-4 outside cornell-fog's
/// fog cube. Ending 1e-5 past the face of a segment 2 long: inside the 2e-4 epsilon.
#[test]
fn a_boundary_crossed_within_the_shadow_epsilon_decides_the_end_medium() {
    let scene = util::scene(&slab_scene([0.5, 0.5, 0.5]));
    let ink = Some(0);
    for (from, to, medium, end, inside) in [
        (0.0, -0.25 - 1e-5, ink, None, 0.25), // leaves the slab through its back face
        (2.25 - 1e-5, 0.25 - 1e-5, None, ink, 1e-5), // enters it just before the end
        (0.0, -0.2, ink, ink, 0.2),           // stays inside: no crossing
    ] {
        let (a, b) = (Vec3::new(0.1, 0.2, from), Vec3::new(0.1, 0.2, to));
        let t = scene
            .transmittance(
                &Endpoint::point(a),
                Some(&Endpoint::point(b)),
                Vec3::NEG_Z,
                medium,
            )
            .expect("only index-matched boundaries in between");
        assert_eq!(t.end_medium, end, "segment {from} -> {to}");
        let expected = (-0.5f32 * inside).exp();
        assert!(
            (t.tr.x - expected).abs() < 1e-4,
            "{from} -> {to}: tr {} vs {expected}",
            t.tr.x
        );
    }
}

/// A purely scattering sphere (index-matched) in a uniform environment conserves energy: the
/// image is the environment's radiance everywhere, with every strategy.
#[test]
fn scattering_medium_in_a_uniform_environment_renders_the_environment() {
    let toml = r#"
[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 35
resolution = [24, 24]
[[medium]]
name = "cloud"
sigma_a = [0, 0, 0]
sigma_s = [1.0, 2.0, 4.0]
g = 0.4
[[shape]]
type = "sphere"
radius = 1
interior = "cloud"
[[light]]
type = "environment"
radiance = [0.8, 0.6, 0.4]
"#;
    let scene = util::scene(toml);
    for (i, strategy) in ["mis", "nee", "bsdf"].iter().enumerate() {
        let img = util::render(
            &scene,
            "pt",
            63,
            &[&format!("strategy={strategy}")],
            64,
            10 + i as u64,
            2,
        )
        .image;
        util::assert_constant_image(&img, [0.8, 0.6, 0.4], strategy);
    }
}

/// In the fog Cornell box, and with the whole box filled with fog (camera inside the medium),
/// MIS, next-event estimation only and phase/BSDF sampling only agree.
#[test]
fn pt_in_media_agrees_with_and_without_nee() {
    let fog = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-fog.toml"
    ))
    .unwrap()
    .replace("resolution = [256, 256]", "resolution = [32, 32]");
    let world = fog.replacen("[camera]", "world_medium = \"haze\"\n\n[camera]", 1)
        + "\n[[medium]]\nname = \"haze\"\nsigma_a = [0.05, 0.1, 0.2]\nsigma_s = [0.3, 0.2, 0.1]\ng = -0.3\n";
    for (name, text) in [("cornell-fog", fog), ("world haze", world)] {
        let scene = util::scene(&text);
        assert!(scene.features.media);
        let mis = util::render(&scene, "pt", 6, &["strategy=mis"], 256, 1, 2).image;
        let nee = util::render(&scene, "pt", 6, &["strategy=nee"], 256, 2, 2).image;
        let bsdf = util::render(&scene, "pt", 6, &["strategy=bsdf"], 512, 3, 2).image;
        for (other_name, other) in [("nee", &nee), ("bsdf", &bsdf)] {
            util::assert_same_mean(&mis, other, &format!("{name}: mis vs {other_name}"));
        }
    }
}

/// Media are paid for only where they exist: the fog scene's features say so, the plain box's
/// do not, and the camera starts in the world medium.
#[test]
fn features_and_camera_medium() {
    assert!(!util::cornell(8).features.media);
    let scene = util::scene(&slab_scene([1.0, 1.0, 1.0]));
    assert!(scene.features.media);
    assert_eq!(scene.camera_medium, None);
    let ray = scene.camera.generate_ray(Vec2::new(12.0, 12.0));
    let sp = scene.intersect(&ray).unwrap();
    assert!(sp.is_null() && scene.medium_after(&sp, ray.d, None) == Some(0));
}

/// A dielectric boundary around a medium: a glass sphere (ior 1.5) filled with a purely
/// scattering medium, in a uniform environment, still renders the environment everywhere
/// (refraction and the medium switch at the boundary conserve energy).
#[test]
fn medium_inside_a_dielectric_boundary_conserves_energy() {
    let toml = r#"
[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 35
resolution = [24, 24]
[[material]]
name = "glass"
type = "dielectric"
ior = 1.5
[[medium]]
name = "milk"
sigma_a = [0, 0, 0]
sigma_s = [2.0, 1.0, 0.5]
g = 0.6
[[shape]]
type = "sphere"
radius = 1
material = "glass"
interior = "milk"
[[light]]
type = "environment"
radiance = [0.5, 0.7, 0.9]
"#;
    let scene = util::scene(toml);
    for (i, strategy) in ["mis", "nee"].iter().enumerate() {
        let img = util::render(
            &scene,
            "pt",
            63,
            &[&format!("strategy={strategy}")],
            64,
            20 + i as u64,
            2,
        )
        .image;
        util::assert_constant_image(&img, [0.5, 0.7, 0.9], strategy);
    }
}
