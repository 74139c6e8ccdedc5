//! The pole route (module doc of `locate`): no clock, the pole alone.
//!
//! ```text
//! sᵢ = (sin βᵢ cos hᵢ, cos βᵢ cos hᵢ, sin hᵢ),  βᵢ = b̂ᵢ + Δyawᵢ    first frame's level axes
//! p(β_p, e_p) = (sin β_p cos e_p, cos β_p cos e_p, sin e_p)         the pole, same axes
//! rᵢ = (sᵢ·p − c)/σᵢ,  σᵢ² = (∂(s·p)/∂β)² σ_b,ᵢ² + (∂(s·p)/∂h)² σ_h,ᵢ²
//! ```
//!
//! The sun's diurnal circle has sᵢ·p_N = sin δ for the north celestial pole p_N and
//! the declination δ: a cone. Start: the normal of the plane through the sᵢ (least
//! eigenvector of their scatter about the mean); LM on (β_p, e_p, c). The sun turns
//! westward, ds/dt = −Ω p_N × s, so Σ (sᵢ × sᵢ₊₁)·p_N < 0 in time order: that sign
//! picks p_N from ±p. Latitude φ = e_p (the north pole's elevation, negative south of
//! the equator); the image top's azimuth ψ₀ = −β_p. Frames are taken in the capture's
//! order, which must be time order.

use super::model::bearing_sigma;
use super::{lm, LocateError, Located, Route, SunObs};
use crate::conventions::{enu_from_az_el_deg, wrap_deg_360};
use glam::DVec3;

/// The declination's largest drift per degree of hour angle, degrees per degree.
const DECLINATION_DRIFT_PER_HOUR_ANGLE: f64 = 0.40 / 360.0;

/// The true (geometric) elevation under an apparent one, degrees: SPA's standard
/// refraction (Reda & Andreas 2003, eq. 42, 1010 hPa and 10 °C scaled to the
/// standard 1013.25 hPa, 15 °C: Δe = 1.02/(60 tan(e + 10.3/(e + 5.11)))·(P/1010)·(283/(273 + T)))
/// undone by fixed-point iteration. The diurnal circle is the true sun's; refraction
/// lifts a low sun by up to 0.5° and would bend it.
fn unrefracted_deg(apparent_deg: f64) -> f64 {
    let scale = (1013.25 / 1010.0) * (283.0 / 288.0);
    let mut e = apparent_deg;
    for _ in 0..4 {
        let r = scale * 1.02 / (60.0 * (e + 10.3 / (e + 5.11)).to_radians().tan());
        e = apparent_deg - r;
    }
    e
}

pub(crate) fn solve_pole(obs: &[SunObs]) -> Result<Located, LocateError> {
    let s: Vec<DVec3> =
        obs.iter().map(|o| enu_from_az_el_deg(o.bearing_deg + o.yaw_deg, unrefracted_deg(o.elevation_deg))).collect();
    let n = s.len() as f64;
    let mean = s.iter().copied().sum::<DVec3>() / n;
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    for v in &s {
        let d = *v - mean;
        let d = nalgebra::Vector3::new(d.x, d.y, d.z);
        m += d * d.transpose();
    }
    let eig = m.symmetric_eigen();
    let k = eig.eigenvalues.imin();
    let axis = eig.eigenvectors.column(k);
    let mut p0 = DVec3::new(axis[0], axis[1], axis[2]).normalize();
    // The north pole: the sun turns clockwise about it (module doc).
    let turn: f64 = s.windows(2).map(|w| w[0].cross(w[1]).dot(p0)).sum();
    if turn > 0.0 {
        p0 = -p0;
    }
    let to_angles = |p: DVec3| (p.x.atan2(p.y).to_degrees(), p.z.clamp(-1.0, 1.0).asin().to_degrees());
    let (b0, e0) = to_angles(p0);
    let c0 = s.iter().map(|v| v.dot(p0)).sum::<f64>() / n;
    let f = |q: &[f64; 3]| -> Option<Vec<f64>> {
        let p = enu_from_az_el_deg(q[0], q[1]);
        Some(
            obs.iter()
                .zip(&s)
                .map(|(o, v)| {
                    // ∂s/∂β and ∂s/∂h per degree, dotted with p.
                    let (sb, cb) = (o.bearing_deg + o.yaw_deg).to_radians().sin_cos();
                    let (sh, ch) = o.elevation_deg.to_radians().sin_cos();
                    let ds_db = DVec3::new(cb * ch, -sb * ch, 0.0) * 1f64.to_radians();
                    let ds_dh = DVec3::new(-sb * sh, -cb * sh, ch) * 1f64.to_radians();
                    let sigma = (ds_db.dot(p) * bearing_sigma(o)).hypot(ds_dh.dot(p) * o.elevation_sigma_deg);
                    (v.dot(p) - q[2]) / sigma.max(1e-12)
                })
                .collect(),
        )
    };
    let fit = lm([1e-3, 1e-3, 1e-6])
        .solve([b0, e0, c0], &f)
        .ok_or_else(|| LocateError::Solver("the cone fit failed".into()))?;
    let q = fit.p;
    let mut cov = fit.covariance().ok_or_else(|| LocateError::Solver("the frames do not determine the pole".into()))?;
    // Two errors every frame shares, which χ² cannot see: an elevation bias of about
    // one frame's 1σ (the median), and the declination's drift over the span, up to
    // 23.44°·2π/365.25 ≈ 0.40° a day, i.e. 0.40°/360° = 0.0011° per degree of hour
    // angle (its worst, at the equinoxes): each enters the whitened residuals as v.
    let p = enu_from_az_el_deg(q[0], q[1]);
    let sigmas =
        f(&q).map(|r| obs.iter().zip(&s).zip(&r).map(|((_, v), ri)| (v.dot(p) - q[2]) / ri).collect::<Vec<f64>>());
    let sigma_i: Vec<f64> = match sigmas {
        Some(x) => x.into_iter().map(|x| if x.is_finite() && x != 0.0 { x.abs() } else { f64::NAN }).collect(),
        None => vec![f64::NAN; obs.len()],
    };
    if sigma_i.iter().all(|x| x.is_finite()) {
        let el_sigma = crate::stats::median(obs.iter().map(super::shared_elevation_sigma).collect());
        let v_el: Vec<f64> = obs
            .iter()
            .zip(&sigma_i)
            .map(|(o, si)| {
                let (sb, cb) = (o.bearing_deg + o.yaw_deg).to_radians().sin_cos();
                let (sh, ch) = o.elevation_deg.to_radians().sin_cos();
                DVec3::new(-sb * sh, -cb * sh, ch).dot(p) * 1f64.to_radians() / si
            })
            .collect();
        fit.add_shared_bias(&mut cov, &v_el, el_sigma.unwrap_or(f64::NAN));
        let u0 = s[0] - p * s[0].dot(p);
        let cos_dec = (1.0 - q[2] * q[2]).max(0.0).sqrt();
        let v_drift: Vec<f64> = s
            .iter()
            .zip(&sigma_i)
            .map(|(v, si)| {
                let u = *v - p * v.dot(p);
                let tau_deg = u0.cross(u).dot(p).atan2(u0.dot(u)).to_degrees();
                cos_dec * tau_deg * 1f64.to_radians() / si
            })
            .collect();
        fit.add_shared_bias(&mut cov, &v_drift, DECLINATION_DRIFT_PER_HOUR_ANGLE);
    }
    Ok(Located {
        route: Route::Pole,
        heading_deg: wrap_deg_360(-q[0]),
        heading_sigma_deg: cov[0][0].sqrt(),
        latitude_deg: q[1].clamp(-90.0, 90.0),
        latitude_sigma_deg: cov[1][1].sqrt(),
        longitude_deg: None,
        longitude_sigma_deg: None,
        frames_used: obs.len(),
        span_s: None,
        chi2_per_dof: fit.chi2_per_dof(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::locate::model::SunModel;

    /// Exact suns from SPA over three hours at the June solstice (the declination
    /// stands still), a camera facing 30° and turning 5° a frame: the cone's axis gives
    /// the latitude and north to under 0.1°, north and south of the equator. (Near an
    /// equinox the declination moves ≈ 0.05° in three hours, which a short arc's fit
    /// amplifies several times: the 1σ must then cover it.)
    #[test]
    fn exact_suns_give_the_pole() {
        for (lat, t0) in [(40.0, 1_782_028_800.0), (-33.0, 1_782_028_800.0)] {
            let obs: Vec<SunObs> = (0..13)
                .filter_map(|i| {
                    let t = t0 + 900.0 * i as f64;
                    let (a, h) = SunModel::sun(t, lat, 10.0)?;
                    (h > 5.0).then_some(SunObs {
                        time_unix_s: None,
                        yaw_deg: 5.0 * i as f64,
                        yaw_sigma_deg: 0.0,
                        bearing_deg: wrap_deg_360(a - 30.0 - 5.0 * i as f64),
                        bearing_sigma_deg: 0.05,
                        elevation_deg: h,
                        elevation_sigma_deg: 0.05,
                        elevation_nuisance_sigma_deg: 0.0,
                        separation_deg: 0.0,
                        separation_sigma_deg: 1.0,
                        given_sun_deg: None,
                    })
                })
                .collect();
            assert!(obs.len() >= 6, "{lat}: {} frames in daylight", obs.len());
            let r = solve_pole(&obs).unwrap();
            assert!((r.latitude_deg - lat).abs() < 0.1, "{lat}: {r:?}");
            assert!(crate::conventions::wrap_deg_180(r.heading_deg - 30.0).abs() < 0.1, "{lat}: {r:?}");
        }
    }
}
