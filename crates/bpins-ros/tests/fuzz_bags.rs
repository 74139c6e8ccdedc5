//! Fuzzing the bag reader: proptest damages valid bags (MCAP files with uncompressed
//! or zstd chunks and sqlite3 files cut
//! short, bytes flipped or inserted, metadata.yaml cut or flipped, message bytes
//! flipped inside the sqlite3 rows) and raw CDR messages, and reading every topic
//! through the mappings bpins uses (image → mosaic, CameraInfo → intrinsics, Imu →
//! tilt, NavSatFix → place) must end in values or in an error naming the bag, never a
//! panic, and never a write into the bag.
//!
//! 64 cases per property in the test command; longer on demand:
//! `BPINS_FUZZ_CASES=20000 cargo test --release -p bpins-ros --test fuzz_bags`.

use bpins_core::sensor::ColourTiles;
use bpins_ros::cdr::{decode, encode};
use bpins_ros::convert::{camera_size_px, imu_orientation, intrinsics, mosaic, tilt_of};
use bpins_ros::matching::{decode_fix, decode_imu};
use bpins_ros::metadata::Metadata;
use bpins_ros::msgs::{types, CameraInfo, Header, Image, Imu, NavSatFix, Time};
use bpins_ros::writer::{BagWriter, Chunks};
use bpins_ros::Bag;
use proptest::prelude::*;
use std::borrow::Cow;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

fn cases() -> u32 {
    std::env::var("BPINS_FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(64)
}

const W: u32 = 8;
const H: u32 = 6;

/// The messages of one small bag: three frames, each with CameraInfo, two Imu
/// samples and a NavSatFix, in time order: (topic, type, time, bytes).
fn messages() -> Vec<(&'static str, &'static str, i64, Vec<u8>)> {
    let mut out = Vec::new();
    for i in 0..3i64 {
        let t = 1_782_009_000_000_000_000 + i * 100_000_000;
        let header = |t: i64| Header { stamp: Time::from_ns(t), frame_id: "cam".into() };
        let ci = CameraInfo {
            header: header(t),
            width: W,
            height: H,
            distortion_model: "plumb_bob".into(),
            d: vec![0.0; 5],
            k: [10.0, 0.0, 3.5, 0.0, 10.0, 2.5, 0.0, 0.0, 1.0],
            ..Default::default()
        };
        out.push(("/cam/camera_info", types::CAMERA_INFO, t, encode(&ci)));
        for dt in [-5_000_000, 5_000_000] {
            let mut imu = Imu { header: header(t + dt), ..Default::default() };
            imu.orientation.w = 1.0;
            imu.orientation_covariance[0] = 1e-6;
            imu.orientation_covariance[4] = 1e-6;
            out.push(("/imu", types::IMU, t + dt, encode(&imu)));
        }
        let fix = NavSatFix { header: header(t), latitude: 36.07, longitude: 120.38, ..Default::default() };
        out.push(("/fix", types::NAV_SAT_FIX, t, encode(&fix)));
        let data: Vec<u8> = (0..W * H).flat_map(|k| ((k * 37 + i as u32) as u16 % 4000).to_le_bytes()).collect();
        let im = Image {
            header: header(t),
            height: H,
            width: W,
            encoding: "mono16".into(),
            is_bigendian: 0,
            step: 2 * W,
            data: Cow::Owned(data),
        };
        out.push(("/cam/image_raw", types::IMAGE, t, encode(&im)));
    }
    out.sort_by_key(|m| m.2);
    out
}

/// A valid MCAP bag and a valid sqlite3 bag of [`messages`], written once.
fn bases() -> &'static (tempfile::TempDir, PathBuf, PathBuf) {
    static B: std::sync::OnceLock<(tempfile::TempDir, PathBuf, PathBuf)> = std::sync::OnceLock::new();
    B.get_or_init(|| {
        let tmp = tempfile::tempdir().unwrap();
        let mcap = tmp.path().join("mcap_bag");
        let mut w = BagWriter::create(&mcap).unwrap();
        for (topic, ty, t, bytes) in messages() {
            w.write(topic, ty, t, &bytes).unwrap();
        }
        w.finish().unwrap();
        let sq = tmp.path().join("sqlite_bag");
        write_sqlite_bag(&sq);
        (tmp, mcap, sq)
    })
}

/// A valid MCAP bag of [`messages`] in small zstd chunks (rosbag2's MCAP default is
/// zstd), written once.
fn zstd_base() -> &'static (tempfile::TempDir, PathBuf) {
    static B: std::sync::OnceLock<(tempfile::TempDir, PathBuf)> = std::sync::OnceLock::new();
    B.get_or_init(|| {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("zstd_bag");
        let mut w = BagWriter::create_with(&dir, Chunks { zstd: true, size_bytes: 512 }).unwrap();
        for (topic, ty, t, bytes) in messages() {
            w.write(topic, ty, t, &bytes).unwrap();
        }
        w.finish().unwrap();
        read_all(&dir).expect("the undamaged zstd bag reads");
        (tmp, dir)
    })
}

/// A sqlite3 bag as rosbag2 (Humble) lays it out.
fn write_sqlite_bag(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let db = rusqlite::Connection::open(dir.join("sqlite_bag_0.db3")).unwrap();
    db.execute_batch(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, \
         serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL); \
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, \
         data BLOB NOT NULL);",
    )
    .unwrap();
    let mut topics: Vec<(&str, &str, u64)> = Vec::new();
    for (topic, ty, t, bytes) in messages() {
        let id = match topics.iter().position(|x| x.0 == topic) {
            Some(i) => i,
            None => {
                topics.push((topic, ty, 0));
                db.execute(
                    "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')",
                    rusqlite::params![topics.len() as i64, topic, ty],
                )
                .unwrap();
                topics.len() - 1
            }
        };
        topics[id].2 += 1;
        db.execute(
            "INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
            rusqlite::params![id as i64 + 1, t, bytes],
        )
        .unwrap();
    }
    drop(db);
    let m = Metadata {
        version: 5,
        storage_identifier: "sqlite3".into(),
        relative_file_paths: vec!["sqlite_bag_0.db3".into()],
        duration: Default::default(),
        starting_time: Default::default(),
        message_count: topics.iter().map(|t| t.2).sum(),
        topics_with_message_count: topics.iter().map(|t| Metadata::topic(t.0, t.1, t.2)).collect(),
        compression_format: String::new(),
        compression_mode: String::new(),
        files: Vec::new(),
        ros_distro: None,
    };
    std::fs::write(dir.join("metadata.yaml"), m.to_yaml()).unwrap();
}

/// Reads every topic of the bag at `dir` through bpins' mappings: the number of
/// messages that mapped to values, or the first error's text.
fn read_all(dir: &Path) -> Result<usize, String> {
    let bag = Bag::open(dir).map_err(|e| e.to_string())?;
    let mut ok = 0;
    let mut scratch = Vec::new();
    for t in bag.topics.clone() {
        for m in bag.cursor(&t.name).map_err(|e| e.to_string())? {
            let m = m.map_err(|e| e.to_string())?;
            let mapped = match t.type_name.as_str() {
                types::IMAGE => decode::<Image>(&m.data).and_then(|im| mosaic(&im, None, &mut scratch).map(|_| ())),
                types::CAMERA_INFO => decode::<CameraInfo>(&m.data).and_then(|ci| {
                    let _ = camera_size_px(&ci);
                    intrinsics(&ci).map(|_| ())
                }),
                types::IMU => decode::<Imu>(&m.data)
                    .and_then(|imu| imu_orientation(&imu))
                    .and_then(|(q, r, p)| tilt_of(q, r, p).map(|_| ())),
                types::NAV_SAT_FIX => decode_fix(&m.data).map(|_| ()),
                _ => Ok(()),
            };
            if mapped.is_ok() {
                ok += 1;
            }
        }
    }
    Ok(ok)
}

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

#[derive(Clone, Debug)]
enum Damage {
    Cut(f64),
    Flip(f64, u8),
    Insert(f64, Vec<u8>),
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        (0.0..1.0f64).prop_map(Damage::Cut),
        (0.0..1.0f64, 1..=255u8).prop_map(|(at, x)| Damage::Flip(at, x)),
        (0.0..1.0f64, prop::collection::vec(any::<u8>(), 1..16)).prop_map(|(at, b)| Damage::Insert(at, b)),
    ]
}

fn apply(bytes: &mut Vec<u8>, d: &Damage) {
    let at = |f: f64, n: usize| ((f * n as f64) as usize).min(n.saturating_sub(1));
    match d {
        Damage::Cut(f) => bytes.truncate(at(*f, bytes.len())),
        Damage::Flip(f, x) => {
            let i = at(*f, bytes.len());
            if let Some(b) = bytes.get_mut(i) {
                *b ^= x;
            }
        }
        Damage::Insert(f, b) => {
            let i = at(*f, bytes.len());
            bytes.splice(i..i, b.iter().copied());
        }
    }
}

/// Copies the bag at `src`, damages the file named `file` of it, reads the copy.
fn damaged(src: &Path, file: &str, ds: &[Damage]) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join(src.file_name().unwrap());
    std::fs::create_dir(&dir).unwrap();
    for e in std::fs::read_dir(src).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
    }
    let target = dir.join(file);
    let mut bytes = std::fs::read(&target).unwrap();
    for d in ds {
        apply(&mut bytes, d);
    }
    std::fs::write(&target, &bytes).unwrap();
    let before = snapshot(&dir);
    let r = catch_unwind(AssertUnwindSafe(|| read_all(&dir)));
    let r = r.unwrap_or_else(|_| panic!("the reader panicked on {file} damaged by {ds:?}"));
    if let Err(e) = r {
        assert!(e.contains(&dir.display().to_string()), "error without the bag's name: {e}");
    }
    assert!(snapshot(&dir) == before, "the bag was written to");
}

#[test]
fn the_undamaged_bags_read_whole() {
    let (_, mcap, sq) = bases();
    assert_eq!(read_all(mcap), Ok(15));
    assert_eq!(read_all(sq), Ok(15));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

    #[test]
    fn damaged_mcap_files(ds in prop::collection::vec(damage(), 1..4)) {
        damaged(&bases().1, "mcap_bag_0.mcap", &ds);
    }

    #[test]
    fn damaged_zstd_mcap_files(ds in prop::collection::vec(damage(), 1..4)) {
        damaged(&zstd_base().1, "zstd_bag_0.mcap", &ds);
    }

    #[test]
    fn damaged_sqlite_files(ds in prop::collection::vec(damage(), 1..3)) {
        damaged(&bases().2, "sqlite_bag_0.db3", &ds);
    }

    #[test]
    fn damaged_metadata(ds in prop::collection::vec(damage(), 1..4), sqlite in any::<bool>()) {
        let b = bases();
        damaged(if sqlite { &b.2 } else { &b.1 }, "metadata.yaml", &ds);
    }

    #[test]
    fn damaged_messages(which in 0usize..15, ds in prop::collection::vec(damage(), 1..4)) {
        // Inside a valid storage file: the rows of a sqlite3 bag rewritten.
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("sqlite_bag");
        std::fs::create_dir(&dir).unwrap();
        for e in std::fs::read_dir(&bases().2).unwrap() {
            let p = e.unwrap().path();
            std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
        }
        {
            let db = rusqlite::Connection::open(dir.join("sqlite_bag_0.db3")).unwrap();
            let mut data: Vec<u8> = db.query_row("SELECT data FROM messages WHERE id = ?1", [which as i64 + 1], |r| r.get(0)).unwrap();
            for d in &ds {
                apply(&mut data, d);
            }
            db.execute("UPDATE messages SET data = ?1 WHERE id = ?2", rusqlite::params![data, which as i64 + 1]).unwrap();
        }
        let r = catch_unwind(AssertUnwindSafe(|| read_all(&dir)));
        prop_assert!(r.is_ok(), "the reader panicked on message {} damaged by {:?}", which, ds);
    }

    #[test]
    fn random_cdr(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let mut scratch = Vec::new();
        let r = catch_unwind(AssertUnwindSafe(|| {
            if let Ok(im) = decode::<Image>(&bytes) { let _ = mosaic(&im, None, &mut scratch); let _ = mosaic(&im, Some(&ColourTiles::imx250myr()), &mut scratch); }
            if let Ok(ci) = decode::<CameraInfo>(&bytes) { let _ = intrinsics(&ci); }
            let _ = decode_imu(&bytes);
            let _ = decode_fix(&bytes);
        }));
        prop_assert!(r.is_ok());
    }
}
