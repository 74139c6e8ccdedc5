//! # `sky_spectrum` — a clear sky's radiance and DoLP differ from band to band
//!
//! ```text
//! I_b = r_b · I_G,   d_max,b = f_b · d_max,G        b ∈ {R, G, B}; r_G = f_G = 1
//! ```
//!
//! Source: a clear sky is Rayleigh's, whose scattering grows as λ⁻⁴, so its blue is
//! brighter than its red against a solar spectrum that is nearly flat across the visible
//! (Coulson 1988, *Polarization and Intensity of Light in the Atmosphere*, ch. 5). Its
//! peak DoLP falls toward the blue, where multiple scattering (stronger at short λ)
//! depolarizes, and toward the near-IR the ground's albedo takes over (Coulson 1988;
//! Pust & Shaw 2008, Appl. Opt. 47(34) H190: measured all-sky DoLP at 450–700 nm, its
//! maximum rising with wavelength). Frame: any (a band scale of the sky's Stokes vector
//! before the lens: `I`, `Q`, `U` by r_b, the polarized part by f_b through d_max).
//! Units: dimensionless, relative to the green band, whose radiance and d_max are the
//! scene's (`--dmax`). Acts only on a colour-polarization sensor's band frames
//! (`ChainFrame::in_band`); a monochrome sensor has no band and is untouched.
//!
//! | param        | unit | neutral | fit bounds  | physical    |
//! |--------------|------|---------|-------------|-------------|
//! | `radiance_r` | 1    | 1       | [0.05, 20]  | [0.2, 1.5]  |
//! | `radiance_b` | 1    | 1       | [0.05, 20]  | [0.7, 3]    |
//! | `dmax_r`     | 1    | 1       | [0.2, 2]    | [0.9, 1.3]  |
//! | `dmax_b`     | 1    | 1       | [0.2, 2]    | [0.6, 1.05] |
//!
//! Typical values are those of `samples/colour-clear` (radiance R 0.5, G 0.8, B 1.0;
//! d_max R 0.74, G 0.70, B 0.62), a clear blue sky of the kind the sources describe.
//! Cannot: a band's sky shape that differs from green's (the CIE gradation per band),
//! neutral points that move with wavelength, or a band finer than a filter's. The
//! radiance scale is applied as a gain of the band's frame; a field scene's clouds,
//! deck and sun disc add white light (r = 1 in every band), scaled by 1/r_b before
//! that gain (`FieldFrame::white_over_sky`), so they are whiter than the sky.

use super::{Apply, EffectDef, Inseparable, Model, ParamSpec, SkyBlindness, Stage};

/// Physical ranges. Engineering bounds from the sources above: between 465 and 615 nm a
/// λ⁻⁴ sky changes by 3×, a hazy one by less; measured clear-sky peak DoLP differs by
/// a few tenths of itself between blue and red (Pust & Shaw 2008).
const RADIANCE_R_PHYSICAL: (f64, f64) = (0.2, 1.5);
const RADIANCE_B_PHYSICAL: (f64, f64) = (0.7, 3.0);
const DMAX_R_PHYSICAL: (f64, f64) = (0.9, 1.3);
const DMAX_B_PHYSICAL: (f64, f64) = (0.6, 1.05);

pub const EFFECT: EffectDef = EffectDef {
    name: "sky_spectrum",
    summary: "colour sensor: the sky's radiance and d_max per band, relative to green (a clear sky: bluer, less polarized in the blue)",
    source: "Rayleigh λ⁻⁴ radiance, peak DoLP rising with λ (Coulson 1988; Pust & Shaw 2008, Appl. Opt. 47 H190)",
    stage: Stage::Sky,
    params: &[
        ParamSpec {
            name: "radiance_r",
            unit: "1",
            neutral: 1.0,
            typical: 0.625,
            min: 0.05,
            max: 20.0,
            physical: Some(RADIANCE_R_PHYSICAL),
            doc: "the sky's radiance in the red band relative to green's",
        },
        ParamSpec {
            name: "radiance_b",
            unit: "1",
            neutral: 1.0,
            typical: 1.25,
            min: 0.05,
            max: 20.0,
            physical: Some(RADIANCE_B_PHYSICAL),
            doc: "the sky's radiance in the blue band relative to green's",
        },
        ParamSpec {
            name: "dmax_r",
            unit: "1",
            neutral: 1.0,
            typical: 1.057,
            min: 0.2,
            max: 2.0,
            physical: Some(DMAX_R_PHYSICAL),
            doc: "factor on the sky's d_max in the red band (green's is the scene's)",
        },
        ParamSpec {
            name: "dmax_b",
            unit: "1",
            neutral: 1.0,
            typical: 0.886,
            min: 0.2,
            max: 2.0,
            physical: Some(DMAX_B_PHYSICAL),
            doc: "factor on the sky's d_max in the blue band (green's is the scene's)",
        },
    ],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: Some(Inseparable { when: SkyBlindness::Monochrome, why: |_| COLOUR_ONLY.to_string() }),
};

/// Why a monochrome sky capture's fit cannot measure a band parameter.
pub(crate) const COLOUR_ONLY: &str = "it acts only on a colour sensor's bands (colour_tiles), and a monochrome \
     capture has one band; the fit and the diagnosis of a colour capture, which model each pixel through its own \
     band, measure it";

fn apply(v: &[f64], m: &mut Model) {
    // Green (index 1) is the reference: only red (0) and blue (2) are parameters.
    m.bands.radiance[0] *= v[0];
    m.bands.radiance[2] *= v[1];
    m.bands.dmax_factor[0] *= v[2];
    m.bands.dmax_factor[2] *= v[3];
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::{pixel_stokes, ChainFrame};
    use crate::effects::EffectSet;
    use crate::sensor::Band;

    #[test]
    fn scales_each_band_and_leaves_green_and_the_mono_frame_alone() {
        let mut set = EffectSet::new();
        for p in super::EFFECT.params {
            set.set("sky_spectrum", p.name, p.typical).unwrap();
        }
        let m = set.model();
        let sc = scene();
        let mono = ChainFrame::noise_free(&m, &intrinsics(), &sc);
        // The monochrome frame is the ideal one, bitwise.
        assert_eq!(mono, ChainFrame::noise_free(&Default::default(), &intrinsics(), &sc));
        let band = |b| mono.clone().in_band(&m, &sc, b);
        // Green is the scene: the same frame, bitwise.
        assert_eq!(band(Band::G), mono);
        let (u, v) = (20.0, 15.0);
        let g = pixel_stokes(&band(Band::G), u, v);
        for (b, r, f) in [(Band::R, 0.625, 1.057), (Band::B, 1.25, 0.886)] {
            let fb = band(b);
            assert_eq!(fb.dmax, sc.dmax * f);
            // Radiance scales the gain behind every channel (the chain is linear before
            // the sensor), the DoLP scales with d_max.
            assert!(fb.gain_dn.iter().zip(&mono.gain_dn).all(|(a, m)| (a / m - r).abs() < 1e-15));
            let s = pixel_stokes(&fb, u, v);
            assert!((s.i - g.i).abs() < 1e-15);
            assert!((s.dolp() / g.dolp() - f).abs() < 1e-12, "{b:?}: {} vs {}", s.dolp(), g.dolp());
        }
    }
}
