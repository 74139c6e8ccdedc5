//! # `window` — a tilted flat window (or decentred dome) in front of the lens
//!
//! ```text
//! D = 2 p_z · (k · p_xy,  k · s_xy)            k = (kx, ky) = κ · (tilt toward +x, +y)
//! M = [[1, Dᵀ, 0], [D, c·1 + D Dᵀ/(1 + c), 0], [0, 0, c]],   c = √(1 − |D|²)
//! ```
//! on (I, Q_p, U_p, V) in the ray's meridional frame (p radial, s sagittal; p_z =
//! −sin θ for a ray at field angle θ).
//!
//! Source: Fresnel transmission through a plane-parallel plate (Born & Wolf §1.5.3):
//! p-polarized light (in the plane of incidence) passes better than s, so a plate seen
//! at incidence θᵢ is a linear diattenuator of ρ ≈ κ sin²θᵢ along the plane of
//! incidence; κ = 0.11 for two uncoated surfaces of n = 1.5 (exact Fresnel: ρ/sin²θᵢ
//! = 0.112 at 5°, 0.136 at 30°). For a window with normal n = (tx, ty, 1) and a ray
//! with meridional basis (p, s), the diattenuation vector is exactly
//! κ((n·p)² − (n·s)², 2(n·p)(n·s)) (|n − (n·d)d|² = sin²θᵢ). At t = 0 that is κ sin²θ
//! along p: rotationally symmetric, the shape of `lens_diattenuation` (r² ≈ sin²θ
//! near the axis), with which a sky capture confuses it; that part is left to
//! `lens_diattenuation`. This effect is the rest to first order in the tilt: the
//! equation above, which moves the diattenuation's null from the optical axis to the
//! window's normal. The diattenuator's Mueller matrix is the general one
//! (Lu & Chipman 1996, eq. 7) with D Dᵀ/(1 + c) in place of (1 − c) D̂ D̂ᵀ, so that
//! D = 0 is exactly the identity.
//!
//! Units: `kx`, `ky` dimensionless (κ times the window normal's tilt, in radians for
//! small tilts: a window of n = 1.5 tilted 5° toward +x has kx ≈ 0.11 · 0.087 ≈
//! 0.0096). Frame: the true camera frame for the tilt (x right, y down, z along the
//! optical axis, CONVENTIONS.md), the ray's meridional frame for the Stokes vector.
//! A per-pixel effect, first in the chain's lens stage (light crosses the window
//! before the lens).
//!
//! | param | unit | neutral | range      |
//! |-------|------|---------|------------|
//! | `kx`  | 1    | 0       | [−0.5, 0.5] |
//! | `ky`  | 1    | 0       | [−0.5, 0.5] |   (|D| is clamped below 1 per pixel)
//!
//! Cannot: the window's rotationally symmetric diattenuation (`lens_diattenuation`
//! holds it), terms of second order in the tilt, the transmission loss of the window
//! (folded into the radiance scale, as the lens's is), stress birefringence
//! (retardance: for a sky without circular polarization it changes the measured Q, U
//! only at second order in the retardance; `lens_retardance` holds a symmetric one),
//! a dome's refraction of the ray's direction, or coatings whose diattenuation is not
//! Fresnel's shape.

use super::{Apply, EffectDef, ParamSpec, RayParams, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;

pub const EFFECT: EffectDef = EffectDef {
    name: "window",
    summary: "tilted window: Fresnel diattenuation D = 2 p_z (k.p, k.s) to first order in its tilt, meridional frame",
    source: "Fresnel plate transmission (Born & Wolf §1.5.3), diattenuator Mueller matrix (Lu & Chipman 1996 eq. 7)",
    stage: Stage::Lens,
    params: &[
        ParamSpec {
            name: "kx",
            unit: "1",
            neutral: 0.0,
            typical: 0.01,
            min: -0.5,
            max: 0.5,
            doc: "plate coefficient κ (0.11 for n = 1.5) times the window normal's tilt toward +x, rad",
        },
        ParamSpec {
            name: "ky",
            unit: "1",
            neutral: 0.0,
            typical: 0.01,
            min: -0.5,
            max: 0.5,
            doc: "plate coefficient κ times the window normal's tilt toward +y (down in the image), rad",
        },
    ],
    apply: Apply::Ray { params: |v| [v[0], v[1], 0.0, 0.0], frame: None, pixel: window },
    wgsl: Some(include_str!("../../../../shaders/effects/window.wgsl")),
};

/// Largest |D| the matrix is evaluated at (|D| = 1 is a perfect polarizer).
pub const D_LIMIT: f64 = 0.999;

/// The window's diattenuation vector (D_q, D_u) along the ray `g`, meridional frame,
/// clamped to |D| ≤ [`D_LIMIT`]; `p = [kx, ky, 0, 0]`.
#[inline(always)]
pub fn window_diattenuation(p: &RayParams, g: &RayGeometry) -> (f64, f64) {
    // D = 2 p_z (k·p_xy, k·s_xy): the first-order tilt term of κ((n·p)² − (n·s)², 2(n·p)(n·s)).
    let b = &g.basis;
    let dq = 2.0 * b.p.z * (p[0] * b.p.x + p[1] * b.p.y);
    let du = 2.0 * b.p.z * (p[0] * b.s.x + p[1] * b.s.y);
    // Clamp |D| below 1 (a perfect polarizer has no inverse); exactly D where |D| ≤ limit.
    let d2 = dq * dq + du * du;
    let scale = if d2 > D_LIMIT * D_LIMIT { D_LIMIT / d2.sqrt() } else { 1.0 };
    (dq * scale, du * scale)
}

/// Applies the window's diattenuator to a meridional-frame Stokes vector; p = (kx, ky, 0, 0).
#[inline(always)]
pub fn window(p: &RayParams, g: &RayGeometry, s: Stokes) -> Stokes {
    // Diattenuation vector D along this ray.
    let (dq, du) = window_diattenuation(p, g);
    // c = √(1 − |D|²); D Dᵀ/(1 + c) is the (1 − c) D̂ D̂ᵀ term, exactly 0 at D = 0.
    let c = (1.0 - (dq * dq + du * du)).sqrt();
    let dot = (dq * s.q + du * s.u) / (1.0 + c);
    Stokes { i: s.i + dq * s.q + du * s.u, q: dq * s.i + c * s.q + dq * dot, u: du * s.i + c * s.u + du * dot, v: c * s.v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{ideal_frame, intrinsics};
    use crate::effects::{EffectSet, Model};

    /// The exact plate diattenuation of a window with normal (tx, ty, 1) and plate
    /// coefficient κ, less its rotationally symmetric part κ sin²θ along p.
    fn exact_tilt_part(kappa: f64, tx: f64, ty: f64, g: &RayGeometry) -> (f64, f64) {
        let b = &g.basis;
        let (np, ns) = (tx * b.p.x + ty * b.p.y + b.p.z, tx * b.s.x + ty * b.s.y);
        (kappa * (np * np - ns * ns) - kappa * b.p.z * b.p.z, kappa * 2.0 * np * ns)
    }

    #[test]
    fn zero_strength_is_exactly_the_identity_and_stays_neutral_in_the_frame() {
        let f = ideal_frame(&Model::default());
        let s = Stokes::new(0.8, 0.1, -0.2, 0.01);
        for (u, v) in [(0.0, 0.0), (305.5, 255.5), (611.0, 17.0)] {
            assert_eq!(window(&[0.0; 4], &f.intr.geometry(u, v), s), s);
        }
        let mut set = EffectSet::new();
        set.enable("window").unwrap();
        assert!(!ideal_frame(&set.model()).has_pixel_effects());
        set.set("window", "kx", 0.01).unwrap();
        assert!(ideal_frame(&set.model()).has_pixel_effects());
    }

    #[test]
    fn first_order_term_of_the_exact_tilted_plate() {
        // Small tilts: the effect is the exact plate's tilt part up to O(t²).
        let g = intrinsics().geometry(40.0, 90.0);
        let kappa = 0.11;
        for (tx, ty) in [(1e-3, 0.0), (0.0, -1e-3), (7e-4, 5e-4)] {
            let (dq, du) = window_diattenuation(&[kappa * tx, kappa * ty, 0.0, 0.0], &g);
            let (eq, eu) = exact_tilt_part(kappa, tx, ty, &g);
            let scale = kappa * (tx * tx + ty * ty);
            assert!((dq - eq).abs() <= 2.0 * scale && (du - eu).abs() <= 2.0 * scale, "{dq} {du} vs {eq} {eu}");
            assert!(dq.hypot(du) > 50.0 * scale, "the first-order term dominates");
        }
    }

    #[test]
    fn unpolarized_light_takes_the_diattenuation_and_malus_holds_along_it() {
        let g = intrinsics().geometry(500.0, 60.0);
        let p = [0.2, -0.1, 0.0, 0.0];
        let (dq, du) = window_diattenuation(&p, &g);
        let rho = dq.hypot(du);
        assert!(rho > 0.01);
        // Unpolarized in: DoLP = |D|, along D (the plane of incidence).
        let out = window(&p, &g, Stokes::new(1.0, 0.0, 0.0, 0.0));
        assert!((out.dolp() - rho).abs() < 1e-15 && (out.q - dq).abs() < 1e-15 && (out.u - du).abs() < 1e-15);
        // Fully polarized along D passes 1 + ρ, across it 1 − ρ; polarized light stays fully polarized.
        let along = window(&p, &g, Stokes::new(1.0, dq / rho, du / rho, 0.0));
        let across = window(&p, &g, Stokes::new(1.0, -dq / rho, -du / rho, 0.0));
        assert!((along.i - (1.0 + rho)).abs() < 1e-14 && (across.i - (1.0 - rho)).abs() < 1e-14);
        for s in [along, across, window(&p, &g, Stokes::new(1.0, 0.0, 1.0, 0.0))] {
            assert!((s.dolp() - 1.0).abs() < 1e-12, "{s:?}");
        }
    }

    #[test]
    fn turning_the_tilt_turns_the_pattern() {
        // A window tilted toward +x seen by a ray at radial angle a acts as one tilted
        // toward +y on the ray at a + 90°, in the rays' own meridional frames.
        let intr = intrinsics();
        let (cx, cy) = (intr.cx_px, intr.cy_px);
        for (dx, dy) in [(120.0, 35.0), (-60.0, 200.0)] {
            let g = intr.geometry(cx + dx, cy + dy);
            let g90 = intr.geometry(cx - dy, cy + dx);
            let a = window_diattenuation(&[0.05, 0.0, 0.0, 0.0], &g);
            let b = window_diattenuation(&[0.0, 0.05, 0.0, 0.0], &g90);
            assert!((a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12, "{a:?} {b:?}");
        }
        // On the optical axis there is nothing to first order.
        let axis = window_diattenuation(&[0.05, 0.05, 0.0, 0.0], &intr.geometry(cx, cy));
        assert!(axis.0.abs() < 1e-15 && axis.1.abs() < 1e-15);
    }

    #[test]
    fn the_clamp_keeps_the_matrix_physical() {
        let g = intrinsics().geometry(0.0, 0.0);
        let (dq, du) = window_diattenuation(&[0.5, 0.5, 0.0, 0.0], &g);
        assert!(dq.hypot(du) <= D_LIMIT + 1e-15);
        let s = window(&[0.5, 0.5, 0.0, 0.0], &g, Stokes::new(1.0, 0.3, -0.2, 0.0));
        assert!(s.i > 0.0 && s.dolp() <= 1.0 + 1e-12);
    }
}
