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
//! has ρ ≈ 0 ± 1/√n, so n_eff ≈ n. (The heading's 1σ under a misfit the model leaves
//! is not from these sums but from the residual projected on the heading's sensitivity
//! tile by tile: `spatial`.)

use crate::error::Result;
use crate::fit::model::problem::Problem;
use crate::sensor::Layout;
use rayon::prelude::*;

/// Lag products of one frame: (Σ z·z_next, Σ z², Σ z_next²) along x, then along y.
#[derive(Clone, Copy, Default)]
struct Lags {
    x: [f64; 3],
    y: [f64; 3],
}

/// What the residuals' correlations give the fit.
pub(crate) struct Correlation {
    /// Effective sample count over every frame.
    pub n_eff: f64,
}

/// n_eff of the residuals of `theta` over every usable sample. The lag pairs lie within
/// each rectangle the frames hold (the whole frame, or each sampled block of whole 2 × 2
/// tiles: neighbours stay adjacent).
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
    Ok(Correlation { n_eff: samples as f64 * factor(&lags.x) * factor(&lags.y) })
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
        let add = |acc: &mut [f64; 3], a: &[f64], b: &[f64]| {
            for (&p, &q) in a.iter().zip(b) {
                if p.is_finite() && q.is_finite() {
                    acc[0] += p * q;
                    acc[1] += p * p;
                    acc[2] += q * q;
                }
            }
        };
        let at = |u: usize, v: usize| &z[(v * w + u) * nq..][..nq];
        for v in 0..h {
            for u in 0..w {
                if u + lag < w {
                    add(&mut lags.x, at(u, v), at(u + lag, v));
                }
                if v + lag < h {
                    add(&mut lags.y, at(u, v), at(u, v + lag));
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
    use super::factor;

    #[test]
    fn white_residuals_count_fully_and_correlated_ones_less() {
        // Uncorrelated: ρ = 0, factor 1; ρ = 0.5: a third; anticorrelated: no gain.
        assert_eq!(factor(&[0.0, 10.0, 10.0]), 1.0);
        assert!((factor(&[5.0, 10.0, 10.0]) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(factor(&[-5.0, 10.0, 10.0]), 1.0);
        assert_eq!(factor(&[0.0, 0.0, 0.0]), 1.0);
    }
}
