//! # `sky_neutral_spectrum` — the sky's neutral points stand farther apart in the blue
//!
//! ```text
//! s_b = m_b · s_G        b ∈ {R, G, B}; m_G = 1
//! ```
//!
//! s is `sky_neutral_points`'s separation of each pair of neutral points (the Berry,
//! Dennis & Lee quartic sky), m_b the band's factor on it. Source: the neutral points
//! are the mark of multiple scattering on a single-scattering (Rayleigh) sky (Berry,
//! Dennis & Lee, New J. Phys. 6, 162 (2004) §1–2); their distance from the sun and the
//! anti-sun grows with the atmosphere's optical thickness (Coulson 1988, *Polarization
//! and Intensity of Light in the Atmosphere*, ch. 5: the Arago distance as a turbidity
//! measure), and Rayleigh's optical thickness goes as λ^−4.08, so the same sky's pairs
//! split wider in the blue than in the red. Frame: ENU world (the quartic sky's chart),
//! as `sky_neutral_points`. Units: dimensionless, relative to the green band's
//! separation, which is `sky_neutral_points.separation_deg`. Acts only on a colour
//! sensor's band frames (`ChainFrame::in_band`, through the band block's
//! `multiple_scattering`, which the frame's sky effects read from `FrameContext`) and
//! only where `sky_neutral_points` is on: without neutral points it changes nothing.
//!
//! | param          | unit | neutral | fit bounds | physical    |
//! |----------------|------|---------|------------|-------------|
//! | `separation_r` | 1    | 1       | [0.2, 3]   | [0.5, 1.0]  |
//! | `separation_b` | 1    | 1       | [0.2, 3]   | [1.0, 1.75] |
//!
//! Typical values (R 0.8, B 1.25) are an engineering choice between the physical bounds
//! (about the square root of Rayleigh's optical-thickness ratio); no measurement of
//! band-resolved neutral-point positions was at hand here. Cannot: a pair that moves
//! differently about the sun and the anti-sun, a band's depolarization (that is
//! `sky_spectrum`'s d_max factor), or a neutral point's shift with aerosol rather than
//! molecular optical thickness (whose spectral slope is far flatter, Ångström α ≈ 1).

use super::{Apply, EffectDef, Inseparable, Model, ParamSpec, SkyBlindness, Stage};

/// Physical ranges. Engineering bounds: between the same separation in every band and
/// one proportional to Rayleigh's optical thickness, (λ_G/λ_b)^4.08 at the IMX250MYR's
/// band centres (R 615, G 530, B 465 nm; CAPTURE.md `band_centre_nm`): R 0.54, B 1.70.
const SEPARATION_R_PHYSICAL: (f64, f64) = (0.5, 1.0);
const SEPARATION_B_PHYSICAL: (f64, f64) = (1.0, 1.75);

pub const EFFECT: EffectDef = EffectDef {
    name: "sky_neutral_spectrum",
    summary: "colour sensor: the neutral points' separation per band, relative to green (wider in the blue)",
    source: "neutral-point distance grows with optical thickness (Coulson 1988 ch. 5), Rayleigh's as λ^-4",
    stage: Stage::Sky,
    params: &[
        ParamSpec {
            name: "separation_r",
            unit: "1",
            neutral: 1.0,
            typical: 0.8,
            min: 0.2,
            max: 3.0,
            physical: Some(SEPARATION_R_PHYSICAL),
            doc: "factor on the neutral points' separation in the red band (green's is sky_neutral_points')",
        },
        ParamSpec {
            name: "separation_b",
            unit: "1",
            neutral: 1.0,
            typical: 1.25,
            min: 0.2,
            max: 3.0,
            physical: Some(SEPARATION_B_PHYSICAL),
            doc: "factor on the neutral points' separation in the blue band (green's is sky_neutral_points')",
        },
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
    // Green (index 1) is the reference: only red (0) and blue (2) are parameters.
    m.bands.multiple_scattering[0] *= v[0];
    m.bands.multiple_scattering[2] *= v[1];
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::{pixel_stokes, ChainFrame};
    use crate::effects::EffectSet;
    use crate::sensor::Band;

    fn model(separation_deg: f64, spectrum: bool) -> crate::effects::Model {
        let mut set = EffectSet::new();
        if separation_deg > 0.0 {
            set.set("sky_neutral_points", "separation_deg", separation_deg).unwrap();
        }
        if spectrum {
            set.set("sky_neutral_spectrum", "separation_r", 0.8).unwrap();
            set.set("sky_neutral_spectrum", "separation_b", 1.25).unwrap();
        }
        set.model()
    }

    #[test]
    fn each_band_sees_the_sky_of_its_own_separation_and_green_and_mono_are_untouched() {
        let sc = scene();
        let (with, without) = (model(20.0, true), model(20.0, false));
        let mono = ChainFrame::noise_free(&with, &intrinsics(), &sc);
        // A monochrome frame has no band: bitwise the frame without the band factors.
        assert_eq!(mono, ChainFrame::noise_free(&without, &intrinsics(), &sc));
        let band = |m: &crate::effects::Model, b| ChainFrame::noise_free(m, &intrinsics(), &sc).in_band(m, &sc, b);
        // Green is the reference band: bitwise the frame without the factors.
        assert_eq!(band(&with, Band::G), band(&without, Band::G));
        // Red at 0.8 is green's sky at 16°, blue at 1.25 green's at 25°, at every pixel.
        for (b, sep) in [(Band::R, 16.0), (Band::B, 25.0)] {
            let (got, want) = (band(&with, b), band(&model(sep, false), b));
            assert_eq!(got.sky, want.sky, "{b:?}");
            for (u, v) in [(20.0, 15.0), (3.0, 40.0), (60.0, 5.0)] {
                let (s, t) = (pixel_stokes(&got, u, v), pixel_stokes(&want, u, v));
                assert!((s.q - t.q).abs() < 1e-15 && (s.u - t.u).abs() < 1e-15, "{b:?} at ({u}, {v})");
            }
            // And it is another sky than green's separation gives that band.
            assert_ne!(got.sky, band(&without, b).sky, "{b:?}");
        }
    }

    #[test]
    fn without_neutral_points_it_changes_nothing() {
        // The factor scales a separation of zero: the Rayleigh sky in every band, bitwise.
        let sc = scene();
        let (with, without) = (model(0.0, true), model(0.0, false));
        for b in Band::ALL {
            let f = |m: &crate::effects::Model| ChainFrame::noise_free(m, &intrinsics(), &sc).in_band(m, &sc, b);
            assert_eq!(f(&with), f(&without), "{b:?}");
        }
    }
}
