//! Confusable pairs: two candidates that explain the same Δχ² within the noise of
//! their difference. Neither is named alone; the pair is reported with what would
//! separate them.
//!
//! ```text
//! D = max(0, f·|Δχ²_a − Δχ²_b| − |k_a − k_b|)   f = n_eff/n of the model they add to
//! confusable: |ΔBIC_a − ΔBIC_b| < BIC_THRESHOLD + 2·(2√D)
//! ```
//!
//! Two refits of the same data share their noise: the difference of their Δχ² moves
//! with the noise only through the part of the signal on which they differ, whose
//! power is about D (one refit's fitted signal nearly holding the other's), so its 1σ
//! is 2√D (the cross term of that part with the noise, on the effective-sample scale:
//! correlated residuals carry n_eff/n of their count). The |k_a − k_b| taken off is
//! what the extra parameters of a refit that holds the other gain from noise alone
//! (χ² with that many degrees of freedom: no signal they differ on). Within 2σ of that
//! beyond the ΔBIC threshold, the data cannot say which. ΔBIC, not Δχ², is compared: an effect
//! with fewer parameters that explains as much (a rotation of the whole analyzer
//! array against four analyzer angles) is the simpler explanation, not a tie. Units:
//! χ² and ΔBIC have none.

use crate::diagnose::{Candidate, BIC_THRESHOLD};
use crate::effects::{find, SkyBlindness, Stage};

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
    let dk = a.added_rank.abs_diff(b.added_rank) as f64;
    let d = (f.clamp(0.0, 1.0) * (a.delta_chi2 - b.delta_chi2).abs() - dk).max(0.0);
    (a.delta_bic - b.delta_bic).abs() < BIC_THRESHOLD + 2.0 * 2.0 * d.sqrt()
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

/// What separates two effects on a colour sensor's bands alone (`sky_spectrum`,
/// `band_response`): a band's d_max factor f_b and its analyzers' ε_b are one number on
/// any sky, I_k = ½(1 + ε_b)[I + (1 − ε_b)/(1 + ε_b)·(Q cos 2θ_k + U sin 2θ_k)] (the
/// level's (1 + ε_b) taken by a band gain), at every pixel and every sun.
const BANDS_APART: &str = "both act on one colour band alike at every pixel of any sky (a band's sky d_max \
     factor and its analyzers' ε scale its modulation alike, a band's sky radiance and its response its level); a lab \
     capture of the colour sensor through a rotating polarizer measures the sensor's part (band_response), or a sky \
     of known spectrum and polarization the sky's (sky_spectrum)";

impl Confusable {
    pub fn new(first: &'static str, second: &'static str) -> Confusable {
        let stage = |e: &str| find(e).map(|d| d.stage).ok();
        let band_only =
            |e: &str| find(e).is_ok_and(|d| d.inseparable.is_some_and(|i| i.when == SkyBlindness::Monochrome));
        if band_only(first) && band_only(second) {
            return Confusable { first, second, separates: BANDS_APART.to_string() };
        }
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
        cand_k(effect, delta_chi2, delta_bic, 1)
    }

    fn cand_k(effect: &'static str, delta_chi2: f64, delta_bic: f64, added_rank: usize) -> Candidate {
        Candidate {
            effect,
            score: delta_chi2,
            delta_chi2,
            delta_bic,
            evidence: crate::diagnose::Evidence::EveryPixelRefit,
            identifiable: true,
            added_rank,
            params: Vec::new(),
            size: None,
            outside_physical: Vec::new(),
        }
    }

    #[test]
    fn the_issues_clean_sky_pair_is_confusable_and_a_clear_lead_is_not() {
        // Issue 31: 21 822 against 21 805 on a white residual (f = 1), the same k:
        // ΔBIC 17 apart, within 10 + 4√17 = 26.5.
        let (a, b) = (cand("sky_dolp_shape", 21822.0, 21807.0), cand("sensor_nonlinearity", 21805.0, 21790.0));
        assert!(confusable(&a, &b, 1.0));
        // A typical effect 10 % ahead of its runner-up at 10⁶ (f = 0.01): 1000 apart
        // against 10 + 4√1000 = 136.
        let (a, b) = (cand("analyzer_angles", 1e6, 9000.0), cand("window", 0.9e6, 8000.0));
        assert!(!confusable(&a, &b, 0.01));
        // The same Δχ² with three more parameters (ln n_eff ≈ 14.7 each), which gain
        // 3 from noise: the simpler one.
        let (a, b) = (cand("array_rotation", 58000.0, 57985.0), cand_k("analyzer_angles", 58003.0, 57959.0, 4));
        assert!(!confusable(&a, &b, 1.0));
        // Two more gaining 6 (noise: 2): 23.4 ΔBIC apart against 10 + 4√4 = 18.
        let (a, b) =
            (cand("sky_depolarization", 1e6, 1e6 - 14.7), cand_k("extinction_ratio", 1e6 + 6.0, 1e6 + 6.0 - 44.1, 3));
        assert!(!confusable(&a, &b, 1.0));
    }

    #[test]
    fn a_colour_band_pair_says_no_sky_separates_it() {
        let p = Confusable::new("sky_spectrum", "band_response");
        assert!(p.separates.contains("any sky") && !p.separates.contains("sun elevation"), "{}", p.separates);
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
