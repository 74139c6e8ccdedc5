//! ROS 2 bags against an independent implementation: `rosbags` (PyPI, pure Python,
//! no ROS; tests/ros/bags.py) writes bags of a simulated capture's frames, in MCAP
//! and sqlite3 storage, with the pixel and CDR byte orders and row paddings a
//! driver may use; `bpins heading --bag` must give the headings `bpins heading` gives
//! on the capture itself, and the bag it writes, read back by rosbags, must hold
//! REP 103's yaw (90° − heading), the heading's variance and the images' stamps.
//! Bad bags must give errors naming the bag, the topic and the message index.
//!
//! Needs the `.venv` of crates/bpins-py/requirements-test.txt (rosbags, numpy,
//! Pillow through matplotlib); without it the tests count as ignored
//! (tests/needs/mod.rs), and fail where `CI` is set. `BPINS_PYTHON` names another
//! interpreter.

#[path = "needs/mod.rs"]
mod needs;

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

const REPO: &str = env!("CARGO_MANIFEST_DIR");
const BAGS_PY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros/bags.py");
/// The first image's stamp (2026-06-21T02:30:00Z), and the frames' spacing.
const T0_NS: i64 = 1_782_009_000_000_000_000;
const DT_NS: i64 = 100_000_000;

fn python() -> Option<PathBuf> {
    let p =
        std::env::var_os("BPINS_PYTHON").map(PathBuf::from).unwrap_or_else(|| Path::new(REPO).join(".venv/bin/python"));
    p.is_file().then_some(p)
}

fn main() -> std::process::ExitCode {
    let missing = match python() {
        None => Some(
            "no Python environment at .venv; make it with `python3 -m venv .venv && \
             .venv/bin/pip install -r crates/bpins-py/requirements-test.txt` (`.ci/run` does)"
                .to_string(),
        ),
        Some(py) => match Command::new(&py).args(["-c", "import rosbags, numpy, PIL"]).output() {
            Ok(o) if o.status.success() => None,
            _ => Some(format!(
                "{} lacks rosbags, numpy or Pillow; `{} -m pip install -r crates/bpins-py/requirements-test.txt`",
                py.display(),
                py.display()
            )),
        },
    };
    needs::run(vec![(
        needs::Need::new("a Python environment with rosbags", missing),
        vec![
            ("bags_of_both_storages_give_the_captures_headings", bags_of_both_storages_give_the_captures_headings),
            (
                "the_output_bag_holds_rep103_yaw_variance_and_stamps",
                the_output_bag_holds_rep103_yaw_variance_and_stamps,
            ),
            ("the_sun_follows_from_navsatfix_and_the_stamps", the_sun_follows_from_navsatfix_and_the_stamps),
            (
                "nan_in_an_imu_message_skips_its_frame_with_a_diagnostic",
                nan_in_an_imu_message_skips_its_frame_with_a_diagnostic,
            ),
            ("bad_bags_are_refused_naming_bag_topic_and_message", bad_bags_are_refused_naming_bag_topic_and_message),
            ("mono8_frames_give_the_8_bit_captures_headings", mono8_frames_give_the_8_bit_captures_headings),
            ("a_split_bag_reads_as_one_bag", a_split_bag_reads_as_one_bag),
            ("heading_frame_id_reaches_the_imu_header", heading_frame_id_reaches_the_imu_header),
            (
                "padded_rows_through_bag_to_capture_give_the_unpadded_bags_files",
                padded_rows_through_bag_to_capture_give_the_unpadded_bags_files,
            ),
            (
                "a_calibrated_capture_and_its_bag_give_the_same_rows_bit_for_bit",
                a_calibrated_capture_and_its_bag_give_the_same_rows_bit_for_bit,
            ),
            (
                "a_colour_capture_and_its_bag_give_the_same_band_rows",
                a_colour_capture_and_its_bag_give_the_same_band_rows,
            ),
        ],
    )])
}

fn run(cmd: &mut Command) -> Output {
    let o = cmd.output().expect("command runs");
    if needs::verbose() {
        println!("{}\n{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    }
    o
}

fn bpins(args: &[&str]) -> Output {
    run(Command::new(env!("CARGO_BIN_EXE_bpins")).args(args))
}

fn ok(o: Output) -> Output {
    assert!(
        o.status.success(),
        "failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn py(args: &[&str]) -> Output {
    run(Command::new(python().expect("main checked")).arg(BAGS_PY).args(args))
}

fn json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// A folder of the run's files, kept for the whole run.
fn tmp() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().unwrap()).path()
}

/// A small simulated capture (3 frames, tilted, IMU 1σ 0.1°) and `bpins heading`'s
/// JSON of it.
fn capture() -> &'static (PathBuf, Value) {
    static C: OnceLock<(PathBuf, Value)> = OnceLock::new();
    C.get_or_init(|| {
        let cap = tmp().join("cap");
        let c = cap.to_str().unwrap();
        ok(bpins(&[
            "simulate",
            "--out",
            c,
            "--width-px",
            "306",
            "--height-px",
            "256",
            "--pixel-pitch-um",
            "27.6",
            "--headings-deg",
            "0,70,200",
            "--tilt-x-deg",
            "2",
            "--tilt-y-deg",
            "-1",
            "--imu-sigma-deg",
            "0.1",
        ]));
        let j = tmp().join("ref.json");
        ok(bpins(&["heading", c, "--json", j.to_str().unwrap()]));
        (cap, json(&j))
    })
}

/// `bags.py write` of the capture into `name` with `extra` options; the bag's path.
fn bag(name: &str, extra: &[&str]) -> PathBuf {
    let b = tmp().join(name);
    let mut args = vec!["write", capture().0.to_str().unwrap(), b.to_str().unwrap()];
    args.extend_from_slice(extra);
    ok(py(&args));
    b
}

const SUN: [&str; 4] = ["--sun-azimuth-deg", "40", "--sun-elevation-deg", "25"];
const SENSOR: [&str; 4] = ["--bit-depth", "12", "--black-level-dn", "64"];

/// `bpins heading --bag` with `extra`; its JSON.
fn heading_bag(bag: &Path, extra: &[&str]) -> Value {
    let j = bag.with_extension("json");
    let mut args = vec!["heading", "--bag", bag.to_str().unwrap(), "--json", j.to_str().unwrap()];
    args.extend_from_slice(extra);
    ok(bpins(&args));
    json(&j)
}

fn assert_same_headings(got: &Value, what: &str) {
    let want = &capture().1["frames"];
    let got = &got["frames"];
    assert_eq!(got.as_array().unwrap().len(), 3, "{what}");
    for i in 0..3 {
        for k in ["heading_deg", "sigma_deg"] {
            let (a, b) = (want[i][k].as_f64().unwrap(), got[i][k].as_f64().unwrap());
            assert!((a - b).abs() < 1e-9, "{what}, frame {i}, {k}: capture {a}, bag {b}");
        }
        assert_eq!(got[i]["stamp_ns"].as_i64().unwrap(), T0_NS + i as i64 * DT_NS, "{what}");
    }
}

fn bags_of_both_storages_give_the_captures_headings() {
    // A driver's every layout: mono16 little- and big-endian, padded rows, mono8
    // is below (a 12-bit capture has no 8-bit equivalent), CDR of both byte orders;
    // the camera from CameraInfo or from a sensor file; IMU nearest or slerped.
    let sensor = tmp().join("sensor.toml");
    let text = std::fs::read_to_string(capture().0.join("capture.toml")).unwrap();
    std::fs::write(&sensor, text.split("[[frames]]").next().unwrap().replace("format = \"bpins-capture/1\"", ""))
        .unwrap();
    let cases: [(&str, &[&str], &[&str]); 4] = [
        ("mcap_le", &["--storage", "mcap", "--camera-info", "--imu"], &SENSOR),
        (
            "sqlite_be_padded",
            &[
                "--storage",
                "sqlite3",
                "--camera-info",
                "--imu",
                "--big-endian-pixels",
                "--pad",
                "7",
                "--cdr-big-endian",
            ],
            &SENSOR,
        ),
        ("mcap_sensor_file", &["--storage", "mcap", "--imu", "--pad", "2"], &["--sensor", sensor.to_str().unwrap()]),
        (
            "sqlite_nearest",
            &["--storage", "sqlite3", "--camera-info", "--imu"],
            &["--bit-depth", "12", "--black-level-dn", "64", "--imu-match", "nearest"],
        ),
    ];
    for (name, write, read) in cases {
        let b = bag(name, write);
        let mut args: Vec<&str> = SUN.to_vec();
        args.extend_from_slice(read);
        assert_same_headings(&heading_bag(&b, &args), name);
    }
}

fn the_output_bag_holds_rep103_yaw_variance_and_stamps() {
    let b = bag("for_out", &["--storage", "mcap", "--camera-info", "--imu"]);
    let out = tmp().join("out_rep103");
    let mut args: Vec<&str> = SUN.to_vec();
    args.extend_from_slice(&SENSOR);
    args.extend_from_slice(&["--bag-out", out.to_str().unwrap()]);
    let mine = heading_bag(&b, &args);
    let back: Value = serde_json::from_slice(&ok(py(&["read", out.to_str().unwrap()])).stdout).unwrap();
    let msgs = back.as_array().unwrap();
    assert_eq!(msgs.len(), 3);
    let wrap = |x: f64| (x + 180.0).rem_euclid(360.0) - 180.0;
    for (i, m) in msgs.iter().enumerate() {
        let f = &mine["frames"][i];
        let (h, s) = (f["heading_deg"].as_f64().unwrap(), f["sigma_deg"].as_f64().unwrap());
        assert_eq!((m["topic"].as_str(), m["type"].as_str()), (Some("/bpins/heading"), Some("sensor_msgs/msg/Imu")));
        assert_eq!(m["stamp_ns"].as_i64().unwrap(), T0_NS + i as i64 * DT_NS);
        assert_eq!(m["log_time_ns"].as_i64().unwrap(), T0_NS + i as i64 * DT_NS);
        assert_eq!(m["frame_id"], "cam");
        let yaw = m["yaw_deg"].as_f64().unwrap();
        // REP 103: yaw counter-clockwise from East = 90° − heading; a writer that wrote
        // heading − 90° fails here (the headings 0°, 70°, 200° tell the two apart).
        assert!(wrap(yaw - (90.0 - h)).abs() < 1e-9, "frame {i}: yaw {yaw}, heading {h}");
        assert!(wrap(yaw - (h - 90.0)).abs() > 1.0, "frame {i}: yaw {yaw} = heading − 90°");
        let cov: Vec<f64> =
            m["orientation_covariance"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        assert!((cov[8] - s.to_radians().powi(2)).abs() < 1e-15, "frame {i}: yaw variance {}", cov[8]);
        let imu_var = 0.1f64.to_radians().powi(2);
        assert!((cov[0] - imu_var).abs() < 1e-15 && (cov[4] - imu_var).abs() < 1e-15, "{cov:?}");
        assert_eq!(
            (m["angular_velocity_covariance0"].as_f64(), m["linear_acceleration_covariance0"].as_f64()),
            (Some(-1.0), Some(-1.0))
        );
    }
    // Never written over: the same --bag-out again is refused.
    let again = bpins(&[
        "heading",
        "--bag",
        b.to_str().unwrap(),
        SUN[0],
        SUN[1],
        SUN[2],
        SUN[3],
        "--bag-out",
        out.to_str().unwrap(),
    ]);
    assert!(!again.status.success() && String::from_utf8_lossy(&again.stderr).contains("already exists"));
}

fn the_sun_follows_from_navsatfix_and_the_stamps() {
    // A capture rendered under the sun of 2026-06-21T02:30:00Z at Qingdao (SPA), and
    // its bag with a NavSatFix there and images stamped from that instant (frame i
    // at +0.1 i s: the sun moves 0.0004°/0.1 s, so the headings agree to ~0.001°).
    let cap = tmp().join("cap_spa");
    let c = cap.to_str().unwrap();
    ok(bpins(&[
        "simulate",
        "--out",
        c,
        "--width-px",
        "306",
        "--height-px",
        "256",
        "--pixel-pitch-um",
        "27.6",
        "--headings-deg",
        "30,250",
        "--time-utc",
        "2026-06-21T02:30:00Z",
        "--latitude-deg",
        "36.07",
        "--longitude-deg",
        "120.38",
    ]));
    let j = tmp().join("ref_spa.json");
    ok(bpins(&["heading", c, "--json", j.to_str().unwrap()]));
    let want = json(&j);
    let b = tmp().join("bag_spa");
    ok(py(&["write", c, b.to_str().unwrap(), "--camera-info", "--fix", "36.07,120.38"]));
    let got = heading_bag(&b, &SENSOR);
    for i in 0..2 {
        let (a, g) = (&want["frames"][i], &got["frames"][i]);
        let (ha, hg) = (a["heading_deg"].as_f64().unwrap(), g["heading_deg"].as_f64().unwrap());
        assert!((ha - hg).abs() < 0.003, "frame {i}: capture {ha}, bag {hg}");
        assert!(g["sun"].as_str().unwrap().contains("NREL SPA"), "{g}");
    }
    // No fix and no sun given: refused, saying what to give.
    let b2 = bag("no_sun", &["--camera-info"]);
    let o = bpins(&["heading", "--bag", b2.to_str().unwrap()]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("--sun-azimuth-deg") && e.contains("NavSatFix"), "{e}");
}

fn nan_in_an_imu_message_skips_its_frame_with_a_diagnostic() {
    let b = bag("nan_imu", &["--camera-info", "--imu", "--nan-imu-frame", "1"]);
    let out = tmp().join("out_nan");
    let mut args: Vec<&str> = SUN.to_vec();
    args.extend_from_slice(&SENSOR);
    args.extend_from_slice(&["--bag-out", out.to_str().unwrap()]);
    let got = heading_bag(&b, &args);
    let why = got["frames"][1]["no_heading_reason"].as_str().unwrap();
    // Frame 1's IMU samples are messages 2 and 3 of /imu/data.
    assert!(why.contains("topic /imu/data, message 2") && why.contains("NaN"), "{why}");
    assert!(got["frames"][0]["heading_deg"].is_f64() && got["frames"][2]["heading_deg"].is_f64());
    let back: Value = serde_json::from_slice(&ok(py(&["read", out.to_str().unwrap()])).stdout).unwrap();
    let diag: Vec<&Value> = back.as_array().unwrap().iter().filter(|m| m["topic"] == "/diagnostics").collect();
    assert_eq!(diag.len(), 1);
    assert_eq!(diag[0]["stamp_ns"].as_i64().unwrap(), T0_NS + DT_NS);
    assert_eq!((diag[0]["level"].as_i64(), diag[0]["message"].as_str()), (Some(1), Some(why)));
    assert_eq!(diag[0]["values"]["image_message"], "1");
}

fn bad_bags_are_refused_naming_bag_topic_and_message() {
    let err = |o: Output| {
        assert!(!o.status.success());
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let heading = |b: &Path, extra: &[&str]| {
        let mut args = vec!["heading", "--bag", b.to_str().unwrap()];
        args.extend_from_slice(&SUN);
        args.extend_from_slice(extra);
        err(bpins(&args))
    };
    // A truncated MCAP: the bag, the topic, and the message the damage stopped at.
    let b = bag("truncated", &["--camera-info", "--imu"]);
    let f = b.join("truncated.mcap");
    let len = std::fs::metadata(&f).unwrap().len();
    std::fs::OpenOptions::new().write(true).open(&f).unwrap().set_len(len * 2 / 3).unwrap();
    let before = snapshot(&b);
    let e = heading(&b, &SENSOR);
    assert!(e.contains("truncated") && e.contains("topic /cam/image_raw, message "), "{e}");
    assert!(snapshot(&b) == before, "the bag read was written to");
    // An unknown encoding.
    let b = bag("rgb", &["--camera-info", "--encoding", "rgb8"]);
    let e = heading(&b, &SENSOR);
    assert!(e.contains("topic /cam/image_raw, message 0") && e.contains("encoding `rgb8`"), "{e}");
    // An image whose size does not match the camera (a sensor file of another size).
    let b = bag("sized", &["--imu"]);
    let before = snapshot(&b);
    let sensor = tmp().join("small_sensor.toml");
    std::fs::write(&sensor, "[sensor]\nlayout = \"dofp\"\nwidth_px = 300\nheight_px = 256\npixel_pitch_um = 27.6\nbit_depth = 12\n[lens]\nprojection = \"pinhole\"\nfocal_length_mm = 8.0\n").unwrap();
    let e = heading(&b, &["--sensor", sensor.to_str().unwrap()]);
    assert!(e.contains("message 0: image of 306 × 256 px does not match the camera's 300 × 256 px"), "{e}");
    // A missing topic, and no intrinsics.
    let e = heading(&b, &["--imu-topic", "/nope"]);
    assert!(e.contains("topic /nope") && e.contains("no such topic") && e.contains("/cam/image_raw"), "{e}");
    let e = heading(&b, &SENSOR);
    assert!(e.contains("no intrinsics"), "{e}");
    // Not a bag.
    let e = heading(&tmp().join("cap"), &[]);
    assert!(e.contains("metadata.yaml"), "{e}");
    // Nothing was written into the bag read, nor beside its files.
    assert!(snapshot(&b) == before, "the bag read was written to");
}

/// Every file of a folder with its bytes, sorted.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    v.sort();
    v
}

fn mono8_frames_give_the_8_bit_captures_headings() {
    // An 8-bit camera: its capture's DN fit mono8 (bags.py checks), so the bag's
    // mono8 frames must give the capture's headings exactly.
    let cap = tmp().join("cap8");
    let c = cap.to_str().unwrap();
    ok(bpins(&[
        "simulate",
        "--out",
        c,
        "--width-px",
        "306",
        "--height-px",
        "256",
        "--pixel-pitch-um",
        "27.6",
        "--bit-depth",
        "8",
        "--black-level-dn",
        "4",
        "--headings-deg",
        "20,160,290",
    ]));
    let j = tmp().join("ref8.json");
    ok(bpins(&["heading", c, "--json", j.to_str().unwrap()]));
    let want = json(&j);
    for (name, storage) in [("mono8_mcap", "mcap"), ("mono8_sqlite", "sqlite3")] {
        let b = tmp().join(name);
        ok(py(&["write", c, b.to_str().unwrap(), "--storage", storage, "--camera-info", "--mono8", "--pad", "3"]));
        let mut args: Vec<&str> = SUN.to_vec();
        args.extend_from_slice(&["--bit-depth", "8", "--black-level-dn", "4"]);
        let got = heading_bag(&b, &args);
        assert_eq!(got["frames"].as_array().unwrap().len(), 3, "{name}");
        for i in 0..3 {
            for k in ["heading_deg", "sigma_deg"] {
                let (a, g) = (want["frames"][i][k].as_f64().unwrap(), got["frames"][i][k].as_f64().unwrap());
                assert!((a - g).abs() < 1e-9, "{name}, frame {i}, {k}: capture {a}, bag {g}");
            }
        }
        // mono8 frames for a 12-bit sensor: refused by name, not read as 12-bit DN.
        let o = bpins(&["heading", "--bag", b.to_str().unwrap(), SUN[0], SUN[1], SUN[2], SUN[3], "--bit-depth", "12"]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains("message 0: a mono8 image for a 12-bit sensor"), "{e}");
    }
}

fn a_split_bag_reads_as_one_bag() {
    // rosbag2 splits a long recording into NAME_0, NAME_1, … (`--max-bag-size`), each
    // file with its own channels; metadata.yaml lists them in order. Frame 2 and its
    // IMU samples lie in the second file (and, split after frame 1, frame 1's in the
    // first and frame 2's in the second).
    for (name, storage, after) in [("split_mcap", "mcap", "2"), ("split_sqlite", "sqlite3", "1")] {
        let b = bag(name, &["--storage", storage, "--camera-info", "--imu", "--split-after", after]);
        let meta = std::fs::read_to_string(b.join("metadata.yaml")).unwrap();
        let ext = if storage == "mcap" { "mcap" } else { "db3" };
        let files = [format!("{name}_0.{ext}"), format!("{name}_1.{ext}")];
        assert!(files.iter().all(|f| meta.contains(f.as_str()) && b.join(f).is_file()), "{meta}");
        let mut args: Vec<&str> = SUN.to_vec();
        args.extend_from_slice(&SENSOR);
        assert_same_headings(&heading_bag(&b, &args), name);
        // The second file gone: refused when the bag is opened, naming the file.
        let gone = tmp().join(format!("{name}_gone"));
        std::fs::create_dir(&gone).unwrap();
        std::fs::copy(b.join("metadata.yaml"), gone.join("metadata.yaml")).unwrap();
        std::fs::copy(b.join(&files[0]), gone.join(&files[0])).unwrap();
        let o = bpins(&[&["heading", "--bag", gone.to_str().unwrap()][..], &args[..]].concat());
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains(files[1].as_str()), "{e}");
    }
}

fn heading_frame_id_reaches_the_imu_header() {
    let b = bag("frame_id", &["--storage", "mcap", "--camera-info", "--imu"]);
    let out = tmp().join("out_frame_id");
    let mut args: Vec<&str> = SUN.to_vec();
    args.extend_from_slice(&SENSOR);
    args.extend_from_slice(&["--bag-out", out.to_str().unwrap(), "--heading-frame-id", "polcam_optical"]);
    let mine = heading_bag(&b, &args);
    let back: Value = serde_json::from_slice(&ok(py(&["read", out.to_str().unwrap()])).stdout).unwrap();
    let msgs = back.as_array().unwrap();
    assert_eq!(msgs.len(), 3);
    for (i, m) in msgs.iter().enumerate() {
        assert_eq!(m["type"], "sensor_msgs/msg/Imu", "message {i}");
        assert_eq!(m["frame_id"], "polcam_optical", "message {i}: the image's frame id `cam` written instead");
        assert_eq!(m["stamp_ns"].as_i64().unwrap(), T0_NS + i as i64 * DT_NS);
        assert!(mine["frames"][i]["heading_deg"].is_f64());
    }
}

/// Issue 50 item 1, one frame source: the lab-flawed sample's sky frames with the
/// calibration `bpins calibrate` fits from its lab frames, read as a capture and as a
/// rosbags bag of the same frames (padded rows, the same sun and sensor), give the
/// same JSON row, bit for bit, but for the fields that say where the frame came from
/// (a capture's file and reference heading, a bag's message and stamp, the sun's
/// source in words). A turn ago the capture route resampled the calibration's
/// per-pixel maps onto each frame and the bag route read them per cell, and the two
/// differed by up to 0.0038°.
fn a_calibrated_capture_and_its_bag_give_the_same_rows_bit_for_bit() {
    let root = Path::new(REPO).join("samples/lab-flawed-sensor");
    let (lab, sky) = (root.join("lab"), root.join("sky"));
    let cal = tmp().join("lab_cal");
    ok(bpins(&["calibrate", lab.to_str().unwrap(), "--out", cal.to_str().unwrap()]));
    let calibration = cal.join("calibration.toml");
    let calibration = calibration.to_str().unwrap();
    let sensor = tmp().join("lab_sensor.toml");
    let text = std::fs::read_to_string(sky.join("capture.toml")).unwrap();
    std::fs::write(&sensor, text.split("[[frames]]").next().unwrap().replace("format = \"bpins-capture/1\"", ""))
        .unwrap();
    let b = tmp().join("lab_sky_bag");
    ok(py(&["write", sky.to_str().unwrap(), b.to_str().unwrap(), "--storage", "mcap", "--pad", "3"]));
    let cap_json = tmp().join("lab_sky.json");
    ok(bpins(&[
        "heading",
        sky.to_str().unwrap(),
        "--calibration",
        calibration,
        "--extractor",
        "all",
        "--json",
        cap_json.to_str().unwrap(),
    ]));
    let cap = json(&cap_json);
    let origin =
        ["file", "message_index", "stamp", "stamp_ns", "frame_id", "sun", "reference_heading_deg", "error_deg"];
    for extractor in ["sun_vector", "meridian_line"] {
        let mut args: Vec<&str> = SUN.to_vec();
        args.extend_from_slice(&["--sensor", sensor.to_str().unwrap(), "--calibration", calibration]);
        args.extend_from_slice(&["--extractor", extractor]);
        let bag = heading_bag(&b, &args);
        let want: Vec<&Value> =
            cap["frames"].as_array().unwrap().iter().filter(|r| r["extractor"] == extractor).collect();
        let got = bag["frames"].as_array().unwrap();
        assert_eq!(want.len(), 8, "{cap}");
        assert_eq!(got.len(), 8, "{bag}");
        for (i, (w, g)) in want.iter().zip(got).enumerate() {
            let strip = |v: &Value| {
                let mut m = v.as_object().unwrap().clone();
                m.retain(|k, _| !origin.contains(&k.as_str()));
                m
            };
            assert!(w["heading_deg"].is_f64(), "frame {i}: {w}");
            assert_eq!(strip(w), strip(g), "{extractor}, frame {i}: capture row and bag row differ");
        }
        // The calibrated capture reads to the noise (sun_vector: ~0.01°), each error within 3σ.
        for w in &want {
            let (e, s) = (w["error_deg"].as_f64().unwrap(), w["sigma_deg"].as_f64().unwrap());
            assert!(e.abs() < 3.0 * s, "{extractor}: error {e}°, 1σ {s}°");
            assert!(extractor != "sun_vector" || e.abs() < 0.03, "{extractor}: error {e}°");
        }
    }
}

/// Issue 50 item 3: rosbags' bags of one capture with rows padded by any number of
/// bytes (odd too), mono16 of either byte order and mono8, in MCAP and sqlite3,
/// give `bag-to-capture` the same capture as the unpadded bag, file for file and bit
/// for bit (the frames those of the capture the bag was written from), and `heading
/// --bag` the same frames. (`bag-to-capture` stopped on padded little-endian mono16
/// rows, "mosaic has 317432 values, expected 313344", which `heading --bag` read.)
fn padded_rows_through_bag_to_capture_give_the_unpadded_bags_files() {
    // A 12-bit capture (DN above 255) for mono16, an 8-bit one for mono8.
    let cap8 = tmp().join("cap8_padded");
    ok(bpins(&[
        "simulate",
        "--out",
        cap8.to_str().unwrap(),
        "--width-px",
        "306",
        "--height-px",
        "256",
        "--pixel-pitch-um",
        "27.6",
        "--bit-depth",
        "8",
        "--black-level-dn",
        "4",
        "--headings-deg",
        "20,160",
        "--tilt-x-deg",
        "1",
        "--imu-sigma-deg",
        "0.1",
    ]));
    let mono16: &[&[&str]] = &[
        &["--pad", "2"],
        &["--pad", "3"],
        &["--pad", "5", "--big-endian-pixels"],
        &["--storage", "sqlite3", "--pad", "1"],
        &["--storage", "sqlite3", "--pad", "4", "--big-endian-pixels", "--cdr-big-endian"],
    ];
    let mono8: &[&[&str]] = &[&["--mono8", "--pad", "3"], &["--mono8", "--storage", "sqlite3", "--pad", "1"]];
    for (name, cap, read, layouts) in
        [("pad16", &capture().0, SENSOR, mono16), ("pad8", &cap8, ["--bit-depth", "8", "--black-level-dn", "4"], mono8)]
    {
        let c = cap.to_str().unwrap();
        let mut args: Vec<&str> = SUN.to_vec();
        args.extend_from_slice(&read);
        let write = |tag: &str, extra: &[&str]| {
            let b = tmp().join(format!("{name}_{tag}"));
            let mut w = vec!["write", c, b.to_str().unwrap(), "--camera-info", "--imu"];
            w.extend_from_slice(extra);
            ok(py(&w));
            b
        };
        let unpadded = write("unpadded", if name == "pad8" { &["--mono8"] } else { &[] });
        let want = (heading_bag(&unpadded, &args)["frames"].clone(), bag_to_capture(&unpadded, &args));
        assert!(want.0.as_array().unwrap().iter().all(|f| f["heading_deg"].is_f64()), "{name}: {}", want.0);
        // The frames are the capture's own, bit for bit.
        let spec = std::fs::read_to_string(cap.join("capture.toml")).unwrap();
        let frames: Vec<Vec<u8>> = spec
            .lines()
            .filter_map(|l| l.strip_prefix("file = "))
            .map(|f| std::fs::read(cap.join(f.trim().trim_matches('"'))).unwrap())
            .collect();
        let written: Vec<&Vec<u8>> = want.1.iter().filter(|f| f.0.ends_with(".png")).map(|f| &f.1).collect();
        assert!(frames.len() >= 2 && written == frames.iter().collect::<Vec<_>>(), "{name}: frames differ");
        for (k, extra) in layouts.iter().enumerate() {
            let b = write(&k.to_string(), extra);
            let got = (heading_bag(&b, &args)["frames"].clone(), bag_to_capture(&b, &args));
            assert_eq!(got.0, want.0, "{name} {extra:?}: heading --bag's frames differ from the unpadded bag's");
            assert_eq!(got.1.len(), want.1.len(), "{name} {extra:?}");
            for (g, w) in got.1.iter().zip(&want.1) {
                assert!(g == w, "{name} {extra:?}: {} differs from the unpadded bag's {}", g.0, w.0);
            }
        }
    }
}

/// `bpins bag-to-capture` of `bag` with `extra` into a new folder beside it: every
/// file it wrote (its path in the capture and its bytes), sorted.
fn bag_to_capture(bag: &Path, extra: &[&str]) -> Vec<(String, Vec<u8>)> {
    let out = bag.with_extension("capture");
    let mut args = vec!["bag-to-capture", "--bag", bag.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(&["--pixel-pitch-um", "27.6"]);
    args.extend_from_slice(extra);
    ok(bpins(&args));
    let mut files = Vec::new();
    let mut dirs = vec![out.clone()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else {
                files.push((p.strip_prefix(&out).unwrap().display().to_string(), std::fs::read(&p).unwrap()));
            }
        }
    }
    files.sort();
    files
}

/// Issue 45 item 2: a colour-polarization capture (the colour sample) written as a
/// rosbags bag of raw mono16 mosaics, read with a sensor file that gives its
/// `colour_tiles`, gives the capture's rows band by band, bit for bit; so does the
/// bag of the same mosaics as `bayer_rggb16` read with a sensor file without them
/// (the encoding names the tiles), and one whose tiles are not the encoding's is
/// refused naming both.
fn a_colour_capture_and_its_bag_give_the_same_band_rows() {
    let sky = Path::new(REPO).join("samples/colour-clear");
    let sensor = tmp().join("colour_sensor.toml");
    let text = std::fs::read_to_string(sky.join("capture.toml")).unwrap();
    let header = text.split("[[frames]]").next().unwrap().replace("format = \"bpins-capture/1\"", "");
    std::fs::write(&sensor, &header).unwrap();
    assert!(header.contains("colour_tiles"));
    let sun = ["--sun-azimuth-deg", "200", "--sun-elevation-deg", "45", "--sensor"];
    let b = tmp().join("colour_bag");
    ok(py(&["write", sky.to_str().unwrap(), b.to_str().unwrap(), "--storage", "mcap", "--pad", "5"]));
    let cap_json = tmp().join("colour_cap.json");
    ok(bpins(&["heading", sky.to_str().unwrap(), "--json", cap_json.to_str().unwrap()]));
    let cap = json(&cap_json);
    let bag = heading_bag(&b, &[&sun[..], &[sensor.to_str().unwrap()]].concat());
    same_band_rows(&cap, &bag);
    // bayer_rggb16: the tiles from the encoding.
    let bayer = tmp().join("colour_bag_bayer");
    ok(py(&["write", sky.to_str().unwrap(), bayer.to_str().unwrap(), "--encoding", "bayer_rggb16"]));
    let mono_sensor = tmp().join("colour_sensor_without_tiles.toml");
    let without: String = header.lines().filter(|l| !l.starts_with("colour_tiles")).map(|l| format!("{l}\n")).collect();
    std::fs::write(&mono_sensor, &without).unwrap();
    same_band_rows(&cap, &heading_bag(&bayer, &[&sun[..], &[mono_sensor.to_str().unwrap()]].concat()));
    // Tiles that are not the encoding's.
    let grbg = tmp().join("colour_sensor_grbg.toml");
    std::fs::write(
        &grbg,
        header.replace(r#"colour_tiles = [["R", "G"], ["G", "B"]]"#, r#"colour_tiles = [["G", "R"], ["B", "G"]]"#),
    )
    .unwrap();
    let mut args = vec!["heading", "--bag", bayer.to_str().unwrap()];
    args.extend_from_slice(&sun);
    args.push(grbg.to_str().unwrap());
    let o = bpins(&args);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("bayer_rggb16") && e.contains("GRBG"), "{e}");
}

/// The capture's and the bag's rows, band by band, bit for bit (where they came from
/// aside).
fn same_band_rows(cap: &Value, bag: &Value) {
    let (want, got) = (cap["frames"].as_array().unwrap(), bag["frames"].as_array().unwrap());
    assert_eq!(want.len(), 16, "4 frames × (fused, R, G, B): {cap}");
    assert_eq!(got.len(), want.len(), "{bag}");
    let origin =
        ["file", "message_index", "stamp", "stamp_ns", "frame_id", "sun", "reference_heading_deg", "error_deg"];
    for (i, (w, g)) in want.iter().zip(got).enumerate() {
        let strip = |v: &Value| {
            let mut m = v.as_object().unwrap().clone();
            m.retain(|k, _| !origin.contains(&k.as_str()));
            m
        };
        assert_eq!(strip(w), strip(g), "row {i} ({}): capture and bag differ", w["band"]);
    }
}
