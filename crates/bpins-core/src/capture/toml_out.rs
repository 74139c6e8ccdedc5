//! Writing `capture.toml` (docs/spec/CAPTURE.md) from a typed [`Capture`]: every
//! default written out explicitly (bit depth, black level, mosaic or channels,
//! principal point), floats in Rust's shortest round-trip form so that the file reads
//! back to the same `f64`s, and each frame's sun as it came (given angles, or the
//! UTC time and place it was computed from).

use super::spec::FORMAT;
use super::Capture;
use crate::sensor::{Channel, Layout};
use crate::sky::sun::SunSource;

/// A TOML float that reads back to the same `f64`.
fn num(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{x:?}")
    }
}

/// A TOML basic string.
fn string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for ch in s.chars() {
        match ch {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 || c as u32 == 0x7f => out.push_str(&format!("\\u{:04X}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn angle(c: Channel) -> String {
    format!("{}", 45 * c.index())
}

/// `capture.toml` text for `c`, every default written out explicitly.
pub(crate) fn to_toml(c: &Capture) -> String {
    let s = &c.sensor;
    let g = &s.geometry;
    let mut t = format!("format = {}\n\n[sensor]\n", string(FORMAT));
    match &s.layout {
        Layout::Dofp { .. } => t.push_str("layout = \"dofp\"\n"),
        Layout::Colocated { .. } => t.push_str("layout = \"colocated\"\n"),
    }
    t.push_str(&format!("width_px = {}\nheight_px = {}\n", g.width_px, g.height_px));
    t.push_str(&format!("pixel_pitch_um = {}\n", num(g.pixel_pitch_um)));
    t.push_str(&format!("bit_depth = {}\nblack_level_dn = {}\n", s.bit_depth, num(s.black_level_dn)));
    match &s.layout {
        Layout::Dofp { mosaic } => t.push_str(&format!(
            "mosaic = [[{}, {}], [{}, {}]]\n",
            angle(mosaic[0][0]),
            angle(mosaic[0][1]),
            angle(mosaic[1][0]),
            angle(mosaic[1][1])
        )),
        Layout::Colocated { channels } => {
            let list: Vec<String> = channels.iter().map(|&ch| angle(ch)).collect();
            t.push_str(&format!("channels = [{}]\n", list.join(", ")));
        }
    }
    let l = &c.lens;
    t.push_str(&format!("\n[lens]\nprojection = {}\n", string(l.projection.name())));
    t.push_str(&format!("focal_length_mm = {}\n", num(l.focal_length_mm)));
    let (px, py) = l.principal_point_px;
    t.push_str(&format!("principal_point_px = [{}, {}]\n", num(px), num(py)));
    for f in &c.frames {
        let file: Vec<String> = f.file.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
        t.push_str(&format!("\n[[frames]]\nfile = {}\n", string(&file.join("/"))));
        match &f.sun.source {
            SunSource::Given => {
                t.push_str(&format!("sun_azimuth_deg = {}\n", num(f.sun.azimuth_deg)));
                t.push_str(&format!("sun_elevation_deg = {}\n", num(f.sun.elevation_deg)));
            }
            SunSource::Spa { time_utc, latitude_deg, longitude_deg } => {
                t.push_str(&format!("time_utc = {}\n", string(time_utc)));
                t.push_str(&format!("latitude_deg = {}\n", num(*latitude_deg)));
                t.push_str(&format!("longitude_deg = {}\n", num(*longitude_deg)));
            }
            SunSource::Unplaced { time_utc } => {
                t.push_str(&format!("time_utc = {}\n", string(time_utc)));
            }
        }
        for (key, v) in [
            // Azimuths in files are in [0°, 360°) (CONVENTIONS.md).
            ("heading_deg", f.heading_deg.map(crate::conventions::wrap_deg_360)),
            ("tilt_x_deg", f.tilt_x_deg),
            ("tilt_y_deg", f.tilt_y_deg),
            ("tilt_sigma_deg", f.tilt_sigma_deg),
            ("sun_sigma_deg", f.sun_sigma_deg),
            ("yaw_deg", f.yaw_deg),
            ("yaw_sigma_deg", f.yaw_sigma_deg),
        ] {
            if let Some(v) = v {
                t.push_str(&format!("{key} = {}\n", num(v)));
            }
        }
    }
    t
}
