//! # `extinction_ratio` — the analyzers are partial polarizers
//!
//! ```text
//! I_k = ½[(1 + ε_k) I + (1 − ε_k)(Q cos 2θ_k + U sin 2θ_k)],   ε_k = 1/ER_k
//! ```
//!
//! Source: CONVENTIONS.md "Stokes and Mueller" (a partial polarizer of extinction
//! ratio ER = T_max/T_min, transmission normalised so that unpolarized light passes
//! ½I(1 + ε)). Units: ε dimensionless. Light polarized across channel k's axis
//! passes ε_k·I instead of 0 (tested). Folded on the host into the frame's analyzers
//! (no per-pixel twin). Reconstruction that assumes ε = 0 reads a DoLP too small by
//! (1 − ε) where all channels share ε, and a biased AoP where they differ.
//!
//! | param    | unit | neutral | fit bounds | physical |
//! |----------|------|---------|------------|----------|
//! | `eps0`   | 1    | 0       | [0, 0.5]   | [0, 0.1] |
//! | `eps45`  | 1    | 0       | [0, 0.5]   | [0, 0.1] |
//! | `eps90`  | 1    | 0       | [0, 0.5]   | [0, 0.1] |
//! | `eps135` | 1    | 0       | [0, 0.5]   | [0, 0.1] |
//!
//! Cannot: an extinction ratio that varies across the array or with wavelength, or
//! diattenuation that is not along the analyzer's axis.

use super::{Apply, EffectDef, Model, ParamSpec, Stage};

/// The range a real micro-polarizer's ε has. Engineering bound: ER ≥ 10; on-chip arrays
/// measure ER 43 (65-nm CMOS wire grid: Zhang et al. 2014, IEEE Trans. Electron Devices,
/// doi:10.1109/TED.2014.2299757) and commercial microgrid cameras of before the
/// IMX250MZR up to 30 (Hagen, Shibata & Otani 2019, Opt. Eng. 58(8) 082408); the
/// IMX250MZR's air-gap wire grid does better.
const EPS_PHYSICAL: (f64, f64) = (0.0, 0.1);

const fn eps(name: &'static str, typical: f64, doc: &'static str) -> ParamSpec {
    ParamSpec { name, unit: "1", neutral: 0.0, typical, min: 0.0, max: 0.5, physical: Some(EPS_PHYSICAL), doc }
}

pub const EFFECT: EffectDef = EffectDef {
    name: "extinction_ratio",
    summary: "each analyzer passes eps = 1/ER of the crossed polarization",
    source: "CONVENTIONS.md partial polarizer, eps = 1/ER",
    stage: Stage::Analyzer,
    params: &[
        eps("eps0", 0.01, "1/ER of the 0° analyzer"),
        eps("eps45", 0.02, "1/ER of the 45° analyzer"),
        eps("eps90", 0.01, "1/ER of the 90° analyzer"),
        eps("eps135", 0.02, "1/ER of the 135° analyzer"),
    ],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: None,
};

fn apply(v: &[f64], m: &mut Model) {
    for (e, x) in m.channels.analyzer_eps.iter_mut().zip(v) {
        *e += x;
    }
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::ideal_frame;
    use crate::effects::EffectSet;
    use crate::stokes::{analyzer_intensity, Stokes};

    #[test]
    fn crossed_light_leaks_eps_and_parallel_light_passes_whole() {
        let mut set = EffectSet::new();
        set.set("extinction_ratio", "eps90", 0.02).unwrap();
        let f = ideal_frame(&set.model());
        let horizontal = Stokes::new(1.0, 1.0, 0.0, 0.0);
        let vertical = Stokes::new(1.0, -1.0, 0.0, 0.0);
        assert!((analyzer_intensity(horizontal, &f.analyzers[2]) - 0.02).abs() < 1e-15);
        assert!((analyzer_intensity(vertical, &f.analyzers[2]) - 1.0).abs() < 1e-15);
        // The other channels are untouched.
        assert_eq!(analyzer_intensity(horizontal, &f.analyzers[0]), 1.0);
    }
}
