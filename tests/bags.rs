//! Captures and ROS 2 bags both ways, bpins with itself (tests/ros.rs checks bpins
//! against rosbags): `simulate --bag-out` writes a capture's frames, tilt, GNSS and
//! truth as a bag that `heading --bag` reads to the capture's headings, and
//! `bag-to-capture` turns the bag back into a capture with the same headings.

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn bpins(args: &[&str]) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_bpins")).args(args).output().unwrap();
    assert!(
        o.status.success(),
        "{args:?}:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

#[test]
fn a_simulated_capture_as_a_bag_and_back_keeps_its_headings() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    bpins(&[
        "simulate",
        "--out",
        &p("cap"),
        "--bag-out",
        &p("bag"),
        "--width-px",
        "306",
        "--height-px",
        "256",
        "--pixel-pitch-um",
        "27.6",
        "--headings-deg",
        "30,250,300",
        "--time-utc",
        "2026-06-21T02:30:00Z",
        "--latitude-deg",
        "36.07",
        "--longitude-deg",
        "120.38",
        "--tilt-x-deg",
        "1.5",
        "--tilt-y-deg",
        "-2",
        "--imu-sigma-deg",
        "0.05",
    ]);
    bpins(&["heading", &p("cap"), "--json", &p("cap.json")]);
    let sensor = ["--bit-depth", "12", "--black-level-dn", "64", "--imu-topic", "/imu/data"];
    let (bag, bag_json, back) = (p("bag"), p("bag.json"), p("back"));
    let mut args = vec!["heading", "--bag", &bag, "--json", &bag_json];
    args.extend_from_slice(&sensor);
    bpins(&args);
    let mut args = vec!["bag-to-capture", "--bag", &bag, "--out", &back, "--pixel-pitch-um", "27.6"];
    args.extend_from_slice(&sensor);
    bpins(&args);
    bpins(&["heading", &p("back"), "--json", &p("back.json")]);
    let (cap, bag, back) =
        (json(&tmp.path().join("cap.json")), json(&tmp.path().join("bag.json")), json(&tmp.path().join("back.json")));
    for i in 0..3 {
        let h = |v: &Value| v["frames"][i]["heading_deg"].as_f64().unwrap();
        let s = |v: &Value| v["frames"][i]["sigma_deg"].as_f64().unwrap();
        // Frames 1 and 2 are stamped 1 ms and 2 ms after the capture's time (the
        // bag's stamps strictly increase): the sun moves < 0.00001°.
        assert!((h(&cap) - h(&bag)).abs() < 1e-4, "frame {i}: capture {}, bag {}", h(&cap), h(&bag));
        assert!((s(&cap) - s(&bag)).abs() < 1e-4, "frame {i}");
        assert!((h(&bag) - h(&back)).abs() < 1e-9 && (s(&bag) - s(&back)).abs() < 1e-9, "frame {i}");
    }
    // The truth is in the bag too: /bpins/reference_heading, one per frame.
    let meta = std::fs::read_to_string(tmp.path().join("bag/metadata.yaml")).unwrap();
    assert!(meta.contains("/bpins/reference_heading") && meta.contains("/gnss/fix"), "{meta}");
}
