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
//!
//! The level s is read from the centre pixel, whose own noise is in d: binned by it, d²
//! is biased up at both ends of the levels (E[d²|c] = n_c² + σ²/2), a curvature the
//! quadratic takes as PRNU. By day the levels spread over hundreds of times the noise and
//! the bias vanishes; by moonlight (tens of electrons, the levels within a few σ of each
//! other) it made K = 0 and p = 0.15 of a frame with K = 0.38 DN/e⁻ and no PRNU, the
//! noise 4.6 × the truth in variance (χ²/dof 0.21), and the diagnosis blind. So the sums
//! are also kept against the three pixels' mean s̄ = (l + c + r)/3 − black, uncorrelated
//! with d (cov(c − ½(l + r), l + c + r) = σ² − ½σ² − ½σ² = 0), and used where the
//! noise is more than [`LEVEL_NOISE_SHARE`] of the levels' variance; below it the
//! centre's sums are kept (every day capture's model bit for bit as before).

use crate::capture::FrameData;

/// The noise variance, as a share of the variance of the levels, above which the level
/// is read from the three pixels' mean (module doc). By day it is ~10⁻³ or less.
pub const LEVEL_NOISE_SHARE: f64 = 0.01;

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
    /// For y = a + b·s + c·s²: n, Σs, Σs², Σs³, Σs⁴, Σy, Σsy, Σs²y, s the centre's level.
    acc: [f64; 8],
    /// The same with s the three pixels' mean level (module doc).
    acc_mean: [f64; 8],
}

impl NoiseSums {
    /// Adds every usable second difference of `frame`.
    pub fn add(&mut self, frame: &FrameData, black_dn: f64, full_scale_dn: f64) {
        let (acc, acc_mean) = (&mut self.acc, &mut self.acc_mean);
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
                    let y = d * d / 1.5;
                    // In units of the full scale (a well-conditioned quadratic).
                    for (acc, s) in [(&mut *acc, c), (&mut *acc_mean, (l + c + r) / 3.0)] {
                        let s = (s - black_dn) / full_scale_dn;
                        let s2 = s * s;
                        for (a, x) in acc.iter_mut().zip([1.0, s, s2, s2 * s, s2 * s2, y, s * y, s2 * y]) {
                            *a += x;
                        }
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

    /// How many second differences the sums hold.
    pub(crate) fn samples(&self) -> f64 {
        self.acc[0]
    }

    /// Adds the sums of other frames.
    pub fn merge(&mut self, o: &NoiseSums) {
        self.acc.iter_mut().zip(o.acc).for_each(|(a, b)| *a += b);
        self.acc_mean.iter_mut().zip(o.acc_mean).for_each(|(a, b)| *a += b);
    }

    /// The noise model of the sums; `None` when too few samples.
    pub fn model(&self, full_scale_dn: f64) -> Option<NoiseModel> {
        let [n, s, s2, _, _, y, _, _] = self.acc;
        if n < 100.0 {
            return None;
        }
        // The noise (mean y) against the spread of the levels, both in full-scale units².
        let levels_var = s2 / n - (s / n) * (s / n);
        let noise_var = y / n / (full_scale_dn * full_scale_dn);
        let acc = if noise_var > LEVEL_NOISE_SHARE * levels_var { self.acc_mean } else { self.acc };
        let [n, s, s2, s3, s4, y, sy, s2y] = acc;
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
    fn a_moonlit_frame_s_noise_is_not_taken_for_prnu() {
        // Tens of electrons, the levels within a few σ of each other: 40 ± 10 DN above
        // black, K = 0.384 DN/e⁻, read noise 0.88 DN, no PRNU (the night capture of
        // docs/night.md at 2 s). Read from the centre pixel the model was K = 0, p = 0.15.
        let (w, h) = (400, 400);
        let key = FrameKey::new(5, 0, 0);
        let dn: Vec<f32> = (0..w * h)
            .map(|p| {
                let s = 30.0 + 20.0 * (p % w) as f64 / w as f64;
                let var = 0.88 * 0.88 + 0.384 * s;
                (64.0 + s + var.sqrt() * key.normal(p as u32, 0, stream::TEMPORAL)).round() as f32
            })
            .collect();
        let m = estimate(&[FrameData::Mosaic { width_px: w as u32, height_px: h as u32, dn }], 64.0, 4095.0).unwrap();
        let var40 = m.variance_dn2(40.0);
        let truth = 0.88 * 0.88 + 0.384 * 40.0 + 1.0 / 12.0;
        assert!((var40 / truth - 1.0).abs() < 0.03, "{m:?}: {var40} DN² at 40 DN, truth {truth}");
        assert!(m.prnu < 0.05, "{m:?}");
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
