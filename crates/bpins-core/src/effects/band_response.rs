//! # `band_response` — each colour band's gain and analyzer extinction ratio
//!
//! ```text
//! g_b = q_b · g_G,   I_k,b = ½[(1 + ε_k + ε_b) I + (1 − ε_k − ε_b)(Q cos 2θ_k + U sin 2θ_k)]
//! ```
//!
//! Source: a colour-polarization sensor (Sony IMX250MYR) has a Bayer filter over each
//! 2 × 2 analyzer tile (CONVENTIONS.md); each band's response is its filter's
//! transmittance × the photodiode's quantum efficiency (EMVA 1288: the responsivity
//! η(λ)·K), and the wire-grid analyzers' extinction ratio falls toward the blue, where
//! the grid pitch is a larger fraction of the wavelength (Sony Semiconductor Solutions,
//! Polarsens IMX250MZR/MYR product information: extinction-ratio curves against λ;
//! wire-grid theory: Yu & Kwok 2003, J. Appl. Phys. 93 4407). ε_b adds to each
//! channel's ε_k (`extinction_ratio`): ε_k carries the channel-to-channel spread,
//! ε_b the wavelength. Units: dimensionless, gains relative to the green band's.
//! Acts only on a colour sensor's band frames (`ChainFrame::in_band`).
//!
//! | param   | unit | neutral | fit bounds | physical   |
//! |---------|------|---------|------------|------------|
//! | `qe_r`  | 1    | 1       | [0.05, 20] | [0.3, 1.5] |
//! | `qe_b`  | 1    | 1       | [0.05, 20] | [0.3, 1.5] |
//! | `eps_r` | 1    | 0       | [0, 0.5]   | [0, 0.1]   |
//! | `eps_g` | 1    | 0       | [0, 0.5]   | [0, 0.1]   |
//! | `eps_b` | 1    | 0       | [0, 0.5]   | [0, 0.1]   |
//!
//! Typical values are those of `samples/colour-clear` (QE R 0.60, G 0.75, B 0.50; ER R
//! 200, G 250, B 120). Crosstalk between neighbouring tiles (hence between bands) is
//! `crosstalk`, which on a colour sensor mixes each pixel with its neighbours as their
//! own bands see the sky (`simulate::render_colour_mosaic`). Cannot: spectral leakage
//! of a filter (red light through the green filter), a band's gain varying across the
//! array (PRNU does, alike for all bands).

use super::{Apply, EffectDef, Inseparable, Model, ParamSpec, SkyBlindness, Stage};

/// Physical ranges. Engineering bounds: Bayer-filtered CMOS peak responsivities of the
/// three bands lie within a factor of about 2 of each other (EMVA 1288 data sheets of
/// IMX250-based cameras); ε as `extinction_ratio`'s (ER ≥ 10).
const QE_PHYSICAL: (f64, f64) = (0.3, 1.5);
const EPS_PHYSICAL: (f64, f64) = (0.0, 0.1);

const fn qe(name: &'static str, typical: f64, doc: &'static str) -> ParamSpec {
    ParamSpec { name, unit: "1", neutral: 1.0, typical, min: 0.05, max: 20.0, physical: Some(QE_PHYSICAL), doc }
}

const fn eps(name: &'static str, typical: f64, doc: &'static str) -> ParamSpec {
    ParamSpec { name, unit: "1", neutral: 0.0, typical, min: 0.0, max: 0.5, physical: Some(EPS_PHYSICAL), doc }
}

pub const EFFECT: EffectDef = EffectDef {
    name: "band_response",
    summary: "colour sensor: each band's gain (QE × filter, relative to green) and the 1/ER its analyzers add",
    source: "Bayer filter × QE (EMVA 1288 responsivity); wire-grid ER falling toward the blue (Sony IMX250MYR)",
    stage: Stage::Sensor,
    params: &[
        qe("qe_r", 0.8, "the red band's gain (QE × filter transmittance) relative to green's"),
        qe("qe_b", 0.667, "the blue band's gain (QE × filter transmittance) relative to green's"),
        eps("eps_r", 0.005, "1/ER the red band's analyzers add to their channel's"),
        eps("eps_g", 0.004, "1/ER the green band's analyzers add to their channel's"),
        eps("eps_b", 0.0083, "1/ER the blue band's analyzers add to their channel's"),
    ],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: Some(Inseparable {
        when: SkyBlindness::Monochrome,
        why: |_| super::sky_spectrum::COLOUR_ONLY.to_string(),
    }),
};

fn apply(v: &[f64], m: &mut Model) {
    // Green (index 1) is the gain's reference.
    m.bands.gain[0] *= v[0];
    m.bands.gain[2] *= v[1];
    for (e, x) in m.bands.eps.iter_mut().zip(&v[2..5]) {
        *e += x;
    }
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::ChainFrame;
    use crate::effects::EffectSet;
    use crate::sensor::Band;
    use crate::stokes::{analyzer_intensity, Stokes};

    #[test]
    fn each_band_has_its_gain_and_its_analyzers_leak_its_eps() {
        let mut set = EffectSet::new();
        set.set("band_response", "qe_b", 0.5).unwrap();
        set.set("band_response", "eps_b", 0.01).unwrap();
        set.set("extinction_ratio", "eps90", 0.02).unwrap();
        let m = set.model();
        let sc = scene();
        let mono = ChainFrame::noise_free(&m, &intrinsics(), &sc);
        let blue = mono.clone().in_band(&m, &sc, Band::B);
        assert_eq!(blue.gain_dn.map(|g| g / mono.gain_dn[0]), [0.5; 4]);
        // Crossed light through the 90° analyzer: ε_90 + ε_b; through the 0°: ε_b.
        let horizontal = Stokes::new(1.0, 1.0, 0.0, 0.0);
        assert!((analyzer_intensity(horizontal, &blue.analyzers[2]) - 0.03).abs() < 1e-15);
        assert!((analyzer_intensity(Stokes::new(1.0, -1.0, 0.0, 0.0), &blue.analyzers[0]) - 0.01).abs() < 1e-15);
        // Red and green keep the monochrome frame's analyzers and gains.
        for b in [Band::R, Band::G] {
            assert_eq!(mono.clone().in_band(&m, &sc, b), mono, "{b:?}");
        }
    }
}
