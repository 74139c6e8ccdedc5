//! # `mount_tilt` — the camera sits tilted on its mount
//!
//! ```text
//! world_from_camera = R_level(ψ) · Rx(tilt_x) · Ry(tilt_y) · Rx(tilt_x_deg) · Ry(tilt_y_deg)
//!                      frame's reference orientation          this effect (same every frame)
//! ```
//!
//! Source: CONVENTIONS.md "Tilt"; EFFECTS.md. Frame: rotations about the camera's own
//! x then y axis, right-handed, degrees. Unlike a per-frame tilt, this one turns with
//! the camera on a turntable, which is what makes it separable from the sky.
//! Near the zenith it moves the pattern almost like a principal-point shift of
//! f·tilt (confusable for a narrow field of view).
//!
//! | param        | unit | neutral | fit bounds | physical |
//! |--------------|------|---------|------------|----------|
//! | `tilt_x_deg` | deg  | 0       | ±45        | ±5       |
//! | `tilt_y_deg` | deg  | 0       | ±45        | ±5       |
//!
//! Cannot: a tilt that changes between frames (that is the frame's `tilt_*_deg`).

use super::{Apply, EffectDef, Model, ParamSpec, Stage};

/// The range a real camera's tilt on its mount has, degrees. Engineering bound: a camera
/// levelled by hand or by its mount sits within a degree or two; beyond ±5° the frames'
/// tilt is not what the capture says, or the value stands in for a misfit.
const TILT_PHYSICAL_DEG: (f64, f64) = (-5.0, 5.0);

pub const EFFECT: EffectDef = EffectDef {
    name: "mount_tilt",
    summary: "the camera sits tilted on its mount: the same tilt in every frame",
    source: "CONVENTIONS.md (tilt), EFFECTS.md",
    stage: Stage::Geometry,
    params: &[
        ParamSpec {
            name: "tilt_x_deg",
            unit: "deg",
            neutral: 0.0,
            typical: 1.0,
            min: -45.0,
            max: 45.0,
            physical: Some(TILT_PHYSICAL_DEG),
            doc: "rotation about camera x",
        },
        ParamSpec {
            name: "tilt_y_deg",
            unit: "deg",
            neutral: 0.0,
            typical: -0.5,
            min: -45.0,
            max: 45.0,
            physical: Some(TILT_PHYSICAL_DEG),
            doc: "rotation about camera y",
        },
    ],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: None,
};

fn apply(v: &[f64], m: &mut Model) {
    m.geometry.mount_tilt_deg[0] += v[0];
    m.geometry.mount_tilt_deg[1] += v[1];
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::{ideal_frame, scene, stokes_at};
    use crate::chain::ChainFrame;
    use crate::effects::EffectSet;

    #[test]
    fn a_mount_tilt_equals_the_same_frame_tilt() {
        let mut set = EffectSet::new();
        set.set("mount_tilt", "tilt_x_deg", 2.0).unwrap();
        let tilted = ideal_frame(&set.model());
        let mut sc = scene();
        sc.tilt_x_deg = 2.0;
        let frame_tilt = ChainFrame::noise_free(&EffectSet::new().model(), &crate::chain::tests::intrinsics(), &sc);
        for (u, v) in [(10.0, 20.0), (300.0, 200.0)] {
            let a = stokes_at(&tilted, u, v);
            let b = stokes_at(&frame_tilt, u, v);
            assert!((a.q - b.q).abs() < 1e-12 && (a.u - b.u).abs() < 1e-12);
        }
        let ideal = ideal_frame(&EffectSet::new().model());
        assert!((stokes_at(&ideal, 10.0, 20.0).q - stokes_at(&tilted, 10.0, 20.0).q).abs() > 1e-4);
    }
}
