//! Frame images of a `bpins-capture/1` capture (docs/spec/CAPTURE.md, "Image
//! files"): decoding and checking on read, checking and encoding on write (EXR
//! frames' headers are checked in `exr.rs`, EXR files read and written in `output/exr.rs`).
//!
//! * `dofp`: one single-channel image of the raw mosaic in DN: 16-bit grayscale PNG
//!   or TIFF, or a one-channel EXR (any channel name; written as `DN`). An 8-bit
//!   grayscale PNG/TIFF is accepted only for a sensor of `bit_depth` ≤ 8 (its values
//!   are then DN as they stand); for a deeper sensor it is an error, since 8 bits
//!   cannot hold its DN. RGB, alpha and other formats are errors.
//! * `colocated`: one single-layer EXR with one channel per analyzer, `I0`, `I45`,
//!   `I90`, `I135` (those of `[sensor] channels`); a missing or extra channel is an
//!   error that names it.
//!
//! Values: integer DN above full scale `2^bit_depth − 1` are an error that hints at
//! left-shifted data; float DN must be finite and not above full scale (float DN may
//! be negative: an unquantised simulation with noise about a zero black level).
//! Writing rounds mosaics for PNG/TIFF to integers clamped to [0, 65535] and keeps
//! EXR floats exactly. Decoders and encoders run behind `catch_unwind`, so a corrupt file is an
//! error, never a crash.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use image::{DynamicImage, ImageBuffer, ImageFormat, ImageReader, Luma};

use super::{spec, Capture, FrameData};
use crate::output::{self, Replace};
use crate::sensor::{Channel, Layout};
use crate::{Error, Result};

pub(crate) fn err(path: &Path, message: impl Into<String>) -> Error {
    Error::Capture { path: path.to_path_buf(), message: message.into() }
}

pub(crate) fn io(path: &Path, source: std::io::Error) -> Error {
    Error::Io { path: path.to_path_buf(), source }
}

/// Runs a decoder or encoder; a panic inside it becomes an error about `path`.
pub(crate) use crate::output::exr::guarded;

pub(crate) fn check_size(path: &Path, label: &str, got: (usize, usize), want: (u32, u32)) -> Result<()> {
    if got != (want.0 as usize, want.1 as usize) {
        bail!(
            path,
            "{label}: image is {} × {} px, expected {} × {} px ([sensor] width_px × height_px)",
            got.0,
            got.1,
            want.0,
            want.1
        );
    }
    Ok(())
}

/// Float DN: finite and not above full scale (see the module doc).
pub(crate) fn check_float_dn(path: &Path, label: &str, what: &str, v: &[f32], width: u32, full: f64) -> Result<()> {
    let at = |i: usize| (i % width.max(1) as usize, i / width.max(1) as usize);
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        let (u, w) = at(i);
        bail!(path, "{label}: {what} pixel ({u}, {w}) is {} (not finite)", v[i]);
    }
    let n = v.iter().filter(|&&x| f64::from(x) > full).count();
    if let Some(i) = v.iter().position(|&x| f64::from(x) > full) {
        let (u, w) = at(i);
        bail!(
            path,
            "{label}: {what} {n} pixels exceed full scale {full} DN of the sensor's bit depth, \
             first at ({u}, {w}) = {} DN",
            v[i]
        );
    }
    Ok(())
}

/// Decodes a dofp frame: the mosaic in DN, row-major.
pub(crate) fn read_dofp(path: &Path, label: &str, size: (u32, u32), bit_depth: u32, full: f64) -> Result<Vec<f32>> {
    let format = match spec::image_kind(path) {
        Some("png") => ImageFormat::Png,
        Some("tiff") => ImageFormat::Tiff,
        Some(_) => {
            let (w, _, mut layers) = super::exr::read_exr_checked(path, label, size, |names| {
                if names.len() == 1 {
                    Ok(())
                } else {
                    Err(format!("a dofp EXR must have one channel, this one has {}: {}", names.len(), names.join(", ")))
                }
            })?;
            let (name, v) = layers.pop().ok_or_else(|| err(path, format!("{label}: no channel")))?;
            check_float_dn(path, label, &format!("channel {name}:"), &v, w, full)?;
            return Ok(v);
        }
        None => {
            bail!(path, "{label}: not a .png, .tif/.tiff or .exr file")
        }
    };
    let file = File::open(path).map_err(|e| io(path, e))?;
    let img = guarded(path, || {
        ImageReader::with_format(BufReader::new(file), format).decode().map_err(|e| {
            // A file cut short (a copy or a write interrupted) says so.
            let text = e.to_string();
            let short = if text.contains("end of file") || text.contains("EOF") {
                let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
                format!(" (the file ends early, at {bytes} bytes: truncated?)")
            } else {
                String::new()
            };
            err(path, format!("{label}: cannot decode the image: {text}{short}"))
        })
    })?;
    check_size(path, label, (img.width() as usize, img.height() as usize), size)?;
    let values: Vec<u16> = match img {
        DynamicImage::ImageLuma16(b) => b.into_raw(),
        DynamicImage::ImageLuma8(b) if bit_depth <= 8 => b.into_raw().into_iter().map(u16::from).collect(),
        DynamicImage::ImageLuma8(_) => {
            bail!(path, "{label}: 8-bit image for a {bit_depth}-bit sensor; store the DN in a 16-bit grayscale image");
        }
        other => {
            bail!(
                path,
                "{label}: pixel format {:?}; a dofp frame must be single-channel 16-bit grayscale",
                other.color()
            );
        }
    };
    let n = values.iter().filter(|&&x| f64::from(x) > full).count();
    if let Some(i) = values.iter().position(|&x| f64::from(x) > full) {
        let (u, v) = (i % size.0 as usize, i / size.0 as usize);
        let shift = 16u32.saturating_sub(bit_depth);
        bail!(
            path,
            "{label}: {n} pixels exceed full scale {full} DN of bit_depth = {bit_depth}, first at \
             ({u}, {v}) = {} DN; values look left-shifted (DN·2^{shift} in 16 bits?): store DN, \
             not left-shifted values",
            values[i]
        );
    }
    Ok(values.into_iter().map(f32::from).collect())
}

/// Decodes a colocated frame: one plane per channel of `channels`, in that order.
pub(crate) fn read_colocated(
    path: &Path,
    label: &str,
    size: (u32, u32),
    channels: &[Channel],
    full: f64,
) -> Result<Vec<(Channel, Vec<f32>)>> {
    let want: Vec<&str> = channels.iter().map(|c| c.exr_name()).collect();
    let (w, _, layers) = super::exr::read_exr_checked(path, label, size, |names| {
        if let Some(m) = want.iter().find(|n| !names.iter().any(|x| x == *n)) {
            return Err(format!("missing channel {m} (the file has: {})", names.join(", ")));
        }
        if let Some(x) = names.iter().find(|x| !want.contains(&x.as_str())) {
            return Err(format!("unexpected channel {x}; [sensor] channels lists {}", want.join(", ")));
        }
        Ok(())
    })?;
    let mut out = Vec::with_capacity(channels.len());
    for &c in channels {
        let v = layers
            .iter()
            .find(|(n, _)| n == c.exr_name())
            .map(|(_, v)| v.clone())
            .ok_or_else(|| err(path, format!("{label}: missing channel {}", c.exr_name())))?;
        check_float_dn(path, label, &format!("channel {}:", c.exr_name()), &v, w, full)?;
        out.push((c, v));
    }
    Ok(out)
}

/// Mosaic DN as 16-bit integers: rounded, clamped to [0, 65535].
pub(crate) fn to_u16(dn: &[f32]) -> Vec<u16> {
    dn.iter().map(|&x| x.round().clamp(0.0, 65535.0) as u16).collect()
}

/// Writes a dofp mosaic (already validated), whole or not at all (`output.rs`), in
/// the format its extension names.
pub(crate) fn write_dofp(path: &Path, width_px: u32, height_px: u32, dn: &[f32], replace: Replace) -> Result<()> {
    let kind = spec::image_kind(path);
    if kind == Some("exr") {
        let image = crate::output::exr::exr_image(path, width_px, height_px, &[("DN", dn)])?;
        return output::write_with(path, replace, |w| crate::output::exr::write_exr_to(path, w, image));
    }
    let format = match kind {
        Some("png") => ImageFormat::Png,
        Some("tiff") => ImageFormat::Tiff,
        _ => {
            bail!(path, "a dofp frame is written as .png, .tif/.tiff or .exr")
        }
    };
    let buf: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_raw(width_px, height_px, to_u16(dn))
        .ok_or_else(|| err(path, "mosaic size does not match width × height"))?;
    output::write_with(path, replace, |w| {
        guarded(path, || buf.write_to(w, format).map_err(|e| err(path, format!("cannot write the image: {e}"))))
    })
}

/// Writes a colocated frame (already validated) to an EXR file, whole or not at all.
pub(crate) fn write_colocated(
    path: &Path,
    width_px: u32,
    height_px: u32,
    planes: &[(Channel, Vec<f32>)],
    replace: Replace,
) -> Result<()> {
    let layers: Vec<(&str, &[f32])> = planes.iter().map(|(c, v)| (c.exr_name(), v.as_slice())).collect();
    let image = crate::output::exr::exr_image(path, width_px, height_px, &layers)?;
    output::write_with(path, replace, |w| crate::output::exr::write_exr_to(path, w, image))
}

/// Checks that `data` fits frame `i` of capture `c` and will read back (before any
/// file is written).
pub(crate) fn check_frame_data(c: &Capture, i: usize, data: &FrameData, path: &Path) -> Result<()> {
    let label = spec::frame_label(i, Some(&c.frames[i].file));
    let g = &c.sensor.geometry;
    let (w, h) = data.size_px();
    if (w, h) != (g.width_px, g.height_px) {
        bail!(path, "{label}: data is {w} × {h} px, the sensor {} × {} px", g.width_px, g.height_px);
    }
    let n = w as usize * h as usize;
    let full = c.sensor.full_scale_dn();
    match (&c.sensor.layout, data) {
        (Layout::Dofp { .. }, FrameData::Mosaic { dn, .. }) => {
            if dn.len() != n {
                bail!(path, "{label}: mosaic has {} values, expected {n}", dn.len());
            }
            if spec::image_kind(path) == Some("exr") {
                check_float_dn(path, &label, "mosaic", dn, w, full)
            } else {
                check_float_dn(path, &label, "mosaic", dn, w, f64::INFINITY)?;
                let ints: Vec<f32> = to_u16(dn).into_iter().map(f32::from).collect();
                check_float_dn(path, &label, "rounded mosaic", &ints, w, full)
            }
        }
        (Layout::Colocated { channels }, FrameData::Colocated { channels: planes, .. }) => {
            let mut got: Vec<Channel> = planes.iter().map(|(c, _)| *c).collect();
            let mut want = channels.clone();
            got.sort();
            want.sort();
            if got != want {
                bail!(path, "{label}: data has channels {:?}, [sensor] channels are {:?}", got, want);
            }
            for (c, v) in planes {
                if v.len() != n {
                    bail!(path, "{label}: channel {} has {} values, expected {n}", c.exr_name(), v.len());
                }
                check_float_dn(path, &label, &format!("channel {}:", c.exr_name()), v, w, full)?;
            }
            Ok(())
        }
        (Layout::Dofp { .. }, _) => Err(err(path, format!("{label}: a dofp capture needs FrameData::Mosaic"))),
        (Layout::Colocated { .. }, _) => {
            Err(err(path, format!("{label}: a colocated capture needs FrameData::Colocated")))
        }
    }
}
