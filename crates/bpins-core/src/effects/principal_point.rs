//! # `principal_point` — the true principal point is off its nominal position
//!
//! ```text
//! (c_x, c_y)_true = (c_x, c_y)_nominal + (dx_px, dy_px)
//! ```
//!
//! Source: seed paper §2.3, eq. 8 (coordinate deviation of the principal point, δβ).
//! Frame: image, pixels (x right, y down). The sensor samples rays through the true
//! principal point, while reconstruction computes β = atan2(−(v − c_y), u − c_x) and
//! the rays from the nominal one, so AoE = α − β errs by about δ/r at radius r.
//!
//! | param   | unit | neutral | fit bounds | physical |
//! |---------|------|---------|------------|----------|
//! | `dx_px` | px   | 0       | ±10 000    | ±200     |
//! | `dy_px` | px   | 0       | ±10 000    | ±200     |
//!
//! Cannot: a principal point that moves with focus, or a tilted sensor (Scheimpflug).

use super::{Apply, EffectDef, Model, ParamSpec, Stage};

/// The range a real principal point has about the nominal one, px. Engineering bound: a
/// sensor's placement in its body and a lens mount's decentration are each a few tenths
/// of a millimetre; 0.5 mm is 145 px at the IMX250MZR's 3.45 µm pitch. Beyond ±200 px the
/// capture's principal point is wrong (a crop or region of interest) or the value stands
/// in for a misfit.
const OFFSET_PHYSICAL_PX: (f64, f64) = (-200.0, 200.0);

pub const EFFECT: EffectDef = EffectDef {
    name: "principal_point",
    summary: "true principal point = nominal + (dx, dy)",
    source: "seed paper §2.3 eq. 8",
    stage: Stage::Geometry,
    params: &[
        ParamSpec {
            name: "dx_px",
            unit: "px",
            neutral: 0.0,
            typical: 5.0,
            min: -1e4,
            max: 1e4,
            physical: Some(OFFSET_PHYSICAL_PX),
            doc: "offset along image x (columns)",
        },
        ParamSpec {
            name: "dy_px",
            unit: "px",
            neutral: 0.0,
            typical: -3.0,
            min: -1e4,
            max: 1e4,
            physical: Some(OFFSET_PHYSICAL_PX),
            doc: "offset along image y (rows, down)",
        },
    ],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: None,
};

fn apply(v: &[f64], m: &mut Model) {
    m.geometry.pp_offset_px[0] += v[0];
    m.geometry.pp_offset_px[1] += v[1];
}

#[cfg(test)]
mod tests {
    use crate::chain::tests::{ideal_frame, stokes_at};
    use crate::effects::EffectSet;

    #[test]
    fn shifting_the_principal_point_shifts_the_pattern_with_it() {
        // The sky seen at pixel (u, v) with a (+3, −2) px offset equals the ideal sky
        // at (u − 3, v + 2): the whole pattern moves with the principal point.
        let mut set = EffectSet::new();
        set.set("principal_point", "dx_px", 3.0).unwrap();
        set.set("principal_point", "dy_px", -2.0).unwrap();
        let shifted = ideal_frame(&set.model());
        let ideal = ideal_frame(&EffectSet::new().model());
        for (u, v) in [(10.0, 20.0), (300.0, 200.0), (600.0, 500.0)] {
            let a = stokes_at(&shifted, u, v);
            let b = stokes_at(&ideal, u - 3.0, v + 2.0);
            assert!((a.q - b.q).abs() < 1e-12 && (a.u - b.u).abs() < 1e-12 && (a.i - b.i).abs() < 1e-12);
        }
    }
}
