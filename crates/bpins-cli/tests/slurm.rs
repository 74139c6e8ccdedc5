//! `examples/slurm/` on a real Slurm: `examples/slurm/local-cluster.sh` starts a
//! one-node cluster on localhost (Debian's slurm-wlm and munge; slurmctld + slurmd,
//! proctrack/linuxproc, task/none, as root), `submit.sh` queues the tiny sweep as a
//! job array of 3 slices and a dependent merge; the merged summary must equal an
//! unsharded run bit for bit. Then one array task is killed (scancel) and another
//! slice is left half-written; resubmitting only that index and merging again gives
//! the same bits. The daemons it started are stopped (by their pid files) at the end,
//! also when the test fails.
//!
//! Without slurm-wlm and munge installed, or not as root, it reports itself skipped,
//! with the reason — except with `CI` set, where it fails (`.ci/run` installs them).

use std::env;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::thread::sleep;
use std::time::{Duration, Instant};

const REPO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn find(bin: &str) -> Option<PathBuf> {
    let path = env::var_os("PATH").unwrap_or_default();
    env::split_paths(&path)
        .chain([PathBuf::from("/usr/sbin"), PathBuf::from("/usr/bin")])
        .map(|d| d.join(bin))
        .find(|p| p.is_file())
}

/// Why this machine cannot run the test, if it cannot.
fn unavailable() -> Option<String> {
    let missing: Vec<&str> = ["munged", "slurmctld", "slurmd", "sbatch", "squeue", "scancel"]
        .into_iter()
        .filter(|b| find(b).is_none())
        .collect();
    if !missing.is_empty() {
        return Some(format!("not installed: {} (apt-get install -y slurm-wlm munge)", missing.join(", ")));
    }
    let uid = Command::new("id").arg("-u").output().ok()?;
    if String::from_utf8_lossy(&uid.stdout).trim() != "0" {
        return Some("the local cluster's daemons run as root; this test is not root".into());
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

#[test]
fn the_slurm_example_runs_on_a_real_cluster_and_reruns_one_slice() {
    if let Some(why) = unavailable() {
        if env::var_os("CI").is_some() {
            panic!("CI is set and the Slurm test cannot run: {why}");
        }
        eprintln!("SKIPPED (no local Slurm: {why})");
        return;
    }
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
