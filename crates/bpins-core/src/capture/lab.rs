//! Lab captures (`kind = "lab"`, docs/spec/CAPTURE.md): calibration frames of a
//! uniform source instead of the sky. A flat field through a linear polarizer turned
//! to known angles (Powell & Gruev 2013), unpolarized flat fields at several
//! exposures (EMVA 1288 photon transfer) and dark frames (cap on).
//!
//! `[sensor]` and `[lens]` are read and checked as for a sky capture (`spec.rs`,
//! `validate.rs`); each `[[frames]]` holds `file` and any of
//! `polarizer_angle_deg` (image frame, CONVENTIONS.md; absent: unpolarized),
//! `source_dolp` (default 1), `exposure_rel` (default 1) and `dark` (default false).
//! An unknown key, a value out of range, a dark frame with a polarizer angle or a
//! missing image is an error naming the file and the frame. Nothing is ever written
//! into a capture: [`LabCapture::write`] refuses a folder holding `capture.toml`.

use std::fs;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::images::{self, err};
use super::spec::{clean, frame_label, parse_header, Header};
use super::validate::{normalised, validate_frame_file, validate_sensor_lens};
use super::{FrameData, LensSpec, SensorSpec};
use crate::sensor::Layout;
use crate::Result;

/// A lab capture: where it lies, the sensor, and what each frame shows.
#[derive(Clone, Debug, PartialEq)]
pub struct LabCapture {
    pub dir: PathBuf,
    pub sensor: SensorSpec,
    pub lens: LensSpec,
    pub frames: Vec<LabFrame>,
}

/// One `[[frames]]` entry of a lab capture.
#[derive(Clone, Debug, PartialEq)]
pub struct LabFrame {
    pub file: PathBuf,
    /// The polarizer's transmission axis, degrees, image frame; `None`: unpolarized.
    pub polarizer_angle_deg: Option<f64>,
    /// DoLP of the light reaching the lens (1: an ideal polarizer), 0 … 1.
    pub source_dolp: f64,
    /// Exposure relative to the first frame (> 0).
    pub exposure_rel: f64,
    /// A dark frame (cap on): offsets and read noise.
    pub dark: bool,
}

impl LabFrame {
    /// What the frame is, in words (for reports and errors).
    pub fn describe(&self) -> String {
        match (self.dark, self.polarizer_angle_deg) {
            (true, _) => "dark".into(),
            (false, Some(a)) => format!("polarizer {a}°, DoLP {}, exposure {}×", self.source_dolp, self.exposure_rel),
            (false, None) => format!("unpolarized flat, exposure {}×", self.exposure_rel),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLabFrame {
    file: String,
    polarizer_angle_deg: Option<f64>,
    source_dolp: Option<f64>,
    exposure_rel: Option<f64>,
    dark: Option<bool>,
}

/// One `[[frames]]` table as [`LabCapture::to_toml_string`] writes it: a dark frame
/// is `dark = true` alone; a polarized one its angle and DoLP; every lit one its
/// exposure.
#[derive(serde::Serialize)]
struct OutLabFrame {
    file: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    dark: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    polarizer_angle_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    source_dolp: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    exposure_rel: Option<f64>,
}

impl LabCapture {
    /// Reads and validates `dir/capture.toml` of a lab capture and checks that every
    /// frame file exists (images are not decoded).
    pub fn load(dir: &Path) -> Result<LabCapture> {
        let (toml_path, text) = super::read_capture_toml(dir)?;
        let c = parse(dir, &toml_path, &text)?;
        for (i, f) in c.frames.iter().enumerate() {
            if !dir.join(&f.file).is_file() {
                bail!(&toml_path, "{}: {} does not exist", frame_label(i, Some(&f.file)), dir.join(&f.file).display());
            }
        }
        Ok(c)
    }

    /// `capture.toml` of this capture.
    pub fn toml_path(&self) -> PathBuf {
        self.dir.join("capture.toml")
    }

    /// Decodes frame `index` (a DoFP mosaic in DN) and checks its size and values.
    pub fn read_frame(&self, index: usize) -> Result<Vec<f32>> {
        let f = self.frames.get(index).ok_or_else(|| {
            err(&self.toml_path(), format!("frame index {index} is out of range ({} frames)", self.frames.len()))
        })?;
        let g = &self.sensor.geometry;
        images::read_dofp(
            &self.dir.join(&f.file),
            &frame_label(index, Some(&f.file)),
            (g.width_px, g.height_px),
            self.sensor.bit_depth,
            self.sensor.full_scale_dn(),
        )
    }

    /// `capture.toml` text of this lab capture (serde, as the sky writer's).
    pub fn to_toml_string(&self) -> String {
        let frames = self
            .frames
            .iter()
            .map(|f| OutLabFrame {
                file: super::toml_out::file_key(&f.file),
                dark: f.dark.then_some(true),
                polarizer_angle_deg: f.polarizer_angle_deg.filter(|_| !f.dark),
                source_dolp: f.polarizer_angle_deg.filter(|_| !f.dark).map(|_| f.source_dolp),
                exposure_rel: (!f.dark).then_some(f.exposure_rel),
            })
            .collect();
        super::toml_out::write(Some("lab"), &self.sensor, &self.lens, frames)
    }

    /// Writes this lab capture into the new folder `out_dir`: one 16-bit PNG (or EXR,
    /// by extension) per frame from `frames` (DN mosaics), `capture.toml` last.
    /// Refuses a folder that already holds `capture.toml` or any frame file.
    pub fn write(&self, out_dir: &Path, frames: &[Vec<f32>]) -> Result<()> {
        let toml_path = out_dir.join("capture.toml");
        validate(self, &toml_path)?;
        if toml_path.exists() {
            bail!(&toml_path, "already exists: bpins never writes into a capture; choose a new folder");
        }
        if frames.len() != self.frames.len() {
            bail!(&toml_path, "{} frames of data for {} [[frames]] entries", frames.len(), self.frames.len());
        }
        let g = &self.sensor.geometry;
        for (f, dn) in self.frames.iter().zip(frames) {
            let path = out_dir.join(&f.file);
            if path.exists() {
                bail!(&path, "already exists: bpins never overwrites a frame");
            }
            if dn.len() != (g.width_px * g.height_px) as usize {
                bail!(&path, "{} samples for a {} × {} px sensor", dn.len(), g.width_px, g.height_px);
            }
        }
        for (f, dn) in self.frames.iter().zip(frames) {
            let path = out_dir.join(&f.file);
            if let Some(parent) = path.parent() {
                fs::create_dir_all(parent).map_err(|e| images::io(parent, e))?;
            }
            images::write_dofp(&path, g.width_px, g.height_px, dn, crate::output::Replace::Never)?;
        }
        let text = self.to_toml_string();
        crate::output::write_with(&toml_path, crate::output::Replace::Never, |w| {
            std::io::Write::write_all(w, text.as_bytes()).map_err(|e| images::io(&toml_path, e))
        })
    }
}

/// Parses a lab capture's `capture.toml` (`text`, read from `toml_path`) rooted at `dir`.
pub(crate) fn parse(dir: &Path, toml_path: &Path, text: &str) -> Result<LabCapture> {
    let p = toml_path;
    let Header { kind, sensor, lens, frames: raw } = parse_header(p, text)?;
    if kind != "lab" {
        bail!(p, "kind = \"{kind}\": a sky capture; `bpins calibrate` needs a lab capture (kind = \"lab\")");
    }
    let mut frames = Vec::with_capacity(raw.len());
    for (i, v) in raw.into_iter().enumerate() {
        let hint = v.get("file").and_then(|f| f.as_str()).map(PathBuf::from);
        let label = frame_label(i, hint.as_deref());
        if !v.is_table() {
            bail!(p, "{label} must be a table: write each frame as [[frames]]");
        }
        let f: RawLabFrame = v.try_into().map_err(|e| err(p, format!("{label}: {}", clean(e))))?;
        let dark = f.dark.unwrap_or(false);
        if dark && (f.polarizer_angle_deg.is_some() || f.source_dolp.is_some()) {
            bail!(p, "{label}: a dark frame (dark = true) has no polarizer_angle_deg or source_dolp");
        }
        if f.polarizer_angle_deg.is_none() && f.source_dolp.is_some() {
            bail!(p, "{label}: source_dolp needs polarizer_angle_deg (an unpolarized flat has DoLP 0)");
        }
        frames.push(LabFrame {
            file: PathBuf::from(f.file),
            polarizer_angle_deg: f.polarizer_angle_deg,
            source_dolp: f.source_dolp.unwrap_or(1.0),
            exposure_rel: f.exposure_rel.unwrap_or(1.0),
            dark,
        });
    }
    let c = LabCapture { dir: dir.to_path_buf(), sensor, lens, frames };
    validate(&c, p)?;
    Ok(c)
}

/// The rules of CAPTURE.md on a typed lab capture.
fn validate(c: &LabCapture, p: &Path) -> Result<()> {
    validate_sensor_lens(&c.sensor, &c.lens, p)?;
    if !matches!(c.sensor.layout, Layout::Dofp { .. }) {
        bail!(p, "[sensor] layout: a lab capture is calibrated per pixel of a dofp mosaic; use layout = \"dofp\"");
    }
    if c.frames.is_empty() {
        bail!(p, "no frames: at least one [[frames]] table is required");
    }
    let mut seen: Vec<PathBuf> = Vec::new();
    for (i, f) in c.frames.iter().enumerate() {
        let label = frame_label(i, Some(&f.file));
        validate_frame_file(p, &label, &f.file, &c.sensor.layout)?;
        if let Some(a) = f.polarizer_angle_deg {
            if !a.is_finite() {
                bail!(p, "{label}: polarizer_angle_deg = {a} is not a finite angle");
            }
        }
        if !(0.0..=1.0).contains(&f.source_dolp) || (f.polarizer_angle_deg.is_some() && f.source_dolp <= 0.0) {
            bail!(p, "{label}: source_dolp = {} must be in (0, 1]", f.source_dolp);
        }
        if !(f.exposure_rel.is_finite() && f.exposure_rel > 0.0) {
            bail!(p, "{label}: exposure_rel = {} must be finite and > 0", f.exposure_rel);
        }
        let n = normalised(&f.file);
        if let Some(j) = seen.iter().position(|s| *s == n) {
            bail!(p, "{label}: the same file is already frames[{j}]; each frame needs its own image");
        }
        seen.push(n);
    }
    Ok(())
}

/// Builds the `FrameData` a sky reader would see of a lab frame (the mosaic as is).
pub fn as_frame_data(c: &LabCapture, dn: Vec<f32>) -> FrameData {
    FrameData::Mosaic { width_px: c.sensor.geometry.width_px, height_px: c.sensor.geometry.height_px, dn }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "format = \"bpins-capture/1\"\nkind = \"lab\"\n[sensor]\nlayout = \"dofp\"\n\
        width_px = 8\nheight_px = 4\npixel_pitch_um = 3.45\nbit_depth = 12\n[lens]\nprojection = \"pinhole\"\n\
        focal_length_mm = 8.0\n";

    #[test]
    fn a_lab_capture_parses_with_defaults_and_round_trips() {
        let text = format!(
            "{HEAD}[[frames]]\nfile = \"p0.png\"\npolarizer_angle_deg = 15.0\n\
             [[frames]]\nfile = \"f.png\"\nexposure_rel = 0.5\n[[frames]]\nfile = \"d.png\"\ndark = true\n"
        );
        let c = parse(Path::new("lab"), Path::new("lab/capture.toml"), &text).unwrap();
        assert_eq!(c.frames[0].polarizer_angle_deg, Some(15.0));
        assert_eq!((c.frames[0].source_dolp, c.frames[0].exposure_rel), (1.0, 1.0));
        assert_eq!((c.frames[1].polarizer_angle_deg, c.frames[1].exposure_rel), (None, 0.5));
        assert!(c.frames[2].dark);
        let back = parse(Path::new("lab"), Path::new("lab/capture.toml"), &c.to_toml_string()).unwrap();
        assert_eq!(back, c);
    }

    #[test]
    fn bad_lab_captures_name_the_file_and_the_key() {
        let bad = [
            ("[[frames]]\nfile = \"a.png\"\npolariser_angle_deg = 1.0", "polariser_angle_deg"),
            ("[[frames]]\nfile = \"a.png\"\ndark = true\npolarizer_angle_deg = 1.0", "dark frame"),
            ("[[frames]]\nfile = \"a.png\"\nexposure_rel = -1.0", "exposure_rel"),
            ("[[frames]]\nfile = \"a.png\"\npolarizer_angle_deg = 1.0\nsource_dolp = 1.5", "source_dolp"),
            ("[[frames]]\nfile = \"a.png\"\nsource_dolp = 0.5", "source_dolp needs"),
            ("[[frames]]\nfile = \"a.png\"\n[[frames]]\nfile = \"./a.png\"", "frames[0]"),
            ("", "no frames"),
        ];
        for (frames, want) in bad {
            let text = format!("{HEAD}{frames}\n");
            let e = parse(Path::new("lab"), Path::new("lab/capture.toml"), &text).unwrap_err().to_string();
            assert!(e.contains("lab/capture.toml") && e.contains(want), "{frames:?}: {e}");
        }
        let sky = HEAD.replace("kind = \"lab\"\n", "");
        let e = parse(Path::new("x"), Path::new("x/capture.toml"), &format!("{sky}[[frames]]\nfile = \"a.png\"\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("lab capture"), "{e}");
    }
}
