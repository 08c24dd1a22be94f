//! `render --part I/N` and `merge`: the parts of a render merge into the render itself (to f32
//! rounding) for every integrator that can be split, including vcm (whose radius schedule
//! follows the global pass index) and guided-pt with one saved cache; parts that do not belong
//! together are refused with the file and the field named.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lodestar(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lodestar"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cannot run lodestar")
}

fn ok(args: &[&str]) {
    let o = lodestar(args);
    assert!(
        o.status.success(),
        "lodestar {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The error message of a command that must fail.
fn fails(args: &[&str]) -> String {
    let o = lodestar(args);
    assert!(!o.status.success(), "lodestar {} succeeded", args.join(" "));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("lodestar-parts-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
    fn path(&self, name: &str) -> String {
        self.0.join(name).to_string_lossy().into_owned()
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The fog box at 20 x 20 (media, glass, an area light), written beside the test's outputs.
fn fog_scene(dir: &Dir) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("scenes/cornell-fog.toml"))
        .unwrap()
        .replace("resolution = [256, 256]", "resolution = [20, 20]");
    let path = dir.path("fog.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn read(path: &str) -> lodestar::film::Image {
    lodestar::film::Image::read_exr(Path::new(path)).unwrap().0
}

fn assert_same(a: &str, b: &str, what: &str) {
    let (a, b) = (read(a), read(b));
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (i, (x, y)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for c in 0..3 {
            let tol = 1e-5 * x[c].abs().max(y[c].abs()) + 1e-9;
            assert!(
                (x[c] - y[c]).abs() <= tol,
                "{what}: pixel {i} channel {c}: merged {} vs whole {}",
                x[c],
                y[c]
            );
        }
    }
}

/// Whole render of 7 passes against its 3 parts (2, 2 and 3 passes) merged in shuffled order.
fn whole_equals_merged(dir: &Dir, scene: &str, integrator: &str, extra: &[&str]) {
    let whole = dir.path(&format!("{integrator}-whole.exr"));
    let base = [
        "render",
        scene,
        "--integrator",
        integrator,
        "--spp",
        "7",
        "--seed",
        "11",
        "--quiet",
    ];
    let with = |more: &[&str]| -> Vec<String> {
        base.iter()
            .chain(extra)
            .chain(more)
            .map(|s| s.to_string())
            .collect()
    };
    let run = |args: Vec<String>| ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    run(with(&["-o", &whole, "--threads", "2"]));
    let parts: Vec<String> = (1..=3)
        .map(|i| dir.path(&format!("{integrator}-part{i}.exr")))
        .collect();
    for (i, p) in parts.iter().enumerate() {
        // Threads differ between parts (the image does not depend on them).
        let part = format!("{}/3", i + 1);
        let threads = (i % 2 + 1).to_string();
        run(with(&["--part", &part, "-o", p, "--threads", &threads]));
    }
    let merged = dir.path(&format!("{integrator}-merged.exr"));
    ok(&["merge", &parts[2], &parts[0], &parts[1], "-o", &merged]);
    assert_same(&merged, &whole, integrator);
}

#[test]
fn parts_merge_into_the_whole_render() {
    let dir = Dir::new("merge");
    let scene = fog_scene(&dir);
    for integrator in ["pt", "lt", "bdpt", "vcm", "bpm"] {
        whole_equals_merged(&dir, &scene, integrator, &[]);
    }
}

/// guided-pt: the cache is learned once and every part (and the whole render) loads it.
#[test]
fn guided_parts_with_one_saved_cache_merge_into_the_whole_render() {
    let dir = Dir::new("guided");
    let scene = fog_scene(&dir);
    let cache = dir.path("guides.bin");
    ok(&[
        "render",
        &scene,
        "--integrator",
        "guided-pt",
        "--spp",
        "6",
        "--save-guides",
        &cache,
        "--quiet",
        "-o",
        &dir.path("learn.exr"),
    ]);
    let load = format!("load_guides={cache}");
    whole_equals_merged(&dir, &scene, "guided-pt", &["-O", &load]);
    let err = fails(&[
        "render",
        &scene,
        "--integrator",
        "guided-pt",
        "--spp",
        "6",
        "--part",
        "1/2",
        "-o",
        &dir.path("x.exr"),
    ]);
    assert!(err.contains("same saved guide cache"), "{err}");
}

#[test]
fn parts_of_different_renders_are_refused() {
    let dir = Dir::new("refuse");
    let scene = fog_scene(&dir);
    let part = |name: &str, i: u32, extra: &[&str]| -> String {
        let out = dir.path(&format!("{name}.exr"));
        let p = format!("{i}/2");
        let seed = if extra.contains(&"--seed") {
            &[][..]
        } else {
            &["--seed", "1"][..]
        };
        let mut args = vec![
            "render", &scene, "--spp", "4", "--part", &p, "--quiet", "-o", &out,
        ];
        args.extend(seed);
        args.extend(extra);
        ok(&args);
        out
    };
    let (a1, a2) = (part("a1", 1, &[]), part("a2", 2, &[]));
    ok(&["merge", &a1, &a2, "-o", &dir.path("ok.exr")]);
    // Another seed, other settings, another integrator.
    let b2 = part("b2", 2, &["--seed", "2"]);
    let err = fails(&["merge", &a1, &b2, "-o", &dir.path("x.exr")]);
    assert!(err.contains("b2.exr") && err.contains("'seed'"), "{err}");
    let c2 = part("c2", 2, &["--max-depth", "3"]);
    let err = fails(&["merge", &a1, &c2, "-o", &dir.path("x.exr")]);
    assert!(
        err.contains("c2.exr") && err.contains("'settings'"),
        "{err}"
    );
    let d2 = part("d2", 2, &["--integrator", "bdpt"]);
    let err = fails(&["merge", &a1, &d2, "-o", &dir.path("x.exr")]);
    assert!(err.contains("'integrator'"), "{err}");
    // Another version of the scene file.
    let edited = dir.path("fog2.toml");
    let text = std::fs::read_to_string(&scene).unwrap() + "\n# edited\n";
    std::fs::write(&edited, text).unwrap();
    let e2 = dir.path("e2.exr");
    ok(&[
        "render", &edited, "--spp", "4", "--seed", "1", "--part", "2/2", "--quiet", "-o", &e2,
    ]);
    let err = fails(&["merge", &a1, &e2, "-o", &dir.path("x.exr")]);
    assert!(err.contains("'scene_hash'"), "{err}");
    // Missing and repeated slices, a different split, a whole render.
    let err = fails(&["merge", &a1, "-o", &dir.path("x.exr")]);
    assert!(err.contains("missing part 2/2"), "{err}");
    let err = fails(&["merge", &a1, &a1, &a2, "-o", &dir.path("x.exr")]);
    assert!(err.contains("part 1/2 is also in"), "{err}");
    let out3 = dir.path("t3.exr");
    ok(&[
        "render", &scene, "--spp", "4", "--seed", "1", "--part", "3/3", "--quiet", "-o", &out3,
    ]);
    let err = fails(&["merge", &a1, &a2, &out3, "-o", &dir.path("x.exr")]);
    assert!(err.contains("t3.exr") && err.contains("one of 2"), "{err}");
    let whole = dir.path("whole.exr");
    ok(&[
        "render", &scene, "--spp", "4", "--seed", "1", "--quiet", "-o", &whole,
    ]);
    let err = fails(&["merge", &a1, &whole, "-o", &dir.path("x.exr")]);
    assert!(
        err.contains("whole.exr") && err.contains("no 'part'"),
        "{err}"
    );
    assert!(!Path::new(&dir.path("x.exr")).exists());
}

#[test]
fn renders_that_cannot_be_split_say_why() {
    let dir = Dir::new("cannot");
    let out = dir.path("x.exr");
    for (args, expected) in [
        (
            vec!["--integrator", "pssmlt", "--spp", "4", "--part", "1/2"],
            "cannot be split",
        ),
        (
            vec!["--integrator", "mmlt", "--spp", "4", "--part", "1/2"],
            "cannot be split",
        ),
        (
            vec!["--spp", "4", "-O", "guiding=sdtree", "--part", "1/2"],
            "each part would learn its own tree",
        ),
        (vec!["--time", "1", "--part", "1/2"], "--part needs --spp"),
        (vec!["--spp", "4", "--part", "1/2", "--dbor"], "--dbor"),
        (vec!["--spp", "2", "--part", "1/3"], "leaves this part none"),
        (vec!["--spp", "4", "--part", "0/2"], "1 <= I <= N"),
        (vec!["--spp", "4", "--part", "3/2"], "1 <= I <= N"),
    ] {
        let mut all = vec!["render", "--quiet", "-o", &out];
        all.extend(&args);
        let err = fails(&all);
        assert!(err.contains(expected), "{args:?}: {err}");
    }
}
