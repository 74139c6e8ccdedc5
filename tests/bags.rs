//! Captures and ROS 2 bags both ways, bpins with itself (tests/ros.rs checks bpins
//! against rosbags): `simulate --bag-out` writes a capture's frames, tilt, GNSS and
//! truth as a bag that `heading --bag` reads to the capture's headings, and
//! `bag-to-capture` turns the bag back into a capture with the same headings.

use serde_json::Value;
use std::path::{Path, PathBuf};
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

/// `simulate` into `dir`/cap and its bag `dir`/bag: 27.6 µm pixels at 36.07° N
/// 120.38° E at `time_utc`, `args` the rest (size, headings, tilt, scene).
fn simulate_with_bag(dir: &Path, time_utc: &str, args: &[&str]) {
    let (cap, bag) = (dir.join("cap"), dir.join("bag"));
    let (cap, bag) = (cap.to_str().unwrap(), bag.to_str().unwrap());
    let mut all = vec!["simulate", "--out", cap, "--bag-out", bag, "--pixel-pitch-um", "27.6", "--time-utc", time_utc];
    all.extend_from_slice(&["--latitude-deg", "36.07", "--longitude-deg", "120.38"]);
    all.extend_from_slice(args);
    bpins(&all);
}

#[test]
fn a_simulated_capture_as_a_bag_and_back_keeps_its_headings() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    simulate_with_bag(
        tmp.path(),
        "2026-06-21T02:30:00Z",
        &[
            "--width-px",
            "306",
            "--height-px",
            "256",
            "--headings-deg",
            "30,250,300",
            "--tilt-x-deg",
            "1.5",
            "--tilt-y-deg",
            "-2",
            "--imu-sigma-deg",
            "0.05",
        ],
    );
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

/// Issue 46 item 4: `--tilt-sigma-deg` gives one heading and 1σ on the same frames
/// whether they are read from a capture or from its bag.
#[test]
fn tilt_sigma_is_taken_alike_from_a_capture_and_its_bag() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    simulate_with_bag(
        tmp.path(),
        "2026-06-21T02:30:00Z",
        &["--width-px", "306", "--height-px", "256", "--headings-deg", "30,250"],
    );
    let tilt = ["--tilt-sigma-deg", "0.05"];
    let (cap, cap_json) = (p("cap"), p("cap.json"));
    let mut args = vec!["heading", &cap, "--json", &cap_json];
    args.extend_from_slice(&tilt);
    bpins(&args);
    let bag = p("bag");
    let bag_json = p("bag.json");
    let mut args = vec!["heading", "--bag", &bag, "--json", &bag_json];
    args.extend_from_slice(&["--bit-depth", "12", "--black-level-dn", "64", "--imu-topic", "/imu/data"]);
    args.extend_from_slice(&tilt);
    bpins(&args);
    let (cap, bag) = (json(&tmp.path().join("cap.json")), json(&tmp.path().join("bag.json")));
    for i in 0..2 {
        let h = |v: &Value| v["frames"][i]["heading_deg"].as_f64().unwrap();
        let s = |v: &Value| v["frames"][i]["sigma_deg"].as_f64().unwrap();
        assert!((h(&cap) - h(&bag)).abs() < 1e-4, "frame {i}: capture {}, bag {}", h(&cap), h(&bag));
        assert!((s(&cap) - s(&bag)).abs() < 1e-4, "frame {i}: capture 1σ {}, bag 1σ {}", s(&cap), s(&bag));
        assert!(cap["frames"][i]["sigma_parts_deg"]["tilt_deg"].as_f64().unwrap() > 0.005, "{cap}");
    }
}

/// Issue 48: a twilight lit by both the sun and the moon read from a bag (the sun
/// and the moon from each frame's stamp and the bag's /gnss/fix, `FrameSun::of`) as
/// from the capture it was written with: both sources, the same headings, 1σ and
/// fitted share.
#[test]
fn a_mixed_twilight_reads_alike_from_a_capture_and_its_bag() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    simulate_with_bag(
        tmp.path(),
        "2026-06-24T12:30:00Z",
        &["--width-px", "128", "--height-px", "128", "--headings-deg", "20,200", "--scene", "twilight"],
    );
    bpins(&["heading", &p("cap"), "--json", &p("cap.json")]);
    let bag = p("bag");
    let bag_json = p("bag.json");
    bpins(&["heading", "--bag", &bag, "--json", &bag_json, "--bit-depth", "12", "--black-level-dn", "64"]);
    let (cap, bag) = (json(&tmp.path().join("cap.json")), json(&tmp.path().join("bag.json")));
    for i in 0..2 {
        let (c, b) = (&cap["frames"][i], &bag["frames"][i]);
        let f = |v: &Value, k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
        let sun = b["sun"].as_str().unwrap();
        assert!(sun.contains("the moon (at 35.5°, 75 % lit) 50 %"), "frame {i}: {sun}");
        // The bag's frames are stamped 1 ms apart from the capture's time.
        assert!((f(c, "heading_deg") - f(b, "heading_deg")).abs() < 1e-3, "frame {i}: {c} / {b}");
        assert!((f(c, "sigma_deg") - f(b, "sigma_deg")).abs() < 1e-3, "frame {i}");
        assert!((f(c, "fitted_sun_share") - f(b, "fitted_sun_share")).abs() < 1e-3, "frame {i}");
    }
}

/// Issue 50 item 4: `heading --bag` (--bag-out, --json) and `bag-to-capture --out`
/// refuse an output in the bag reached through a symbolic link or through `..`.
#[test]
fn outputs_into_the_bag_through_a_link_or_dotdot_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    let place = ["--time-utc", "2026-06-21T02:30:00Z", "--latitude-deg", "36.07", "--longitude-deg", "120.38"];
    let (cap, bag) = (p("cap"), p("bag"));
    let mut args = vec!["simulate", "--out", &cap, "--bag-out", &bag, "--width-px", "96", "--height-px", "64"];
    args.extend_from_slice(&place);
    bpins(&args);
    bpins(&["simulate", "--out", &p("cap2"), "--width-px", "96", "--height-px", "64", "--headings-deg", "0"]);
    std::os::unix::fs::symlink(tmp.path().join("bag"), tmp.path().join("link")).unwrap();
    let listing = || {
        let mut v: Vec<_> = std::fs::read_dir(tmp.path().join("bag")).unwrap().map(|e| e.unwrap().path()).collect();
        v.sort();
        v
    };
    let before = listing();
    let sensor = ["--bit-depth", "12", "--black-level-dn", "64", "--imu-topic", "/imu/data"];
    for target in [p("link/out"), p("nowhere/../bag/out"), p("link/../bag/out"), p("link/deeper/out")] {
        let mut args = vec!["heading", "--bag", &bag, "--bag-out", &target];
        args.extend_from_slice(&sensor);
        assert!(bpins_fails(&args).contains("never writes into a bag"), "--bag-out {target}");
        let json = format!("{target}.json");
        let mut args = vec!["heading", "--bag", &bag, "--json", &json];
        args.extend_from_slice(&sensor);
        assert!(bpins_fails(&args).contains("never writes into a bag"), "--json {json}");
        let mut args = vec!["bag-to-capture", "--bag", &bag, "--out", &target, "--pixel-pitch-um", "27.6"];
        args.extend_from_slice(&sensor);
        assert!(bpins_fails(&args).contains("never writes into a bag"), "bag-to-capture --out {target}");
        assert_eq!(listing(), before, "an output through {target} changed the bag");
    }
    // A capture reached through a link is one too, for --json beside a bag.
    std::os::unix::fs::symlink(tmp.path().join("cap2"), tmp.path().join("caplink")).unwrap();
    let json = p("caplink/out.json");
    let mut args = vec!["heading", "--bag", &bag, "--json", &json];
    args.extend_from_slice(&sensor);
    assert!(bpins_fails(&args).contains("never writes into a capture"));
}

#[test]
fn a_bag_with_zstd_chunks_gives_the_headings_of_its_uncompressed_twin() {
    // rosbag2's MCAP plugin writes zstd chunks by default; rosbags (tests/ros.rs)
    // writes them uncompressed. The same messages in small zstd chunks (an image
    // spans several of the default size's worth; IMU samples share chunks) must give
    // `heading --bag` the same frames, to the bit.
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
        "10,130,260",
        "--sun-azimuth-deg",
        "40",
        "--sun-elevation-deg",
        "25",
        "--tilt-x-deg",
        "1",
        "--imu-sigma-deg",
        "0.1",
    ]);
    // The bag rewritten with zstd chunks of 16 KiB, messages in log-time order.
    let all = messages(Path::new(&p("bag")));
    let chunks = bpins_ros::writer::Chunks { zstd: true, size_bytes: 16 << 10 };
    let mut w = bpins_ros::writer::BagWriter::create_with(Path::new(&p("zstd")), chunks).unwrap();
    for (t, topic, ty, data) in &all {
        w.write(topic, ty, *t, data).unwrap();
    }
    w.finish().unwrap();
    let mcap = std::fs::read(tmp.path().join("zstd/zstd_0.mcap")).unwrap();
    assert!(mcap.windows(4).any(|w| w == [0x28, 0xb5, 0x2f, 0xfd]), "no zstd frame in the rewritten bag");
    let args = ["--sun-azimuth-deg", "40", "--sun-elevation-deg", "25", "--bit-depth", "12", "--black-level-dn", "64"];
    let mut headings = Vec::new();
    for name in ["bag", "zstd"] {
        let (b, j) = (p(name), p(&format!("{name}.json")));
        let mut a = vec!["heading", "--bag", &b, "--json", &j, "--imu-topic", "/imu/data"];
        a.extend_from_slice(&args);
        bpins(&a);
        headings.push(json(Path::new(&j))["frames"].clone());
    }
    assert_eq!(headings[0].as_array().unwrap().len(), 3);
    assert!(headings[0].as_array().unwrap().iter().all(|f| f["heading_deg"].is_f64()), "{}", headings[0]);
    assert_eq!(headings[0], headings[1], "the zstd bag's frames differ from the uncompressed bag's");
}

/// `bpins` with `args`, failing: its stderr.
fn bpins_fails(args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_bpins")).args(args).output().unwrap();
    assert!(!o.status.success(), "{args:?} succeeded:\n{}", String::from_utf8_lossy(&o.stdout));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn the_docs_bag_commands_run_as_written_on_the_docs_simulated_bag() {
    // docs/ros2.md's test stack (`simulate --bag-out`) holds two sensor_msgs/Imu topics:
    // the IMU (/imu/data) and the truth (/bpins/reference_heading). The truth is
    // bpins' own output, never taken for the IMU, so the README's and docs/ros2.md's
    // commands, which name no --imu-topic, read the IMU.
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    let (cap, run1) = (p("cap"), p("run1"));
    bpins(&[
        "simulate",
        "--out",
        &cap,
        "--bag-out",
        &run1,
        "--time-utc",
        "2026-06-21T02:30:00Z",
        "--latitude-deg",
        "36.07",
        "--longitude-deg",
        "120.38",
        "--tilt-x-deg",
        "2",
    ]);
    let meta = std::fs::read_to_string(tmp.path().join("run1/metadata.yaml")).unwrap();
    assert!(meta.contains(bpins_ros::topics::REFERENCE_HEADING) && meta.contains(bpins_ros::topics::IMU), "{meta}");
    // README.md, "Robot logs": exactly its flags.
    let (out, json_path) = (p("run1_bpins"), p("run1.json"));
    let o = bpins(&["heading", "--bag", &run1, "--bit-depth", "12", "--black-level-dn", "64", "--bag-out", &out]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("tilt from /imu/data (/bpins/reference_heading not read: bpins' own output"),
        "the tilt's source is not said:\n{err}"
    );
    assert!(Path::new(&out).join("metadata.yaml").is_file());
    // docs/ros2.md, "The whole path": its flags, and the tilt read from the IMU.
    bpins(&[
        "heading",
        "--bag",
        &run1,
        "--bit-depth",
        "12",
        "--black-level-dn",
        "64",
        "--json",
        &json_path,
        "--bag-out",
        &p("run1_bpins2"),
        "--heading-frame-id",
        "bpins_body",
    ]);
    let frames = json(Path::new(&json_path))["frames"].as_array().unwrap().clone();
    assert_eq!(frames.len(), 8);
    for f in &frames {
        assert!(f["heading_deg"].is_f64(), "{f}");
        assert!((f["tilt_x_deg"].as_f64().unwrap() - 2.0).abs() < 1e-6, "the tilt is not the IMU's: {f}");
    }
    // docs/ros2.md: the recorded frames into a capture, exactly its flags.
    let run1_cap = p("run1_cap");
    bpins(&[
        "bag-to-capture",
        "--bag",
        &run1,
        "--out",
        &run1_cap,
        "--bit-depth",
        "12",
        "--black-level-dn",
        "64",
        "--pixel-pitch-um",
        "3.45",
    ]);
    let toml = std::fs::read_to_string(tmp.path().join("run1_cap/capture.toml")).unwrap();
    assert_eq!(toml.matches("[[frames]]").count(), 8, "{toml}");
    let tilts: Vec<f64> =
        toml.lines().filter_map(|l| l.strip_prefix("tilt_x_deg = ")).map(|v| v.trim().parse().unwrap()).collect();
    assert!(tilts.len() == 8 && tilts.iter().all(|t| (t - 2.0).abs() < 1e-6), "the tilt is not the IMU's:\n{toml}");
    // Named, the truth is read like any topic.
    bpins(&["heading", "--bag", &run1, "--bit-depth", "12", "--imu-topic", "/bpins/reference_heading"]);
}

#[test]
fn two_imus_are_an_error_naming_both_and_the_topic_left_out() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    bpins(&[
        "simulate",
        "--out",
        &p("cap"),
        "--bag-out",
        &p("bag"),
        "--width-px",
        "100",
        "--height-px",
        "80",
        "--headings-deg",
        "10,20",
    ]);
    // The bag again with a second IMU, /imu/second.
    let mut all = messages(Path::new(&p("bag")));
    let second: Vec<_> = all
        .iter()
        .filter(|m| m.1 == bpins_ros::topics::IMU)
        .map(|(t, _, ty, data)| (*t, "/imu/second".to_string(), ty.clone(), data.clone()))
        .collect();
    all.extend(second);
    all.sort_by_key(|m| m.0);
    let mut w = bpins_ros::writer::BagWriter::create(Path::new(&p("two"))).unwrap();
    for (t, topic, ty, data) in &all {
        w.write(topic, ty, *t, data).unwrap();
    }
    w.finish().unwrap();
    let (two, c) = (p("two"), p("c"));
    let sun = ["--sun-azimuth-deg", "40", "--sun-elevation-deg", "25"];
    for cmd in [vec!["heading", "--bag", &two], vec!["bag-to-capture", "--bag", &two, "--out", &c]] {
        let cmd = [&cmd[..], &sun[..]].concat();
        let cmd = &cmd[..];
        let err = bpins_fails(cmd);
        assert!(
            err.contains("2 topics of type sensor_msgs/msg/Imu (/imu/data, /imu/second)")
                && err.contains("besides bpins' own output /bpins/reference_heading")
                && err.contains("choose one with --imu-topic"),
            "{cmd:?}:\n{err}"
        );
    }
    let mut args = vec!["heading", "--bag", &two, "--imu-topic", "/imu/second"];
    args.extend_from_slice(&sun);
    bpins(&args);
}

/// Issue 50 item 3: rows padded beyond their pixels (`step` > row bytes, by an odd
/// number of bytes too), in mono16 of either byte order and in mono8, give
/// `bag-to-capture` the unpadded bag's capture, file for file and bit for bit, and
/// `heading --bag` its frames. (`bag-to-capture` stopped on padded little-endian
/// mono16 rows, "mosaic has 317432 values, expected 313344": it copied the padding.)
#[test]
fn padded_rows_give_the_unpadded_bags_capture_and_headings() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    let sun = ["--sun-azimuth-deg", "40", "--sun-elevation-deg", "25"];
    // A 12-bit camera (DN above 255: both bytes of mono16 matter), and an 8-bit one
    // whose DN fit mono8.
    for (name, bits, black, layouts) in [
        (
            "b12",
            "12",
            "64",
            &[("mono16", false, 2), ("mono16", false, 3), ("mono16", true, 0), ("mono16", true, 5)][..],
        ),
        ("b8", "8", "4", &[("mono8", false, 0), ("mono8", false, 3), ("mono8", false, 4), ("mono16", true, 1)][..]),
    ] {
        let (cap, bag) = (p(&format!("{name}_cap")), p(&format!("{name}_bag")));
        let mut args = vec!["simulate", "--out", &cap, "--bag-out", &bag, "--width-px", "306", "--height-px", "256"];
        args.extend_from_slice(&["--pixel-pitch-um", "27.6", "--headings-deg", "30,250", "--tilt-x-deg", "1"]);
        args.extend_from_slice(&["--imu-sigma-deg", "0.1", "--bit-depth", bits, "--black-level-dn", black]);
        args.extend_from_slice(&sun);
        bpins(&args);
        let mut read = vec!["--imu-topic", "/imu/data", "--bit-depth", bits, "--black-level-dn", black];
        read.extend_from_slice(&sun);
        // The simulated bag: mono16, little-endian, rows unpadded.
        let want = bag_route(Path::new(&bag), &p(&format!("{name}_out")), &read);
        assert!(want.0.as_array().unwrap().iter().all(|f| f["heading_deg"].is_f64()), "{}", want.0);
        assert_eq!(
            want.1.len(),
            3,
            "capture.toml and two frames: {:?}",
            want.1.iter().map(|f| &f.0).collect::<Vec<_>>()
        );
        for &(encoding, big, pad) in layouts {
            let tag = format!("{name}_{encoding}_{}_pad{pad}", if big { "be" } else { "le" });
            let b = p(&tag);
            relayout(Path::new(&bag), Path::new(&b), encoding, big, pad);
            let got = bag_route(Path::new(&b), &p(&format!("{tag}_out")), &read);
            assert_eq!(got.0, want.0, "{tag}: heading --bag's frames differ from the unpadded bag's");
            for (g, w) in got.1.iter().zip(&want.1) {
                assert!(g == w, "{tag}: bag-to-capture's {} differs from the unpadded bag's {}", g.0, w.0);
            }
            assert_eq!(got.1.len(), want.1.len(), "{tag}");
        }
    }
}

/// `heading --bag` (its JSON's frames) and `bag-to-capture` (every file of the
/// capture written at `out`: name and bytes) of the bag at `bag`, with `args`.
fn bag_route(bag: &Path, out: &str, args: &[&str]) -> (Value, Vec<(String, Vec<u8>)>) {
    let (b, j) = (bag.to_str().unwrap(), format!("{out}.json"));
    bpins(&[&["heading", "--bag", b, "--json", &j][..], args].concat());
    bpins(&[&["bag-to-capture", "--bag", b, "--out", out, "--pixel-pitch-um", "27.6"][..], args].concat());
    let mut files = Vec::new();
    let mut dirs = vec![PathBuf::from(out)];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else {
                files.push((p.strip_prefix(out).unwrap().display().to_string(), std::fs::read(&p).unwrap()));
            }
        }
    }
    files.sort();
    (json(Path::new(&j))["frames"].clone(), files)
}

/// The bag at `src` written again at `dst`, each image's DN (mono16, little-endian,
/// unpadded) rewritten as `encoding` (`mono8` or `mono16`), big-endian if `big`, and
/// `pad` bytes (0xAB) after each row; every other message as it was.
fn relayout(src: &Path, dst: &Path, encoding: &str, big: bool, pad: usize) {
    use bpins_ros::msgs::{types, Image};
    let mut w = bpins_ros::writer::BagWriter::create(dst).unwrap();
    for (t, topic, ty, data) in messages(src) {
        let data = if ty == types::IMAGE {
            let im: Image = bpins_ros::cdr::decode(&data).unwrap();
            assert_eq!((im.encoding.as_str(), im.is_bigendian, im.step), ("mono16", 0, 2 * im.width));
            let mut rows = Vec::new();
            for row in im.data.chunks_exact(im.step as usize) {
                for px in row.chunks_exact(2) {
                    let dn = u16::from_le_bytes([px[0], px[1]]);
                    match (encoding, big) {
                        ("mono8", _) => rows.push(u8::try_from(dn).expect("8-bit DN")),
                        (_, true) => rows.extend(dn.to_be_bytes()),
                        (_, false) => rows.extend(dn.to_le_bytes()),
                    }
                }
                rows.extend(std::iter::repeat_n(0xABu8, pad));
            }
            let step = (rows.len() / im.height as usize) as u32;
            let padded = Image {
                encoding: encoding.into(),
                is_bigendian: big as u8,
                step,
                data: std::borrow::Cow::Owned(rows),
                ..im.clone()
            };
            bpins_ros::cdr::encode(&padded)
        } else {
            data
        };
        w.write(&topic, &ty, t, &data).unwrap();
    }
    w.finish().unwrap();
}

/// Every message of the bag at `dir`: (log time ns, topic, type, CDR bytes), in log-time
/// order (a stable sort: each topic's messages keep their order).
fn messages(dir: &Path) -> Vec<(i64, String, String, Vec<u8>)> {
    let bag = bpins_ros::Bag::open(dir).unwrap();
    let mut all = Vec::new();
    for t in &bag.topics {
        for m in bag.cursor(&t.name).unwrap() {
            let m = m.unwrap();
            all.push((m.log_time_ns, t.name.clone(), t.type_name.clone(), m.data.into_owned()));
        }
    }
    all.sort_by_key(|m| m.0);
    all
}
