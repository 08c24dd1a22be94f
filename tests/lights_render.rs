//! Lights through the whole renderer, against analytic answers: a diffuse floor of albedo rho
//! under a light that gives it irradiance E shows radiance rho E / pi (direct lighting only,
//! max_depth 2). z-tests at |z| < 4.5 per channel (false-failure rate below 1e-5 each), with
//! fixed seeds; noiseless cases are compared to the f32 resolution of the image.

use crate::util;

fn floor_scene(light: &str, fov: f32) -> String {
    format!(
        r#"
[camera]
position = [0, 3, 0.001]
look_at = [0, 0, 0]
up = [0, 0, -1]
fov = {fov}
resolution = [16, 16]
[[material]]
name = "floor"
type = "diffuse"
albedo = [0.5, 0.5, 0.5]
[[shape]]
type = "quad"
origin = [-50, 0, -50]
edge_u = [0, 0, 100]
edge_v = [100, 0, 0]
material = "floor"
{light}
"#
    )
}

fn assert_uniform_radiance(toml: &str, strategies: &[&str], expected: [f64; 3]) {
    let scene = util::scene(toml);
    for (k, strategy) in strategies.iter().enumerate() {
        let img = util::render(
            &scene,
            "pt",
            2,
            &[&format!("strategy={strategy}")],
            64,
            7 + k as u64,
            2,
        )
        .image;
        util::assert_constant_image(&img, expected, strategy);
    }
}

#[test]
fn sun_disk_lights_a_floor() {
    // Sun overhead with irradiance E: the floor shows rho E / pi. The sun is hit-able, so BSDF
    // sampling alone converges too.
    let light =
        "[[light]]\ntype = \"sun\"\ndirection = [0, 1, 0]\nangle = 2.0\nirradiance = [3, 2, 1]";
    let e = [3.0, 2.0, 1.0];
    let expected = e.map(|x| 0.5 * x / std::f64::consts::PI);
    assert_uniform_radiance(&floor_scene(light, 20.0), &["mis", "nee", "bsdf"], expected);
}

#[test]
fn directional_light_lights_a_tilted_floor() {
    // Light travelling at 60 degrees from the normal: E cos(60) on the floor.
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0.8660254, -0.5, 0]\nirradiance = [2, 2, 2]";
    let expected = [0.5 * 2.0 * 0.5 / std::f64::consts::PI; 3];
    assert_uniform_radiance(&floor_scene(light, 20.0), &["mis", "nee"], expected);
}

#[test]
fn spot_light_center_and_outside_of_its_cone() {
    // A spot 2 above the floor pointing down with a 10-degree cone: in the centre the floor
    // gets I / h^2 (inside the full-intensity cone for a narrow field of view); a spot pointing
    // away lights nothing.
    let light = "[[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\ndirection = [0, -1, 0]\nintensity = [4, 4, 4]\ncone_angle = 40\ncone_delta = 5";
    // Field of view 2 degrees at height 3: the floor patch seen is within 0.05 of the centre,
    // where cos^3 of the angle from the spot differs from 1 by < 1e-3 (bounded below).
    let scene = util::scene(&floor_scene(light, 2.0));
    let img = util::render(&scene, "pt", 2, &[], 4, 1, 2).image;
    let center = 0.5 * 4.0 / (4.0 * std::f64::consts::PI);
    for p in &img.pixels {
        let v = p.x as f64;
        assert!(
            v <= center * 1.0001 && v >= center * 0.998,
            "{v} vs {center}"
        );
    }
    let away = floor_scene(
        &light.replace("direction = [0, -1, 0]", "direction = [0, 1, 0]"),
        2.0,
    );
    let img = util::render(&util::scene(&away), "pt", 2, &[], 4, 1, 2).image;
    assert!(img.pixels.iter().all(|p| *p == glam::Vec3::ZERO));
}

#[test]
fn area_spot_light_falls_off_with_the_angle() {
    // A small emissive disk 2 above the floor, facing down, with a 20-degree cone. The camera
    // looks at the floor obliquely (a Lambertian floor looks the same from anywhere), so the
    // disk does not block its view: straight below the disk the floor is lit, 2 to the side
    // (45 degrees off the axis) it is dark.
    let scene_at = |x: f32| {
        let light = "[[shape]]\ntype = \"disk\"\ncenter = [0, 2, 0]\nnormal = [0, -1, 0]\nradius = 0.05\nemission = [100, 100, 100]\ncone_angle = 20\ncone_delta = 5";
        let camera = format!("position = [{}, 3, 0.001]\nlook_at = [{x}, 0, 0]", x + 1.5);
        util::scene(
            &floor_scene(light, 2.0)
                .replace("position = [0, 3, 0.001]\nlook_at = [0, 0, 0]", &camera),
        )
    };
    let img = util::render(&scene_at(0.0), "pt", 2, &[], 64, 3, 2).image;
    // Small-source limit: E = L A / h^2 for the 64-gon's area (r/h = 0.025 makes the exact
    // integral differ by about 1e-3, allowed below), inside the full-intensity cone.
    let area = 32.0 * (2.0 * std::f64::consts::PI / 64.0).sin() * 0.05f64 * 0.05;
    let expected = 0.5 / std::f64::consts::PI * 100.0 * area / 4.0;
    let (mean, se) = util::mean_and_stderr(&img);
    let ok = (mean.x - expected).abs() < 4.5 * se.x + 2e-3 * expected;
    assert!(ok, "{} vs {expected} (se {})", mean.x, se.x);
    let img = util::render(&scene_at(2.0), "pt", 2, &[], 64, 3, 2).image;
    assert_eq!(img.mean().x, 0.0);
}

/// A spot light projecting a texture (Mitsuba's spot `texture`; TOML's `texture` with `up`)
/// onto the floor: pt, lt, bdpt and vcm render the same pattern tile by tile (pt reaches the
/// light by `sample_li`, lt and the light subpaths leave it by `sample_le`, both through
/// `intensity_towards`). Controls: without the texture, and with `up` turned a quarter (the
/// pattern rotated), pt's image changes. Errors name the file, line and what was expected.
#[test]
fn a_projected_spot_texture_renders_alike_in_every_integrator() {
    let light = |extra: &str| {
        format!(
            "[[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\ndirection = [0, -1, 0]\n\
             intensity = [4, 4, 4]\ncone_angle = 40\ncone_delta = 5\n{extra}"
        )
    };
    let texture = "texture = { type = \"checkerboard\", color0 = [1, 0.8, 0.6], color1 = [0.1, \
                   0.2, 0.3], scale = [3, 2] }";
    let scene_with = |extra: &str| {
        util::scene(
            &floor_scene(&light(extra), 50.0)
                .replace("resolution = [16, 16]", "resolution = [24, 24]"),
        )
    };
    let scene = scene_with(&format!("{texture}\nup = [1, 0, 0]"));
    let pt = util::seeded_renders(&scene, "pt", 2, &[], 16, 5, 100);
    for name in ["lt", "bdpt", "vcm"] {
        let other = util::seeded_renders(&scene, name, 2, &[], 16, 5, 200);
        util::assert_same_image(&pt, &other, 4, &format!("{name} vs pt, projected spot"));
    }
    let plain = util::seeded_renders(&scene_with(""), "pt", 2, &[], 16, 5, 300);
    assert!(util::differs(&pt, &plain, 2), "the texture changes nothing");
    let turned = scene_with(&format!("{texture}\nup = [0, 0, 1]"));
    let turned = util::seeded_renders(&turned, "pt", 2, &[], 16, 5, 400);
    assert!(util::differs(&pt, &turned, 2), "'up' changes nothing");
    // Errors.
    let err = |extra: &str| {
        lodestar::scene::loader::load_str(&floor_scene(&light(extra), 50.0), "t.toml", None)
            .err()
            .unwrap()
            .to_string()
    };
    let e = err("up = [1, 0, 0]");
    assert!(
        e.contains("t.toml:") && e.contains("'up' orients a 'texture'"),
        "{e}"
    );
    let e = err(&format!("{texture}\nup = [0, 3, 0]"));
    assert!(
        e.contains("t.toml:") && e.contains("must not be parallel"),
        "{e}"
    );
}

/// An area light whose radiance is a texture over its surface (Mitsuba's area `radiance`
/// texture; TOML's `emission_texture`): the Cornell box's ceiling light a checkerboard of
/// 2 x 2 squares (the quad's texture coordinates from `origin` along `edge_u` and `edge_v`).
/// Next-event estimation (`sample_li`), light subpaths (`sample_le`) and emitters hit by
/// chance (`le`) all see the texture: bdpt, vcm and mmlt render pt's image tile by tile, the
/// light's own pixels included. Control: the untextured light changes pt's image. The
/// light's samples carry the texture at their points (checked against the squares' layout),
/// and its power is scaled by the texture's mean.
#[test]
fn a_textured_area_light_renders_alike_in_every_integrator() {
    use lodestar::light::Light;
    let light = |texture: &str| util::cornell_light_with(24, 24, texture);
    let scene = light(util::CHECKER_EMISSION);
    // The samples, and the power.
    let l = scene
        .lights
        .iter()
        .find_map(|l| match l {
            Light::Area(a) if a.texture.is_some() => Some(a),
            _ => None,
        })
        .expect("the textured light");
    let expected = |p: glam::Vec3| {
        // u along edge_u (x from -0.25), v along edge_v (z from -0.2); 2 x 2 squares.
        let (u, v) = ((p.x + 0.25) / 0.5 * 2.0, (p.z + 0.2) / 0.4 * 2.0);
        let same = (u.fract() > 0.5) == (v.fract() > 0.5);
        let t = if same {
            glam::Vec3::ONE
        } else {
            glam::Vec3::new(0.2, 0.5, 0.1)
        };
        glam::Vec3::new(17.0, 12.0, 4.0) * t
    };
    for k in 0..64 {
        let u = glam::Vec2::new((k % 8) as f32 / 8.0 + 0.06, (k / 8) as f32 / 8.0 + 0.03);
        let ls = l.sample_li(glam::Vec3::new(0.1, 0.0, 0.05), u).unwrap();
        assert!(
            (ls.li - expected(ls.p)).abs().max_element() < 1e-4,
            "{} at {}",
            ls.li,
            ls.p
        );
        let e = l.sample_le(u, glam::Vec2::new(0.3, 0.6)).unwrap();
        assert!(
            (e.le - expected(e.p)).abs().max_element() < 1e-4,
            "{} at {}",
            e.le,
            e.p
        );
    }
    let plain = light("");
    let power = |s: &lodestar::scene::Scene| s.lights.iter().map(|l| l.power()).sum::<f32>();
    let mean = lodestar::math::luminance(glam::Vec3::new(0.6, 0.75, 0.55));
    assert!((power(&scene) / power(&plain) - mean).abs() < 1e-4);
    // Every integrator.
    let pt = util::seeded_renders(&scene, "pt", 6, &[], 64, 5, 10);
    // mmlt's default bootstrap (100 000 paths) would be most of its time on 24 x 24 pixels.
    let mmlt = &["bootstrap=10000"][..];
    for (name, options, spp) in [("bdpt", &[][..], 32), ("vcm", &[], 32), ("mmlt", mmlt, 128)] {
        let other = util::seeded_renders(&scene, name, 6, options, spp, 5, 20);
        util::assert_same_image(&pt, &other, 4, &format!("{name} vs pt, textured light"));
    }
    let plain = util::seeded_renders(&plain, "pt", 6, &[], 64, 5, 30);
    assert!(util::differs(&pt, &plain, 2), "the texture changes nothing");
}
