//! # `vignetting` — the lens passes less light toward the edge of the field
//!
//! ```text
//! S_out = S_in · (1 + v2·r² + v4·r⁴)        r: normalised radius (focal lengths)
//! ```
//!
//! Source: EFFECTS.md; the even polynomial of radial falloff (natural cos⁴θ falloff
//! and mechanical vignetting, to fourth order in r). A non-polarizing attenuation:
//! every Stokes component scales alike, so no AoP and no DoLP moves (tested), only
//! intensity and with it the SNR. Frame: any (a scalar). Units: dimensionless.
//! Per pixel on both backends (`shaders/effects/vignetting.wgsl`), after the lens
//! Mueller matrices.
//!
//! | param | unit | neutral | fit bounds | physical  |
//! |-------|------|---------|------------|-----------|
//! | `v2`  | 1    | 0       | ±2         | [−2, 0.5] |
//! | `v4`  | 1    | 0       | ±2         | bounds    |
//!
//! (The factor is clamped at 0 where the polynomial would go negative.)
//!
//! Cannot: a falloff that is not rotationally symmetric about the principal point,
//! or that depends on polarization (that is `lens_diattenuation`).

use super::{Apply, EffectDef, Inseparable, Model, ParamSpec, RayParams, SkyBlindness, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;

/// The range a real lens's r² falloff has. Physics: the cos⁴ law (1 − 2r² + 3r⁴ on a
/// pinhole) and mechanical vignetting only darken the edge; a lens corrected for flat
/// illumination reaches about 0; v2 > 0.5 (an edge brighter by half at r = 1) is no lens.
const V2_PHYSICAL: (f64, f64) = (-2.0, 0.5);

pub const EFFECT: EffectDef = EffectDef {
    name: "vignetting",
    summary: "intensity × (1 + v2 r² + v4 r⁴), no polarization change",
    source: "EFFECTS.md; radial falloff polynomial",
    stage: Stage::Lens,
    params: &[
        ParamSpec {
            name: "v2",
            unit: "1",
            neutral: 0.0,
            typical: -0.2,
            min: -2.0,
            max: 2.0,
            physical: Some(V2_PHYSICAL),
            doc: "falloff per r²",
        },
        ParamSpec {
            name: "v4",
            unit: "1",
            neutral: 0.0,
            typical: 0.05,
            min: -2.0,
            max: 2.0,
            // The bounds are the physical range: the cos⁴ law's own r⁴ term is +3 on a
            // pinhole, beyond them, and a corrected lens's is smaller.
            physical: None,
            doc: "falloff per r⁴",
        },
    ],
    apply: Apply::Ray { params: |v| [v[0], v[1], 0.0, 0.0], frame: None, pixel: vignetting },
    wgsl: Some(include_str!("../../../../shaders/effects/vignetting.wgsl")),
    derivatives: &[],
    inseparable: Some(Inseparable {
        when: SkyBlindness::FreeRadiance,
        why: |_| {
            "an intensity-only radial falloff: the sky's radiance nuisance takes the same shape (a sky brightens \
             toward the horizon, radially for a camera looking up); a lab flat field measures it (then `--calibration FILE` holds it)"
                .to_string()
        },
    }),
};

/// The falloff (v2, v4) in `model`: what a lab simulation of a flat field applies.
pub fn coefficients(model: &Model) -> [f64; 2] {
    let p = model.ray_params(&EFFECT);
    [p[0], p[1]]
}

/// The falloff factor max(1 + v2·r² + v4·r⁴, 0) at squared normalised radius `r2`.
#[inline(always)]
pub fn factor(v2: f64, v4: f64, r2: f64) -> f64 {
    (1.0 + v2 * r2 + v4 * r2 * r2).max(0.0)
}

/// Applies the radial falloff to the ray's Stokes vector (any frame); `p = [v2, v4, 0, 0]`.
#[inline(always)]
pub fn vignetting(p: &RayParams, g: &RayGeometry, s: Stokes) -> Stokes {
    // Falloff factor at the ray's squared normalised radius, at least 0.
    let k = factor(p[0], p[1], g.r2);
    Stokes { i: k * s.i, q: k * s.q, u: k * s.u, v: k * s.v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{ideal_frame, intrinsics, ray_at_r2, stokes_at};
    use crate::effects::{EffectSet, Model};

    #[test]
    fn intensity_falls_as_the_polynomial_and_no_angle_moves() {
        let mut set = EffectSet::new();
        set.set("vignetting", "v2", -0.3).unwrap();
        set.set("vignetting", "v4", 0.1).unwrap();
        let (vig, ideal) = (ideal_frame(&set.model()), ideal_frame(&Model::default()));
        let i = intrinsics();
        for (u, v) in [(5.0, 7.0), (305.5, 255.5), (600.0, 20.0)] {
            let (a, b) = (stokes_at(&vig, u, v), stokes_at(&ideal, u, v));
            let (x, y) = i.normalised(u, v);
            let r2 = x * x + y * y;
            assert!((a.i / b.i - (1.0 - 0.3 * r2 + 0.1 * r2 * r2)).abs() < 1e-12);
            assert!((a.dolp() - b.dolp()).abs() < 1e-12);
            assert!((a.aop_rad() - b.aop_rad()).abs() < 1e-12);
        }
    }

    #[test]
    fn zero_strength_is_the_identity_and_the_factor_never_goes_negative() {
        let s = Stokes::new(1.0, 0.3, -0.2, 0.0);
        assert_eq!(vignetting(&[0.0; 4], &ray_at_r2(0.7), s), s);
        assert_eq!(vignetting(&[-2.0, 0.0, 0.0, 0.0], &ray_at_r2(1.0), s).i, 0.0);
    }
}
