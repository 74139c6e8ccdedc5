//! A frame too dark to tell: its polarized signal against its noise, and the refusal
//! ([`NoHeading::TooDark`]) where the signal does not stand above it.
//!
//! ```text
//! σ_i²  = 4·P̂_i²·σ_α,i²  = (U² var Q + Q² var U)/P̂²          cell i's noise across P̂, DN²
//! S²    = max(Σ (P̂_i² − 2σ_i²), 0) / n                       polarized signal², bias removed
//! N²    = Σ σ_i² / n                                         noise² per cell
//! snr   = S / N
//! refuse: snr < 1 before the fit; snr < 3 where the fit then fails (ambiguous, too
//!         little sky, a misfit, a contradiction): the failure is the dark's
//! ```
//!
//! P̂² = Q̂² + Û² of a cell's mean overstates P² by var Q + var U (a Rice bias): a
//! frame of pure noise shows a DoLP of about σ/I everywhere, which is why the bias is
//! taken out before the ratio. The cells are the estimator's own (`cells.rs`: their
//! noise measured from their pixels' scatter), so the threshold moves with the cell
//! size as the estimator's information does. Below snr 1 a cell's angle is uniform
//! noise; between 1 and 3 (a cell's AoP to ±10–30°) the estimator can still find the
//! sky on many cells, and it is its own failure that says it did not.
//! Units: DN above black. Frame: none (magnitudes only). Cannot: tell a dark frame
//! from an unpolarized one (fog, a thick overcast at night): both have no polarized
//! signal, and both are refused as too dark when it sinks below their noise.

use super::observe::Obs;
use super::NoHeading;

/// Below this the frame is refused before the fit.
const MIN_SNR: f64 = 1.0;
/// Below this a failed fit is named for the dark.
const DIM_SNR: f64 = 3.0;

/// A frame's polarized signal and noise per cell, DN.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Polarized {
    pub(super) signal_dn: f64,
    pub(super) noise_dn: f64,
}

impl Polarized {
    /// Of the observed cells (module doc).
    pub(super) fn of(obs: &[Obs]) -> Polarized {
        let (mut p2, mut s2) = (0.0, 0.0);
        for o in obs {
            let p = o.dolp * o.ln_i.exp();
            let var = 4.0 * p * p * o.var_aop;
            p2 += p * p;
            s2 += var;
        }
        let n = obs.len().max(1) as f64;
        Polarized { signal_dn: ((p2 - 2.0 * s2).max(0.0) / n).sqrt(), noise_dn: (s2 / n).sqrt() }
    }

    pub(super) fn snr(&self) -> f64 {
        if self.noise_dn > 0.0 {
            self.signal_dn / self.noise_dn
        } else {
            f64::INFINITY
        }
    }

    fn refusal(&self) -> NoHeading {
        NoHeading::TooDark { signal_dn: self.signal_dn, noise_dn: self.noise_dn, snr: self.snr() }
    }

    /// The refusal where the signal is below the noise.
    pub(super) fn too_dark(&self) -> Option<NoHeading> {
        (self.snr() < MIN_SNR).then(|| self.refusal())
    }

    /// `why` a dim frame's fit failed, named for the dark where the signal stood less
    /// than [`DIM_SNR`] above the noise; other reasons (the sun's place) unchanged.
    pub(super) fn explain(&self, why: NoHeading) -> NoHeading {
        let fit_failed = matches!(
            why,
            NoHeading::Ambiguous { .. }
                | NoHeading::TooLittleSky { .. }
                | NoHeading::PoorFit { .. }
                | NoHeading::Contradicts { .. }
        );
        if fit_failed && self.snr() < DIM_SNR {
            self.refusal()
        } else {
            why
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn obs(i: f64, dolp: f64, sigma_dn: f64) -> Obs {
        let p = i * dolp;
        Obs {
            d: DVec3::Z,
            e: DVec3::X,
            dolp,
            ln_i: i.ln(),
            tint: f64::NAN,
            var_aop: sigma_dn * sigma_dn / (4.0 * p * p),
            block: 0,
            grid: 0,
            ep: 1.0,
            es: 0.0,
            cos2b: 1.0,
            sin2b: 0.0,
        }
    }

    #[test]
    fn the_bias_is_taken_out_and_the_ratio_refuses_below_one() {
        // P̂ = 10 DN, σ = 2 DN: S = √(100 − 8) = 9.59, N = 2.
        let p = Polarized::of(&[obs(100.0, 0.1, 2.0); 5]);
        assert!((p.signal_dn - 92f64.sqrt()).abs() < 1e-9 && (p.noise_dn - 2.0).abs() < 1e-9, "{p:?}");
        assert!(p.too_dark().is_none());
        // Pure noise: P̂² ≈ 2σ² on average, so S ≈ 0.
        let noise = Polarized::of(&[obs(10.0, 2f64.sqrt() * 0.1, 1.0); 5]);
        assert!(noise.signal_dn < 1e-6, "{noise:?}");
        let why = noise.too_dark().expect("refused").to_string();
        assert!(why.starts_with("too dark: the polarized signal is below the noise"), "{why}");
    }

    #[test]
    fn a_dim_frame_s_failed_fit_is_named_for_the_dark_and_a_bright_one_s_is_not() {
        let amb = NoHeading::Ambiguous { best_deg: 1.0, other_deg: 180.0 };
        let dim = Polarized { signal_dn: 2.0, noise_dn: 1.0 };
        assert!(matches!(dim.explain(amb.clone()), NoHeading::TooDark { .. }));
        assert!(matches!(dim.explain(NoHeading::SunTooLow { sun_el_deg: -12.0 }), NoHeading::SunTooLow { .. }));
        let bright = Polarized { signal_dn: 40.0, noise_dn: 1.0 };
        assert_eq!(bright.explain(amb.clone()), amb);
    }
}
