//! The command line on bad input: one test per class. Each must exit non-zero — 2 when clap
//! cannot parse the command line (unknown flag or subcommand, a value of the wrong type,
//! conflicting flags), 1 for everything found after parsing (out-of-range values, bad
//! options, unreadable or invalid files) — with exactly one line on stderr that starts with
//! `lodestar:` and names the offending file, flag or value, never a panic, and must write
//! nothing. Plus the positive paths: render, info, compare, integrators.

use lodestar::film::Image;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

const TINY: &str = "tests/data/tiny.toml";

/// A fresh, empty directory for one test's outputs, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> TempDir {
        static N: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "lodestar-cli-errors-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    fn s(&self, name: &str) -> String {
        self.path(name).display().to_string()
    }

    fn is_empty(&self) -> bool {
        std::fs::read_dir(&self.0).unwrap().next().is_none()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Run lodestar in the package root.
fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lodestar"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cannot run lodestar")
}

/// The run failed with `code`, printed nothing on stdout and exactly one line on stderr that
/// starts with `lodestar:` and contains every fact; returns that line.
fn fails(out: &Output, code: i32, facts: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    let line = stderr.strip_suffix('\n').unwrap_or(&stderr);
    assert_eq!(
        out.status.code(),
        Some(code),
        "exit status; stderr: {stderr}"
    );
    assert!(
        !line.contains('\n'),
        "stderr should be one line: {stderr:?}"
    );
    assert!(line.starts_with("lodestar: "), "stderr: {stderr:?}");
    assert!(!line.contains("panicked"), "stderr: {stderr:?}");
    assert!(!line.contains("internal error"), "stderr: {stderr:?}");
    for fact in facts {
        assert!(
            line.contains(fact),
            "stderr should contain {fact:?}: {line}"
        );
    }
    assert!(
        out.stdout.is_empty(),
        "stdout: {:?}",
        String::from_utf8_lossy(&out.stdout)
    );
    line.to_string()
}

/// `lodestar render TINY -o T/x.exr --png T/x.png --quiet` plus `extra`: must fail with
/// `code` and the facts, writing nothing into T.
fn render_fails(extra: &[&str], code: i32, facts: &[&str]) -> String {
    let t = TempDir::new();
    let (exr, png) = (t.s("x.exr"), t.s("x.png"));
    let mut args = vec!["render", TINY, "-o", &exr, "--png", &png, "--quiet"];
    args.extend_from_slice(extra);
    let line = fails(&run(&args), code, facts);
    assert!(t.is_empty(), "nothing may be written on error");
    line
}

// ---- render: bad values ----

#[test]
fn unknown_integrator() {
    render_fails(
        &["--integrator", "bogus"],
        1,
        &["unknown integrator 'bogus'", "available", "pt"],
    );
}

#[test]
fn spp_zero() {
    render_fails(&["--spp", "0"], 1, &["--spp", "at least 1"]);
}

#[test]
fn spp_negative() {
    render_fails(&["--spp", "-3"], 2, &["--spp", "'-3'"]);
}

#[test]
fn spp_not_a_number() {
    render_fails(&["--spp", "abc"], 2, &["--spp", "'abc'"]);
}

#[test]
fn time_zero() {
    render_fails(&["--time", "0"], 1, &["--time", "got 0"]);
}

#[test]
fn time_nan() {
    render_fails(&["--time", "nan"], 1, &["--time", "NaN"]);
}

#[test]
fn time_negative() {
    render_fails(&["--time", "-1"], 1, &["--time", "got -1"]);
}

#[test]
fn spp_and_time_together() {
    render_fails(
        &["--spp", "4", "--time", "1"],
        2,
        &["--spp", "--time", "cannot be used with"],
    );
}

#[test]
fn threads_zero() {
    render_fails(&["--threads", "0"], 1, &["--threads", "at least 1"]);
}

#[test]
fn max_depth_zero() {
    render_fails(&["--max-depth", "0"], 1, &["--max-depth", "got 0"]);
}

#[test]
fn max_depth_below_minus_one() {
    render_fails(
        &["--max-depth", "-2"],
        1,
        &["--max-depth", "-1 for no limit", "got -2"],
    );
}

/// Mitsuba's usual 64 and "no limit" render with pt, lt, bdpt and vcm; what stores whole paths
/// (the guided integrators, mmlt) names its own limit.
#[test]
fn max_depth_64_and_unlimited() {
    for depth in ["64", "-1", "1000"] {
        for integrator in ["pt", "lt", "bdpt", "vcm"] {
            let t = TempDir::new();
            let exr = t.s("x.exr");
            let args = [
                "render",
                TINY,
                "-o",
                &exr,
                "--quiet",
                "--spp",
                "1",
                "--max-depth",
                depth,
                "--integrator",
                integrator,
            ];
            let out = run(&args);
            assert!(
                out.status.success(),
                "{integrator} --max-depth {depth}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }
    for integrator in ["guided-pt", "guided-bdpt", "mmlt"] {
        render_fails(
            &["--max-depth", "-1", "--integrator", integrator],
            1,
            &["max_depth must be at most 63", "got unlimited"],
        );
        render_fails(
            &["--max-depth", "64", "--integrator", integrator],
            1,
            &["max_depth must be at most 63", "got 64"],
        );
    }
}

#[test]
fn seed_negative() {
    render_fails(&["--seed", "-1"], 2, &["--seed", "'-1'"]);
}

#[test]
fn unknown_integrator_option() {
    render_fails(&["-O", "foo=1"], 1, &["option 'foo'", "'pt'"]);
}

#[test]
fn malformed_integrator_option() {
    render_fails(&["-O", "foo"], 1, &["option 'foo'", "key=value"]);
}

#[test]
fn bad_integrator_option_value() {
    render_fails(
        &["-O", "strategy=banana"],
        1,
        &["option 'strategy'", "'banana'", "mis"],
    );
}

#[test]
fn repeated_integrator_option() {
    render_fails(
        &["-O", "strategy=nee", "-O", "strategy=mis"],
        1,
        &["option 'strategy'", "twice"],
    );
}

#[test]
fn output_directory_does_not_exist() {
    let out = run(&["render", TINY, "-o", "/nonexistent/dir/x.exr", "--quiet"]);
    fails(&out, 1, &["/nonexistent/dir/x.exr", "does not exist"]);
    assert!(!Path::new("/nonexistent/dir/x.exr").exists());
}

#[test]
fn png_directory_does_not_exist() {
    // Checked before rendering: the EXR is not written either.
    let t = TempDir::new();
    let out = run(&[
        "render",
        TINY,
        "-o",
        &t.s("x.exr"),
        "--png",
        "/nonexistent/dir/x.png",
        "--quiet",
    ]);
    fails(&out, 1, &["/nonexistent/dir/x.png", "does not exist"]);
    assert!(t.is_empty());
}

/// An output path under a regular file (`file.exr/out.exr`: fails for root too, unlike a
/// read-only directory), for the EXR and for the PNG: the message says the parent is not a
/// directory, and nothing is written.
#[test]
fn output_under_a_regular_file() {
    let t = TempDir::new();
    std::fs::write(t.path("file.exr"), b"not a directory").unwrap();
    let (under, exr) = (t.s("file.exr/out.exr"), t.s("x.exr"));
    let parent = format!("'{}' is not a directory", t.s("file.exr"));
    let out = run(&["render", TINY, "-o", &under, "--quiet"]);
    fails(&out, 1, &[&under, "cannot write", &parent]);
    let png = t.s("file.exr/out.png");
    let out = run(&["render", TINY, "-o", &exr, "--png", &png, "--quiet"]);
    fails(&out, 1, &[&png, &parent]);
    let names: Vec<_> = std::fs::read_dir(&t.0)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["file.exr"], "nothing may be written on error");
}

/// `-o` naming an existing directory fails before rendering.
#[test]
fn output_is_a_directory() {
    let t = TempDir::new();
    std::fs::create_dir(t.path("out.exr")).unwrap();
    let dir = t.s("out.exr");
    let out = run(&["render", TINY, "-o", &dir, "--quiet"]);
    fails(&out, 1, &[&dir, "it is a directory (expected a file name)"]);
}

/// An output directory that does not take new files fails before rendering. Root writes into
/// read-only directories, so there the test says it was skipped.
#[test]
fn output_directory_read_only() {
    use std::os::unix::fs::PermissionsExt;
    let t = TempDir::new();
    let ro = t.path("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::write(ro.join("probe"), b"").is_ok() {
        eprintln!(
            "output_directory_read_only: skipped: this user (root?) may write into a read-only \
             directory (output_under_a_regular_file covers an unwritable path)"
        );
    } else {
        let exr = t.s("ro/x.exr");
        let out = run(&["render", TINY, "-o", &exr, "--quiet"]);
        let dir = format!("cannot create files in '{}'", ro.display());
        fails(&out, 1, &[&exr, &dir, "ermission denied"]);
        assert_eq!(std::fs::read_dir(&ro).unwrap().count(), 0);
    }
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
}

// ---- render: bad scene files ----

#[test]
fn nonexistent_scene_file() {
    let t = TempDir::new();
    let exr = t.s("x.exr");
    let out = run(&[
        "render",
        "tests/data/no-such-scene.toml",
        "-o",
        &exr,
        "--quiet",
    ]);
    fails(
        &out,
        1,
        &["tests/data/no-such-scene.toml", "cannot read scene file"],
    );
    assert!(t.is_empty());
}

/// A scene file that is not UTF-8 text: the message names the file, the line and the byte.
#[test]
fn scene_file_not_utf8() {
    let t = TempDir::new();
    let scene = t.path("latin1.toml");
    let mut text = std::fs::read(TINY).unwrap();
    text.extend(b"\n# caf\xe9\n");
    std::fs::write(&scene, &text).unwrap();
    let line = String::from_utf8_lossy(&text).lines().count();
    let (scene, exr) = (scene.display().to_string(), t.s("x.exr"));
    let where_ = format!("{scene}:{line}:");
    let out = run(&["render", &scene, "-o", &exr, "--quiet"]);
    fails(
        &out,
        1,
        &[
            &where_,
            "the scene file is not UTF-8 text (byte 0xe9 at column 6)",
        ],
    );
    assert!(!t.path("x.exr").exists());
}

/// A directory given as the scene.
#[test]
fn scene_path_is_a_directory() {
    let t = TempDir::new();
    let exr = t.s("x.exr");
    for dir in ["tests/data", "tests/data/"] {
        let out = run(&["render", dir, "-o", &exr, "--quiet"]);
        fails(&out, 1, &[dir, "cannot read scene file: it is a directory"]);
    }
    fails(
        &run(&["info", "tests"]),
        1,
        &["tests: cannot read scene file", "directory"],
    );
    assert!(t.is_empty());
}

/// The line of the first line of `file` (relative to the package root) containing `needle`.
fn line_in(file: &str, needle: &str) -> usize {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(file)).unwrap();
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn malformed_scene_names_file_and_line() {
    let file = "tests/data/bad-material.toml";
    let where_ = format!("{file}:{}:", line_in(file, r#"material = "missing""#));
    let t = TempDir::new();
    let exr = t.s("x.exr");
    let out = run(&["render", file, "-o", &exr, "--quiet"]);
    fails(&out, 1, &[&where_, "unknown material 'missing'"]);
    assert!(t.is_empty());
}

#[test]
fn scene_with_missing_mesh_names_file_and_line() {
    let file = "tests/data/bad-mesh.toml";
    let where_ = format!("{file}:{}:", line_in(file, "does-not-exist.obj"));
    let t = TempDir::new();
    let exr = t.s("x.exr");
    let out = run(&["render", file, "-o", &exr, "--quiet"]);
    fails(&out, 1, &[&where_, "tests/data/meshes/does-not-exist.obj"]);
    assert!(t.is_empty());
}

#[test]
fn scene_with_malformed_obj_names_file_and_line() {
    let file = "tests/data/bad-obj.toml";
    let where_ = format!("{file}:{}:", line_in(file, "broken.obj"));
    fails(
        &run(&["info", file]),
        1,
        &[&where_, "tests/data/meshes/broken.obj"],
    );
}

// ---- compare ----

fn write_exr(path: &Path, w: u32, h: u32) {
    Image::new(w, h).write_exr(path, &[]).unwrap();
}

#[test]
fn compare_missing_file() {
    let t = TempDir::new();
    let a = t.path("a.exr");
    write_exr(&a, 4, 4);
    let missing = t.s("missing.exr");
    fails(
        &run(&["compare", &a.display().to_string(), &missing]),
        1,
        &[&missing],
    );
    fails(
        &run(&["compare", &missing, &a.display().to_string()]),
        1,
        &[&missing],
    );
}

#[test]
fn compare_non_exr_file() {
    let t = TempDir::new();
    let a = t.path("a.exr");
    write_exr(&a, 4, 4);
    let fake = t.path("fake.exr");
    std::fs::write(&fake, "this is not an image\n").unwrap();
    let fake = fake.display().to_string();
    fails(
        &run(&["compare", &a.display().to_string(), &fake]),
        1,
        &[&fake, "cannot read EXR"],
    );
    // A scene file is not an image either.
    fails(
        &run(&["compare", TINY, TINY]),
        1,
        &[TINY, "cannot read EXR"],
    );
}

#[test]
fn compare_different_sizes() {
    let t = TempDir::new();
    let (a, b) = (t.path("a.exr"), t.path("b.exr"));
    write_exr(&a, 16, 16);
    write_exr(&b, 8, 16);
    let (a, b) = (a.display().to_string(), b.display().to_string());
    fails(
        &run(&["compare", &a, &b]),
        1,
        &[&a, &b, "differ in size", "16x16", "8x16"],
    );
}

#[test]
fn compare_missing_argument() {
    fails(&run(&["compare", "a.exr"]), 2, &["required", "<B>"]);
}

// ---- info, subcommands, flags ----

#[test]
fn info_missing_file() {
    fails(
        &run(&["info", "tests/data/no-such-scene.toml"]),
        1,
        &["tests/data/no-such-scene.toml", "cannot read scene file"],
    );
}

#[test]
fn unknown_subcommand() {
    fails(&run(&["frobnicate"]), 2, &["'frobnicate'", "subcommand"]);
}

#[test]
fn unknown_flag() {
    render_fails(&["--bogus"], 2, &["'--bogus'"]);
    fails(&run(&["info", "--verbose", TINY]), 2, &["'--verbose'"]);
}

// ---- Positive paths ----

#[test]
fn render_writes_exr_and_png() {
    let t = TempDir::new();
    let (exr, png) = (t.path("x.exr"), t.path("x.png"));
    let out = run(&[
        "render",
        TINY,
        "--spp",
        "1",
        "--seed",
        "7",
        "--threads",
        "2",
        "-o",
        &exr.display().to_string(),
        "--png",
        &png.display().to_string(),
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let (img, meta) = Image::read_exr(&exr).unwrap();
    assert_eq!((img.width, img.height), (16, 16));
    let get = |k: &str| {
        meta.iter()
            .find(|(key, _)| key == k)
            .map(|(_, v)| v.as_str())
            .unwrap_or_else(|| panic!("metadata key {k} missing: {meta:?}"))
    };
    assert_eq!(get("integrator"), "pt");
    assert_eq!(get("spp"), "1");
    assert_eq!(get("seed"), "7");
    assert_eq!(get("scene"), TINY);
    let seconds: f64 = get("seconds").parse().unwrap();
    assert!(seconds >= 0.0 && seconds.is_finite());
    let m = img.mean();
    assert!(m.is_finite() && m.x > 0.0, "the lamp lights the scene: {m}");
    let png_bytes = std::fs::read(&png).unwrap();
    assert!(png_bytes.starts_with(b"\x89PNG\r\n\x1a\n"));
    // Only the two outputs: no temporary files left behind.
    let mut names: Vec<String> = std::fs::read_dir(&t.0)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["x.exr", "x.png"]);
}

#[test]
fn info_prints_counts() {
    let out = run(&["info", "scenes/cornell-box.toml"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = |key: &str| {
        stdout
            .lines()
            .find(|l| l.starts_with(key))
            .unwrap_or_else(|| panic!("no {key} line: {stdout}"))
            .to_string()
    };
    let shapes = line("shapes");
    assert!(shapes.contains(" 8 "), "{shapes}");
    assert!(shapes.contains("24 triangles"), "{shapes}");
    assert!(shapes.contains("1 sphere"), "{shapes}");
    assert_eq!(line("lights").split_whitespace().nth(1), Some("1"));
    assert!(line("scene").contains("scenes/cornell-box.toml"));
}

#[test]
fn compare_identical_images() {
    let t = TempDir::new();
    let a = t.path("a.exr");
    let mut img = Image::new(4, 3);
    for (i, p) in img.pixels.iter_mut().enumerate() {
        *p = glam::Vec3::splat(i as f32 * 0.1);
    }
    img.write_exr(&a, &[]).unwrap();
    let a = a.display().to_string();
    let out = run(&["compare", &a, &a]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let value = |key: &str| -> f64 {
        let l = stdout
            .lines()
            .find(|l| l.split_whitespace().next() == Some(key))
            .unwrap_or_else(|| panic!("no {key} line: {stdout}"));
        l.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    assert_eq!(value("MSE"), 0.0);
    assert_eq!(value("RMSE"), 0.0);
    assert_eq!(value("relMSE"), 0.0);
}

#[test]
fn integrators_lists_pt() {
    let out = run(&["integrators"]);
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout
            .lines()
            .any(|l| l.split_whitespace().next() == Some("pt")),
        "{stdout}"
    );
}

// ---- render --snapshots, compare --crop ----

#[test]
fn snapshots_not_numbers() {
    render_fails(&["--snapshots", "5,x"], 1, &["--snapshots", "'5,x'"]);
}

#[test]
fn snapshots_not_positive() {
    render_fails(&["--snapshots", "0,1"], 1, &["--snapshots", "got 0"]);
    render_fails(&["--snapshots", "nan"], 1, &["--snapshots", "NaN"]);
}

#[test]
fn snapshots_beyond_the_time_budget() {
    render_fails(
        &["--time", "1", "--snapshots", "0.5,2"],
        1,
        &["--snapshots", "2 s is beyond --time 1"],
    );
}

#[test]
fn compare_bad_crop() {
    let t = TempDir::new();
    let a = t.path("a.exr");
    write_exr(&a, 8, 8);
    let a = a.display().to_string();
    fails(
        &run(&["compare", &a, &a, "--crop", "1,2,3"]),
        1,
        &["--crop", "x0,y0,x1,y1", "'1,2,3'"],
    );
    fails(
        &run(&["compare", &a, &a, "--crop", "0,0,9,8"]),
        1,
        &["--crop 0,0,9,8", "outside the 8x8 image"],
    );
}

// ---- bench ----

/// `lodestar bench` on TINY with a 16 x 16 reference in T, output T/out, with `flags`
/// (flag, value) replacing the defaults or added: must fail with `code` and the facts,
/// creating no output directory.
fn bench_fails(flags: &[(&str, &str)], code: i32, facts: &[&str]) -> String {
    let t = TempDir::new();
    let reference = t.path("ref.exr");
    write_exr(&reference, 16, 16);
    let (reference, out) = (reference.display().to_string(), t.s("out"));
    let mut pairs = vec![
        ("--scene", TINY),
        ("--integrators", "pt"),
        ("--time", "0.01"),
        ("--reference", &reference),
        ("--out", &out),
    ];
    for &(flag, value) in flags {
        match pairs.iter_mut().find(|(f, _)| *f == flag) {
            Some(pair) => pair.1 = value,
            None => pairs.push((flag, value)),
        }
    }
    let mut args = vec!["bench", "--quiet"];
    args.extend(pairs.iter().flat_map(|&(f, v)| [f, v]));
    let line = fails(&run(&args), code, facts);
    assert!(!t.path("out").exists(), "nothing may be written on error");
    line
}

#[test]
fn bench_unknown_integrator() {
    bench_fails(
        &[("--integrators", "pt,bogus")],
        1,
        &["--integrators", "unknown integrator 'bogus'", "bdpt"],
    );
}

#[test]
fn bench_integrator_listed_twice() {
    bench_fails(&[("--integrators", "pt,lt,pt")], 1, &["'pt'", "twice"]);
}

#[test]
fn bench_bad_time() {
    bench_fails(&[("--time", "0")], 1, &["--time", "got 0"]);
    bench_fails(&[("--time", "-2")], 1, &["--time", "got -2"]);
    bench_fails(&[("--time", "nan")], 1, &["--time", "NaN"]);
    bench_fails(&[("--time", "soon")], 2, &["--time", "'soon'"]);
}

#[test]
fn bench_zero_runs() {
    bench_fails(&[("--runs", "0")], 1, &["--runs", "at least 1"]);
}

#[test]
fn bench_reference_of_the_wrong_resolution() {
    let t = TempDir::new();
    let small = t.path("small.exr");
    write_exr(&small, 8, 16);
    let small = small.display().to_string();
    bench_fails(
        &[("--reference", &small)],
        1,
        &[&small, "reference is 8x16", TINY, "16x16"],
    );
}

#[test]
fn bench_unreadable_reference() {
    let t = TempDir::new();
    let missing = t.s("missing.exr");
    bench_fails(
        &[("--reference", &missing)],
        1,
        &[&missing, "cannot read EXR"],
    );
    bench_fails(&[("--reference", TINY)], 1, &[TINY, "cannot read EXR"]);
}

#[test]
fn bench_bad_crop() {
    bench_fails(&[("--crop", "4,4,2,8")], 1, &["--crop", "'4,4,2,8'"]);
    bench_fails(
        &[("--crop", "0,0,16,17")],
        1,
        &["--crop 0,0,16,17", "outside the 16x16 image"],
    );
}

#[test]
fn bench_missing_scene_and_required_flags() {
    bench_fails(
        &[("--scene", "tests/data/no-such-scene.toml")],
        1,
        &["tests/data/no-such-scene.toml", "cannot read scene file"],
    );
    fails(
        &run(&["bench", "--scene", TINY, "--time", "1"]),
        2,
        &["required", "--integrators", "--reference"],
    );
}

#[test]
fn bench_output_parent_missing() {
    bench_fails(
        &[("--out", "/nonexistent/dir/out")],
        1,
        &["--out /nonexistent/dir/out", "does not exist"],
    );
}

/// A reader that stops early (`lodestar info S | head -1`) closes the pipe: the write fails
/// and lodestar ends quietly with status 0 instead of panicking in `println!` (which printed
/// "internal error" and exited 101). The pipe's read end is closed before lodestar starts,
/// so its first write fails every time.
#[test]
fn output_into_a_closed_pipe_ends_quietly() {
    for args in [
        &["info", "scenes/cornell-box.toml"][..],
        &["integrators"][..],
    ] {
        let (reader, writer) = std::io::pipe().expect("a pipe");
        drop(reader);
        let out = Command::new(env!("CARGO_BIN_EXE_lodestar"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(writer)
            .output()
            .expect("cannot run lodestar");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {:?}: {stderr}", out.status);
        assert!(stderr.is_empty(), "{args:?}: {stderr}");
    }
}

// ---- guide caches (-O load_guides=) ----

/// One vertex of a guide path as `integrators/guided/io.rs` stores it.
#[derive(Clone)]
struct GuideVertex {
    p: [f32; 3],
    n: [f32; 3],
    tag: u8,
    ids: [u32; 2],
}

/// A guide path: vertex count as written (camera included), f, p_u, weight, vertices after
/// the camera.
#[derive(Clone)]
struct GuidePath {
    len: u8,
    f: f64,
    p_u: f64,
    weight: f64,
    vertices: Vec<GuideVertex>,
}

/// The fields of a guide cache file, serialised in the layout `io.rs` documents.
#[derive(Clone)]
struct GuideFile {
    version: u32,
    fingerprint: u64,
    widths: [f64; 3],
    ratio: f64,
    paths: Vec<GuidePath>,
    /// The path count as written, when not `paths.len()`.
    count: Option<u32>,
}

impl GuideFile {
    /// A valid cache for TINY: one path from the camera to the back wall (shape 0, material
    /// 0) and on to the lamp (light 0).
    fn valid() -> GuideFile {
        use lodestar::integrators::guided::io;
        let scene =
            lodestar::scene::loader::load_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join(TINY))
                .unwrap();
        assert_eq!(scene.shape_info[0].name, "back");
        GuideFile {
            version: io::VERSION,
            fingerprint: io::scene_fingerprint(&scene),
            widths: [1.0, 1.0, 1.0],
            ratio: 0.5,
            paths: vec![GuidePath {
                len: 3,
                f: 2.0,
                p_u: 0.25,
                weight: 1.0,
                vertices: vec![
                    GuideVertex {
                        p: [0.0, 0.0, -1.0],
                        n: [0.0, 0.0, 1.0],
                        tag: 1,
                        ids: [0, 0],
                    },
                    GuideVertex {
                        p: [0.0, 0.99, 0.0],
                        n: [0.0, -1.0, 0.0],
                        tag: 3,
                        ids: [0, 0],
                    },
                ],
            }],
            count: None,
        }
    }

    fn bytes(&self) -> Vec<u8> {
        let mut b = b"LSGUIDES".to_vec();
        b.extend(self.version.to_le_bytes());
        b.extend(self.fingerprint.to_le_bytes());
        b.extend(3u32.to_le_bytes());
        for w in self.widths {
            b.extend(w.to_le_bytes());
        }
        b.extend(self.ratio.to_le_bytes());
        let count = self.count.unwrap_or(self.paths.len() as u32);
        b.extend(count.to_le_bytes());
        for g in &self.paths {
            b.push(g.len);
            b.extend(1u16.to_le_bytes());
            for x in [g.f, g.p_u, g.weight] {
                b.extend(x.to_le_bytes());
            }
            for v in &g.vertices {
                // Position, normal, shading normal, tangent (zero: an isotropic surface).
                for x in [v.p, v.n, v.n, [0.0; 3]].concat() {
                    b.extend(x.to_le_bytes());
                }
                // Texture coordinates.
                for x in [0f32, 0f32] {
                    b.extend(x.to_le_bytes());
                }
                b.push(v.tag);
                b.extend(v.ids[0].to_le_bytes());
                b.extend(v.ids[1].to_le_bytes());
                b.push(0);
            }
        }
        b
    }
}

/// `lodestar render TINY --integrator guided-pt -O load_guides=F` with F holding `data`: the
/// output of the run.
fn render_with_guides(t: &TempDir, name: &str, data: &[u8], extra: &[&str]) -> Output {
    let file = t.path(name);
    std::fs::write(&file, data).unwrap();
    let load = format!("load_guides={}", file.display());
    let exr = t.s("x.exr");
    let mut args = vec![
        "render",
        TINY,
        "--integrator",
        "guided-pt",
        "-O",
        &load,
        "--spp",
        "1",
        "-o",
        &exr,
        "--quiet",
    ];
    args.extend_from_slice(extra);
    run(&args)
}

/// Every way `io::load` rejects a guide cache, through the command line: exit status 1, one
/// line naming the file and what was expected, nothing written. The hand-made valid file the
/// cases break renders, so each case fails for its own reason.
#[test]
fn bad_guide_caches_name_the_file_and_the_fault() {
    let t = TempDir::new();
    let valid = GuideFile::valid();
    let out = render_with_guides(&t, "valid.guides", &valid.bytes(), &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "the valid cache: {stderr}");
    assert!(t.path("x.exr").is_file());
    std::fs::remove_file(t.path("x.exr")).unwrap();

    let edited = |edit: &dyn Fn(&mut GuideFile)| {
        let mut f = valid.clone();
        edit(&mut f);
        f.bytes()
    };
    let vertex = |k: usize, edit: &dyn Fn(&mut GuideVertex)| {
        edited(&|f: &mut GuideFile| edit(&mut f.paths[0].vertices[k]))
    };
    let path = |edit: &dyn Fn(&mut GuidePath)| edited(&|f: &mut GuideFile| edit(&mut f.paths[0]));
    let mut trailing = valid.bytes();
    trailing.extend([0, 0, 0]);
    let full = valid.bytes();
    let path0 = "guide path 0";
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        (
            "magic",
            b"LSGUIDEX and more".to_vec(),
            vec!["not a lodestar guide cache (bad magic)"],
        ),
        ("short", b"LSG".to_vec(), vec!["bad magic"]),
        (
            "version",
            edited(&|f| f.version = 4),
            vec!["guide cache format version 4, this lodestar reads version 7"],
        ),
        (
            "fingerprint",
            edited(&|f| f.fingerprint ^= 1),
            vec!["guide cache was learned on another scene (not tests/data/tiny.toml)"],
        ),
        (
            "widths",
            edited(&|f| f.widths[1] = 0.0),
            vec!["invalid kernel widths", "expected finite numbers > 0"],
        ),
        (
            "ratio",
            edited(&|f| f.ratio = -2.0),
            vec!["invalid guided share ratio -2 (expected a finite number >= 0, or -1 for none)"],
        ),
        (
            "ratio-nan",
            edited(&|f| f.ratio = f64::NAN),
            vec!["invalid guided share ratio NaN"],
        ),
        (
            "length-2",
            path(&|g| {
                g.len = 2;
                g.vertices.truncate(1);
            }),
            vec!["guide path 0 has 2 vertices (expected 3 to 64)"],
        ),
        (
            "length-65",
            path(&|g| g.len = 65),
            vec!["guide path 0 has 65 vertices"],
        ),
        (
            "kind",
            vertex(0, &|v| v.tag = 0),
            vec!["guide path 0, vertex 1: kind 0 (expected 1 surface, 2 medium or 3 emitter)"],
        ),
        (
            "kind-9",
            vertex(1, &|v| v.tag = 9),
            vec!["guide path 0, vertex 2: kind 9"],
        ),
        (
            "material",
            vertex(0, &|v| v.ids[0] = 99),
            vec!["guide path 0, vertex 1: material 99, but the scene has"],
        ),
        (
            "shape",
            vertex(0, &|v| v.ids[1] = 4),
            vec!["guide path 0, vertex 1: shape 4, but the scene has 4"],
        ),
        (
            "medium",
            vertex(0, &|v| v.tag = 2),
            vec!["guide path 0, vertex 1: medium 0, but the scene has 0"],
        ),
        (
            "light",
            vertex(1, &|v| v.ids[0] = 1),
            vec!["guide path 0, vertex 2: light 1, but the scene has 1"],
        ),
        (
            "position",
            vertex(0, &|v| v.p[1] = f32::INFINITY),
            vec![
                "guide path 0, vertex 1: position [0, inf, -1]",
                "expected finite numbers",
            ],
        ),
        (
            "normal",
            vertex(1, &|v| v.n[0] = f32::NAN),
            vec!["guide path 0, vertex 2: position", "normal [NaN, -1, 0]"],
        ),
        (
            "f",
            path(&|g| g.f = f64::INFINITY),
            vec![
                "guide path 0 has f = inf, p_u = 0.25, weight = 1 (expected finite numbers, weight >= 0)",
            ],
        ),
        ("p_u", path(&|g| g.p_u = f64::NAN), vec![path0, "p_u = NaN"]),
        (
            "weight",
            path(&|g| g.weight = -1.0),
            vec![path0, "weight = -1"],
        ),
        (
            "emitter-inside",
            vertex(0, &|v| {
                v.tag = 3;
                v.ids = [0, 0];
            }),
            vec![
                "guide path 0 is not a complete path (expected an emitter as its last vertex and only there)",
            ],
        ),
        (
            "no-emitter",
            vertex(1, &|v| v.tag = 1),
            vec![path0, "not a complete path"],
        ),
        (
            "weights",
            path(&|g| g.weight = 0.5),
            vec!["guide path weights sum to 0.5, not 1"],
        ),
        (
            "trailing",
            trailing,
            vec!["3 trailing bytes after the 1 guide paths the file declares"],
        ),
        (
            "truncated",
            full[..full.len() - 5].to_vec(),
            vec!["truncated guide cache (needs more than"],
        ),
        (
            "count",
            edited(&|f| f.count = Some(2)),
            vec!["truncated guide cache"],
        ),
    ];
    for (name, data, facts) in cases {
        let file = format!("{name}.guides");
        let out = render_with_guides(&t, &file, &data, &[]);
        let mut facts = facts;
        let path = t.s(&file);
        facts.push(&path);
        fails(&out, 1, &facts);
        assert!(!t.path("x.exr").exists(), "{name}: an image was written");
    }
    // A missing file, and guide paths longer than the render's max_depth (the driver's check).
    let (missing, exr) = (t.s("missing.guides"), t.s("x.exr"));
    let load = format!("load_guides={missing}");
    fails(
        &run(&[
            "render",
            TINY,
            "--integrator",
            "guided-pt",
            "-O",
            &load,
            "-o",
            &exr,
            "--quiet",
        ]),
        1,
        &[&missing, "cannot read guide cache"],
    );
    let out = render_with_guides(&t, "deep.guides", &full, &["--max-depth", "1"]);
    fails(
        &out,
        1,
        &["deep.guides", "2 segments, more than max_depth 1"],
    );
}
