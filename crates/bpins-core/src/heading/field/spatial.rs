//! The heading's 1σ under a spatially correlated misfit (step 5 of `mod.rs`): a
//! spatial heteroskedasticity-and-autocorrelation-consistent (HAC) sandwich over the
//! cell grid.
//!
//! ```text
//! ψ̂ solves Σ_i w_i δ_i(ψ) ∂δ_i/∂ψ = 0             (the heading on the sun's cone)
//! g_i = w_i δ_i a_i,  a_i = ∂δ_i/∂ψ,  H = Σ_i w_i a_i²
//! G_b = Σ_{i ∈ b} g_i                              sums over super-blocks b of S × S cells
//! V   = Σ_b Σ_b' K(|b − b'|) G_b G_b',  K(r) = max(0, 1 − r/(R + 1))   (Bartlett)
//! σ_coherent = √V / H
//! ```
//!
//! Source: Conley, "GMM estimation with cross sectional dependence", J. Econometrics
//! 92, 1 (1999), the spatial form of Newey & West (Econometrica 55, 703 (1987)): the
//! variance of an M-estimator whose scores are correlated within a distance, with a
//! kernel that keeps V ≥ 0. Why: what clouds and an unmodelled sky leave after
//! rejection is smooth over the image, so neighbouring cells' residuals share a sign;
//! the extractor's own σ counts them as independent, and a delete-one-block
//! jackknife over 4 × 4 blocks sees only what differs between blocks. Here a cloud
//! rim's turned E-vectors, however many cells they span, count as one correlated
//! draw. With independent residuals V → Σ g_i² ≈ H, so σ_coherent falls back to the
//! fit's 1/√H.
//!
//! Units: ψ and a_i per degree, so σ in degrees. Frame: the cell grid (image rows and
//! columns). Cannot: see a bias shared by every cell alike (a turn common to the whole
//! sky is a heading); correlation beyond R super-blocks is counted as independent.

/// Super-blocks per side of the grid's longer side (the fit's spatial 1σ,
/// `fit::uncertainty::spatial`, tiles a frame alike).
pub(crate) const SUPER_BLOCKS: usize = 16;
/// Bartlett bandwidth, super-blocks.
const BANDWIDTH: usize = 2;

/// σ_coherent in degrees from the used cells' `(grid index, g_i, w_i a_i²)` on a
/// `cols × rows` grid; `sums` is a buffer. NaN when H is 0.
pub(super) fn coherent_sigma_deg(
    items: impl Iterator<Item = (usize, f64, f64)>,
    cols: usize,
    rows: usize,
    sums: &mut Vec<f64>,
) -> f64 {
    let s = cols.max(rows).div_ceil(SUPER_BLOCKS).max(1);
    let (bc, br) = (cols.div_ceil(s).max(1), rows.div_ceil(s).max(1));
    sums.clear();
    sums.resize(bc * br, 0.0);
    let mut h = 0.0;
    for (grid, g, hi) in items {
        let (r, c) = (grid / cols.max(1), grid % cols.max(1));
        sums[(r / s) * bc + c / s] += g;
        h += hi;
    }
    if h <= 0.0 {
        return f64::NAN;
    }
    bartlett(sums, bc, br).sqrt() / h
}

/// V = Σ_b Σ_b' K(|b − b'|) G_b G_b' (module doc) of the sums `g` on a `cols` × `rows`
/// grid (row-major), K the Bartlett kernel of bandwidth [`BANDWIDTH`]; ≥ 0.
pub(crate) fn bartlett(g: &[f64], cols: usize, rows: usize) -> f64 {
    let bw = BANDWIDTH as isize;
    let mut v = 0.0;
    for r in 0..rows as isize {
        for c in 0..cols as isize {
            let gb = g[r as usize * cols + c as usize];
            if gb == 0.0 {
                continue;
            }
            for dr in -bw..=bw {
                for dc in -bw..=bw {
                    let (rr, cc) = (r + dr, c + dc);
                    if rr < 0 || cc < 0 || rr >= rows as isize || cc >= cols as isize {
                        continue;
                    }
                    let k = 1.0 - ((dr * dr + dc * dc) as f64).sqrt() / (BANDWIDTH + 1) as f64;
                    if k > 0.0 {
                        v += k * gb * g[rr as usize * cols + cc as usize];
                    }
                }
            }
        }
    }
    v.max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::FrameKey;

    /// A location model on a 64 × 48 grid: ψ̂ is the weighted mean of y_i = ψ + e_i,
    /// so δ_i = y_i − ψ̂, a_i = −1, g_i = −w δ_i, H = Σ w.
    fn sigma_of(e: &[f64]) -> (f64, f64) {
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        let items = e.iter().enumerate().map(|(i, x)| (i, -(x - mean), 1.0));
        let mut buf = Vec::new();
        (coherent_sigma_deg(items, 64, 48, &mut buf), mean)
    }

    #[test]
    fn independent_residuals_give_the_usual_sigma() {
        // σ of the mean of n independent unit draws: 1/√n. Over 40 seeds the HAC σ
        // scatters about it (its bandwidth costs it some precision, not its scale).
        let n = 64 * 48;
        let mut ratio = 0.0;
        for seed in 0..40 {
            let k = FrameKey::new(seed, 0, 0);
            let e: Vec<f64> = (0..n as u32).map(|i| k.normal(i, 0, 0)).collect();
            ratio += sigma_of(&e).0 * (n as f64).sqrt() / 40.0;
        }
        assert!((ratio - 1.0).abs() < 0.15, "{ratio}");
    }

    #[test]
    fn correlated_residuals_widen_it_and_it_covers_the_mean_they_shift() {
        // Patches of 8 × 8 cells sharing one draw: the mean moves by ~1/√(patches),
        // not 1/√cells; the HAC σ follows, the white σ does not.
        let (mut within, mut trials, mut ratio) = (0, 0, 0.0);
        for seed in 0..60 {
            let k = FrameKey::new(seed, 1, 0);
            let e: Vec<f64> = (0..64 * 48)
                .map(|i| {
                    let (r, c) = (i / 64, i % 64);
                    k.normal(((r / 8) * 8 + c / 8) as u32, 0, 0) + 0.1 * k.normal(10_000 + i as u32, 0, 0)
                })
                .collect();
            let (sigma, mean) = sigma_of(&e);
            ratio += sigma * (48.0f64).sqrt() / 60.0; // 48 patches: σ_true = 1/√48
            within += (mean.abs() <= 2.0 * sigma) as usize;
            trials += 1;
        }
        assert!(ratio > 0.6 && ratio < 1.5, "HAC σ / true σ = {ratio}");
        assert!(within as f64 / trials as f64 >= 0.85, "{within} of {trials} within 2σ");
    }
}
