//! Float OpenEXR files, read and written: a capture's float frames
//! (docs/spec/CAPTURE.md: a one-channel EXR for dofp, channels `I0` … `I135` for
//! colocated; `capture/exr.rs` checks a frame's header before it reads), a
//! calibration's per-pixel maps, and multi-channel float dumps of a run (`I0` …
//! `I135`, `AoP`, `DoLP`, `AoE`). Here, below both the capture format and the
//! calibration, so that each reads and writes its EXR files without the other.
//! Files are written single-layer, f32, lossless ZIP (or RLE: `write_exr_layers_fast`),
//! whole or absent (`output.rs`); reading converts any sample type to f32, row-major.
//! The decoder runs behind `catch_unwind` ([`guarded`]), so a corrupt file is an
//! error, never a crash. Errors are [`Error::Capture`] naming the file.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, ReadChannels, ReadLayers, SmallVec,
    Text, WritableImage,
};

use crate::{Error, Result};

/// `(width_px, height_px, [(channel name, row-major f32 plane)])` of an EXR file.
pub type ExrLayers = (u32, u32, Vec<(String, Vec<f32>)>);

fn err(path: &Path, message: impl Into<String>) -> Error {
    Error::Capture { path: path.to_path_buf(), message: message.into() }
}

/// Runs a decoder or encoder; a panic inside it becomes an error about `path`.
pub(crate) fn guarded<T>(path: &Path, f: impl FnOnce() -> Result<T>) -> Result<T> {
    catch_unwind(AssertUnwindSafe(f))
        .unwrap_or_else(|_| Err(err(path, "the image library failed on this file (corrupt or unsupported)")))
}

fn flat_to_f32(s: &FlatSamples) -> Vec<f32> {
    match s {
        FlatSamples::F32(v) => v.clone(),
        other => other.values_as_f32().collect(),
    }
}

/// Reads every channel of a flat (non-deep) OpenEXR file as `f32`, row-major, at full
/// resolution: `(width_px, height_px, [(name, plane)])`. Channels come in the file's
/// (alphabetical) order; in a multi-layer file names are `layer.channel`, and all
/// layers must share one size.
pub fn read_exr_layers(path: &Path) -> Result<ExrLayers> {
    let image = guarded(path, || {
        exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_file(path)
            .map_err(|e| err(path, format!("cannot read as OpenEXR: {e}")))
    })?;
    let mut size: Option<(usize, usize)> = None;
    let mut out = Vec::new();
    for layer in &image.layer_data {
        let s = (layer.size.0, layer.size.1);
        if *size.get_or_insert(s) != s {
            return Err(err(path, "EXR layers differ in size"));
        }
        let prefix = layer.attributes.layer_name.as_ref().map(|n| format!("{n}."));
        for ch in &layer.channel_data.list {
            let v = flat_to_f32(&ch.sample_data);
            let name = format!("{}{}", prefix.as_deref().unwrap_or(""), ch.name);
            if v.len() != s.0 * s.1 {
                return Err(err(
                    path,
                    format!("EXR channel {name} is subsampled; only full-resolution channels are read"),
                ));
            }
            out.push((name, v));
        }
    }
    let (w, h) = size.ok_or_else(|| err(path, "EXR file has no layers"))?;
    let (w, h) = (u32::try_from(w), u32::try_from(h));
    match (w, h) {
        (Ok(w), Ok(h)) => Ok((w, h, out)),
        _ => Err(err(path, "EXR image too large")),
    }
}

pub(crate) fn exr_image(
    path: &Path,
    width_px: u32,
    height_px: u32,
    layers: &[(&str, &[f32])],
) -> Result<Image<Layer<AnyChannels<FlatSamples>>>> {
    exr_image_encoded(path, width_px, height_px, layers, Encoding::SMALL_LOSSLESS)
}

fn exr_image_encoded(
    path: &Path,
    width_px: u32,
    height_px: u32,
    layers: &[(&str, &[f32])],
    encoding: Encoding,
) -> Result<Image<Layer<AnyChannels<FlatSamples>>>> {
    if width_px == 0 || height_px == 0 {
        return Err(err(path, format!("cannot write an empty {width_px} × {height_px} px EXR")));
    }
    if layers.is_empty() {
        return Err(err(path, "cannot write an EXR without channels"));
    }
    let n = width_px as usize * height_px as usize;
    let mut channels = Vec::with_capacity(layers.len());
    for (i, (name, data)) in layers.iter().enumerate() {
        let ok_name = !name.is_empty() && name.len() <= 31 && name.bytes().all(|b| b.is_ascii_graphic());
        let text = Text::new_or_none(name)
            .filter(|_| ok_name)
            .ok_or_else(|| err(path, format!("EXR channel name `{name}` must be 1 … 31 printable ASCII characters")))?;
        if layers[..i].iter().any(|(m, _)| m == name) {
            return Err(err(path, format!("EXR channel `{name}` given twice")));
        }
        if data.len() != n {
            return Err(err(
                path,
                format!("EXR channel `{name}` has {} values, expected {width_px} × {height_px} = {n}", data.len()),
            ));
        }
        channels.push(AnyChannel::new(text, FlatSamples::F32(data.to_vec())));
    }
    let layer = Layer::new(
        (width_px as usize, height_px as usize),
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    Ok(Image::from_layer(layer))
}

pub(crate) fn write_exr_to(
    path: &Path,
    w: &mut (impl std::io::Write + std::io::Seek),
    image: Image<Layer<AnyChannels<FlatSamples>>>,
) -> Result<()> {
    guarded(path, || image.write().to_buffered(w).map_err(|e| err(path, format!("cannot write OpenEXR: {e}"))))
}

/// Writes one single-layer float OpenEXR file (lossless ZIP) holding `layers` as
/// named `f32` channels, each `width_px × height_px` row-major (e.g. `I0` … `I135`,
/// `AoP`, `DoLP`, `AoE` for a run's dumps). Replaces `path` if it exists, whole or
/// not at all (`output.rs`); callers choose an output folder outside any capture. Channel names: 1 … 31 printable
/// ASCII characters, distinct; EXR stores them sorted by name.
pub fn write_exr_layers(path: &Path, width_px: u32, height_px: u32, layers: &[(&str, &[f32])]) -> Result<()> {
    let image = exr_image(path, width_px, height_px, layers)?;
    crate::output::write_with(path, crate::output::Replace::Allowed, |w| write_exr_to(path, w, image))
}

/// [`write_exr_layers`] with run-length instead of ZIP compression: several times
/// faster for large noisy float maps (which ZIP hardly shrinks), files about as
/// large as the raw floats. Read back by [`read_exr_layers`] like any other.
pub fn write_exr_layers_fast(path: &Path, width_px: u32, height_px: u32, layers: &[(&str, &[f32])]) -> Result<()> {
    use exr::prelude::{Blocks, Compression, LineOrder};
    let encoding =
        Encoding { compression: Compression::RLE, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let image = exr_image_encoded(path, width_px, height_px, layers, encoding)?;
    crate::output::write_with(path, crate::output::Replace::Allowed, |w| write_exr_to(path, w, image))
}
