//! What remains after a diagnosis, as data — the final χ²/dof against what noise alone
//! gives and, where it is above, where the misfit lies (by channel, by colour band on a
//! colour sensor, by radius, the strongest trends in sky space); and the fitted values of what the search added that
//! no real instrument or sky has — with the English sentence rendered from it.
//!
//! A residual at the noise reached only with such a value is not an explanation: a
//! broad veil of glare over the sensor is brought to the noise by channel offsets of
//! +144 DN (measured, `tests/glare_and_ghost.rs`), which would otherwise read "nothing
//! else structured remains" — and an effect named beside them, at a physical value,
//! as a clean finding. Such a capture is unexplained too ([`Remains::is_unexplained`]),
//! and everything the search named is possibly compensating.

use crate::diagnose::sizes::OutsidePhysical;
use crate::diagnose::{BIC_THRESHOLD, EXCESS_FRACTION};
use crate::fit::output::profiles::{trends, Axis, Profile, ProfileBin, Trend};

/// The residual the final model leaves.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Remains {
    /// χ²/dof of the final model.
    pub chi2_per_dof: f64,
    /// The most noise alone gives: 1 + max(5·√(2/dof), 0.02).
    pub noise_limit: f64,
    /// Present when χ²/dof is above the noise limit and no catalog effect explains it.
    pub unexplained: Option<Unexplained>,
    /// Within the noise: what the model was given to get there — the effects named,
    /// each confusable pair ("a or b") — and the effects detected but negligible.
    pub named: Vec<String>,
    pub negligible: Vec<&'static str>,
    /// The final model's fitted values of the effects the search added that lie
    /// outside their physical range by more than 3σ (`sizes::excluded_physical`): each
    /// value, 1σ and range as numbers, with the words. Where any is, the capture is
    /// unexplained whatever its χ²/dof.
    pub unphysical: Vec<OutsidePhysical>,
    /// Present when the search stopped at its cap (`max_added`) while a candidate not
    /// added still passed its rule for adding one: what the cap left out. Then nothing
    /// says that nothing else remains, and the headings' 1σ carry its shift (`margin`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left_by_cap: Option<LeftByCap>,
}

/// What the search's cap left out: each candidate of the step the cap stopped that
/// passes the rule for adding an effect (converged on every pixel, ΔBIC >
/// [`BIC_THRESHOLD`], removing [`EXCESS_FRACTION`] of the excess χ²; or the best two
/// together).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LeftByCap {
    /// The cap: most effects added (`--max-added`).
    pub max_added: usize,
    pub candidates: Vec<CapCandidate>,
}

/// One candidate the cap left out.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CapCandidate {
    pub effect: &'static str,
    /// Its ΔBIC on every pixel against the final model.
    pub delta_bic: f64,
    /// The worst frame's |heading change| with it added (refitted on every pixel),
    /// degrees: `sizes`' heading change.
    pub heading_shift_deg: f64,
    /// The other effect it passes with, where only the two together remove half the
    /// excess (the shift is then the pair's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub with: Option<&'static str>,
}

impl CapCandidate {
    /// `effect` (passing `with` another, if any) against the final fit `without`, from
    /// the fit `with_it` that adds it: its figures and its heading shift per frame,
    /// degrees (signed, wrapped to ±180°).
    pub(crate) fn of(
        effect: &'static str,
        delta_bic: f64,
        with: Option<&'static str>,
        with_it: &crate::fit::FitResult,
        without: &crate::fit::FitResult,
    ) -> (CapCandidate, Vec<f64>) {
        let h: Vec<f64> = with_it
            .state
            .frames
            .iter()
            .zip(&without.state.frames)
            .map(|(a, b)| crate::conventions::wrap_deg_180(a[0] - b[0]))
            .collect();
        let heading_shift_deg = h.iter().map(|x| x.abs()).fold(0.0, f64::max);
        (CapCandidate { effect, delta_bic, heading_shift_deg, with }, h)
    }
}

impl std::fmt::Display for LeftByCap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let each: Vec<String> = self
            .candidates
            .iter()
            .map(|c| {
                let with = c.with.map_or(String::new(), |w| format!(" together with {w}"));
                format!("{}{with} (ΔBIC {:.0}, moves the heading {:.2}°)", c.effect, c.delta_bic, c.heading_shift_deg)
            })
            .collect();
        let n = self.candidates.len();
        write!(
            f,
            "the search stopped at its cap (--max-added {}) with {} not added, though the data show {} (it passes the \
             rule for adding an effect): the headings' 1σ carry {} shift; raise --max-added to model {}.",
            self.max_added,
            each.join(" or "),
            if n == 1 { "it" } else { "them" },
            if n == 1 { "its" } else { "the largest" },
            if n == 1 { "it" } else { "them" },
        )
    }
}

/// Where an unexplained residual lies.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Unexplained {
    /// Effects the search added, each a partial explanation at most (empty: none).
    pub partial: Vec<&'static str>,
    /// The raw-DN misfit by analyzer channel (bins of [`Axis::Channel`]).
    pub by_channel: Vec<ProfileBin>,
    /// The raw-DN misfit by colour band (bins of [`Axis::ColourBand`]; empty on a
    /// monochrome sensor).
    pub by_band: Vec<ProfileBin>,
    /// The raw-DN misfit by radius from the principal point, focal lengths.
    pub by_radius: Vec<ProfileBin>,
    /// The strongest trend of each residual quantity in sky space.
    pub trends: Vec<Trend>,
}

/// Fewest samples of a profile bin whose mean a trend believes.
const TREND_MIN_SAMPLES: usize = 1000;

impl Remains {
    /// The χ²/dof above which a residual is structured (more than 5σ of χ²'s spread
    /// above 1, at least 2 %).
    pub fn noise_limit(dof: f64) -> f64 {
        1.0 + (5.0 * (2.0 / dof).sqrt()).max(0.02)
    }

    /// An unexplained residual, described from its profiles.
    pub fn unexplained(
        chi2_per_dof: f64,
        noise_limit: f64,
        partial: Vec<&'static str>,
        profiles: &[Profile],
    ) -> Remains {
        let along = |a: Axis| profiles.iter().find(|p| p.axis == a).map_or(Vec::new(), |p| p.bins.clone());
        let u = Unexplained {
            partial,
            by_channel: along(Axis::Channel),
            by_band: along(Axis::ColourBand),
            by_radius: along(Axis::Radius),
            trends: trends(profiles, TREND_MIN_SAMPLES),
        };
        Remains {
            chi2_per_dof,
            noise_limit,
            unexplained: Some(u),
            named: Vec::new(),
            negligible: Vec::new(),
            unphysical: Vec::new(),
            left_by_cap: None,
        }
    }

    /// A residual within the noise once `named` (effects, and pairs as "a or b") and
    /// `negligible` are in the model.
    pub fn within_noise(
        chi2_per_dof: f64,
        noise_limit: f64,
        named: &[&'static str],
        pairs: &[String],
        negligible: &[&'static str],
    ) -> Remains {
        let named = named.iter().map(|s| s.to_string()).chain(pairs.iter().cloned()).collect();
        Remains {
            chi2_per_dof,
            noise_limit,
            unexplained: None,
            named,
            negligible: negligible.to_vec(),
            unphysical: Vec::new(),
            left_by_cap: None,
        }
    }

    /// The same, with the fitted values no real instrument or sky has
    /// ([`Remains::unphysical`]).
    pub fn with_unphysical(self, unphysical: Vec<OutsidePhysical>) -> Remains {
        Remains { unphysical, ..self }
    }

    /// The same, with what the search's cap left out ([`Remains::left_by_cap`]).
    pub fn with_left_by_cap(self, left_by_cap: Option<LeftByCap>) -> Remains {
        Remains { left_by_cap, ..self }
    }

    /// Whether the catalog leaves the capture unexplained: a structured residual
    /// remains that no catalog effect explains (not one a candidate the cap left out
    /// explains), or the model reached the noise only with values no real instrument
    /// or sky has.
    pub fn is_unexplained(&self) -> bool {
        (self.unexplained.is_some() && self.left_by_cap.is_none()) || !self.unphysical.is_empty()
    }

    /// The strongest trend of `quantity`, if any.
    pub fn trend(&self, quantity: crate::fit::output::profiles::Quantity) -> Option<&Trend> {
        self.unexplained.as_ref()?.trends.iter().find(|t| t.quantity == quantity)
    }
}

impl Unexplained {
    /// The channel bin with the largest χ² per sample.
    pub fn worst_channel(&self) -> Option<&ProfileBin> {
        self.by_channel.iter().max_by(|a, b| a.chi2_per_sample.total_cmp(&b.chi2_per_sample))
    }

    /// The colour band whose raw-DN misfit stands above every other band's by more
    /// than χ² per sample's noise (5·√(2/n) of its n samples, at least 0.02, as
    /// [`Remains::noise_limit`]): where a residual is one band's (a blue-only flaw);
    /// `None` on a monochrome sensor or where the bands are alike.
    pub fn band_apart(&self) -> Option<&ProfileBin> {
        let worst = self.by_band.iter().max_by(|a, b| a.chi2_per_sample.total_cmp(&b.chi2_per_sample))?;
        let next = self
            .by_band
            .iter()
            .filter(|b| !std::ptr::eq(*b, worst))
            .map(|b| b.chi2_per_sample)
            .max_by(f64::total_cmp)?;
        let noise = (5.0 * (2.0 / worst.dn_samples.max(1) as f64).sqrt()).max(0.02);
        (worst.chi2_per_sample - next > noise).then_some(worst)
    }

    /// The radius bin with the largest χ² per sample.
    pub fn worst_radius(&self) -> Option<&ProfileBin> {
        self.by_radius.iter().max_by(|a, b| a.chi2_per_sample.total_cmp(&b.chi2_per_sample))
    }
}

impl std::fmt::Display for Remains {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Some(u) = &self.unexplained else {
            write!(f, "χ²/dof {:.3} is within the noise (≤ {:.3})", self.chi2_per_dof, self.noise_limit)?;
            if !self.unphysical.is_empty() {
                let named =
                    if self.named.is_empty() { "the effects added".to_string() } else { self.named.join(" and ") };
                return write!(
                    f,
                    " once {named} {} modelled, but only with values no real instrument or sky has ({}, each beyond \
                     3σ): the catalog does not explain this capture, and {named} may stand in for an effect outside \
                     it; nothing named is a finding.",
                    if self.named.len() > 1 { "are" } else { "is" },
                    words(&self.unphysical)
                );
            }
            if let Some(cap) = &self.left_by_cap {
                if !self.named.is_empty() {
                    let are = if self.named.len() > 1 { "are" } else { "is" };
                    write!(f, " once {} {are} modelled", self.named.join(" and "))?;
                }
                write!(f, ", but {cap}")?;
                if !self.negligible.is_empty() {
                    write!(f, " Detected but negligible (not named): {}.", self.negligible.join(", "))?;
                }
                return Ok(());
            }
            if self.named.is_empty() {
                write!(f, ": nothing structured remains")?;
            } else {
                write!(f, " once {} is modelled: nothing else structured remains", self.named.join(" and "))?;
            }
            if !self.negligible.is_empty() {
                write!(
                    f,
                    "; detected but negligible (below the size thresholds, not named): {}",
                    self.negligible.join(", ")
                )?;
            }
            return write!(f, ".");
        };
        let n = u.partial.len();
        let added = u.partial.join(", ");
        if let Some(cap) = &self.left_by_cap {
            // Not "no catalog effect explains it": the cap stopped the search before one.
            write!(
                f,
                "χ²/dof {:.3} remains (noise alone: ≤ {:.3}) after {}: {cap}",
                self.chi2_per_dof,
                self.noise_limit,
                if n == 0 { "the starting model".to_string() } else { format!("adding {added}") },
            )?;
            if !self.unphysical.is_empty() {
                write!(f, " Values no real instrument or sky has: {}.", words(&self.unphysical))?;
            }
            return Ok(());
        }
        write!(
            f,
            "χ²/dof {:.3} remains (noise alone: ≤ {:.3}) after {}; no catalog effect explains it (none removes {:.0} % of the excess χ² with ΔBIC > {}).",
            self.chi2_per_dof,
            self.noise_limit,
            if n == 0 { "the starting model".to_string() } else { format!("adding {added}") },
            100.0 * EXCESS_FRACTION,
            BIC_THRESHOLD
        )?;
        if n > 0 {
            write!(
                f,
                " {added} explain{} part of the misfit and {} added, but {} no more than a partial explanation: it may stand in for an effect outside the catalog.",
                if n == 1 { "s" } else { "" },
                if n == 1 { "was" } else { "were" },
                if n == 1 { "is" } else { "are" },
            )?;
        }
        if let Some(w) = u.worst_channel() {
            let each: Vec<String> =
                u.by_channel.iter().map(|b| format!("{:.0}° {:.3}", 45.0 * b.lo, b.chi2_per_sample)).collect();
            write!(
                f,
                " The raw DN misfit is largest in {} (χ² per sample {:.3}; channels: {}).",
                Axis::Channel.describe(w.lo),
                w.chi2_per_sample,
                each.join(", ")
            )?;
        }
        // A colour sensor: whether one band carries the misfit (a blue-only flaw is the
        // blue band's, not the sensor's).
        if !u.by_band.is_empty() {
            let each: Vec<String> = u
                .by_band
                .iter()
                .map(|b| format!("{} {:.3}", ["R", "G", "B"][(b.lo as usize).min(2)], b.chi2_per_sample))
                .collect();
            match u.band_apart() {
                Some(w) => write!(
                    f,
                    " By colour band it is largest in {} (χ² per sample {:.3}; bands: {}).",
                    Axis::ColourBand.describe(w.lo),
                    w.chi2_per_sample,
                    each.join(", ")
                )?,
                None => write!(f, " It is alike in every colour band (χ² per sample {}).", each.join(", "))?,
            }
        }
        if let Some(w) = u.worst_radius() {
            let each: Vec<String> =
                u.by_radius.iter().map(|b| format!("{:.2}–{:.2}: {:.2}", b.lo, b.hi, b.chi2_per_sample)).collect();
            write!(
                f,
                " By radius from the principal point it peaks at r = {:.3}–{:.3} focal lengths (χ² per sample {:.3}, mean residual {:+.2}σ: the data are {} than the model there); profile: {}.",
                w.lo,
                w.hi,
                w.chi2_per_sample,
                w.mean_z,
                if w.mean_z > 0.0 { "brighter" } else { "darker" },
                each.join(", ")
            )?;
        }
        // Where in sky space: the axis of the strongest trend.
        if !u.trends.is_empty() {
            let t: Vec<String> = u.trends.iter().map(|t| t.to_string()).collect();
            write!(f, " In sky space, {}.", t.join("; "))?;
        }
        if !self.unphysical.is_empty() {
            write!(
                f,
                " Values no real instrument or sky has (each beyond 3σ of its physical range): {}.",
                words(&self.unphysical)
            )?;
        }
        Ok(())
    }
}

/// Values outside their physical range, in words, `; `-separated.
fn words(v: &[OutsidePhysical]) -> String {
    v.iter().map(|x| x.words.as_str()).collect::<Vec<_>>().join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::output::profiles::{Quantity, TrendPoint};

    #[test]
    fn the_sentence_is_rendered_from_the_data() {
        let bin = |lo: f64, chi2: f64| ProfileBin { lo, hi: lo + 1.0, chi2_per_sample: chi2, ..Default::default() };
        let trend = Trend {
            quantity: Quantity::DolpResidual,
            axis: Axis::Radius,
            min: TrendPoint { at: 0.05, value: 0.0 },
            max: TrendPoint { at: 0.55, value: -0.002 },
        };
        let u = Unexplained {
            partial: vec!["lens_retardance"],
            by_channel: vec![bin(0.0, 1.1), bin(1.0, 1.3)],
            by_band: vec![],
            by_radius: vec![],
            trends: vec![trend],
        };
        let r = Remains {
            chi2_per_dof: 1.135,
            noise_limit: 1.02,
            unexplained: Some(u),
            named: vec![],
            negligible: vec![],
            unphysical: vec![],
            left_by_cap: None,
        };
        assert!(r.is_unexplained());
        assert_eq!(r.trend(Quantity::DolpResidual).map(|t| t.axis), Some(Axis::Radius));
        assert!(r.trend(Quantity::MeanDnResidualSigma).is_none());
        let s = r.to_string();
        assert!(s.starts_with("χ²/dof 1.135 remains (noise alone: ≤ 1.020) after adding lens_retardance"), "{s}");
        assert!(
            s.contains("lens_retardance explains part of the misfit and was added, but is no more than a partial"),
            "{s}"
        );
        assert!(s.contains("largest in the 45° channel (χ² per sample 1.300"), "{s}");
        assert!(s.contains("In sky space, the DoLP residual (measured − model) varies most along the radius"), "{s}");
        // A monochrome sensor's residual has no band.
        assert!(!s.contains("band"), "{s}");
        // A colour sensor's: a residual that is the blue band's says so; one alike in
        // every band (within χ²'s noise of 10⁴ samples, 0.07) says that.
        let banded = |chi2: [f64; 3]| {
            let by_band =
                (0..3).map(|k| ProfileBin { dn_samples: 10_000, ..bin(k as f64, chi2[k]) }).collect::<Vec<_>>();
            let u = Unexplained { by_band, ..r.unexplained.clone().unwrap() };
            Remains { unexplained: Some(u), ..r.clone() }.to_string()
        };
        let blue = banded([1.02, 1.03, 1.45]);
        assert!(blue.contains("By colour band it is largest in the blue band (χ² per sample 1.450; bands: R 1.020, G 1.030, B 1.450)."), "{blue}");
        let alike = banded([1.30, 1.33, 1.29]);
        assert!(
            alike.contains("It is alike in every colour band (χ² per sample R 1.300, G 1.330, B 1.290)."),
            "{alike}"
        );
        let quiet = Remains::within_noise(0.999, 1.02, &[], &[], &[]);
        assert_eq!(quiet.to_string(), "χ²/dof 0.999 is within the noise (≤ 1.020): nothing structured remains.");
        // Never "nothing structured remains" beside a name.
        let named = Remains::within_noise(0.993, 1.02, &["analyzer_angles"], &[], &["sky_dolp_shape"]);
        assert_eq!(
            named.to_string(),
            "χ²/dof 0.993 is within the noise (≤ 1.020) once analyzer_angles is modelled: nothing else structured \
             remains; detected but negligible (below the size thresholds, not named): sky_dolp_shape."
        );
        // Stopped by the cap with a candidate the data still show: never "nothing else
        // structured remains", and not unexplained (a catalog effect explains it).
        let left = CapCandidate { effect: "analyzer_angles", delta_bic: 7827.4, heading_shift_deg: 0.6912, with: None };
        let cap = LeftByCap { max_added: 2, candidates: vec![left] };
        let capped = Remains::within_noise(1.011, 1.02, &["extinction_ratio", "polarimetric_nonuniformity"], &[], &[])
            .with_left_by_cap(Some(cap.clone()));
        assert!(!capped.is_unexplained());
        assert_eq!(
            capped.to_string(),
            "χ²/dof 1.011 is within the noise (≤ 1.020) once extinction_ratio and polarimetric_nonuniformity are \
             modelled, but the search stopped at its cap (--max-added 2) with analyzer_angles (ΔBIC 7827, moves the \
             heading 0.69°) not added, though the data show it (it passes the rule for adding an effect): the \
             headings' 1σ carry its shift; raise --max-added to model it."
        );
        let above = Remains { left_by_cap: Some(cap), ..r.clone() };
        assert!(!above.is_unexplained());
        let s = above.to_string();
        assert!(s.starts_with("χ²/dof 1.135 remains (noise alone: ≤ 1.020) after adding lens_retardance: the search stopped at its cap (--max-added 2) with analyzer_angles (ΔBIC 7827"), "{s}");
        assert!(!s.contains("no catalog effect explains"), "{s}");
        let pair = Remains::within_noise(0.993, 1.02, &[], &["window or lens_diattenuation".into()], &[]);
        assert!(pair.to_string().contains("once window or lens_diattenuation is modelled"), "{pair}");
        assert!(!pair.is_unexplained());
        // At the noise only with a value no real sensor has: unexplained, and no finding.
        let offsets = OutsidePhysical::new("channel_response.offset0_dn", 466.538_71, 1.2, "DN", (-50.0, 50.0));
        let glare = Remains::within_noise(0.970, 1.02, &["channel_response", "principal_point"], &[], &[])
            .with_unphysical(vec![offsets]);
        assert!(glare.is_unexplained());
        assert_eq!(
            glare.to_string(),
            "χ²/dof 0.970 is within the noise (≤ 1.020) once channel_response and principal_point are modelled, but \
             only with values no real instrument or sky has (channel_response.offset0_dn = 466.5387 DN outside the \
             physical -50…50, each beyond 3σ): the catalog does not explain this capture, and channel_response and \
             principal_point may stand in for an effect outside it; nothing named is a finding."
        );
    }
}
