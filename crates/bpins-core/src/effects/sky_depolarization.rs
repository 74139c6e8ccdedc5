//! # `sky_depolarization` — the sky is less polarized than the scene says
//!
//! ```text
//! d_max,true = d_max,scene · dmax            DoLP(γ) = d_max,true · sin²γ / (1 + cos²γ)
//! ```
//!
//! Source: seed paper §2.1 eq. 2 (single-scattering Rayleigh with peak DoLP d_max;
//! multiple scattering, aerosols and ground albedo lower it). The parameter is a
//! factor on the scene's d_max (0.6 in the samples), so its neutral value 1 leaves
//! the chain exactly ideal. Units: dimensionless. Changes every DoLP by the same
//! factor and no AoP (tested). Folded on the host (no per-pixel twin).
//!
//! | param  | unit | neutral | fit bounds | physical |
//! |--------|------|---------|------------|----------|
//! | `dmax` | 1    | 1       | [0, 1.6]   | [0, 1.4] |
//!
//! Cannot: a depolarization that varies over the sky (near the horizon, around
//! clouds), or the neutral points (that is `sky_neutral_points`).

use super::{Apply, EffectDef, Inseparable, Model, ParamSpec, SkyBlindness, Stage};

/// The range a real sky's d_max has, as a factor on the scene's (0.6 by default). Clear
/// skies peak below a DoLP of about 0.8 (Coulson 1988, *Polarization and Intensity of Light
/// in the Atmosphere*), 1.33 times 0.6; ≤ 1.4 holds that; overcast skies go to 0.
const DMAX_PHYSICAL: (f64, f64) = (0.0, 1.4);

pub const EFFECT: EffectDef = EffectDef {
    name: "sky_depolarization",
    summary: "peak degree of polarization of the sky, as a factor on the scene's d_max",
    source: "seed paper §2.1 eq. 2 (Rayleigh d_max)",
    stage: Stage::Sky,
    params: &[ParamSpec {
        name: "dmax",
        unit: "1",
        neutral: 1.0,
        typical: 0.8,
        min: 0.0,
        max: 1.6,
        physical: Some(DMAX_PHYSICAL),
        doc: "factor on the scene's peak DoLP (the true d_max is scene d_max × dmax ≤ 1)",
    }],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: Some(Inseparable {
        when: SkyBlindness::FreeDmax,
        why: |_| {
            "a factor on the sky's d_max, which each frame fits: give the sky's d_max (--fixed-dmax) to measure it"
                .to_string()
        },
    }),
};

fn apply(v: &[f64], m: &mut Model) {
    m.sky_block.dmax_factor *= v[0];
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::{ideal_frame, stokes_at};
    use crate::effects::{EffectSet, Model};

    #[test]
    fn every_dolp_scales_and_no_aop_moves() {
        let mut set = EffectSet::new();
        set.set("sky_depolarization", "dmax", 0.8).unwrap();
        let (dep, ideal) = (ideal_frame(&set.model()), ideal_frame(&Model::default()));
        assert!((dep.dmax - 0.48).abs() < 1e-15);
        for (u, v) in [(5.0, 7.0), (305.0, 255.0), (600.0, 20.0)] {
            let (a, b) = (stokes_at(&dep, u, v), stokes_at(&ideal, u, v));
            assert_eq!(a.i, b.i);
            assert!((a.dolp() - 0.8 * b.dolp()).abs() < 1e-12);
            assert!((a.aop_rad() - b.aop_rad()).abs() < 1e-12);
        }
    }
}
