//! What an effect changes, in the user's units, and whether that matters.
//!
//! An effect's size is the difference between two fits of the capture, with and
//! without it, as a user would see it:
//!
//! ```text
//! Δheading_k = heading_k(with) − heading_k(without)        degrees, wrapped to ±180°
//! heading change: RMS over frames of Δheading_k, and the worst frame's |Δheading_k|
//! AoP, DoLP, DN: the model with the effect against the same fit with its parameters
//!                at neutral (`fit::output::contrast`): RMS ΔAoP (°), RMS ΔDoLP, max |ΔDN|
//! ```
//!
//! The heading change is taken from the two fits' headings (the heading is refitted
//! with the effect: what a user would get by modelling it), the AoP, DoLP and DN
//! changes from one fit evaluated twice (what the effect itself contributes, not what
//! the refit's other parameters moved to absorb it). A candidate known only by its
//! score test (no refit) moves no heading: its heading change is `None`; one whose
//! score is within its noise has no size at all (nothing to measure).
//!
//! An effect *matters* where one of its changes exceeds its threshold:
//!
//! ```text
//! min_heading_deg = 2 · RMS over frames of the heading 1σ (with misfit, `FrameFit`)
//! min_aop_deg     = NOISE_FRACTION · AoP RMS / √max(1, χ²/dof)
//! min_dolp        = NOISE_FRACTION · DoLP RMS / √max(1, χ²/dof)
//! min_dn          = NOISE_FRACTION · σ_DN(mean radiance scale)   one pixel's noise (EMVA model)
//! ```
//!
//! each from the fit with the effect where it was refitted on every pixel, else from
//! the model it adds to (`--min-heading-deg`, `--min-aop-deg`, `--min-dolp`, `--min-dn`
//! set them):
//! a heading change within the frames' own 2σ is not one a user can act on, and an AoP
//! or DoLP change below a tenth of one sample's noise scatter (the residual's RMS with
//! the misfit's share of χ² taken out) adds under 1 % to that scatter, and so does a
//! worst pixel's DN change below a tenth of that pixel's noise (σ_DN at the frames'
//! mean radiance scale, DN; measured: a typical radial distortion moves one pixel by
//! 37 DN while its AoP and DoLP RMS changes stay at 0.9 of theirs). What it cannot
//! say: whether a change that is negligible on this capture would be on another (a
//! wider lens, another sun elevation).

use crate::capture::Capture;
use crate::conventions::wrap_deg_180;
use crate::diagnose::evidence::beyond_noise;
use crate::diagnose::refits::{Refit, Stage};
use crate::error::Result;
use crate::fit::input::frames::FitFrames;
use crate::fit::output::contrast::effect_change;
use crate::fit::{FitOptions, FitResult, FitState};

/// Fraction of one sample's AoP or DoLP noise scatter below which a change is
/// negligible.
pub const NOISE_FRACTION: f64 = 0.1;

/// Thresholds a user gives (`None`: derived from the capture, module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MinSize {
    pub heading_deg: Option<f64>,
    pub aop_deg: Option<f64>,
    pub dolp: Option<f64>,
    pub dn: Option<f64>,
}

/// The thresholds one effect was held to.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Thresholds {
    pub min_heading_deg: f64,
    pub min_aop_deg: f64,
    pub min_dolp: f64,
    pub min_dn: f64,
}

impl Thresholds {
    /// The thresholds of a fit `fit` (module doc), where `given` does not set them.
    pub fn of(fit: &FitResult, given: &MinSize) -> Thresholds {
        let sigmas: Vec<f64> =
            fit.frames.iter().map(|f| f.heading_sigma_deg).filter(|s| s.is_finite() && *s > 0.0).collect();
        let heading = if sigmas.is_empty() {
            0.0
        } else {
            2.0 * (sigmas.iter().map(|s| s * s).sum::<f64>() / sigmas.len() as f64).sqrt()
        };
        let noise = 1.0 / fit.chi2_per_dof.max(1.0).sqrt();
        let or_zero = |x: f64| if x.is_finite() { x } else { 0.0 };
        let scale_dn = fit.frames.iter().map(|f| f.scale_dn).sum::<f64>() / fit.frames.len().max(1) as f64;
        Thresholds {
            min_heading_deg: given.heading_deg.unwrap_or(heading),
            min_aop_deg: given.aop_deg.unwrap_or(or_zero(NOISE_FRACTION * fit.aop_rms_deg * noise)),
            min_dolp: given.dolp.unwrap_or(or_zero(NOISE_FRACTION * fit.dolp_rms * noise)),
            min_dn: given.dn.unwrap_or(or_zero(NOISE_FRACTION * fit.noise.variance_dn2(scale_dn).sqrt())),
        }
    }
}

/// What an effect changes (module doc), and the thresholds it was held to.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EffectSize {
    /// RMS over frames of the heading change, degrees (`None`: not refitted).
    pub heading_change_rms_deg: Option<f64>,
    /// The worst frame's |heading change|, degrees.
    pub heading_change_max_deg: Option<f64>,
    /// RMS change of the model AoP, degrees.
    pub aop_change_rms_deg: f64,
    /// RMS change of the model DoLP.
    pub dolp_change_rms: f64,
    /// Largest change of one pixel's model DN.
    pub max_change_dn: f64,
    pub thresholds: Thresholds,
}

impl EffectSize {
    /// Whether one of its changes exceeds its threshold.
    pub fn matters(&self) -> bool {
        let t = &self.thresholds;
        self.heading_change_max_deg.is_some_and(|h| h > t.min_heading_deg)
            || self.aop_change_rms_deg > t.min_aop_deg
            || self.dolp_change_rms > t.min_dolp
            || self.max_change_dn > t.min_dn
    }

    /// Which of its changes exceed their thresholds, in words (empty: none).
    pub fn what_matters(&self) -> Vec<String> {
        let t = &self.thresholds;
        let mut out = Vec::new();
        if let Some(h) = self.heading_change_max_deg.filter(|h| *h > t.min_heading_deg) {
            out.push(format!("heading {h:.4}° > {:.4}°", t.min_heading_deg));
        }
        if self.aop_change_rms_deg > t.min_aop_deg {
            out.push(format!("AoP {:.4}° > {:.4}°", self.aop_change_rms_deg, t.min_aop_deg));
        }
        if self.dolp_change_rms > t.min_dolp {
            out.push(format!("DoLP {:.5} > {:.5}", self.dolp_change_rms, t.min_dolp));
        }
        if self.max_change_dn > t.min_dn {
            out.push(format!("{:.1} DN > {:.1} DN", self.max_change_dn, t.min_dn));
        }
        out
    }
}

/// RMS and largest |Δheading| over frames between two fits' states (`None` without
/// frames).
pub(crate) fn heading_change(with: &FitState, without: &FitState) -> (Option<f64>, Option<f64>) {
    let d: Vec<f64> = with.frames.iter().zip(&without.frames).map(|(a, b)| wrap_deg_180(a[0] - b[0]).abs()).collect();
    if d.is_empty() {
        return (None, None);
    }
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    (Some(rms), d.iter().copied().reduce(f64::max))
}

/// One effect's size: `model` holds it, `with` is a fit of `model` (its state),
/// `without` the fit it is compared with for the heading (`None`: no refit),
/// `thresholds` those it is held to; the model changes on every `stride`-th sample.
#[allow(clippy::too_many_arguments)]
pub(crate) fn size_of(
    c: &Capture,
    frames: &FitFrames,
    model: &FitOptions,
    effect: &str,
    with: &FitState,
    without: Option<&FitState>,
    noise: crate::fit::input::noise::NoiseModel,
    stride: usize,
    thresholds: Thresholds,
) -> Result<EffectSize> {
    let m = effect_change(c, frames, model, with, effect, noise, stride)?;
    let (rms, max) = without.map_or((None, None), |w| heading_change(with, w));
    Ok(EffectSize {
        heading_change_rms_deg: rms,
        heading_change_max_deg: max,
        aop_change_rms_deg: m.aop_rms_deg,
        dolp_change_rms: m.dolp_rms,
        max_change_dn: m.max_dn,
        thresholds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn size(heading: Option<f64>, aop: f64, dolp: f64) -> EffectSize {
        EffectSize {
            heading_change_rms_deg: heading,
            heading_change_max_deg: heading,
            aop_change_rms_deg: aop,
            dolp_change_rms: dolp,
            max_change_dn: 1.0,
            thresholds: Thresholds { min_heading_deg: 0.01, min_aop_deg: 0.05, min_dolp: 0.001, min_dn: 2.0 },
        }
    }

    #[test]
    fn an_effect_matters_where_any_change_passes_its_threshold() {
        assert!(!size(Some(0.005), 0.01, 0.0005).matters());
        assert!(size(Some(0.02), 0.01, 0.0005).matters());
        assert!(size(None, 0.06, 0.0).matters());
        assert!(size(None, 0.0, 0.002).matters());
        assert_eq!(size(Some(0.02), 0.06, 0.0).what_matters().len(), 2);
    }

    #[test]
    fn every_fitted_value_beyond_its_physical_range_is_flagged_and_a_typical_one_is_not() {
        use crate::fit::model::slots::EffectParam;
        let param = |e: &'static crate::effects::EffectDef, p: &'static crate::effects::ParamSpec, value: f64| {
            crate::fit::Param::new(EffectParam { effect: e.name, param: p.name }, p.unit, value, 0.0)
        };
        let mut narrower = 0;
        for e in crate::effects::REGISTRY {
            for p in e.params {
                assert!(outside_physical(&[param(e, p, p.typical)]).is_empty(), "{}.{} typical", e.name, p.name);
                let (lo, hi) = p.physical_range();
                // Just beyond each side of the physical range that lies within the fit's
                // bounds (a value the fit can reach): flagged, with its name and range.
                for (beyond, inside) in [(hi + 0.1 * (p.max - hi), hi < p.max), (lo - 0.1 * (lo - p.min), lo > p.min)] {
                    if !inside {
                        continue;
                    }
                    narrower += 1;
                    let out = outside_physical(&[param(e, p, beyond)]);
                    assert_eq!(out.len(), 1, "{}.{} = {beyond}", e.name, p.name);
                    assert_eq!(out[0].name, format!("{}.{}", e.name, p.name));
                    assert!(out[0].words.starts_with(&format!("{}.{} = ", e.name, p.name)), "{}", out[0]);
                    assert_eq!((out[0].value, out[0].min, out[0].max, out[0].unit), (beyond, lo, hi, p.unit));
                }
            }
        }
        // Every effect but the sky's shape and neutral points has a narrower range on
        // one side at least (`effects::*`).
        assert!(narrower >= 30, "{narrower} sides narrower than the fit's bounds");
        // E.g. a focal length 20 % off its nominal one: beyond ±5 %.
        let f = crate::effects::find("focal_length").unwrap();
        let w = outside_physical(&[param(f, &f.params[0], 0.2)]);
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].to_string(), "focal_length.scale = 0.2000 1 outside the physical -0.05…0.05");
        // As numbers in JSON, the words beside them.
        let json = serde_json::to_value(&w[0]).unwrap();
        assert_eq!(
            json,
            serde_json::json!({"name": "focal_length.scale", "value": 0.2, "sigma": 0.0, "min": -0.05, "max": 0.05,
                "unit": "1", "words": "focal_length.scale = 0.2000 1 outside the physical -0.05…0.05"})
        );
    }

    #[test]
    fn only_a_value_beyond_its_physical_range_by_3_sigma_excludes_every_physical_value() {
        use crate::fit::model::slots::EffectParam;
        let scale = |value: f64, sigma: f64| {
            crate::fit::Param::new(EffectParam { effect: "focal_length", param: "scale" }, "1", value, sigma)
        };
        // 0.08 ± 0.001: 30σ beyond 0.05. 0.08 ± 0.02: outside, but a physical value fits.
        assert_eq!(excluded_physical(&[scale(0.08, 0.001)]).len(), 1);
        assert!(excluded_physical(&[scale(0.08, 0.02)]).is_empty());
        assert_eq!(outside_physical(&[scale(0.08, 0.02)]).len(), 1);
        assert!(excluded_physical(&[scale(-0.08, f64::INFINITY)]).is_empty());
        assert!(excluded_physical(&[scale(0.02, 0.0)]).is_empty());
    }

    #[test]
    fn the_heading_change_is_taken_frame_by_frame_across_the_wrap() {
        let st = |h: &[f64]| FitState {
            frames: h.iter().map(|&x| [x; crate::fit::PER_FRAME]).collect(),
            ..Default::default()
        };
        let (rms, max) = heading_change(&st(&[359.99, 10.0]), &st(&[0.01, 10.03]));
        assert!((max.unwrap() - 0.03).abs() < 1e-9, "{max:?}");
        assert!((rms.unwrap() - (0.5f64 * (0.02f64.powi(2) + 0.03f64.powi(2))).sqrt()).abs() < 1e-9);
    }
}

/// Fills each identifiable candidate's size (module doc) and its fitted values outside
/// the physical range: from its every-pixel refit (against `current`, every sample),
/// else from its subsampled refit (against the base model's subsampled optimum
/// `base_sub`, every `stride`-th sample), else from its score step (no heading change)
/// where the score is beyond its noise; a candidate the data do not show has no size.
#[allow(clippy::too_many_arguments)]
pub(crate) fn fill(
    c: &Capture,
    frames: &FitFrames,
    model: &FitOptions,
    current: &FitResult,
    refits: &[Refit],
    base_sub: Option<&FitState>,
    ranking: &mut [crate::diagnose::Candidate],
    given: &MinSize,
    stride: usize,
) -> Result<()> {
    let base_thresholds = Thresholds::of(current, given);
    for cand in ranking.iter_mut() {
        cand.outside_physical = outside_physical(&cand.params);
        let refit = refits.iter().find(|r| r.effect == cand.effect);
        // A score within its noise (the refit's bar) shows no effect to size: its
        // one-step parameters are noise, and for an effect that enters at second order
        // the linear step is far off besides.
        if !cand.identifiable || (refit.is_none() && !beyond_noise(cand.score, cand.added_rank)) {
            continue;
        }
        cand.size = Some(match refit {
            Some(r @ Refit { stage: Stage::Converged(full), .. }) => {
                let t = Thresholds::of(full, given);
                size_of(c, frames, &r.model, cand.effect, &full.state, Some(&current.state), current.noise, 1, t)?
            }
            Some(r) => {
                let t = base_thresholds;
                size_of(c, frames, &r.model, cand.effect, &r.sub.state, base_sub, current.noise, stride, t)?
            }
            None => {
                let mut m = model.clone();
                m.effects.push(crate::effects::find(cand.effect)?);
                let mut with = current.state.clone();
                with.effect_values.extend(cand.params.iter().map(|p| (p.id, p.value)));
                size_of(c, frames, &m, cand.effect, &with, None, current.noise, stride, base_thresholds)?
            }
        });
    }
    Ok(())
}

/// A fitted value outside the range a real instrument or sky has
/// (`effects::ParamSpec::physical_range`), as numbers, and the same in words.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OutsidePhysical {
    /// The parameter, `effect.param`.
    pub name: String,
    /// Its fitted value and 1σ (`Param::sigma`: infinite, `null` in JSON, where the data
    /// cannot tell it from others), in `unit`.
    pub value: f64,
    pub sigma: f64,
    /// The physical range, in `unit`.
    pub min: f64,
    pub max: f64,
    pub unit: &'static str,
    /// The same in words: "`name` = value unit outside the physical min…max".
    pub words: String,
}

impl OutsidePhysical {
    /// `name` = `value` ± `sigma` (`unit`) against the physical range `(min, max)`.
    pub fn new(name: &str, value: f64, sigma: f64, unit: &'static str, (min, max): (f64, f64)) -> OutsidePhysical {
        let words = format!("{name} = {value:.4} {unit} outside the physical {min}…{max}");
        OutsidePhysical { name: name.to_string(), value, sigma, min, max, unit, words }
    }
}

impl std::fmt::Display for OutsidePhysical {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.words)
    }
}

/// Each fitted value beyond its parameter's physical range by more than 3σ (its own
/// 1σ, `Param::sigma`): no physical value fits the data, so the parameter stands in for
/// something else. As [`outside_physical`]. A value outside the range but within 3σ of
/// it (a poorly constrained one) is flagged by [`outside_physical`] only.
pub fn excluded_physical(params: &[crate::fit::Param]) -> Vec<OutsidePhysical> {
    let excluded: Vec<crate::fit::Param> = params
        .iter()
        .filter(|p| {
            let Some(spec) =
                crate::effects::find(p.id.effect).ok().and_then(|e| e.params.iter().find(|s| s.name == p.id.param))
            else {
                return false;
            };
            let (lo, hi) = spec.physical_range();
            p.sigma.is_finite() && (lo - p.value > 3.0 * p.sigma || p.value - hi > 3.0 * p.sigma)
        })
        .cloned()
        .collect();
    outside_physical(&excluded)
}

/// Each fitted value outside its parameter's physical range
/// (`effects::ParamSpec::physical_range`).
pub fn outside_physical(params: &[crate::fit::Param]) -> Vec<OutsidePhysical> {
    params
        .iter()
        .filter_map(|p| {
            let spec = crate::effects::find(p.id.effect).ok()?.params.iter().find(|s| s.name == p.id.param)?;
            let (lo, hi) = spec.physical_range();
            (p.value < lo || p.value > hi).then(|| OutsidePhysical::new(&p.name, p.value, p.sigma, p.unit, (lo, hi)))
        })
        .collect()
}
