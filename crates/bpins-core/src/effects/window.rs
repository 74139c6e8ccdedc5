//! # `window` — a tilted flat window (or decentred dome) in front of the lens
//!
//! ```text
//! n = (tan τx, tan τy, 1)/‖·‖                  the window's unit normal, true camera frame
//! D = κ ((n·p)² − (n·s)² − p_z²,  −2 (n·p)(n·s))  κ = 0.112 (two uncoated surfaces, n = 1.5)
//! M = [[1, Dᵀ, 0], [D, c·1 + D Dᵀ/(1 + c), 0], [0, 0, c]],   c = √(1 − |D|²)
//! ```
//! on (I, Q_p, U_p, V) in the ray's meridional frame (p radial, s sagittal; p_z =
//! −sin θ for a ray at field angle θ).
//!
//! Source: Fresnel transmission through a plane-parallel plate (Born & Wolf §1.5.3):
//! p-polarized light (in the plane of incidence) passes better than s, so a plate seen
//! at incidence θᵢ is a linear diattenuator along the plane of incidence of
//! ρ ≈ κ sin²θᵢ, the leading term of Fresnel's (two uncoated surfaces of n = 1.5:
//! exact ρ/sin²θᵢ = 0.112 at 5°, 0.121 at 20°, 0.136 at 30°). The plane of incidence
//! holds the ray d and n, so its axis is n − (n·d)d, whose components on the ray's
//! meridional basis are (n·p, n·s) and whose squared length is sin²θᵢ: the diattenuation
//! vector is exactly κ((n·p)² − (n·s)², −2(n·p)(n·s)) (the meridional frame's angles
//! run from p toward −s, as the sky's AoE φ = atan2(−e_s, e_p) in `sky::rayleigh`). An untilted window (n = z) gives
//! κ sin²θ along p: rotationally symmetric, the shape of `lens_diattenuation` (r² ≈
//! sin²θ near the axis), with which a sky capture confuses it; this effect leaves that
//! part (κ p_z², 0) to `lens_diattenuation` and is the rest: what the tilt adds. To
//! first order in the tilt t that is 2κ p_z (t·p_xy, −t·s_xy), which moves the
//! diattenuation's null from the optical axis to the window's normal; to second order
//! a uniform diattenuation κ sin²τ along the tilt's azimuth in the image frame. The
//! diattenuator's Mueller matrix is the general one (Lu & Chipman 1996, eq. 7) with
//! D Dᵀ/(1 + c) in place of (1 − c) D̂ D̂ᵀ, so that D = 0 is exactly the identity.
//!
//! Units: degrees for the tilts (of the window's normal toward +x and toward +y, about
//! the other axis), κ dimensionless. Frame: the true camera frame for the normal (x
//! right, y down, z along the optical axis, CONVENTIONS.md), the ray's meridional frame
//! for the Stokes vector. A per-pixel effect, first in the chain's lens stage (light
//! crosses the window before the lens).
//!
//! | param        | unit | neutral | fit bounds | physical |
//! |--------------|------|---------|------------|----------|
//! | `tilt_x_deg` | deg  | 0       | [−45, 45]  | ±15      |
//! | `tilt_y_deg` | deg  | 0       | [−45, 45]  | ±15      |   (|D| is clamped below 1 per pixel)
//!
//! Cannot: a window of another κ (an anti-reflection coating lowers it several-fold:
//! the tilt read is then the true one times √(κ_true/0.112) to first order), Fresnel's
//! growth of ρ/sin²θᵢ beyond the leading term, the window's rotationally symmetric
//! diattenuation (`lens_diattenuation` holds it), its transmission loss (folded into
//! the radiance scale, as the lens's is), stress birefringence (retardance: for a sky
//! without circular polarization it changes the measured Q, U only at second order in
//! the retardance; `lens_retardance` holds a symmetric one), or a dome's refraction of
//! the ray's direction.

use super::{Apply, EffectDef, ParamSpec, RayParams, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;

/// The range a real window's tilt has, degrees. Engineering bound: a housing's window is
/// set square to the lens within a few degrees, and a dome decentred by a few millimetres
/// tilts its surface as seen from the lens by about as much; ±15° is generous.
const TILT_PHYSICAL_DEG: (f64, f64) = (-15.0, 15.0);

/// κ of the plate: ρ ≈ κ sin²θᵢ for two uncoated surfaces of refractive index 1.5.
pub const KAPPA: f64 = 0.112;

pub const EFFECT: EffectDef = EffectDef {
    name: "window",
    summary:
        "tilted window: Fresnel diattenuation k((n.p)^2 - (n.s)^2 - p_z^2, -2(n.p)(n.s)), k = 0.112, meridional frame",
    source: "Fresnel plate transmission (Born & Wolf §1.5.3), diattenuator Mueller matrix (Lu & Chipman 1996 eq. 7)",
    stage: Stage::Lens,
    params: &[
        ParamSpec {
            name: "tilt_x_deg",
            unit: "deg",
            neutral: 0.0,
            typical: 5.0,
            min: -45.0,
            max: 45.0,
            physical: Some(TILT_PHYSICAL_DEG),
            doc: "tilt of the window's normal toward +x (right in the image), about the y axis",
        },
        ParamSpec {
            name: "tilt_y_deg",
            unit: "deg",
            neutral: 0.0,
            typical: 5.0,
            min: -45.0,
            max: 45.0,
            physical: Some(TILT_PHYSICAL_DEG),
            doc: "tilt of the window's normal toward +y (down in the image), about the x axis",
        },
    ],
    apply: Apply::Ray { params: normal, frame: None, pixel: window },
    wgsl: Some(include_str!("../../../../shaders/effects/window.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// The vector of the window: its unit normal (true camera frame) and κ, (n_x, n_y, n_z, κ).
fn normal(v: &[f64]) -> RayParams {
    let (tx, ty) = (v[0].to_radians().tan(), v[1].to_radians().tan());
    let norm = (tx * tx + ty * ty + 1.0).sqrt();
    [tx / norm, ty / norm, 1.0 / norm, KAPPA]
}

/// Largest |D| the matrix is evaluated at (|D| = 1 is a perfect polarizer).
pub const D_LIMIT: f64 = 0.999;

/// The tilted window's diattenuation vector (D_q, D_u) along the ray `g`, meridional
/// frame, less its symmetric part κ(p_z², 0), clamped to |D| ≤ [`D_LIMIT`];
/// `p = (n_x, n_y, n_z, κ)`.
#[inline(always)]
pub fn window_diattenuation(p: &RayParams, g: &RayGeometry) -> (f64, f64) {
    // The window's normal on the ray's meridional basis: n·p and n·s.
    let b = &g.basis;
    let np = p[0] * b.p.x + p[1] * b.p.y + p[2] * b.p.z;
    let ns = p[0] * b.s.x + p[1] * b.s.y + p[2] * b.s.z;
    // D = κ((n·p)² − (n·s)², −2(n·p)(n·s)) less the untilted window's κ(p_z², 0): exactly 0 at n = z.
    let dq = p[3] * (np * np - ns * ns - b.p.z * b.p.z);
    let du = -2.0 * p[3] * np * ns;
    // Clamp |D| below 1 (a perfect polarizer has no inverse); exactly D where |D| ≤ limit.
    let d2 = dq * dq + du * du;
    let scale = if d2 > D_LIMIT * D_LIMIT { D_LIMIT / d2.sqrt() } else { 1.0 };
    (dq * scale, du * scale)
}

/// Applies the window's diattenuator to a meridional-frame Stokes vector; p = (n_x, n_y, n_z, κ).
#[inline(always)]
pub fn window(p: &RayParams, g: &RayGeometry, s: Stokes) -> Stokes {
    // Diattenuation vector D along this ray.
    let (dq, du) = window_diattenuation(p, g);
    // c = √(1 − |D|²); D Dᵀ/(1 + c) is the (1 − c) D̂ D̂ᵀ term, exactly 0 at D = 0.
    let c = (1.0 - (dq * dq + du * du)).sqrt();
    let dot = (dq * s.q + du * s.u) / (1.0 + c);
    Stokes {
        i: s.i + dq * s.q + du * s.u,
        q: dq * s.i + c * s.q + dq * dot,
        u: du * s.i + c * s.u + du * dot,
        v: c * s.v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{ideal_frame, intrinsics};
    use crate::effects::{EffectSet, Model};
    use crate::stokes::meridional_to_image;

    fn at(tx_deg: f64, ty_deg: f64) -> RayParams {
        normal(&[tx_deg, ty_deg])
    }

    #[test]
    fn zero_strength_is_exactly_the_identity_and_stays_neutral_in_the_frame() {
        let f = ideal_frame(&Model::default());
        let s = Stokes::new(0.8, 0.1, -0.2, 0.01);
        for (u, v) in [(0.0, 0.0), (305.5, 255.5), (611.0, 17.0)] {
            assert_eq!(window(&at(0.0, 0.0), &f.intr.geometry(u, v), s), s);
        }
        let mut set = EffectSet::new();
        set.enable("window").unwrap();
        assert!(!ideal_frame(&set.model()).has_pixel_effects());
        set.set("window", "tilt_x_deg", 1.0).unwrap();
        assert!(ideal_frame(&set.model()).has_pixel_effects());
    }

    #[test]
    fn the_ray_along_the_window_normal_sees_no_diattenuation() {
        // With the symmetric part κ sin²θ added back, the ray at normal incidence passes
        // unchanged: the null sits on the window's normal, not on the optical axis.
        let intr = intrinsics();
        let (tx, ty) = (4.0f64, -2.5f64);
        let n = at(tx, ty);
        // The pixel that sees along n (pinhole: x = f·n_x/n_z).
        let (u, v) = (intr.cx_px + intr.f_px * n[0] / n[2], intr.cy_px + intr.f_px * n[1] / n[2]);
        let g = intr.geometry(u, v);
        assert!((g.d.dot(glam::DVec3::new(n[0], n[1], n[2])) - 1.0).abs() < 1e-12);
        let (dq, du) = window_diattenuation(&n, &g);
        assert!((dq + KAPPA * g.basis.p.z * g.basis.p.z).abs() < 1e-12 && du.abs() < 1e-12, "{dq} {du}");
    }

    #[test]
    fn on_the_axis_a_uniform_diattenuation_along_the_tilt() {
        // The optical axis sees the window at incidence τ: ρ = κ sin²τ along the tilt's
        // azimuth, in the image frame whatever the (degenerate) meridional basis there.
        let intr = intrinsics();
        let g = intr.geometry(intr.cx_px, intr.cy_px);
        // Image angles run from +x toward −y (CONVENTIONS.md): a tilt toward +y (down)
        // is an axis at −90° (Q = −ρ), toward (+x, +y) one at −45° (U = −ρ).
        for (tx, ty, q, u) in [(6.0f64, 0.0, 1.0, 0.0), (0.0, 6.0, -1.0, 0.0), (6.0, 6.0, 0.0, -1.0)] {
            let n = at(tx, ty);
            let sin2 = 1.0 - n[2] * n[2];
            let (dq, du) = window_diattenuation(&n, &g);
            let img = meridional_to_image(Stokes::new(1.0, dq, du, 0.0), g.basis.cos2b, g.basis.sin2b);
            assert!((img.q - q * KAPPA * sin2).abs() < 1e-15 && (img.u - u * KAPPA * sin2).abs() < 1e-15, "{img:?}");
        }
    }

    #[test]
    fn small_tilts_move_the_null_to_first_order() {
        // D ≈ 2κ p_z (t·p_xy, −t·s_xy) for small tilts t (radians).
        let g = intrinsics().geometry(40.0, 90.0);
        for (tx, ty) in [(0.05f64, 0.0), (0.0, -0.05), (0.04, 0.03)] {
            let (dq, du) = window_diattenuation(&at(tx, ty), &g);
            let t = (tx.to_radians(), ty.to_radians());
            let b = &g.basis;
            let eq = 2.0 * KAPPA * b.p.z * (t.0 * b.p.x + t.1 * b.p.y);
            let eu = -2.0 * KAPPA * b.p.z * (t.0 * b.s.x + t.1 * b.s.y);
            let second = KAPPA * (t.0 * t.0 + t.1 * t.1);
            assert!((dq - eq).abs() <= 2.0 * second && (du - eu).abs() <= 2.0 * second, "{dq} {du} vs {eq} {eu}");
            assert!(dq.hypot(du) > 50.0 * second, "the first-order term dominates");
        }
    }

    #[test]
    fn unpolarized_light_takes_the_diattenuation_and_malus_holds_along_it() {
        let g = intrinsics().geometry(500.0, 60.0);
        let p = at(20.0, -10.0);
        let (dq, du) = window_diattenuation(&p, &g);
        let rho = dq.hypot(du);
        assert!(rho > 0.005, "{rho}");
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
            let a = window_diattenuation(&at(8.0, 0.0), &g);
            let b = window_diattenuation(&at(0.0, 8.0), &g90);
            assert!((a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12, "{a:?} {b:?}");
        }
    }

    #[test]
    fn the_clamp_keeps_the_matrix_physical() {
        let g = intrinsics().geometry(0.0, 0.0);
        let p = [0.7, 0.7, 0.14, 2.0];
        let (dq, du) = window_diattenuation(&p, &g);
        assert!(dq.hypot(du) <= D_LIMIT + 1e-15);
        let s = window(&p, &g, Stokes::new(1.0, 0.3, -0.2, 0.0));
        assert!(s.i > 0.0 && s.dolp() <= 1.0 + 1e-12);
    }
}
