//! Least-squares sun vector (extractor `sun_vector`).
//!
//! Rayleigh E-vectors are ⊥ the sun direction s, so s minimises `Σ w (e·s)²`: the unit
//! eigenvector of least eigenvalue λ₀ of `M = Σ w e eᵀ` (camera frame). Its sign is
//! chosen so the sun is above the horizon (the pattern alone cannot tell sun from
//! anti-sun). The heading follows from s in the level frame (conventions).
//!
//! Uncertainty: treating w as relative precisions, the residual variance per unit
//! weight is `σ₀² = λ₀/(n − 2)` and a rotation of s toward eigenvector k has variance
//! `σ₀²/(λ_k − λ₀)`; projected on the horizontal direction ⊥ s and divided by cos h.
//! A wrong assumed principal point enters only through the rays' directions, δ/f —
//! far less than through β (δ/r) — which is why this extractor barely feels it.

use super::eigen::symmetric_eigen;
use super::{too_few, HeadingContext, HeadingEstimate, HeadingSums};
use crate::conventions::heading_deg_from_level_sun;
use crate::error::{Error, Result};
use glam::{DMat3, DVec3};

/// Eigen-decomposition of the scatter `Σ w e eᵀ`: eigenvalues ascending and their
/// unit eigenvectors; the sun is ±`vecs[0]` (the sign is the caller's to choose).
pub(crate) fn scatter_eigen(sums: &HeadingSums) -> Result<([f64; 3], [DVec3; 3])> {
    if sums.n < 3.0 {
        return Err(too_few("sun vector", sums.n));
    }
    let s = sums.scatter;
    let m = DMat3::from_cols(DVec3::new(s[0], s[1], s[2]), DVec3::new(s[1], s[3], s[4]), DVec3::new(s[2], s[4], s[5]));
    let (vals, vecs) = symmetric_eigen(m);
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must take this branch too
    if !(vals[1] > vals[0]) {
        return Err(Error::Heading(
            "sun vector: the E-vectors do not determine a sun direction (degenerate scatter)".into(),
        ));
    }
    Ok((vals, vecs))
}

/// The unit sun direction in the camera frame and its covariance ingredients.
pub(crate) fn sun_in_camera(sums: &HeadingSums, ctx: &HeadingContext) -> Result<([f64; 3], [DVec3; 3])> {
    let (vals, mut vecs) = scatter_eigen(sums)?;
    // Sun above the horizon (sign of the known elevation; level if ~0).
    let level = ctx.level_from_camera();
    let up = if ctx.sun_el_deg >= 0.0 { 1.0 } else { -1.0 };
    if (level * vecs[0]).z * up < 0.0 {
        vecs[0] = -vecs[0];
    }
    Ok((vals, vecs))
}

pub fn solve(sums: &HeadingSums, ctx: &HeadingContext) -> Result<HeadingEstimate> {
    let (vals, vecs) = sun_in_camera(sums, ctx)?;
    heading_from_eigen(vals, vecs, sums.n, ctx.level_from_camera(), ctx.sun_az_deg)
}

/// Heading and 1σ from the scatter's eigen-decomposition (`vecs[0]` the sun, sign
/// chosen), `n` samples, `level` = level_from_camera, the sun at azimuth `sun_az_deg`.
pub(crate) fn heading_from_eigen(
    vals: [f64; 3],
    vecs: [DVec3; 3],
    n: f64,
    level: DMat3,
    sun_az_deg: f64,
) -> Result<HeadingEstimate> {
    let s_level = level * vecs[0];
    let heading_deg = heading_deg_from_level_sun(s_level, sun_az_deg);
    // 1σ: rotation of s about the vertical, through the two other eigen-directions.
    let horiz = (s_level.x * s_level.x + s_level.y * s_level.y).sqrt();
    if horiz < 1e-9 {
        return Err(Error::Heading("sun vector: the sun is at the zenith, heading undefined".into()));
    }
    let t_level = DVec3::new(-s_level.y, s_level.x, 0.0) / horiz;
    let t_cam = level.transpose() * t_level;
    let sigma0_sq = (vals[0].max(0.0)) / (n - 2.0);
    let var_t: f64 = (1..3).map(|k| t_cam.dot(vecs[k]).powi(2) * sigma0_sq / (vals[k] - vals[0])).sum();
    Ok(HeadingEstimate { heading_deg, sigma_deg: (var_t.sqrt() / horiz).to_degrees(), samples: n as usize })
}
