//! The physical range of every number a capture holds. CAPTURE.md asks that "a value
//! out of range" be refused and names three examples; this table is the whole list,
//! chosen so that every sensor, lens and sky that exists fits with room to spare and
//! values no sensor has (a pixel pitch of 1e9 µm, an angle of 1e308°) do not. A
//! refusal names the file, the frame, the key and the range. `docs/ranges.md` states
//! the same table for users; a test keeps the two equal.
//!
//! Ranges that depend on other keys (the black level below full scale, the principal
//! point within one image size of the image) are checked in `validate.rs` beside
//! these and listed in the same document.

use std::path::Path;

use crate::Result;

/// One key's range, in the key's own unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// The key as CAPTURE.md writes it, with its table (`[sensor] pixel_pitch_um`) or
    /// without for a frame key (`heading_deg`).
    pub key: &'static str,
    pub min: f64,
    pub max: f64,
    /// Whether `min` and `max` themselves are outside the range.
    pub open: bool,
    /// Why these bounds, in a few words.
    pub why: &'static str,
}

impl Range {
    const fn closed(key: &'static str, min: f64, max: f64, why: &'static str) -> Self {
        Range { key, min, max, open: false, why }
    }

    /// Whether `v` lies in the range (NaN never does).
    pub fn contains(&self, v: f64) -> bool {
        if self.open {
            v > self.min && v < self.max
        } else {
            v >= self.min && v <= self.max
        }
    }

    /// The range as the documentation and the errors write it: `[0.1, 1000]`, `(−90, 90)`.
    pub fn interval(&self) -> String {
        let (l, r) = if self.open { ('(', ')') } else { ('[', ']') };
        format!("{l}{}, {}{r}", self.min, self.max)
    }

    /// `Ok` where `v` is in range; otherwise an error on `path` naming `label` (the
    /// frame, or empty for a table key), the key, the value and the range.
    pub(crate) fn check(&self, path: &Path, label: &str, v: f64) -> Result<()> {
        if self.contains(v) {
            return Ok(());
        }
        let at = if label.is_empty() { String::new() } else { format!("{label}: ") };
        bail!(path, "{at}{} = {} is outside its range {} ({})", self.key, number(v), self.interval(), self.why)
    }
}

/// A value as an error shows it: plain where it reads well, in exponent form where
/// plain would print hundreds of digits (1e308).
fn number(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

pub const WIDTH_PX: Range = Range::closed("[sensor] width_px", 1.0, 65536.0, "no sensor has more columns");
pub const HEIGHT_PX: Range = Range::closed("[sensor] height_px", 1.0, 65536.0, "no sensor has more rows");
pub const PIXEL_PITCH_UM: Range = Range::closed(
    "[sensor] pixel_pitch_um",
    0.1,
    1000.0,
    "CMOS pixels are 0.5 to 30 µm; a sensor binned or simulated small at the same field of view has larger ones",
);
pub const BIT_DEPTH: Range = Range::closed("[sensor] bit_depth", 1.0, 16.0, "16-bit images hold at most 16 bits");
pub const FOCAL_LENGTH_MM: Range =
    Range::closed("[lens] focal_length_mm", 0.1, 10000.0, "from a 1 mm fisheye to a 2 m telephoto, with room");
pub const SUN_AZIMUTH_DEG: Range = Range::closed("sun_azimuth_deg", -360.0, 360.0, "one turn either way of north");
pub const SUN_ELEVATION_DEG: Range = Range::closed("sun_elevation_deg", -90.0, 90.0, "from the nadir to the zenith");
pub const LATITUDE_DEG: Range = Range::closed("latitude_deg", -90.0, 90.0, "a latitude");
pub const LONGITUDE_DEG: Range = Range::closed("longitude_deg", -180.0, 180.0, "a longitude");
pub const HEADING_DEG: Range = Range::closed("heading_deg", -360.0, 360.0, "one turn either way of north");
pub const TILT_X_DEG: Range =
    Range { key: "tilt_x_deg", min: -90.0, max: 90.0, open: true, why: "the camera must see the sky's upper half" };
pub const TILT_Y_DEG: Range = Range { key: "tilt_y_deg", ..TILT_X_DEG };
pub const TILT_SIGMA_DEG: Range =
    Range::closed("tilt_sigma_deg", 0.0, 45.0, "a 1σ; beyond 45° the attitude is unknown");
pub const SUN_SIGMA_DEG: Range = Range::closed("sun_sigma_deg", 0.0, 45.0, "a 1σ; beyond 45° the sun is unknown");
pub const YAW_DEG: Range =
    Range::closed("yaw_deg", -36000.0, 36000.0, "a gyro's integrated yaw: up to a hundred turns either way");
pub const YAW_SIGMA_DEG: Range =
    Range::closed("yaw_sigma_deg", 0.0, 45.0, "a 1σ; beyond 45° the turn between frames is unknown");

/// Every fixed range, in the order `docs/ranges.md` lists them.
pub const ALL: [Range; 16] = [
    WIDTH_PX,
    HEIGHT_PX,
    PIXEL_PITCH_UM,
    BIT_DEPTH,
    FOCAL_LENGTH_MM,
    SUN_AZIMUTH_DEG,
    SUN_ELEVATION_DEG,
    LATITUDE_DEG,
    LONGITUDE_DEG,
    HEADING_DEG,
    TILT_X_DEG,
    TILT_Y_DEG,
    TILT_SIGMA_DEG,
    SUN_SIGMA_DEG,
    YAW_DEG,
    YAW_SIGMA_DEG,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_in_or_out_as_written() {
        assert!(PIXEL_PITCH_UM.contains(0.1) && PIXEL_PITCH_UM.contains(1000.0));
        assert!(!PIXEL_PITCH_UM.contains(1e9) && !PIXEL_PITCH_UM.contains(0.0));
        assert!(!TILT_X_DEG.contains(90.0) && TILT_X_DEG.contains(89.99));
        assert!(!HEADING_DEG.contains(1e308) && !HEADING_DEG.contains(f64::NAN));
        assert_eq!(TILT_X_DEG.interval(), "(-90, 90)");
        assert_eq!(PIXEL_PITCH_UM.interval(), "[0.1, 1000]");
    }

    #[test]
    fn a_refusal_names_file_frame_key_and_range() {
        let e = HEADING_DEG.check(Path::new("c/capture.toml"), "frames[3] (f.png)", 1e308).unwrap_err();
        let msg = e.to_string();
        for part in ["c/capture.toml", "frames[3]", "heading_deg", "1e308", "[-360, 360]"] {
            assert!(msg.contains(part), "{msg} lacks {part}");
        }
    }

    /// docs/ranges.md states this table; every row must be there with the same numbers.
    #[test]
    fn the_documented_table_is_this_one() {
        let doc = include_str!("../../../../docs/ranges.md");
        for r in ALL {
            let row = format!("| `{}` | {} |", r.key, r.interval());
            assert!(doc.contains(&row), "docs/ranges.md lacks the row starting {row}");
        }
    }
}
