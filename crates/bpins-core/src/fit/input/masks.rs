//! Each frame's sky mask, once per capture: what the fit reads (`FitOptions::sky_masks`).
//!
//! A colour-polarization capture's mask is its green band's: the field estimator on the
//! cells of the G tiles alone (`Cells::fill_from_mosaic_band`, cells of whole 4 × 4
//! superpixels as the colour compass makes them), applied to every pixel of every band.
//! G has two tiles of four, hence the most signal, and clouds, trees and buildings are
//! not sky in any band (white clouds are depolarized in each). The G cells carry the
//! frame's red-to-blue ratio (`Cells::tint_of`), as the colour compass's do, so the
//! estimator's colour cloud test leaves out white clouds that are neither brighter nor
//! less polarized than the sky. The mask's heading (the fit's first heading of a frame
//! without a reference) is then G's, within a few hundredths of a degree of the fused
//! one on a clear sky (docs/colour.md).

use crate::capture::{Capture, FrameData};
use crate::effects::Model;
use crate::error::Result;
use crate::fit::FitOptions;
use crate::heading::field::{self, CellScratch, Cells, FieldOptions, RawImage, SkyMask};
use crate::recon::Reconstructor;
use crate::sensor::{Band, Channel, Layout};
use rayon::prelude::*;

/// The sky mask of every frame of `c` ([`crate::heading::field::sky_mask`] on the
/// frames in memory, read with the effects `opts.known`); `None` for a frame whose
/// sky the field estimator cannot find (the fit then reads every pixel of it). A
/// diagnosis computes them once and hands them to each of its fits.
pub fn sky_masks(c: &Capture, frames: &[FrameData], opts: &FitOptions) -> Result<Vec<Option<SkyMask>>> {
    let known = opts.known.model();
    frames.par_iter().enumerate().map(|(k, data)| sky_mask_of(c, k, data, &known)).collect()
}

/// The sky mask of frame `k` of `c` whose pixels are `data`, read with `known`.
pub(crate) fn sky_mask_of(c: &Capture, k: usize, data: &FrameData, known: &Model) -> Result<Option<SkyMask>> {
    let cells = match green_cells(c, data, known, None)? {
        Some(cells) => cells,
        None => crate::pipeline::frame_cells(c, data, known, None)?,
    };
    let ctx = crate::pipeline::field_context(c, &c.frames[k], known);
    Ok(field::sky_mask(&cells, &ctx, &FieldOptions::default()).ok())
}

/// A colour capture's frame: the cells of its G tiles with the frame's red-to-blue
/// ratio, the `known` analyzer and channel errors undone, at the colour compass's cell
/// size (`cell_px`, or the default cell, rounded up to whole superpixels, at least two
/// each way); `None` on a monochrome capture. The fit's masks and `locate`'s sky sun
/// (`locate/capture.rs`) read these.
pub(crate) fn green_cells(
    c: &Capture,
    data: &FrameData,
    known: &Model,
    cell_px: Option<usize>,
) -> Result<Option<Cells>> {
    let (Some(tiles), Layout::Dofp { mosaic }, FrameData::Mosaic { width_px, height_px, dn }) =
        (&c.sensor.colour, &c.sensor.layout, data)
    else {
        return Ok(None);
    };
    let (w, h) = (*width_px as usize, *height_px as usize);
    let rec = Reconstructor::new(known, c.sensor.black_level_dn, &Channel::ALL)?;
    let cell_px = cell_px.unwrap_or_else(|| Cells::default_cell_px(w, h)).div_ceil(4).max(2) * 4;
    let img = RawImage::packed(dn.as_slice(), w, h);
    let mut scratch = CellScratch::default();
    let [mut red, mut green, mut blue] = [Cells::default(), Cells::default(), Cells::default()];
    for (b, cells) in [(Band::R, &mut red), (Band::G, &mut green), (Band::B, &mut blue)] {
        let full = c.sensor.full_scale_dn();
        cells.fill_from_mosaic_band(&img, mosaic, tiles.classes(b), &rec, full, cell_px, &mut scratch);
    }
    Cells::tint_of(&red, &blue, &mut green.tint);
    Ok(Some(green))
}
