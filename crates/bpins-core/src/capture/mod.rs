//! Capture bundles (`bpins-capture/1`, docs/spec/CAPTURE.md): reading, validating
//! and writing.
//!
//! A capture is a folder holding `capture.toml` and the frame images it names.
//! [`Capture::load`] parses (`spec.rs`) and validates (`validate.rs`) `capture.toml`
//! and checks that every frame file exists; [`Capture::read_frame`] decodes and
//! checks one image (`images.rs`, `exr.rs`; EXR files through `output/exr.rs`); [`Capture::write`] writes a new capture
//! into a new folder (`toml_out.rs` writes the toml). Conventions (pixels, angles,
//! mosaic) are those of CONVENTIONS.md.
//!
//! Nothing is ever written into a capture: `write` refuses a folder that already
//! holds `capture.toml`, any target inside the capture being written from, and any
//! image file that already exists. It checks everything before it writes anything
//! and writes `capture.toml` last, so a folder with `capture.toml` is complete (an
//! I/O failure midway leaves images without `capture.toml`). Every error names the
//! file (`capture.toml` or the image) and the key or frame.

/// `return Err(Error::Capture { path, message: format!(…) })`.
macro_rules! bail {
    ($path:expr, $($fmt:tt)+) => {
        return Err($crate::capture::images::err($path, format!($($fmt)+)))
    };
}

mod colour;
mod exr;
mod images;
pub mod lab;
pub mod ranges;
mod spec;
mod toml_out;
mod validate;
mod writer;

use std::fs;
use std::path::{Component, Path, PathBuf};

pub use crate::output::exr::{read_exr_layers, write_exr_layers, write_exr_layers_fast, ExrLayers};
pub use colour::{colour_period, ColourPeriod};
pub use lab::{LabCapture, LabFrame};

/// The message of the [`Error::Capture`] for a folder without `capture.toml` (a
/// missing folder, a mistyped path): the bindings turn it into their language's
/// file-not-found error (Python's `FileNotFoundError`).
pub const NOT_FOUND: &str = "not found: a capture is a folder holding capture.toml (docs/spec/CAPTURE.md)";
pub(crate) use spec::clean as clean_toml_error;
pub(crate) use spec::parse_sensor_lens;
pub use spec::FORMAT;
pub(crate) use validate::validate_sensor_lens;
pub use writer::CaptureWriter;

use crate::camera::{Intrinsics, Projection};
use crate::sensor::{Channel, ColourTiles, Geometry, Layout};
use crate::sky::sun::SunPosition;
use crate::{Error, Result};
use images::err;
use spec::frame_label;

/// A capture: where it lies, what took it, and what is known about each frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    /// The capture folder (as given to [`Capture::load`]).
    pub dir: PathBuf,
    pub sensor: SensorSpec,
    pub lens: LensSpec,
    pub frames: Vec<FrameSpec>,
}

/// `[sensor]` of `capture.toml`.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorSpec {
    pub layout: Layout,
    pub geometry: Geometry,
    /// 1 … 16; default 16.
    pub bit_depth: u32,
    /// Default 0.
    pub black_level_dn: f64,
    /// The colour filters of a colour-polarization DoFP sensor (`colour_tiles`,
    /// `band_centre_nm`); `None`: monochrome.
    pub colour: Option<ColourTiles>,
}

impl SensorSpec {
    /// Largest DN the sensor outputs, `2^bit_depth − 1`.
    pub fn full_scale_dn(&self) -> f64 {
        2f64.powf(f64::from(self.bit_depth)) - 1.0
    }

    /// The analyzer channels the sensor measures: all four for dofp, in angle order;
    /// the listed ones, in file order, for colocated.
    pub fn channels(&self) -> Vec<Channel> {
        match &self.layout {
            Layout::Dofp { .. } => Channel::ALL.to_vec(),
            Layout::Colocated { channels } => channels.clone(),
        }
    }
}

/// `[lens]` of `capture.toml`.
#[derive(Clone, Debug, PartialEq)]
pub struct LensSpec {
    pub projection: Projection,
    pub focal_length_mm: f64,
    /// Nominal principal point (x, y) in pixels; default the image centre
    /// `((W−1)/2, (H−1)/2)`.
    pub principal_point_px: (f64, f64),
}

/// One `[[frames]]` entry.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameSpec {
    /// The image file, relative to the capture folder, as written in the toml.
    pub file: PathBuf,
    /// Given, or resolved from time and place by NREL SPA at load.
    pub sun: SunPosition,
    /// Reference heading, degrees, where known.
    pub heading_deg: Option<f64>,
    pub tilt_x_deg: Option<f64>,
    pub tilt_y_deg: Option<f64>,
    /// 1σ of each reference tilt angle (an IMU's attitude error), degrees.
    pub tilt_sigma_deg: Option<f64>,
    /// 1σ of the sun's azimuth and elevation (clock or position error), degrees.
    pub sun_sigma_deg: Option<f64>,
    /// The camera's yaw as a gyro integrates it (degrees, the sense of the heading:
    /// from North toward East), where known; only its changes between frames count
    /// (`bpins locate`).
    pub yaw_deg: Option<f64>,
    /// 1σ of `yaw_deg`'s change from the first frame, degrees.
    pub yaw_sigma_deg: Option<f64>,
}

impl FrameSpec {
    /// The frame `file` under `sun`, nothing else known (no reference heading, tilt,
    /// 1σ or yaw): set what is known with struct update syntax,
    /// `FrameSpec { heading_deg: Some(30.0), ..FrameSpec::new(file, sun) }`.
    pub fn new(file: impl Into<PathBuf>, sun: SunPosition) -> Self {
        FrameSpec {
            file: file.into(),
            sun,
            heading_deg: None,
            tilt_x_deg: None,
            tilt_y_deg: None,
            tilt_sigma_deg: None,
            sun_sigma_deg: None,
            yaw_deg: None,
            yaw_sigma_deg: None,
        }
    }
}

/// The pixels of one frame, in DN.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameData {
    /// dofp: the raw mosaic, row-major (`dn[v·W + u]`).
    Mosaic { width_px: u32, height_px: u32, dn: Vec<f32> },
    /// colocated: one row-major plane per channel, in `[sensor] channels` order.
    Colocated { width_px: u32, height_px: u32, channels: Vec<(Channel, Vec<f32>)> },
}

impl FrameData {
    /// `(width_px, height_px)`.
    pub fn size_px(&self) -> (u32, u32) {
        match self {
            FrameData::Mosaic { width_px, height_px, .. } | FrameData::Colocated { width_px, height_px, .. } => {
                (*width_px, *height_px)
            }
        }
    }
}

impl Capture {
    /// Reads and validates `dir/capture.toml` (`dir` may also be the `capture.toml`
    /// file itself) and checks that every frame file exists. Images are not decoded.
    pub fn load(dir: &Path) -> Result<Capture> {
        Self::load_with(dir, false)
    }

    /// [`Capture::load`] that also reads frames stamped with `time_utc` and no place
    /// (a robot without GNSS: `bpins locate`); their sun is
    /// [`SunSource::Unplaced`](crate::sky::sun::SunSource), its angles NaN.
    pub fn load_unplaced(dir: &Path) -> Result<Capture> {
        Self::load_with(dir, true)
    }

    fn load_with(dir: &Path, unplaced: bool) -> Result<Capture> {
        let dir = match dir.file_name() {
            Some(n) if n == "capture.toml" && dir.is_file() => match dir.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            },
            _ => dir,
        };
        let (toml_path, text) = read_capture_toml(dir)?;
        let capture = spec::parse(dir, &toml_path, &text, unplaced)?;
        validate::validate(&capture, &toml_path)?;
        for (i, f) in capture.frames.iter().enumerate() {
            let p = dir.join(&f.file);
            if !p.is_file() {
                let what = if p.exists() { "is not a file" } else { "does not exist" };
                bail!(&toml_path, "{}: {} {what}", frame_label(i, Some(&f.file)), p.display());
            }
        }
        Ok(capture)
    }

    /// Parses and validates the text of a `capture.toml` that lies (or is to lie) in
    /// `dir`, as [`Capture::load`] does, without looking for the frame files: for a
    /// capture described in code or in another language before it is written.
    pub fn parse(dir: &Path, text: &str) -> Result<Capture> {
        let toml_path = dir.join("capture.toml");
        let capture = spec::parse(dir, &toml_path, text, false)?;
        validate::validate(&capture, &toml_path)?;
        Ok(capture)
    }

    /// Checks every range and rule of CAPTURE.md (docs/ranges.md), as reading and
    /// writing do; for a capture built in code before it is used. Errors are reported
    /// against [`Capture::toml_path`].
    pub fn validate(&self) -> Result<()> {
        validate::validate(self, &self.toml_path())
    }

    /// `capture.toml` of this capture.
    pub fn toml_path(&self) -> PathBuf {
        self.dir.join("capture.toml")
    }

    /// Decodes frame `index` and checks its size, pixel format and values.
    pub fn read_frame(&self, index: usize) -> Result<FrameData> {
        let f = self.frames.get(index).ok_or_else(|| {
            err(
                &self.toml_path(),
                format!("frame index {index} is out of range: the capture has {} frames", self.frames.len()),
            )
        })?;
        let path = self.dir.join(&f.file);
        let label = frame_label(index, Some(&f.file));
        let g = &self.sensor.geometry;
        let size = (g.width_px, g.height_px);
        let full = self.sensor.full_scale_dn();
        match &self.sensor.layout {
            Layout::Dofp { .. } => {
                let dn = images::read_dofp(&path, &label, size, self.sensor.bit_depth, full)?;
                let (w, h) = (g.width_px as usize, g.height_px as usize);
                // A monochrome sensor's frame that looks like a colour mosaic: refused,
                // as reading it would mix the bands (capture/colour.rs).
                if self.sensor.colour.is_none() {
                    if let Some(period) = colour::colour_period(&dn, w, h, self.sensor.black_level_dn, full) {
                        bail!(&path, "{label}: {period}");
                    }
                }
                Ok(FrameData::Mosaic { width_px: g.width_px, height_px: g.height_px, dn })
            }
            Layout::Colocated { channels } => Ok(FrameData::Colocated {
                width_px: g.width_px,
                height_px: g.height_px,
                channels: images::read_colocated(&path, &label, size, channels, full)?,
            }),
        }
    }

    /// Writes this capture as a new capture in `out_dir`: `capture.toml` and one image
    /// per frame at `out_dir/self.frames[i].file`, from `frames[i]`: a
    /// [`CaptureWriter`] fed every frame (see there for what is refused).
    pub fn write(&self, out_dir: &Path, frames: &[FrameData]) -> Result<()> {
        let toml_path = out_dir.join("capture.toml");
        if frames.len() != self.frames.len() {
            bail!(&toml_path, "{} frames of data for {} [[frames]] entries", frames.len(), self.frames.len());
        }
        for (i, data) in frames.iter().enumerate() {
            images::check_frame_data(self, i, data, &out_dir.join(&self.frames[i].file))?;
        }
        let mut w = self.writer(out_dir)?;
        for data in frames {
            w.write_frame(data)?;
        }
        w.finish()
    }

    /// `capture.toml` text of this capture, every default written out.
    pub fn to_toml_string(&self) -> String {
        toml_out::to_toml(self)
    }

    /// Focal length in pixels, `focal_length_mm · 1000 / pixel_pitch_um`.
    pub fn focal_length_px(&self) -> f64 {
        self.lens.focal_length_mm * 1000.0 / self.sensor.geometry.pixel_pitch_um
    }

    /// Nominal camera intrinsics of the capture (projection, f_px, principal point).
    pub fn intrinsics(&self) -> Intrinsics {
        Intrinsics {
            projection: self.lens.projection,
            f_px: self.focal_length_px(),
            cx_px: self.lens.principal_point_px.0,
            cy_px: self.lens.principal_point_px.1,
            distortion: [0.0; 2],
        }
    }
}

/// A sensor file: the `[sensor]` and `[lens]` tables of `capture.toml` alone, with
/// its defaults and ranges (CAPTURE.md), for frames that come from elsewhere (a ROS
/// 2 bag: `bpins heading --bag`). Any other key is an error naming it.
pub fn load_sensor_file(path: &Path) -> Result<(SensorSpec, LensSpec)> {
    let text = fs::read_to_string(path).map_err(|e| Error::Io { path: path.to_path_buf(), source: e })?;
    let mut table: toml::Table = text.parse().map_err(|e: toml::de::Error| err(path, spec::clean(e)))?;
    let (sensor, lens) = (table.remove("sensor"), table.remove("lens"));
    if let Some(k) = table.keys().next() {
        bail!(path, "unknown key `{k}`: a sensor file holds [sensor] and [lens] only (CAPTURE.md)");
    }
    let (s, l) = spec::parse_sensor_lens(path, sensor, lens)?;
    validate::validate_sensor_lens(&s, &l, path)?;
    Ok((s, l))
}

/// `p` made absolute, `..` resolved, and every existing prefix canonicalised.
/// `dir/capture.toml` (its path and its text), or why `dir` is no capture folder, in
/// words: a file given for the folder, a ROS 2 bag (which `bpins heading --bag` and
/// `bpins bag-to-capture` read), or nothing there ([`NOT_FOUND`]). Sky and lab
/// captures are opened through here.
pub(crate) fn read_capture_toml(dir: &Path) -> Result<(PathBuf, String)> {
    let toml_path = dir.join("capture.toml");
    if dir.is_file() {
        let bag = matches!(dir.extension().and_then(|e| e.to_str()), Some("mcap" | "db3"));
        let hint = if bag {
            format!(
                "; it looks like a ROS 2 bag's storage file: give its folder (the one with metadata.yaml) to \
                 `bpins heading --bag {}` or `bpins bag-to-capture --bag {} --out CAPTURE`",
                parent_or_dot(dir),
                parent_or_dot(dir)
            )
        } else {
            String::new()
        };
        bail!(dir, "is a file, not a capture folder (a folder holding capture.toml){hint}");
    }
    let bytes = match fs::read(&toml_path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            if looks_like_a_ros2_bag(dir) {
                bail!(
                    dir,
                    "has no capture.toml but looks like a ROS 2 bag (metadata.yaml and .mcap/.db3 storage): \
                     `bpins heading --bag {d}` reads its frames as they are, `bpins bag-to-capture --bag {d} \
                     --out CAPTURE` makes a capture of them (docs/ros2.md)",
                    d = dir.display()
                );
            }
            return Err(err(&toml_path, NOT_FOUND));
        }
        Err(e) => return Err(Error::Io { path: toml_path, source: e }),
    };
    let text = String::from_utf8(bytes).map_err(|_| err(&toml_path, "not UTF-8 text"))?;
    Ok((toml_path, text))
}

/// The folder of `file` as a user would type it (`.` for a bare name).
fn parent_or_dot(file: &Path) -> String {
    match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.display().to_string(),
        _ => ".".into(),
    }
}

/// A rosbag2 folder: `metadata.yaml` beside `.mcap` or `.db3` storage files.
fn looks_like_a_ros2_bag(dir: &Path) -> bool {
    dir.join("metadata.yaml").is_file()
        && fs::read_dir(dir).is_ok_and(|entries| {
            entries.flatten().any(|e| matches!(e.path().extension().and_then(|x| x.to_str()), Some("mcap" | "db3")))
        })
}

/// The capture folder (one holding `capture.toml`) that `path` lies in or is, if
/// any: outputs must never go there. `..` and symbolic links are resolved first.
pub fn enclosing_capture(path: &Path) -> Result<Option<PathBuf>> {
    let resolved = resolve_path(path)?;
    Ok(resolved.ancestors().find(|a| a.join("capture.toml").is_file()).map(Path::to_path_buf))
}

/// `p` made absolute, its components taken in order: `.` dropped, `..` the parent of
/// what precedes it, and each prefix that exists canonicalized (its links followed)
/// before the next is added, as the kernel walks it. The one resolution every "never
/// write into the input" check compares with (captures here, bags in the CLI).
pub fn resolve_path(p: &Path) -> Result<PathBuf> {
    let abs = std::path::absolute(p).map_err(|e| Error::Io { path: p.to_path_buf(), source: e })?;
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
        if out.exists() {
            out = fs::canonicalize(&out).unwrap_or(out);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
