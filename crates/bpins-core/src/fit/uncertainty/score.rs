//! The score test of a candidate effect: how much of what a fitted model leaves
//! unexplained one Gauss–Newton step with the candidate freed would remove.

use crate::capture::Capture;
use crate::effects::EffectDef;
use crate::error::Result;
use crate::fit::input::frames::FitFrames;
use crate::fit::model::problem::problem;
use crate::fit::model::slots::{Derivative, Nuisance, SlotId};
use crate::fit::solver::schur::BlockInverse;
use crate::fit::uncertainty::prior;
use crate::fit::{FitOptions, FitResult, Param};

/// The score of adding `candidate` to a fitted model: the Δχ² one Gauss–Newton step
/// from `base` (where the base model's own gradient vanishes) predicts, bᵀA⁺b over
/// the joint system, on every `stride`-th row and column. The candidate's Jacobian is
/// a secant of `probe` × its range from neutral (one-sided at a bound), so an effect
/// that enters at second order (neutral points splitting) still scores.
pub fn score_candidate(
    c: &Capture,
    frames: &FitFrames,
    base_opts: &FitOptions,
    base: &FitResult,
    candidate: &'static EffectDef,
    stride: usize,
    probe: f64,
) -> Result<Score> {
    let mut s = score_candidates(c, frames, base_opts, base, &[candidate], stride, probe)?;
    Ok(s.pop().expect("one score per candidate"))
}

/// [`score_candidate`] for each of `candidates` (in their order), from one pass over
/// the samples: the base model's Jacobian columns are evaluated once and every
/// candidate's beside them, each candidate then scored on its own block of the joint
/// system (the base slots and its own). The same numbers as one candidate at a time,
/// at a fraction of the chain evaluations (a candidate at neutral leaves the chain
/// bitwise ideal, so the others do not see it).
pub fn score_candidates(
    c: &Capture,
    frames: &FitFrames,
    base_opts: &FitOptions,
    base: &FitResult,
    candidates: &[&'static EffectDef],
    stride: usize,
    probe: f64,
) -> Result<Vec<Score>> {
    let mut opts = base_opts.clone();
    opts.effects.extend_from_slice(candidates);
    let (mut pb, theta) = problem(c, frames, &opts, Some(&base.state), base.noise)?;
    for e in candidates {
        for i in pb.slots.of_effect(e.name).collect::<Vec<_>>() {
            // A forward secant (backward at the upper bound): first- and second-order
            // effects alike get a column of their shape.
            let s = &mut pb.slots.all[i];
            s.step = probe * (s.max - s.min);
            s.derivative = Derivative::Secant;
        }
    }
    // An odd stride samples every channel of a DoFP mosaic.
    let acc = pb.accumulate(&theta, stride | 1, true)?;
    let nf = acc.sys.n();
    // The candidates' slots come right after the base effects' (free, in order).
    let first = base_opts.effects.iter().map(|e| e.params.len()).sum::<usize>();
    let all = candidates.iter().map(|e| e.params.len()).sum::<usize>();
    // The base model's own predicted Δχ² on these samples (its optimum on them is not
    // exactly the one on every pixel), on the system without any candidate.
    let block = |keep: &[usize]| {
        let sys = acc.sys.restrict(keep);
        let b = sys.b();
        (sys, b)
    };
    let base_keep: Vec<usize> = (0..nf).filter(|&i| i < first || i >= first + all).collect();
    let (a0, b0) = block(&base_keep);
    let own_cov = BlockInverse::new(&a0);
    let own = own_cov.solve(&b0).iter().zip(&b0).map(|(a, b)| a * b).sum::<f64>();
    // Each frame's heading among the free slots (after every effect's: `p − all` in
    // the base system, `p − all + k` in a candidate's joint one).
    let free = pb.slots.free();
    let headings: Vec<Option<usize>> =
        (0..frames.len()).map(|k| free.binary_search(&pb.slots.at(k, Nuisance::Heading)).ok()).collect();
    // q²: the fit's heading variance over this subsample's (≈ n_sub/n × the fit's
    // n/n_eff), the median over the frames: the scale at which a physical range enters
    // this system (prior.rs).
    let q2 = crate::stats::median(
        headings
            .iter()
            .zip(&base.frames)
            .filter_map(|(p, f)| {
                let s = own_cov.sigma(p.filter(|&p| p >= first + all)? - all);
                let r = (f.heading_sigma_stat_deg / s).powi(2);
                (r.is_finite() && r > 0.0).then_some(r)
            })
            .collect(),
    );
    let mut out = Vec::with_capacity(candidates.len());
    let mut at = first;
    for candidate in candidates {
        let k = candidate.params.len();
        // The joint system of the base and this candidate: its slots where the
        // single-candidate system has them (right after the base effects').
        let keep: Vec<usize> = (0..first).chain(at..at + k).chain(first + all..nf).collect();
        let (a, b) = block(&keep);
        // Pseudo-inverses: a candidate (or part of one) that trades exactly against
        // the model's other parameters adds no constrained direction and no Δχ².
        let cov = BlockInverse::new(&a);
        let x = cov.solve(&b);
        // The heading's 1σ with the candidate free within what the data allow and its
        // physical range (prior.rs): bounded where the data leave it loose or free.
        let sigmas: Vec<f64> = candidate.params.iter().map(prior::physical_sigma).collect();
        let bounded = q2.map(|q2| BlockInverse::new(&prior::with_prior(&a, first, &sigmas, q2)));
        let bounded = bounded.as_ref().unwrap_or(&cov);
        // Score test: the joint model's predicted Δχ² minus the base model's own.
        let joint = x.iter().zip(&b).map(|(a, b)| a * b).sum::<f64>();
        let added = cov.rank().saturating_sub(own_cov.rank());
        let mut score = Score {
            delta_chi2: if added > 0 { (joint - own).max(0.0) } else { 0.0 },
            params: Vec::new(),
            samples: acc.n,
            added_rank: added,
            identifiable: added > 0,
            heading_widen: headings
                .iter()
                .map(|p| {
                    let Some(p) = p.filter(|&p| p >= first + all) else { return 1.0 };
                    let (joint, base) = (bounded.sigma(p - all + k), own_cov.sigma(p - all));
                    if joint.is_finite() && base > 0.0 && base.is_finite() {
                        (joint / base).max(1.0)
                    } else {
                        1.0
                    }
                })
                .collect(),
        };
        for (j, p) in candidate.params.iter().enumerate() {
            let (i, l) = (at + j, first + j);
            let s = &pb.slots.all[i];
            let SlotId::Effect(id) = s.id else { unreachable!("effect slots come first") };
            score.params.push(Param::new(id, p.unit, (theta[i] + x[l]).clamp(s.min, s.max), cov.sigma(l)));
        }
        out.push(score);
        at += k;
    }
    Ok(out)
}

/// What [`score_candidate`] predicts: Δχ² and the one-step parameters with their 1σ.
#[derive(Clone, Debug, PartialEq)]
pub struct Score {
    pub delta_chi2: f64,
    pub params: Vec<Param>,
    pub samples: usize,
    /// How many independent combinations of its parameters the data constrain beside
    /// the model's (its parameters, less those degenerate with the model's): the k of
    /// its information criterion.
    pub added_rank: usize,
    /// False where the candidate cannot be told from the model's other parameters (the
    /// joint system is singular): e.g. a global d_max factor beside per-frame d_max.
    pub identifiable: bool,
    /// Per frame, the heading's 1σ with the candidate freed over the base model's, on
    /// the same samples (≥ 1): how much wider the heading is where the candidate may
    /// take any value the data allow and its physical range holds (`prior.rs`: along a
    /// direction the data do not constrain, the heading's shift across that range).
    pub heading_widen: Vec<f64>,
}
