//! The evidence a candidate's figures rest on ([`Evidence`]), and the two tests every
//! step puts them to, each written once here: ΔBIC and a score beyond its noise.
//!
//! ```text
//! ΔBIC = Δχ²·w − k·ln n_e                every pixel: w = n_eff/n, n_e = n_eff
//!                                        a subsample of n_s samples: w = n_eff/n, n_e = max(2, w·n_s)
//!                                        projected from it: w = (n_eff/n)·(n/n_s), n_e = n_eff
//! beyond the noise: Δχ²_score > k + 3·√(2k)    (k ≥ 1; under the null the score is χ²_k)
//! ```
//!
//! k: the combinations of a candidate's parameters the data constrain beside the model's;
//! n the samples of the model it adds to and n_eff their effective count
//! (`fit::uncertainty::correlation`: residuals correlated between neighbours carry n_eff/n
//! of their count, the same factor for every candidate of a step). Units: none.

use crate::fit::FitResult;

/// How far a candidate of a step was taken, which says what its figures (`delta_chi2`,
/// `delta_bic`, `params`) are: a prediction on the scoring subsample, a refit ranked
/// there, or every-pixel figures — its score test's there where that bounds it below the
/// threshold, else a refit converged on every pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Evidence {
    /// Its score test on the scoring subsample (every third row and column, 1/9 of the
    /// pixels): the Δχ² one Gauss–Newton step predicts; not refitted.
    #[default]
    Score,
    /// Refitted on the scoring subsample and ranked there, clearly behind the leader
    /// (its figures on the subsample's scale).
    SubsampleRefit,
    /// Refitted on the subsample, then scored on every pixel, where it stays below the
    /// threshold even at twice that one-step Δχ² (`diagnose::refits`): every-pixel
    /// figures from the score test, not converged.
    EveryPixelScore,
    /// Converged on every pixel (the leader of its step and any close to it): the figures
    /// every acceptance is decided on.
    EveryPixelRefit,
}

impl Evidence {
    /// Whether it was refitted (on the subsample at least).
    pub fn refitted(self) -> bool {
        self != Evidence::Score
    }

    /// Whether its figures are from every pixel.
    pub fn every_pixel(self) -> bool {
        matches!(self, Evidence::EveryPixelScore | Evidence::EveryPixelRefit)
    }

    /// Whether it was converged on every pixel.
    pub fn converged(self) -> bool {
        self == Evidence::EveryPixelRefit
    }

    /// The order in which a step's candidates are ranked: every pixel first, then
    /// refitted on the subsample, then scored.
    pub(crate) fn tier(self) -> u8 {
        match self {
            Evidence::Score => 0,
            Evidence::SubsampleRefit => 1,
            Evidence::EveryPixelScore | Evidence::EveryPixelRefit => 2,
        }
    }
}

/// ΔBIC of a refit that lowered χ² by `delta_chi2` with `k` more constrained
/// combinations, each Δχ² counted at `weight` of itself and each combination paying
/// ln `n_eff` (module doc). The one formula every ΔBIC of a diagnosis is.
pub(crate) fn delta_bic(delta_chi2: f64, k: usize, weight: f64, n_eff: f64) -> f64 {
    delta_chi2 * weight - k as f64 * n_eff.ln()
}

/// Whether a score (the Δχ² one Gauss–Newton step predicts) is beyond its noise: more
/// than 3σ above its null distribution χ²_k (mean k, σ √(2k)), k at least 1. Only such a
/// candidate is refitted, and only such a score shows an effect to size.
pub(crate) fn beyond_noise(score: f64, k: usize) -> bool {
    let k = k.max(1) as f64;
    score > k + 3.0 * (2.0 * k).sqrt()
}

/// The share of its count one Δχ² carries against a model: f = n_eff/n of the model's
/// every-pixel residual, and n_eff (n_eff clamped to [2, n]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Share {
    pub f: f64,
    pub n_eff: f64,
}

impl Share {
    /// The share of `base`, the model a step adds to.
    pub fn of(base: &FitResult) -> Share {
        let n = base.samples.max(2) as f64;
        let n_eff = base.n_eff.clamp(2.0, n);
        Share { f: n_eff / n, n_eff }
    }

    /// ΔBIC on every pixel.
    pub fn delta_bic(&self, delta_chi2: f64, k: usize) -> f64 {
        delta_bic(delta_chi2, k, self.f, self.n_eff)
    }

    /// ΔBIC on a subsample of `samples` samples (the score's scale): the subsample's
    /// share of the model's effective count.
    pub fn sub_delta_bic(&self, delta_chi2: f64, k: usize, samples: f64) -> f64 {
        delta_bic(delta_chi2, k, self.f, (self.f * samples).max(2.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_score_is_beyond_its_noise_only_3_sigma_above_chi2_k() {
        // k = 1: 1 + 3√2 = 5.24; k = 2: 2 + 6 = 8; k = 0 counts as 1.
        assert!(!beyond_noise(5.2, 1) && beyond_noise(5.3, 1));
        assert!(!beyond_noise(8.0, 2) && beyond_noise(8.01, 2));
        assert_eq!(beyond_noise(5.3, 0), beyond_noise(5.3, 1));
        assert!(!beyond_noise(f64::NAN, 1));
    }

    #[test]
    fn every_delta_bic_is_one_formula_at_its_share() {
        let base = FitResult { samples: 1_000_000, n_eff: 250_000.0, ..Default::default() };
        let s = Share::of(&base);
        assert_eq!(s, Share { f: 0.25, n_eff: 250_000.0 });
        assert!((s.delta_bic(400.0, 2) - (100.0 - 2.0 * 250_000f64.ln())).abs() < 1e-9);
        // On a subsample of 1/9 of the samples: a quarter of its count.
        let sub = s.sub_delta_bic(400.0, 2, 111_111.0);
        assert!((sub - (100.0 - 2.0 * (0.25f64 * 111_111.0).ln())).abs() < 1e-9, "{sub}");
        // A degenerate base (no samples, no n_eff) still counts two.
        let s = Share::of(&FitResult::default());
        assert_eq!(s, Share { f: 1.0, n_eff: 2.0 });
    }

    #[test]
    fn the_evidence_ranks_every_pixel_first() {
        use Evidence::*;
        assert!(EveryPixelRefit.tier() == EveryPixelScore.tier());
        assert!(EveryPixelScore.tier() > SubsampleRefit.tier() && SubsampleRefit.tier() > Score.tier());
        assert!(!Score.refitted() && SubsampleRefit.refitted() && !SubsampleRefit.every_pixel());
        assert!(EveryPixelScore.every_pixel() && !EveryPixelScore.converged() && EveryPixelRefit.converged());
        assert_eq!(serde_json::to_string(&EveryPixelScore).unwrap(), "\"every_pixel_score\"");
    }
}
