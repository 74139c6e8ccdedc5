//! `examples/slurm/` on a real Slurm: `examples/slurm/local-cluster.sh` starts a
//! one-node cluster on localhost (Debian's slurm-wlm and munge; slurmctld + slurmd,
//! proctrack/linuxproc, task/none, as root), `submit.sh` queues the tiny sweep as a
//! job array of 3 slices and a dependent merge; the merged summary must equal an
//! unsharded run bit for bit. Then one array task is killed (scancel) and another
//! slice is left half-written; resubmitting only that index and merging again gives
//! the same bits. The daemons it started are stopped (by their pid files) at the end,
//! also when the test fails.
//!
//! Without slurm-wlm and munge installed, or not as root, it is counted as ignored,
//! with the reason and the install command below the run's summary — except with
//! `CI` set, where it fails (`.ci/run` installs them; the harness is `tests/needs/mod.rs`).

#[path = "needs/mod.rs"]
mod needs;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::thread::sleep;
use std::time::{Duration, Instant};

const REPO: &str = env!("CARGO_MANIFEST_DIR");

fn main() -> std::process::ExitCode {
    needs::run(vec![
        (
            needs::Need::new("a local Slurm", unavailable()),
            vec![(
                "the_slurm_example_runs_on_a_real_cluster_and_reruns_one_slice",
                the_slurm_example_runs_on_a_real_cluster_and_reruns_one_slice,
            )],
        ),
        // The scripts' own checks, which run before any Slurm command: bash only.
        (
            needs::Need::none(),
            vec![
                ("submit_finds_the_binary_or_says_how_to_build_it", submit_finds_the_binary_or_says_how_to_build_it),
                ("local_cluster_names_a_taken_port_and_a_free_one", local_cluster_names_a_taken_port_and_a_free_one),
            ],
        ),
    ])
}

/// `submit.sh` hands every job the absolute path of the binary it found ($BPINS, or
/// `bpins` on PATH), and refuses a BPINS that is not there before queueing anything.
/// A stand-in `sbatch` records what each job would get.
fn submit_finds_the_binary_or_says_how_to_build_it() {
    let t = tempfile::tempdir().unwrap();
    let bin = t.path().join("bin");
    fs::create_dir(&bin).unwrap();
    let log = t.path().join("sbatch.log");
    let fake = format!("#!/bin/sh\necho \"BPINS=$BPINS\" >> {}\necho 4242\n", log.display());
    fs::write(bin.join("sbatch"), fake).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_bpins"), bin.join("bpins")).unwrap();
    let path = format!("{}:/usr/bin:/bin", bin.display());
    Command::new("chmod").arg("+x").arg(bin.join("sbatch")).status().unwrap();
    let submit = |bpins: Option<&str>| {
        let mut c = Command::new("bash");
        c.arg(format!("{REPO}/examples/slurm/submit.sh"))
            .arg(format!("{REPO}/examples/sweeps/tiny.toml"))
            .arg(t.path().join("out"))
            .arg("3")
            .env("PATH", &path)
            .env_remove("BPINS");
        if let Some(b) = bpins {
            c.env("BPINS", b);
        }
        c.output().unwrap()
    };
    // Found on PATH: its absolute path goes to both jobs.
    let o = submit(None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "array 4242 merge 4242");
    let want = format!("BPINS={}/bpins", bin.display());
    let got = fs::read_to_string(&log).unwrap();
    assert_eq!(got.lines().collect::<Vec<_>>(), [want.as_str(), want.as_str()], "{got}");
    // A BPINS that is not there: refused, saying how to build one, nothing queued.
    fs::remove_file(&log).unwrap();
    let o = submit(Some("/nonexistent/bpins"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("BPINS=/nonexistent/bpins is not an executable") && err.contains("cargo build --release"),
        "{err}"
    );
    assert!(!log.exists(), "sbatch ran");
}

/// `local-cluster.sh start` with a port in use names it and a free one, at once,
/// before it starts anything (it used to wait 20 s for a node that never came up).
fn local_cluster_names_a_taken_port_and_a_free_one() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let t = tempfile::tempdir().unwrap();
    for (arg, who) in [(port, "slurmctld"), (port - 1, "slurmd")] {
        let o = Command::new("bash")
            .arg(format!("{REPO}/examples/slurm/local-cluster.sh"))
            .arg("start")
            .arg(t.path())
            .arg(arg.to_string())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(&format!("port {port} (for {who}) is already taken")), "{err}");
        assert!(err.contains("choose other ports") && err.contains(" start "), "{err}");
        assert!(!t.path().join("slurm.conf").exists(), "it went on after the check");
    }
}

fn find(bin: &str) -> Option<PathBuf> {
    needs::find_on_path(&[bin], &["/usr/sbin", "/usr/bin"])
}

/// Why this machine cannot run the test, if it cannot.
fn unavailable() -> Option<String> {
    let missing: Vec<&str> = ["munged", "slurmctld", "slurmd", "sbatch", "squeue", "scancel"]
        .into_iter()
        .filter(|b| find(b).is_none())
        .collect();
    if !missing.is_empty() {
        return Some(format!(
            "not installed: {} (`apt-get install -y slurm-wlm munge`; `.ci/run` does)",
            missing.join(", ")
        ));
    }
    let uid = Command::new("id").arg("-u").output().ok()?;
    if String::from_utf8_lossy(&uid.stdout).trim() != "0" {
        return Some("the local cluster's daemons run as root; run the tests as root".into());
    }
    None
}

/// The cluster this test started; stopped when dropped.
struct Cluster {
    state: PathBuf,
    conf: PathBuf,
}

impl Cluster {
    fn start(state: &Path) -> Cluster {
        // A port of its own, so that two test runs on one machine do not meet.
        let port = 20_000 + (std::process::id() % 4000) * 2;
        let o = Command::new(format!("{REPO}/examples/slurm/local-cluster.sh"))
            .arg("start")
            .arg(state)
            .arg(port.to_string())
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "local-cluster.sh start failed:\n{stdout}\n{}", String::from_utf8_lossy(&o.stderr));
        let conf = stdout.trim().strip_prefix("export SLURM_CONF=").expect("it prints export SLURM_CONF=…");
        Cluster { state: state.to_path_buf(), conf: PathBuf::from(conf) }
    }

    fn cmd(&self, program: &str) -> Command {
        let mut c = Command::new(find(program).unwrap());
        c.env("SLURM_CONF", &self.conf);
        c
    }

    fn run(&self, program: &str, args: &[&str]) -> Output {
        let o = self.cmd(program).args(args).output().unwrap();
        assert!(o.status.success(), "{program} {args:?}: {}", String::from_utf8_lossy(&o.stderr));
        o
    }

    /// Submits with examples/slurm/submit.sh; returns (array job, merge job).
    fn submit(&self, sweep: &str, out: &Path, n: usize, indices: Option<&str>) -> (String, String) {
        let mut c = self.cmd("bash");
        c.arg(format!("{REPO}/examples/slurm/submit.sh")).arg(sweep).arg(out).arg(n.to_string());
        if let Some(i) = indices {
            c.arg(i);
        }
        let o = c.env("BPINS", env!("CARGO_BIN_EXE_bpins")).env("TRIALS", "6").output().unwrap();
        let s = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(o.status.success(), "submit.sh: {s}\n{}", String::from_utf8_lossy(&o.stderr));
        let w: Vec<&str> = s.split_whitespace().collect();
        assert_eq!((w.len(), w[0], w[2]), (4, "array", "merge"), "{s}");
        (w[1].to_string(), w[3].to_string())
    }

    /// Waits until none of `jobs` is pending or running (at most 120 s).
    fn wait(&self, jobs: &[&str]) {
        let deadline = Instant::now() + Duration::from_secs(120);
        loop {
            let o = self.run("squeue", &["-h", "-o", "%i %T %r", "-j", &jobs.join(",")]);
            let q = String::from_utf8_lossy(&o.stdout).into_owned();
            if q.trim().is_empty() {
                return;
            }
            assert!(Instant::now() < deadline, "jobs still queued after 120 s:\n{q}\n{}", self.logs());
            sleep(Duration::from_millis(250));
        }
    }

    fn logs(&self) -> String {
        ["slurmctld.log", "slurmd.log"]
            .iter()
            .map(|f| fs::read_to_string(self.state.join("log").join(f)).unwrap_or_default())
            .collect::<Vec<_>>()
            .join("\n")
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(format!("{REPO}/examples/slurm/local-cluster.sh")).arg("stop").arg(&self.state).output();
    }
}

fn same_outputs(a: &Path, b: &Path) {
    for f in ["summary.json", "summary.csv", "budget.csv", "trials.csv", "report.html"] {
        let (x, y) = (fs::read(a.join(f)), fs::read(b.join(f)));
        assert!(x.is_ok() && y.is_ok(), "{f}: {} or {} missing", a.display(), b.display());
        assert!(x.unwrap() == y.unwrap(), "{f} differs between {} and {}", a.display(), b.display());
    }
}

fn the_slurm_example_runs_on_a_real_cluster_and_reruns_one_slice() {
    let t = tempfile::tempdir().unwrap();
    let sweep = format!("{REPO}/examples/sweeps/tiny.toml");
    // The unsharded reference, run directly.
    let whole = t.path().join("whole");
    let o = Command::new(env!("CARGO_BIN_EXE_bpins"))
        .args(["sweep", &sweep, "--trials", "6", "--out"])
        .arg(&whole)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let cluster = Cluster::start(&t.path().join("cluster"));

    // 1. The array of 3 slices and the dependent merge.
    let out = t.path().join("run");
    let (array, merge) = cluster.submit(&sweep, &out, 3, None);
    cluster.wait(&[&array, &merge]);
    same_outputs(&whole, &out.join("merged"));

    // 2. A slice that fails: slice 1 killed before it finished (held, then scancel'ed)
    // and left half-written by an earlier attempt; the merge then never runs.
    let out2 = t.path().join("rerun");
    fs::create_dir_all(out2.join("shard-1")).unwrap();
    fs::write(out2.join("shard-1/trials.csv"), "sun_elevation_deg,source,trial\n5,installation_ang").unwrap();
    let o = cluster
        .cmd("sbatch")
        .args(["--parsable", "--hold", "--array=0-2", "--chdir"])
        .arg(&out2)
        .arg(format!("{REPO}/examples/slurm/sweep-array.sbatch"))
        .env("SWEEP", &sweep)
        .env("OUT", &out2)
        .env("SHARDS", "3")
        .env("TRIALS", "6")
        .env("BPINS", env!("CARGO_BIN_EXE_bpins"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let held = String::from_utf8_lossy(&o.stdout).trim().to_string();
    cluster.run("scontrol", &["release", &format!("{held}_0")]);
    cluster.run("scontrol", &["release", &format!("{held}_2")]);
    cluster.run("scancel", &[&format!("{held}_1")]);
    cluster.wait(&[&held]);
    assert!(out2.join("shard-0/shard.toml").is_file() && out2.join("shard-2/shard.toml").is_file());
    assert!(!out2.join("shard-1/shard.toml").exists(), "the killed slice looks complete");
    let done0 = fs::metadata(out2.join("shard-0/trials.csv")).unwrap().modified().unwrap();

    // 3. Resubmit only index 1 (and the merge): the other slices are not recomputed.
    let (array, merge) = cluster.submit(&sweep, &out2, 3, Some("1"));
    cluster.wait(&[&array, &merge]);
    assert_eq!(fs::metadata(out2.join("shard-0/trials.csv")).unwrap().modified().unwrap(), done0);
    same_outputs(&whole, &out2.join("merged"));
    drop(cluster);
}
