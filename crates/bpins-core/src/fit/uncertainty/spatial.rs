//! # The heading's 1σ under the residual's spatial correlation (a spatial HAC sandwich)
//!
//! ```text
//! δθ = A⁺ Jᵀ W r                                 the Gauss–Newton step the residual r drives
//! ℓ_h = A⁺ e_h                                   the heading's row of A⁺ (A = JᵀWJ, free slots)
//! G_t = Σ_{p ∈ t} w_p r_p ℓ_h · d_p              what tile t's residual moves the heading by, degrees
//!                                                (d_p the sample's Jacobian row over the frame's
//!                                                local slots: the free globals, then its own)
//! V_k = Σ_t Σ_t' K(|t − t'|) G_t G_t',   K(x) = max(0, 1 − x/(R + 1))    (Bartlett, x in tiles)
//! σ_spatial,k = √V_k
//! ```
//!
//! What: at the fit's optimum Σ_t G_t = 0 — the residual is orthogonal to the heading's
//! signature, so the whole frame's residual moves the heading by nothing and cannot
//! say how much of a misfit the heading absorbed. Tile by tile it does not vanish: a
//! misfit the model does not explain pulls the heading one way in one part of the sky
//! and the other way elsewhere, and G_t is how far each part pulls, projected on the
//! heading's own sensitivity to each sample's DN (ℓ_h·d_p w_p: its influence function,
//! with the frame's other nuisances and the effects' parameters free). V_k is the
//! variance of the heading were those pulls a draw of a field correlated over R tiles:
//! the spatial form (Conley 1999, J. Econometrics 92, 1) of the Newey–West sandwich
//! (Econometrica 55, 703 (1987)), as `heading::field::spatial` uses for the field
//! heading, with its constants (16 tiles along the longer side, R = 2). White residuals
//! give E[V_k] = ℓ_hᵀ A_k ℓ_h ≈ σ_white² (the statistical 1σ); residuals larger than
//! their noise scale it by their χ²/dof; residuals correlated between neighbouring
//! samples add their cross terms — the misfit's share, measured from the residual
//! itself rather than bounded by its whole power.
//!
//! Units: G_t and σ in the heading's unit, degrees. Frame: the image's pixel grid
//! (tiles of square pixels, even sides: whole DoFP superpixels). Cannot: see a pull
//! shared alike by every tile (a turn common to the whole sky is a heading, and is
//! absorbed); correlation beyond R tiles counts as independent. The sampled frames'
//! blocks (`fit::input::frames`) fall into the same tiles.

use crate::heading::field::spatial::{bartlett, SUPER_BLOCKS as TILES};

/// The tile grid of a frame, and each frame's per-tile sums of w·r·d over its local
/// slots.
#[derive(Clone, Debug)]
pub(crate) struct Tiles {
    /// Side of a tile, pixels (even).
    side_px: usize,
    cols: usize,
    rows: usize,
    /// Per frame: its local slots' count and its tiles' sums (tile-major, `n_local`
    /// each).
    frames: Vec<(usize, Vec<f64>)>,
}

impl Tiles {
    /// The grid of a `w` × `h` frame; `n_local[k]` local slots for frame `k`.
    pub(crate) fn new(w: usize, h: usize, n_local: &[usize]) -> Tiles {
        let side_px = (w.max(h).div_ceil(TILES).max(1) + 1) / 2 * 2;
        let (cols, rows) = (w.div_ceil(side_px).max(1), h.div_ceil(side_px).max(1));
        let frames = n_local.iter().map(|&n| (n, vec![0.0; cols * rows * n])).collect();
        Tiles { side_px, cols, rows, frames }
    }

    /// The tile of pixel (u, v).
    #[inline]
    pub(crate) fn of(&self, u: usize, v: usize) -> usize {
        (v / self.side_px).min(self.rows - 1) * self.cols + (u / self.side_px).min(self.cols - 1)
    }

    /// Adds one part's per-tile sums (`(tile, sums over the local slots)`) to frame `k`.
    pub(crate) fn add(&mut self, k: usize, part: &[(usize, Vec<f64>)]) {
        let (n, sums) = &mut self.frames[k];
        for (t, b) in part {
            sums[t * *n..][..*n].iter_mut().zip(b).for_each(|(s, x)| *s += x);
        }
    }

    /// σ_spatial of frame `k` (module doc) for the heading's row `ell` of A⁺ over the
    /// frame's local slots.
    pub(crate) fn sigma(&self, k: usize, ell: &[f64]) -> f64 {
        let (n, sums) = &self.frames[k];
        let g: Vec<f64> = sums.chunks_exact((*n).max(1)).map(|b| b.iter().zip(ell).map(|(x, l)| x * l).sum()).collect();
        bartlett(&g, self.cols, self.rows).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_the_frame_in_even_squares() {
        let t = Tiles::new(306, 256, &[3]);
        // ⌈306/16⌉ = 20 px: 16 × 13 tiles, the last ones partial.
        assert_eq!((t.side_px, t.cols, t.rows), (20, 16, 13));
        assert_eq!(t.of(0, 0), 0);
        assert_eq!(t.of(305, 255), 16 * 13 - 1);
        assert_eq!(t.of(21, 40), 2 * 16 + 1);
        // An odd side is rounded up to whole superpixels.
        assert_eq!(Tiles::new(100, 20, &[1]).side_px, 8);
    }

    #[test]
    fn independent_pulls_add_in_variance_and_correlated_ones_add_in_amplitude() {
        // One tile pulling by 1: V = 1. Two neighbours pulling alike: 2 + 2·K(1) = 2 +
        // 2·(2/3); pulling against each other, 2 − 4/3. Far apart: 2 (independent).
        let grid = |cells: &[(usize, f64)]| {
            let mut g = vec![0.0; 10 * 10];
            for &(i, x) in cells {
                g[i] = x;
            }
            bartlett(&g, 10, 10)
        };
        assert!((grid(&[(0, 1.0)]) - 1.0).abs() < 1e-12);
        assert!((grid(&[(0, 1.0), (1, 1.0)]) - (2.0 + 4.0 / 3.0)).abs() < 1e-12);
        assert!((grid(&[(0, 1.0), (1, -1.0)]) - (2.0 - 4.0 / 3.0)).abs() < 1e-12);
        assert!((grid(&[(0, 1.0), (99, 1.0)]) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_frames_sums_are_projected_on_the_heading_row() {
        let mut t = Tiles::new(40, 40, &[2, 2]);
        // Frame 1, tile 0: (1, 2); ℓ = (0.5, 0.25): G = 1, V = 1.
        t.add(1, &[(0, vec![1.0, 2.0])]);
        assert!((t.sigma(1, &[0.5, 0.25]) - 1.0).abs() < 1e-12);
        assert_eq!(t.sigma(0, &[0.5, 0.25]), 0.0);
    }
}
