//! Dim frames read on larger cells: where a frame is dim (its median cell's radiance
//! less than 300σ of its noise: a night's, up to at least the 731 e⁻ per pixel a full
//! moon at 82° gives in 4 s on 3.45 µm at f/1.4),
//! its cells' noise is first counted whole ([`noise_factor`]: `cells.rs` leaves out
//! the gradient extrapolation's share, ×1.5 on 4 px cells, which by day the robust fit
//! absorbs and at night made the 1σ and the dark test too small), and where its
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
//! its cells' radiance stands hundreds of σ above their noise, or, on small cells,
//! its holes of clear sky stand 30σ polarized), and so is a dim one whose polarized
//! signal stands 6σ above it.
//!
//! Dim is judged cell by cell, the median cell deciding ([`is_dim`]), not on the pooled
//! mean: a city's light dome on one side of a fisheye (docs/night.md) lifted the pooled
//! radiance over the threshold, so its frames were read on 4 px cells and refused as
//! too dark. The threshold was 40σ on the pooled mean; a full moon over a city's glow at
//! 2 s (about 300 e⁻ per pixel, its 4 px cells ≈ 56σ) then stood just above it and was
//! read on noisy 4 px cells (11 of 16, median 1σ 2.6°) while 1 s (merged) and 4 s
//! (polarized enough) read 16 of 16. At 100σ the same switch came back with a full moon
//! at 82° over the city at 4 s (2 of 16 read, 16 of 16 at 2 s: little DoLP in view, so
//! S/N under 6 on 4 px cells, the moon alone giving 731 e⁻ per pixel). At 300σ every frame of the night's
//! sweep (`examples/night/sweep.sh`, four latitudes) is dim: more photons never read
//! fewer frames there, and the median 1σ rises from one exposure to the next in three
//! rows only, by 0.003–0.017°, where the longer exposure stops the merge a step earlier
//! (docs/night.md, "Why the 1σ rises with the exposure": on 4 px cells the
//! delete-one-block jackknife over-counts, conservatively); the cloud table's day
//! frames read exactly as under the old rule (measured 2026-11-28).
//!
//! A day's frame can be dim too: the IMX250MZR's 3.45 µm pixels on 4 px cells stand
//! 300σ (noise ×1.5) only from about 8000 e⁻ per pixel at the zenith, three quarters of
//! its full well (measured: 234σ at 4720 e⁻, 324σ at 9441 e⁻). Clear or weakly
//! polarized, it is read as well or better dim (docs/night.md, "Day frames near the
//! bound"); a heavy overcast's is not: its pooled polarized S/N is under 6 because
//! its cloud is depolarized, not because its cells are noisy, and merging blurs its
//! holes of clear sky into the cloud about them (measured, 4720 e⁻ per pixel, 8 seeds
//! × 8 headings: 33 of 64 read, one at 4.7σ, against 44 of 64 read bright). So a dim
//! frame with at least 40 cells (`min_cells`) standing 30σ polarized above their
//! noise in clusters ([`clear_holes`]: a noise-limited frame's few such cells lie
//! alone) is read as a bright one: 39 of 64, the largest 2.1σ; every row of the
//! night's sweep unchanged.
//!
//! Where the fit of a dim frame that still stands less than 6σ above its noise fails
//! (ambiguous, too little sky, a misfit, a contradiction), the failure is named for the
//! dark ([`explain_dim`]: `NoHeading::TooDark`, with the numbers), its S/N judged
//! without the cells brighter than twice the median cell's radiance (a light dome's,
//! whose noise pooled in named the dome frames' too little usable sky for the dark).
//!
//! Units: DN; pixels. Frame: the image's (cell centres), Stokes in the image frame.
//! Cannot: merge across a cell that is missing (saturated, off the sensor's whole
//! cells): such a 2 × 2 block is dropped, which on a frame with the sun's disc in
//! view removes a little more sky around it.

use super::{Cell, Cells, NoHeading};
use crate::stokes::Stokes;

/// Merge while the polarized signal stands less than this above the noise…
const POLARIZED_SNR: f64 = 6.0;
/// … and the median cell's radiance less than this above its noise (a night's, up to
/// at least 731 e⁻ per pixel; the cloud table's day frames read the same as
/// under the old 40σ pooled rule, measured 2026-11-28).
const DIM_SNR: f64 = 300.0;
/// A failed fit's dark is judged without the cells brighter than this × the median
/// cell's radiance (a light dome: `explain_dim`).
const GLOW: f64 = 2.0;
/// A dim frame is read as a bright one where at least HOLE_CELLS of its cells (the
/// field estimator's default `min_cells`) stand HOLE_SNR polarized above their noise
/// in clusters (`clear_holes`: an overcast's holes). 30σ: on the night's sweep a 4 px
/// frame's clustered cells that high number 0–7 (the full moon at 42°, 4 s, S/N 8.3
/// pooled), a heavy overcast's at 4720 e⁻ per pixel 60–143.
const HOLE_SNR: f64 = 5.0 * POLARIZED_SNR;
const HOLE_CELLS: usize = 40;
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

/// Whether the frame is dim: fewer than half its cells' radiance stands `min_snr` above
/// its own noise, var I ≈ (var Q + var U)/4 (four channels: I = ½ΣI_k, Q = I_0 − I_90,
/// U = I_45 − I_135). Cell by cell, not pooled: a city's light dome on one side of a
/// night's fisheye lifts the pooled mean radiance far above its noise while the sky
/// away from it, the cells the fit reads, stays dim (the median cell decides).
fn is_dim(cells: &Cells, min_snr: f64) -> bool {
    let bright = cells
        .cells
        .iter()
        .filter(|c| {
            let var_i = 0.25 * (c.var_q_dn2 + c.var_u_dn2);
            var_i <= 0.0 || c.stokes.i >= min_snr * var_i.sqrt()
        })
        .count();
    2 * bright < cells.cells.len()
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
    if !fit_failed || !is_dim(cells, DIM_SNR) || clear_holes(cells, HOLE_SNR) >= HOLE_CELLS {
        return why;
    }
    // Judged on the sky the fit reads, not on a glow that drowns part of it: cells more
    // than GLOW × the median cell's radiance (a city's dome) left out. A uniformly dim
    // frame keeps nearly all its cells, so its measure is the whole frame's.
    let mut i: Vec<f64> = cells.cells.iter().map(|c| c.stokes.i).collect();
    let mid = i.len() / 2;
    let median_dn = if i.is_empty() { 0.0 } else { *i.select_nth_unstable_by(mid, f64::total_cmp).1 };
    let (mut n, mut p2, mut s2) = (0usize, 0.0, 0.0);
    for c in cells.cells.iter().filter(|c| c.stokes.i <= GLOW * median_dn) {
        n += 1;
        p2 += c.stokes.q * c.stokes.q + c.stokes.u * c.stokes.u;
        s2 += 0.5 * (c.var_q_dn2 + c.var_u_dn2);
    }
    let snr = if s2 > 0.0 { ((p2 - 2.0 * s2).max(0.0) / s2).sqrt() } else { f64::INFINITY };
    if snr >= POLARIZED_SNR {
        return why;
    }
    let n = n.max(1) as f64;
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
    if !is_dim(cells, DIM_SNR * k.sqrt()) || clear_holes(cells, HOLE_SNR * k.sqrt()) >= HOLE_CELLS {
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

/// How many of `c`'s cells stand `min_snr` polarized above their noise in clusters
/// (each with two others of them among its eight neighbours, `stats::clustered`): an
/// overcast's holes of clear sky. Per cell, as [`polarized_snr`] pools it:
/// (Q² + U² − 2σ²)/σ² ≥ min_snr², σ² = ½(var Q + var U), DN². A noise-limited frame's
/// cells scatter about its pooled S/N, and the few that a noisy variance (one degree
/// of freedom per channel on 4 px cells) lifts that high lie alone. Limits: a clear
/// night exposed long enough has such clusters too (the full moon at 42°, 256 px, from
/// 8 s) and is then read as a bright one, its noise not counted ×1.5: at 8 s median 1σ
/// 0.071° against 0.063° under the rule before, RMS error 0.051° against 0.054°.
fn clear_holes(c: &Cells, min_snr: f64) -> usize {
    let mut mask = vec![false; c.cols * c.rows];
    for x in &c.cells {
        let s2 = 0.5 * (x.var_q_dn2 + x.var_u_dn2);
        let p2 = x.stokes.q * x.stokes.q + x.stokes.u * x.stokes.u;
        if let Some(m) = mask.get_mut(x.row as usize * c.cols + x.col as usize) {
            *m = p2 - 2.0 * s2 >= min_snr * min_snr * s2;
        }
    }
    let mut kept = Vec::new();
    super::stats::clustered(&mask, c.cols, &mut kept);
    kept.iter().filter(|&&m| m).count()
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
    fn a_bright_dome_on_one_side_leaves_the_dim_sky_elsewhere_dim() {
        // A third of the grid (the columns toward a city) 3000 × brighter, its noise
        // √3000 × (shot noise): the pooled mean radiance stands 556σ (I ≈ 10300 DN against
        // σ_I ≈ 18.5 DN), above the threshold even with the noise ×1.5; the median cell
        // 17σ. The sky away from the dome (P = 2 DN, σ² = 1/1.5 measured) is merged as a
        // dim frame's is, to 16 px cells (σ² = 1/16: S/N √62 = 7.9); a uniformly dim one too.
        let mut g = grid(64, 2.0, 1.0 / 1.5);
        for c in g.cells.iter_mut().filter(|c| c.col < 22) {
            c.stokes = Stokes::new(30000.0, 1.0, 0.0, 0.0);
            c.var_q_dn2 *= 3000.0;
            c.var_u_dn2 *= 3000.0;
        }
        let (i, s2) =
            g.cells.iter().fold((0.0, 0.0), |(a, b), c| (a + c.stokes.i, b + 0.25 * (c.var_q_dn2 + c.var_u_dn2)));
        assert!(i / s2.sqrt() / (g.cells.len() as f64).sqrt() > DIM_SNR * 1.5f64.sqrt(), "pooled: bright");
        let c = coarsened(&g).expect("dim: the median cell decides");
        assert!(c.cell_px > 4, "merged: {}", c.cell_px);
        assert!(coarsened(&grid(64, 1.0, 1.0 / 1.5)).expect("dim").cell_px > 4);
        // Merged, the sky away from the dome stands 6σ or more; a failed fit there is not
        // the dark's (the dome's noise pooled in would have made it so), while the same
        // sky at P = 1 DN (S/N 3.7 on 16 px cells) is.
        let tls = NoHeading::TooLittleSky { used: 10, total: 256 };
        assert!(polarized_snr(&c) < POLARIZED_SNR, "pooled: {}", polarized_snr(&c));
        assert_eq!(explain_dim(&c, tls.clone()), tls);
        let dark = coarsened(&grid(64, 1.0, 1.0 / 1.5)).unwrap();
        assert!(matches!(explain_dim(&dark, tls.clone()), NoHeading::TooDark { .. }));
        // Half the cells or more bright: a bright frame, untouched.
        for c in g.cells.iter_mut().filter(|c| c.col < 40) {
            c.stokes = Stokes::new(1000.0, 1.0, 0.0, 0.0);
            c.var_q_dn2 = 1e-4;
            c.var_u_dn2 = 1e-4;
        }
        assert!(coarsened(&g).is_none());
    }

    #[test]
    fn an_overcast_s_clear_holes_keep_its_cells_and_the_dark_s_lone_bright_cells_do_not() {
        // Dim (I = 10 DN, σ_I = √½ DN), weakly polarized on the whole (P = 1 DN against
        // σ = 1 DN: merged, as `a_bright_frame_is_untouched…` shows), with a 7 × 7 hole of
        // clear sky (P = 40 DN: (1600 − 2)/1 ≥ 30² · 1.5, 30σ with the noise ×1.5): 49
        // clustered cells ≥ 40, read as they are, and a failed fit there is not the dark's.
        let mut g = grid(64, 1.0, 1.0);
        for c in g.cells.iter_mut().filter(|c| (10..17).contains(&c.col) && (20..27).contains(&c.row)) {
            c.stokes.q = 40.0;
        }
        assert!(polarized_snr(&g) < POLARIZED_SNR, "{}", polarized_snr(&g));
        assert_eq!(clear_holes(&g, HOLE_SNR * 1.5f64.sqrt()), 49);
        assert!(coarsened(&g).is_none(), "an overcast's holes: its fine cells kept");
        let amb = NoHeading::Ambiguous { best_deg: 1.0, other_deg: 180.0 };
        assert_eq!(explain_dim(&g, amb.clone()), amb);
        // A hole of 6 × 6 = 36 cells is too few: merged as a dark frame.
        let mut small = grid(64, 1.0, 1.0);
        for c in small.cells.iter_mut().filter(|c| c.col < 6 && c.row < 6) {
            c.stokes.q = 40.0;
        }
        assert_eq!(clear_holes(&small, HOLE_SNR * 1.5f64.sqrt()), 36);
        assert!(coarsened(&small).expect("dim").cell_px > 4);
        // 64 as bright but alone (every 8th cell of every 8th row: no two neighbours):
        // a noisy variance's, not a hole; merged.
        let mut lone = grid(64, 1.0, 1.0);
        for c in lone.cells.iter_mut().filter(|c| c.col % 8 == 0 && c.row % 8 == 0) {
            c.stokes.q = 40.0;
        }
        assert_eq!(clear_holes(&lone, HOLE_SNR * 1.5f64.sqrt()), 0);
        assert!(coarsened(&lone).expect("dim").cell_px > 4);
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
