//! Diagnosis: which catalog effect the model lacks. A sibling of [`crate::fit`] that
//! uses it through a narrow interface: `fit_from` (a fit from a starting state;
//! `fit_every_pixel_from`, the same without the subsampled stage, from a subsampled optimum),
//! `fit::solver::subfit` (the same on a subsample), `fit::uncertainty::score` (the
//! score test of a candidate), the frames and the residual's maps and profiles.
//!
//! From a fitted model (default: no effect), every catalog effect not in it is scored
//! (`score_candidates`: the Δχ² one Gauss–Newton step predicts, a score test, on every
//! third row and column, every candidate from one pass over the samples); the strongest `refit_top` whose score is beyond noise (more
//! than 3σ above its null distribution χ²_k: > k + 3√(2k)) are refitted on that
//! subsample and ranked by their real Δχ² there; the leader, and any whose every-pixel
//! ΔBIC could come within reach of it (`diagnose::refits`: within
//! [`CLOSE_MARGIN`] thresholds beyond their 3σ spread), are converged on every pixel
//! (where the subsample cannot tell whether the leader passes there, the refits are
//! first scored on every pixel, and one below the threshold even at twice that Δχ² is
//! not: `diagnose::refits`),
//! ranked by ΔBIC = Δχ²·n_eff/n − k·ln n_eff (k the combinations
//! of its parameters the data constrain beside the model's — fewer than its
//! parameters where some trade exactly against the model's —, n the samples, n_eff
//! their effective count under the model it adds to, `correlation`: residuals
//! correlated between neighbours carry less evidence than their Δχ² says). The winner
//! is added if ΔBIC > 10 on every pixel ("very strong" evidence, Kass & Raftery 1995) and it removes
//! at least half of the model's excess χ² (χ² − dof); where it alone does not, the
//! two best refitted together are added if both pass ΔBIC (the runner-up converged
//! on every pixel for it) and together they remove
//! half (two effects that each explain a part) — an effect that only nibbles at a
//! misfit it does not describe is not named — and the search repeats, up to its cap
//! (`max_added`); at the cap one more step is searched and nothing added: whatever
//! passes the rule there is what the cap left out (`Remains::left_by_cap`, never
//! "nothing remains"), its heading shift joining the headings' 1σ (`margin`). Effects a sky
//! capture cannot tell from the fit's nuisances ([`inseparable`]: vignetting from the
//! sky's radiance, a factor on d_max from each frame's d_max) are not candidates but
//! listed, with why, as what the capture cannot tell. Two candidates that explain the
//! same Δχ² within the noise of their difference (`pairs`) are a confusable pair:
//! the better one is added to the model, neither is named, and the pair is reported
//! with what would separate them. Every candidate carries its size in the user's
//! units (`sizes`: the change to the heading, the AoP, the DoLP, the DN); an added
//! effect whose size stays below the thresholds (derived from the frames' heading 1σ
//! and noise, or given) is *detected, negligible*, not named. When no effect is worth its parameters but
//! χ²/dof stays clearly above 1, the residual is reported as unexplained, described by
//! channel, by radius and by the strongest trend of its sky-space profiles
//! (`profiles::trends`) instead of naming the least-bad effect: as data
//! ([`Remains`]), with the sentence rendered from it. A residual brought to the noise
//! only with fitted values no real instrument or sky has (beyond the registry's physical
//! range by more than 3σ, `sizes::excluded_physical`) is unexplained too: what was named
//! may stand in for something outside the catalog, and every named effect is then
//! possibly compensating.

pub mod bands;
mod evidence;
mod json;
pub mod margin;
pub mod night;
pub mod pairs;
mod raise;
mod refits;
pub mod remains;
pub mod sizes;
mod timings;

use crate::capture::{Capture, FrameData};
use crate::effects::{EffectDef, SkyBlindness, REGISTRY};
use crate::error::Result;
use crate::fit::uncertainty::score::score_candidates;
use crate::fit::{fit_from, residual_maps_of, FitFrames, FitOptions, FitResult, Param};
use crate::sensor::Layout;
pub use evidence::Evidence;
use evidence::{beyond_noise, Share};
pub use json::DiagnosisJson;
use pairs::{confusable, Confusable};
pub use refits::CLOSE_MARGIN;
use refits::{base_on_subsample, bound_on_every_pixel, converge, next_to_converge, refit_on_subsample, Refit, Stage};
use remains::{CapCandidate, LeftByCap, Remains};
use sizes::{EffectSize, MinSize, OutsidePhysical};
use timings::timed;
pub use timings::Timings;

/// How the search runs.
#[derive(Clone, Debug)]
pub struct DiagnoseOptions {
    /// The model to start from (and keep).
    pub base: FitOptions,
    /// Most effects added. At the cap the next step is still searched, nothing added:
    /// what it would add is reported as left out (`Remains::left_by_cap`) and its
    /// heading shift joins the headings' 1σ (`margin`).
    pub max_added: usize,
    /// Candidates refitted per step for their real Δχ².
    pub refit_top: usize,
    /// Row and column stride of candidate scoring.
    pub score_stride: usize,
    /// Catalog effects not to consider, as if the catalog lacked them.
    pub exclude: Vec<&'static str>,
    /// Sizes below which an added effect is negligible (`None`: derived, `sizes`).
    pub min_size: MinSize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            base: FitOptions::default(),
            max_added: 3,
            refit_top: 2,
            score_stride: 3,
            exclude: Vec::new(),
            min_size: MinSize::default(),
        }
    }
}

/// ΔBIC an effect must bring to be added.
pub const BIC_THRESHOLD: f64 = 10.0;

/// The score test's secant step, a fraction of each parameter's range
/// (`score::score_candidate`'s `probe`).
pub const SCORE_PROBE: f64 = 1e-3;

/// Fraction of the model's excess χ² (χ² − dof) an effect — or the best two together
/// — must remove to be added: an effect that only nibbles at a misfit it does not
/// describe (a tilt absorbing a little of a gain ramp, a lens term bending to a sky's
/// radiance) is not named.
pub const EXCESS_FRACTION: f64 = 0.5;

/// The catalog effects a sky capture fitted under `opts` cannot separate from the
/// fit's own nuisances, each with why and what would measure it.
pub fn inseparable(c: &Capture, opts: &FitOptions) -> Vec<(&'static str, String)> {
    // Each effect's definition says when and why (`EffectDef::inseparable`).
    let blind = |when: SkyBlindness| match when {
        SkyBlindness::FreeRadiance => !opts.rayleigh_radiance,
        SkyBlindness::FreeDmax => opts.fixed_dmax.is_none(),
        SkyBlindness::Dofp => matches!(c.sensor.layout, Layout::Dofp { .. }),
        SkyBlindness::Monochrome => c.sensor.colour.is_none(),
        SkyBlindness::Always => true,
    };
    REGISTRY
        .iter()
        .filter_map(|e| e.inseparable.filter(|i| blind(i.when)).map(|i| (e.name, (i.why)(opts.fixed_dmax.is_some()))))
        .collect()
}

/// One candidate of one step.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Candidate {
    pub effect: &'static str,
    /// Predicted (score test) Δχ².
    #[serde(rename = "score_delta_chi2")]
    pub score: f64,
    /// Real Δχ² where refitted (on every pixel, or on the scoring subsample: its
    /// `evidence` says which), else the prediction.
    pub delta_chi2: f64,
    pub delta_bic: f64,
    /// What its figures rest on: its score test on the scoring subsample, a refit ranked
    /// there (on the score's scale, 1/9 of the pixels), or every pixel — the score test
    /// there bounding it below the threshold, or a refit converged there (the leader of
    /// its step and any close to it).
    pub evidence: Evidence,
    /// False where the data cannot tell it from the model's other parameters.
    pub identifiable: bool,
    /// Independent combinations of its parameters the data constrain beside the
    /// model's: the k its ΔBIC pays for (less than its parameters where some trade
    /// exactly against the model's, e.g. a common extinction ratio against d_max).
    #[serde(rename = "constrained_params")]
    pub added_rank: usize,
    pub params: Vec<Param>,
    /// What it changes in the user's units (`sizes`); `None` where unidentifiable.
    pub size: Option<EffectSize>,
    /// Its fitted values outside the range a real instrument or sky has, as numbers
    /// (value, 1σ, range, unit) with the words.
    pub outside_physical: Vec<OutsidePhysical>,
}

impl Candidate {
    /// Whether its size passes the thresholds (`sizes`).
    pub fn matters(&self) -> bool {
        self.size.is_some_and(|s| s.matters())
    }
}

/// One model along the way: its effects and its fit (the fit's fields beside
/// `model` in JSON).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Step {
    pub model: Vec<&'static str>,
    #[serde(flatten)]
    pub fit: FitResult,
}

/// The result of a diagnosis.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Diagnosis {
    pub steps: Vec<Step>,
    /// Candidates of each step, best first.
    pub rankings: Vec<Vec<Candidate>>,
    /// Effects named: added, and large enough to matter (`sizes`).
    pub selected: Vec<&'static str>,
    /// Effects added (detected) whose size stays below the thresholds: not named.
    pub negligible: Vec<&'static str>,
    /// Pairs the evidence could not separate: the first added to the model, neither
    /// named.
    pub confusable: Vec<Confusable>,
    /// What the final model leaves: noise, or a residual no catalog effect explains.
    pub remains: Remains,
    /// Effects this capture cannot tell from the fit's nuisances, with why (not
    /// candidates): [`inseparable`], and any the scoring found unidentifiable.
    #[serde(serialize_with = "effects_with_why")]
    pub inseparable: Vec<(&'static str, String)>,
    /// ΔBIC an effect must bring to be added ([`BIC_THRESHOLD`]).
    pub bic_threshold: f64,
    /// Wall seconds per stage of the search (a caller adds its own stages).
    pub timings: Timings,
    /// Per frame of the final fit: how far its heading's 1σ was widened for the
    /// candidates the data cannot rule out, and by which (`margin`).
    pub heading_margin: Vec<margin::HeadingMargin>,
    /// By moonlight: the source and what its photons let the search see (`night`);
    /// absent by day.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub night: Option<night::Night>,
}

impl Diagnosis {
    /// Whether the catalog leaves the capture unexplained: a structured residual
    /// remains, or the model reached the noise only with fitted values no real
    /// instrument or sky has ([`Remains::is_unexplained`]).
    pub fn unexplained(&self) -> bool {
        self.remains.is_unexplained()
    }

    /// What remains, in words (rendered from [`Diagnosis::remains`]), and by moonlight
    /// what the photons allow ([`Diagnosis::night`]).
    pub fn summary(&self) -> String {
        match &self.night {
            Some(n) => format!("{} {n}", self.remains),
            None => self.remains.to_string(),
        }
    }

    /// Whether a named effect may only stand in for a misfit it does not describe: the
    /// capture stays unexplained, or a fitted value lies outside the physical range.
    pub fn possibly_compensating(&self, effect: &str) -> bool {
        let named = self.selected.contains(&effect) || self.confusable.iter().any(|p| p.first == effect);
        named && (self.unexplained() || self.outside_physical(effect).next().is_some())
    }

    /// The final model's fitted values of `effect` outside the physical range.
    pub fn outside_physical(&self, effect: &str) -> impl Iterator<Item = OutsidePhysical> + '_ {
        let params = self.steps.last().map_or(&[][..], |s| &s.fit.params[..]);
        let own: Vec<Param> = params.iter().filter(|p| p.id.effect == effect).cloned().collect();
        sizes::outside_physical(&own).into_iter()
    }
}

/// `[(effect, why)]` as `[{"effect": …, "why": …}]`.
fn effects_with_why<S: serde::Serializer>(v: &[(&'static str, String)], s: S) -> std::result::Result<S::Ok, S::Error> {
    #[derive(serde::Serialize)]
    struct EffectWhy<'a> {
        effect: &'a str,
        why: &'a str,
    }
    s.collect_seq(v.iter().map(|(effect, why)| EffectWhy { effect, why }))
}

/// Runs the diagnosis on every pixel of `frames`; `progress(what)` as it goes.
pub fn diagnose(
    c: &Capture,
    frames: &[FrameData],
    opts: &DiagnoseOptions,
    progress: &dyn Fn(&str),
) -> Result<Diagnosis> {
    diagnose_frames(c, &FitFrames::all(c, frames)?, opts, progress)
}

/// [`diagnose`] on the frames as [`FitFrames`] hold them (every pixel or a sample
/// within a budget: each step's fit says which, `FitResult::sample`).
pub fn diagnose_frames(
    c: &Capture,
    frames: &FitFrames,
    opts: &DiagnoseOptions,
    progress: &dyn Fn(&str),
) -> Result<Diagnosis> {
    let t0 = std::time::Instant::now();
    let mut t = Timings::default();
    let mut model = opts.base.clone();
    if model.sky_masks.is_none() && !model.all_pixels {
        // Once for every fit of the search.
        progress("finding the sky in each frame");
        model.sky_masks = Some(timed(&mut t.sky_masks_s, || frames.sky_masks(c, &model))?);
    }
    let insep = inseparable(c, &model);
    progress("fitting the starting model");
    let mut current = timed(&mut t.baseline_fit_s, || fit_from(c, frames, &model, None, &|_, _| {}))?;
    let mut d = Diagnosis {
        steps: vec![Step { model: model.effects.iter().map(|e| e.name).collect(), fit: current.clone() }],
        rankings: Vec::new(),
        selected: Vec::new(),
        negligible: Vec::new(),
        confusable: Vec::new(),
        remains: Remains::within_noise(current.chi2_per_dof, f64::NAN, &[], &[], &[]),
        inseparable: insep.clone(),
        bic_threshold: BIC_THRESHOLD,
        timings: Timings::default(),
        night: None,
        heading_margin: Vec::new(),
    };
    let candidates_of = |model: &FitOptions| -> Vec<&'static EffectDef> {
        REGISTRY
            .iter()
            .copied()
            .filter(|e| !model.effects.iter().any(|m| m.name == e.name) && !opts.exclude.contains(&e.name))
            .filter(|e| !insep.iter().any(|(n, _)| *n == e.name))
            .collect()
    };
    // Each candidate's widening of every frame's heading 1σ, scored against the
    // current model: every step scores, and the search ends only after a step's scoring
    // (at the cap too), so this is against the final model.
    let mut widen: Vec<(&'static str, Vec<f64>)>;
    // What the cap left out: each candidate of the step the cap stopped that passes the
    // rule for adding one, with its heading shift per frame (`margin`).
    let mut left_out: Vec<(CapCandidate, Vec<f64>)> = Vec::new();
    loop {
        // At the cap the step is still searched but nothing is added: what it would add
        // is what the cap left out (the same rule, not another threshold).
        let at_cap = model.effects.len() >= opts.base.effects.len() + opts.max_added;
        let candidates = candidates_of(&model);
        // On the scoring subsample, every candidate from one pass (the base model's
        // columns once): under the null the score is χ²_k whatever the sample size,
        // so it is compared with k·ln n of that subsample.
        progress(&format!("scoring {} candidates", candidates.len()));
        let scores = timed(&mut t.scoring_s, || {
            score_candidates(c, frames, &model, &current, &candidates, opts.score_stride, SCORE_PROBE)
        })?;
        // ΔBIC at the effective sample count of the model a candidate adds to: where its
        // residual is smooth, Δχ² counts for n_eff/n of itself (the same factor for every
        // candidate of a step, so it does not reorder them by noise in n_eff).
        widen = candidates.iter().zip(&scores).map(|(e, s)| (e.name, s.heading_widen.clone())).collect();
        let share = Share::of(&current);
        let mut ranking = Vec::new();
        for (e, s) in candidates.iter().zip(scores) {
            ranking.push(Candidate {
                effect: e.name,
                score: s.delta_chi2,
                delta_chi2: s.delta_chi2,
                // At the subsample's share of the model's effective sample count.
                delta_bic: share.sub_delta_bic(s.delta_chi2, s.added_rank, s.samples as f64),
                evidence: Evidence::Score,
                identifiable: s.identifiable,
                added_rank: s.added_rank,
                params: s.params,
                size: None,
                outside_physical: Vec::new(),
            });
        }
        // Unidentifiable candidates last; then by predicted ΔBIC.
        ranking.sort_by(|a, b| b.identifiable.cmp(&a.identifiable).then(b.delta_bic.total_cmp(&a.delta_bic)));
        // Refit the strongest identifiable ones for their real Δχ²: on the subsample
        // (against the base model's own optimum there) to rank them, then on every
        // pixel the leader and any close to it.
        let mut refits = Vec::new();
        let worth: Vec<&'static str> = ranking
            .iter()
            // The strongest by predicted ΔBIC (a candidate with more parameters than an
            // equal rival pays for them) where the score is beyond its noise.
            .filter(|c| c.identifiable && beyond_noise(c.score, c.added_rank))
            .take(opts.refit_top)
            .map(|c| c.effect)
            .collect();
        let base_sub = if worth.is_empty() {
            None
        } else {
            progress("fitting the model on the subsample");
            Some(timed(&mut t.subsample_refits_s, || base_on_subsample(c, frames, &model, &current))?)
        };
        if let Some((sub, scale)) = &base_sub {
            for e in &worth {
                progress(&format!("refitting with {e} on the subsample"));
                let cand = ranking.iter_mut().find(|c| c.effect == *e).expect("ranked");
                refits.push(timed(&mut t.subsample_refits_s, || {
                    refit_on_subsample(c, frames, &model, &current, (sub, scale), cand)
                })?);
            }
        }
        let by_evidence = |ranking: &mut Vec<Candidate>| {
            // Every pixel first, then refitted on the subsample, then the rest by score.
            ranking.sort_by(|a, b| {
                b.evidence
                    .tier()
                    .cmp(&a.evidence.tier())
                    .then(b.identifiable.cmp(&a.identifiable))
                    .then(b.delta_bic.total_cmp(&a.delta_bic))
            })
        };
        if let Some((_, scale)) = &base_sub {
            // Where the subsample cannot tell whether its leader passes on every pixel,
            // the refits' score tests there bound them first (one pass for all).
            let unsettled = next_to_converge(&refits, &ranking, scale)
                .filter(|&i| !scale.clearly_passes(refits[i].sub_delta_chi2, refits[i].sub_rank));
            if unsettled.is_some() {
                progress("scoring the refits on every pixel");
                timed(&mut t.every_pixel_scores_s, || {
                    bound_on_every_pixel(c, frames, &model, &current, &mut refits, &mut ranking)
                })?;
            }
            while let Some(i) = next_to_converge(&refits, &ranking, scale) {
                progress(&format!("refitting with {} on every pixel", refits[i].effect));
                let cand = ranking.iter_mut().find(|c| c.effect == refits[i].effect).expect("ranked");
                timed(&mut t.every_pixel_refits_s, || converge(c, frames, &current, &mut refits[i], cand))?;
            }
        }
        by_evidence(&mut ranking);
        let excess = (current.chi2 - current.dof).max(0.0);
        // Decided on every pixel: converged there (a candidate bounded by its every-pixel
        // score is below the threshold by construction).
        let evident = |c: &Candidate| c.evidence.converged() && c.delta_bic > BIC_THRESHOLD;
        let explains = |c: &Candidate| evident(c) && c.delta_chi2 >= EXCESS_FRACTION * excess;
        // Where the leader is evident but does not explain half alone, the runner-up
        // is converged on every pixel too (the two together are tried on every-pixel
        // evidence).
        loop {
            let pending = match (ranking.first(), ranking.get(1)) {
                (Some(b), Some(r))
                    if evident(b) && !explains(b) && r.evidence == Evidence::SubsampleRefit && r.identifiable =>
                {
                    refits.iter().position(|x| x.effect == r.effect)
                }
                _ => None,
            };
            let Some(i) = pending else { break };
            let pending = refits[i].effect;
            progress(&format!("refitting with {pending} on every pixel"));
            let cand = ranking.iter_mut().find(|c| c.effect == pending).expect("ranked");
            timed(&mut t.pair_refits_s, || converge(c, frames, &current, &mut refits[i], cand))?;
            by_evidence(&mut ranking);
        }
        progress("sizing the candidates");
        let sub_state = base_sub.as_ref().map(|(s, _)| &s.state);
        timed(&mut t.sizes_s, || {
            sizes::fill(
                c,
                frames,
                &model,
                &current,
                &refits,
                sub_state,
                &mut ranking,
                &opts.min_size,
                opts.score_stride,
            )
        })?;
        let best = ranking.first().cloned();
        let runner = ranking.get(1).cloned();
        d.rankings.push(ranking);
        for cand in d.rankings.last().expect("pushed").iter().filter(|c| !c.identifiable && !c.evidence.refitted()) {
            if !d.inseparable.iter().any(|(n, _)| *n == cand.effect) {
                let why =
                    "the data cannot tell it from the fit's other parameters (it adds no constrained combination)";
                d.inseparable.push((cand.effect, why.to_string()));
            }
        }
        let Some(best) = best.filter(|b| evident(b)) else { break };
        if explains(&best) {
            if at_cap {
                // Every candidate that passes alone (rivals: the next step would add the
                // best), each converged on every pixel.
                for cand in d.rankings.last().expect("pushed").iter().filter(|c| explains(c)) {
                    if let Some(full) = refits.iter().find(|r| r.effect == cand.effect).and_then(|r| r.full()) {
                        left_out.push(CapCandidate::of(cand.effect, cand.delta_bic, None, full, &current));
                    }
                }
                break;
            }
            let f = current.n_eff / current.samples.max(1) as f64;
            let pair = runner.filter(|r| explains(r) && confusable(&best, r, f));
            // Evident: converged on every pixel, so its refit holds that fit.
            let Some(Refit { model: m, stage: Stage::Converged(full), .. }) =
                refits.into_iter().find(|r| r.effect == best.effect)
            else {
                break;
            };
            model = m;
            current = *full;
            match pair {
                Some(r) => d.confusable.push(Confusable::new(best.effect, r.effect)),
                None if best.matters() => d.selected.push(best.effect),
                None => d.negligible.push(best.effect),
            }
        } else {
            // Neither explains half alone: the best two together, each evident alone.
            let Some(second) = runner.filter(|r| evident(r)) else { break };
            progress(&format!("refitting with {} and {}", best.effect, second.effect));
            // From the leader's every-pixel optimum (its values and every frame's
            // nuisances converged with it) with the runner-up's values from its own: the
            // same least-squares problem as from the base model's optimum, started
            // nearer its optimum (samples/clean with `benches/diagnose.rs`'s glare: 7
            // iterations instead of 24, the same χ²/dof to 10⁻⁴; BENCHMARKS.md).
            let mut m = model.clone();
            let lead = refits.iter().find(|r| r.effect == best.effect).and_then(|r| r.full());
            let mut start = lead.map_or_else(|| current.state.clone(), |f| f.state.clone());
            for cand in [&best, &second] {
                m.effects.push(crate::effects::find(cand.effect)?);
                if lead.is_none() || cand.effect != best.effect {
                    start.effect_values.extend(cand.params.iter().map(|p| (p.id, p.value)));
                }
            }
            let r = timed(&mut t.pair_refits_s, || fit_from(c, frames, &m, Some(&start), &|_, _| {}))?;
            let dc = current.chi2 - r.chi2;
            let k = r.rank.saturating_sub(current.rank);
            if dc < EXCESS_FRACTION * excess || share.delta_bic(dc, k) < 2.0 * BIC_THRESHOLD {
                break;
            }
            if at_cap {
                // The two together: one refit, one shift.
                for (a, b) in [(&best, &second), (&second, &best)] {
                    left_out.push(CapCandidate::of(a.effect, a.delta_bic, Some(b.effect), &r, &current));
                }
                break;
            }
            model = m;
            current = r;
            for cand in [&best, &second] {
                if cand.matters() {
                    d.selected.push(cand.effect);
                } else {
                    d.negligible.push(cand.effect);
                }
            }
        }
        d.steps.push(Step { model: model.effects.iter().map(|e| e.name).collect(), fit: current.clone() });
    }
    // The final headings' 1σ with what the data cannot rule out (margin.rs).
    let last = &mut d.steps.last_mut().expect("the starting model's step").fit;
    d.heading_margin = margin::widen_headings(last, &widen);
    // And the heading shift of what the cap left out, which the data show.
    let shifts: Vec<(&'static str, Vec<f64>)> = left_out.iter().map(|(l, h)| (l.effect, h.clone())).collect();
    margin::carry_left_out(last, &mut d.heading_margin, &shifts);
    // Whatever remains: is it noise?
    let limit = Remains::noise_limit(current.dof);
    let pairs: Vec<String> = d.confusable.iter().map(|p| format!("{} or {}", p.first, p.second)).collect();
    d.remains = if current.chi2_per_dof > limit {
        progress("describing the residual");
        let maps = timed(&mut t.residual_s, || {
            residual_maps_of(c, frames, &model, &current.state, current.noise, &mut |_, _| {})
        })?;
        let mut partial = d.selected.clone();
        partial.extend(d.confusable.iter().flat_map(|p| [p.first, p.second]));
        Remains::unexplained(current.chi2_per_dof, limit, partial, &maps.profiles)
    } else {
        Remains::within_noise(current.chi2_per_dof, limit, &d.selected, &pairs, &d.negligible)
    };
    // What the search added, at values the data say no real instrument or sky has.
    let added: Vec<&str> =
        d.selected.iter().chain(&d.negligible).copied().chain(d.confusable.iter().map(|p| p.first)).collect();
    let own: Vec<Param> = current.params.iter().filter(|p| added.contains(&p.id.effect)).cloned().collect();
    d.remains = d.remains.with_unphysical(sizes::excluded_physical(&own));
    let left_by_cap = (!left_out.is_empty())
        .then(|| LeftByCap { max_added: opts.max_added, candidates: left_out.into_iter().map(|(l, _)| l).collect() });
    d.remains = d.remains.with_left_by_cap(left_by_cap);
    d.night = night::Night::of(c, frames, &current, &d);
    t.total_s = t0.elapsed().as_secs_f64();
    d.timings = t;
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::model::slots::EffectParam;

    /// A diagnosis that named `focal_length` at `scale` and ended within the noise.
    fn named_focal_length(scale: f64) -> Diagnosis {
        let id = EffectParam { effect: "focal_length", param: "scale" };
        let fit = FitResult { params: vec![Param::new(id, "1", scale, 0.001)], ..Default::default() };
        Diagnosis {
            steps: vec![Step { model: vec!["focal_length"], fit }],
            rankings: Vec::new(),
            selected: vec!["focal_length"],
            negligible: Vec::new(),
            confusable: Vec::new(),
            remains: Remains::within_noise(1.0, 1.02, &["focal_length"], &[], &[]),
            inseparable: Vec::new(),
            bic_threshold: BIC_THRESHOLD,
            timings: Timings::default(),
            night: None,
            heading_margin: Vec::new(),
        }
    }

    #[test]
    fn a_named_effect_outside_its_physical_range_is_possibly_compensating() {
        // A focal length 2 % off (typical) is a finding; 20 % off is beyond what a lens's
        // tolerance and focus give (±5 %): the capture's focal length is wrong, or the
        // parameter stands in for something else.
        let d = named_focal_length(0.02);
        assert!(!d.possibly_compensating("focal_length"));
        assert_eq!(d.outside_physical("focal_length").count(), 0);
        let d = named_focal_length(0.2);
        assert!(d.possibly_compensating("focal_length"));
        let out: Vec<OutsidePhysical> = d.outside_physical("focal_length").collect();
        assert_eq!(out.len(), 1);
        assert_eq!((out[0].value, out[0].min, out[0].max, out[0].unit), (0.2, -0.05, 0.05, "1"));
        assert_eq!(out[0].words, "focal_length.scale = 0.2000 1 outside the physical -0.05…0.05");
        // Only what was named is marked.
        assert!(!d.possibly_compensating("mount_tilt"));
    }
}
