//! The sensor's temporal noise read off the measured frames themselves (a photon
//! transfer estimate), so that the fit's weights and χ² do not depend on the model.
//!
//! ```text
//! d = DN(u) − ½[DN(u − 2) + DN(u + 2)]          same channel (2 px apart on a DoFP row)
//! E[d²] = 1.5·σ²(s),  σ²(s) = σ_r² + K·s + (p·s)²,  s = DN − black   (EMVA 1288 §4, §8)
//! ```
//!
//! The sky is smooth: over four pixels its curvature is far below the noise, so the
//! second difference is noise alone. σ_r², K and p² come from a least-squares
//! quadratic of d²/1.5 in s over every usable pixel of every frame (a line where the
//! quadratic term comes out negative). p is the multiplicative part: PRNU (a gain
//! that differs pixel to pixel, EMVA 1288's S_g) and any noise proportional to the
//! signal. Rounding (1/12 DN²) and fixed-pattern noise count as noise, as they should
//! for a single exposure.

use crate::capture::FrameData;

/// EMVA noise model of one sensor: variance σ_r² + K·s + (p·s)² in DN².
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct NoiseModel {
    /// Read noise (and rounding), DN.
    pub read_dn: f64,
    /// System gain: shot-noise variance per DN of signal, DN/e⁻.
    pub k_dn_per_e: f64,
    /// Multiplicative noise (PRNU): standard deviation per unit signal, 1.
    pub prnu: f64,
}

impl NoiseModel {
    /// Variance in DN² of a sample whose signal above black is `signal_dn`.
    #[inline]
    pub fn variance_dn2(&self, signal_dn: f64) -> f64 {
        let s = signal_dn.max(0.0);
        (self.read_dn * self.read_dn + self.k_dn_per_e * s + (self.prnu * s).powi(2)).max(1e-6)
    }
}

/// Estimates the noise from `frames` (black level `black_dn`, usable DN in
/// (0, `full_scale_dn`)); `None` when too few samples.
pub fn estimate(frames: &[FrameData], black_dn: f64, full_scale_dn: f64) -> Option<NoiseModel> {
    let mut sums = NoiseSums::default();
    for f in frames {
        sums.add(f, black_dn, full_scale_dn);
    }
    sums.model(full_scale_dn)
}

/// The sums of the photon-transfer fit, frame by frame: a capture's frames need not
/// be in memory together (`fit::frames` adds each as it reads it).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoiseSums {
    /// For y = a + b·s + c·s²: n, Σs, Σs², Σs³, Σs⁴, Σy, Σsy, Σs²y.
    acc: [f64; 8],
}

impl NoiseSums {
    /// Adds every usable second difference of `frame`.
    pub fn add(&mut self, frame: &FrameData, black_dn: f64, full_scale_dn: f64) {
        let acc = &mut self.acc;
        let mut add = |plane: &[f32], w: usize, h: usize| {
            for v in 0..h {
                let row = &plane[v * w..][..w];
                for u in 2..w.saturating_sub(2) {
                    let (l, c, r) = (row[u - 2] as f64, row[u] as f64, row[u + 2] as f64);
                    let ok = |x: f64| x > 0.0 && x < full_scale_dn;
                    if !(ok(l) && ok(c) && ok(r)) {
                        continue;
                    }
                    let d = c - 0.5 * (l + r);
                    let (s, y) = (c - black_dn, d * d / 1.5);
                    // In units of the full scale (a well-conditioned quadratic).
                    let s = s / full_scale_dn;
                    let s2 = s * s;
                    for (a, x) in acc.iter_mut().zip([1.0, s, s2, s2 * s, s2 * s2, y, s * y, s2 * y]) {
                        *a += x;
                    }
                }
            }
        };
        match frame {
            FrameData::Mosaic { width_px, height_px, dn } => add(dn, *width_px as usize, *height_px as usize),
            FrameData::Colocated { width_px, height_px, channels } => {
                for (_, p) in channels {
                    add(p, *width_px as usize, *height_px as usize);
                }
            }
        }
    }

    /// Adds the sums of other frames.
    pub fn merge(&mut self, o: &NoiseSums) {
        self.acc.iter_mut().zip(o.acc).for_each(|(a, b)| *a += b);
    }

    /// The noise model of the sums; `None` when too few samples.
    pub fn model(&self, full_scale_dn: f64) -> Option<NoiseModel> {
        let [n, s, s2, s3, s4, y, sy, s2y] = self.acc;
        if n < 100.0 {
            return None;
        }
        // The quadratic (normal equations), or the line where it curves down.
        let normal = nalgebra::Matrix3::new(n, s, s2, s, s2, s3, s2, s3, s4);
        let quad = nalgebra::Cholesky::new(normal)
            .map(|l| l.solve(&nalgebra::Vector3::new(y, sy, s2y)))
            .filter(|x| x[2] >= 0.0 && x.iter().all(|v| v.is_finite()));
        let (a, b, c) = match quad {
            Some(x) => (x[0], x[1], x[2]),
            None => {
                let det = n * s2 - s * s;
                if det > 0.0 {
                    ((s2 * y - s * sy) / det, (n * sy - s * y) / det, 0.0)
                } else {
                    (y / n, 0.0, 0.0)
                }
            }
        };
        let (b, c) = (b / full_scale_dn, c / (full_scale_dn * full_scale_dn));
        Some(NoiseModel { read_dn: a.max(1.0 / 12.0).sqrt(), k_dn_per_e: b.max(0.0), prnu: c.sqrt() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::{stream, FrameKey};

    #[test]
    fn recovers_read_and_shot_noise_of_a_smooth_frame() {
        let (w, h) = (400, 200);
        let key = FrameKey::new(3, 0, 0);
        let dn: Vec<f32> = (0..w * h)
            .map(|p| {
                let s = 5.0 + 2.0 * (p % w) as f64; // a smooth ramp from near black
                let var = 2.0 * 2.0 + 0.2 * s;
                (100.0 + s + var.sqrt() * key.normal(p as u32, 0, stream::TEMPORAL)) as f32
            })
            .collect();
        let m = estimate(&[FrameData::Mosaic { width_px: w as u32, height_px: h as u32, dn }], 100.0, 4095.0).unwrap();
        assert!((m.k_dn_per_e - 0.2).abs() < 0.02, "{m:?}");
        assert!((m.read_dn - 2.0).abs() < 0.5, "{m:?}");
        assert!(m.prnu < 0.003, "{m:?}");
    }

    #[test]
    fn recovers_multiplicative_noise() {
        let (w, h) = (400, 200);
        let key = FrameKey::new(4, 0, 0);
        let dn: Vec<f32> = (0..w * h)
            .map(|p| {
                let s = 5.0 + 6.0 * (p % w) as f64; // up to 2400 DN
                let var = 1.0 + 0.1 * s + (0.01 * s) * (0.01 * s);
                (64.0 + s + var.sqrt() * key.normal(p as u32, 0, stream::TEMPORAL)) as f32
            })
            .collect();
        let m = estimate(&[FrameData::Mosaic { width_px: w as u32, height_px: h as u32, dn }], 64.0, 4095.0).unwrap();
        assert!((m.prnu - 0.01).abs() < 0.001, "{m:?}");
        assert!((m.k_dn_per_e - 0.1).abs() < 0.03, "{m:?}");
    }
}
