//! Captures and bags both ways: `bpins bag-to-capture` (a bag's frames and their
//! sun and tilt into a `bpins-capture/1` folder, for `fit`, `diagnose` and
//! `calibrate`) and `bpins simulate --bag-out` (a capture as a ROS 2 bag, for a
//! robot's stack on a sky whose truth is known). Both hold one frame in memory.

use crate::bag::{bag_at, BagArgs};
use anyhow::{anyhow, bail, Context};
use bpins_core::camera::Projection;
use bpins_core::sensor::Layout;
use bpins_core::SunSource;
use bpins_core::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
use bpins_ros::cdr::{decode, encode};
use bpins_ros::convert::mosaic;
use bpins_ros::msgs::{types, CameraInfo, Header, Image, NavSatFix, NavSatStatus, Time};
use bpins_ros::writer::BagWriter;
use bpins_ros::{rep103, topics};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// `bpins bag-to-capture`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    bag: BagArgs,
    /// The new capture folder (must not hold a capture.toml).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Pixel pitch, micrometres, where no sensor file gives it (a capture records
    /// the focal length in mm and the pitch; CameraInfo gives f in pixels).
    #[arg(long)]
    pixel_pitch_um: Option<f64>,
}

pub fn bag_to_capture(a: Args) -> anyhow::Result<()> {
    if a.bag.bag.is_none() {
        bail!("--bag DIR is required");
    }
    let input = a.bag.open()?;
    say!("bag {}: images on {}, tilt from {}", input.bag.dir.display(), input.image_topic, input.tilt_source());
    crate::ensure_not_in_input(&a.out, &[&input.bag.dir]).context("--out")?;
    let intr = input.intrinsics;
    if intr.distortion != [0.0; 2] {
        bail!(
            "{}: distortion {:?} cannot be recorded in a capture (CAPTURE.md has no distortion key)",
            input.intrinsics_source,
            intr.distortion
        );
    }
    let mut sensor: SensorSpec = input.sensor.clone();
    if let Some(p) = a.pixel_pitch_um {
        sensor.geometry.pixel_pitch_um = p;
    }
    let pitch = sensor.geometry.pixel_pitch_um;
    if pitch.is_nan() || pitch <= 0.0 {
        bail!("no pixel pitch: give --pixel-pitch-um or a sensor file (--sensor)");
    }
    let lens = match &input.lens {
        Some(l) if input.intrinsics_source.starts_with("sensor file") => l.clone(),
        _ => LensSpec {
            projection: intr.projection,
            focal_length_mm: intr.f_px * pitch / 1000.0,
            principal_point_px: (intr.cx_px, intr.cy_px),
        },
    };
    // Pass 1: which frames have a sun and a tilt, and their [[frames]] entries.
    let mut specs = Vec::new();
    let mut kept = Vec::new();
    let mut frames = input.frames(&a.bag)?;
    while let Some(f) = frames.next_frame()? {
        match (&f.sun, &f.tilt) {
            (Ok(sun), Ok(t)) => {
                specs.push(FrameSpec {
                    tilt_x_deg: Some(t.tilt_x_deg),
                    tilt_y_deg: Some(t.tilt_y_deg),
                    tilt_sigma_deg: Some(t.sigma_deg()),
                    sun_sigma_deg: (a.bag.sun_sigma_deg > 0.0).then_some(a.bag.sun_sigma_deg),
                    ..FrameSpec::new(format!("frames/m{:06}.png", f.message.index), sun.clone())
                });
                kept.push(f.message.index);
            }
            (Err(w), _) | (_, Err(w)) => say!("message {}: skipped: {w}", f.message.index),
        }
    }
    if specs.is_empty() {
        bail!("bag {}: no frame has both a sun and a tilt; nothing to write", input.bag.dir.display());
    }
    let capture = Capture { dir: input.bag.dir.clone(), sensor, lens, frames: specs };
    capture.validate()?;
    // Pass 2: the pixels of the frames kept, frame by frame. The capture's frames are
    // listed in capture.toml, which is written first (bpins-capture/1), so the pixels
    // come in a second walk; it reads the image topic alone (the sun and tilt are
    // known) and stops after the last frame kept.
    let mut w = capture.writer(&a.out)?;
    let pb = crate::progress::bar(kept.len() as u64, "frames");
    let mut scratch = Vec::new();
    let g = capture.sensor.geometry;
    let mut wanted = kept.iter().copied().peekable();
    for m in input.bag.cursor(&input.image_topic)? {
        let Some(&next) = wanted.peek() else { break };
        let m = m?;
        if m.index != next {
            continue;
        }
        wanted.next();
        let at = || bag_at(&input.bag, &input.image_topic, m.index);
        let im: Image = decode(&m.data).map_err(|e| anyhow!("{}: {e}", at()))?;
        // Row by row, each row's padding (step beyond the pixels) left out, in
        // whichever encoding and byte order the bag has.
        let dn = mosaic(&im, capture.sensor.colour.as_ref(), &mut scratch)
            .map_err(|e| anyhow!("{}: {e}", at()))?
            .packed_dn_f32();
        w.write_frame(&FrameData::Mosaic { width_px: g.width_px, height_px: g.height_px, dn })?;
        pb.inc(1);
    }
    if let Some(missing) = wanted.next() {
        bail!(
            "{}: not found when read again (the bag changed while it was read?)",
            bag_at(&input.bag, &input.image_topic, missing)
        );
    }
    pb.finish_and_clear();
    w.finish()?;
    say!("wrote {} frames to {}", kept.len(), a.out.display());
    Ok(())
}

/// Frames without a time: stamped from 2026-06-21T02:30:00Z, 0.1 s apart.
const T0_NS: i64 = 1_782_009_000_000_000_000;
const DT_NS: i64 = 100_000_000;

/// Writes `c` (a DoFP capture) as a new MCAP bag at `out`: per frame a
/// sensor_msgs/Image (`/cam/image_raw`, mono16 DN), a CameraInfo (pinhole and
/// equidistant lenses: `plumb_bob`, `equidistant`, no distortion), an Imu
/// (`/imu/data`: the reference tilt, yaw 0 with variance 1e6 rad², i.e. not
/// measured), a NavSatFix (`/gnss/fix`) where the sun came from a time and place,
/// and the truth (`/bpins/reference_heading`, an Imu per REP 103, under bpins' own
/// namespace so that no reader takes it for the IMU) where the reference heading is
/// known (topic names: bpins_ros::topics). Stamps: the frame's `time_utc`, else T0 + i·0.1 s,
/// and at least 1 ms after the previous frame's.
pub fn capture_to_bag(c: &Capture, out: &Path) -> anyhow::Result<()> {
    let Layout::Dofp { .. } = c.sensor.layout else {
        bail!("--bag-out: a colocated capture has no raw mosaic to record")
    };
    let mut w = BagWriter::create(out)?;
    let g = c.sensor.geometry;
    let intr = c.intrinsics();
    let pb = crate::progress::bar(c.frames.len() as u64, "frames to bag");
    let mut last_ns = i64::MIN;
    for (i, f) in c.frames.iter().enumerate() {
        let (t_ns, place) = match &f.sun.source {
            SunSource::Spa { time_utc, latitude_deg, longitude_deg }
            | SunSource::Moon { time_utc, latitude_deg, longitude_deg, .. } => {
                let t = chrono::DateTime::parse_from_rfc3339(time_utc)
                    .with_context(|| format!("frame {i}: time_utc {time_utc}"))?;
                let ns = t.timestamp_nanos_opt().ok_or_else(|| anyhow!("frame {i}: {time_utc} out of range"))?;
                (ns, Some((*latitude_deg, *longitude_deg)))
            }
            _ => (T0_NS + i as i64 * DT_NS, None),
        };
        // Stamps strictly increase (frames sharing a time, a turntable's, 1 ms apart:
        // the sun moves < 0.00001° in that), so each IMU sample matches its image.
        let t_ns = t_ns.max(last_ns.saturating_add(1_000_000));
        last_ns = t_ns;
        let header = |frame_id: &str| Header { stamp: Time::from_ns(t_ns), frame_id: frame_id.into() };
        let model = match intr.projection {
            Projection::Pinhole => Some(("plumb_bob", 5)),
            Projection::Equidistant => Some(("equidistant", 4)),
            _ => None,
        };
        if let Some((model, n)) = model {
            let (f_px, cx, cy) = (intr.f_px, intr.cx_px, intr.cy_px);
            let ci = CameraInfo {
                header: header("cam"),
                height: g.height_px,
                width: g.width_px,
                distortion_model: model.into(),
                d: vec![0.0; n],
                k: [f_px, 0.0, cx, 0.0, f_px, cy, 0.0, 0.0, 1.0],
                r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                p: [f_px, 0.0, cx, 0.0, 0.0, f_px, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
                ..Default::default()
            };
            w.write(topics::CAMERA_INFO, types::CAMERA_INFO, t_ns, &encode(&ci))?;
        }
        let (tx, ty) = (f.tilt_x_deg.unwrap_or(0.0), f.tilt_y_deg.unwrap_or(0.0));
        let var = f.tilt_sigma_deg.unwrap_or(0.0).to_radians().powi(2);
        // An IMU without a magnetometer: the tilt, yaw not measured.
        let mut imu = rep103::heading_imu(header("imu"), 90.0, 0.0, tx, ty, var, var);
        imu.orientation_covariance[8] = 1e6;
        w.write(topics::IMU, types::IMU, t_ns, &encode(&imu))?;
        if let Some(h) = f.heading_deg {
            let truth = rep103::heading_imu(header("cam"), h, 0.0, tx, ty, 0.0, 0.0);
            w.write(topics::REFERENCE_HEADING, types::IMU, t_ns, &encode(&truth))?;
        }
        if let Some((lat, lon)) = place {
            let fix = NavSatFix {
                header: header("gnss"),
                status: NavSatStatus { status: 0, service: 1 },
                latitude: lat,
                longitude: lon,
                ..Default::default()
            };
            w.write(topics::GNSS_FIX, types::NAV_SAT_FIX, t_ns, &encode(&fix))?;
        }
        let FrameData::Mosaic { dn, .. } = c.read_frame(i)? else { bail!("frame {i}: not a mosaic") };
        let data: Vec<u8> = dn.iter().flat_map(|&x| (x.round().clamp(0.0, 65535.0) as u16).to_le_bytes()).collect();
        let im = Image {
            header: header("cam"),
            height: g.height_px,
            width: g.width_px,
            encoding: "mono16".into(),
            is_bigendian: 0,
            step: 2 * g.width_px,
            data: Cow::Owned(data),
        };
        w.write(topics::IMAGE, types::IMAGE, t_ns, &encode(&im))?;
        pb.inc(1);
    }
    pb.finish_and_clear();
    let dir = w.finish()?;
    say!("wrote the bag {}", dir.display());
    Ok(())
}
