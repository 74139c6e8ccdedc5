//! What one effect changes in a fitted model, in the user's units: the model evaluated
//! at a fit's parameters with and without the effect (its parameters at neutral, every
//! other parameter — headings, d_max, radiance — as fitted), compared sample by sample.
//!
//! ```text
//! ΔAoP(p)  = AoP_with(p) − AoP_without(p)     degrees, wrapped to ±90°, where the model DoLP > 0.01
//! ΔDoLP(p) = DoLP_with(p) − DoLP_without(p)
//! ΔDN(p)   = max over channels |DN_with(p) − DN_without(p)|
//! ```
//!
//! RMS of ΔAoP and ΔDoLP over the usable polarization samples of every frame (DoFP
//! superpixels, colocated pixels; nominal inversion, `recon::Reconstructor`), and the
//! largest ΔDN. What it cannot say: the change to the heading — the heading is refitted
//! with the effect, so that change is the difference of two fits' headings
//! (the diagnosis's `sizes`), not of two evaluations.

use crate::capture::Capture;
use crate::error::{Error, Result};
use crate::fit::input::frames::FitFrames;
use crate::fit::input::noise::NoiseModel;
use crate::fit::model::problem::problem;
use crate::fit::output::residuals::{for_each_sample, pol_residual};
use crate::fit::{FitOptions, FitState};
use crate::recon::Reconstructor;
use rayon::prelude::*;

/// An effect's change to the fitted model.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ModelChange {
    /// RMS change of the model AoP, degrees.
    pub aop_rms_deg: f64,
    /// RMS change of the model DoLP.
    pub dolp_rms: f64,
    /// Largest change of one pixel's model DN.
    pub max_dn: f64,
}

/// The change `effect` (one of `opts.effects`) makes to the model of `state` under
/// `opts`, on every `stride`-th polarization sample along each axis.
pub fn effect_change(
    c: &Capture,
    frames: &FitFrames,
    opts: &FitOptions,
    state: &FitState,
    effect: &str,
    noise: NoiseModel,
    stride: usize,
) -> Result<ModelChange> {
    let def = opts
        .effects
        .iter()
        .find(|e| e.name == effect)
        .ok_or_else(|| Error::NotInModel { effect: effect.to_string() })?;
    let (pb, with) = problem(c, frames, opts, Some(state), noise)?;
    let mut without = with.clone();
    for (i, p) in pb.slots.of_effect(effect).zip(def.params) {
        without[i] = p.neutral;
    }
    let rec = Reconstructor::new(&Default::default(), c.sensor.black_level_dn, &c.sensor.channels())?;
    let per_frame = (0..frames.len())
        .into_par_iter()
        .map(|k| {
            let (fw, fo) = (pb.chain(&with, k)?, pb.chain(&without, k)?);
            // (Σ ΔAoP², n_aop, Σ ΔDoLP², n, max ΔDN)
            let mut s = (0.0, 0usize, 0.0, 0usize, 0.0f64);
            for_each_sample(&pb, k, stride, &[&fw, &fo], |_, _, [_, a, b]| {
                let (da, dd, _) = pol_residual(&rec, a, b);
                if let Some(d) = da {
                    s.0 += d * d;
                    s.1 += 1;
                }
                s.2 += dd * dd;
                s.3 += 1;
                s.4 = a.iter().zip(b).fold(s.4, |m, (x, y)| m.max((x - y).abs()));
            });
            Ok(s)
        })
        .collect::<Result<Vec<_>>>()?;
    let (mut sa, mut na, mut sd, mut nd, mut max_dn) = (0.0, 0, 0.0, 0, 0.0f64);
    for s in per_frame {
        (sa, na, sd, nd, max_dn) = (sa + s.0, na + s.1, sd + s.2, nd + s.3, max_dn.max(s.4));
    }
    let rms = |s: f64, n: usize| if n > 0 { (s / n as f64).sqrt() } else { 0.0 };
    Ok(ModelChange { aop_rms_deg: rms(sa, na), dolp_rms: rms(sd, nd), max_dn })
}
