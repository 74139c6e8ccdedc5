//! Dim frames read on larger cells: where a frame is dim (its cells' mean radiance
//! less than 40σ of its noise: tens of electrons per pixel, a night's), its cells'
//! noise is first counted whole ([`noise_factor`]: `cells.rs` leaves out the gradient
//! extrapolation's share, ×1.5 on 4 px cells, which by day the robust fit absorbs and
//! at night made the 1σ and the dark test too small), and where its
//! polarized signal stands less than 6σ above its cells' noise (`dark.rs`'s measure),
//! 2 × 2 cells are merged, again while it does and the grid keeps at least 16 × 16
//! cells.
//!
//! ```text
//! S_merged = ¼ Σ S_j                 mean Stokes of the four (equal pixel counts)
//! var_merged = Σ var_j / 16          the variance of that mean (independent noise)
//! snr ← ≈ 2·snr per merge            (the signal stays, the noise halves)
//! ```
//!
//! Why: a cell's AoP noise σ_α = σ/(2P) enters every step of the estimator (the start
//! search's 2° cap, the cloud test's DoLP, Tukey's weights). At night, with a few tens
//! of electrons per pixel, default cells (~1/64 of the shorter side: 4 px on a 256 px
//! frame, four pixels per analyzer channel) measure AoP to ±20° and their noise from
//! one degree of freedom; the start search then finds no heading its cells agree on
//! (measured: a full moon at 25°, the IMX250MZR at f/1.4 and 0.5 s, 256 × 256 px: 7 of
//! 8 frames ambiguous at 4 px cells, 8 of 8 within 1σ at 8 px). Larger cells carry the
//! same information with less noise per cell and 4× the degrees of freedom per noise
//! estimate. A bright frame is untouched, however weakly polarized (a day's overcast:
//! its cells' radiance stands hundreds of σ above their noise), and so is a dim one
//! whose polarized signal stands 6σ above it.
//!
//! Where the fit of a dim frame that still stands less than 6σ above its noise fails
//! (ambiguous, too little sky, a misfit, a contradiction), the failure is named for the
//! dark ([`explain_dim`]: `NoHeading::TooDark`, with the numbers).
//!
//! Units: DN; pixels. Frame: the image's (cell centres), Stokes in the image frame.
//! Cannot: merge across a cell that is missing (saturated, off the sensor's whole
//! cells): such a 2 × 2 block is dropped, which on a frame with the sun's disc in
//! view removes a little more sky around it.

use super::{Cell, Cells, NoHeading};
use crate::stokes::Stokes;

/// Merge while the polarized signal stands less than this above the noise…
const POLARIZED_SNR: f64 = 6.0;
/// … and the cells' radiance less than this.
const DIM_SNR: f64 = 40.0;
/// Never merge below this many cells across or down.
const MIN_GRID: usize = 16;

/// The frame's polarized signal against its cells' noise (`dark.rs`'s measure on the
/// cells themselves: bias removed, ratio of sums).
pub(super) fn polarized_snr(cells: &Cells) -> f64 {
    let (mut p2, mut s2) = (0.0, 0.0);
    for c in &cells.cells {
        p2 += c.stokes.q * c.stokes.q + c.stokes.u * c.stokes.u;
        s2 += 0.5 * (c.var_q_dn2 + c.var_u_dn2);
    }
    if s2 > 0.0 {
        ((p2 - 2.0 * s2).max(0.0) / s2).sqrt()
    } else {
        f64::INFINITY
    }
}

/// The cells' mean radiance against its noise, var I ≈ (var Q + var U)/4 (four
/// channels: I = ½ΣI_k, Q = I_0 − I_90, U = I_45 − I_135).
fn radiance_snr(cells: &Cells) -> f64 {
    let (mut i, mut s2) = (0.0, 0.0);
    for c in &cells.cells {
        i += c.stokes.i;
        s2 += 0.25 * (c.var_q_dn2 + c.var_u_dn2);
    }
    let n = cells.cells.len().max(1) as f64;
    if s2 > 0.0 {
        (i / n) / (s2 / n).sqrt()
    } else {
        f64::INFINITY
    }
}

/// `why` the fit of a dim frame's `cells` (as read, merged or not) failed, named for the
/// dark where its polarized signal stood less than 6σ above the noise: the search found
/// no heading its cells agree on because they are noise-limited, not because the sky
/// is not the model's. A bright frame's reasons, and reasons not of the fit, unchanged.
pub(super) fn explain_dim(cells: &Cells, why: NoHeading) -> NoHeading {
    let fit_failed = matches!(
        why,
        NoHeading::Ambiguous { .. }
            | NoHeading::TooLittleSky { .. }
            | NoHeading::PoorFit { .. }
            | NoHeading::Contradicts { .. }
    );
    if !fit_failed || radiance_snr(cells) >= DIM_SNR {
        return why;
    }
    let snr = polarized_snr(cells);
    if snr >= POLARIZED_SNR {
        return why;
    }
    let n = cells.cells.len().max(1) as f64;
    let (p2, s2) = cells.cells.iter().fold((0.0, 0.0), |(a, b), c| {
        (a + c.stokes.q * c.stokes.q + c.stokes.u * c.stokes.u, b + 0.5 * (c.var_q_dn2 + c.var_u_dn2))
    });
    NoHeading::TooDark { signal_dn: ((p2 - 2.0 * s2).max(0.0) / n).sqrt(), noise_dn: (s2 / n).sqrt(), snr }
}

/// The factor by which a whole DoFP cell's measured variance of its mean understates
/// that of its centre value (`cells.rs` reads each channel at the cell centre along
/// its own gradient): 1 + ½·n/sxx = 1 + 1.5/(n − 1), n = (cell_px/2)² pixels per
/// channel; 1.5 on 4 px cells, 1.1 on 8 px.
pub(super) fn noise_factor(cell_px: usize) -> f64 {
    let n = ((cell_px / 2) * (cell_px / 2)) as f64;
    if n > 1.0 {
        1.0 + 1.5 / (n - 1.0)
    } else {
        1.0
    }
}

/// `cells` of a dim frame with their noise counted whole ([`noise_factor`]) and merged
/// 2 × 2 while the polarized signal stands less than 6σ above it (module doc); `None`
/// for a bright frame, read as it is.
pub(super) fn coarsened(cells: &Cells) -> Option<Cells> {
    let k = noise_factor(cells.cell_px);
    // The noise scaled by k scales the radiance's S/N by 1/√k: a bright frame is told
    // before any copy (a live loop allocates nothing for it).
    if radiance_snr(cells) / k.sqrt() >= DIM_SNR {
        return None;
    }
    let mut c = cells.clone();
    for cell in &mut c.cells {
        cell.var_q_dn2 *= k;
        cell.var_u_dn2 *= k;
    }
    while polarized_snr(&c) < POLARIZED_SNR && c.cols / 2 >= MIN_GRID && c.rows / 2 >= MIN_GRID {
        c = merged(&c);
    }
    Some(c)
}

/// Every whole 2 × 2 block of `c`'s cells as one cell.
fn merged(c: &Cells) -> Cells {
    let (cols, rows) = (c.cols / 2, c.rows / 2);
    let mut blocks: Vec<[Option<&Cell>; 4]> = vec![[None; 4]; cols * rows];
    for cell in &c.cells {
        let (i, j) = (cell.col as usize / 2, cell.row as usize / 2);
        if i < cols && j < rows {
            blocks[j * cols + i][(cell.row as usize % 2) * 2 + cell.col as usize % 2] = Some(cell);
        }
    }
    let cells = blocks
        .iter()
        .enumerate()
        .filter_map(|(k, b)| {
            let [Some(a), Some(b), Some(d), Some(e)] = *b else { return None };
            let four = [a, b, d, e];
            let mean = |f: fn(&Cell) -> f64| four.iter().map(|&c| f(c)).sum::<f64>() / 4.0;
            Some(Cell {
                x_px: mean(|c| c.x_px),
                y_px: mean(|c| c.y_px),
                stokes: Stokes::new(
                    mean(|c| c.stokes.i),
                    mean(|c| c.stokes.q),
                    mean(|c| c.stokes.u),
                    mean(|c| c.stokes.v),
                ),
                var_q_dn2: mean(|c| c.var_q_dn2) / 4.0,
                var_u_dn2: mean(|c| c.var_u_dn2) / 4.0,
                col: (k % cols) as u32,
                row: (k / cols) as u32,
            })
        })
        .collect();
    // A colour frame's band ratio: the mean of the four cells' (NaN unless all four have one).
    let tint = if c.tint.is_empty() {
        Vec::new()
    } else {
        (0..cols * rows)
            .map(|k| {
                let (i, j) = (2 * (k % cols), 2 * (k / cols));
                [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)]
                    .iter()
                    .map(|&(i, j)| c.tint[j * c.cols + i])
                    .sum::<f64>()
                    / 4.0
            })
            .collect()
    };
    Cells { cell_px: 2 * c.cell_px, cols, rows, cells, tint }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize, q_dn: f64, var_dn2: f64) -> Cells {
        let cells = (0..n * n)
            .map(|k| Cell {
                x_px: (4 * (k % n)) as f64 + 1.5,
                y_px: (4 * (k / n)) as f64 + 1.5,
                stokes: Stokes::new(10.0, q_dn, 0.0, 0.0),
                var_q_dn2: var_dn2,
                var_u_dn2: var_dn2,
                col: (k % n) as u32,
                row: (k / n) as u32,
            })
            .collect();
        Cells { cell_px: 4, cols: n, rows: n, cells, tint: Vec::new() }
    }

    #[test]
    fn a_bright_frame_is_untouched_and_a_dim_one_merged_until_it_stands_out() {
        // Dim (I = 10 DN, σ_I ≈ 0.43 DN) but polarized enough (snr ≈ 8): not merged.
        assert_eq!(coarsened(&grid(64, 5.0, 0.25)).unwrap().cell_px, 4);
        // A bright frame (I = 10 DN against σ_I = 0.007 DN), however weakly polarized: untouched.
        assert!(coarsened(&grid(64, 0.1, 1e-4)).is_none(), "an overcast day");
        // I = 10 DN, σ_I = √½ DN: dim. P = 1 DN, σ = 1 DN: snr ≈ 0 (P² = 1 < 2σ²);
        // merged once, σ² = ¼: snr = √(1/¼ − 2) = 1.41; twice, σ² = 1/16: √14 = 3.7;
        // three times, σ² = 1/64: √62 = 7.9: stops at 32 px cells.
        // (4 px cells: their noise counted ×1.5 first, so σ² = 1/1.5 as measured here.)
        let dim = grid(128, 1.0, 1.0 / 1.5);
        let c = coarsened(&dim).expect("merged");
        assert_eq!((c.cell_px, c.cols, c.rows, c.cells.len()), (32, 16, 16, 256));
        assert!((polarized_snr(&c) - 62f64.sqrt()).abs() < 1e-9, "{}", polarized_snr(&c));
        // The merged cell sits at the centre of its four, with their mean Stokes vector.
        let first = c.cells[0];
        assert!((first.x_px - 15.5).abs() < 1e-12 && (first.y_px - 15.5).abs() < 1e-12, "{first:?}");
        assert!((first.stokes.q - 1.0).abs() < 1e-12 && (first.var_q_dn2 - 1.0 / 64.0).abs() < 1e-12);
        // Too small a grid to merge: read as it is, its noise counted whole (and refused
        // by dark.rs if below 1).
        let small = coarsened(&grid(20, 1.0, 1.0)).expect("dim");
        assert_eq!((small.cell_px, small.cells.len()), (4, 400));
        assert!((small.cells[0].var_q_dn2 - 1.5).abs() < 1e-12);
        assert!((noise_factor(8) - 1.1).abs() < 1e-12 && noise_factor(2) == 1.0);
    }

    #[test]
    fn a_block_with_a_missing_cell_is_dropped() {
        let mut g = grid(64, 1.0, 1.0);
        g.cells.remove(0);
        let m = merged(&g);
        assert_eq!(m.cells.len(), 32 * 32 - 1);
        assert!(m.cells.iter().all(|c| !(c.col == 0 && c.row == 0)));
    }

    #[test]
    fn a_dim_frame_s_failed_fit_is_named_for_the_dark_and_a_bright_one_s_is_not() {
        let amb = NoHeading::Ambiguous { best_deg: 1.0, other_deg: 180.0 };
        let why = explain_dim(&grid(32, 1.0, 0.25), amb.clone());
        assert!(matches!(why, NoHeading::TooDark { .. }), "{why:?}");
        assert!(why.to_string().starts_with("too dark: the polarized signal is below the noise"), "{why}");
        assert_eq!(explain_dim(&grid(32, 0.1, 1e-4), amb.clone()), amb, "bright");
        assert_eq!(explain_dim(&grid(32, 5.0, 0.25), amb.clone()), amb, "dim but polarized enough");
        let low = NoHeading::SunTooLow { sun_el_deg: -12.0 };
        assert_eq!(explain_dim(&grid(32, 1.0, 0.25), low.clone()), low);
    }
}
