//! Confusable pairs: two candidates that explain the same Δχ² within the noise of
//! their difference. Neither is named alone; the pair is reported with what would
//! separate them.
//!
//! ```text
//! confusable: |ΔBIC_a − ΔBIC_b| < BIC_THRESHOLD
//!          or f·|Δχ²_a − Δχ²_b| < 2·(√(f·Δχ²_a) + √(f·Δχ²_b))     f = n_eff/n of the model they add to
//! ```
//!
//! 2√Δχ² is the 1σ of a refit's Δχ² from the noise (the cross term of its signal with
//! the noise: `refits`), on the effective-sample scale f (correlated residuals carry
//! n_eff/n of their count); the sum of the two 1σ bounds the difference's 1σ however
//! the two refits' noise is correlated. Units: χ² and ΔBIC have none.

use crate::diagnose::{Candidate, BIC_THRESHOLD};
use crate::effects::{find, Stage};

/// A pair the data cannot tell apart, with what would.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Confusable {
    /// The better of the two by ΔBIC (added to the model, not named).
    pub first: &'static str,
    pub second: &'static str,
    /// What separates them, in words.
    pub separates: String,
}

/// Whether `a` and `b` (each refitted on every pixel) explain the same Δχ² within the
/// noise of their difference (module doc); `f` = n_eff/n of the model they add to.
pub fn confusable(a: &Candidate, b: &Candidate, f: f64) -> bool {
    let f = f.clamp(0.0, 1.0);
    let noise = 2.0 * ((f * a.delta_chi2.max(0.0)).sqrt() + (f * b.delta_chi2.max(0.0)).sqrt());
    (a.delta_bic - b.delta_bic).abs() < BIC_THRESHOLD || f * (a.delta_chi2 - b.delta_chi2).abs() < noise
}

/// What measures an effect of `stage` apart from the sky.
fn measured_by(stage: Stage) -> &'static str {
    match stage {
        Stage::Geometry => {
            "frames tilted or a wider field (the sky's pattern moves across the image, the lens's does not)"
        }
        Stage::Sky => "frames at another sun elevation (the sky's pattern moves with the sun, the camera's stays)",
        Stage::Lens => "a lab capture through a polarizer across the field (`bpins calibrate`)",
        Stage::Analyzer | Stage::Sensor => "a lab capture through a rotating polarizer (`bpins calibrate`)",
    }
}

impl Confusable {
    pub fn new(first: &'static str, second: &'static str) -> Confusable {
        let stage = |e: &str| find(e).map(|d| d.stage).ok();
        let separates = match (stage(first), stage(second)) {
            (Some(a), Some(b)) if a == b => format!(
                "both act at the {} stage; {} measures them, or fit both together with a capture that moves one \
                 and not the other",
                a.name(),
                measured_by(a)
            ),
            (Some(a), Some(b)) => format!(
                "{first} ({} stage): {}; {second} ({} stage): {}",
                a.name(),
                measured_by(a),
                b.name(),
                measured_by(b)
            ),
            _ => "a capture that moves one and not the other".to_string(),
        };
        Confusable { first, second, separates }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(effect: &'static str, delta_chi2: f64, delta_bic: f64) -> Candidate {
        Candidate {
            effect,
            score: delta_chi2,
            delta_chi2,
            delta_bic,
            refitted: true,
            every_pixel: true,
            bounded: false,
            identifiable: true,
            added_rank: 1,
            params: Vec::new(),
            size: None,
            outside_physical: Vec::new(),
        }
    }

    #[test]
    fn the_issues_clean_sky_pair_is_confusable_and_a_clear_lead_is_not() {
        // Issue 31: 21 822 against 21 805 at f = 0.01 — 0.17 apart, noise ≈ 5.9.
        let (a, b) = (cand("sky_dolp_shape", 21822.0, 200.0), cand("sensor_nonlinearity", 21805.0, 180.0));
        assert!(confusable(&a, &b, 0.01));
        // A typical effect 10 % ahead of its runner-up at 10⁶: 10⁵·f = 1000 against ≈ 39.
        let (a, b) = (cand("analyzer_angles", 1e6, 9000.0), cand("window", 0.9e6, 8000.0));
        assert!(!confusable(&a, &b, 0.01));
    }

    #[test]
    fn a_pair_says_what_separates_it() {
        let p = Confusable::new("sky_dolp_shape", "sensor_nonlinearity");
        assert!(
            p.separates.contains("another sun elevation") && p.separates.contains("bpins calibrate"),
            "{}",
            p.separates
        );
    }
}
