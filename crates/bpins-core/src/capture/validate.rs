//! Validation of a typed [`Capture`] against the rules of docs/spec/CAPTURE.md:
//! ranges of every number, the mosaic and channel sets, frame file paths (relative,
//! inside the capture folder, no `..`, a supported extension, no file named twice) and
//! the sun of each frame. Both [`Capture::load`] (after parsing) and [`Capture::write`]
//! (before writing anything) run it, so a capture built in code meets the same rules.

use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};

use super::spec::{frame_label, image_kind};
use super::{ranges, Capture, FrameSpec, LensSpec, SensorSpec};
use crate::sensor::{Channel, Layout};
use crate::sky::sun::SunSource;
use crate::Result;

/// Checks every range and rule of CAPTURE.md on a typed capture; `toml_path` is the
/// file errors are reported against.
pub(crate) fn validate(c: &Capture, toml_path: &Path) -> Result<()> {
    let p = toml_path;
    validate_sensor_lens(&c.sensor, &c.lens, p)?;
    if c.frames.is_empty() {
        bail!(p, "no frames: at least one [[frames]] table is required");
    }
    let mut by_file: HashMap<PathBuf, usize> = HashMap::new();
    for (i, f) in c.frames.iter().enumerate() {
        let label = frame_label(i, Some(&f.file));
        validate_frame(p, &label, f, &c.sensor.layout)?;
        if let Some(j) = by_file.insert(normalised(&f.file), i) {
            bail!(p, "{label}: the same file is already frames[{j}]; each frame needs its own image");
        }
    }
    Ok(())
}

/// The `[sensor]` and `[lens]` rules every capture kind shares.
pub(crate) fn validate_sensor_lens(sensor: &SensorSpec, lens: &LensSpec, p: &Path) -> Result<()> {
    let g = &sensor.geometry;
    ranges::WIDTH_PX.check(p, "", g.width_px as f64)?;
    ranges::HEIGHT_PX.check(p, "", g.height_px as f64)?;
    ranges::PIXEL_PITCH_UM.check(p, "", g.pixel_pitch_um)?;
    ranges::BIT_DEPTH.check(p, "", sensor.bit_depth as f64)?;
    let full = sensor.full_scale_dn();
    let b = sensor.black_level_dn;
    if !(b.is_finite() && b >= 0.0 && b < full) {
        bail!(p, "[sensor] black_level_dn = {b} must be ≥ 0 and below full scale {full} DN");
    }
    match &sensor.layout {
        Layout::Dofp { mosaic } => {
            let mut seen: Vec<Channel> = mosaic.iter().flatten().copied().collect();
            seen.sort();
            seen.dedup();
            if seen.len() != 4 {
                bail!(p, "[sensor] mosaic must hold each of 0, 45, 90, 135 once");
            }
        }
        Layout::Colocated { channels } => {
            let mut seen = channels.clone();
            seen.sort();
            seen.dedup();
            let has = |c: Channel| seen.contains(&c);
            if seen.len() != channels.len()
                || !(3..=4).contains(&channels.len())
                || !(has(Channel::C0) && has(Channel::C45) && has(Channel::C90))
            {
                bail!(p, "[sensor] channels must be 3 or 4 distinct angles including 0, 45 and 90");
            }
        }
    }
    ranges::FOCAL_LENGTH_MM.check(p, "", lens.focal_length_mm)?;
    let (px, py) = lens.principal_point_px;
    let (w, h) = (g.width_px as f64, g.height_px as f64);
    if !((-w..=2.0 * w).contains(&px) && (-h..=2.0 * h).contains(&py)) {
        bail!(
            p,
            "[lens] principal_point_px = [{px}, {py}] is more than one image size ({w} × {h} px) \
             outside the image: x must be in [{}, {}], y in [{}, {}]",
            -w,
            2.0 * w,
            -h,
            2.0 * h
        );
    }
    Ok(())
}

pub(crate) fn normalised(file: &Path) -> PathBuf {
    file.components().filter(|c| !matches!(c, Component::CurDir)).collect()
}

fn validate_frame(p: &Path, label: &str, f: &FrameSpec, layout: &Layout) -> Result<()> {
    validate_frame_file(p, label, &f.file, layout)?;
    validate_sun(p, label, f)
}

/// A frame's file: a relative path inside the capture, of a type its layout reads.
pub(crate) fn validate_frame_file(p: &Path, label: &str, file: &Path, layout: &Layout) -> Result<()> {
    let bad_path = file.as_os_str().is_empty()
        || file.to_str().is_none()
        || file.components().any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
        || file.components().all(|c| matches!(c, Component::CurDir));
    if bad_path {
        bail!(p, "{label}: file must be a UTF-8 relative path inside the capture folder (no `..`, not absolute)");
    }
    match (layout, image_kind(file)) {
        (Layout::Dofp { .. }, Some(_)) | (Layout::Colocated { .. }, Some("exr")) => {}
        (Layout::Dofp { .. }, None) => {
            bail!(p, "{label}: a dofp frame must be a .png, .tif/.tiff or .exr file");
        }
        (Layout::Colocated { .. }, _) => {
            bail!(p, "{label}: a colocated frame must be one multi-channel .exr file");
        }
    }
    Ok(())
}

fn validate_sun(p: &Path, label: &str, f: &FrameSpec) -> Result<()> {
    match &f.sun.source {
        SunSource::Given => {
            ranges::SUN_AZIMUTH_DEG.check(p, label, f.sun.azimuth_deg)?;
            ranges::SUN_ELEVATION_DEG.check(p, label, f.sun.elevation_deg)?;
        }
        SunSource::Spa { latitude_deg, longitude_deg, .. } | SunSource::Moon { latitude_deg, longitude_deg, .. } => {
            ranges::LATITUDE_DEG.check(p, label, *latitude_deg)?;
            ranges::LONGITUDE_DEG.check(p, label, *longitude_deg)?;
        }
        SunSource::Unplaced { .. } => {}
    }
    let optional = [
        (ranges::HEADING_DEG, f.heading_deg),
        (ranges::TILT_X_DEG, f.tilt_x_deg),
        (ranges::TILT_Y_DEG, f.tilt_y_deg),
        (ranges::TILT_SIGMA_DEG, f.tilt_sigma_deg),
        (ranges::SUN_SIGMA_DEG, f.sun_sigma_deg),
        (ranges::YAW_DEG, f.yaw_deg),
        (ranges::YAW_SIGMA_DEG, f.yaw_sigma_deg),
    ];
    for (range, v) in optional {
        if let Some(v) = v {
            range.check(p, label, v)?;
        }
    }
    Ok(())
}
