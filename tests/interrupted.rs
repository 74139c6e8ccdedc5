//! Outputs whole or absent: long commands killed part-way (SIGKILL, no chance to
//! clean up) leave every file either absent or whole, never a capture that is not
//! one, and rerunning the same command completes.

use bpins_core::internal::capture::Capture;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_bpins"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("bpins starts")
}

fn run_ok(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_bpins")).args(args).output().unwrap();
    assert!(out.status.success(), "bpins {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

/// Waits until `ready()` or the child exits (then: false), for at most a minute.
fn wait_until(child: &mut Child, ready: impl Fn() -> bool) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(60) {
        if ready() {
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    panic!("bpins neither got there nor ended in a minute");
}

/// The frame images written so far (not the temporaries, whose names start with a dot).
fn frames(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> =
        std::fs::read_dir(dir.join("frames")).map(|r| r.flatten().map(|e| e.path()).collect()).unwrap_or_default();
    v.retain(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'));
    v.sort();
    v
}

#[test]
fn a_killed_simulate_leaves_whole_frames_and_no_capture_and_reruns() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("sim");
    let o = out.to_str().unwrap();
    let headings: Vec<String> = (0..24).map(|k| (15 * k).to_string()).collect();
    let headings = headings.join(",");
    let args = ["simulate", "--out", o, "--width-px", "306", "--height-px", "256", "--headings-deg", &headings];
    // Killed after the first frame, then after half of them: each time whole frames
    // (they decode at the sensor's size) and no capture.toml; the reader refuses the
    // folder as a capture.
    for at in [1, 12] {
        let mut child = spawn(&args);
        let got_there = wait_until(&mut child, || frames(&out).len() >= at);
        child.kill().unwrap();
        child.wait().unwrap();
        if !got_there {
            continue; // it finished first: nothing to check here
        }
        let written = frames(&out);
        for f in &written {
            let img = image::open(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
            assert_eq!((img.width(), img.height()), (306, 256), "{}", f.display());
        }
        if !out.join("capture.toml").exists() {
            let e = Capture::load(&out).unwrap_err().to_string();
            assert!(e.contains("capture.toml"), "{e}");
        }
    }
    // Rerun into the same folder: completes, and the capture reads back whole.
    if out.join("capture.toml").exists() {
        return; // a fast machine finished every run before the kill
    }
    run_ok(&args);
    let c = Capture::load(&out).unwrap();
    assert_eq!(c.frames.len(), 24);
    for i in 0..24 {
        c.read_frame(i).unwrap();
    }
    assert!(!out.join(".bpins-partial").exists());
    // And a finished capture is still never written over.
    let again = Command::new(env!("CARGO_BIN_EXE_bpins")).args(args).output().unwrap();
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("already exists"));
}

#[test]
fn a_killed_fit_leaves_each_output_absent_or_whole_and_reruns() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf();
    let sample = root.join("samples/clean");
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("fit");
    let args = ["fit", sample.to_str().unwrap(), "--out", out.to_str().unwrap()];
    let outputs = ["calibration.toml", "fit.json", "residual_dn.exr", "residual_aop.png", "profiles.csv"];
    // Kill as soon as the first output appears, and as soon as the second does.
    for first in [0, 1] {
        let mut child = spawn(&args);
        let order = ["calibration.toml", "residual_dn.exr"];
        wait_until(&mut child, || out.join(order[first]).exists());
        child.kill().unwrap();
        child.wait().unwrap();
        check_whole(&out, &outputs);
    }
    run_ok(&args);
    check_whole(&out, &outputs);
    for f in outputs {
        assert!(out.join(f).is_file(), "{f} after the rerun");
    }
}

#[test]
fn a_killed_diagnose_leaves_each_output_absent_or_whole_and_reruns() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf();
    let sample = root.join("samples/clean");
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("diag");
    let args = ["diagnose", sample.to_str().unwrap(), "--out", out.to_str().unwrap()];
    let outputs = [
        "diagnosis.json",
        "report.html",
        "step0/residual_dn.exr",
        "step0/residual_pol.exr",
        "step0/residual_aop.png",
        "step0/profiles.csv",
    ];
    // Killed as soon as the diagnosis is written, and as soon as the first step's maps are.
    for first in ["diagnosis.json", "step0/residual_dn.exr"] {
        let mut child = spawn(&args);
        wait_until(&mut child, || out.join(first).exists());
        child.kill().unwrap();
        child.wait().unwrap();
        check_whole(&out, &outputs);
        if out.join("report.html").exists() {
            let page = std::fs::read_to_string(out.join("report.html")).unwrap();
            assert!(page.trim_end().ends_with("</html>"), "report.html cut short");
        }
    }
    run_ok(&args);
    check_whole(&out, &outputs);
    for f in ["diagnosis.json", "report.html"] {
        assert!(out.join(f).is_file(), "{f} after the rerun");
    }
}

/// Each output that exists reads back whole.
fn check_whole(out: &Path, outputs: &[&str]) {
    for f in outputs {
        let p = out.join(f);
        if !p.exists() {
            continue;
        }
        match p.extension().and_then(|e| e.to_str()) {
            Some("json") => {
                serde_json::from_slice::<serde_json::Value>(&std::fs::read(&p).unwrap())
                    .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            }
            Some("toml") => {
                bpins_core::calibration::Calibration::load(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            }
            Some("exr") => {
                bpins_core::internal::capture::read_exr_layers(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            }
            Some("png") => {
                image::open(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            }
            _ => {
                let text = std::fs::read_to_string(&p).unwrap();
                assert!(text.ends_with('\n'), "{} ends mid-line", p.display());
            }
        }
    }
}
