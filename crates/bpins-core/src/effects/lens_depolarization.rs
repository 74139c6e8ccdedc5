//! # `lens_depolarization` — the lens scrambles part of the polarization toward the edge
//!
//! ```text
//! M = diag(1, a, a, a),   a = max(1 − p2·r², 0)        r: normalised radius (focal lengths)
//! S_out = (I, a·Q, a·U, a·V)
//! ```
//!
//! Source: the isotropic partial depolarizer (Chipman, Lam & Young, *Polarized Light
//! and Optical Systems*, 2018, §6.9: Mueller matrix diag(1, a, a, a)), with a
//! depolarization growing as r² toward the field edge — scattering in coatings,
//! cemented surfaces and stress in the glass act most on the oblique ray bundles.
//! This is the worked example of `docs/adding-an-effect.md`. Frame: any (isotropic:
//! it commutes with rotations, so the meridional and image frames give the same).
//! Units: p2 dimensionless, per r². Intensity and AoP untouched, DoLP × a (tested).
//! Per pixel on both backends (`shaders/effects/lens_depolarization.wgsl`), between
//! the lens retarder and the vignetting.
//!
//! | param | unit | neutral | fit bounds | physical |
//! |-------|------|---------|------------|----------|
//! | `p2`  | 1    | 0       | [0, 2]     | [0, 0.5] |
//!
//! (a is clamped at 0: a lens cannot depolarize more than completely.)
//!
//! Cannot: depolarization that prefers an orientation (that would be a diattenuator
//! or retarder with a spread of axes), that varies with wavelength, or that is not
//! rotationally symmetric about the principal point; a uniform depolarization over
//! the whole field is indistinguishable from the sky's d_max (`sky_depolarization`).

use super::{Apply, EffectDef, ParamSpec, RayParams, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;

/// The range a real lens's depolarization has. Engineering bound (no published lens
/// measurement gives one): p2 = 0.5 loses half the polarization at 45° off the axis of a
/// pinhole lens, far more than coated glass scatters.
const P2_PHYSICAL: (f64, f64) = (0.0, 0.5);

pub const EFFECT: EffectDef = EffectDef {
    name: "lens_depolarization",
    summary: "Q, U, V × (1 − p2 r²): the lens depolarizes toward the field edge",
    source: "isotropic depolarizer diag(1, a, a, a) (Chipman et al. 2018 §6.9), a = 1 − p2 r²",
    stage: Stage::Lens,
    params: &[ParamSpec {
        name: "p2",
        unit: "1",
        neutral: 0.0,
        typical: 0.1,
        min: 0.0,
        max: 2.0,
        physical: Some(P2_PHYSICAL),
        doc: "depolarized fraction per r² (focal lengths²)",
    }],
    apply: Apply::Ray { params: |v| [v[0], 0.0, 0.0, 0.0], frame: None, pixel: lens_depolarization },
    wgsl: Some(include_str!("../../../../shaders/effects/lens_depolarization.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// Applies the depolarizer to the ray's Stokes vector (any frame); `p = [p2, 0, 0, 0]`.
#[inline(always)]
pub fn lens_depolarization(p: &RayParams, g: &RayGeometry, s: Stokes) -> Stokes {
    // Retained polarized fraction a = 1 − p2·r², at least 0; exactly 1 at p2 = 0.
    let a = (1.0 - p[0] * g.r2).max(0.0);
    Stokes { i: s.i, q: a * s.q, u: a * s.u, v: a * s.v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{ideal_frame, intrinsics, ray_at_r2, stokes_at};
    use crate::effects::{EffectSet, Model};

    #[test]
    fn dolp_falls_as_one_minus_p2_r2_and_nothing_else_moves() {
        let mut set = EffectSet::new();
        set.set("lens_depolarization", "p2", 0.3).unwrap();
        let (dep, ideal) = (ideal_frame(&set.model()), ideal_frame(&Model::default()));
        let i = intrinsics();
        for (u, v) in [(5.0, 7.0), (305.5, 255.5), (600.0, 20.0)] {
            let (a, b) = (stokes_at(&dep, u, v), stokes_at(&ideal, u, v));
            let (x, y) = i.normalised(u, v);
            let r2 = x * x + y * y;
            assert_eq!(a.i, b.i);
            assert!((a.dolp() / b.dolp() - (1.0 - 0.3 * r2)).abs() < 1e-12);
            assert!((a.aop_rad() - b.aop_rad()).abs() < 1e-12);
        }
    }

    #[test]
    fn zero_strength_is_the_identity_and_it_commutes_with_rotations() {
        let s = Stokes::new(1.0, 0.3, -0.2, 0.05);
        assert_eq!(lens_depolarization(&[0.0; 4], &ray_at_r2(0.7), s), s);
        // Never more than completely depolarized.
        assert_eq!(lens_depolarization(&[2.0, 0.0, 0.0, 0.0], &ray_at_r2(1.0), s), Stokes::new(1.0, 0.0, 0.0, 0.0));
        // Isotropic: rotating the frame before or after gives the same Stokes vector.
        let rot =
            |s: Stokes, t: f64| Stokes::new(s.i, s.q * t.cos() + s.u * t.sin(), -s.q * t.sin() + s.u * t.cos(), s.v);
        let (p, g) = ([0.4, 0.0, 0.0, 0.0], ray_at_r2(0.5));
        let (a, b) = (lens_depolarization(&p, &g, rot(s, 0.7)), rot(lens_depolarization(&p, &g, s), 0.7));
        for (x, y) in [(a.i, b.i), (a.q, b.q), (a.u, b.u), (a.v, b.v)] {
            assert!((x - y).abs() < 1e-15);
        }
    }
}
