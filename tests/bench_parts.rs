//! `bench --part I/N` and `bench --from-parts`: a bench split into three parts and gathered
//! back holds the same runs (integrators, seeds) as the same bench on one machine, its numbers
//! are those of the runs the parts wrote (errors recomputed here from their images), its
//! images are the parts' images, and parts that do not belong together are refused.

use lodestar::film::Image;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const TINY: &str = "tests/data/tiny.toml";

struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn lodestar(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lodestar"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cannot run lodestar")
}

fn ok(args: &[&str]) -> Output {
    let o = lodestar(args);
    assert!(
        o.status.success(),
        "lodestar {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn fails(args: &[&str], needle: &str) {
    let o = lodestar(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "lodestar {args:?} succeeded");
    assert!(err.contains(needle), "lodestar {args:?}: {err}");
}

/// report.csv rows keyed by (integrator, run).
fn rows(path: &Path) -> HashMap<(String, String), HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            let row: HashMap<String, String> = header
                .iter()
                .map(|h| h.to_string())
                .zip(l.split(',').map(String::from))
                .collect();
            ((row["integrator"].clone(), row["run"].clone()), row)
        })
        .collect()
}

/// stats.csv rows in file order: ((integrator, run, key), value).
fn stats(path: &Path) -> Vec<((String, String, String), String)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("scene,integrator,run,seed,key,value"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 6, "{l}");
            ((f[1].into(), f[2].into(), f[4].into()), f[5].into())
        })
        .collect()
}

fn mse(a: &Image, b: &Image) -> f64 {
    let mut s = 0.0;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            s += (p[c] as f64 - q[c] as f64).powi(2);
        }
    }
    s / (3 * a.pixels.len()) as f64
}

#[test]
fn a_bench_in_three_parts_gathers_to_the_same_runs() {
    let dir =
        TempDir(std::env::temp_dir().join(format!("lodestar-bench-parts-{}", std::process::id())));
    std::fs::create_dir_all(&dir.0).unwrap();
    let d = |name: &str| dir.0.join(name).display().to_string();
    // A reference: pt at 64 spp.
    ok(&[
        "render",
        TINY,
        "--spp",
        "64",
        "--seed",
        "99",
        "--quiet",
        "-o",
        &d("ref.exr"),
    ]);
    let reference = d("ref.exr");
    let bench = |extra: &[&str]| -> Vec<String> {
        let mut a: Vec<String> = [
            "bench",
            "--scene",
            TINY,
            "--integrators",
            "pt,bdpt",
            "--time",
            "0.2",
            "--runs",
            "3",
            "--seed",
            "5",
            "--threads",
            "1",
            "--quiet",
            "--reference",
            &reference,
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let run = |extra: &[&str]| {
        let a = bench(extra);
        ok(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    run(&["--out", &d("single")]);
    for i in 1..=3 {
        run(&["--part", &format!("{i}/3"), "--out", &d(&format!("p{i}"))]);
    }
    // Six runs over three parts: two each.
    for i in 1..=3 {
        let n = std::fs::read_dir(dir.0.join(format!("p{i}/runs")))
            .unwrap()
            .count();
        assert_eq!(n, 2, "part {i}");
        assert!(!dir.0.join(format!("p{i}/index.html")).exists());
    }
    run(&[
        "--from-parts",
        &d("p1"),
        &d("p2"),
        &d("p3"),
        "--out",
        &d("merged"),
    ]);
    let (single, merged) = (
        rows(&dir.0.join("single/report.csv")),
        rows(&dir.0.join("merged/report.csv")),
    );
    let mut keys: Vec<_> = single.keys().cloned().collect();
    let mut mkeys: Vec<_> = merged.keys().cloned().collect();
    keys.sort();
    mkeys.sort();
    assert_eq!(keys, mkeys, "the same integrators and runs");
    assert_eq!(keys.len(), 2 * 3 + 2);
    let (reference, _) = Image::read_exr(&dir.0.join("ref.exr")).unwrap();
    for ((integrator, run), row) in &merged {
        assert_eq!(
            row["seed"],
            single[&(integrator.clone(), run.clone())]["seed"]
        );
        if run == "median" {
            continue;
        }
        // The run's image, from whichever part rendered it: its error is the report's.
        let file = format!("{integrator}.seed{}.exr", row["seed"]);
        let path = (1..=3)
            .map(|i| dir.0.join(format!("p{i}/runs/{file}")))
            .find(|p| p.exists())
            .unwrap_or_else(|| panic!("no part holds {file}"));
        let (img, meta) = Image::read_exr(&path).unwrap();
        let m = mse(&img, &reference);
        let reported: f64 = row["mse"].parse().unwrap();
        assert!(
            (m - reported).abs() <= 1e-6 * m,
            "{file}: {m} vs {reported}"
        );
        let spp = meta.iter().find(|(k, _)| k == "spp").unwrap().1.clone();
        assert_eq!(row["spp"], spp, "{file}");
        // The first seed's image is the integrator's image in the report.
        if row["seed"] == "5" {
            let (shown, _) =
                Image::read_exr(&dir.0.join(format!("merged/images/{integrator}.exr"))).unwrap();
            assert_eq!(shown.pixels, img.pixels, "{integrator}");
        }
    }
    assert!(dir.0.join("merged/index.html").exists());
    assert!(dir.0.join("merged/curves.svg").exists());
    // Every run's end-of-render statistics reach stats.csv, through the parts as well.
    let (single_stats, merged_stats) = (
        stats(&dir.0.join("single/stats.csv")),
        stats(&dir.0.join("merged/stats.csv")),
    );
    // The same statistics of the same runs, in the same order (values may differ in time).
    let names = |m: &[((String, String, String), String)]| -> Vec<(String, String, String)> {
        m.iter().map(|(k, _)| k.clone()).collect()
    };
    assert_eq!(names(&single_stats), names(&merged_stats));
    let merged_stats: HashMap<_, _> = merged_stats.into_iter().collect();
    for integrator in ["pt", "bdpt"] {
        for run in ["0", "1", "2"] {
            assert!(
                merged_stats
                    .keys()
                    .any(|(i, r, _)| i == integrator && r == run),
                "no statistics for {integrator} run {run}"
            );
        }
    }
    for run in ["0", "1", "2"] {
        let key = (
            "pt".to_string(),
            run.to_string(),
            "invalid_samples".to_string(),
        );
        assert_eq!(merged_stats[&key], "0", "pt run {run}");
    }

    // Refusals, each naming what is wrong.
    let refuse = |extra: &[&str], needle: &str| {
        let a = bench(extra);
        fails(&a.iter().map(String::as_str).collect::<Vec<_>>(), needle);
    };
    refuse(
        &["--from-parts", &d("p1"), &d("p2"), "--out", &d("m2")],
        "is missing",
    );
    refuse(
        &[
            "--from-parts",
            &d("p1"),
            &d("p2"),
            &d("p3"),
            &d("p1"),
            "--out",
            &d("m3"),
        ],
        "is also in",
    );
    let mut other = bench(&[
        "--from-parts",
        &d("p1"),
        &d("p2"),
        &d("p3"),
        "--out",
        &d("m4"),
    ]);
    let t = other.iter().position(|a| a == "0.2").unwrap();
    other[t] = "0.3".into();
    fails(
        &other.iter().map(String::as_str).collect::<Vec<_>>(),
        "field 'bench_time' is '0.2'",
    );
    refuse(&["--part", "4/3"], "1 <= I <= N");
}
