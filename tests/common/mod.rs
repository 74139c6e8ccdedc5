//! Helpers shared by the CLI's end-to-end test binaries (cli.rs, gpu.rs): run `bpins`
//! as a user does and check what it did.

#![allow(dead_code)]

use serde_json::Value;
use std::ffi::OsStr;
use std::fs;
use std::path::Path;
use std::process::Command;

pub const REPO: &str = env!("CARGO_MANIFEST_DIR");

/// Why the GPU twin cannot run here (no usable adapter), or `None` where it can.
pub fn gpu_missing() -> Option<String> {
    bpins_gpu::Gpu::new().err().map(|e| {
        format!(
            "{e}; Debian: `apt-get install -y mesa-vulkan-drivers libvulkan1` (lavapipe, Vulkan on the CPU; `.ci/run` does)"
        )
    })
}

/// What one invocation did.
#[derive(Debug)]
pub struct Run {
    pub args: String,
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Run {
    pub fn ok(self) -> Run {
        assert_eq!(self.code, Some(0), "`bpins {}` failed:\n{}", self.args, self.stderr);
        self
    }

    /// A clean failure: a non-zero exit code (not a signal) and an `error:` line.
    pub fn fails(self) -> Run {
        assert!(
            matches!(self.code, Some(c) if c != 0),
            "`bpins {}` should fail, exit {:?}\nstdout:\n{}\nstderr:\n{}",
            self.args,
            self.code,
            self.stdout,
            self.stderr
        );
        assert!(self.stderr.contains("error"), "`bpins {}`: no error message:\n{}", self.args, self.stderr);
        self
    }

    pub fn stderr_has(&self, what: &str) -> &Self {
        assert!(
            self.stderr.contains(what),
            "`bpins {}`: stderr does not mention `{what}`:\n{}",
            self.args,
            self.stderr
        );
        self
    }
}

/// Runs `bpins args…` in the repository root with extra environment `envs`.
pub fn bpins_env<S: AsRef<OsStr>>(args: &[S], envs: &[(&str, &str)]) -> Run {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_bpins"));
    cmd.current_dir(REPO).args(args);
    for (k, v) in envs {
        cmd.env(k, v);
    }
    let out = cmd.output().expect("running bpins");
    let run = Run {
        args: args.iter().map(|a| a.as_ref().to_string_lossy().into_owned()).collect::<Vec<_>>().join(" "),
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    };
    assert!(!run.stderr.contains("panicked"), "`bpins {}` panicked:\n{}", run.args, run.stderr);
    assert!(run.code.is_some(), "`bpins {}` was killed by a signal:\n{}", run.args, run.stderr);
    run
}

pub fn bpins<S: AsRef<OsStr>>(args: &[S]) -> Run {
    bpins_env(args, &[])
}

pub fn s(p: &Path) -> String {
    p.to_str().expect("temporary paths are UTF-8").to_string()
}

pub fn read_json(p: &Path) -> Value {
    let text = fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: not JSON: {e}", p.display()))
}

pub fn f64_of(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("`{key}` is not a number in {v}"))
}
