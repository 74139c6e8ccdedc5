//! `bpins heading --bag DIR`: the images of a ROS 2 bag as a frame source
//! ([`crate::frames`]) for the compass loop every route shares, with `--json` and,
//! with `--bag-out`, a new MCAP bag holding per frame a sensor_msgs/Imu (REP 103
//! orientation, REP 145 covariance) or a diagnostic_msgs/DiagnosticArray saying why
//! the frame has no heading (docs/ros2.md).

use crate::bag::{bag_at, BagArgs, BagInput};
use crate::frames::{self, FrameId, FrameSource, FrameSun, FrameTilt, Pixels, Row, SourceFrame, Stamp};
use crate::write_json;
use anyhow::{anyhow, bail, Context};
use bpins_core::calibration::Calibration;
use bpins_core::compass::Extractor;
use bpins_core::compass::FieldOptions;
use bpins_core::compass::{Compass, CompassConfig};
use bpins_core::sensor::Layout;
use bpins_core::SunSource;
use bpins_ros::cdr::{decode, encode};
use bpins_ros::convert::{mosaic, Mosaic};
use bpins_ros::msgs::{types, Header, Image, Time};
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
    /// For the JSON: the `--effect` assignments and the `--calibration` file.
    pub compensated_effects: &'a [String],
    pub calibration: Option<&'a Path>,
}

/// Runs the compass over the bag; `calibration` and `options` as `bpins heading`.
pub fn run(
    args: &BagArgs,
    extractors: &[Extractor],
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
        extractor: extractors[0],
        colour: s.colour.clone(),
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
    let mut source = BagSource { input: &input, args, scratch: Vec::new() };
    let rows = frames::read_frames(&mut source, &mut compass, extractors, &mut |f, rows| match writer.as_mut() {
        Some(w) => write_out(w, &out, &input, f, &rows[0]),
        None => Ok(()),
    })?;
    let summary = frames::summary(&rows, extractors)?;
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
            "recon": "cells",
            "compensated_effects": out.compensated_effects,
            "calibration": out.calibration.map(|p| p.display().to_string()),
            "frames": rows,
            "summary": summary,
        });
        write_json(p, &v)?;
        say!("wrote {}", p.display());
    }
    Ok(())
}

/// A bag's images as a frame source: each image's raw rows (mono8 or mono16, any
/// stride, never copied unless their byte order is not the machine's), its origin
/// (message index, stamp, frame_id), the sun at its stamp (the flags', or SPA at the
/// fix) and the tilt (the IMU's, slerped or nearest, or level), each or why not.
struct BagSource<'a> {
    input: &'a BagInput,
    args: &'a BagArgs,
    /// mono16 rows in the other byte order, swapped.
    scratch: Vec<u16>,
}

impl FrameSource for BagSource<'_> {
    fn len(&self) -> u64 {
        self.input.frames
    }

    fn each(&mut self, visit: &mut dyn FnMut(SourceFrame<'_>) -> anyhow::Result<()>) -> anyhow::Result<()> {
        let (input, args) = (self.input, self.args);
        let mut frames = input.frames(args)?;
        while let Some(f) = frames.next_frame()? {
            let at = || bag_at(&input.bag, &input.image_topic, f.message.index);
            let im: Image = decode(&f.message.data).map_err(|e| anyhow!("{}: {e}", at()))?;
            let (pixels, sun, tilt) = frame_parts(
                &im,
                input.sensor.colour.as_ref(),
                &mut self.scratch,
                input.sensor.bit_depth,
                &f.sun,
                &f.tilt,
                args.sun_sigma_deg,
            )
            .map_err(|e| anyhow!("{}: {e}", at()))?;
            let id = FrameId {
                message_index: Some(f.message.index),
                stamp: Some(Stamp { sec: im.header.stamp.sec, nanosec: im.header.stamp.nanosec }),
                stamp_ns: Some(f.stamp_ns),
                frame_id: Some(im.header.frame_id.clone()),
                ..FrameId::default()
            };
            visit(SourceFrame { id, pixels, sun, tilt, reference_heading_deg: None })?;
        }
        Ok(())
    }
}

/// The compass's view of one image message, shared by the bag and the live node
/// (`bpins node`): its raw rows (mono8 or mono16, any stride, swapped only where
/// their byte order is not the machine's), the sun (the flags' or SPA's, a dark
/// night refused) and the tilt (the IMU's or level), each or why not.
pub fn frame_parts<'a>(
    im: &'a Image<'_>,
    colour: Option<&bpins_core::sensor::ColourTiles>,
    scratch: &'a mut Vec<u16>,
    bit_depth: u32,
    sun: &Result<bpins_core::SunPosition, String>,
    tilt: &Result<bpins_ros::convert::Tilt, String>,
    sun_sigma_deg: f64,
) -> anyhow::Result<(Pixels<'a>, Result<FrameSun, String>, Result<FrameTilt, String>)> {
    let pixels = match mosaic(im, colour, scratch).map_err(|e| anyhow!("{e}"))? {
        Mosaic::U8(_) if bit_depth > 8 => {
            bail!("a mono8 image for a {bit_depth}-bit sensor (--bit-depth, or the sensor file)")
        }
        Mosaic::U8(r) => Pixels::Dn8(r),
        Mosaic::U16(r) => Pixels::Dn16(r),
    };
    let sigma_deg = (sun_sigma_deg > 0.0).then_some(sun_sigma_deg);
    let sun = sun.as_ref().map_err(Clone::clone).and_then(|s| {
        let source = match &s.source {
            SunSource::Given => "given by --sun-azimuth-deg and --sun-elevation-deg".to_string(),
            other => frames::sun_source(other, sigma_deg.map(|_| "--sun-sigma-deg")),
        };
        FrameSun::of(s, sigma_deg, source)
    });
    let tilt = tilt.as_ref().map_err(Clone::clone).map(|t| FrameTilt {
        tilt_x_deg: t.tilt_x_deg,
        tilt_y_deg: t.tilt_y_deg,
        sigma_deg: t.sigma_deg(),
        roll_var_rad2: t.roll_var_rad2,
        pitch_var_rad2: t.pitch_var_rad2,
    });
    Ok((pixels, sun, tilt))
}

/// `--bag-out`: frame `f`'s heading as a sensor_msgs/Imu, or a DiagnosticArray saying
/// why it has none (`row`: the one extractor's result).
fn write_out(w: &mut BagWriter, out: &BagOut, input: &BagInput, f: &SourceFrame<'_>, row: &Row) -> anyhow::Result<()> {
    let Some(stamp_ns) = f.id.stamp_ns else {
        bail!("--bag-out: frame {} has no stamp", row.id.file.as_deref().unwrap_or("?"))
    };
    let index = f.id.message_index.map(|i| i.to_string()).unwrap_or_default();
    let values = [("image_topic", input.image_topic.clone()), ("image_message", index)];
    let (heading, type_name, bytes) = out_message(f, row, out.heading_frame_id, &values)?;
    let topic = if heading { out.heading_topic } else { out.diagnostics_topic };
    w.write(topic, type_name, stamp_ns, &bytes)?;
    Ok(())
}

/// Frame `f`'s output message, one code path for the bag and the live node: a
/// sensor_msgs/Imu with the heading (REP 103 orientation, REP 145 covariance: the
/// tilt's variances and the heading's 1σ²), stamped with the image's stamp, or a
/// DiagnosticArray with the reason and `values`. Returns whether it is the heading,
/// the type name and the CDR bytes.
pub fn out_message(
    f: &SourceFrame<'_>,
    row: &Row,
    heading_frame_id: Option<&str>,
    values: &[(&str, String)],
) -> anyhow::Result<(bool, &'static str, Vec<u8>)> {
    let Some(stamp) = f.id.stamp else { bail!("frame {} has no stamp", row.id.file.as_deref().unwrap_or("?")) };
    let frame_id = f.id.frame_id.clone().unwrap_or_default();
    let header = Header { stamp: Time { sec: stamp.sec, nanosec: stamp.nanosec }, frame_id: frame_id.clone() };
    Ok(match (row.heading_deg, row.sigma_deg, &f.tilt) {
        (Some(h), Some(sg), Ok(t)) => {
            let mut header = header;
            if let Some(id) = heading_frame_id {
                header.frame_id = id.to_string();
            }
            let msg = rep103::heading_imu(header, h, sg, t.tilt_x_deg, t.tilt_y_deg, t.roll_var_rad2, t.pitch_var_rad2);
            (true, types::IMU, encode(&msg))
        }
        _ => {
            let reason = row.no_heading_reason.clone().unwrap_or_default();
            let msg = rep103::no_heading(header, &frame_id, &reason, values);
            (false, types::DIAGNOSTIC_ARRAY, encode(&msg))
        }
    })
}
