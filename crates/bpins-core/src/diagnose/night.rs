//! The diagnosis by moonlight: which source lit the sky, and what its photons allow the
//! search to see (issue 48 item 5).
//!
//! ```text
//! σ_α  = AoP residual RMS of one sample (superpixel), rad      at the noise: σ_α ≈ σ_P/(2P)
//! snr  = P/σ_P ≈ 1/(2σ_α)                                      one sample's polarized signal/noise
//! m    = samples/4                                              AoP samples (4 analyzer values each)
//! w    = n_eff/samples                                          correlated residuals count for less
//! Δχ²(δ) ≈ m·(δ/σ_α)²                                           a uniform AoP change δ
//! ΔBIC = Δχ²·w − ln n_eff > BIC_THRESHOLD  ⇒  δ_min = σ_α·√((BIC_THRESHOLD + ln n_eff)/(m·w))
//! s̄    = ⟨DN − black⟩,  snr_px = s̄/σ(s̄),  e⁻_eq = snr_px²      a pixel's level, its signal/noise, and the
//!                                                               electrons of shot noise alone that give it
//! ```
//!
//! The same for the DoLP with its residual RMS. δ_min is the smallest change, spread
//! evenly over the sky in view, that would pass the evidence threshold one effect must
//! pass ([`super::BIC_THRESHOLD`], one constrained parameter); an effect concentrated
//! in part of the frame, or trading against the sky's nuisances, needs more. It is the
//! reach of the capture, not of an effect: where nothing is named, an effect below it
//! is beyond reach, and the diagnosis says so with these numbers instead of "nothing
//! structured remains" alone.
//!
//! Where one sample's polarized signal is below its noise (snr < 1: the AoP residual is
//! near a uniform angle's 52°), σ_α saturates and δ_min is a lower bound.
//!
//! Units: degrees (AoP), 1 (DoLP), e⁻. Frame: none. Cannot: tell what hides below the
//! reach; a day capture carries no such record (the reach is not computed by day), so its
//! diagnosis and diagnosis.json are unchanged.

use super::{Diagnosis, BIC_THRESHOLD};
use crate::capture::Capture;
use crate::fit::{FitFrames, FitResult};
use crate::sensor::Layout;
use crate::sky::sun::SunSource;

/// Below this polarized signal/noise of one sample, a sample's AoP is close to a uniform
/// angle: the search barely sees the sky's pattern, and the reach is a lower bound.
pub const MIN_SAMPLE_SNR: f64 = 1.0;

/// The moonlit capture's light and the diagnosis's reach.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Night {
    /// The source that lit the sky, as every reader names it (the first moonlit frame's).
    pub source: String,
    /// Frames lit by the moon, of all.
    pub moonlit_frames: usize,
    pub frames: usize,
    /// A pixel's mean level above black over the pixels the fit read, DN.
    pub level_dn: f64,
    /// Its signal/noise (σ from the fit's photon-transfer noise model), and the
    /// electrons that give it with shot noise alone (snr²: fewer than the pixel holds
    /// where read noise counts; read noise and the shot noise cannot be told apart at a
    /// level of a few DN, their sum can).
    pub pixel_snr: f64,
    pub equivalent_electrons_per_px: f64,
    /// One sample's polarized signal/noise, 1/(2σ_α) (module doc).
    pub sample_snr: f64,
    /// AoP samples the fit read, over all frames.
    pub aop_samples: usize,
    /// Smallest even AoP change (RMS, degrees) and DoLP change the evidence threshold
    /// lets the search see at this signal.
    pub aop_reach_deg: f64,
    pub dolp_reach: f64,
    /// Nothing was named or detected and nothing unexplained remains: whatever the
    /// capture hides below the reach is beyond it.
    pub beyond_reach: bool,
}

impl Night {
    /// The record of a capture any of whose frames the moon lit; `None` by day (or a
    /// capture whose source is given, not read from its time and place).
    pub fn of(c: &Capture, frames: &FitFrames, fit: &FitResult, d: &Diagnosis) -> Option<Night> {
        let moonlit: Vec<&SunSource> =
            c.frames.iter().map(|f| &f.sun.source).filter(|s| matches!(s, SunSource::Moon { .. })).collect();
        let first = moonlit.first()?;
        let level_dn = mean_level_dn(c, frames);
        let pixel_snr = level_dn.max(0.0) / fit.noise.variance_dn2(level_dn).sqrt();
        let sigma_aop_rad = fit.aop_rms_deg.to_radians();
        let m = fit.samples / 4;
        let t = reach_factor(fit.samples, fit.n_eff);
        let nothing_named =
            d.selected.is_empty() && d.negligible.is_empty() && d.confusable.is_empty() && !d.unexplained();
        Some(Night {
            source: first.describe(),
            moonlit_frames: moonlit.len(),
            frames: c.frames.len(),
            level_dn,
            pixel_snr,
            equivalent_electrons_per_px: pixel_snr * pixel_snr,
            sample_snr: if sigma_aop_rad > 0.0 { 0.5 / sigma_aop_rad } else { f64::INFINITY },
            aop_samples: m,
            aop_reach_deg: fit.aop_rms_deg * t,
            dolp_reach: fit.dolp_rms * t,
            beyond_reach: nothing_named,
        })
    }
}

/// The mean DN above black of every sample the fit reads, all frames.
fn mean_level_dn(c: &Capture, frames: &FitFrames) -> f64 {
    let nq = match &c.sensor.layout {
        Layout::Dofp { .. } => 1,
        Layout::Colocated { channels } => channels.len(),
    };
    let (mut sum, mut n) = (0.0, 0usize);
    for k in 0..frames.len() {
        for r in frames.rects(k) {
            for (u, v) in r.points(1) {
                for q in 0..nq {
                    sum += frames.value(k, u, v, q) as f64;
                    n += 1;
                }
            }
        }
    }
    sum / n.max(1) as f64 - c.sensor.black_level_dn
}

/// δ_min/σ of one sample (module doc): √((BIC_THRESHOLD + ln n_eff)/(m·w)), m = samples/4
/// AoP samples, w = n_eff/samples.
fn reach_factor(samples: usize, n_eff: f64) -> f64 {
    let m = (samples / 4).max(1) as f64;
    let w = if samples > 0 { (n_eff / samples as f64).clamp(1e-9, 1.0) } else { 1.0 };
    ((BIC_THRESHOLD + n_eff.max(1.0).ln()) / (m * w)).sqrt()
}

impl std::fmt::Display for Night {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let signal = format!(
            "{:.1} DN per pixel at signal/noise {:.1}, as from {:.0} e⁻ of shot noise alone; polarized signal/noise \
             {:.2} per sample over {} samples",
            self.level_dn, self.pixel_snr, self.equivalent_electrons_per_px, self.sample_snr, self.aop_samples
        );
        let bound = if self.sample_snr < MIN_SAMPLE_SNR { " (a lower bound)" } else { "" };
        let reach = format!("{:.2}° RMS and the DoLP by {:.4}{bound}", self.aop_reach_deg, self.dolp_reach);
        if self.beyond_reach {
            write!(
                f,
                "By moonlight: beyond reach at this signal ({signal}): an effect that changes the AoP by less \
                 than {reach} would not pass the evidence threshold; nothing named is not evidence of no effect."
            )?;
        } else {
            write!(
                f,
                "By moonlight ({signal}): the smallest change this signal shows moves the \
                 AoP by about {reach}."
            )?;
        }
        if self.sample_snr < MIN_SAMPLE_SNR {
            write!(f, " One sample's polarized signal is below its noise: the sky's pattern itself is barely seen.")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn night(snr: f64, beyond: bool) -> Night {
        Night {
            source: "the moon".into(),
            moonlit_frames: 4,
            frames: 4,
            level_dn: 42.0,
            pixel_snr: 10.2,
            equivalent_electrons_per_px: 104.0,
            sample_snr: snr,
            aop_samples: 65_536,
            aop_reach_deg: 0.21,
            dolp_reach: 0.0012,
            beyond_reach: beyond,
        }
    }

    #[test]
    fn the_sentence_says_beyond_reach_with_the_numbers_only_where_nothing_was_named() {
        let s = night(3.2, true).to_string();
        assert!(
            s.starts_with(
                "By moonlight: beyond reach at this signal (42.0 DN per pixel at signal/noise 10.2, as from 104 e⁻"
            ),
            "{s}"
        );
        assert!(s.contains("changes the AoP by less than 0.21° RMS and the DoLP by 0.0012 would not pass"), "{s}");
        let s = night(3.2, false).to_string();
        assert!(!s.contains("beyond reach") && s.contains("AoP by about 0.21° RMS"), "{s}");
        let s = night(0.4, true).to_string();
        assert!(s.contains("the DoLP by 0.0012 (a lower bound)") && s.contains("below its noise"), "{s}");
    }

    #[test]
    fn the_reach_shrinks_as_the_square_root_of_the_effective_samples() {
        // Four times the samples (white residuals): about half the reach (ln n grows too).
        let n = 65_536;
        let r = reach_factor(4 * n, 4.0 * n as f64) / reach_factor(n, n as f64);
        assert!((0.5..0.55).contains(&r), "{r}");
        // 256 × 256 samples, white: √((10 + ln 65 536)/16 384) = 0.0359.
        assert!((reach_factor(n, n as f64) - 0.0359).abs() < 1e-4, "{}", reach_factor(n, n as f64));
        // Residuals correlated (n_eff a quarter): twice the reach, less the log's change.
        let r = reach_factor(n, n as f64 / 4.0) / reach_factor(n, n as f64);
        assert!((1.8..2.0).contains(&r), "{r}");
    }
}
