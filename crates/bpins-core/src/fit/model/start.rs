//! Starting guesses: where a fit begins when no warm start names a value. Effects at
//! neutral; each frame's heading at its reference, else the field estimator's (from
//! the sky mask), else the sun-vector extractor's on the whole frame; d_max 0.5
//! (or the given one); no radiance shape; a twilight's second sky at the model's weight
//! (strength 1); the radiance scale that fits best (linear).

use crate::error::{Error, Result};
use crate::fit::model::problem::Problem;
use crate::fit::model::radiance;
use crate::fit::model::slots::{EffectParam, Nuisance, PER_FRAME};
use crate::fit::FitState;
use crate::heading::field::SkyMask;

/// The parameter vector to start from: `warm`'s values where it has them (effects by
/// parameter, frames by index), else the guesses above (the scale at 1: see [`scale`]).
pub(crate) fn theta(pb: &Problem, warm: Option<&FitState>, field: &[Option<SkyMask>]) -> Result<Vec<f64>> {
    let opts = pb.opts;
    let mut theta = Vec::with_capacity(pb.slots.all.len());
    for e in &opts.effects {
        for p in e.params {
            let id = EffectParam { effect: e.name, param: p.name };
            let value = warm.and_then(|s| s.effect_values.iter().find(|(n, _)| *n == id)).map_or(p.neutral, |x| x.1);
            theta.push(value);
        }
    }
    for (k, spec) in pb.capture.frames.iter().enumerate() {
        let warm = warm.and_then(|s| s.frames.get(k));
        let heading = match (warm, spec.heading_deg, &field[k]) {
            (Some(w), _, _) => w[0],
            (None, Some(h), _) => h,
            (None, None, Some(m)) => m.heading_deg,
            (None, None, None) => heading(pb, k)?,
        };
        let mut frame = [0.0; PER_FRAME];
        for n in Nuisance::all() {
            frame[n.index()] = match n {
                Nuisance::Heading => heading,
                Nuisance::Scale => warm.map_or(1.0, |w| w[n.index()]),
                Nuisance::Dmax => opts.fixed_dmax.or(warm.map(|w| w[n.index()])).unwrap_or(0.5),
                Nuisance::Radiance(_) if opts.rayleigh_radiance => 0.0,
                Nuisance::Radiance(_) => warm.map_or(0.0, |w| w[n.index()]),
                // The model's weight of a second sky as it is (1 where there is none).
                Nuisance::Twilight => warm.map_or(1.0, |w| w[n.index()]),
            };
        }
        theta.extend(frame);
    }
    Ok(theta)
}

/// First heading guess of frame `k` without a reference: the sun-vector extractor on
/// the whole frame.
fn heading(pb: &Problem, k: usize) -> Result<f64> {
    pb.frames.first_heading(pb.capture, k)
}

/// Each frame's radiance basis, orthonormal over its sky at the start (every 4th
/// pixel).
pub(crate) fn radiance_bases(pb: &Problem, theta: &[f64]) -> Result<Vec<radiance::Basis>> {
    (0..pb.frames.len())
        .map(|k| {
            let f = pb.chain(theta, k)?;
            let (w, h) = (pb.w(), pb.h());
            let at = (0..h).step_by(4).flat_map(|v| (0..w).step_by(4).map(move |u| (u, v)));
            let sky = at.filter(|&(u, v)| pb.usable(k, u, v, 1.0));
            Ok(radiance::Basis::orthonormal(sky.map(|(u, v)| radiance::raw_at(&f.intr, f.sun_cam, u, v, w, h))))
        })
        .collect()
}

/// The radiance scale that fits frame `k` best with the rest of `theta` (linear: the
/// model at unit scale, the black level taken as the offset, every 7th row and column
/// of the pixels the frames hold).
pub(crate) fn scale(pb: &Problem, theta: &[f64], k: usize) -> Result<f64> {
    let mut t = theta.to_vec();
    t[pb.slots.at(k, Nuisance::Scale)] = 1.0;
    let f = pb.chain(&t, k)?;
    let black = pb.capture.sensor.black_level_dn;
    let (mut sy, mut ss) = (0.0, 0.0);
    let mut buf = Vec::new();
    for (u, v) in pb.frames.parts(k, 7).into_iter().flat_map(|r| r.points(7)) {
        pb.pixel(&f, k, u, v, &mut buf);
        for &(y, m) in buf.iter().filter(|(y, _)| pb.usable(k, u, v, *y)) {
            sy += (y - black) * (m - black);
            ss += (m - black) * (m - black);
        }
    }
    if ss.is_nan() || ss <= 0.0 {
        return Err(Error::TooFewSamples(format!("frame {k}: no usable pixels to fit")));
    }
    Ok((sy / ss).max(1e-6))
}
