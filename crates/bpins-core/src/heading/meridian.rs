//! Solar meridian line read off the AoE image (extractor `meridian_line`), as the
//! seed paper reads its azimuth (§3, Fig. 8k).
//!
//! On the solar meridian the E-vector is ⊥ the meridian plane: AoE = ±90°. Near it,
//! with ψ = AoE − 90° and β the image angle of a sample about the assumed principal
//! point, ψ ≈ −k·(β − β_m) (k ≈ 1 near the zenith), so within the band |ψ| < band:
//!
//! ```text
//! ψ ≈ −(k/2)·sin 2(β − β_m) = A·sin 2β + B·cos 2β,   A = −(k/2)cos 2β_m,  B = (k/2) sin 2β_m
//! ```
//!
//! a linear least-squares fit without intercept; `2β_m = atan2(B, −A)`. β comes from
//! the assumed principal point, so an offset δ errs by ~δ/r: this extractor feels
//! the principal point the way the seed paper's does. It assumes a level camera.
//!
//! The line gives the sun's azimuth up to 180°; the half is taken from the sun
//! vector of the same samples. 1σ: from the fit's residuals, propagated to β_m.

use super::{sun_vector, too_few, HeadingContext, HeadingEstimate, HeadingSums};
use crate::conventions::{heading_deg_from_level_sun, level_from_camera, wrap_deg_180, wrap_deg_360};
use crate::error::{Error, Result};

pub fn solve(sums: &HeadingSums, ctx: &HeadingContext) -> Result<HeadingEstimate> {
    let n = sums.n_line;
    if n < 3.0 {
        return Err(too_few("meridian line (no samples with AoE near ±90°)", n));
    }
    let [ss, sc, cc, ps, pc, pp] = sums.line;
    let det = ss * cc - sc * sc;
    if det <= 1e-12 * (ss + cc).powi(2) {
        return Err(Error::Heading("meridian line: the band samples all lie on one radial line".into()));
    }
    // Normal equations of ψ = A sin 2β + B cos 2β.
    let a = (cc * ps - sc * pc) / det;
    let b = (ss * pc - sc * ps) / det;
    let r2 = a * a + b * b;
    if r2 == 0.0 {
        return Err(Error::Heading("meridian line: AoE does not vary across the band".into()));
    }
    let two_beta_m = b.atan2(-a);
    // Residual variance and covariance of (A, B).
    let rss = (pp - a * ps - b * pc).max(0.0);
    let sigma2 = rss / (n - 2.0);
    let (caa, cab, cbb) = (sigma2 * cc / det, -sigma2 * sc / det, sigma2 * ss / det);
    let (ja, jb) = (b / r2, -a / r2); // ∂(2β_m)/∂A, ∂(2β_m)/∂B
    let var_2beta = ja * ja * caa + 2.0 * ja * jb * cab + jb * jb * cbb;
    // The meridian's image angle β_m; the sun lies along β_m or β_m + 180°.
    let beta_m_deg = 0.5 * two_beta_m.to_degrees();
    let candidates = [beta_m_deg, beta_m_deg + 180.0].map(|beta_s| wrap_deg_360(ctx.sun_az_deg + 90.0 - beta_s));
    // Pick the half the sun vector points to.
    let (_, vecs) = sun_vector::sun_in_camera(sums, ctx)?;
    let sv = heading_deg_from_level_sun(level_from_camera(ctx.tilt_x_deg, ctx.tilt_y_deg) * vecs[0], ctx.sun_az_deg);
    let heading_deg = if wrap_deg_180(candidates[0] - sv).abs() <= wrap_deg_180(candidates[1] - sv).abs() {
        candidates[0]
    } else {
        candidates[1]
    };
    Ok(HeadingEstimate {
        heading_deg,
        sigma_deg: 0.5 * var_2beta.max(0.0).sqrt().to_degrees(),
        samples: n as usize,
    })
}
