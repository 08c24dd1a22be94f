//! The run-time-against-error harness end to end, through the `lodestar` binary: a bench on
//! the 16 x 16 test scene completes and writes a well-formed report (CSV and XHTML parsed
//! back, numbers checked against each other and against errors recomputed here from the
//! written images), and `render --snapshots` writes the images a shorter render would give.

use crate::util;

use lodestar::film::Image;
use lodestar::integrators::{self, IntegratorParams, Options};
use lodestar::render::Budget;
use lodestar::scene::loader;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const TINY: &str = "tests/data/tiny.toml";

struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("lodestar-bench-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
    fn s(&self, name: &str) -> String {
        self.0.join(name).display().to_string()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn run(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_lodestar"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cannot run lodestar");
    assert!(
        out.status.success(),
        "lodestar {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// A pt reference of the tiny scene (256 spp) written to `path`.
fn write_reference(path: &Path) {
    let scene =
        loader::load_file(Path::new(&format!("{}/{TINY}", env!("CARGO_MANIFEST_DIR")))).unwrap();
    let params = IntegratorParams {
        max_depth: scene.render.max_depth,
        options: Options::default(),
    };
    let r =
        integrators::render_named(&scene, "pt", &params, Budget::Spp(256), 1000, 2, false).unwrap();
    r.result.image.write_exr(path, &[]).unwrap();
}

/// MSE and relMSE over the crop [x0, x1) x [y0, y1), written out independently of
/// `lodestar::metrics`.
fn errors(a: &Image, r: &Image, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> (f64, f64) {
    let (mut se, mut rel, mut n) = (0.0, 0.0, 0.0);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * a.width + x) as usize;
            for c in 0..3 {
                let (v, t) = (a.pixels[i][c] as f64, r.pixels[i][c] as f64);
                se += (v - t) * (v - t);
                rel += (v - t) * (v - t) / (t * t + 0.01);
                n += 1.0;
            }
        }
    }
    (se / n, rel / n)
}

/// A CSV file as a header and rows of named fields.
fn read_csv(path: &Path) -> (Vec<String>, Vec<HashMap<String, String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), header.len(), "{path:?}: {l}");
            header
                .iter()
                .cloned()
                .zip(f.iter().map(|s| s.to_string()))
                .collect()
        })
        .collect();
    (header, rows)
}

fn num(row: &HashMap<String, String>, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = {:?} is not a number", row[key]))
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

/// Median, written out independently of `lodestar::metrics::median` (the oracle for the
/// report's median rows).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

#[test]
fn bench_writes_a_consistent_report() {
    let t = TempDir::new("report");
    let reference = t.s("reference.exr");
    write_reference(Path::new(&reference));
    let out_dir = t.0.join("out");
    let out = run(&[
        "bench",
        "--scene",
        TINY,
        "--integrators",
        "pt,bdpt",
        "--time",
        "0.15",
        "--reference",
        &reference,
        "--runs",
        "3",
        "--seed",
        "5",
        "--threads",
        "2",
        "--out",
        &out_dir.display().to_string(),
        "--quiet",
    ]);

    // ---- report.csv: 3 runs per integrator, then one median row each ----
    let (header, rows) = read_csv(&out_dir.join("report.csv"));
    assert_eq!(
        header,
        [
            "scene",
            "integrator",
            "run",
            "seed",
            "seconds",
            "spp",
            "passes",
            "mse",
            "rmse",
            "rel_mse",
            "speedup",
            "variance",
            "var_speedup"
        ]
    );
    assert_eq!(rows.len(), 8);
    let runs_of = |name: &str| -> Vec<&HashMap<String, String>> {
        rows.iter()
            .filter(|r| r["integrator"] == name && r["run"] != "median")
            .collect()
    };
    let median_of = |name: &str| {
        rows.iter()
            .find(|r| r["integrator"] == name && r["run"] == "median")
            .unwrap()
    };
    let (pt, bdpt) = (runs_of("pt"), runs_of("bdpt"));
    assert_eq!((pt.len(), bdpt.len()), (3, 3));
    for (k, (p, b)) in pt.iter().zip(&bdpt).enumerate() {
        for r in [p, b] {
            assert_eq!(r["scene"], TINY);
            assert_eq!(r["run"], k.to_string());
            assert_eq!(r["seed"], (5 + k).to_string(), "seeds seed..seed+runs");
            // Every render spent the budget, in whole passes.
            assert!(num(r, "seconds") >= 0.15, "{r:?}");
            assert!(num(r, "spp") >= 1.0 && num(r, "spp").fract() == 0.0);
            assert!(close(num(r, "rmse"), num(r, "mse").sqrt(), 1e-8));
            assert!(num(r, "mse") > 0.0 && num(r, "rel_mse") > 0.0);
        }
        assert_eq!(num(p, "speedup"), 1.0);
        assert!(close(
            num(b, "speedup"),
            num(p, "mse") / num(b, "mse"),
            1e-8
        ));
    }
    for (name, runs) in [("pt", &pt), ("bdpt", &bdpt)] {
        let m = median_of(name);
        for key in ["seconds", "spp", "mse", "rmse", "rel_mse"] {
            let expect = median(runs.iter().map(|r| num(r, key)).collect());
            assert!(close(num(m, key), expect, 1e-8), "{name} {key}");
        }
    }
    let speedup = num(median_of("pt"), "mse") / num(median_of("bdpt"), "mse");
    assert!(close(num(median_of("bdpt"), "speedup"), speedup, 1e-8));
    // The seed-pair variance (its formula is unit-tested in bench::report): positive, the
    // same on every row of an integrator, within the bound the triangle inequality gives,
    // and the variance speed-up is pt's over bdpt's. |I_i - I_j|² <= 2 (|I_i - R|² +
    // |I_j - R|²), so the mean over pairs of MSE(I_i, I_j) / 2 is at most twice the runs'
    // mean MSE against any reference R; the bound holds for every outcome, so it cannot fail
    // by chance. (An earlier check, "below the median MSE", failed in a full test run: the
    // tiny scene's fireflies enter the pair variance and the MSEs alike; in one of six runs
    // measured afterwards pt's pair variance was 1.6x its median MSE.)
    for (name, runs) in [("pt", &pt), ("bdpt", &bdpt)] {
        let v = num(median_of(name), "variance");
        assert!(v > 0.0, "{name}: {v}");
        for r in runs.iter() {
            assert_eq!(num(r, "variance"), v);
        }
        let mean_mse = runs.iter().map(|r| num(r, "mse")).sum::<f64>() / runs.len() as f64;
        assert!(
            v <= 2.0 * mean_mse * (1.0 + 1e-6),
            "{name}: variance {v} above twice the mean MSE {mean_mse}"
        );
    }
    let var_speedup = num(median_of("pt"), "variance") / num(median_of("bdpt"), "variance");
    assert!(close(
        num(median_of("bdpt"), "var_speedup"),
        var_speedup,
        1e-8
    ));

    // ---- the images of the first run carry the errors of run 0 ----
    let (reference_img, _) = Image::read_exr(Path::new(&reference)).unwrap();
    for (name, runs) in [("pt", &pt), ("bdpt", &bdpt)] {
        let (img, meta) = Image::read_exr(&out_dir.join(format!("images/{name}.exr"))).unwrap();
        let (mse, rel) = errors(&img, &reference_img, (0, 0, 16, 16));
        assert!(close(num(runs[0], "mse"), mse, 1e-6), "{name}: {mse}");
        assert!(close(num(runs[0], "rel_mse"), rel, 1e-6), "{name}: {rel}");
        let spp = meta.iter().find(|(k, _)| k == "spp").unwrap();
        assert_eq!(spp.1, runs[0]["spp"]);
    }

    // ---- curves.csv: increasing in time and passes, ending at the report's numbers ----
    let (header, points) = read_csv(&out_dir.join("curves.csv"));
    assert_eq!(header[..4], ["scene", "integrator", "run", "seed"]);
    for (name, runs) in [("pt", &pt), ("bdpt", &bdpt)] {
        for (k, r) in runs.iter().enumerate() {
            let curve: Vec<_> = points
                .iter()
                .filter(|q| q["integrator"] == name && q["run"] == k.to_string())
                .collect();
            assert!(!curve.is_empty());
            for w in curve.windows(2) {
                assert!(num(w[0], "seconds") <= num(w[1], "seconds"));
                assert!(num(w[0], "passes") < num(w[1], "passes"));
            }
            let last = curve.last().unwrap();
            for key in ["seconds", "spp", "mse", "rel_mse"] {
                assert_eq!(last[key], r[key], "{name} run {k} {key}");
            }
        }
    }

    // ---- the printed table: header plus one median row per integrator ----
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    for (line, name) in lines[1..].iter().zip(["pt", "bdpt"]) {
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(&f[..5], [TINY, name, "median", "of", "3"], "{line}");
        let mse: f64 = f[8].parse().unwrap();
        assert!(close(mse, num(median_of(name), "mse"), 1e-4), "{line}");
    }

    // ---- index.html: well-formed, table matches the CSV, every link resolves ----
    let html = std::fs::read_to_string(out_dir.join("index.html")).unwrap();
    // The page starts with <!DOCTYPE html>, which roxmltree accepts when asked to.
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(&html, options)
        .expect("index.html is well-formed XHTML");
    let summary = doc
        .descendants()
        .find(|n| n.has_tag_name("table") && n.attribute("class") == Some("summary"))
        .expect("summary table");
    let rows_html: Vec<Vec<String>> = summary
        .children()
        .filter(|n| n.has_tag_name("tr"))
        .map(|tr| {
            tr.children()
                .filter(|c| c.is_element())
                .map(|c| c.text().unwrap_or("").to_string())
                .collect()
        })
        .collect();
    assert_eq!(rows_html.len(), 3);
    assert_eq!(rows_html[0][1], "integrator");
    for (cells, name) in rows_html[1..].iter().zip(["pt", "bdpt"]) {
        assert_eq!(cells[1], name);
        assert_eq!(cells[2], "median of 3");
        let mse: f64 = cells[6].parse().unwrap();
        assert!(close(mse, num(median_of(name), "mse"), 1e-4));
        let speedup: f64 = cells[9].parse().unwrap();
        assert!((speedup - num(median_of(name), "speedup")).abs() < 1e-3);
        let variance: f64 = cells[10].parse().unwrap();
        assert!(close(variance, num(median_of(name), "variance"), 1e-4));
    }
    let runs_table = doc
        .descendants()
        .find(|n| n.has_tag_name("table") && n.attribute("class") == Some("runs"))
        .expect("per-run table");
    assert_eq!(
        runs_table
            .children()
            .filter(|n| n.has_tag_name("tr"))
            .count(),
        7
    );
    let mut links: Vec<&str> = doc
        .descendants()
        .filter_map(|n| n.attribute("src").or(n.attribute("href")))
        .collect();
    links.sort();
    links.dedup();
    for expected in [
        "curves.svg",
        "report.csv",
        "curves.csv",
        "images/reference.png",
        "images/pt.png",
        "images/pt.error.png",
        "images/bdpt.exr",
    ] {
        assert!(
            links.contains(&expected),
            "{expected} not linked: {links:?}"
        );
    }
    for link in &links {
        assert!(
            !link.contains(':') && !link.starts_with('/'),
            "not relative: {link}"
        );
        let file = out_dir.join(link);
        assert!(file.is_file(), "{link} does not exist");
        if link.ends_with(".png") {
            assert!(
                std::fs::read(&file)
                    .unwrap()
                    .starts_with(b"\x89PNG\r\n\x1a\n")
            );
        }
    }

    // ---- curves.svg: parses, one legend entry and one line per integrator ----
    let svg = std::fs::read_to_string(out_dir.join("curves.svg")).unwrap();
    let svg = roxmltree::Document::parse(&svg).expect("curves.svg is well-formed");
    let texts: Vec<String> = svg
        .descendants()
        .filter(|n| n.has_tag_name("text"))
        .map(|n| n.text().unwrap_or("").trim().to_string())
        .collect();
    for label in ["pt", "bdpt", "seconds", "MSE"] {
        assert!(
            texts.iter().any(|t| t == label),
            "{label} missing: {texts:?}"
        );
    }
    let lines = svg
        .descendants()
        .filter(|n| n.has_tag_name("polyline"))
        .count();
    assert!(lines >= 2, "{lines} polylines");

    // No temporary files left behind.
    for entry in std::fs::read_dir(&out_dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.starts_with('.'), "{name}");
    }
}

/// `--crop` restricts the errors: recomputed here over the same window.
#[test]
fn bench_crop_applies_to_the_errors() {
    let t = TempDir::new("crop");
    let reference = t.s("reference.exr");
    write_reference(Path::new(&reference));
    let out_dir = t.s("out");
    run(&[
        "bench",
        "--scene",
        TINY,
        "--integrators",
        "lt",
        "--time",
        "0.05",
        "--reference",
        &reference,
        "--crop",
        "2,3,10,16",
        "--out",
        &out_dir,
        "--quiet",
    ]);
    let (_, rows) = read_csv(&Path::new(&out_dir).join("report.csv"));
    let (img, _) = Image::read_exr(&Path::new(&out_dir).join("images/lt.exr")).unwrap();
    let (reference_img, _) = Image::read_exr(Path::new(&reference)).unwrap();
    let (mse, rel) = errors(&img, &reference_img, (2, 3, 10, 16));
    let (full, _) = errors(&img, &reference_img, (0, 0, 16, 16));
    assert!(
        close(num(&rows[0], "mse"), mse, 1e-6),
        "{} vs {mse}",
        rows[0]["mse"]
    );
    assert!(close(num(&rows[0], "rel_mse"), rel, 1e-6));
    assert!(
        !close(mse, full, 1e-3),
        "the crop must make a difference here"
    );
}

/// `render --snapshots` writes `out.tNNNN.exr` (and PNGs) beside the outputs, each the image
/// an spp-budget render of its pass count gives with the same seed.
#[test]
fn render_snapshots_are_shorter_renders() {
    let t = TempDir::new("snapshots");
    let (exr, png) = (t.s("x.exr"), t.s("x.png"));
    run(&[
        "render",
        TINY,
        "--time",
        "0.3",
        "--snapshots",
        "0.1,0.05",
        "--seed",
        "9",
        "-o",
        &exr,
        "--png",
        &png,
        "--quiet",
    ]);
    let mut names: Vec<String> = std::fs::read_dir(&t.0)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "x.exr",
            "x.png",
            "x.t0000.05.exr",
            "x.t0000.05.png",
            "x.t0000.1.exr",
            "x.t0000.1.png"
        ]
    );
    let scene = loader::load_file(Path::new(TINY)).unwrap();
    let get = |meta: &[(String, String)], k: &str| -> f64 {
        meta.iter()
            .find(|(key, _)| key == k)
            .unwrap()
            .1
            .parse()
            .unwrap()
    };
    let (_, final_meta) = Image::read_exr(Path::new(&exr)).unwrap();
    let mut last_spp = 0.0;
    for (file, time) in [("x.t0000.05.exr", 0.05), ("x.t0000.1.exr", 0.1)] {
        let (img, meta) = Image::read_exr(&t.0.join(file)).unwrap();
        assert_eq!(get(&meta, "snapshot_time"), time);
        assert!(get(&meta, "seconds") >= time - 5e-4, "{meta:?}");
        let spp = get(&meta, "spp");
        assert!(spp >= last_spp && spp <= get(&final_meta, "spp"));
        last_spp = spp;
        let shorter = util::render(&scene, "pt", 4, &[], spp as u64, 9, 1);
        assert_eq!(img, shorter.image, "{file}");
    }
}
