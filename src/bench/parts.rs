//! A bench spread over machines: `lodestar bench ... --part I/N` renders the I-th of N shares
//! of the bench's list of runs (integrator x seed) and writes each run into `OUT/runs/` (its
//! final image as an EXR whose header carries the run: seconds, spp, passes, the error and the
//! error-against-time curve, and the bench it belongs to); `lodestar bench ... --from-parts
//! DIR...` (the same bench arguments) reads the runs back from the parts' output directories,
//! checks that they belong to this bench and that every run is there exactly once, and writes
//! the report, plot, images and page as a single-machine bench would.
//!
//! The list is the order a single machine renders in (seeds outer, integrators inner). Part
//! shares are dealt round-robin over that list with the integrators rotated by one place per
//! seed, so parts get equally many runs (to one) and an integrator's seeds land on different
//! parts: one slow machine does not hold all of one integrator's runs.
//! Each run is an independent render, so a report from parts differs from a one-machine
//! report only in the measured times (and hence spp and error at the budget), never in which
//! runs it holds.

use super::run::{CurvePoint, Job, Rendered, Run, jobs};
use super::{BenchConfig, Prepared};
use crate::error::{Error, Result};
use crate::film::Image;
use crate::metrics::Comparison;
use crate::parts::{Part, fingerprint};
use glam::DVec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The runs of part `part`: dealt round-robin over [`jobs`] with the integrators rotated by
/// one place per seed (the run of integrator `i` with the `r`-th seed has slot
/// `r n + (i + r) mod n` for `n` integrators; part `I` of `N` takes the slots `I - 1 mod N`).
pub fn share(c: &BenchConfig, part: Part) -> Vec<Job> {
    let n = c.integrators.len() as u64;
    jobs(c)
        .into_iter()
        .filter(|job| {
            let r = job.seed - c.seed;
            let slot = r * n + (job.integrator as u64 + r) % n;
            slot % part.count == part.index - 1
        })
        .collect()
}

/// The header fields that tie a run to its bench, from the configuration.
fn identity(p: &Prepared) -> Result<Vec<(&'static str, String)>> {
    let c = &p.config;
    let bytes = |path: &Path| {
        std::fs::read(path).map_err(|e| Error::new(format!("{}: cannot read: {e}", path.display())))
    };
    Ok(vec![
        ("bench_scene_hash", fingerprint(&bytes(&c.scene)?)),
        ("bench_reference_hash", fingerprint(&bytes(&c.reference)?)),
        ("bench_integrators", c.integrators.join(",")),
        (
            "bench_defines",
            c.defines
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(","),
        ),
        ("bench_time", c.seconds.to_string()),
        ("bench_runs", c.runs.to_string()),
        ("bench_seed", c.seed.to_string()),
        ("bench_threads", c.threads.to_string()),
        ("bench_max_depth", p.max_depth.to_string()),
        (
            "bench_crop",
            c.crop.map_or("none".to_string(), |k| {
                format!("{},{},{},{}", k.x0, k.y0, k.x1, k.y1)
            }),
        ),
    ])
}

fn comparison_text(e: &Comparison) -> String {
    let v = |d: DVec3| format!("{}/{}/{}", d.x, d.y, d.z);
    format!(
        "{} {} {} {} {}",
        e.mse,
        e.rmse,
        e.rel_mse,
        v(e.mean_a),
        v(e.mean_b)
    )
}

fn parse_comparison(words: &[&str]) -> Option<Comparison> {
    let v = |w: &str| -> Option<DVec3> {
        let n: Vec<f64> = w
            .split('/')
            .map(|x| x.parse().ok())
            .collect::<Option<_>>()?;
        (n.len() == 3).then(|| DVec3::new(n[0], n[1], n[2]))
    };
    match words {
        [mse, rmse, rel, a, b] => Some(Comparison {
            mse: mse.parse().ok()?,
            rmse: rmse.parse().ok()?,
            rel_mse: rel.parse().ok()?,
            mean_a: v(a)?,
            mean_b: v(b)?,
        }),
        _ => None,
    }
}

/// Prefix of the EXR header fields that carry a run's end-of-render statistics.
const STAT_PREFIX: &str = "bench_stat:";

/// File of one run inside a part's output directory.
fn run_file(out: &Path, job: Job, c: &BenchConfig) -> PathBuf {
    out.join("runs").join(format!(
        "{}.seed{}.exr",
        super::file_stem(&c.integrators[job.integrator]),
        job.seed
    ))
}

/// Render part `part` of the bench and write its runs; returns how many it rendered.
pub fn run_part(p: &Prepared, part: Part) -> Result<usize> {
    let c = &p.config;
    let identity = identity(p)?;
    let dir = c.out.join("runs");
    std::fs::create_dir_all(&dir)
        .map_err(|e| Error::new(format!("--out {}: cannot create: {e}", dir.display())))?;
    let mine = share(c, part);
    for &job in &mine {
        let r = super::run::render_job(p, job)?;
        let mut meta: Vec<(String, String)> = super::run::metadata(p, &r.name, &r.settings, &r.run);
        meta.extend(identity.iter().map(|(k, v)| (k.to_string(), v.clone())));
        meta.push(("bench_part".into(), part.to_string()));
        meta.push(("bench_integrator_index".into(), job.integrator.to_string()));
        meta.push(("bench_error".into(), comparison_text(&r.run.error)));
        let curve: Vec<String> = r
            .run
            .curve
            .iter()
            .map(|q| {
                format!(
                    "{} {} {} {}",
                    q.seconds,
                    q.spp,
                    q.passes,
                    comparison_text(&q.error)
                )
            })
            .collect();
        meta.push(("bench_curve".into(), curve.join(";")));
        meta.extend(
            r.run
                .stats
                .iter()
                .map(|(k, v)| (format!("{STAT_PREFIX}{k}"), v.clone())),
        );
        r.image.write_exr(&run_file(&c.out, job, c), &meta)?;
    }
    Ok(mine.len())
}

/// One run read back from a part.
fn read_run(path: &Path, identity: &[(&str, String)], c: &BenchConfig) -> Result<(Job, Rendered)> {
    let (image, meta) = Image::read_exr(path)?;
    let at = |msg: String| Error::new(format!("{}: {msg}", path.display()));
    let get = |key: &str| -> Result<&str> {
        meta.iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
            .ok_or_else(|| {
                at(format!(
                    "no '{key}' field: not a run written by `bench --part`"
                ))
            })
    };
    for (key, expected) in identity {
        let found = get(key)?;
        if found != expected {
            return Err(at(format!(
                "field '{key}' is '{found}', but this bench has '{expected}' (a run of another bench)"
            )));
        }
    }
    let number = |key: &str| -> Result<u64> {
        get(key)?
            .parse()
            .map_err(|_| at(format!("field '{key}' is not an integer")))
    };
    let integrator = number("bench_integrator_index")? as usize;
    let seed = number("seed")?;
    let name = get("integrator")?.to_string();
    if c.integrators.get(integrator) != Some(&name) {
        return Err(at(format!(
            "field 'integrator' is '{name}', not entry {integrator} of --integrators"
        )));
    }
    let bad = |key: &str| at(format!("field '{key}' cannot be read"));
    let error = parse_comparison(&get("bench_error")?.split(' ').collect::<Vec<_>>())
        .ok_or_else(|| bad("bench_error"))?;
    let mut curve = Vec::new();
    for point in get("bench_curve")?.split(';').filter(|s| !s.is_empty()) {
        let w: Vec<&str> = point.split(' ').collect();
        let (Some(seconds), Some(spp), Some(passes), Some(error)) = (
            w.first().and_then(|x| x.parse().ok()),
            w.get(1).and_then(|x| x.parse().ok()),
            w.get(2).and_then(|x| x.parse().ok()),
            w.get(3..).and_then(parse_comparison),
        ) else {
            return Err(bad("bench_curve"));
        };
        curve.push(CurvePoint {
            seconds,
            spp,
            passes,
            error,
        });
    }
    let run = Run {
        seed,
        seconds: get("seconds")?.parse().map_err(|_| bad("seconds"))?,
        spp: number("spp")?,
        passes: number("passes")?,
        error,
        curve,
        stats: meta
            .iter()
            .filter_map(|(k, v)| Some((k.strip_prefix(STAT_PREFIX)?.to_string(), v.clone())))
            .collect(),
    };
    let job = Job { integrator, seed };
    Ok((
        job,
        Rendered {
            index: integrator,
            run,
            image,
            name,
            settings: get("settings")?.to_string(),
        },
    ))
}

/// Every run of the bench, read from the parts' output directories `dirs` (each `OUT` of a
/// `--part` bench, or its `runs/` directory).
pub fn collect(p: &Prepared, dirs: &[PathBuf]) -> Result<Vec<Rendered>> {
    let c = &p.config;
    let identity = identity(p)?;
    let mut found: HashMap<Job, (PathBuf, Rendered)> = HashMap::new();
    for dir in dirs {
        let runs = if dir.join("runs").is_dir() {
            dir.join("runs")
        } else {
            dir.clone()
        };
        let entries = std::fs::read_dir(&runs).map_err(|e| {
            Error::new(format!("--from-parts {}: cannot read: {e}", runs.display()))
        })?;
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|f| f.extension().is_some_and(|x| x == "exr"))
            .collect();
        files.sort();
        for f in files {
            let (job, r) = read_run(&f, &identity, c)?;
            if let Some((other, _)) = found.get(&job) {
                return Err(Error::new(format!(
                    "{}: run {} seed {} is also in {}",
                    f.display(),
                    c.integrators[job.integrator],
                    job.seed,
                    other.display()
                )));
            }
            found.insert(job, (f, r));
        }
    }
    let mut out = Vec::new();
    for job in jobs(c) {
        match found.remove(&job) {
            Some((_, r)) => out.push(r),
            None => {
                return Err(Error::new(format!(
                    "--from-parts: run {} seed {} is missing (in none of {})",
                    c.integrators[job.integrator],
                    job.seed,
                    dirs.iter()
                        .map(|d| d.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_cover_every_job_once() {
        let c = BenchConfig {
            scene: PathBuf::new(),
            defines: Vec::new(),
            integrators: vec!["pt".into(), "bdpt".into(), "vcm".into()],
            seconds: 1.0,
            reference: PathBuf::new(),
            runs: 5,
            seed: 3,
            out: PathBuf::new(),
            threads: 1,
            max_depth: None,
            crop: None,
            exposure: 0.0,
            verbose: false,
            splat_film: false,
        };
        let all = jobs(&c);
        assert_eq!(all.len(), 15);
        assert_eq!(
            all[0],
            Job {
                integrator: 0,
                seed: 3
            }
        );
        assert_eq!(
            all[4],
            Job {
                integrator: 1,
                seed: 4
            }
        );
        for n in 1..=16 {
            let mut seen: Vec<Job> = (1..=n)
                .flat_map(|i| share(&c, Part { index: i, count: n }))
                .collect();
            assert_eq!(seen.len(), all.len(), "{n} parts");
            seen.sort_by_key(|j| (j.seed, j.integrator));
            let mut sorted = all.clone();
            sorted.sort_by_key(|j| (j.seed, j.integrator));
            assert_eq!(seen, sorted);
            // Balanced to one run.
            let sizes: Vec<usize> = (1..=n)
                .map(|i| share(&c, Part { index: i, count: n }).len())
                .collect();
            assert!(
                sizes.iter().max().unwrap() - sizes.iter().min().unwrap() <= 1,
                "{sizes:?}"
            );
        }
        // As many parts as integrators: each integrator's five seeds over three parts.
        for i in 0..3 {
            let parts: std::collections::HashSet<u64> = (1..=3)
                .filter(|&p| {
                    share(&c, Part { index: p, count: 3 })
                        .iter()
                        .any(|j| j.integrator == i)
                })
                .collect();
            assert_eq!(parts.len(), 3, "integrator {i}");
        }
    }

    #[test]
    fn comparisons_round_trip_exactly() {
        let e = Comparison {
            mse: 1.0 / 3.0,
            rmse: 0.1,
            rel_mse: 1e-300,
            mean_a: DVec3::new(0.1, 0.2, std::f64::consts::PI),
            mean_b: DVec3::new(1e10, -0.0, 5.0),
        };
        let t = comparison_text(&e);
        let back = parse_comparison(&t.split(' ').collect::<Vec<_>>()).unwrap();
        assert_eq!(comparison_text(&back), t);
        assert_eq!(back.mse, e.mse);
        assert_eq!(back.mean_a, e.mean_a);
    }
}
