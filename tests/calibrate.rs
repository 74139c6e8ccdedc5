//! `bpins calibrate` and `bpins simulate --lab` end to end, as a user runs them:
//! the sample flawed sensor calibrated in the lab and its sky read through the
//! calibration; a simulated lab capture; what is refused. Outputs go to temporary
//! folders; samples/ is only read.

use std::fs;
use std::path::Path;
use std::process::Command;

use serde_json::Value;

const REPO: &str = env!("CARGO_MANIFEST_DIR");

struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

fn bpins(args: &[&str]) -> Run {
    let out = Command::new(env!("CARGO_BIN_EXE_bpins")).current_dir(REPO).args(args).output().unwrap();
    let r = Run {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    };
    assert!(!r.stderr.contains("panicked"), "`bpins {}` panicked:\n{}", args.join(" "), r.stderr);
    r
}

fn ok(args: &[&str]) -> Run {
    let r = bpins(args);
    assert_eq!(r.code, Some(0), "`bpins {}` failed:\n{}", args.join(" "), r.stderr);
    r
}

fn fails(args: &[&str], want: &[&str]) {
    let r = bpins(args);
    assert!(matches!(r.code, Some(c) if c != 0), "`bpins {}` should fail", args.join(" "));
    for w in want {
        assert!(r.stderr.contains(w), "`bpins {}`: stderr lacks `{w}`:\n{}", args.join(" "), r.stderr);
    }
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

fn heading_rms(json: &Path) -> f64 {
    let v: Value = serde_json::from_str(&fs::read_to_string(json).unwrap()).unwrap();
    v["summary"][0]["rms_error_deg"].as_f64().unwrap()
}

#[test]
fn the_sample_sensor_calibrated_in_the_lab_reads_its_sky_to_the_noise() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("cal");
    let r = ok(&["calibrate", "samples/lab-flawed-sensor/lab", "--out", &s(&out)]);
    assert!(r.stdout.contains("analyzer angle offset") && r.stdout.contains("DN/e⁻"), "{}", r.stdout);
    assert!(r.stdout.contains("not determined: dark_noise_dn"), "{}", r.stdout);
    for f in
        ["calibration.toml", "pixels.exr", "maps.exr", "summary.json", "report.html", "png/analyzer_offset_deg.png"]
    {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let summary: Value = serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let k = summary["photon_transfer"]["conversion_gain_dn_per_e"].as_f64().unwrap();
    assert!((k - 0.1).abs() < 0.005, "K {k}");
    assert_eq!(summary["channels"].as_array().unwrap().len(), 16);

    let cal = s(&out.join("calibration.toml"));
    let (raw, fixed) = (tmp.path().join("raw.json"), tmp.path().join("cal.json"));
    let sky = "samples/lab-flawed-sensor/sky";
    ok(&["heading", sky, "--json", &s(&raw)]);
    ok(&["heading", sky, "--calibration", &cal, "--json", &s(&fixed)]);
    let (before, after) = (heading_rms(&raw), heading_rms(&fixed));
    assert!(before > 0.3 && after < 0.015, "heading RMS {before}° → {after}°");

    // The calibration of a 306 × 256 sensor is refused for the 612 × 512 samples.
    fails(&["heading", "samples/clean", "--calibration", &cal], &["306 × 256", "612 × 512"]);
    // A lab capture is not a sky capture, and calibrate never writes into a capture.
    fails(&["heading", "samples/lab-flawed-sensor/lab"], &["lab capture"]);
    fails(
        &["calibrate", "samples/lab-flawed-sensor/lab", "--out", "samples/lab-flawed-sensor/lab/out"],
        &["inside the capture"],
    );
    fails(&["calibrate", sky, "--out", &s(&tmp.path().join("x"))], &["kind = \"sky\""]);
}

#[test]
fn a_simulated_lab_capture_is_calibrated_and_partial_ones_say_what_they_lack() {
    let tmp = tempfile::tempdir().unwrap();
    let lab = tmp.path().join("lab");
    let truth = tmp.path().join("truth.exr");
    ok(&[
        "simulate",
        "--lab",
        "--out",
        &s(&lab),
        "--width-px",
        "96",
        "--height-px",
        "64",
        "--effect",
        "analyzer_angles.d45_deg=0.8",
        "--pixel-angle-sigma-deg",
        "0.4",
        "--prnu",
        "0.01",
        "--dsnu-dn",
        "1.5",
        "--lab-truth",
        &s(&truth),
    ]);
    assert!(lab.join("capture.toml").is_file() && truth.is_file());
    let out = tmp.path().join("cal");
    let r = ok(&["calibrate", &s(&lab), "--out", &s(&out)]);
    // The 45° channel's mean offset, +0.8° (± a few hundredths at this size).
    let line = r.stdout.lines().find(|l| l.starts_with("analyzer angle offset") && l.contains(" 45°")).unwrap();
    let mean: f64 = line.split_whitespace().nth(4).unwrap().parse().unwrap();
    assert!((mean - 0.8).abs() < 0.05, "{line}");

    // One polarizer angle, no exposure series: analyzers and photon transfer left out.
    let one = tmp.path().join("one");
    ok(&[
        "simulate",
        "--lab",
        "--out",
        &s(&one),
        "--width-px",
        "64",
        "--height-px",
        "48",
        "--lab-angles-deg",
        "30",
        "--lab-exposures",
    ]);
    let r = ok(&["calibrate", &s(&one), "--out", &s(&tmp.path().join("one-cal"))]);
    assert!(r.stdout.contains("not determined: analyzer_deg, eps") && r.stdout.contains("has 1 (30°)"), "{}", r.stdout);
    assert!(r.stdout.contains("2 or more exposures") || r.stdout.contains("no unsaturated"), "{}", r.stdout);
}
