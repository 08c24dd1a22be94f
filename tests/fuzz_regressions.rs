//! Inputs the scene and mesh fuzzer (`examples/fuzz_scenes.rs`) found to crash, hang or be wrongly
//! accepted, kept under `tests/data/fuzz/`: each must now load or fail with a clean one-line
//! error, without a panic. Plus a short deterministic run of the fuzzer itself.

use crate::fuzz_support;

use fuzz_support::{Kind, Outcome, XorShift, corpus, mutate, run_input};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn fuzz_dir() -> PathBuf {
    fuzz_support::repo_root().join("tests/data/fuzz")
}

/// Run one input with panics caught; a panic or a finding fails with the file named.
fn check(kind: Kind, path: &Path, dir: &Path, emissive: bool) -> Outcome {
    match std::panic::catch_unwind(|| run_input(kind, path, dir, emissive)) {
        Ok(Ok(outcome)) => outcome,
        Ok(Err(finding)) => panic!("{}: {finding}", path.display()),
        Err(_) => panic!("{}: the loader panicked", path.display()),
    }
}

/// Every kept regression input loads or is rejected cleanly (scenes against
/// `tests/data/fuzz/`, meshes through both wrapper scenes). Some inputs must be rejected;
/// `expected_errors` names the message each must contain.
#[test]
fn regression_inputs_fail_cleanly() {
    let dir = fuzz_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("tests/data/fuzz exists")
        .map(|e| e.expect("entry").path())
        .collect();
    files.sort();
    let scratch = std::env::temp_dir().join(format!("lodestar-fuzz-reg-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).expect("scratch dir");
    let mut n = 0;
    for f in &files {
        let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("");
        let outcomes = match Kind::from_ext(ext) {
            Some(k) if k.is_mesh() => {
                vec![check(k, f, &scratch, false), check(k, f, &scratch, true)]
            }
            Some(k) => vec![check(k, f, &dir, false)],
            None => continue,
        };
        n += 1;
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        if let Some((_, want)) = expected_errors().iter().find(|(file, _)| *file == name) {
            for o in &outcomes {
                match o {
                    Outcome::Rejected(msg) => assert!(
                        msg.contains(want),
                        "{name}: expected an error containing {want:?}, got {msg:?}"
                    ),
                    Outcome::Loaded => panic!("{name}: expected the error {want:?}, it loaded"),
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    assert!(n > 0, "no regression inputs found in {}", dir.display());
}

/// The message each kept input must be rejected with (file name, part of the message).
/// Inputs not listed here must load or fail cleanly, nothing more: the fuzzer found them
/// crashing with a direction or an axis the loader now normalises whatever its magnitude.
fn expected_errors() -> Vec<(&'static str, &'static str)> {
    let bounds = "every point of a shape must lie within +-1e12 per axis";
    vec![
        // Found by the fuzzer: BVH construction (obvhs) indexed out of bounds or never
        // finished on vertices or extents that overflow f32 (1e30 edges, 1e38 translations).
        ("huge-quad-edge-bvh-panic.toml", bounds),
        ("huge-translate-bvh-hang.toml", bounds),
        ("huge-origin-infinite-bounds.toml", bounds),
        ("huge-vertex-bvh-panic.obj", bounds),
        ("huge-vertex-bvh-panic-2.obj", bounds),
        // Found by the fuzzer (an allocation failure at 8.6M triangles under a 4 GB limit).
        (
            "too-many-triangles.toml",
            "at most 16777216 (2^24) are supported",
        ),
        (
            "huge-heightfield-grid.toml",
            "'grid' = [4096, 4096] makes 33554432 triangles",
        ),
        // Absurd work and values, from reading the loader.
        ("huge-resolution.toml", "at most 2^28 pixels"),
        (
            "tiny-scale.toml",
            "'scale' must be finite with every |component| in [1e-9, 1e9]",
        ),
        (
            "tiny-look-at-distance.toml",
            "'look_at' must differ from 'position'",
        ),
        ("infinite-light-power.toml", "the light's power overflows"),
        // Found by the fuzzer: messages quoting a newline were two lines; now escaped.
        ("newline-in-mesh-name.toml", "cannot load mesh"),
        ("newline-in-xml-error.xml", "not well-formed XML"),
    ]
}

/// A few seconds of the fuzzer, from a fixed seed, in-process: no input may panic or be
/// wrongly accepted. Deterministic (the same inputs every run); the long runs are
/// `cargo run --release --example fuzz_scenes -- SECONDS SEED`.
#[test]
fn fuzz_smoke() {
    let seeds: Vec<(Kind, PathBuf, Vec<u8>)> = corpus()
        .into_iter()
        // The two large meshes take most of the time; the small ones exercise the same code.
        .filter(|(_, p)| std::fs::metadata(p).is_ok_and(|m| m.len() < 100_000))
        .map(|(k, p)| {
            let b = std::fs::read(&p).expect("read");
            (k, p, b)
        })
        .collect();
    let scratch = std::env::temp_dir().join(format!("lodestar-fuzz-smoke-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).expect("scratch dir");
    let mut rng = XorShift::new(2024);
    let start = Instant::now();
    let (mut loaded, mut rejected) = (0, 0);
    // Per kind (Kind::ALL order): inputs loaded and rejected.
    let mut per_kind = [[0u32; 2]; 4];
    for i in 0..400 {
        let (kind, src, bytes) = &seeds[rng.below(seeds.len())];
        let donor = &seeds[rng.below(seeds.len())].2;
        let input = mutate(&mut rng, bytes, donor);
        let path = scratch.join(format!("input.{}", kind.ext()));
        std::fs::write(&path, &input).expect("write");
        let dir = if kind.is_mesh() {
            scratch.clone()
        } else {
            src.parent().unwrap().to_path_buf()
        };
        let k = Kind::ALL.iter().position(|k| k == kind).expect("a kind");
        match std::panic::catch_unwind(|| run_input(*kind, &path, &dir, i % 2 == 0)) {
            Ok(Ok(Outcome::Loaded)) => {
                loaded += 1;
                per_kind[k][0] += 1;
            }
            Ok(Ok(Outcome::Rejected(_))) => {
                rejected += 1;
                per_kind[k][1] += 1;
            }
            Ok(Err(finding)) => panic!(
                "input {i} (from {}): {finding}\n{}",
                src.display(),
                String::from_utf8_lossy(&input)
            ),
            Err(_) => panic!(
                "input {i} (from {}) panicked:\n{}",
                src.display(),
                String::from_utf8_lossy(&input)
            ),
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    // The mutator must produce inputs that load and inputs that are rejected, of every kind
    // of file, or the smoke run tests nothing.
    assert!(
        loaded > 10 && rejected > 10,
        "loaded {loaded}, rejected {rejected}"
    );
    for (kind, [l, r]) in Kind::ALL.iter().zip(per_kind) {
        assert!(l > 0 && r > 0, "{kind:?}: {l} loaded, {r} rejected");
    }
    eprintln!(
        "fuzz smoke: 400 inputs in {:.1} s ({loaded} loaded, {rejected} rejected; per kind \
         (toml, xml, obj, ply) loaded / rejected {per_kind:?})",
        start.elapsed().as_secs_f64()
    );
}
