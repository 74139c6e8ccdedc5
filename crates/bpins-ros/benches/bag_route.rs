//! Criterion benchmark of the bag route (`cargo bench -p bpins-ros --bench
//! bag_route`): one frame of `bpins heading --bag` against the front door alone.
//!
//! * `bag_route/dofp_512x612_compass`, `…_2048x2448_compass`: the front door
//!   (`Compass::heading`) on a u16 mosaic in memory, as `bpins-core`'s field bench.
//! * `bag_route/dofp_*_mcap`, `…_sqlite3`: the same frame read from a bag, per
//!   frame what `crates/bpins-cli/src/cmd_heading_bag.rs` does: the image topic's
//!   next message (MCAP mapped; sqlite3 row; the image and IMU cursors served by one
//!   walk of the storage, `Bag::cursors`), CDR decoded, its mono16 pixels into a
//!   reused buffer, the IMU samples around its stamp slerped, then the compass.
//!   Target (issue 32): ≤ 1.5 × the front door's time per frame.
//! * `bag_route/dofp_*_mcap_read_only`, `…_sqlite3_read_only`: the same without the
//!   compass: the reading the route adds, single-threaded (on a loaded machine the
//!   least disturbed way to say what the route costs an idle one).

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{Attitude, Compass, CompassConfig, RawImage, Sun};
use bpins_core::render::{Renderer, RendererConfig, View};
use bpins_core::sensor::Response;
use bpins_core::NoiseIndex;
use bpins_ros::cdr::{decode, encode};
use bpins_ros::convert::{mosaic, Mosaic};
use bpins_ros::matching::{decode_imu, tilt_at, ImuMatch, ImuSample, Track};
use bpins_ros::msgs::{types, Header, Image, Imu, Time};
use bpins_ros::rep103::enu_quaternion;
use bpins_ros::writer::BagWriter;
use bpins_ros::{Bag, TopicCursor};
use criterion::{criterion_group, criterion_main, Criterion};
use std::borrow::Cow;
use std::hint::black_box;
use std::path::Path;

const FRAMES: i64 = 8;

/// An MCAP bag (through bpins' writer) of FRAMES copies of `dn`, with IMU samples
/// 5 ms before and after each at the frame's tilt.
fn write_bag(dir: &Path, dn: &[u16], w: usize, h: usize) {
    let mut bag = BagWriter::create(dir).unwrap();
    for i in 0..FRAMES {
        let t = 1_782_009_000_000_000_000 + i * 100_000_000;
        for dt in [-5_000_000, 5_000_000] {
            let [x, y, z, qw] = enu_quaternion(0.0, 4.0, -3.0);
            let mut imu =
                Imu { header: Header { stamp: Time::from_ns(t + dt), frame_id: "imu".into() }, ..Default::default() };
            imu.orientation = bpins_ros::msgs::Quaternion { x, y, z, w: qw };
            imu.orientation_covariance[0] = 0.1f64.to_radians().powi(2);
            imu.orientation_covariance[4] = 0.1f64.to_radians().powi(2);
            bag.write("/imu", types::IMU, t + dt, &encode(&imu)).unwrap();
        }
        let im = Image {
            header: Header { stamp: Time::from_ns(t), frame_id: "cam".into() },
            height: h as u32,
            width: w as u32,
            encoding: "mono16".into(),
            is_bigendian: 0,
            step: 2 * w as u32,
            data: Cow::Owned(dn.iter().flat_map(|x| x.to_le_bytes()).collect()),
        };
        bag.write("/cam/image_raw", types::IMAGE, t, &encode(&im)).unwrap();
    }
    bag.finish().unwrap();
}

/// The same bag in sqlite3 storage: the MCAP bag's messages copied into rosbag2's
/// tables.
fn write_sqlite(mcap_dir: &Path, dir: &Path) {
    let bag = Bag::open(mcap_dir).unwrap();
    std::fs::create_dir_all(dir).unwrap();
    let db = rusqlite::Connection::open(dir.join("b_0.db3")).unwrap();
    db.execute_batch(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, \
         serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL); \
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, \
         data BLOB NOT NULL);",
    )
    .unwrap();
    let mut meta = bag.metadata.clone();
    for (k, t) in bag.topics.iter().enumerate() {
        db.execute(
            "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')",
            rusqlite::params![k as i64 + 1, t.name, t.type_name],
        )
        .unwrap();
        for m in bag.cursor(&t.name).unwrap() {
            let m = m.unwrap();
            db.execute(
                "INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
                rusqlite::params![k as i64 + 1, m.log_time_ns, &m.data[..]],
            )
            .unwrap();
        }
    }
    meta.storage_identifier = "sqlite3".into();
    meta.relative_file_paths = vec!["b_0.db3".into()];
    meta.files.clear();
    std::fs::write(dir.join("metadata.yaml"), meta.to_yaml()).unwrap();
}

/// The image cursor and the IMU track, served by one walk of the bag (as the CLI reads).
fn cursors(bag: &Bag) -> (TopicCursor<'_>, Track<'_, ImuSample>) {
    let mut c = bag.cursors(&["/cam/image_raw", "/imu"]).unwrap();
    let imu = Track::new(c.pop().unwrap(), decode_imu);
    (c.pop().unwrap(), imu)
}

fn route(c: &mut Criterion) {
    let tmp = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("bag_route");
    for (w, h, pitch, name) in [(612usize, 512usize, 13.8, "dofp_512x612"), (2448, 2048, 3.45, "dofp_2048x2448")] {
        let intr = Intrinsics::new(Projection::Pinhole, 8000.0 / pitch, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
        let renderer = Renderer::new(RendererConfig::dofp(intr, w, h, Response::samples(3000.0))).unwrap();
        let view = View {
            sun_azimuth_deg: 40.0,
            sun_elevation_deg: 25.0,
            heading_deg: 30.0,
            tilt_x_deg: 4.0,
            tilt_y_deg: -3.0,
        };
        let mut dn = Vec::new();
        renderer.raw_frame(&view, NoiseIndex { seed: 1, trial: 0, frame: 0 }).unwrap().to_u16_into(&mut dn);
        let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
        let att = Attitude { tilt_x_deg: 4.0, tilt_y_deg: -3.0, sigma_deg: 0.1 };
        let mut compass = Compass::new(CompassConfig::dofp(intr, w, h, 12, 64.0)).unwrap();
        g.bench_function(format!("{name}_compass"), |b| {
            b.iter(|| black_box(compass.heading(RawImage::packed(&dn, w, h), sun, att).unwrap()))
        });
        let mcap_dir = tmp.path().join(format!("{name}_mcap"));
        write_bag(&mcap_dir, &dn, w, h);
        let sqlite_dir = tmp.path().join(format!("{name}_sqlite3"));
        write_sqlite(&mcap_dir, &sqlite_dir);
        for (storage, dir) in [("mcap", &mcap_dir), ("sqlite3", &sqlite_dir)] {
            let bag = Bag::open(dir).unwrap();
            let mut scratch: Vec<u16> = Vec::new();
            let (mut images, mut imu) = cursors(&bag);
            g.bench_function(format!("{name}_{storage}"), |b| {
                b.iter(|| {
                    let m = match images.next() {
                        Some(m) => m.unwrap(),
                        None => {
                            // The bag replayed from its start (outside no timing: a
                            // cursor's start is part of a long bag's cost too).
                            (images, imu) = cursors(&bag);
                            images.next().unwrap().unwrap()
                        }
                    };
                    let im: Image = decode(&m.data).unwrap();
                    let t = tilt_at(&mut imu, im.header.stamp.ns(), ImuMatch::Interpolate, 0.05).unwrap().unwrap();
                    let att = Attitude { tilt_x_deg: t.tilt_x_deg, tilt_y_deg: t.tilt_y_deg, sigma_deg: t.sigma_deg() };
                    let r = match mosaic(&im, None, &mut scratch).unwrap() {
                        Mosaic::U16(r) => compass.heading(r, sun, att),
                        Mosaic::U8(r) => compass.heading(r, sun, att),
                    };
                    black_box(r.unwrap())
                })
            });
            // The reading alone (everything above but the compass): what the route
            // adds to the front door, on one core.
            let (mut images, mut imu) = cursors(&bag);
            g.bench_function(format!("{name}_{storage}_read_only"), |b| {
                b.iter(|| {
                    let m = match images.next() {
                        Some(m) => m.unwrap(),
                        None => {
                            (images, imu) = cursors(&bag);
                            images.next().unwrap().unwrap()
                        }
                    };
                    let im: Image = decode(&m.data).unwrap();
                    let t = tilt_at(&mut imu, im.header.stamp.ns(), ImuMatch::Interpolate, 0.05).unwrap().unwrap();
                    let sum = match mosaic(&im, None, &mut scratch).unwrap() {
                        Mosaic::U16(r) => r.data[r.data.len() / 2] as u64,
                        Mosaic::U8(r) => r.data[r.data.len() / 2] as u64,
                    };
                    black_box((sum, t))
                })
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = route
}
criterion_main!(benches);
