//! # `lens_diattenuation` — the lens transmits p and s polarizations unequally
//!
//! ```text
//! ρ = rho2 · r²                                r: normalised radius (focal lengths)
//! M = T · [[1, ρ, 0], [ρ, 1, 0], [0, 0, √(1 − ρ²)]]   on (I, Q_p, U_p), T = 1
//! ```
//!
//! Source: seed paper §2.2 eq. 10 (lens Mueller matrix, "linear bidirectional
//! attenuation" ρ = (τ₁² − τ₂²)/(τ₁² + τ₂²)); CONVENTIONS.md "Stokes and Mueller".
//! Frame: the ray's **meridional** frame (reference axis p, the radial direction);
//! the chain rotates into it and back explicitly. ρ > 0 passes p (radial) better.
//! Growing as r² is the lowest order a rotationally symmetric lens allows (ρ = 0 on
//! the axis by symmetry). The overall transmission T is folded into the radiance scale.
//! Light polarized along p or s (U_p = 0) keeps its angle: on the solar meridian of a
//! level camera the AoE is untouched (tested below).
//!
//! | param  | unit | neutral | fit bounds | physical |
//! |--------|------|---------|------------|----------|
//! | `rho2` | 1    | 0       | ±50        | ±5       |  (|ρ| is clamped below 1 per pixel)
//!
//! Cannot: retardance (see `lens_retardance`), depolarization, or a ρ that is not
//! rotationally symmetric (decentred or tilted elements).

use super::{Apply, EffectDef, Model, ParamSpec, RayParams, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;

/// The range a real lens's diattenuation has. Fresnel: an uncoated air–glass surface
/// (n = 1.5) at 45° incidence has ρ = 0.044, so ten surfaces give at most ρ ≈ 0.4 at r = 1
/// and coatings lower it; the seed paper's Monte Carlo draws ρ ~ N(0, 0.2) at its field corner
/// (r² = 0.119, `docs/paper.md`): ±5 holds that draw to 3σ.
const RHO2_PHYSICAL: (f64, f64) = (-5.0, 5.0);

pub const EFFECT: EffectDef = EffectDef {
    name: "lens_diattenuation",
    summary: "seed lens Mueller matrix with rho = rho2 * r^2, meridional frame",
    source: "seed paper §2.2 eq. 10",
    stage: Stage::Lens,
    params: &[ParamSpec {
        name: "rho2",
        unit: "1",
        neutral: 0.0,
        typical: 0.1,
        min: -50.0,
        max: 50.0,
        physical: Some(RHO2_PHYSICAL),
        doc: "diattenuation per squared normalised radius",
    }],
    apply: Apply::Ray { params: |v| [v[0], 0.0, 0.0, 0.0], frame: None, pixel: lens_diattenuation },
    wgsl: Some(include_str!("../../../../shaders/effects/lens_diattenuation.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// The lens's rho2 in `model` (what a reconstruction that knows the lens inverts).
pub fn rho2(model: &Model) -> f64 {
    model.ray_params(&EFFECT)[0]
}

/// Largest |ρ| the matrix is evaluated at (ρ = ±1 is a perfect polarizer, singular).
pub const RHO_LIMIT: f64 = 0.999;

/// ρ at squared normalised radius `r2`, clamped to ±[`RHO_LIMIT`].
#[inline(always)]
#[allow(clippy::manual_clamp)] // f64::clamp may panic, which stops row loops vectorizing
pub fn rho_at(rho2: f64, r2: f64) -> f64 {
    (rho2 * r2).max(-RHO_LIMIT).min(RHO_LIMIT)
}

/// Applies the lens Mueller matrix to a meridional-frame Stokes vector; `p = [rho2, 0, 0, 0]`.
#[inline(always)]
pub fn lens_diattenuation(p: &RayParams, g: &RayGeometry, s: Stokes) -> Stokes {
    // ρ at the ray's squared normalised radius, clamped below 1.
    let rho = rho_at(p[0], g.r2);
    let c = (1.0 - rho * rho).sqrt();
    Stokes { i: s.i + rho * s.q, q: rho * s.i + s.q, u: c * s.u, v: c * s.v }
}

/// Inverts the lens Mueller matrix (seed eq. 13: reconstruction with ρ known).
#[inline(always)]
pub(crate) fn lens_diattenuation_inverse(rho2: f64, r2: f64, s: Stokes) -> Stokes {
    let rho = rho_at(rho2, r2);
    let det = 1.0 - rho * rho;
    let c = det.sqrt();
    Stokes { i: (s.i - rho * s.q) / det, q: (s.q - rho * s.i) / det, u: s.u / c, v: s.v / c }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{ideal_frame, ray_at_r2, scene, stokes_at};
    use crate::conventions::{enu_from_az_el_deg, wrap_deg_90};
    use crate::effects::EffectSet;

    #[test]
    fn zero_strength_is_exactly_identity() {
        let s = Stokes::new(1.3, 0.2, -0.4, 0.01);
        assert_eq!(lens_diattenuation(&[0.0; 4], &ray_at_r2(0.7), s), s);
        assert_eq!(lens_diattenuation_inverse(0.0, 0.7, s), s);
    }

    #[test]
    fn inverse_undoes_the_lens() {
        let s = Stokes::new(1.3, 0.2, -0.4, 0.0);
        let back = lens_diattenuation_inverse(2.0, 0.1, lens_diattenuation(&[2.0, 0.0, 0.0, 0.0], &ray_at_r2(0.1), s));
        assert!((back.i - s.i).abs() < 1e-14 && (back.q - s.q).abs() < 1e-14 && (back.u - s.u).abs() < 1e-14);
    }

    #[test]
    fn diattenuation_matches_tau_definition() {
        // Unpolarized light through a lens with ρ: DoLP out = |ρ| along p.
        let out = lens_diattenuation(&[0.5, 0.0, 0.0, 0.0], &ray_at_r2(0.4), Stokes::new(1.0, 0.0, 0.0, 0.0));
        assert!((out.dolp() - 0.2).abs() < 1e-15);
        assert_eq!(out.u, 0.0);
    }

    #[test]
    fn aoe_on_the_solar_meridian_is_untouched() {
        let mut set = EffectSet::new();
        // ρ ≤ 0.07 here: below the sky's DoLP, so the polarization keeps its axis.
        set.set("lens_diattenuation", "rho2", 0.5).unwrap();
        let lens = ideal_frame(&set.model());
        let ideal = ideal_frame(&EffectSet::new().model());
        let sc = scene();
        // Pixels on the solar meridian: project sun-azimuth directions at several elevations.
        let r = crate::conventions::world_from_camera(sc.heading_deg, 0.0, 0.0);
        let mut moved_elsewhere = false;
        for el in [70.0, 80.0, 88.0] {
            let d = r.transpose() * enu_from_az_el_deg(sc.sun_az_deg, el);
            let (u, v) = lens.intr.project(d).unwrap();
            let a = stokes_at(&lens, u, v);
            let b = stokes_at(&ideal, u, v);
            let da = wrap_deg_90(a.aop_rad().to_degrees() - b.aop_rad().to_degrees());
            assert!(da.abs() < 1e-9, "AoE moved by {da}° on the meridian");
            assert!((a.dolp() - b.dolp()).abs() > 1e-5, "DoLP should change");
            // Off the meridian the angle does move.
            let d = r.transpose() * enu_from_az_el_deg(sc.sun_az_deg + 60.0, el);
            let (u, v) = lens.intr.project(d).unwrap();
            let da = wrap_deg_90(
                stokes_at(&lens, u, v).aop_rad().to_degrees() - stokes_at(&ideal, u, v).aop_rad().to_degrees(),
            );
            moved_elsewhere |= da.abs() > 1e-3;
        }
        assert!(moved_elsewhere);
    }
}
