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
        for integrator in [
            "pt",
            "lt",
            "bdpt",
            "vcm",
            "bpm",
            "guided-pt",
            "guided-bdpt",
            "pssmlt",
            "mmlt",
        ] {
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

/// A 2 x 2 light of radiance 3e38 (near the largest f32) overflows light subpaths'
/// throughput (Le cos / (p_pos p_dir) = pi A Le): `--check` lists the invalid values by
/// technique and the exit status is non-zero.
#[test]
fn overflowing_light_is_reported_and_fails() {
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
emission = [3e38, 3e38, 3e38]
"#;
    let scene =
        std::env::temp_dir().join(format!("lodestar-check-hot-{}.toml", std::process::id()));
    std::fs::write(&scene, text).unwrap();
    for integrator in ["lt", "bdpt", "vcm"] {
        let (ok, stderr) = check(scene.to_str().unwrap(), integrator, "2");
        assert!(!ok, "{integrator}: must fail: {stderr}");
        assert!(
            stderr.contains(&format!("check: {integrator}: "))
                && stderr.contains("value not finite or negative")
                && stderr.contains("--check:"),
            "{integrator}: {stderr}"
        );
    }
    std::fs::remove_file(&scene).unwrap();
}
