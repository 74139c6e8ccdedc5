//! The sun as the sky shows it, with no sun given: its bearing from the image top and
//! its elevation, each with its 1σ — the measurement `crate::locate` builds a place
//! and true north from.
//!
//! ```text
//! 1. start: the sun vector of every observed cell (least eigenvector of
//!    Σ w e eᵀ, w = 1/(σ_α² + 0.3°²), level frame, the branch above the horizon);
//!    its elevation h₀
//! 2. the field estimator's robust loop (mod.rs, steps 3–4) at the sun (A = 0, h),
//!    any elevation offset allowed; h ← h + the sky's own elevation offset
//!    (`FieldQuality::sun_elevation_offset_deg`), until it moves by < 0.02° (≤ 6 rounds)
//! 3. bearing b = −ψ (with A = 0 the heading ψ is minus the sun's bearing); its 1σ the
//!    field heading's (step 5 of mod.rs, no sun or tilt σ other than the frame's tilt)
//! 4. elevation h = asin(s_z) of the final weighted sun vector s; its 1σ² =
//!    max(σ_fit, σ_jack, σ_coherent·cos h)² + σ_shared² + σ_tilt² + σ_floor²: σ_fit the
//!    eigenvector's rotation toward the zenith (sun_vector.rs's formula with the
//!    vertical tangent u: σ₀²·Σ_k (u·v_k)²/(λ_k − λ₀)), σ_jack the delete-one-block
//!    jackknife of h over the 4 × 4 blocks, σ_coherent the heading's (spatial.rs);
//!    σ_shared = m·√(W·Σ_k (u·v_k)²/(λ_k − λ₀)) for the used cells' RMS residual m
//!    beyond their noise taken as shared by every cell (W = Σw: n coherent terms do
//!    not average out; a narrow view near the zenith amplifies them, since its
//!    E-vectors are nearly level); σ_tilt = the tilt's 1σ (a tilt about the horizontal
//!    axis across the sun moves h 1:1)
//! ```
//!
//! Frame: the level camera (CONVENTIONS.md; the frame's reference tilt undone): the
//! bearing is the sun's azimuth minus the azimuth of the image top, degrees from
//! North toward East, in [0°, 360°); the elevation in degrees above the horizon.
//!
//! Cannot: read a Berry sky's elevation (its neutral points move the E-vectors'
//! common normal by degrees in a narrow view, and its residual stays small: the 1σ
//! does not cover it; docs/locate.md); tell the sun from the anti-sun when it stands below the horizon (the
//! branch above is taken), read a sun within 1° of the zenith (no bearing) or below
//! −10° (refused as by the heading); an elevation bias shared by every frame (a
//! mount tilt not in the calibration) passes into the latitude.

use super::robust::{self, block_sums, sum_blocks, Scratch, BLOCKS};
use super::{Cells, FieldContext, FieldOptions, FieldQuality, FieldScratch, NoHeading};
use crate::conventions::{wrap_deg_180, wrap_deg_360};
use crate::heading::{sun_vector, Extractor, HeadingSums};
use glam::DVec3;

/// Rounds of step 2 at most, and the elevation step that ends them, degrees.
const ROUNDS: usize = 6;
const SETTLED_DEG: f64 = 0.02;
/// Per-cell model error of the start's weights, radians (as the start search's).
const START_SIGMA_RAD: f64 = 0.3 * std::f64::consts::PI / 180.0;

/// The sun one frame's sky shows, in the level camera frame, with 1σ.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SkySun {
    /// The sun's azimuth minus the camera's heading (the image top's azimuth), [0°, 360°).
    pub bearing_deg: f64,
    pub bearing_sigma_deg: f64,
    /// The sun's elevation above the level frame's horizon, degrees.
    pub elevation_deg: f64,
    pub elevation_sigma_deg: f64,
    pub quality: FieldQuality,
}

/// The sun of one frame's cells (see the module doc); `ctx`'s sun is ignored, its
/// camera and tilt are used. Errs with the field estimator's reasons (too little sky,
/// an ambiguous or misfitting one, a sun out of range).
pub fn sky_sun(
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    scratch: &mut FieldScratch,
) -> Result<SkySun, NoHeading> {
    let sc = &mut scratch.robust;
    let mut ctx = FieldContext { sun_az_deg: 0.0, sun_sigma_deg: 0.0, ..*ctx };
    let lenient = FieldOptions { max_sun_offset_deg: 180.0, ..*opts };
    // Step 1.
    robust::observe(cells, &ctx, opts, ctx.level_from_camera(), &mut sc.slots, &mut sc.obs);
    let mut start = HeadingSums::default();
    for o in &sc.obs {
        start.add_scatter_weighted(o.e, 1.0 / (o.var_aop + START_SIGMA_RAD * START_SIGMA_RAD));
    }
    let quality0 = FieldQuality { cells_total: cells.grid_len(), cells_valid: sc.obs.len(), ..Default::default() };
    let (_, vecs) = sun_vector::scatter_eigen(&start).map_err(|_| too_little(quality0))?;
    let mut h = vecs[0].z.abs().clamp(0.0, 1.0).asin().to_degrees().clamp(0.5, 88.0);
    // Step 2.
    let mut r = None;
    for _ in 0..ROUNDS {
        ctx.sun_el_deg = h;
        let fit = robust::fitted(cells, &ctx, &lenient, sc).map_err(|e| e.1)?;
        let step = fit.quality.sun_elevation_offset_deg;
        h = (h + step).clamp(0.5, 88.0);
        r = Some(fit);
        if step.abs() < SETTLED_DEG {
            break;
        }
    }
    let r = r.expect("ROUNDS ≥ 1");
    // Step 3.
    let fh = robust::heading(&r, Extractor::SunVector, cells, &ctx, opts, sc);
    let (psi, parts) = fh.result?;
    // Step 4.
    let (elevation_deg, elevation_sigma_deg) =
        elevation(sc, r.coherent_deg, r.misfit_rms_deg, ctx.tilt_sigma_deg, opts.sigma_floor_deg)
            .ok_or_else(|| NoHeading::Solver("the sky's sun vector is degenerate".into()))?;
    Ok(SkySun {
        bearing_deg: wrap_deg_360(-psi),
        bearing_sigma_deg: parts.total_deg(),
        elevation_deg,
        elevation_sigma_deg,
        quality: r.quality,
    })
}

fn too_little(q: FieldQuality) -> NoHeading {
    NoHeading::TooLittleSky { used: q.cells_valid, total: q.cells_total }
}

/// The sun above the horizon from level-frame sums: (elevation, fit 1σ, and the 1σ
/// per radian of a misfit every cell shares), degrees.
fn sun_elevation(sums: &HeadingSums, weight_sum: f64) -> Option<(f64, f64, f64)> {
    let (vals, vecs) = sun_vector::scatter_eigen(sums).ok()?;
    let s = if vecs[0].z < 0.0 { -vecs[0] } else { vecs[0] };
    // The vertical tangent at s (toward the zenith); the rotation of s toward the other
    // eigenvectors has variance σ₀²/(λ_k − λ₀), σ₀² = λ₀/(n − 2) (sun_vector.rs).
    let up = DVec3::Z - s * s.z;
    let up = if up.length() > 1e-9 { up.normalize() } else { return None };
    let sigma0_sq = vals[0].max(0.0) / (sums.n - 2.0).max(1.0);
    let gain: f64 = (1..3).map(|k| up.dot(vecs[k]).powi(2) / (vals[k] - vals[0])).sum();
    // A misfit δ shared by every cell moves s by up to δ·√(W·gain), W = Σw: the
    // coherent sum of n terms w·δ·(e·v_k) against λ_k − λ₀ ~ Σ w (e·v_k)².
    Some((s.z.clamp(-1.0, 1.0).asin().to_degrees(), (sigma0_sq * gain).sqrt().to_degrees(), (weight_sum * gain).sqrt()))
}

/// Step 4 on the final weights left in `sc`: (elevation, 1σ), degrees. `misfit_deg`
/// is the used cells' RMS residual beyond their noise, taken as shared by all.
fn elevation(
    sc: &Scratch,
    coherent_deg: f64,
    misfit_deg: f64,
    tilt_sigma_deg: f64,
    floor_deg: f64,
) -> Option<(f64, f64)> {
    let blocks = block_sums(&sc.obs, &sc.b.w, Extractor::SunVector, (0.0, 0.0, 0.0));
    let total = sum_blocks(&blocks);
    let weight_sum: f64 = sc.b.w.iter().filter(|x| x.0 > 0.0).map(|x| x.0 / (x.1 * x.2)).sum();
    let (h, fit, per_rad) = sun_elevation(&total, weight_sum)?;
    let misfit = if misfit_deg.is_finite() { misfit_deg * per_rad } else { 0.0 };
    let mut dev = Vec::with_capacity(BLOCKS * BLOCKS);
    let used: Vec<_> = blocks.iter().filter(|b| b.n > 0.0).collect();
    for b in &used {
        if let Some((hb, ..)) = sun_elevation(&total.minus(b), weight_sum) {
            dev.push(wrap_deg_180(hb - h));
        }
    }
    let k = used.len() as f64;
    let jack = if dev.len() >= 2 && dev.len() == used.len() {
        let mean = dev.iter().sum::<f64>() / k;
        ((k - 1.0) / k * dev.iter().map(|d| (d - mean).powi(2)).sum::<f64>()).sqrt()
    } else {
        2.0 * fit
    };
    let coherent = if coherent_deg.is_finite() { coherent_deg * h.to_radians().cos() } else { 0.0 };
    let data = fit.max(jack).max(coherent);
    let sigma = (data * data + misfit.powi(2) + tilt_sigma_deg.powi(2) + floor_deg.powi(2)).sqrt();
    Some((h, sigma))
}
