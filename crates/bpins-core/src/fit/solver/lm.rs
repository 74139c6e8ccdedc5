//! Levenberg–Marquardt on the accumulated normal equations:
//! (JᵀWJ + λ·diag JᵀWJ) δ = JᵀW r, solved by pseudo-inverse (a parameter without
//! influence, or a degenerate combination, is not moved) block by block: each frame's
//! nuisances eliminated, the globals solved on the Schur complement, the frames'
//! steps back-substituted (`crate::fit::solver::schur`, the dense pseudo-inverse's numbers in
//! time and memory linear in the frames). Iterations first run on
//! every third row and column (all channels), then on every pixel until converged
//! (from a subsampled optimum, every pixel only: [`minimise_every_pixel`]).

use crate::error::Result;
use crate::fit::model::accumulate::Accum;
use crate::fit::model::problem::Problem;
use crate::fit::model::slots::SlotId;
use crate::fit::solver::schur::BlockInverse;

/// Row and column stride of the subsampled stage (odd: every channel of a DoFP mosaic).
pub(crate) const SUBSAMPLE_STRIDE: usize = 3;

/// An accepted step that gains less than this fraction of the excess χ² (χ² − dof),
/// and under a tenth of its prediction, ends the stage (`step`).
const STALL_FRACTION: f64 = 1e-3;

/// The stages: (name, stride, most iterations, convergence tolerance in χ²). The
/// subsampled stage only brings the parameters near the optimum (within 1σ: a
/// Gauss–Newton decrement below 1); every pixel then converges to 0.01.
const STAGES: [(&str, usize, usize, f64); 2] =
    [("subsampled", SUBSAMPLE_STRIDE, 30, 1.0), ("every pixel", 1, 20, 0.01)];

/// Minimises χ² from `theta`; returns the parameters, the iterations taken and, where
/// the last iteration left the parameters where it accumulated them on every pixel,
/// those sums (the final covariance's, not accumulated again);
/// `progress(stage, iteration)` after each.
pub(crate) fn minimise(
    pb: &Problem,
    theta: Vec<f64>,
    progress: &dyn Fn(&str, usize),
) -> Result<(Vec<f64>, usize, Option<Accum>)> {
    minimise_stages(pb, theta, &STAGES, progress)
}

/// [`minimise`] through the subsampled stage only (the optimum on every
/// [`SUBSAMPLE_STRIDE`]-th row and column, within 1σ there: how a diagnosis ranks
/// its candidates); the sums returned, where given, are on that subsample.
pub(crate) fn minimise_subsampled(pb: &Problem, theta: Vec<f64>) -> Result<(Vec<f64>, usize, Option<Accum>)> {
    minimise_stages(pb, theta, &STAGES[..1], &|_, _| {})
}

/// [`minimise`] through the every-pixel stage only: from a subsampled optimum (a
/// diagnosis's candidate, `diagnose::refits::converge`) the subsampled stage would
/// stop at once, after one pass over the subsample for nothing.
pub(crate) fn minimise_every_pixel(
    pb: &Problem,
    theta: Vec<f64>,
    progress: &dyn Fn(&str, usize),
) -> Result<(Vec<f64>, usize, Option<Accum>)> {
    minimise_stages(pb, theta, &STAGES[1..], progress)
}

/// [`minimise`] through `stages`; the sums returned are at the last stage's stride.
fn minimise_stages(
    pb: &Problem,
    mut theta: Vec<f64>,
    stages: &[(&str, usize, usize, f64)],
    progress: &dyn Fn(&str, usize),
) -> Result<(Vec<f64>, usize, Option<Accum>)> {
    let mut iterations = 0;
    let mut last = None;
    for &(stage, stride, max_iter, tol) in stages {
        let mut lambda = 1e-3;
        for _ in 0..max_iter {
            iterations += 1;
            let acc = pb.accumulate(&theta, stride, true)?;
            let step = step(pb, &theta, &acc, &mut lambda, stride, tol)?;
            progress(stage, iterations);
            // The sums stay valid while θ stays: no step lowered χ², or converged by
            // the decrement (θ returned unchanged).
            let Some((t, converged)) = step else {
                last = Some(acc);
                break;
            };
            let stays = t == theta;
            theta = t;
            last = stays.then_some(acc);
            if converged {
                break;
            }
        }
    }
    Ok((theta, iterations, last))
}

/// One damped Gauss–Newton step: the new parameters and whether the fit converged,
/// or `None` when no step lowers χ².
fn step(
    pb: &Problem,
    theta: &[f64],
    acc: &Accum,
    lambda: &mut f64,
    stride: usize,
    tol: f64,
) -> Result<Option<(Vec<f64>, bool)>> {
    let all_free = pb.slots.free();
    let b_all = acc.sys.b();
    let x = BlockInverse::new(&acc.sys).solve(&b_all);
    // A parameter at a bound that both the Gauss–Newton step and the gradient (b, the
    // descent direction) push out of its range is held there for this step (an active
    // bound: d_max at 1 under a sky more polarized than the model's): the clamp would
    // undo its part of every step, and its share of the predicted decrement would never
    // be realised, so the fit would not stop.
    let keep: Vec<usize> = (0..all_free.len())
        .filter(|&j| {
            let (i, s) = (all_free[j], &pb.slots.all[all_free[j]]);
            let out = |d: f64| (theta[i] <= s.min && d < 0.0) || (theta[i] >= s.max && d > 0.0);
            !(out(x[j]) && (out(b_all[j]) || b_all[j] == 0.0))
        })
        .collect();
    let (free, sys0, x) = if keep.len() == all_free.len() {
        (all_free, acc.sys.clone(), x)
    } else {
        let sys0 = acc.sys.restrict(&keep);
        let x = BlockInverse::new(&sys0).solve(&sys0.b());
        (keep.iter().map(|&j| all_free[j]).collect(), sys0, x)
    };
    let b0 = sys0.b();
    // Converged when the undamped Gauss–Newton step predicts less than `tol` in χ²
    // (minimum-norm where parameters are degenerate).
    let decrement = x.iter().zip(&b0).map(|(a, b)| a * b).sum::<f64>();
    if decrement < tol {
        return Ok(Some((theta.to_vec(), true)));
    }
    for trial in 0..12 {
        let delta = BlockInverse::new(&sys0.damped(*lambda)).solve(&b0);
        let mut t = theta.to_vec();
        for (j, &i) in free.iter().enumerate() {
            let s = &pb.slots.all[i];
            t[i] = (t[i] + delta[j]).clamp(s.min, s.max);
        }
        let chi2 = pb.accumulate(&t, stride, false)?.chi2;
        if chi2 <= acc.chi2 {
            // A nearly undamped step that gains less than a thousandth in χ² is at the
            // optimum to the precision of the differences (the decrement is not real);
            // so is one that gains as little where the predicted decrement is already
            // below 10·tol (within 0.3σ on every pixel), however damped: there the
            // remaining decrement cannot be realised (the `split` capture's shape-only
            // refit sat at a decrement of 0.018 while λ climbed to 10¹² and every
            // step gained nothing, until the stage's iterations ran out).
            let gain = acc.chi2 - chi2;
            let converged = gain < 1e-3 && (*lambda <= 1e-2 || decrement < 10.0 * tol);
            // Stalled: a nearly undamped step that realises under a tenth of what it
            // predicts and gains under STALL_FRACTION of the misfit's excess over the
            // noise (χ² − dof). The misfit is then the model's, not the optimizer's (a
            // cloudy sky the model cannot follow: the field sample's every-pixel stage
            // gained 0.03–0.3 % of its excess per iteration, a tenth of each prediction,
            // until its 20 iterations ran out), and further steps would not change
            // what its residual says. A fit that follows its data (excess near 0) is
            // never stopped by this.
            let excess = acc.chi2 - acc.n.saturating_sub(free.len()) as f64;
            let stalled = *lambda <= 1e-3 && gain < 0.1 * decrement && gain < STALL_FRACTION * excess;
            let converged = converged || stalled;
            *lambda = (*lambda * 0.1).max(1e-9);
            return Ok(Some((t, converged)));
        }
        // Where the undamped step predicts less than 1 in χ² (the parameters within 1σ
        // of the optimum along every combination), two damped steps that do not lower
        // χ² say the sums' precision is reached: more damping only shortens a step
        // that cannot gain what matters (every diagnosis refit ended on every pixel
        // at a decrement of 0.013–0.015 with twelve failed trials, a tenth of
        // diagnosing `berry`, measured).
        if decrement < 1.0 && trial >= 1 {
            break;
        }
        *lambda *= 10.0;
    }
    Ok(None)
}

/// A degenerate direction `d` (over the free slots, scaled) in words: the global
/// parameters it moves, and the per-frame ones by kind with the number of frames.
pub(crate) fn describe_null(pb: &Problem, free: &[usize], d: &[f64]) -> String {
    let big = 0.3 * d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut global = Vec::new();
    let mut per_frame: Vec<(String, usize)> = Vec::new();
    for (_, &i) in free.iter().enumerate().filter(|(j, _)| d[*j].abs() >= big) {
        match pb.slots.all[i].id {
            SlotId::Effect(p) => global.push(p.to_string()),
            SlotId::Frame { nuisance, .. } => {
                let kind = nuisance.name();
                match per_frame.iter_mut().find(|(k, _)| *k == kind) {
                    Some(e) => e.1 += 1,
                    None => per_frame.push((kind, 1)),
                }
            }
        }
    }
    if let ([one], []) = (&global[..], &per_frame[..]) {
        return format!("{one} does not change the model here (its first derivative vanishes at this value)");
    }
    let mut parts = global;
    parts.extend(per_frame.iter().map(|(k, n)| format!("{k} of {n} frame{}", if *n == 1 { "" } else { "s" })));
    format!("{} move together without changing the model: only their other combinations are measured", parts.join(", "))
}
