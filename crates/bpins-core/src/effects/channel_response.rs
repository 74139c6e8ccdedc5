//! # `channel_response` — each analyzer channel has its own gain and offset
//!
//! ```text
//! DN_k = g·(1 + gain_k)·I_θk + b + offset_k_dn     (gain_0 ≡ 0: channel 0 is the reference)
//! ```
//!
//! Source: seed paper §2.2 eq. 11 (EMVA 1288 linear response; "CMOS grayscale
//! response inconsistency"). Units: gains relative (1), offsets DN. The seed's
//! Monte Carlo draws the inconsistency per *pixel* (σ = 1 DN): that per-pixel part
//! is the sensor's DSNU/PRNU (`sensor::Response::{dsnu_dn, prnu}`), random and not
//! fittable; this effect is its systematic per-channel part, which a fit can recover.
//!
//! | param                          | unit | neutral | fit bounds | physical |
//! |--------------------------------|------|---------|------------|----------|
//! | `gain45`, `gain90`, `gain135`  | 1    | 0       | −0.5…0.5   | ±0.1     |
//! | `offset0_dn` … `offset135_dn`  | DN   | 0       | ±1000      | ±50      |
//!
//! Physical ranges: the channels of a micro-polarizer sensor share one pixel design and
//! one black-level clamp, so their gains differ by a few per cent and their dark
//! offsets by a few DN; ±10 % and ±50 DN are generous bounds. A fitted value beyond them
//! (a −176 DN offset: a black level below zero on a 64 DN sensor) is the parameter
//! standing in for a misfit it does not describe, flagged by the diagnosis.
//!
//! Cannot: non-linear response, gains that vary across the sensor (vignetting is a
//! separate effect), or a gain on channel 0 (it is the intensity scale).

use super::{Apply, EffectDef, Model, ParamDerivative, ParamSpec, Stage};

/// The range a real sensor's relative channel gain has (module doc).
const GAIN_PHYSICAL: (f64, f64) = (-0.1, 0.1);
/// The range a real sensor's per-channel dark offset has, DN (module doc).
const OFFSET_PHYSICAL_DN: (f64, f64) = (-50.0, 50.0);

pub const EFFECT: EffectDef = EffectDef {
    name: "channel_response",
    summary: "relative gain (1 + gain_k) of each channel against channel 0 and its offset (seed: CMOS grayscale inconsistency)",
    source: "seed paper §2.2 eq. 11 (EMVA 1288)",
    stage: Stage::Sensor,
    params: &[
        ParamSpec { name: "gain45", unit: "1", neutral: 0.0, typical: 0.02, min: -0.5, max: 0.5, physical: Some(GAIN_PHYSICAL), doc: "relative gain of the 45° channel" },
        ParamSpec { name: "gain90", unit: "1", neutral: 0.0, typical: -0.01, min: -0.5, max: 0.5, physical: Some(GAIN_PHYSICAL), doc: "relative gain of the 90° channel" },
        ParamSpec { name: "gain135", unit: "1", neutral: 0.0, typical: 0.015, min: -0.5, max: 0.5, physical: Some(GAIN_PHYSICAL), doc: "relative gain of the 135° channel" },
        ParamSpec { name: "offset0_dn", unit: "DN", neutral: 0.0, typical: 1.0, min: -1000.0, max: 1000.0, physical: Some(OFFSET_PHYSICAL_DN), doc: "offset of the 0° channel" },
        ParamSpec { name: "offset45_dn", unit: "DN", neutral: 0.0, typical: -2.0, min: -1000.0, max: 1000.0, physical: Some(OFFSET_PHYSICAL_DN), doc: "offset of the 45° channel" },
        ParamSpec { name: "offset90_dn", unit: "DN", neutral: 0.0, typical: 5.0, min: -1000.0, max: 1000.0, physical: Some(OFFSET_PHYSICAL_DN), doc: "offset of the 90° channel" },
        ParamSpec { name: "offset135_dn", unit: "DN", neutral: 0.0, typical: 3.0, min: -1000.0, max: 1000.0, physical: Some(OFFSET_PHYSICAL_DN), doc: "offset of the 135° channel" },
    ],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[
        ParamDerivative::Secant,
        ParamDerivative::Secant,
        ParamDerivative::Secant,
        ParamDerivative::ChannelOffset(0),
        ParamDerivative::ChannelOffset(1),
        ParamDerivative::ChannelOffset(2),
        ParamDerivative::ChannelOffset(3),
    ],
    inseparable: None,
};

fn apply(v: &[f64], m: &mut Model) {
    for k in 1..4 {
        m.channels.gain[k] += v[k - 1];
    }
    for k in 0..4 {
        m.channels.offset_dn[k] += v[3 + k];
    }
}

#[cfg(test)]
mod tests {
    use crate::effects::EffectSet;

    #[test]
    fn folds_gains_and_offsets_by_channel() {
        let mut set = EffectSet::new();
        set.set("channel_response", "gain90", 0.02).unwrap();
        set.set("channel_response", "offset45_dn", -3.0).unwrap();
        let m = set.model();
        assert_eq!(m.channels.gain, [1.0, 1.0, 1.02, 1.0]);
        assert_eq!(m.channels.offset_dn, [0.0, -3.0, 0.0, 0.0]);
    }
}
