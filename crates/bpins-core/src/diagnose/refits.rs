//! A diagnosis step's refits: each candidate worth a refit is fitted on the scoring
//! subsample (every [`crate::fit::solver::lm::SUBSAMPLE_STRIDE`]-th row and column, 1/9 of the samples) and
//! ranked there by its Δχ² against the base model's own subsampled optimum; only the
//! leader, and any candidate whose every-pixel ΔBIC could come within reach of it,
//! is then converged on every pixel (warm-started from its subsampled optimum), for
//! the numbers that are reported and for the acceptance decision. A ranking between
//! candidates that differ by thousands in Δχ² does not need every pixel; a close one
//! is decided on every pixel.
//!
//! ```text
//! Δχ²_sub = χ²_sub(base) − χ²_sub(candidate)            each at its subsampled optimum
//! ΔBIC_sub = Δχ²_sub·f − k·ln(f·n_sub)                  f = n_eff/n of the base (every pixel)
//! ΔBIC_proj = Δχ²_sub·f·r − k·ln n_eff                  r = n/n_sub: the every-pixel ΔBIC it projects
//! spread    = 3·f·r·(2√Δχ²_sub + √(2k))                 3σ of that projection (signal × noise cross
//!                                                       term 2√Δχ² and the χ²_k of noise, on the subsample)
//! close: |ΔBIC_proj,a − ΔBIC_proj,b| < CLOSE_MARGIN·BIC_THRESHOLD + spread_a + spread_b
//! ```
//!
//! Where the subsample cannot say whether the leader passes on every pixel (a
//! near-noise step: 1/9 of the pixels cannot rule out a ΔBIC of 10 on all of them), the
//! refits are first scored on every pixel, all from one pass (the score test at the
//! model's every-pixel optimum, `score::score_candidates`): a refit whose ΔBIC would
//! stay below the threshold even at twice that one-step Δχ² is bounded there and not
//! converged. Twice, because the score test is the Δχ² of one Gauss–Newton step: exact
//! where the model is linear in the candidate's parameters over the step (a near-noise
//! step is ≈ 1σ), and unchanged by the column's scale where the effect enters at second
//! order with a fixed shape (a retardance's r⁴, neutral points splitting); the factor
//! 2 is a margin on that linearity, not a fitted figure. Under noise alone the score on
//! every pixel is χ²_k, so a bounded refit would need a one-step Δχ² above
//! (BIC_THRESHOLD + k·ln n_eff)/2 ≈ 20 for k = 2 to be converged (P ≈ 5·10⁻⁵).
//!
//! ```text
//! bounded: ΔBIC(2·Δχ²_score, k) = 2·Δχ²_score·f − k·ln n_eff < BIC_THRESHOLD
//! ```
//!
//! Units: χ² and ΔBIC have none.

use crate::capture::Capture;
use crate::diagnose::evidence::{delta_bic, Evidence, Share};
use crate::diagnose::{Candidate, BIC_THRESHOLD, SCORE_PROBE};
use crate::error::Result;
use crate::fit::input::frames::FitFrames;
use crate::fit::solver::subfit::{fit_subsampled, SubFit};
use crate::fit::uncertainty::score::score_candidates;
use crate::fit::{fit_every_pixel_from, FitOptions, FitResult};

/// Candidates whose projected every-pixel ΔBIC lie within this many
/// [`BIC_THRESHOLD`]s of the leader's (beyond their 3σ spread) are converged on every
/// pixel too: the choice between them is made on every pixel.
pub const CLOSE_MARGIN: f64 = 5.0;

/// How subsample figures scale to every pixel, from the base model of a step: its
/// every-pixel fit and its subsampled optimum.
pub(crate) struct Scale {
    /// n_eff/n of the base model's every-pixel residual, and n_eff.
    share: Share,
    /// Samples of every pixel over samples of the subsample.
    ratio: f64,
    /// Samples of the subsample.
    n_sub: f64,
}

impl Scale {
    pub fn of(base: &FitResult, sub: &SubFit) -> Scale {
        let n = base.samples.max(2) as f64;
        Scale { share: Share::of(base), ratio: n / sub.samples.max(1) as f64, n_sub: sub.samples.max(1) as f64 }
    }

    /// ΔBIC on the subsample (the score's scale, `diagnose`'s ranking of scores).
    pub fn sub_bic(&self, delta_chi2: f64, k: usize) -> f64 {
        self.share.sub_delta_bic(delta_chi2, k, self.n_sub)
    }

    /// The every-pixel ΔBIC a subsampled Δχ² projects, and its 3σ spread.
    fn projected(&self, delta_chi2: f64, k: usize) -> (f64, f64) {
        let fr = self.share.f * self.ratio;
        let spread = 3.0 * fr * (2.0 * delta_chi2.max(0.0).sqrt() + (2.0 * k as f64).sqrt());
        (delta_bic(delta_chi2, k, fr, self.share.n_eff), spread)
    }

    /// Whether a subsampled refit (Δχ²_sub, k) passes [`BIC_THRESHOLD`] on every pixel
    /// beyond its projection's 3σ spread (no every-pixel bound is needed first).
    pub fn clearly_passes(&self, delta_chi2: f64, k: usize) -> bool {
        let (p, spread) = self.projected(delta_chi2, k);
        p - spread > BIC_THRESHOLD
    }

    /// Whether two subsampled refits, each (Δχ²_sub, k), could come within reach of
    /// each other on every pixel.
    fn close(&self, (da, ka): (f64, usize), (db, kb): (f64, usize)) -> bool {
        let (pa, sa) = self.projected(da, ka);
        let (pb, sb) = self.projected(db, kb);
        (pa - pb).abs() < CLOSE_MARGIN * BIC_THRESHOLD + sa + sb
    }
}

/// One candidate's refit: its model, its subsampled optimum and how far it went since
/// ([`Stage`]: its candidate's [`Evidence`], with the every-pixel fit where converged).
pub(crate) struct Refit {
    pub effect: &'static str,
    pub model: FitOptions,
    pub sub: SubFit,
    /// Δχ² on the subsample against the base model's subsampled optimum.
    pub sub_delta_chi2: f64,
    /// Constrained combinations it adds on the subsample.
    pub sub_rank: usize,
    pub stage: Stage,
}

/// How far a refit went beyond the subsample.
pub(crate) enum Stage {
    /// Only on the subsample ([`Evidence::SubsampleRefit`]).
    Subsample,
    /// Bounded below the threshold by its every-pixel score test, not converged
    /// ([`Evidence::EveryPixelScore`]).
    Bounded,
    /// Converged on every pixel, with that fit ([`Evidence::EveryPixelRefit`]).
    Converged(Box<FitResult>),
}

impl Refit {
    /// Its every-pixel fit, where converged.
    pub fn full(&self) -> Option<&FitResult> {
        match &self.stage {
            Stage::Converged(full) => Some(full),
            _ => None,
        }
    }

    /// Neither converged nor bounded on every pixel.
    fn open(&self) -> bool {
        matches!(self.stage, Stage::Subsample)
    }
}

/// The base model of a step on the subsample, and how its figures scale.
pub(crate) fn base_on_subsample(
    c: &Capture,
    frames: &FitFrames,
    model: &FitOptions,
    current: &FitResult,
) -> Result<(SubFit, Scale)> {
    let sub = fit_subsampled(c, frames, model, &current.state, current.noise)?;
    let scale = Scale::of(current, &sub);
    Ok((sub, scale))
}

/// Refits `cand` (added to `model`, from its score step) on the subsample and fills
/// its ranking figures (subsample scale, `every_pixel` false).
pub(crate) fn refit_on_subsample(
    c: &Capture,
    frames: &FitFrames,
    model: &FitOptions,
    current: &FitResult,
    (base, scale): (&SubFit, &Scale),
    cand: &mut Candidate,
) -> Result<Refit> {
    let mut m = model.clone();
    m.effects.push(crate::effects::find(cand.effect)?);
    // Start the candidate at its score step (an effect that enters at second order
    // has no slope at neutral to start from).
    let mut start = current.state.clone();
    start.effect_values.extend(cand.params.iter().map(|p| (p.id, p.value)));
    let sub = fit_subsampled(c, frames, &m, &start, current.noise)?;
    // Its parameters pay only for the combinations the data constrain.
    let sub_rank = sub.rank.saturating_sub(base.rank);
    let sub_delta_chi2 = base.chi2 - sub.chi2;
    cand.added_rank = sub_rank;
    cand.identifiable = sub_rank > 0;
    cand.delta_chi2 = sub_delta_chi2;
    cand.delta_bic = scale.sub_bic(sub_delta_chi2, sub_rank);
    cand.evidence = Evidence::SubsampleRefit;
    cand.params = sub.params.iter().filter(|p| p.id.effect == cand.effect).cloned().collect();
    Ok(Refit { effect: cand.effect, model: m, sub, sub_delta_chi2, sub_rank, stage: Stage::Subsample })
}

/// Converges `refit` on every pixel from its subsampled optimum and fills its
/// candidate's figures from that fit (the every-pixel ΔBIC against `current`). The
/// every-pixel stage only (`fit::fit_every_pixel_from`): the subsampled stage would
/// stop at once at that optimum, after a pass over the subsample for nothing.
pub(crate) fn converge(
    c: &Capture,
    frames: &FitFrames,
    current: &FitResult,
    refit: &mut Refit,
    cand: &mut Candidate,
) -> Result<()> {
    let r = fit_every_pixel_from(c, frames, &refit.model, &refit.sub.state)?;
    cand.added_rank = r.rank.saturating_sub(current.rank);
    cand.identifiable = cand.added_rank > 0;
    cand.delta_chi2 = current.chi2 - r.chi2;
    cand.delta_bic = Share::of(current).delta_bic(cand.delta_chi2, cand.added_rank);
    cand.evidence = Evidence::EveryPixelRefit;
    cand.params = r.params.iter().filter(|p| p.id.effect == cand.effect).cloned().collect();
    refit.stage = Stage::Converged(Box::new(r));
    Ok(())
}

/// Scores the refits not yet converged or bounded on every pixel (one pass, at the
/// model's every-pixel optimum `current`) and bounds each whose every-pixel ΔBIC stays
/// below [`BIC_THRESHOLD`] at twice its one-step Δχ²: its candidate then carries the
/// score's every-pixel figures ([`Evidence::EveryPixelScore`]).
pub(crate) fn bound_on_every_pixel(
    c: &Capture,
    frames: &FitFrames,
    model: &FitOptions,
    current: &FitResult,
    refits: &mut [Refit],
    ranking: &mut [Candidate],
) -> Result<()> {
    let share = Share::of(current);
    let open: Vec<usize> = (0..refits.len()).filter(|&i| refits[i].open()).collect();
    let effects = open.iter().map(|&i| crate::effects::find(refits[i].effect)).collect::<Result<Vec<_>>>()?;
    if effects.is_empty() {
        return Ok(());
    }
    let scores = score_candidates(c, frames, model, current, &effects, 1, SCORE_PROBE)?;
    for (&i, s) in open.iter().zip(scores) {
        if s.added_rank == 0 || share.delta_bic(2.0 * s.delta_chi2, s.added_rank) >= BIC_THRESHOLD {
            continue;
        }
        let r = &mut refits[i];
        r.stage = Stage::Bounded;
        let cand = ranking.iter_mut().find(|c| c.effect == r.effect).expect("a ranked candidate");
        cand.delta_chi2 = s.delta_chi2;
        cand.added_rank = s.added_rank;
        cand.delta_bic = share.delta_bic(s.delta_chi2, s.added_rank);
        cand.evidence = Evidence::EveryPixelScore;
        cand.params = s.params;
    }
    Ok(())
}

/// The refit to converge next, if any: the subsample's leader while none converged
/// is identifiable on every pixel, else the best of the rest where it could come
/// within reach of the best converged one.
pub(crate) fn next_to_converge(refits: &[Refit], ranking: &[Candidate], scale: &Scale) -> Option<usize> {
    let cand = |r: &Refit| ranking.iter().find(|c| c.effect == r.effect).expect("a ranked candidate");
    let best_full = refits
        .iter()
        .filter(|r| r.full().is_some() && cand(r).identifiable)
        .max_by(|a, b| cand(a).delta_bic.total_cmp(&cand(b).delta_bic));
    let (i, next) = refits.iter().enumerate().filter(|(_, r)| r.open() && r.sub_rank > 0).max_by(|a, b| {
        scale.sub_bic(a.1.sub_delta_chi2, a.1.sub_rank).total_cmp(&scale.sub_bic(b.1.sub_delta_chi2, b.1.sub_rank))
    })?;
    match best_full {
        None => Some(i),
        Some(b) => scale.close((b.sub_delta_chi2, b.sub_rank), (next.sub_delta_chi2, next.sub_rank)).then_some(i),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A base of 2.5 M samples (every pixel) and 280 k on the subsample, with an
    /// effective share `f`.
    fn scale(f: f64) -> Scale {
        let n = 2.5e6;
        Scale { share: Share { f, n_eff: f * n }, ratio: n / 2.8e5, n_sub: 2.8e5 }
    }

    #[test]
    fn a_lead_of_thousands_is_not_close_but_two_near_noise_refits_are() {
        // `berry`'s first step: a smooth residual (f ≈ 0.0023), the two refits 10 %
        // apart in Δχ² on the subsample: thousands apart in projected ΔBIC.
        let s = scale(0.0023);
        assert!(!s.close((2.74e6, 1), (2.39e6, 7)));
        // Its last step: white residual, both within noise on the subsample — the
        // subsample cannot tell which (if either) passes ΔBIC 10 on every pixel.
        let s = scale(1.0);
        assert!(s.close((1.3, 1), (0.9, 3)));
        // Symmetric.
        assert_eq!(s.close((40.0, 1), (400.0, 1)), s.close((400.0, 1), (40.0, 1)));
    }

    #[test]
    fn the_projection_scales_a_subsampled_delta_chi2_to_every_pixel() {
        let s = scale(1.0);
        let (p, spread) = s.projected(100.0, 1);
        // Δχ²·r − ln n_eff, r = 2.5e6/2.8e5.
        assert!((p - (100.0 * 2.5e6 / 2.8e5 - 2.5e6f64.ln())).abs() < 1e-9, "{p}");
        assert!(spread > 0.0 && spread < p, "{spread} vs {p}");
        // The subsample's own ΔBIC is on the score's scale.
        assert!((s.sub_bic(100.0, 1) - (100.0 - 2.8e5f64.ln())).abs() < 1e-9);
    }
}
