//! The harness of the test binaries that need something outside Rust: a browser, a
//! Python environment, a C compiler, a Slurm, a GPU adapter. Each such binary is
//! `harness = false` in its crate's `Cargo.toml` and includes this file with
//! `#[path = "…/tests/needs/mod.rs"] mod needs;`.
//!
//! libtest decides at compile time whether a test is ignored; whether Chromium is
//! installed is known only when the test runs. Here a test whose need is missing is
//! counted as **ignored** in the run's summary (`test result: ok. 0 passed; 0 failed;
//! 3 ignored`), its line names the need (`test [needs chromium] … ignored`), and the
//! reason with the command that installs it is printed below the summary, never a
//! silent pass. With `CI` set a missing need is a failure instead (`.ci/run`
//! installs everything), and so is `--include-ignored` where the need is missing.
//!
//! The harness is libtest-mimic's: filters, `--list`, `--exact`, `--ignored`,
//! `--include-ignored` and `--test-threads` behave as with libtest. It does not
//! capture output, so tests print their details only under `--nocapture` (see
//! [`verbose`]).

#![allow(dead_code)]

use libtest_mimic::{Arguments, Failed, Trial};
use std::process::ExitCode;
use std::sync::OnceLock;

/// Something a group of tests needs: its short name (`chromium`) and, when it is
/// missing here, why and how to install it.
pub struct Need {
    pub name: &'static str,
    pub missing: Option<String>,
}

impl Need {
    pub fn new(name: &'static str, missing: Option<String>) -> Need {
        Need { name, missing }
    }

    /// A need that this machine meets whenever the binary builds.
    pub fn none() -> Need {
        Need { name: "", missing: None }
    }
}

/// One test: its name and body (which panics to fail, like a `#[test]` fn).
pub type Test = (&'static str, fn());

static VERBOSE: OnceLock<bool> = OnceLock::new();

/// Whether the run was asked for the tests' output (`--nocapture` or
/// `--show-output`): details that libtest would have captured print only then.
pub fn verbose() -> bool {
    VERBOSE.get().copied().unwrap_or(false)
}

/// Whether `CI` is set: a missing need then fails its tests.
fn ci() -> bool {
    std::env::var_os("CI").is_some()
}

/// Runs `groups` (each a need and the tests that need it) as libtest would, and
/// prints, below the summary, every missing need's reason and install command.
pub fn run(groups: Vec<(Need, Vec<Test>)>) -> ExitCode {
    let args = Arguments::from_args();
    let _ = VERBOSE.set(args.nocapture || std::env::args().any(|a| a == "--show-output"));
    let (ci, list) = (ci(), args.list);
    let mut notes = Vec::new();
    let mut trials = Vec::new();
    for (need, tests) in groups {
        let missing = need.missing.clone();
        if let Some(why) = &missing {
            notes.push(format!("{} test(s) need {}: {why}{}", tests.len(), need.name, run_hint(why)));
        }
        for (name, body) in tests {
            trials.push(match missing.clone() {
                None => Trial::test(name, move || {
                    body();
                    Ok(())
                }),
                Some(why) => {
                    let msg = if ci {
                        format!("CI is set and this test cannot run: {why}")
                    } else {
                        format!("{} is missing: {why}", need.name)
                    };
                    Trial::test(name, move || Err(Failed::from(msg)))
                        .with_ignored_flag(!ci)
                        .with_kind(format!("needs {}", need.name))
                }
            });
        }
    }
    let conclusion = libtest_mimic::run(&args, trials);
    if !list && !notes.is_empty() {
        let verdict = if ci { "failed (CI is set)" } else { "ignored, not passed" };
        for n in &notes {
            println!("{verdict}: {n}");
        }
        println!();
    }
    conclusion.exit_code()
}

/// How to run this binary's tests once their need is met (where `why` does not say
/// already): `cargo test -p PACKAGE --test BINARY`, from the names cargo compiled it
/// under; `--include-ignored` runs them anyway, failing where the need is missing.
fn run_hint(why: &str) -> String {
    let (package, binary) = (env!("CARGO_PKG_NAME"), env!("CARGO_CRATE_NAME"));
    let command = format!("cargo test -p {package} --test {binary}");
    if why.contains(&command) {
        String::new()
    } else {
        format!("; once it is there: `{command}`")
    }
}

/// The first of `names` found on `PATH` (or in `extra` folders).
pub fn find_on_path(names: &[&str], extra: &[&str]) -> Option<std::path::PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    let dirs: Vec<std::path::PathBuf> =
        std::env::split_paths(&path).chain(extra.iter().map(std::path::PathBuf::from)).collect();
    names.iter().flat_map(|n| dirs.iter().map(move |d| d.join(n))).find(|p| p.is_file())
}
