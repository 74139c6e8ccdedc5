//! Each frame's sky mask, once per capture: what the fit reads (`FitOptions::sky_masks`).

use crate::capture::{Capture, FrameData};
use crate::effects::Model;
use crate::error::Result;
use crate::fit::FitOptions;
use crate::heading::field::{self, FieldOptions, SkyMask};
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
    let cells = crate::pipeline::frame_cells(c, data, known, None)?;
    let ctx = crate::pipeline::field_context(c, &c.frames[k], known);
    Ok(field::sky_mask(&cells, &ctx, &FieldOptions::default()).ok())
}
