//! # Effective sample count of a fit's residuals
//!
//! ```text
//! z = (DN − DN_model)/σ                       normalized residual of each usable sample
//! ρ_x = Σ z(u, v)·z(u + L, v) / √(Σ z(u, v)² · Σ z(u + L, v)²)     (ρ_y likewise in v)
//! n_eff = n · g(ρ_x) · g(ρ_y),   g(ρ) = (1 − ρ)/(1 + ρ) for ρ > 0, else 1
//! ```
//!
//! What: sensor noise is white, a misfit is not — it is smooth, so neighbouring
//! residuals agree. For a first-order autoregressive residual, the variance of a mean
//! over n samples is that of n·(1 − ρ)/(1 + ρ) independent ones (the "effective
//! sample size", e.g. Bayley & Hammersley 1946; von Storch & Zwiers, *Statistical
//! Analysis in Climate Research* §17.1), here separably along rows and columns. L is
//! the distance to the nearest pixel of the same channel (2 on a DoFP mosaic, 1 on a
//! colocated sensor), so the analyzer pattern itself does not count as correlation.
//!
//! Used by the fit for each parameter's 1σ (× √(n/n_eff)) and by the diagnosis for
//! the evidence of a candidate: Δχ²·n_eff/n against k·ln n_eff. Units: none. Limits:
//! ρ is clamped to ≤ 0.999 (n_eff ≥ n/4·10⁻⁶); a residual that is white (noise only)
//! has ρ ≈ 0 ± 1/√n, so n_eff ≈ n.
//!
//! The same lag sums measure, frame by frame, the power of the residual's smooth part
//! (the misfit the model does not explain), for the heading 1σ that carries it
//! (`fit::fit_from`):
//!
//! ```text
//! S_k = ½(Σ_x z·z_next + Σ_y z·z_next),  N_k = ½(pairs_x + pairs_y)
//! E_k = max(0, S_k − 3·√(N_k/2))              coherent misfit power, in σ² units
//! ```
//!
//! White noise gives S_k = 0 ± √(N_k/2); a misfit smooth over more than L pixels adds
//! its own power (its lag-L autocovariance ≈ its variance) however far below the
//! noise each pixel's share is. The 3σ floor keeps a noise-only frame at E_k = 0 (one
//! frame in 740 above it).

use crate::error::Result;
use crate::fit::model::problem::Problem;
use crate::sensor::Layout;
use rayon::prelude::*;

/// Lag products of one frame: (Σ z·z_next, Σ z², Σ z_next²) along x, then along y.
#[derive(Clone, Copy, Default)]
struct Lags {
    x: [f64; 3],
    y: [f64; 3],
    /// Lag pairs counted, along x and along y.
    pairs: [f64; 2],
}

impl Lags {
    /// The frame's coherent misfit power E_k (module doc).
    fn coherent(&self) -> f64 {
        let s = 0.5 * (self.x[0] + self.y[0]);
        let n = 0.5 * (self.pairs[0] + self.pairs[1]);
        (s - 3.0 * (0.5 * n).sqrt()).max(0.0)
    }
}

/// What the residuals' correlations give the fit.
pub(crate) struct Correlation {
    /// Effective sample count over every frame.
    pub n_eff: f64,
    /// Per frame: the coherent misfit power E_k, σ² units (module doc).
    pub coherent: Vec<f64>,
}

/// n_eff of the residuals of `theta` over every usable sample, and each frame's
/// coherent misfit power. The lag pairs lie within each rectangle the frames hold (the
/// whole frame, or each sampled block of whole 2 × 2 tiles: neighbours stay adjacent).
pub(crate) fn effective_samples(pb: &Problem, theta: &[f64], samples: usize) -> Result<Correlation> {
    let lag = match pb.capture.sensor.layout {
        Layout::Dofp { .. } => 2,
        Layout::Colocated { .. } => 1,
    };
    let nq = match &pb.capture.sensor.layout {
        Layout::Dofp { .. } => 1,
        Layout::Colocated { channels } => channels.len(),
    };
    // Frame by frame in parallel, summed in frame order (the same sums whatever the
    // threads).
    let per_frame = (0..pb.frames.len())
        .into_par_iter()
        .map(|k| frame_lags(pb, theta, k, lag, nq))
        .collect::<Result<Vec<Lags>>>()?;
    let mut lags = Lags::default();
    for l in &per_frame {
        for i in 0..3 {
            lags.x[i] += l.x[i];
            lags.y[i] += l.y[i];
        }
    }
    Ok(Correlation {
        n_eff: samples as f64 * factor(&lags.x) * factor(&lags.y),
        coherent: per_frame.iter().map(Lags::coherent).collect(),
    })
}

/// The lag products of frame `k`'s residuals under `theta`.
fn frame_lags(pb: &Problem, theta: &[f64], k: usize, lag: usize, nq: usize) -> Result<Lags> {
    let mut lags = Lags::default();
    let mut buf = Vec::new();
    let f = pb.chain(theta, k)?;
    for r in pb.frames.rects(k) {
        let (w, h) = (r.u1 - r.u0, r.v1 - r.v0);
        // Residual map of the rectangle: per pixel, per sample (NaN where not usable).
        let mut z = vec![f64::NAN; w * h * nq];
        for (u, v) in r.points(1) {
            pb.pixel(&f, k, u, v, &mut buf);
            for (q, &(y, m)) in buf.iter().enumerate().take(nq) {
                if pb.usable(k, u, v, y) {
                    let var = pb.noise.variance_dn2(m - pb.capture.sensor.black_level_dn);
                    z[((v - r.v0) * w + u - r.u0) * nq + q] = (y - m) / var.sqrt();
                }
            }
        }
        let add = |acc: &mut [f64; 3], pairs: &mut f64, a: &[f64], b: &[f64]| {
            for (&p, &q) in a.iter().zip(b) {
                if p.is_finite() && q.is_finite() {
                    acc[0] += p * q;
                    acc[1] += p * p;
                    acc[2] += q * q;
                    *pairs += 1.0;
                }
            }
        };
        let at = |u: usize, v: usize| &z[(v * w + u) * nq..][..nq];
        for v in 0..h {
            for u in 0..w {
                if u + lag < w {
                    add(&mut lags.x, &mut lags.pairs[0], at(u, v), at(u + lag, v));
                }
                if v + lag < h {
                    add(&mut lags.y, &mut lags.pairs[1], at(u, v), at(u, v + lag));
                }
            }
        }
    }
    Ok(lags)
}

/// g(ρ) of one direction's lag sums.
fn factor(s: &[f64; 3]) -> f64 {
    let d = (s[1] * s[2]).sqrt();
    if d <= 0.0 {
        return 1.0;
    }
    let rho = (s[0] / d).clamp(0.0, 0.999);
    (1.0 - rho) / (1.0 + rho)
}

#[cfg(test)]
mod tests {
    use super::{factor, Lags};

    #[test]
    fn only_power_beyond_the_noise_of_the_lag_sums_is_coherent() {
        // 10⁶ pairs each way: white noise gives S = 0 ± 707; a floor at 3σ = 2121.
        let lags = |s: f64| Lags { x: [s, 1e6, 1e6], y: [s, 1e6, 1e6], pairs: [1e6, 1e6] };
        assert_eq!(lags(1500.0).coherent(), 0.0);
        assert!((lags(5000.0).coherent() - (5000.0 - 3.0 * 5e5f64.sqrt())).abs() < 1e-9);
    }

    #[test]
    fn white_residuals_count_fully_and_correlated_ones_less() {
        // Uncorrelated: ρ = 0, factor 1; ρ = 0.5: a third; anticorrelated: no gain.
        assert_eq!(factor(&[0.0, 10.0, 10.0]), 1.0);
        assert!((factor(&[5.0, 10.0, 10.0]) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(factor(&[-5.0, 10.0, 10.0]), 1.0);
        assert_eq!(factor(&[0.0, 0.0, 0.0]), 1.0);
    }
}
