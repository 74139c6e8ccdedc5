//! The stamped route (module doc of `locate`): a grid over the globe for the start,
//! then Levenberg–Marquardt on (ψ₀, φ, λ).
//!
//! The grid: φ in 5° steps over ±85°, λ in 10° steps; on each node ψ₀ in closed form
//! (`model::best_heading`) and the χ² of every residual; the best nodes at least 15°
//! apart each start a fit, and the fit of least χ² wins (an elevation series alone is
//! matched by a mirror place, which the bearings' rate then tells apart).

use super::model::{best_heading, residuals};
use super::{lm, LocateError, Located, Route, SunObs};
use crate::conventions::{wrap_deg_180, wrap_deg_360};

/// Starts from the grid that the fit refines.
const STARTS: usize = 4;

pub(crate) fn solve_stamped(obs: &[SunObs]) -> Result<Located, LocateError> {
    let chi2 = |p: &[f64; 3]| residuals(obs, p).map(|r| r.iter().map(|x| x * x).sum::<f64>());
    let mut nodes = Vec::new();
    for i in -17..=17 {
        for k in -18..18 {
            let (lat, lon) = (5.0 * i as f64, 10.0 * k as f64);
            if let Some(psi) = best_heading(obs, lat, lon) {
                let p = [psi, lat, lon];
                if let Some(c) = chi2(&p) {
                    nodes.push((c, p));
                }
            }
        }
    }
    nodes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut starts: Vec<[f64; 3]> = Vec::new();
    for (_, p) in &nodes {
        let far = starts.iter().all(|q| (q[1] - p[1]).abs() > 15.0 || wrap_deg_180(q[2] - p[2]).abs() > 15.0);
        if far {
            starts.push(*p);
        }
        if starts.len() == STARTS {
            break;
        }
    }
    let f = |p: &[f64; 3]| residuals(obs, p);
    let fit = starts
        .into_iter()
        .filter_map(|p| lm([1e-3, 1e-3, 1e-3]).solve(p, &f))
        .min_by(|a, b| a.chi2.total_cmp(&b.chi2))
        .ok_or_else(|| LocateError::Solver("no start of the grid could be fitted".into()))?;
    let p = fit.p;
    let mut cov =
        fit.covariance().ok_or_else(|| LocateError::Solver("the frames do not determine the place".into()))?;
    // The elevations may share a bias (the estimator's own, a lens or sky error that
    // every frame sees alike) of about one frame's 1σ with the sky's unknown
    // neutral-point separation's part: the median's.
    let shared = crate::stats::median(obs.iter().map(super::shared_elevation_sigma).collect()).unwrap_or(f64::NAN);
    let v: Vec<f64> = obs.iter().flat_map(|o| [0.0, 1.0 / o.elevation_sigma_deg.max(1e-6)]).collect();
    fit.add_shared_bias(&mut cov, &v, shared);
    let times: Vec<f64> = obs.iter().filter_map(|o| o.time_unix_s).collect();
    let span =
        times.iter().copied().fold(f64::NEG_INFINITY, f64::max) - times.iter().copied().fold(f64::INFINITY, f64::min);
    Ok(Located {
        route: Route::Stamped,
        heading_deg: wrap_deg_360(p[0]),
        heading_sigma_deg: cov[0][0].sqrt(),
        latitude_deg: p[1].clamp(-90.0, 90.0),
        latitude_sigma_deg: cov[1][1].sqrt(),
        longitude_deg: Some(wrap_deg_180(p[2])),
        longitude_sigma_deg: Some(cov[2][2].sqrt()),
        frames_used: obs.len(),
        span_s: Some(span),
        chi2_per_dof: fit.chi2_per_dof(),
    })
}
