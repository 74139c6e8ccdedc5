//! Seeded attitude and sun errors of a field capture: each frame's true tilt drawn at
//! random (a robot on rough ground), its reference tilt read by a noisy IMU, and the
//! sun known only to a 1σ.
//!
//! ```text
//! true tilt      t_x = t_x⁰ + T·(2u − 1),  t_y = t_y⁰ + T·(2u′ − 1)      u, u′ ~ U[0, 1)
//! reference tilt t̂ = t + S·n,  n ~ N(0, 1) per axis          written, with tilt_sigma_deg = S
//! true sun       A = Â + σ·n,  h = clamp(ĥ + σ·n′, −90°, 90°)  written Â, ĥ, sun_sigma_deg = σ
//! ```
//!
//! t⁰ is the frame's given tilt, Â, ĥ its given (or SPA) sun. The reference is what a
//! capture records and an extractor is told; the truth is what the frame is rendered
//! under, so the reference is off the truth by N(0, S) per tilt axis and N(0, σ) per
//! sun angle, as `tilt_sigma_deg` and `sun_sigma_deg` declare (CAPTURE.md). For the
//! sun the error is put on the truth, which keeps a time-and-place sun written as
//! such. Frame: tilts about camera x then y (CONVENTIONS.md), degrees; the sun in
//! azimuth (North toward East) and elevation, degrees. Every draw is keyed by (seed,
//! frame index): the same seed gives the same frames.

use super::Draws;
use crate::capture::FrameSpec;
use crate::error::{Error, Result};
use crate::sky::sun::SunPosition;

/// The trial word of the attitude draws (apart from the elements' and a Monte Carlo's).
const ATTITUDE_TRIAL: u32 = 0x5ce0_a771;

/// Per-frame random tilt, IMU error and sun error of a simulated capture.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FieldAttitude {
    /// Largest random tilt about each camera axis, degrees (uniform in ±T).
    pub tilt_random_deg: f64,
    /// 1σ of the IMU's reference tilt per axis, degrees; written as `tilt_sigma_deg`.
    pub imu_sigma_deg: Option<f64>,
    /// 1σ of the sun's azimuth and elevation, degrees; written as `sun_sigma_deg`.
    pub sun_sigma_deg: Option<f64>,
    pub seed: u64,
}

impl FieldAttitude {
    /// Whether it changes nothing (no random tilt, no σ declared).
    pub fn is_none(&self) -> bool {
        self.tilt_random_deg == 0.0 && self.imu_sigma_deg.is_none() && self.sun_sigma_deg.is_none()
    }

    /// The frames to render (truth) and the frames to write (reference), from the
    /// given `frames`. Errors on a bound or σ outside [0°, 45°] or not finite.
    pub fn draw(&self, frames: &[FrameSpec]) -> Result<(Vec<FrameSpec>, Vec<FrameSpec>)> {
        let checks =
            [("random tilt", Some(self.tilt_random_deg)), ("IMU σ", self.imu_sigma_deg), ("sun σ", self.sun_sigma_deg)];
        for (what, v) in checks {
            if let Some(v) = v.filter(|v| !(v.is_finite() && (0.0..=45.0).contains(v))) {
                return Err(Error::OutOfRange {
                    what: what.into(), value: format!("{v}°"), range: "[0°, 45°]".into()
                });
            }
        }
        let (t, s_imu, s_sun) = (self.tilt_random_deg, self.imu_sigma_deg.unwrap_or(0.0), self.sun_sigma_deg);
        let mut truth = Vec::with_capacity(frames.len());
        let mut reference = Vec::with_capacity(frames.len());
        for (i, f) in frames.iter().enumerate() {
            let d = Draws::keyed(self.seed, ATTITUDE_TRIAL, i as u32);
            let (mut tf, mut rf) = (f.clone(), f.clone());
            if t > 0.0 || self.imu_sigma_deg.is_some() {
                let true_x = f.tilt_x_deg.unwrap_or(0.0) + t * (2.0 * d.uniform(0) - 1.0);
                let true_y = f.tilt_y_deg.unwrap_or(0.0) + t * (2.0 * d.uniform(1) - 1.0);
                (tf.tilt_x_deg, tf.tilt_y_deg) = (Some(true_x), Some(true_y));
                rf.tilt_x_deg = Some(true_x + s_imu * d.normal(2));
                rf.tilt_y_deg = Some(true_y + s_imu * d.normal(3));
                rf.tilt_sigma_deg = self.imu_sigma_deg;
            }
            if let Some(s) = s_sun {
                let az = f.sun.azimuth_deg + s * d.normal(4);
                let el = (f.sun.elevation_deg + s * d.normal(5)).clamp(-90.0, 90.0);
                tf.sun = SunPosition::given(az, el);
                rf.sun_sigma_deg = Some(s);
            }
            truth.push(tf);
            reference.push(rf);
        }
        Ok((truth, reference))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn frames(n: usize) -> Vec<FrameSpec> {
        (0..n)
            .map(|i| FrameSpec {
                file: PathBuf::from(format!("f{i}.png")),
                sun: SunPosition::given(120.0, 38.0),
                heading_deg: Some(10.0 * i as f64),
                tilt_x_deg: None,
                tilt_y_deg: Some(1.0),
                tilt_sigma_deg: None,
                sun_sigma_deg: None,
                yaw_deg: None,
                yaw_sigma_deg: None,
            })
            .collect()
    }

    #[test]
    fn nothing_asked_changes_nothing() {
        let a = FieldAttitude { seed: 3, ..Default::default() };
        assert!(a.is_none());
        let (t, r) = a.draw(&frames(3)).unwrap();
        assert_eq!((t, r), (frames(3), frames(3)));
    }

    #[test]
    fn tilts_stay_in_bounds_and_the_imu_error_has_its_sigma() {
        let a = FieldAttitude { tilt_random_deg: 8.0, imu_sigma_deg: Some(0.1), sun_sigma_deg: Some(0.2), seed: 5 };
        let (truth, refs) = a.draw(&frames(4000)).unwrap();
        let (mut s2, mut sun2) = (0.0, 0.0);
        for (t, r) in truth.iter().zip(&refs) {
            let (x, y) = (t.tilt_x_deg.unwrap(), t.tilt_y_deg.unwrap());
            assert!(x.abs() <= 8.0 && (y - 1.0).abs() <= 8.0);
            s2 += (r.tilt_x_deg.unwrap() - x).powi(2) + (r.tilt_y_deg.unwrap() - y).powi(2);
            sun2 += (t.sun.azimuth_deg - r.sun.azimuth_deg).powi(2) + (t.sun.elevation_deg - 38.0).powi(2);
            assert_eq!((r.tilt_sigma_deg, r.sun_sigma_deg), (Some(0.1), Some(0.2)));
            assert_eq!((r.sun.azimuth_deg, r.sun.elevation_deg, r.heading_deg), (120.0, 38.0, t.heading_deg));
        }
        let n = 2.0 * truth.len() as f64;
        assert!(((s2 / n).sqrt() - 0.1).abs() < 0.005, "IMU σ {}", (s2 / n).sqrt());
        assert!(((sun2 / n).sqrt() - 0.2).abs() < 0.01, "sun σ {}", (sun2 / n).sqrt());
        // Spread over the whole ±T.
        let max = truth.iter().map(|t| t.tilt_x_deg.unwrap().abs()).fold(0.0, f64::max);
        assert!(max > 7.9);
        // Seeded.
        assert_eq!(a.draw(&frames(5)).unwrap(), a.draw(&frames(5)).unwrap());
        let b = FieldAttitude { seed: 6, ..a };
        assert_ne!(a.draw(&frames(5)).unwrap().0, b.draw(&frames(5)).unwrap().0);
    }

    #[test]
    fn bad_bounds_are_refused() {
        for a in [
            FieldAttitude { tilt_random_deg: -1.0, ..Default::default() },
            FieldAttitude { imu_sigma_deg: Some(f64::NAN), ..Default::default() },
            FieldAttitude { sun_sigma_deg: Some(50.0), ..Default::default() },
        ] {
            assert!(a.draw(&frames(1)).is_err());
        }
    }
}
