//! `bpins heading --bag DIR`: the heading of every image of a ROS 2 bag through the
//! front door (`bpins_core::compass::Compass`, the field estimator), with a table,
//! `--json`, and with `--bag-out` a new MCAP bag holding per frame a sensor_msgs/Imu
//! (REP 103 orientation, REP 145 covariance) or a diagnostic_msgs/DiagnosticArray
//! saying why the frame has no heading (docs/ros2.md).

use crate::bag::{bag_at, BagArgs};
use crate::write_json;
use anyhow::{anyhow, bail, Context};
use bpins_core::calibration::Calibration;
use bpins_core::compass::Extractor;
use bpins_core::compass::FieldOptions;
use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
use bpins_core::sensor::Layout;
use bpins_ros::cdr::{decode, encode};
use bpins_ros::convert::{mosaic, Mosaic};
use bpins_ros::msgs::{types, Header, Image};
use bpins_ros::rep103;
use bpins_ros::writer::BagWriter;
use serde_json::json;
use std::path::{Path, PathBuf};

/// The outputs of a bag run.
pub struct BagOut<'a> {
    pub json: Option<&'a Path>,
    pub bag_out: Option<&'a PathBuf>,
    pub heading_topic: &'a str,
    pub diagnostics_topic: &'a str,
    /// The Imu headings' frame_id instead of the image's.
    pub heading_frame_id: Option<&'a str>,
}

/// Runs the compass over the bag; `calibration` and `options` as `bpins heading`.
pub fn run(
    args: &BagArgs,
    extractor: Extractor,
    calibration: Calibration,
    options: FieldOptions,
    out: BagOut,
) -> anyhow::Result<()> {
    let input = args.open()?;
    for (flag, o) in [("--bag-out", out.bag_out.map(|p| p.as_path())), ("--json", out.json)] {
        if let Some(o) = o {
            crate::ensure_not_in_input(o, &[&input.bag.dir]).with_context(|| flag)?;
        }
    }
    let s = &input.sensor;
    let Layout::Dofp { mosaic: tiles } = s.layout else { bail!("the sensor must be a DoFP mosaic") };
    let g = &s.geometry;
    let cfg = CompassConfig {
        mosaic: tiles,
        calibration,
        options,
        extractor,
        ..CompassConfig::dofp(
            input.intrinsics,
            g.width_px as usize,
            g.height_px as usize,
            s.bit_depth,
            s.black_level_dn,
        )
    };
    let mut compass = Compass::new(cfg).context("the camera of the bag")?;
    let mut writer = match out.bag_out {
        Some(o) => Some(BagWriter::create(o)?),
        None => None,
    };
    say!(
        "bag {}: images on {}, intrinsics from {}, tilt from {}, sun from {}",
        input.bag.dir.display(),
        input.image_topic,
        input.intrinsics_source,
        input.tilt_source(),
        match (args.sun_azimuth_deg, &input.fix_topic) {
            (Some(_), _) => "--sun-azimuth-deg/--sun-elevation-deg".to_string(),
            (None, Some(t)) => format!("NREL SPA at each stamp and the fix on {t}"),
            (None, None) => "nowhere".to_string(),
        }
    );
    out!(
        "{:>8} {:>21} {:>12} {:>9} {:>10} {:>9} {:>9} {:>15}  sun az/el (°); or why no heading",
        "message",
        "stamp (s)",
        "heading (°)",
        "1σ (°)",
        "yaw (°)",
        "used (%)",
        "cloud (%)",
        "tilt x/y (°)"
    );
    let pb = crate::progress::bar(input.frames, "frames");
    let mut frames = input.frames(args)?;
    let mut scratch: Vec<u16> = Vec::new();
    let mut rows = Vec::new();
    let (mut with, mut without) = (0usize, 0usize);
    while let Some(f) = frames.next_frame()? {
        let im: Image = decode(&f.message.data).map_err(|e| anyhow!("{e}"))?;
        let header = im.header.clone();
        let at = || bag_at(&input.bag, &input.image_topic, f.message.index);
        let fix = match (&f.sun, &f.tilt) {
            (Ok(sun), Ok(t)) => {
                let sun_arg = Sun::Angles {
                    azimuth_deg: sun.azimuth_deg,
                    elevation_deg: sun.elevation_deg,
                    sigma_deg: args.sun_sigma_deg,
                };
                let att = Attitude { tilt_x_deg: t.tilt_x_deg, tilt_y_deg: t.tilt_y_deg, sigma_deg: t.sigma_deg() };
                let m = mosaic(&im, &mut scratch).map_err(|e| anyhow!("{}: {e}", at()))?;
                if matches!(m, Mosaic::U8(_)) && s.bit_depth > 8 {
                    bail!("{}: a mono8 image for a {}-bit sensor (--bit-depth, or the sensor file)", at(), s.bit_depth);
                }
                let r = match m {
                    Mosaic::U8(r) => compass.heading(r, sun_arg, att),
                    Mosaic::U16(r) => compass.heading(r, sun_arg, att),
                };
                Ok(r.with_context(at)?)
            }
            (Err(w), _) | (_, Err(w)) => Err(w.clone()),
        };
        let (heading, sigma, why, quality) = match &fix {
            Ok(h) => match &h.result {
                Ok((hd, p)) => (Some(*hd), Some(p.total_deg()), None, Some(h.quality)),
                Err(r) => (None, None, Some(r.to_string()), Some(h.quality)),
            },
            Err(w) => (None, None, Some(w.clone()), None),
        };
        let yaw = heading.map(|h| rep103::yaw_deg(rep103::enu_quaternion(h, 0.0, 0.0)));
        if let Some(w) = writer.as_mut() {
            match (heading, sigma, &f.tilt) {
                (Some(h), Some(sg), Ok(t)) => {
                    let mut header = header.clone();
                    if let Some(id) = out.heading_frame_id {
                        header.frame_id = id.to_string();
                    }
                    let msg = rep103::heading_imu(
                        header,
                        h,
                        sg,
                        t.tilt_x_deg,
                        t.tilt_y_deg,
                        t.roll_var_rad2,
                        t.pitch_var_rad2,
                    );
                    w.write(out.heading_topic, types::IMU, f.stamp_ns, &encode(&msg))?;
                }
                _ => {
                    let reason = why.clone().unwrap_or_default();
                    let msg = rep103::no_heading(
                        Header { stamp: header.stamp, frame_id: header.frame_id.clone() },
                        &header.frame_id,
                        &reason,
                        &[("image_topic", input.image_topic.clone()), ("image_message", f.message.index.to_string())],
                    );
                    w.write(out.diagnostics_topic, types::DIAGNOSTIC_ARRAY, f.stamp_ns, &encode(&msg))?;
                }
            }
        }
        if heading.is_some() {
            with += 1;
        } else {
            without += 1;
        }
        let opt = |x: Option<f64>, p: usize| x.map(|x| format!("{x:.p$}")).unwrap_or_else(|| "—".into());
        let tilt_txt = f
            .tilt
            .as_ref()
            .map(|t| format!("{:+.2}/{:+.2}", t.tilt_x_deg, t.tilt_y_deg))
            .unwrap_or_else(|_| "—".into());
        let tail = match (&why, &f.sun) {
            (Some(w), _) => format!("no heading: {w}"),
            (None, Ok(s)) => format!("{:.4}/{:.4}", s.azimuth_deg, s.elevation_deg),
            (None, Err(e)) => e.clone(),
        };
        let line = format!(
            "{:>8} {:>21} {:>12} {:>9} {:>10} {:>9} {:>9} {:>15}  {}",
            f.message.index,
            format!("{}.{:09}", header.stamp.sec, header.stamp.nanosec),
            opt(heading, 4),
            opt(sigma, 4),
            opt(yaw, 4),
            opt(quality.map(|q| 100.0 * q.used_fraction), 1),
            opt(quality.map(|q| 100.0 * q.cloud_fraction), 1),
            tilt_txt,
            tail
        );
        pb.inc(1);
        pb.suspend(|| -> anyhow::Result<()> {
            out!("{line}");
            Ok(())
        })?;
        if out.json.is_some() {
            rows.push(json!({
                "message_index": f.message.index,
                "stamp": {"sec": header.stamp.sec, "nanosec": header.stamp.nanosec},
                "stamp_ns": f.stamp_ns,
                "frame_id": header.frame_id,
                "extractor": extractor.name(),
                "heading_deg": heading,
                "sigma_deg": sigma,
                "yaw_enu_deg": yaw,
                "yaw_variance_rad2": sigma.map(|s| s.to_radians().powi(2)),
                "tilt_x_deg": f.tilt.as_ref().ok().map(|t| t.tilt_x_deg),
                "tilt_y_deg": f.tilt.as_ref().ok().map(|t| t.tilt_y_deg),
                "tilt_sigma_deg": f.tilt.as_ref().ok().map(|t| t.sigma_deg()),
                "sun_azimuth_deg": f.sun.as_ref().ok().map(|s| s.azimuth_deg),
                "sun_elevation_deg": f.sun.as_ref().ok().map(|s| s.elevation_deg),
                "sun": f.sun.as_ref().map(|s| s.source.describe()).unwrap_or_default(),
                "used_fraction": quality.map(|q| q.used_fraction),
                "cloud_fraction": quality.map(|q| q.cloud_fraction),
                "no_heading_reason": why,
            }));
        }
    }
    pb.finish_and_clear();
    out!("{}: {with} frame(s) with a heading, {without} without", extractor.name());
    if let Some(w) = writer {
        let dir = w.finish()?;
        say!("wrote {}", dir.display());
    }
    if let Some(p) = out.json {
        let v = json!({
            "bag": input.bag.dir.display().to_string(),
            "storage": input.bag.metadata.storage_identifier,
            "image_topic": input.image_topic,
            "imu_topic": input.imu_topic,
            "fix_topic": input.fix_topic,
            "intrinsics": input.intrinsics_source,
            "estimator": "field",
            "frames": rows,
            "summary": [{"extractor": extractor.name(), "frames": with + without, "frames_without_heading": without}],
        });
        write_json(p, &v)?;
        say!("wrote {}", p.display());
    }
    Ok(())
}
