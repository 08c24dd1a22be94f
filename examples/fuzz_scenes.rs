//! Fuzz the scene loaders (TOML and Mitsuba XML) and the mesh readers (OBJ and PLY).
//!
//! ```sh
//! cargo run --release --example fuzz_scenes -- [SECONDS] [SEED] [OUT_DIR] [TIMEOUT_SECONDS]
//! ```
//!
//! Mutates the shipped scenes (`scenes/*.toml`, `tests/data/*.toml`, `scenes/mitsuba/*.xml`)
//! and meshes (`scenes/meshes/*.obj`, `tests/data/meshes/*.{obj,ply}`) with a deterministic
//! xorshift mutator (`tests/fuzz_support`): absurd numbers (1e9, -1, NaN, inf, 0, 1e308, ...),
//! bit flips, absurd binary values (binary PLY bodies), deleted, duplicated and swapped lines,
//! deleted, repeated and moved XML tags, splices, junk tokens of each format (XML elements,
//! references, defaults; PLY header lines) and truncation. Inputs are drawn by kind: TOML and
//! XML scenes 3 : 3, OBJ and PLY meshes 1 : 2. Each input runs
//! in a worker process (this binary with `--worker`) so that an abort, a stack overflow or an
//! allocation failure is caught as well as a panic; the parent restarts the worker after one.
//! An input that does not finish within the timeout is a hang. Every failing input is written
//! to `OUT_DIR/crashes` (at most 3 per distinct failure) with a `.txt` beside it saying what
//! happened. Run it under a memory limit (`ulimit -v`) so that absurd allocations fail.
//!
//! With `FUZZ_RENDER=1` in the environment every accepted scene is also rendered by every
//! registered integrator (1 spp, 6 x 6 pixels, `--check`'s validation on) and must give a
//! finite image without a violation.
//!
//! Exit status 1 when anything failed.

#[path = "../tests/fuzz_support/mod.rs"]
mod fuzz_support;

use fuzz_support::{Kind, Outcome, XorShift, corpus, mutate, run_input};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("--worker") {
        worker(Path::new(&args[2]));
        return;
    }
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or(default.to_string());
    let seconds: f64 = arg(1, "60").parse().expect("SECONDS must be a number");
    let seed: u64 = arg(2, "1").parse().expect("SEED must be an integer");
    let out = PathBuf::from(arg(3, "fuzz-out"));
    let timeout: f64 = arg(4, "20")
        .parse()
        .expect("TIMEOUT_SECONDS must be a number");
    std::process::exit(fuzz(seconds, seed, &out, Duration::from_secs_f64(timeout)));
}

/// The worker: reads `KIND PATH DIR EMISSIVE` lines, answers one line per input.
fn worker(scratch: &Path) {
    std::panic::set_hook(Box::new(|info| {
        let loc = info
            .location()
            .map_or("?".to_string(), |l| format!("{}:{}", l.file(), l.line()));
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        // The parent reads the panic from stderr, one line.
        eprintln!("PANIC at {loc}: {}", msg.replace('\n', " "));
    }));
    let stdin = std::io::stdin();
    let mut stdout = std::io::stdout();
    for line in stdin.lock().lines() {
        let line = line.expect("stdin");
        let f: Vec<&str> = line.splitn(4, '\t').collect();
        let kind = Kind::from_ext(f[0]).expect("the parent sends a known kind");
        let path = PathBuf::from(f[1]);
        let dir = if kind.is_mesh() {
            scratch.to_path_buf()
        } else {
            PathBuf::from(f[2])
        };
        let emissive = f[3] == "1";
        let r = std::panic::catch_unwind(|| run_input(kind, &path, &dir, emissive));
        let reply = match r {
            Ok(Ok(Outcome::Loaded)) => "ok".to_string(),
            Ok(Ok(Outcome::Rejected(_))) => "err".to_string(),
            Ok(Err(finding)) => format!("bad\t{}", finding.replace(['\n', '\t'], " ")),
            Err(_) => "panic".to_string(),
        };
        writeln!(stdout, "{reply}").expect("stdout");
        stdout.flush().expect("stdout");
    }
}

struct Worker {
    child: Child,
    stdin: ChildStdin,
    replies: Receiver<String>,
    panics: Receiver<String>,
}

fn spawn_worker(scratch: &Path) -> Worker {
    let mut child = Command::new(std::env::current_exe().expect("current exe"))
        .arg("--worker")
        .arg(scratch)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn worker");
    let stdin = child.stdin.take().expect("stdin");
    let (tx, replies) = channel();
    let stdout = child.stdout.take().expect("stdout");
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let (ptx, panics) = channel();
    let stderr = child.stderr.take().expect("stderr");
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if ptx.send(line).is_err() {
                break;
            }
        }
    });
    Worker {
        child,
        stdin,
        replies,
        panics,
    }
}

fn fuzz(seconds: f64, seed: u64, out: &Path, timeout: Duration) -> i32 {
    let crashes = out.join("crashes");
    let scratch = out.join("scratch");
    std::fs::create_dir_all(&crashes).expect("create crash dir");
    std::fs::create_dir_all(&scratch).expect("create scratch dir");
    let seeds: Vec<(Kind, PathBuf, Vec<u8>)> = corpus()
        .into_iter()
        .map(|(k, p)| {
            let bytes = std::fs::read(&p).expect("read corpus file");
            (k, p, bytes)
        })
        .collect();
    let mut rng = XorShift::new(seed);
    let mut worker = spawn_worker(&scratch);
    let start = Instant::now();
    let (mut n, mut n_ok, mut n_err) = (0u64, 0u64, 0u64);
    let mut found: HashMap<String, usize> = HashMap::new();
    let mut last_report = Instant::now();
    while start.elapsed().as_secs_f64() < seconds {
        // Scenes (TOML, XML) 3 : 3, meshes (OBJ, PLY) 1 : 2; within a kind, files alike.
        let pick = [
            Kind::Toml,
            Kind::Toml,
            Kind::Toml,
            Kind::Xml,
            Kind::Xml,
            Kind::Xml,
        ]
        .into_iter()
        .chain([Kind::Obj, Kind::Ply, Kind::Ply])
        .nth(rng.below(9))
        .expect("nine kinds");
        let of_kind: Vec<_> = seeds.iter().filter(|s| s.0 == pick).collect();
        let (kind, src, bytes) = of_kind[rng.below(of_kind.len())];
        let donor = &seeds[rng.below(seeds.len())].2;
        let input = mutate(&mut rng, bytes, donor);
        let emissive = rng.chance(1, 2);
        let ext = kind.ext();
        let cur = scratch.join(format!("current.{ext}"));
        std::fs::write(&cur, &input).expect("write input");
        let dir = src.parent().expect("corpus file has a parent");
        let line = format!(
            "{ext}\t{}\t{}\t{}\n",
            cur.display(),
            dir.display(),
            u8::from(emissive)
        );
        n += 1;
        let verdict: Option<String> = match worker
            .stdin
            .write_all(line.as_bytes())
            .and_then(|_| worker.stdin.flush())
        {
            Err(e) => Some(format!("worker died before the input: {e}")),
            Ok(()) => match worker.replies.recv_timeout(timeout) {
                Ok(r) if r == "ok" => {
                    n_ok += 1;
                    None
                }
                Ok(r) if r == "err" => {
                    n_err += 1;
                    None
                }
                Ok(r) if r == "panic" => {
                    let msg = worker
                        .panics
                        .recv_timeout(Duration::from_secs(1))
                        .unwrap_or_else(|_| "PANIC (no message)".into());
                    Some(msg)
                }
                Ok(r) => Some(format!("BAD {}", r.trim_start_matches("bad\t"))),
                Err(RecvTimeoutError::Timeout) => Some(format!("HANG (> {timeout:?})")),
                Err(RecvTimeoutError::Disconnected) => {
                    let _ = worker.child.wait();
                    let tail: Vec<String> = worker.panics.try_iter().collect();
                    Some(format!("ABORT: {}", tail.join(" | ")))
                }
            },
        };
        if let Some(what) = verdict {
            let restart = what.starts_with("HANG")
                || what.starts_with("ABORT")
                || what.starts_with("worker died");
            // Group failures by their text without numbers (the panic location or the check).
            let key: String = what
                .chars()
                .filter(|c| !c.is_ascii_digit() && *c != '.' && *c != '-')
                .take(90)
                .collect();
            let count = found.entry(key.clone()).or_insert(0);
            *count += 1;
            println!("[{n}] {what} (from {})", src.display());
            if *count <= 3 {
                let stem = format!("{}-{n}", src.file_stem().unwrap().to_string_lossy());
                std::fs::write(crashes.join(format!("{stem}.{ext}")), &input).expect("save");
                std::fs::write(
                    crashes.join(format!("{stem}.txt")),
                    format!(
                        "{what}\nseed corpus file: {}\nemissive wrapper: {emissive}\n",
                        src.display()
                    ),
                )
                .expect("save");
            }
            if restart {
                let _ = worker.child.kill();
                let _ = worker.child.wait();
                worker = spawn_worker(&scratch);
            }
        }
        if last_report.elapsed() > Duration::from_secs(30) {
            last_report = Instant::now();
            println!(
                "{:.0} s: {n} inputs ({n_ok} loaded, {n_err} rejected), {} distinct failures",
                start.elapsed().as_secs_f64(),
                found.len()
            );
        }
    }
    let _ = worker.child.kill();
    let _ = worker.child.wait();
    println!(
        "done: {:.1} s, {n} inputs ({n_ok} loaded, {n_err} rejected), seed {seed}",
        start.elapsed().as_secs_f64()
    );
    println!("{} distinct failures:", found.len());
    let mut f: Vec<_> = found.into_iter().collect();
    f.sort();
    for (k, c) in &f {
        println!("  {c:6}  {k}");
    }
    i32::from(!f.is_empty())
}
