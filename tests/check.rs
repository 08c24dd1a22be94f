//! `lodestar render --check`: every integrator validates its samples, splats, technique
//! densities and MIS weights; a clean render says how much it checked and exits 0, and a
//! render that produces invalid values lists them per technique and exits non-zero.

use std::path::PathBuf;
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lodestar"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cannot run lodestar")
}

fn out_path(tag: &str) -> PathBuf {
    std::env::temp_dir().join(format!("lodestar-check-{}-{tag}.exr", std::process::id()))
}

fn check(scene: &str, integrator: &str, spp: &str) -> (bool, String) {
    let out = out_path(&format!("{integrator}-{}", scene.replace('/', "_")));
    let o = run(&[
        "render",
        scene,
        "--integrator",
        integrator,
        "--spp",
        spp,
        "--quiet",
        "--check",
        "-o",
        out.to_str().unwrap(),
    ]);
    let _ = std::fs::remove_file(&out);
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Every integrator on the fog scene and the glossy Cornell box checks millions of
/// quantities and finds no violation.
#[test]
fn every_integrator_checks_clean() {
    for scene in ["tests/data/tiny.toml", "scenes/cornell-fog.toml"] {
        for integrator in lodestar::integrators::REGISTRY.iter().map(|e| e.name) {
            let spp = if scene.contains("fog") { "1" } else { "4" };
            let (ok, stderr) = check(scene, integrator, spp);
            assert!(ok, "{integrator} on {scene}: {stderr}");
            let line = stderr
                .lines()
                .find(|l| l.starts_with(&format!("check: {integrator}: ")))
                .unwrap_or_else(|| panic!("no check line: {stderr}"));
            let checked: u64 = line
                .split_whitespace()
                .nth(2)
                .and_then(|n| n.parse().ok())
                .unwrap_or_else(|| panic!("{line}"));
            assert!(checked > 1000, "{integrator}: only {checked} checked");
            assert!(line.ends_with(", 0 violations"), "{line}");
        }
    }
}

/// A light the loader would refuse (radiance 3e38 on a 2 x 2 quad: its power overflows),
/// set on a loaded scene behind the loader's back: light subpaths' throughput overflows, and
/// with checking on, every integrator that traces them reports the invalid values by
/// technique (the command line then exits non-zero, as `check_report` in main.rs does for any
/// violation). The loader's own refusal is tested in `fuzz_regressions`.
#[test]
fn overflowing_light_is_reported() {
    use lodestar::light::Light;
    let text = r#"
[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
fov = 40
resolution = [8, 8]
[[material]]
name = "white"
type = "diffuse"
albedo = [0.7, 0.7, 0.7]
[[material]]
name = "black"
type = "black"
[[shape]]
type = "quad"
origin = [-2, -1, -2]
edge_u = [0, 0, 4]
edge_v = [4, 0, 0]
material = "white"
[[shape]]
name = "lamp"
type = "quad"
origin = [-1, 1, -1]
edge_u = [2, 0, 0]
edge_v = [0, 0, 2]
material = "black"
emission = [1, 1, 1]
"#;
    let mut scene = lodestar::scene::loader::load_str(text, "hot.toml", None).unwrap();
    let Light::Area(a) = &mut scene.lights[0] else {
        panic!("the lamp is an area light")
    };
    a.radiance = glam::Vec3::splat(3e38);
    for integrator in ["lt", "bdpt", "vcm"] {
        lodestar::check::enable();
        let options = lodestar::integrators::Options::parse(&[]).unwrap();
        let params = lodestar::integrators::IntegratorParams {
            max_depth: 4,
            options,
        };
        lodestar::integrators::render_named(
            &scene,
            integrator,
            &params,
            lodestar::render::Budget::Spp(2),
            1,
            1,
            false,
        )
        .unwrap();
        lodestar::check::disable();
        let (checked, violations) = lodestar::check::report();
        assert!(checked > 0, "{integrator}: nothing checked");
        assert!(
            violations
                .iter()
                .any(|(_, k, t)| *k == lodestar::check::Kind::Value && t.count > 0),
            "{integrator}: no invalid value reported: {violations:?}"
        );
    }
}

/// End to end through the command line: a point light of intensity 1e36 a millimetre above a
/// floor, seen through a 0.1-degree lens, makes radiance beyond f32's range (I / d^2 = 1e42)
/// in every pixel, a scene the loader accepts (the light's power, 1.3e37, is finite). With
/// `--check` the render lists the invalid values per technique and exits non-zero; without it,
/// it exits 0 and warns that samples were left out. Control: the same scene with the light
/// at 1e30 checks clean.
#[test]
fn check_exit_status_end_to_end() {
    let scene = |intensity: &str| {
        format!(
            r#"
[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
fov = 0.1
resolution = [16, 16]
[render]
max_depth = 4
[[material]]
name = "white"
type = "diffuse"
albedo = [0.5, 0.5, 0.5]
[[shape]]
type = "quad"
origin = [-1, -1, 1]
edge_u = [2, 0, 0]
edge_v = [0, 2, 0]
material = "white"
[[light]]
type = "point"
position = [0, 0, 1.001]
intensity = [{intensity}, {intensity}, {intensity}]
"#
        )
    };
    let dir = std::env::temp_dir();
    let render = |intensity: &str, check: bool| {
        let path = dir.join(format!(
            "lodestar-check-e2e-{}-{intensity}.toml",
            std::process::id()
        ));
        std::fs::write(&path, scene(intensity)).unwrap();
        let out = out_path(&format!("e2e-{intensity}-{check}"));
        let mut args = vec!["render", path.to_str().unwrap(), "--spp", "2", "--quiet"];
        args.extend(["-o", out.to_str().unwrap()]);
        if check {
            args.push("--check");
        }
        let o = run(&args);
        let _ = std::fs::remove_file(&out);
        let _ = std::fs::remove_file(&path);
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (ok, stderr) = render("1e36", true);
    assert!(!ok, "--check with invalid values must fail: {stderr}");
    assert!(
        stderr.contains("pt next-event: value not finite"),
        "{stderr}"
    );
    assert!(
        stderr.contains("--check:") && stderr.contains("violations"),
        "{stderr}"
    );
    let (ok, stderr) = render("1e36", false);
    assert!(ok, "{stderr}");
    assert!(
        stderr.contains("non-finite or negative and left out"),
        "{stderr}"
    );
    let (ok, stderr) = render("1e30", true);
    assert!(ok, "{stderr}");
    assert!(stderr.contains(", 0 violations"), "{stderr}");
}
