//! Validation of a typed [`Capture`] against the rules of docs/spec/CAPTURE.md:
//! ranges of every number, the mosaic and channel sets, frame file paths (relative,
//! inside the capture folder, no `..`, a supported extension, no file named twice) and
//! the sun of each frame. Both [`Capture::load`] (after parsing) and [`Capture::write`]
//! (before writing anything) run it, so a capture built in code meets the same rules.

use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};

use super::spec::{frame_label, image_kind};
use super::{Capture, FrameSpec, LensSpec, SensorSpec};
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
    if g.width_px == 0 || g.height_px == 0 {
        bail!(p, "[sensor] width_px × height_px = {} × {} must both be > 0", g.width_px, g.height_px);
    }
    if !(g.pixel_pitch_um.is_finite() && g.pixel_pitch_um > 0.0) {
        bail!(p, "[sensor] pixel_pitch_um = {} must be finite and > 0", g.pixel_pitch_um);
    }
    let bits = sensor.bit_depth;
    if !(1..=16).contains(&bits) {
        bail!(p, "[sensor] bit_depth = {bits} must be 1 … 16");
    }
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
    let fl = lens.focal_length_mm;
    if !(fl.is_finite() && fl > 0.0) {
        bail!(p, "[lens] focal_length_mm = {fl} must be finite and > 0");
    }
    let (px, py) = lens.principal_point_px;
    if !(px.is_finite() && py.is_finite()) {
        bail!(p, "[lens] principal_point_px = [{px}, {py}] must be finite");
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
            let (az, el) = (f.sun.azimuth_deg, f.sun.elevation_deg);
            if !az.is_finite() {
                bail!(p, "{label}: sun_azimuth_deg = {az} is not a finite angle");
            }
            if el.is_nan() || el > 90.0 {
                bail!(p, "{label}: sun_elevation_deg = {el} is above 90°");
            }
            if el < -90.0 {
                bail!(p, "{label}: sun_elevation_deg = {el} is below −90°");
            }
        }
        SunSource::Spa { latitude_deg, longitude_deg, .. } => {
            if !(-90.0..=90.0).contains(latitude_deg) {
                bail!(p, "{label}: latitude_deg = {latitude_deg} is outside [−90°, 90°]");
            }
            if !(-180.0..=180.0).contains(longitude_deg) {
                bail!(p, "{label}: longitude_deg = {longitude_deg} is outside [−180°, 180°]");
            }
        }
    }
    if let Some(h) = f.heading_deg {
        if !h.is_finite() {
            bail!(p, "{label}: heading_deg = {h} is not a finite angle");
        }
    }
    for (key, t) in [("tilt_x_deg", f.tilt_x_deg), ("tilt_y_deg", f.tilt_y_deg)] {
        if let Some(t) = t {
            if !(t.is_finite() && t.abs() < 90.0) {
                bail!(p, "{label}: {key} = {t} must be strictly between −90° and 90°");
            }
        }
    }
    for (key, s) in [("tilt_sigma_deg", f.tilt_sigma_deg), ("sun_sigma_deg", f.sun_sigma_deg)] {
        if let Some(s) = s {
            if !(s.is_finite() && (0.0..=45.0).contains(&s)) {
                bail!(p, "{label}: {key} = {s} must be a 1σ between 0° and 45°");
            }
        }
    }
    Ok(())
}
