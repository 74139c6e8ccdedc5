//! The stamped route's measurement model: the apparent sun by NREL SPA
//! ([`crate::sky::sun`]: sea level, standard refraction, as `simulate` renders it) at a
//! trial place, and each frame's predicted bearing and elevation.
//!
//! ```text
//! (Aᵢ, hᵢ) = SPA(tᵢ, φ, λ)          azimuth from North toward East, elevation, degrees
//! bᵢ = Aᵢ − ψ₀ − Δyawᵢ              the sun's bearing from the image top
//! rᵢ = (wrap(b̂ᵢ − bᵢ)/σ_b,ᵢ, (ĥᵢ − hᵢ)/σ_h,ᵢ),  σ_b,ᵢ² = σ_bearing,ᵢ² + σ_yaw,ᵢ²
//! ```

use super::SunObs;
use crate::conventions::{wrap_deg_180, wrap_deg_360};
use crate::sky::sun::sun_from_unix_time;

/// The sun seen from a trial place at the frames' stamps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SunModel;

impl SunModel {
    /// (azimuth, elevation) in degrees at `time_unix_s` from (`latitude_deg`,
    /// `longitude_deg`); the latitude is clamped inside ±89.99° and the longitude
    /// wrapped, so a trial step past the pole or the date line stays a place.
    pub fn sun(time_unix_s: f64, latitude_deg: f64, longitude_deg: f64) -> Option<(f64, f64)> {
        let lat = latitude_deg.clamp(-89.99, 89.99);
        let lon = wrap_deg_180(longitude_deg);
        let s = sun_from_unix_time(time_unix_s, lat, lon).ok()?;
        Some((s.azimuth_deg, s.elevation_deg))
    }
}

/// The whitened residuals of `obs` at p = (ψ₀, φ, λ), degrees; `None` where SPA fails.
pub(crate) fn residuals(obs: &[SunObs], p: &[f64; 3]) -> Option<Vec<f64>> {
    let mut r = Vec::with_capacity(2 * obs.len());
    for o in obs {
        let (a, h) = SunModel::sun(o.time_unix_s?, p[1], p[2])?;
        let b = a - p[0] - o.yaw_deg;
        r.push(wrap_deg_180(o.bearing_deg - b) / bearing_sigma(o));
        r.push((o.elevation_deg - h) / o.elevation_sigma_deg.max(1e-6));
    }
    Some(r)
}

/// The bearing's 1σ with the yaw's, degrees.
pub(crate) fn bearing_sigma(o: &SunObs) -> f64 {
    o.bearing_sigma_deg.hypot(o.yaw_sigma_deg).max(1e-6)
}

/// ψ₀ that best fits the bearings at place (φ, λ): the weighted circular mean of
/// Aᵢ − Δyawᵢ − b̂ᵢ; `None` where SPA fails.
pub(crate) fn best_heading(obs: &[SunObs], latitude_deg: f64, longitude_deg: f64) -> Option<f64> {
    let (mut s, mut c) = (0.0, 0.0);
    for o in obs {
        let (a, _) = SunModel::sun(o.time_unix_s?, latitude_deg, longitude_deg)?;
        let w = 1.0 / bearing_sigma(o).powi(2);
        let x = (a - o.yaw_deg - o.bearing_deg).to_radians();
        (s, c) = (s + w * x.sin(), c + w * x.cos());
    }
    Some(wrap_deg_360(s.atan2(c).to_degrees()))
}
