//! A fit on the subsample only: the optimum on every [`lm::SUBSAMPLE_STRIDE`]-th row
//! and column (all channels), within 1σ there, and its χ² on those samples. A
//! diagnosis ranks each step's candidates with it (their Δχ² on the subsample
//! against the base model's own subsampled optimum) and converges on every pixel only
//! the ones whose ranking, acceptance or reported numbers need it
//! (the diagnosis's `converge`), warm-started from here.

use crate::capture::Capture;
use crate::error::Result;
use crate::fit::input::frames::FitFrames;
use crate::fit::input::noise::NoiseModel;
use crate::fit::model::problem::problem;
use crate::fit::solver::lm;
use crate::fit::{FitOptions, FitState, Param};

/// The subsampled optimum of a model.
#[derive(Clone, Debug)]
pub(crate) struct SubFit {
    /// Where it ended (a warm start for every pixel).
    pub state: FitState,
    /// χ² on the subsample there (no unit).
    pub chi2: f64,
    /// Samples of the subsample.
    pub samples: usize,
    /// Independent combinations of the free parameters the subsample constrains.
    pub rank: usize,
    /// The effects' parameters there, each with its 1σ from the subsample's JᵀWJ
    /// (not widened for correlated residuals: a ranking's figure, not a result).
    pub params: Vec<Param>,
}

/// Fits `opts` on the subsample from `start` under the sensor noise `noise` (the
/// base model's: every fit of a diagnosis weighs the samples alike).
pub(crate) fn fit_subsampled(
    c: &Capture,
    frames: &FitFrames,
    opts: &FitOptions,
    start: &FitState,
    noise: NoiseModel,
) -> Result<SubFit> {
    let (pb, theta) = problem(c, frames, opts, Some(start), noise)?;
    let (theta, _, last) = lm::minimise_subsampled(&pb, theta)?;
    let acc = match last {
        Some(acc) => acc,
        None => pb.accumulate(&theta, lm::SUBSAMPLE_STRIDE, true)?,
    };
    let free = pb.slots.free();
    let cov = crate::fit::solver::schur::BlockInverse::new(&acc.sys);
    let sigma = |i: usize| free.binary_search(&i).map_or(0.0, |p| cov.sigma(p));
    let effect_values = pb.effect_values(&theta);
    let params = effect_values
        .iter()
        .enumerate()
        .map(|(i, &(id, value))| Param::new(id, pb.slots.all[i].unit, value, sigma(i)))
        .collect();
    Ok(SubFit {
        state: FitState {
            effect_values,
            frames: (0..frames.len()).map(|k| pb.slots.frame(k).map(|i| theta[i])).collect(),
            radiance_basis: pb.basis.clone(),
        },
        chi2: acc.chi2,
        samples: acc.n,
        rank: cov.rank(),
        params,
    })
}
