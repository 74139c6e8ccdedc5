//! # `lens_retardance` — the lens delays s against p (a linear retarder)
//!
//! ```text
//! δ = delta2 · r²                         degrees, r: normalised radius (focal lengths)
//! M = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, cos δ, sin δ], [0, 0, −sin δ, cos δ]]
//!     on (I, Q_p, U_p, V), fast axis along p
//! ```
//!
//! Source: EFFECTS.md; the linear retarder Mueller matrix with fast axis at 0°
//! (D. Goldstein, *Polarized Light*, 3rd ed., §5.3) in each ray's **meridional**
//! frame: oblique incidence on coated lens surfaces retards s against p, growing as
//! r² to lowest order (zero on the axis by symmetry). Light polarized along p or s
//! (U_p = 0, the solar meridian of a level camera) is untouched (tested); elsewhere
//! part of U_p turns into circular V, which linear analyzers cannot see: the AoE turns
//! toward p or s and the linear DoLP falls, while the total polarization
//! Q² + U² + V² is kept (tested). Applied after `lens_diattenuation`, per pixel on
//! both backends (`shaders/effects/lens_retardance.wgsl`).
//!
//! | param        | unit | neutral | fit bounds | physical |
//! |--------------|------|---------|------------|----------|
//! | `delta2_deg` | deg  | 0       | ±180       | ±90      |
//!
//! Cannot: a retarder whose fast axis is not radial (stress birefringence, decentred
//! elements), or circular retardance (optical activity).

use super::{Apply, EffectDef, ParamSpec, RayParams, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;

/// The range a real lens's retardance has, degrees per r². Engineering bound: coated
/// multi-element lenses retard by tens of degrees toward the edge of a wide field (see
/// `typical`); ±90° per r² is a quarter wave at r = 1.
const DELTA2_PHYSICAL_DEG: (f64, f64) = (-90.0, 90.0);

pub const EFFECT: EffectDef = EffectDef {
    name: "lens_retardance",
    summary: "linear retarder in the meridional frame, retardance delta2 * r^2",
    source: "EFFECTS.md; Goldstein, Polarized Light §5.3 (retarder Mueller matrix)",
    stage: Stage::Lens,
    params: &[ParamSpec {
        name: "delta2_deg",
        unit: "deg",
        neutral: 0.0,
        // Coated multi-element lenses retard by tens of degrees toward the edge of a
        // wide field. At 10° the effect (second order in δ for linear analyzers: the V
        // it makes is invisible) was at the edge of what the hidden-effect test's
        // 306 × 256 pinhole capture (r ≤ 0.66, δ ≤ 4°) sees: χ²/dof 1.002 before the
        // fit, named under one noise seed and not under the next.
        typical: 20.0,
        min: -180.0,
        max: 180.0,
        physical: Some(DELTA2_PHYSICAL_DEG),
        doc: "retardance per squared normalised radius",
    }],
    apply: Apply::Ray { params: |v| [v[0].to_radians(), 0.0, 0.0, 0.0], frame: None, pixel: lens_retardance },
    wgsl: Some(include_str!("../../../../shaders/effects/lens_retardance.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// Applies the retarder to a meridional-frame Stokes vector; `p = [delta2 (rad per r²), 0, 0, 0]`.
#[inline(always)]
pub fn lens_retardance(p: &RayParams, g: &RayGeometry, s: Stokes) -> Stokes {
    // Retardance δ = delta2·r² at the ray, fast axis p.
    let (sd, cd) = (p[0] * g.r2).sin_cos();
    Stokes { i: s.i, q: s.q, u: cd * s.u + sd * s.v, v: -sd * s.u + cd * s.v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{ideal_frame, ray_at_r2, scene, stokes_at};
    use crate::conventions::{enu_from_az_el_deg, wrap_deg_90};
    use crate::effects::{EffectSet, Model};

    #[test]
    fn zero_strength_is_the_identity() {
        let s = Stokes::new(1.0, 0.3, -0.2, 0.05);
        assert_eq!(lens_retardance(&[0.0; 4], &ray_at_r2(0.9), s), s);
    }

    #[test]
    fn total_polarization_is_kept_and_u_turns_into_v() {
        let s = Stokes::new(1.0, 0.3, -0.2, 0.0);
        let t = lens_retardance(&[30f64.to_radians(), 0.0, 0.0, 0.0], &ray_at_r2(1.0), s);
        assert!(((t.q * t.q + t.u * t.u + t.v * t.v) - (0.09 + 0.04)).abs() < 1e-15);
        assert!((t.u - (-0.2 * 30f64.to_radians().cos())).abs() < 1e-15);
        assert_eq!((t.i, t.q), (s.i, s.q));
    }

    #[test]
    fn the_solar_meridian_keeps_its_aoe_and_elsewhere_the_aoe_turns() {
        let mut set = EffectSet::new();
        set.set("lens_retardance", "delta2_deg", 40.0).unwrap();
        let (ret, ideal) = (ideal_frame(&set.model()), ideal_frame(&Model::default()));
        // A pixel on the solar meridian, sunward of the principal point (level camera).
        let sc = scene();
        let sun = crate::conventions::world_from_camera(sc.heading_deg, 0.0, 0.0).transpose()
            * enu_from_az_el_deg(sc.sun_az_deg, sc.sun_el_deg);
        let i = crate::chain::tests::intrinsics();
        let (u, v) = i.project(sun).unwrap();
        let (u, v) = (i.cx_px + 0.3 * (u - i.cx_px), i.cy_px + 0.3 * (v - i.cy_px));
        let aoe = |f: &crate::chain::ChainFrame, u: f64, v: f64| {
            let s = stokes_at(f, u, v);
            let beta = crate::conventions::image_angle_rad(u - i.cx_px, v - i.cy_px).to_degrees();
            wrap_deg_90(s.aop_rad().to_degrees() - beta)
        };
        assert!((aoe(&ret, u, v) - aoe(&ideal, u, v)).abs() < 1e-9);
        // Off the meridian the AoE moves.
        assert!((aoe(&ret, 40.0, 480.0) - aoe(&ideal, 40.0, 480.0)).abs() > 0.01);
    }
}
