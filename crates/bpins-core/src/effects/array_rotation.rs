//! # `array_rotation` — the whole micro-polarizer array is rotated
//!
//! ```text
//! θ_k,true = θ_k,nominal + dtheta_deg        for every channel k
//! ```
//!
//! Source: seed paper §2.2 eq. 9 (installation angle error δθ of the
//! micro-polarization array). Frame: image angles, counter-clockwise as displayed,
//! degrees. Reconstruction that assumes the nominal angles reads every AoP
//! exactly dtheta smaller (tested below), DoLP and intensity unchanged.
//!
//! | param        | unit | neutral | fit bounds | physical |
//! |--------------|------|---------|------------|----------|
//! | `dtheta_deg` | deg  | 0       | ±90        | ±5       |
//!
//! Cannot: per-channel errors (that is `analyzer_angles`) or a rotation that varies
//! across the array.

use super::{Apply, EffectDef, Model, ParamSpec, Stage};

/// The range a real array's rotation against the pixel grid has, degrees. Engineering
/// bound: an on-chip array (IMX250MZR) is aligned to its pixels by lithography, a bonded
/// one to within about a degree; beyond ±5° the layout is not the nominal one or the
/// value stands in for a misfit.
const ROTATION_PHYSICAL_DEG: (f64, f64) = (-5.0, 5.0);

pub const EFFECT: EffectDef = EffectDef {
    name: "array_rotation",
    summary: "every analyzer rotated by the same angle (seed: installation angle error)",
    source: "seed paper §2.2 eq. 9",
    stage: Stage::Analyzer,
    params: &[ParamSpec {
        name: "dtheta_deg",
        unit: "deg",
        neutral: 0.0,
        typical: 0.5,
        min: -90.0,
        max: 90.0,
        physical: Some(ROTATION_PHYSICAL_DEG),
        doc: "rotation of the array, counter-clockwise as displayed",
    }],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: None,
};

fn apply(v: &[f64], m: &mut Model) {
    for d in &mut m.channels.analyzer_delta_deg {
        *d += v[0];
    }
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::{ideal_frame, stokes_at};
    use crate::conventions::wrap_deg_90;
    use crate::effects::EffectSet;
    use crate::recon::Reconstructor;
    use crate::sensor::Channel;

    #[test]
    fn every_aop_shifts_by_exactly_minus_dtheta() {
        let mut set = EffectSet::new();
        set.set("array_rotation", "dtheta_deg", 0.3).unwrap();
        let rotated = ideal_frame(&set.model());
        let nominal = Reconstructor::new(&EffectSet::new().model(), 0.0, &Channel::ALL).unwrap();
        for (u, v) in [(5.0, 7.0), (305.0, 255.0), (600.0, 20.0), (100.0, 500.0)] {
            let s = stokes_at(&rotated, u, v);
            let dn = rotated.analyzers.map(|a| crate::stokes::analyzer_intensity(s, &a));
            let got = nominal.stokes(&dn);
            let d_aop = wrap_deg_90(got.aop_rad().to_degrees() - s.aop_rad().to_degrees());
            assert!((d_aop + 0.3).abs() < 1e-9, "Δα = {d_aop}°");
            assert!((got.dolp() - s.dolp()).abs() < 1e-12);
        }
        let _ = ideal_frame(&EffectSet::new().model());
        let _ = stokes_at;
    }
}
