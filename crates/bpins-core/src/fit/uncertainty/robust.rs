//! # Cluster-robust 1σ of the global parameters
//!
//! ```text
//! g̃_c = Σ_k Σ_{p ∈ c} w_p r_p (d_g(p) − A_gk A_kk⁺ d_k(p))    score of cluster c, globals only
//! B   = G/(G − 1) · Σ_c g̃_c g̃_cᵀ                              G clusters with samples
//! V_g = S⁺ B S⁺,   S⁺ = (A⁺)_gg                                  A = JᵀWJ over all free slots
//! ```
//!
//! What: the fit weighs each sample as independent noise of variance σ²(s). A real
//! sensor's noise is not: its PRNU (a gain that differs pixel to pixel) is the same
//! pattern in every frame, so a parameter whose signature sits in the camera (a lens
//! or sensor effect) sees the same pattern F times, and the inverse of JᵀWJ
//! underestimates its variance by up to 1 + (F − 1)·ρ, ρ the pattern's share of the
//! variance (2.3× in 1σ on the `real_sky` capture: 8 frames, 1 % PRNU). The
//! sandwich ("cluster-robust", Liang & Zeger 1986; Cameron & Miller, *J. Human
//! Resources* 50 (2015) §II–IV) measures the variance of the estimating equations
//! from the residuals themselves instead of from the weights: samples in one cluster
//! may be correlated in any way, clusters are independent. A cluster is one row of the
//! sensor (a frame read whole) or one sampled block (`crate::fit::input::frames`), taken across
//! every frame: a pixel's fixed pattern, and a misfit along a row, fall in one cluster.
//!
//! Each frame's nuisances (heading, scale, d_max, radiance) are profiled out: a
//! sample's global gradient is taken after its frame's own slots are projected away
//! (the global rows of A⁻¹ applied to the full score, block-inverse identity), so
//! only the frame's own JᵀWJ block is needed, frame by frame, never the frames
//! together. Units: those of each parameter. Frame: none (sums over samples).
//!
//! Limits: it is the variance at the fitted optimum, to first order; with G clusters
//! it is itself uncertain by ≈ √(2/G) in variance (a 612 × 512 capture: 512 rows, 6 %);
//! correlation across rows (a misfit smooth in v) is not in it — the fit's
//! neighbour-correlation factor (`crate::fit::uncertainty::correlation`) is, and the reported 1σ is the
//! larger of the two. It does not make a misspecified model right: a misfit makes
//! the 1σ honest about the scatter, not the value unbiased.

use crate::fit::solver::linalg::PseudoInverse;
use nalgebra::DMatrix;

/// The clusters' projected scores, accumulated frame by frame.
#[derive(Clone, Debug)]
pub(crate) struct Clusters {
    /// Free global slots (the first `n_g` of every frame's local slots).
    n_g: usize,
    /// Per cluster, its score over the free globals (`n_g` each).
    sums: Vec<f64>,
}

impl Clusters {
    pub(crate) fn new(n_clusters: usize, n_g: usize) -> Self {
        Clusters { n_g, sums: vec![0.0; n_clusters * n_g] }
    }

    /// Adds one frame: `a` its local JᵀWJ (`nl` × `nl`, row-major, lower triangle
    /// filled; the first `n_g` local slots are the free globals, the rest the frame's
    /// own) and, per part, its cluster and its local JᵀWr.
    pub(crate) fn add_frame(&mut self, a: &[f64], nl: usize, parts: &[(usize, Vec<f64>)]) {
        let (ng, no) = (self.n_g, nl - self.n_g);
        let at = |i: usize, j: usize| a[i.max(j) * nl + i.min(j)];
        // M = A_gk A_kk⁺ (n_g × n_o): what of a global's gradient the frame's own
        // slots absorb.
        let m = if no == 0 {
            DMatrix::<f64>::zeros(ng, 0)
        } else {
            let akk: Vec<f64> = (0..no).flat_map(|i| (0..no).map(move |j| at(ng + i, ng + j))).collect();
            let akk_inv = PseudoInverse::new(&akk, no).inv;
            DMatrix::from_fn(ng, no, |g, o| (0..no).map(|l| at(g, ng + l) * akk_inv[(l, o)]).sum::<f64>())
        };
        for (c, b) in parts {
            let sum = &mut self.sums[c * ng..][..ng];
            for (g, s) in sum.iter_mut().enumerate() {
                *s += b[g] - (0..no).map(|o| m[(g, o)] * b[ng + o]).sum::<f64>();
            }
        }
    }

    /// The sandwich's 1σ of each free global: √(S⁺ B S⁺)_ii, `s_inv` the global
    /// block of the pseudo-inverse of JᵀWJ (`n_g` × `n_g`).
    pub(crate) fn sigmas(&self, s_inv: &DMatrix<f64>) -> Vec<f64> {
        let ng = self.n_g;
        let mut b = DMatrix::<f64>::zeros(ng, ng);
        let mut clusters = 0usize;
        for g in self.sums.chunks_exact(ng.max(1)).filter(|g| g.iter().any(|x| *x != 0.0)) {
            clusters += 1;
            let v = nalgebra::DVector::from_column_slice(g);
            b += &v * v.transpose();
        }
        if ng == 0 || clusters < 2 {
            return vec![0.0; ng];
        }
        b *= clusters as f64 / (clusters as f64 - 1.0);
        let v = s_inv * b * s_inv;
        (0..ng).map(|i| v[(i, i)].max(0.0).sqrt()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::{stream, FrameKey};

    /// Least squares of y = θ_g·x + θ_k (one global slope, one offset per frame) over
    /// F frames of the same N pixels, with noise = a fixed pattern (the same in every
    /// frame, std `fixed`) plus white noise (std 1), weighted as if white of variance
    /// 1 + fixed². Returns (1σ of the weights, sandwich 1σ, the slope's error).
    fn fit_slope(fixed: f64, seed: u32) -> (f64, f64, f64) {
        let (nf, np) = (8usize, 4000usize);
        let key = FrameKey::new(seed as u64, 0, 0);
        let pattern: Vec<f64> = (0..np).map(|p| fixed * key.normal(p as u32, 0, stream::TEMPORAL)).collect();
        let w = 1.0 / (1.0 + fixed * fixed);
        // Per frame the slope differs a little (a signature that moves with the sky).
        let xs = |k: usize, p: usize| ((p as f64 * 0.37).sin() + 0.1 * k as f64) * (1.0 + 0.05 * k as f64);
        let mut clusters = Clusters::new(np, 1);
        let (mut agg, mut bg) = (0.0, 0.0);
        for k in 0..nf {
            let kk = FrameKey::new(seed as u64, 0, k as u32 + 1);
            // Truth θ_g = 0, θ_k = 0: y is the noise; the residual at θ = 0 is y.
            let y: Vec<f64> = (0..np).map(|p| pattern[p] + kk.normal(p as u32, 0, stream::TEMPORAL)).collect();
            let (mut a, mut parts) = (vec![0.0; 4], Vec::new());
            for p in 0..np {
                let d = [xs(k, p), 1.0];
                a[0] += w * d[0] * d[0];
                a[2] += w * d[1] * d[0];
                a[3] += w * d[1] * d[1];
                parts.push((p, vec![w * d[0] * y[p], w * d[1] * y[p]]));
            }
            clusters.add_frame(&a, 2, &parts);
            let bk: f64 = parts.iter().map(|x| x.1[1]).sum();
            let bgk: f64 = parts.iter().map(|x| x.1[0]).sum();
            // Schur complement of the frame's offset.
            agg += a[0] - a[2] * a[2] / a[3];
            bg += bgk - a[2] / a[3] * bk;
        }
        let s_inv = DMatrix::from_element(1, 1, 1.0 / agg);
        let robust = clusters.sigmas(&s_inv)[0];
        (1.0 / agg.sqrt(), robust, bg / agg)
    }

    #[test]
    fn white_noise_keeps_the_weights_1_sigma_and_a_fixed_pattern_widens_it() {
        // White noise only: the sandwich agrees with the weights (to its own ≈ √(2/G)).
        let (model, robust, _) = fit_slope(0.0, 1);
        assert!((robust / model - 1.0).abs() < 0.1, "{robust} vs {model}");
        // A fixed pattern of twice the white noise's std: ρ = 0.8, F = 8; the slope's
        // signature is nearly the same in every frame, so the variance grows by close
        // to 1 + 7·0.8 = 6.6 (1σ × 2.57).
        let (model, robust, _) = fit_slope(2.0, 2);
        let ratio = robust / model;
        eprintln!("fixed pattern: 1σ × {ratio:.3}");
        assert!(ratio > 2.0 && ratio < 2.8, "1σ × {ratio}");
    }

    #[test]
    fn the_sandwich_1_sigma_matches_the_scatter_of_the_estimate() {
        // Over seeds, the slope's error divided by the sandwich 1σ has unit RMS (the
        // weights' 1σ would give ≈ 2.5).
        let n = 400;
        let (mut z2, mut z2_model) = (0.0, 0.0);
        for seed in 0..n {
            let (model, robust, err) = fit_slope(2.0, 100 + seed);
            z2 += (err / robust).powi(2);
            z2_model += (err / model).powi(2);
        }
        let (rms, rms_model) = ((z2 / n as f64).sqrt(), (z2_model / n as f64).sqrt());
        eprintln!("RMS z {rms:.3} (weights' {rms_model:.3})");
        assert!(rms > 0.85 && rms < 1.15, "RMS z {rms} (weights' {rms_model})");
        assert!(rms_model > 1.8, "the weights' 1σ was not optimistic here: RMS z {rms_model}");
    }
}
