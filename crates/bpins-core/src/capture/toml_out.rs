//! Writing `capture.toml` (docs/spec/CAPTURE.md) from a typed [`Capture`], through
//! serde and the `toml` crate (the reader's, `spec.rs`): every default written out
//! explicitly (bit depth, black level, mosaic or channels, principal point), floats in
//! their shortest round-trip form so that the file reads back to the same `f64`s, and
//! each frame's sun as it came (given angles, or the UTC time and place it was
//! computed from). The key names are the reader's (`spec.rs`'s raw structs), so a
//! written file reads back to the same capture (tested in `tests.rs`).

use std::path::Path;

use serde::Serialize;

use super::spec::FORMAT;
use super::{Capture, LensSpec, SensorSpec};
use crate::sensor::{Channel, Layout};
use crate::sky::sun::SunSource;

#[derive(Serialize)]
struct OutTop<'a, F> {
    format: &'a str,
    /// `"lab"` for a lab capture; a sky capture does not write its default.
    #[serde(skip_serializing_if = "Option::is_none")]
    kind: Option<&'a str>,
    sensor: OutSensor,
    lens: OutLens<'a>,
    frames: Vec<F>,
}

#[derive(Serialize)]
struct OutSensor {
    layout: &'static str,
    width_px: u32,
    height_px: u32,
    pixel_pitch_um: f64,
    bit_depth: u32,
    black_level_dn: f64,
    /// Analyzer angles, degrees, by tile row and column (dofp).
    #[serde(skip_serializing_if = "Option::is_none")]
    mosaic: Option<[[u32; 2]; 2]>,
    /// Analyzer angles, degrees, in plane order (colocated).
    #[serde(skip_serializing_if = "Option::is_none")]
    channels: Option<Vec<u32>>,
    /// A colour-polarization sensor's filter over each analyzer tile (dofp).
    #[serde(skip_serializing_if = "Option::is_none")]
    colour_tiles: Option<[[&'static str; 2]; 2]>,
    /// Its bands' centre wavelengths, nm, with `colour_tiles`.
    #[serde(skip_serializing_if = "Option::is_none")]
    band_centre_nm: Option<std::collections::BTreeMap<&'static str, f64>>,
}

#[derive(Serialize)]
struct OutLens<'a> {
    projection: &'a str,
    focal_length_mm: f64,
    principal_point_px: [f64; 2],
}

/// One `[[frames]]` table; an absent value is not written (CAPTURE.md: optional keys).
#[derive(Serialize)]
struct OutFrame {
    file: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    sun_azimuth_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sun_elevation_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    time_utc: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    latitude_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    longitude_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    heading_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tilt_x_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tilt_y_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tilt_sigma_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sun_sigma_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    yaw_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    yaw_sigma_deg: Option<f64>,
}

/// An analyzer's angle as the file writes it, degrees.
fn angle(c: Channel) -> u32 {
    45 * c.index() as u32
}

/// `capture.toml` text for `c`, every default written out explicitly.
pub(crate) fn to_toml(c: &Capture) -> String {
    let frames = c
        .frames
        .iter()
        .map(|f| {
            let mut o = OutFrame {
                file: file_key(&f.file),
                sun_azimuth_deg: None,
                sun_elevation_deg: None,
                time_utc: None,
                latitude_deg: None,
                longitude_deg: None,
                // Azimuths in files are in [0°, 360°) (CONVENTIONS.md).
                heading_deg: f.heading_deg.map(crate::conventions::wrap_deg_360),
                tilt_x_deg: f.tilt_x_deg,
                tilt_y_deg: f.tilt_y_deg,
                tilt_sigma_deg: f.tilt_sigma_deg,
                sun_sigma_deg: f.sun_sigma_deg,
                yaw_deg: f.yaw_deg,
                yaw_sigma_deg: f.yaw_sigma_deg,
            };
            match &f.sun.source {
                SunSource::Given => {
                    o.sun_azimuth_deg = Some(f.sun.azimuth_deg);
                    o.sun_elevation_deg = Some(f.sun.elevation_deg);
                }
                SunSource::Spa { time_utc, latitude_deg, longitude_deg }
                | SunSource::Moon { time_utc, latitude_deg, longitude_deg, .. } => {
                    o.time_utc = Some(time_utc.clone());
                    o.latitude_deg = Some(*latitude_deg);
                    o.longitude_deg = Some(*longitude_deg);
                }
                SunSource::Unplaced { time_utc } => o.time_utc = Some(time_utc.clone()),
            }
            o
        })
        .collect();
    write(None, &c.sensor, &c.lens, frames)
}

/// A frame's file as the toml names it: relative to the capture folder, `/`-separated.
pub(crate) fn file_key(file: &Path) -> String {
    let parts: Vec<String> = file.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    parts.join("/")
}

/// `capture.toml` text of a capture of `kind` (`None`: sky) with this sensor, lens and
/// `[[frames]]` tables (the sky's [`OutFrame`]s or a lab capture's own).
pub(crate) fn write<F: Serialize>(kind: Option<&str>, s: &SensorSpec, l: &LensSpec, frames: Vec<F>) -> String {
    let g = &s.geometry;
    let (layout, mosaic, channels) = match &s.layout {
        Layout::Dofp { mosaic } => ("dofp", Some(mosaic.map(|row| row.map(angle))), None),
        Layout::Colocated { channels } => ("colocated", None, Some(channels.iter().map(|&ch| angle(ch)).collect())),
    };
    let top = OutTop {
        format: FORMAT,
        kind,
        sensor: OutSensor {
            layout,
            width_px: g.width_px,
            height_px: g.height_px,
            pixel_pitch_um: g.pixel_pitch_um,
            bit_depth: s.bit_depth,
            black_level_dn: s.black_level_dn,
            mosaic,
            channels,
            colour_tiles: s.colour.as_ref().map(|c| c.tiles.map(|row| row.map(|b| b.name()))),
            band_centre_nm: s
                .colour
                .as_ref()
                .map(|c| c.bands().into_iter().map(|b| (b.name(), c.centre_nm[b.index()])).collect()),
        },
        lens: OutLens {
            projection: l.projection.name(),
            focal_length_mm: l.focal_length_mm,
            principal_point_px: [l.principal_point_px.0, l.principal_point_px.1],
        },
        frames,
    };
    // Every field is a number, a string, a bool or an array of them: nothing the
    // serializer refuses (a non-finite float is written as TOML's nan / inf).
    toml::to_string(&top).unwrap_or_else(|e| unreachable!("a capture's fields are all TOML values: {e}"))
}
