//! # `focal_length` — the true focal length differs from the nominal one
//!
//! ```text
//! f_true = f_nominal · (1 + scale)                 pixels (f / pitch)
//! ```
//!
//! Source: EFFECTS.md; pinhole and fisheye projections r = f·g(θ) (CONVENTIONS.md,
//! "Pixels and projection"). Frame: camera. A pixel at radius ρ px from the
//! principal point sees the field angle g⁻¹(ρ / f_true): a scale > 0 narrows the
//! field, every ray closer to the axis. Folded on the host into the true camera of
//! each frame (both backends run the same folded camera; no per-pixel twin).
//!
//! | param   | unit | neutral | fit bounds | physical |
//! |---------|------|---------|------------|----------|
//! | `scale` | 1    | 0       | ±0.5       | ±0.05    |
//!
//! Cannot: a focal length that differs along x and y (anamorphic), or that varies
//! over the field (that is `radial_distortion`).

use super::{Apply, EffectDef, Model, ParamSpec, Stage};

/// The range a real lens's focal length has about its nominal one. Engineering bound:
/// stock lenses' focal lengths are quoted rounded (an "8 mm" lens may be 8.2 mm), and
/// focusing closer than infinity lengthens the image distance by about f²/d (under 1 %
/// beyond 1 m for f ≤ 10 mm); beyond ±5 % the capture's focal length, pixel pitch or
/// projection is wrong, or the value stands in for a misfit.
const SCALE_PHYSICAL: (f64, f64) = (-0.05, 0.05);

pub const EFFECT: EffectDef = EffectDef {
    name: "focal_length",
    summary: "true focal length = nominal · (1 + scale)",
    source: "EFFECTS.md; CONVENTIONS.md projection r = f·g(θ)",
    stage: Stage::Geometry,
    params: &[ParamSpec {
        name: "scale",
        unit: "1",
        neutral: 0.0,
        typical: 0.02,
        min: -0.5,
        max: 0.5,
        physical: Some(SCALE_PHYSICAL),
        doc: "relative error of the focal length",
    }],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: None,
};

fn apply(v: &[f64], m: &mut Model) {
    m.geometry.focal_scale += v[0];
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::{ideal_frame, intrinsics, scene, stokes_at};
    use crate::chain::ChainFrame;
    use crate::effects::{EffectSet, Model};

    #[test]
    fn a_pixel_sees_the_nominal_ray_of_the_pixel_scaled_toward_the_centre() {
        let mut set = EffectSet::new();
        set.set("focal_length", "scale", 0.1).unwrap();
        let scaled = ideal_frame(&set.model());
        let nominal = ideal_frame(&Model::default());
        let (cx, cy) = (intrinsics().cx_px, intrinsics().cy_px);
        for (u, v) in [(5.0, 7.0), (600.0, 20.0), (100.0, 500.0)] {
            let a = stokes_at(&scaled, u, v);
            let b = stokes_at(&nominal, cx + (u - cx) / 1.1, cy + (v - cy) / 1.1);
            assert!((a.i - b.i).abs() < 1e-12 && (a.q - b.q).abs() < 1e-12 && (a.u - b.u).abs() < 1e-12);
        }
        // The principal point sees the same ray whatever the focal length.
        assert_eq!(stokes_at(&scaled, cx, cy), stokes_at(&nominal, cx, cy));
        let f = ChainFrame::noise_free(&set.model(), &intrinsics(), &scene());
        assert!((f.intr.f_px - intrinsics().f_px * 1.1).abs() < 1e-9);
    }
}
