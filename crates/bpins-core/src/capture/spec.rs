//! Parsing `capture.toml` of a `bpins-capture/1` capture (docs/spec/CAPTURE.md).
//!
//! Two stages. `toml` + serde with `deny_unknown_fields` turn each section into a raw
//! struct (unknown keys, missing required keys and wrong types are errors naming the
//! key and the table or frame); the raw values then become the typed [`Capture`],
//! with the defaults of CAPTURE.md and the sun resolved (NREL SPA for time-and-place
//! frames, [`crate::sky::sun`]). Ranges are checked afterwards on the typed value
//! (`validate.rs`). Numbers may be written as TOML integers or floats; `time_utc` as a
//! string or an unquoted TOML offset date-time.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::images::err;
use super::{Capture, FrameSpec, LensSpec, SensorSpec};
use crate::camera::Projection;
use crate::conventions::image_centre_px;
use crate::sensor::{Band, Channel, ColourTiles, Geometry, Layout, DEFAULT_MOSAIC};
use crate::sky::sun::SunPosition;
use crate::Result;

/// The value of the `format` key this reader and writer implement.
pub const FORMAT: &str = "bpins-capture/1";

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTop {
    format: Option<String>,
    kind: Option<String>,
    sensor: Option<toml::Value>,
    lens: Option<toml::Value>,
    frames: Option<Vec<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSensor {
    layout: String,
    width_px: u32,
    height_px: u32,
    pixel_pitch_um: f64,
    bit_depth: Option<u32>,
    black_level_dn: Option<f64>,
    mosaic: Option<Vec<Vec<f64>>>,
    channels: Option<Vec<f64>>,
    /// CAPTURE.md's colour-polarization keys (`parse_colour`).
    colour_tiles: Option<toml::Value>,
    band_centre_nm: Option<toml::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLens {
    projection: String,
    focal_length_mm: f64,
    principal_point_px: Option<Vec<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFrame {
    file: String,
    sun_azimuth_deg: Option<f64>,
    sun_elevation_deg: Option<f64>,
    /// A string, or a TOML offset date-time written without quotes.
    time_utc: Option<toml::Value>,
    latitude_deg: Option<f64>,
    longitude_deg: Option<f64>,
    heading_deg: Option<f64>,
    tilt_x_deg: Option<f64>,
    tilt_y_deg: Option<f64>,
    tilt_sigma_deg: Option<f64>,
    sun_sigma_deg: Option<f64>,
    yaw_deg: Option<f64>,
    yaw_sigma_deg: Option<f64>,
}

/// A serde message in this format's words, on one line.
pub(crate) fn clean(e: toml::de::Error) -> String {
    let m = e.to_string();
    let m = m.trim().replace("\nin `", " in key `");
    let m = m.replace("unknown field", "unknown key").replace("missing field", "missing required key");
    m.split('\n').map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join("; ")
}

/// `frames[i] (file)`, the way every message names a frame.
pub(crate) fn frame_label(index: usize, file: Option<&Path>) -> String {
    match file {
        Some(f) => format!("frames[{index}] ({})", f.display()),
        None => format!("frames[{index}]"),
    }
}

fn section<T: serde::de::DeserializeOwned>(path: &Path, name: &str, v: Option<toml::Value>) -> Result<T> {
    match v {
        None => Err(err(path, format!("missing required table [{name}]"))),
        Some(v) if !v.is_table() => Err(err(path, format!("`{name}` must be a table [{name}]"))),
        Some(v) => v.try_into().map_err(|e| err(path, format!("[{name}]: {}", clean(e)))),
    }
}

fn angle_channel(path: &Path, key: &str, deg: f64) -> Result<Channel> {
    Channel::from_angle_deg(deg)
        .ok_or_else(|| err(path, format!("[sensor] {key}: {deg} is not an analyzer angle (0, 45, 90 or 135)")))
}

/// What every capture kind shares: `kind`, `[sensor]`, `[lens]` and the raw
/// `[[frames]]` tables of `text` (the contents of `toml_path`), `format` checked.
pub(crate) struct Header {
    pub kind: String,
    pub sensor: SensorSpec,
    pub lens: LensSpec,
    pub frames: Vec<toml::Value>,
}

/// Parses the parts of `capture.toml` every kind shares (see [`Header`]).
pub(crate) fn parse_header(toml_path: &Path, text: &str) -> Result<Header> {
    let p = toml_path;
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let at = e.span().map(|r| {
            let before = text.get(..r.start).unwrap_or(text);
            let line = before.matches('\n').count() + 1;
            let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!(" at line {line}, column {col}")
        });
        err(p, format!("not valid TOML{}: {}", at.unwrap_or_default(), e.message().trim()))
    })?;
    let top: RawTop = toml::Value::Table(table).try_into().map_err(|e| err(p, format!("top level: {}", clean(e))))?;
    match top.format.as_deref() {
        None => {
            bail!(p, "missing required key `format` (should be \"{FORMAT}\")")
        }
        Some(FORMAT) => {}
        Some(f) => {
            bail!(p, "format = \"{f}\" is not supported; this reader knows \"{FORMAT}\"")
        }
    }
    let kind = top.kind.clone().unwrap_or_else(|| "sky".into());
    if kind != "sky" && kind != "lab" {
        bail!(p, "kind = \"{kind}\" is unknown; use \"sky\" (the default) or \"lab\"")
    }
    let (sensor, lens) = parse_sensor_lens(p, top.sensor, top.lens)?;
    Ok(Header { kind, sensor, lens, frames: top.frames.unwrap_or_default() })
}

/// The `[sensor]` and `[lens]` tables of a capture (or of any file that embeds them,
/// such as a sweep file: `crate::sweep`), parsed with CAPTURE.md's defaults; errors
/// name `toml_path` and the key. Ranges are checked by `validate_sensor_lens`.
pub(crate) fn parse_sensor_lens(
    toml_path: &Path,
    sensor: Option<toml::Value>,
    lens: Option<toml::Value>,
) -> Result<(SensorSpec, LensSpec)> {
    let p = toml_path;
    let s: RawSensor = section(p, "sensor", sensor)?;
    let l: RawLens = section(p, "lens", lens)?;
    let colour = parse_colour(p, &s)?;
    let layout = match s.layout.as_str() {
        "dofp" => {
            if s.channels.is_some() {
                bail!(p, "[sensor] channels is for layout = \"colocated\"; a dofp sensor uses mosaic");
            }
            let mosaic = match &s.mosaic {
                None => DEFAULT_MOSAIC,
                Some(rows) => {
                    if rows.len() != 2 || rows.iter().any(|r| r.len() != 2) {
                        bail!(p, "[sensor] mosaic must be 2 rows of 2 angles, like [[90, 45], [135, 0]]");
                    }
                    let mut m = DEFAULT_MOSAIC;
                    for (r, row) in rows.iter().enumerate() {
                        for (c, &deg) in row.iter().enumerate() {
                            m[r][c] = angle_channel(p, "mosaic", deg)?;
                        }
                    }
                    m
                }
            };
            Layout::Dofp { mosaic }
        }
        "colocated" => {
            if s.mosaic.is_some() {
                bail!(p, "[sensor] mosaic is for layout = \"dofp\"; a colocated sensor uses channels");
            }
            let channels = match &s.channels {
                None => Channel::ALL.to_vec(),
                Some(list) => list.iter().map(|&d| angle_channel(p, "channels", d)).collect::<Result<Vec<_>>>()?,
            };
            Layout::Colocated { channels }
        }
        other => {
            bail!(p, "[sensor] layout = \"{other}\" is unknown; use \"dofp\" or \"colocated\"");
        }
    };
    let sensor = SensorSpec {
        layout,
        geometry: Geometry { width_px: s.width_px, height_px: s.height_px, pixel_pitch_um: s.pixel_pitch_um },
        bit_depth: s.bit_depth.unwrap_or(16),
        black_level_dn: s.black_level_dn.unwrap_or(0.0),
        colour,
    };

    let projection = Projection::ALL.into_iter().find(|q| q.name() == l.projection).ok_or_else(|| {
        let known: Vec<_> = Projection::ALL.iter().map(|q| q.name()).collect();
        err(p, format!("[lens] projection = \"{}\" is unknown; use one of {}", l.projection, known.join(", ")))
    })?;
    let principal_point_px = match l.principal_point_px.as_deref() {
        None => image_centre_px(s.width_px, s.height_px),
        Some([x, y]) => (*x, *y),
        Some(_) => {
            bail!(p, "[lens] principal_point_px must be two numbers [x, y] in pixels")
        }
    };
    let lens = LensSpec { projection, focal_length_mm: l.focal_length_mm, principal_point_px };

    Ok((sensor, lens))
}

/// `[sensor] colour_tiles` (2 rows of 2 of "R", "G", "B", each band at least once; a
/// dofp sensor only) and `band_centre_nm` (a table of the bands' centre wavelengths in
/// nm, CAPTURE.md's defaults for those not given), or `None` for a monochrome sensor.
fn parse_colour(p: &Path, s: &RawSensor) -> Result<Option<ColourTiles>> {
    let Some(tiles) = &s.colour_tiles else {
        if s.band_centre_nm.is_some() {
            bail!(p, "[sensor] band_centre_nm is for a colour-polarization sensor, with colour_tiles (CAPTURE.md)");
        }
        return Ok(None);
    };
    if s.layout != "dofp" {
        bail!(p, "[sensor] colour_tiles is for layout = \"dofp\" (a filter over each 2×2 analyzer tile)");
    }
    let shape = || {
        err(
            p,
            format!(
                "[sensor] colour_tiles = {tiles}: expected 2 rows of 2 bands, like [[\"R\", \"G\"], [\"G\", \"B\"]]"
            ),
        )
    };
    let rows = tiles.as_array().filter(|r| r.len() == 2).ok_or_else(shape)?;
    let mut out = ColourTiles::imx250myr();
    for (r, row) in rows.iter().enumerate() {
        let row = row.as_array().filter(|c| c.len() == 2).ok_or_else(shape)?;
        for (c, name) in row.iter().enumerate() {
            let name = name.as_str().ok_or_else(shape)?;
            out.tiles[r][c] = Band::from_name(name).ok_or_else(|| {
                err(p, format!("[sensor] colour_tiles: band \"{name}\" is unknown; use \"R\", \"G\" or \"B\""))
            })?;
        }
    }
    if let Some(t) = &s.band_centre_nm {
        let table = t.as_table().ok_or_else(|| {
            err(p, "[sensor] band_centre_nm must be a table like { R = 615.0, G = 530.0, B = 465.0 }".to_string())
        })?;
        for (name, v) in table {
            let b = Band::from_name(name)
                .ok_or_else(|| err(p, format!("[sensor] band_centre_nm: band \"{name}\" is unknown; use R, G or B")))?;
            let nm = v.as_float().or_else(|| v.as_integer().map(|i| i as f64)).filter(|x| x.is_finite() && *x > 0.0);
            out.centre_nm[b.index()] = nm.ok_or_else(|| {
                err(p, format!("[sensor] band_centre_nm.{name} = {v}: expected a wavelength in nm above 0"))
            })?;
        }
    }
    Ok(Some(out))
}

/// Parses `text` (the contents of `toml_path`) into a capture rooted at `dir`.
/// Ranges are not checked here: see `validate.rs`. With `unplaced`, a frame may give
/// `time_utc` alone (its sun is then [`SunSource::Unplaced`](crate::sky::sun::SunSource)).
pub(crate) fn parse(dir: &Path, toml_path: &Path, text: &str, unplaced: bool) -> Result<Capture> {
    let p = toml_path;
    let Header { kind, sensor, lens, frames: raw_frames } = parse_header(p, text)?;
    if kind == "lab" {
        bail!(
            p,
            "kind = \"lab\": this is a lab capture (calibration frames of a uniform source, \
             no sky); the sky readers (heading, fit, diagnose) need kind = \"sky\"; \
             calibrate it with `bpins calibrate`"
        )
    }
    if raw_frames.is_empty() {
        bail!(p, "no frames: at least one [[frames]] table is required");
    }
    let mut frames = Vec::with_capacity(raw_frames.len());
    for (i, v) in raw_frames.into_iter().enumerate() {
        let file_hint = v.get("file").and_then(|f| f.as_str()).map(PathBuf::from);
        let label = frame_label(i, file_hint.as_deref());
        if !v.is_table() {
            bail!(p, "{label} must be a table: write each frame as [[frames]]");
        }
        let f: RawFrame = v.try_into().map_err(|e| err(p, format!("{label}: {}", clean(e))))?;
        frames.push(parse_frame(p, &label, f, unplaced)?);
    }
    Ok(Capture { dir: dir.to_path_buf(), sensor, lens, frames })
}

fn parse_frame(p: &Path, label: &str, f: RawFrame, unplaced: bool) -> Result<FrameSpec> {
    let given = f.sun_azimuth_deg.is_some() || f.sun_elevation_deg.is_some();
    let timed = f.time_utc.is_some() || f.latitude_deg.is_some() || f.longitude_deg.is_some();
    let sun = match (given, timed) {
        (true, true) => {
            bail!(
                p,
                "{label}: give the sun either as sun_azimuth_deg + sun_elevation_deg or as \
                 time_utc + latitude_deg + longitude_deg, not both"
            )
        }
        (false, false) => {
            bail!(
                p,
                "{label}: no sun position: give sun_azimuth_deg + sun_elevation_deg, or \
                 time_utc + latitude_deg + longitude_deg"
            )
        }
        (true, false) => match (f.sun_azimuth_deg, f.sun_elevation_deg) {
            (Some(az), Some(el)) => {
                // Checked before the wrap into [0, 360), which would hide 1e308.
                super::ranges::SUN_AZIMUTH_DEG.check(p, label, az)?;
                SunPosition::given(az, el)
            }
            (Some(_), None) => {
                bail!(p, "{label}: sun_azimuth_deg needs sun_elevation_deg")
            }
            _ => {
                bail!(p, "{label}: sun_elevation_deg needs sun_azimuth_deg")
            }
        },
        (false, true) => {
            let missing: Vec<&str> = [
                ("time_utc", f.time_utc.is_none()),
                ("latitude_deg", f.latitude_deg.is_none()),
                ("longitude_deg", f.longitude_deg.is_none()),
            ]
            .into_iter()
            .filter_map(|(k, m)| m.then_some(k))
            .collect();
            let time_only = f.time_utc.is_some() && f.latitude_deg.is_none() && f.longitude_deg.is_none();
            if unplaced && time_only {
                let time = time_string(p, label, f.time_utc.clone())?;
                let sun = SunPosition::unplaced(&time).map_err(|e| err(p, format!("{label}: {e}")))?;
                return Ok(frame_spec(f, sun));
            }
            if !missing.is_empty() {
                bail!(
                    p,
                    "{label}: a sun from time and place needs time_utc, latitude_deg and \
                     longitude_deg; missing {}{}",
                    missing.join(", "),
                    if time_only { " (`bpins locate` reads frames with time_utc alone)" } else { "" }
                );
            }
            let time = time_string(p, label, f.time_utc.clone())?;
            let (lat, lon) = (f.latitude_deg.unwrap_or(f64::NAN), f.longitude_deg.unwrap_or(f64::NAN));
            crate::sky::source_from_time_place(&time, lat, lon).map_err(|e| err(p, format!("{label}: {e}")))?
        }
    };
    Ok(frame_spec(f, sun))
}

/// `time_utc` as a string: a TOML string or an unquoted offset date-time.
fn time_string(p: &Path, label: &str, v: Option<toml::Value>) -> Result<String> {
    match v {
        Some(toml::Value::String(s)) => Ok(s),
        Some(toml::Value::Datetime(d)) => Ok(d.to_string()),
        _ => {
            bail!(p, "{label}: time_utc must be a timestamp like \"2026-06-21T18:30:00Z\"")
        }
    }
}

fn frame_spec(f: RawFrame, sun: SunPosition) -> FrameSpec {
    FrameSpec {
        file: PathBuf::from(f.file),
        sun,
        heading_deg: f.heading_deg,
        tilt_x_deg: f.tilt_x_deg,
        tilt_y_deg: f.tilt_y_deg,
        tilt_sigma_deg: f.tilt_sigma_deg,
        sun_sigma_deg: f.sun_sigma_deg,
        yaw_deg: f.yaw_deg,
        yaw_sigma_deg: f.yaw_sigma_deg,
    }
}

/// The lower-case extension of a frame file, if it is one this format reads.
pub(crate) fn image_kind(file: &Path) -> Option<&'static str> {
    let ext = file.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "png" => Some("png"),
        "tif" | "tiff" => Some("tiff"),
        "exr" => Some("exr"),
        _ => None,
    }
}
