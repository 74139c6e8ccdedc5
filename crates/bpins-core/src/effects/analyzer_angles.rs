//! # `analyzer_angles` — each analyzer channel off its nominal angle by its own amount
//!
//! ```text
//! θ_k,true = θ_k,nominal + d_k            k = 0°, 45°, 90°, 135°
//! I_k = ½[(1 + ε_k) I + (1 − ε_k)(Q cos 2θ_k + U sin 2θ_k)]
//! ```
//!
//! Source: seed paper §2.2 eq. 7–9 (the analyzer's transmission axis; the seed's
//! installation error generalised to one error per channel, as manufacturing
//! tolerances of a micro-polarizer array are); CONVENTIONS.md (image angles,
//! counter-clockwise as displayed). Folded on the host into the frame's analyzers
//! (no per-pixel twin). Equal d_k is exactly `array_rotation` (tested); unequal d_k
//! bias the AoP by an amount that depends on the AoP itself, and leak intensity into
//! the DoLP.
//!
//! | param      | unit | neutral | fit bounds | physical |
//! |------------|------|---------|------------|----------|
//! | `d0_deg`   | deg  | 0       | ±45        | ±5       |
//! | `d45_deg`  | deg  | 0       | ±45        | ±5       |
//! | `d90_deg`  | deg  | 0       | ±45        | ±5       |
//! | `d135_deg` | deg  | 0       | ±45        | ±5       |
//!
//! Cannot: errors that vary across the array (per pixel), or a retardance of the
//! analyzers.

use super::{Apply, EffectDef, Model, ParamSpec, Stage};

/// The range a real array's per-channel angle error has, degrees. Engineering bound: no
/// datasheet (Sony IMX250MZR, Lucid PHX050S) states an angle tolerance; the four grids
/// are drawn by one lithographic mask, so a channel's mean error is a mask or alignment
/// error far below 5°; beyond it the channel is not the nominal angle's (a wrong mosaic
/// layout) or the value stands in for a misfit.
const ANGLE_PHYSICAL_DEG: (f64, f64) = (-5.0, 5.0);

const fn angle(name: &'static str, typical: f64, doc: &'static str) -> ParamSpec {
    ParamSpec {
        name,
        unit: "deg",
        neutral: 0.0,
        typical,
        min: -45.0,
        max: 45.0,
        physical: Some(ANGLE_PHYSICAL_DEG),
        doc,
    }
}

pub const EFFECT: EffectDef = EffectDef {
    name: "analyzer_angles",
    summary: "each analyzer channel off its nominal angle by its own amount",
    source: "seed paper §2.2 eq. 7–9, per channel",
    stage: Stage::Analyzer,
    params: &[
        angle("d0_deg", 0.3, "angle error of the 0° analyzer"),
        angle("d45_deg", 1.0, "angle error of the 45° analyzer"),
        angle("d90_deg", -0.4, "angle error of the 90° analyzer"),
        angle("d135_deg", -0.6, "angle error of the 135° analyzer"),
    ],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: None,
};

fn apply(v: &[f64], m: &mut Model) {
    for (d, x) in m.channels.analyzer_delta_deg.iter_mut().zip(v) {
        *d += x;
    }
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::ideal_frame;
    use crate::effects::EffectSet;
    use crate::sensor::Channel;
    use crate::stokes::Analyzer;

    #[test]
    fn each_channel_moves_by_its_own_angle_and_equal_angles_are_array_rotation() {
        let mut set = EffectSet::new();
        for (p, d) in ["d0_deg", "d45_deg", "d90_deg", "d135_deg"].iter().zip([0.5, -0.3, 0.0, 1.0]) {
            set.set("analyzer_angles", p, d).unwrap();
        }
        let f = ideal_frame(&set.model());
        for (c, d) in Channel::ALL.iter().zip([0.5, -0.3, 0.0, 1.0]) {
            assert_eq!(f.analyzers[c.index()], Analyzer::at(c.angle_deg(), d, 0.0), "{c:?}");
        }
        let (mut equal, mut rotation) = (EffectSet::new(), EffectSet::new());
        for p in ["d0_deg", "d45_deg", "d90_deg", "d135_deg"] {
            equal.set("analyzer_angles", p, 0.25).unwrap();
        }
        rotation.set("array_rotation", "dtheta_deg", 0.25).unwrap();
        assert_eq!(equal.model(), rotation.model());
    }
}
