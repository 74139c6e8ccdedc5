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
//! a linear least-squares fit without intercept; `2β_m = atan2(B, −A)`. Only the
//! half-line toward the sun is fitted (the half is taken from the sun vector of the
//! same samples): β comes from the assumed principal point, so an offset δ turns
//! that half-line by ~δ/r, the way the seed paper's extractor feels it (a full line
//! through the principal point would cancel it to first order). Samples lie in a
//! disc inside the image, so the band is symmetric about the meridian and the
//! noise-free estimate unbiased. It reads a level camera and refuses a tilted one
//! (the field estimator, `field/`, fits the same line in the level frame instead).
//! 1σ: from the fit's residuals, propagated to β_m.

use super::{sector_centre_rad, sun_vector, too_few, HeadingContext, HeadingEstimate, HeadingSums, SECTORS};
use crate::conventions::{image_angle_rad, wrap_deg_180, wrap_deg_360};
use crate::error::{Error, Result};

pub fn solve(sums: &HeadingSums, ctx: &HeadingContext) -> Result<HeadingEstimate> {
    // The per-pixel band reads AoE about the image's principal point: a level camera only.
    let tilt = ctx.level_from_camera();
    let off_axis_deg = (tilt * glam::DVec3::Z).z.clamp(-1.0, 1.0).acos().to_degrees();
    if off_axis_deg > LEVEL_TOLERANCE_DEG {
        return Err(Error::Heading(format!(
            "meridian line: the camera is tilted {off_axis_deg:.2}° from level (frame and mount); \
             this per-pixel extractor reads the AoE image of a level camera (`bpins heading`'s \
             field estimator reads tilted frames)"
        )));
    }
    // The sun's side of the image, from the sun vector of the same samples.
    let (_, vecs) = sun_vector::sun_in_camera(sums, ctx)?;
    solve_half(sums, image_angle_rad(vecs[0].x, vecs[0].y), ctx.sun_az_deg)
}

/// Tilt from level (degrees) up to which the per-pixel meridian line reads a frame.
pub(crate) const LEVEL_TOLERANCE_DEG: f64 = 0.01;

/// The meridian line fitted on the half toward image angle `beta_sun` (radians) of
/// the frame the band sums were taken in, the sun at azimuth `sun_az_deg`.
pub(crate) fn solve_half(sums: &HeadingSums, beta_sun: f64, sun_az_deg: f64) -> Result<HeadingEstimate> {
    solve_line(sums, beta_sun, sun_az_deg, false)
}

/// The meridian line fitted on the sun's half (`both_halves` false) or on the whole
/// line through the zenith (the anti-sun half too); the sun's half-line is the one
/// within 90° of `beta_sun` either way.
pub(crate) fn solve_line(
    sums: &HeadingSums,
    beta_sun: f64,
    sun_az_deg: f64,
    both_halves: bool,
) -> Result<HeadingEstimate> {
    let mut l = [0.0; 7];
    for k in 0..SECTORS {
        if both_halves || (sector_centre_rad(k) - beta_sun).cos() > 0.0 {
            for (a, b) in l.iter_mut().zip(&sums.line[k]) {
                *a += b;
            }
        }
    }
    let [ss, sc, cc, ps, pc, pp, n] = l;
    if n < 3.0 {
        return Err(too_few("meridian line (no samples with AoE near ±90° on the sun's side)", n));
    }
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
    // The meridian's image angle β_m (mod 180°): the sun's half-line is the one
    // within 90° of the sun vector's image direction.
    let mut beta_s_deg = 0.5 * two_beta_m.to_degrees();
    if wrap_deg_180(beta_s_deg - beta_sun.to_degrees()).abs() > 90.0 {
        beta_s_deg += 180.0;
    }
    // Image angle β_s of the sun's direction ↔ heading (conventions): ψ = A + 90° − β_s.
    let heading_deg = wrap_deg_360(sun_az_deg + 90.0 - beta_s_deg);
    Ok(HeadingEstimate { heading_deg, sigma_deg: 0.5 * var_2beta.max(0.0).sqrt().to_degrees(), samples: n as usize })
}
