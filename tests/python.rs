//! The Python package in the workspace's test command: builds `crates/bpins-py` into
//! the virtual environment `.venv` at the repository root (`maturin develop`, the
//! `python` profile) and runs its pytest suite (`crates/bpins-py/tests`), which
//! compares Python's headings with this CLI's, round-trips captures, checks every
//! bad-input error, runs `examples/python/quickstart.py` and checks agreement with
//! polanalyser. `.ci/run` makes the environment (maturin, pytest, numpy,
//! polanalyser); without it the test is counted as ignored, with the command that
//! makes the environment below the run's summary, and fails where `CI` is set (the
//! harness is `tests/needs/mod.rs`, `harness = false`). `BPINS_PYTHON` names another
//! interpreter (one whose environment has those).

#[path = "needs/mod.rs"]
mod needs;

use std::path::{Path, PathBuf};
use std::process::Command;

const REPO: &str = env!("CARGO_MANIFEST_DIR");

fn python() -> Option<PathBuf> {
    let p =
        std::env::var_os("BPINS_PYTHON").map(PathBuf::from).unwrap_or_else(|| Path::new(REPO).join(".venv/bin/python"));
    p.is_file().then_some(p)
}

fn main() -> std::process::ExitCode {
    let missing = match python() {
        None => Some(
            "no Python environment at .venv; make it with `python3 -m venv .venv && \
             .venv/bin/pip install -r crates/bpins-py/requirements-test.txt` (about 1 min; `.ci/run` does)"
                .to_string(),
        ),
        Some(py) => {
            let ok = Command::new(&py).args(["-c", "import maturin, pytest, numpy, polanalyser"]).output();
            match ok {
                Ok(o) if o.status.success() => None,
                _ => Some(format!(
                    "{} lacks maturin, pytest, numpy or polanalyser; install them with `{} -m pip install -r \
                     crates/bpins-py/requirements-test.txt`",
                    py.display(),
                    py.display()
                )),
            }
        }
    };
    needs::run(vec![(
        needs::Need::new("a Python environment", missing),
        vec![("the_python_package_builds_and_its_tests_pass", the_python_package_builds_and_its_tests_pass)],
    )])
}

fn the_python_package_builds_and_its_tests_pass() {
    let py = python().expect("main checked for Python");
    let venv = py.parent().and_then(Path::parent).expect("python in <venv>/bin").to_path_buf();
    let repo = Path::new(REPO);
    // A target folder of its own: the outer `cargo test` may still hold the
    // workspace's build lock while it runs this test.
    let target = repo.join("target/python-ext");
    let build = Command::new(&py)
        .args(["-m", "maturin", "develop", "--locked", "--profile", "python", "-m"])
        .arg(repo.join("crates/bpins-py/Cargo.toml"))
        .env("VIRTUAL_ENV", &venv)
        .env("CARGO_TARGET_DIR", &target)
        .output()
        .expect("maturin runs");
    assert!(
        build.status.success(),
        "maturin develop failed:\n{}\n{}",
        String::from_utf8_lossy(&build.stdout),
        String::from_utf8_lossy(&build.stderr)
    );
    let test = Command::new(&py)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(repo.join("crates/bpins-py/tests"))
        .env("BPINS_CLI", env!("CARGO_BIN_EXE_bpins"))
        .env("BPINS_SAMPLES", repo.join("samples"))
        .current_dir(repo)
        .output()
        .expect("pytest runs");
    let out = String::from_utf8_lossy(&test.stdout);
    if needs::verbose() {
        println!("{out}");
    }
    assert!(test.status.success(), "pytest failed:\n{out}\n{}", String::from_utf8_lossy(&test.stderr));
    assert!(out.contains("passed") && !out.contains("skipped"), "pytest skipped tests:\n{out}");
}
