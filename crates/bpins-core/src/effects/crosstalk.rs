//! # `crosstalk` — DoFP pixels share signal with their edge neighbours
//!
//! ```text
//! S'(u, v) = (1 − 4c)·S(u, v) + c·[S(u−1, v) + S(u+1, v) + S(u, v−1) + S(u, v+1)]
//! ```
//!
//! Source: EFFECTS.md (optical and electrical crosstalk of a micro-polarizer array:
//! light through one analyzer reaching the photodiode under its neighbour). S is the
//! photo-signal in DN after each pixel's own analyzer and channel gain, before the
//! sensor's noise; a neighbour outside the sensor contributes nothing (that signal
//! is lost). On a DoFP mosaic every edge neighbour sits behind a different analyzer,
//! so crosstalk mixes channels: it lowers the measured DoLP by about (1 − 8c) and,
//! with unequal neighbours, biases the AoP. Colocated sensors have no mosaic, and no
//! crosstalk here. A neighbour pass: the drivers evaluate the four neighbours' signals
//! (rows above and below on the CPU, per pixel on the GPU, `mosaic_pixel_dn` in
//! `shaders/common/chain.wgsl`), both through this function.
//!
//! | param | unit | neutral | fit bounds | physical  |
//! |-------|------|---------|------------|-----------|
//! | `c`   | 1    | 0       | [0, 0.125] | [0, 0.05] |
//!
//! Cannot: diagonal neighbours, anisotropic crosstalk (rows ≠ columns), or crosstalk
//! that depends on the angle of incidence.

use super::{Apply, EffectDef, Inseparable, ParamSpec, SensorParams, SkyBlindness, Stage};

/// The range a real DoFP sensor's crosstalk has. Engineering bound: crosstalk c raises a
/// channel's apparent ε by about 2c (crossed light reaches it from its 45° and 135°
/// neighbours), and on-chip micro-polarizer arrays measure extinction ratios above 10
/// through the whole pixel (ER 43 for a 65-nm CMOS wire grid: Zhang et al. 2014, IEEE
/// Trans. Electron Devices, doi:10.1109/TED.2014.2299757), so 2c < 0.1.
const C_PHYSICAL: (f64, f64) = (0.0, 0.05);

pub const EFFECT: EffectDef = EffectDef {
    name: "crosstalk",
    summary: "dofp: each pixel keeps (1 - 4c) of its signal and receives c of each edge neighbour's",
    source: "EFFECTS.md",
    stage: Stage::Sensor,
    params: &[ParamSpec {
        name: "c",
        unit: "1",
        neutral: 0.0,
        typical: 0.01,
        min: 0.0,
        max: 0.125,
        physical: Some(C_PHYSICAL),
        doc: "fraction of its signal a pixel gives to each edge neighbour",
    }],
    apply: Apply::Mosaic { params: |v| [v[0], 0.0, 0.0, 0.0], pixel: crosstalk },
    wgsl: Some(include_str!("../../../../shaders/effects/crosstalk.wgsl")),
    derivatives: &[],
    inseparable: Some(Inseparable {
        when: SkyBlindness::Dofp,
        why: |dmax_fixed| {
            format!(
                "away from the sensor's border (not fitted) crosstalk between a pixel and its four neighbours lowers \
                 the modulation as a lower sky DoLP does ({}); a lab capture through a polarizer measures it, or fit \
                 it alone with the sky's d_max given (`fit --effects crosstalk --fixed-dmax D`)",
                if dmax_fixed { "sky_depolarization" } else { "each frame's d_max" }
            )
        },
    }),
};

/// A pixel's photo-signal after crosstalk c = `p[0]`, from its own and its edge
/// neighbours' (0 for a neighbour outside the sensor).
#[inline(always)]
pub fn crosstalk(p: &SensorParams, own: f64, up: f64, down: f64, left: f64, right: f64) -> f64 {
    let c = p[0];
    (1.0 - 4.0 * c) * own + c * (up + down + left + right)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::{mosaic_pixel_signal_dn, ChainFrame};
    use crate::effects::{EffectSet, Model};
    use crate::sensor::DEFAULT_MOSAIC;
    use crate::simulate::render_mosaic;

    #[test]
    fn signal_is_conserved_inside_and_zero_strength_is_the_identity() {
        assert_eq!(crosstalk(&[0.0; 4], 3.5, 1.0, 2.0, 3.0, 4.0), 3.5);
        let (c, own, n) = (0.05, 10.0, [1.0, 2.0, 3.0, 4.0]);
        let out = crosstalk(&[c, 0.0, 0.0, 0.0], own, n[0], n[1], n[2], n[3]);
        // What this pixel loses, its neighbours gain: 4c·own leaves, c·Σn arrives.
        assert!((out - (own - 4.0 * c * own + c * n.iter().sum::<f64>())).abs() < 1e-15);
    }

    #[test]
    fn the_rendered_mosaic_is_the_per_pixel_reference_and_mixes_channels() {
        let mut set = EffectSet::new();
        set.set("crosstalk", "c", 0.03).unwrap();
        let (w, h) = (40, 24);
        let f = ChainFrame::noise_free(&set.model(), &intrinsics(), &scene());
        let dn = render_mosaic(&f, w, h, &DEFAULT_MOSAIC);
        for (u, v) in [(0, 0), (17, 9), (39, 23), (5, 23), (39, 0)] {
            let want = mosaic_pixel_signal_dn(&f, u, v, w, h, &DEFAULT_MOSAIC);
            assert_eq!(dn[v * w + u], want as f32, "({u}, {v})");
        }
        // Inside the sensor each pixel moves toward its neighbours' mean.
        let ideal = ChainFrame::noise_free(&Model::default(), &intrinsics(), &scene());
        let dn0 = render_mosaic(&ideal, w, h, &DEFAULT_MOSAIC);
        let (u, v) = (17, 9);
        let mean = (dn0[(v - 1) * w + u] + dn0[(v + 1) * w + u] + dn0[v * w + u - 1] + dn0[v * w + u + 1]) / 4.0;
        assert!((dn[v * w + u] - dn0[v * w + u]) * (mean - dn0[v * w + u]) > 0.0);
    }
}
