//! EXR files round-trip: the pixels bit for bit (f32) or as their f16 rounding (half), and
//! every header entry the command line writes: the run's identity, the integrator's settings,
//! the pass count and every statistic the render reported (guided statistics included).

use crate::util;

use lodestar::film::Image;
use std::process::Command;

/// Test images with values that f16 rounds: a ramp over 1e-6 .. 6e4 and special cases.
fn ramp() -> Image {
    let mut img = Image::new(7, 5);
    for (i, p) in img.pixels.iter_mut().enumerate() {
        let t = i as f32 / 34.0;
        *p = glam::Vec3::new(1e-6 * (1e10f32).powf(t), t, 0.1 + 3.3 * t);
    }
    img
}

#[test]
fn f32_and_half_pixels_and_metadata_round_trip() {
    let dir = std::env::temp_dir().join(format!("lodestar-exr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let img = ramp();
    let meta = vec![
        ("integrator".to_string(), "guided-pt".to_string()),
        (
            "settings".to_string(),
            "alpha=0.5 max_depth=8 seeder=mcmc".to_string(),
        ),
        ("stats".to_string(), "[0, 0, 3] 1e-6 inf".to_string()),
    ];
    let full = dir.join("full.exr");
    img.write_exr(&full, &meta).unwrap();
    let (back, back_meta) = Image::read_exr(&full).unwrap();
    assert_eq!(back, img, "f32 pixels");
    let mut sorted = meta.clone();
    sorted.sort();
    assert_eq!(back_meta, sorted);

    let half = dir.join("half.exr");
    img.write_exr_half(&half, &meta).unwrap();
    let (back, back_meta) = Image::read_exr(&half).unwrap();
    assert_eq!(back_meta, sorted);
    for (a, b) in img.pixels.iter().zip(&back.pixels) {
        let want = a
            .to_array()
            .map(|v| exr::prelude::f16::from_f32(v).to_f32());
        assert_eq!(b.to_array(), want, "half pixel of {a}");
    }
    // EXR text is Latin-1: other text is refused with an error naming the key, never written
    // mangled.
    let bad = vec![("unicode".to_string(), "σ_t".to_string())];
    let err = img.write_exr(&dir.join("bad.exr"), &bad).unwrap_err();
    assert!(err.to_string().contains("'unicode'"), "{err}");
    assert!(!dir.join("bad.exr").exists(), "nothing written on error");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A guided render from the command line: the EXR's header holds the integrator, scene,
/// seed, threads, settings, spp, passes and every `stats:` entry the run printed, with the
/// same values; its pixels equal the library's render of the same seed bit for bit.
#[test]
fn command_line_header_holds_every_statistic() {
    let dir = std::env::temp_dir().join(format!("lodestar-exr-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let exr = dir.join("g.exr");
    let out = Command::new(env!("CARGO_BIN_EXE_lodestar"))
        .args([
            "render",
            "tests/data/tiny.toml",
            "--integrator",
            "guided-pt",
            "--spp",
            "6",
        ])
        .args([
            "--seed",
            "3",
            "--threads",
            "2",
            "-O",
            "learn_fraction=0.5",
            "-o",
        ])
        .arg(&exr)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let (img, meta) = Image::read_exr(&exr).unwrap();
    let get = |k: &str| {
        meta.iter()
            .find(|(key, _)| key == k)
            .map(|(_, v)| v.clone())
            .unwrap_or_else(|| panic!("header key {k} missing: {meta:?}"))
    };
    assert_eq!(get("integrator"), "guided-pt");
    assert_eq!(get("seed"), "3");
    assert_eq!(get("threads"), "2");
    assert_eq!(get("spp"), "6");
    assert!(
        get("settings").contains("learn_fraction"),
        "{}",
        get("settings")
    );
    get("passes");
    let stats = stderr
        .lines()
        .find_map(|l| l.strip_prefix("stats: "))
        .unwrap_or_else(|| panic!("no stats line: {stderr}"));
    // Entries are `key=value` joined by ", "; values may hold ", " themselves (lists), so a
    // piece starts a new entry only when it begins with a key and '='.
    let mut entries: Vec<String> = Vec::new();
    for piece in stats.split(", ") {
        let starts_entry = piece.split_once('=').is_some_and(|(k, _)| {
            !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        });
        match entries.last_mut() {
            Some(last) if !starts_entry => {
                last.push_str(", ");
                last.push_str(piece);
            }
            _ => entries.push(piece.to_string()),
        }
    }
    let mut n = 0;
    for kv in &entries {
        let (k, v) = kv.split_once('=').unwrap();
        assert_eq!(get(k), v, "header entry {k}");
        n += 1;
    }
    assert!(n >= 5, "only {n} statistics: {stats}");
    assert!(
        stats.contains("guide_paths="),
        "guided statistics in the header: {stats}"
    );
    let scene = lodestar::scene::loader::load_file(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/tiny.toml"
    )))
    .unwrap();
    let lib = util::render(&scene, "guided-pt", 4, &["learn_fraction=0.5"], 6, 3, 2).image;
    assert_eq!(img, lib, "the file's pixels are the render's");
    std::fs::remove_dir_all(&dir).unwrap();
}
