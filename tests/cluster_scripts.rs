//! The cluster scripts (`cluster/`) without the engine: a stub `lodestar` records its
//! arguments, a stub `sbatch` records each submission and prints a fake job id. Checked: the
//! Slurm array task's part index and output (`cluster/slurm/part.sh`), the submission chain of
//! `cluster/slurm/submit.sh` (learning job for guided integrators, array, afterok merge), and
//! the Kubernetes Indexed Job's and merge Job's `sh -c` lines (`cluster/k8s/*.yaml`).

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("lodestar-cluster-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
    fn path(&self, name: &str) -> String {
        self.0.join(name).to_string_lossy().into_owned()
    }
    /// An executable shell script `name` in this directory.
    fn script(&self, name: &str, text: &str) -> String {
        let path = self.path(name);
        std::fs::write(&path, text).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
        path
    }
    /// A stub `lodestar` writing its arguments, one a line, to `args.txt`.
    fn stub_lodestar(&self) -> String {
        let log = self.path("args.txt");
        self.script(
            "lodestar",
            &format!("#!/bin/sh\nprintf '%s\\n' \"$@\" > '{log}'\n"),
        )
    }
    /// The arguments the stub `lodestar` was run with.
    fn recorded_args(&self) -> Vec<String> {
        let text = std::fs::read_to_string(self.path("args.txt")).expect("lodestar was not run");
        text.lines().map(str::to_string).collect()
    }
    /// `PATH` with this directory first.
    fn path_env(&self) -> String {
        format!(
            "{}:{}",
            self.0.display(),
            std::env::var("PATH").unwrap_or_default()
        )
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// `program args` in the repository with the Slurm and lodestar variables cleared, then `env`.
fn run(program: &str, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(program);
    cmd.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    for (key, _) in std::env::vars() {
        if key.starts_with("SLURM_") || key.starts_with("SBATCH_") || key.starts_with("LODESTAR") {
            cmd.env_remove(key);
        }
    }
    cmd.env_remove("JOB_COMPLETION_INDEX");
    cmd.envs(env.iter().copied());
    cmd.output()
        .unwrap_or_else(|e| panic!("cannot run {program}: {e}"))
}

fn assert_ok(o: &Output, what: &str) {
    assert!(
        o.status.success(),
        "{what} failed: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Whether `args` holds `flag value` as consecutive arguments.
fn has_pair(args: &[String], flag: &str, value: &str) -> bool {
    args.windows(2).any(|w| w[0] == flag && w[1] == value)
}

#[test]
fn part_sh_takes_its_index_from_the_array_task() {
    let dir = Dir::new("part");
    let stub = dir.stub_lodestar();
    let part_sh = repo("cluster/slurm/part.sh");
    let part_sh = part_sh.to_str().unwrap();
    let args = [
        "-n",
        "4",
        "-d",
        "/scratch/w",
        "--",
        "--spp",
        "16",
        "--seed",
        "5",
    ];

    let o = run(
        part_sh,
        &args,
        &[("SLURM_ARRAY_TASK_ID", "3"), ("LODESTAR", &stub)],
    );
    assert_ok(&o, "part.sh");
    let got = dir.recorded_args();
    assert_eq!(got[0], "render", "{got:?}");
    assert!(has_pair(&got, "--part", "3/4"), "{got:?}");
    assert!(has_pair(&got, "-o", "/scratch/w/part-3.exr"), "{got:?}");
    assert!(has_pair(&got, "--spp", "16") && has_pair(&got, "--seed", "5"));
    assert!(!got.iter().any(|a| a == "--load-guides"), "{got:?}");

    // The count from the environment instead of -n; a guided integrator loads the cache.
    let o = run(
        part_sh,
        &["-d", "/w", "--", "--integrator", "guided-pt", "--spp", "8"],
        &[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("LODESTAR_PARTS", "5"),
            ("LODESTAR", &stub),
        ],
    );
    assert_ok(&o, "part.sh (guided)");
    let got = dir.recorded_args();
    assert!(has_pair(&got, "--part", "2/5"), "{got:?}");
    assert!(has_pair(&got, "--load-guides", "/w/guides.bin"), "{got:?}");
    assert!(has_pair(&got, "-o", "/w/part-2.exr"), "{got:?}");

    // No array task id: a non-zero exit that says what is missing, and no render.
    std::fs::remove_file(dir.path("args.txt")).unwrap();
    let o = run(part_sh, &args, &[("LODESTAR", &stub)]);
    assert!(
        !o.status.success(),
        "part.sh ran without SLURM_ARRAY_TASK_ID"
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("SLURM_ARRAY_TASK_ID is not set"), "{err}");
    assert!(!Path::new(&dir.path("args.txt")).exists());

    // An index outside 1..N.
    let o = run(
        part_sh,
        &args,
        &[("SLURM_ARRAY_TASK_ID", "5"), ("LODESTAR", &stub)],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("outside 1..4"), "{err}");
}

/// The submissions of `submit.sh ARGS` to a stub sbatch (ids 101, 102, ...), each as its
/// argument list, and submit.sh's output.
fn submissions(dir: &Dir, args: &[&str]) -> (Vec<Vec<String>>, String) {
    submissions_of("cluster/slurm/submit.sh", dir, args)
}

/// [`submissions`] of another submission script.
fn submissions_of(script: &str, dir: &Dir, args: &[&str]) -> (Vec<Vec<String>>, String) {
    let log = dir.path("sbatch.txt");
    let count = dir.path("count");
    dir.script(
        "sbatch",
        &format!(
            "#!/bin/sh\n\
             n=$(cat '{count}' 2>/dev/null || echo 100); n=$((n + 1)); echo $n > '{count}'\n\
             {{ printf '%s\\n' \"$@\"; echo '<end>'; }} >> '{log}'\n\
             echo \"$n;local\"\n"
        ),
    );
    let _ = std::fs::remove_file(&log);
    let _ = std::fs::remove_file(&count);
    let submit = repo(script);
    let path = dir.path_env();
    let o = run(
        submit.to_str().unwrap(),
        args,
        &[("PATH", &path), ("LODESTAR", "/opt/lodestar")],
    );
    assert_ok(&o, script);
    let text = std::fs::read_to_string(&log).unwrap();
    let jobs = text
        .split("<end>\n")
        .filter(|s| !s.is_empty())
        .map(|s| s.lines().map(str::to_string).collect())
        .collect();
    (jobs, String::from_utf8_lossy(&o.stdout).into_owned())
}

#[test]
fn submit_sh_chains_array_and_merge() {
    let dir = Dir::new("submit");
    let work = dir.path("work");
    let out = dir.path("out/merged.exr");
    let (jobs, stdout) = submissions(
        &dir,
        &[
            "-n", "4", "-o", &out, "-d", &work, "--", "--spp", "16", "--seed", "5",
        ],
    );
    assert_eq!(jobs.len(), 2, "{jobs:?}");
    let (array, merge) = (&jobs[0], &jobs[1]);
    assert!(array.iter().all(|a| a != "--wrap"));
    assert!(array.contains(&"--parsable".to_string()), "{array:?}");
    assert!(array.contains(&"--array=1-4".to_string()), "{array:?}");
    assert!(!array.iter().any(|a| a.starts_with("--dependency")));
    // The task script and its arguments: part.sh -n 4 -d WORK -- RENDER_ARGS.
    let at = array.iter().position(|a| a.ends_with("part.sh")).unwrap();
    assert_eq!(
        array[at + 1..],
        ["-n", "4", "-d", &work, "--", "--spp", "16", "--seed", "5"]
    );
    assert!(
        merge.contains(&"--dependency=afterok:101".to_string()),
        "{merge:?}"
    );
    let wrap = &merge[merge.iter().position(|a| a == "--wrap").unwrap() + 1];
    let parts: Vec<String> = (1..=4).map(|i| format!("{work}/part-{i}.exr")).collect();
    assert!(
        wrap.starts_with("/opt/lodestar merge ")
            && wrap.contains(&parts.join(" "))
            && wrap.contains(&format!("-o {out}")),
        "{wrap}"
    );
    assert!(stdout.contains("array job 101") && stdout.contains("merge job 102"));
    assert!(Path::new(&work).is_dir());

    // A guided integrator: a learning job first, the array after it, the merge after the array.
    let (jobs, _) = submissions(
        &dir,
        &[
            "-n",
            "3",
            "-o",
            &out,
            "-d",
            &work,
            "--",
            "--integrator",
            "guided-pt",
            "--spp",
            "16",
        ],
    );
    assert_eq!(jobs.len(), 3, "{jobs:?}");
    let learn = &jobs[0];
    let wrap = &learn[learn.iter().position(|a| a == "--wrap").unwrap() + 1];
    assert!(
        wrap.starts_with("/opt/lodestar render --integrator guided-pt --spp 16 ")
            && wrap.contains(&format!("--save-guides {work}/guides.bin")),
        "{wrap}"
    );
    assert!(
        jobs[1].contains(&"--array=1-3".to_string()),
        "{:?}",
        jobs[1]
    );
    assert!(jobs[1].contains(&"--dependency=afterok:101".to_string()));
    assert!(jobs[2].contains(&"--dependency=afterok:102".to_string()));

    // Refused before anything is submitted: no --spp, no part count.
    let submit = repo("cluster/slurm/submit.sh");
    let submit = submit.to_str().unwrap();
    let path = dir.path_env();
    let _ = std::fs::remove_file(dir.path("sbatch.txt"));
    let env = [("PATH", path.as_str())];
    for (args, message) in [
        (
            vec!["-n", "2", "-o", &out, "--", "--seed", "1"],
            "must give --spp",
        ),
        (vec!["-o", &out, "--", "--spp", "4"], "-n PARTS"),
        (
            vec!["-n", "2", "-o", &out, "--", "--spp", "4", "--part", "1/2"],
            "must not give --part",
        ),
    ] {
        let o = run(submit, &args, &env);
        assert!(!o.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(message), "{args:?}: {err}");
    }
    assert!(!Path::new(&dir.path("sbatch.txt")).exists());
}

/// The `sh -c` script of a Kubernetes manifest: the line after `- -c`, unquoted.
fn k8s_command(file: &str) -> String {
    let text = std::fs::read_to_string(repo(file)).unwrap();
    let mut lines = text.lines();
    lines
        .by_ref()
        .find(|l| l.trim() == "- -c")
        .unwrap_or_else(|| panic!("{file}: no '- -c' line"));
    let line = lines.next().unwrap().trim();
    let value = line.strip_prefix("- ").expect("a list item after '- -c'");
    match value.strip_prefix('\'').and_then(|v| v.strip_suffix('\'')) {
        Some(quoted) => quoted.replace("''", "'"),
        None => value.to_string(),
    }
}

/// The manifest's `N=` (parts) and `completions`, which must agree.
fn k8s_parts(file: &str, command: &str) -> u32 {
    let n: u32 = command
        .strip_prefix("N=")
        .and_then(|s| s.split(';').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{file}: the command does not start with N=<parts>;"));
    let text = std::fs::read_to_string(repo(file)).unwrap();
    if let Some(c) = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("completions:"))
    {
        assert_eq!(
            c.trim().parse::<u32>().unwrap(),
            n,
            "{file}: completions vs N"
        );
    }
    n
}

#[test]
fn k8s_indexed_job_renders_part_index_plus_one() {
    let dir = Dir::new("k8s");
    dir.stub_lodestar();
    let path = dir.path_env();
    let render = k8s_command("cluster/k8s/render-job.yaml");
    let n = k8s_parts("cluster/k8s/render-job.yaml", &render);
    for (index, part) in [("0", 1), ("2", 3)] {
        let o = run(
            "sh",
            &["-c", &render],
            &[("JOB_COMPLETION_INDEX", index), ("PATH", &path)],
        );
        assert_ok(&o, "render-job.yaml's command");
        let got = dir.recorded_args();
        assert_eq!(got[0], "render", "{got:?}");
        assert!(has_pair(&got, "--part", &format!("{part}/{n}")), "{got:?}");
        let out = format!("/work-out/part-{part}.exr");
        assert!(has_pair(&got, "-o", &out), "{got:?}");
        assert!(got.iter().any(|a| a == "--spp"), "{got:?}");
    }

    let merge = k8s_command("cluster/k8s/merge-job.yaml");
    let m = k8s_parts("cluster/k8s/merge-job.yaml", &merge);
    assert_eq!(m, n, "merge-job.yaml's N vs render-job.yaml's");
    let o = run("sh", &["-c", &merge], &[("PATH", &path)]);
    assert_ok(&o, "merge-job.yaml's command");
    let got = dir.recorded_args();
    let mut want = vec!["merge".to_string()];
    want.extend((1..=n).map(|i| format!("/work-out/part-{i}.exr")));
    assert_eq!(got[..want.len()], want[..], "{got:?}");
    assert!(has_pair(&got, "-o", "/work-out/merged.exr"), "{got:?}");
}

/// `bench.sh`: an array whose task I runs `bench ... --part I/N --out OUT/part-I` (the index
/// expanded by the task's shell), then a report job after it gathering every part.
#[test]
fn bench_sh_spreads_a_bench_over_an_array() {
    let dir = Dir::new("bench");
    let out = dir.path("cmp");
    let (jobs, stdout) = submissions_of(
        "cluster/slurm/bench.sh",
        &dir,
        &[
            "-n", "3", "-o", &out, "--", "--scene", "s.toml", "--time", "60",
        ],
    );
    assert_eq!(jobs.len(), 2, "{jobs:?}");
    let wrap = |job: &[String]| job[job.iter().position(|a| a == "--wrap").unwrap() + 1].clone();
    assert!(jobs[0].contains(&"--array=1-3".to_string()));
    // Run the task's line as a task would (SLURM_ARRAY_TASK_ID=2) with a stub lodestar.
    let stub = dir.stub_lodestar();
    let task = wrap(&jobs[0]).replacen("/opt/lodestar", &stub, 1);
    let o = run("sh", &["-c", &task], &[("SLURM_ARRAY_TASK_ID", "2")]);
    assert_ok(&o, "the array task");
    let args = dir.recorded_args();
    assert_eq!(args[..5], ["bench", "--scene", "s.toml", "--time", "60"]);
    assert!(has_pair(&args, "--part", "2/3"), "{args:?}");
    assert!(
        has_pair(&args, "--out", &format!("{out}/part-2")),
        "{args:?}"
    );
    let report = wrap(&jobs[1]);
    assert!(jobs[1].contains(&"--dependency=afterok:101".to_string()));
    let dirs: Vec<String> = (1..=3).map(|i| format!("{out}/part-{i}")).collect();
    assert!(
        report.starts_with("/opt/lodestar bench --scene s.toml --time 60 --from-parts ")
            && report.contains(&dirs.join(" "))
            && report.ends_with(&format!("--out {out}")),
        "{report}"
    );
    assert!(stdout.contains("array job 101") && stdout.contains("report job 102"));
    // Refused: BENCH_ARGS that the script sets itself.
    let path = dir.path_env();
    let script = repo("cluster/slurm/bench.sh");
    let o = run(
        script.to_str().unwrap(),
        &["-n", "2", "-o", &out, "--", "--out", "x"],
        &[("PATH", path.as_str())],
    );
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("must not give --out"));
}
