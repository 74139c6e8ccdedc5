//! A capture's EXR frames: the header checked (one layer, the sensor's size, the
//! channel names the layout wants) before the frame is read. Reading and writing EXR
//! files themselves is `output/exr.rs`, shared with the calibration and the dumps.

use std::path::Path;

use exr::prelude::MetaData;

use super::images::{check_size, err, guarded};
use crate::output::exr::{read_exr_layers, ExrLayers};
use crate::{Error, Result};

/// Reads a frame EXR after checking its header: one layer, of `size`, whose channel
/// names pass `names_ok`.
pub(crate) fn read_exr_checked(
    path: &Path,
    label: &str,
    size: (u32, u32),
    names_ok: impl FnOnce(&[String]) -> std::result::Result<(), String>,
) -> Result<ExrLayers> {
    let meta = guarded(path, || {
        MetaData::read_from_file(path, false)
            .map_err(|e| err(path, format!("{label}: not a readable OpenEXR file: {e}")))
    })?;
    if meta.headers.len() != 1 {
        bail!(path, "{label}: EXR has {} layers; a frame is one layer", meta.headers.len());
    }
    let h = &meta.headers[0];
    if h.deep {
        bail!(path, "{label}: deep EXR data is not an image frame");
    }
    check_size(path, label, (h.layer_size.0, h.layer_size.1), size)?;
    let names: Vec<String> = h.channels.list.iter().map(|c| c.name.to_string()).collect();
    names_ok(&names).map_err(|m| err(path, format!("{label}: {m}")))?;
    read_exr_layers(path).map_err(|e| match e {
        Error::Capture { path, message } => Error::Capture { path, message: format!("{label}: {message}") },
        e => e,
    })
}
