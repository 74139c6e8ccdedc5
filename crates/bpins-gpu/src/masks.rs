//! Which of the registry's hooks a dispatch runs: per stage (sky, per-pixel, analyzer,
//! sensor, mosaic), one bit per effect that some frame of the dispatch has off its
//! neutral vector. They are the pipeline constants `SKY_ON`, `RAY_ON`, … of the
//! generated dispatch (`ray_dispatch.rs`), so the driver leaves a neutral effect's
//! call out at compile time: the ideal chain does no per-pixel work for the 21
//! effects it does not have. The GPU twin of `bpins_core::twin::ActiveEffects`.
//!
//! Each effect is the identity at its neutral vector, bitwise
//! (`every_registered_effect_at_neutral_gives_bitwise_the_ideal_chain` in bpins-core;
//! `a_neutral_effect_left_out_of_a_dispatch_changes_no_output_bit` in
//! `tests/gpu_parity.rs` on the device), so leaving it out changes no
//! output: bit for bit with the f64 kernels and on lavapipe. A vendor compiler may fuse
//! `a * b + c` differently once other hooks are compiled in, so its f32 kernels may move
//! the last bits (up to 4 ulp of the chain and sky maps on an NVIDIA H200; the DN and the
//! heading sums were bitwise the same). The vectors are compared
//! as the kernels receive them ([`FrameParams`]'s (hi, lo) pairs), bit for bit.

use crate::params::{analyzer_slots, sky_slots, FrameParams, Wide4};
use crate::ray_dispatch::MASKS;
use bpins_core::effects::{
    neutral_analyzer_params, neutral_mosaic_params, neutral_ray_params, neutral_sensor_params, neutral_sky_params,
};
use std::sync::LazyLock;

/// The stages' masks, in the order of [`MASKS`] (sky, ray, analyzer, sensor, mosaic):
/// bit `k` set where effect `k` of the stage (registry order) runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct EffectMasks(pub [u32; 5]);

/// A frame with every hook at its effect's neutral vector (the rest zero).
static NEUTRAL: LazyLock<FrameParams> = LazyLock::new(|| FrameParams {
    sky: sky_slots(neutral_sky_params()),
    ray: neutral_ray_params().map(Wide4::new),
    analyzer: analyzer_slots(neutral_analyzer_params()),
    sensor: neutral_sensor_params().map(Wide4::new),
    mosaic_fx: neutral_mosaic_params().map(Wide4::new),
    ..FrameParams::default()
});

/// Bit `k` set where slot `k` of `slots` differs, bit for bit, from slot `k` of `neutral`.
fn off_neutral<T: bytemuck::Pod>(slots: &[T], neutral: &[T]) -> u32 {
    slots.iter().zip(neutral).enumerate().fold(0, |m, (k, (a, b))| {
        if bytemuck::bytes_of(a) == bytemuck::bytes_of(b) {
            m
        } else {
            m | 1 << k
        }
    })
}

impl EffectMasks {
    /// The effects some frame of `frames` has off its neutral vector.
    pub(crate) fn of(frames: &[FrameParams]) -> EffectMasks {
        let n = &*NEUTRAL;
        frames.iter().fold(EffectMasks([0; 5]), |EffectMasks([sky, ray, analyzer, sensor, mosaic]), f| {
            EffectMasks([
                sky | off_neutral(&f.sky, &n.sky),
                ray | off_neutral(&f.ray, &n.ray),
                analyzer | off_neutral(&f.analyzer, &n.analyzer),
                sensor | off_neutral(&f.sensor, &n.sensor),
                mosaic | off_neutral(&f.mosaic_fx, &n.mosaic_fx),
            ])
        })
    }

    /// The pipeline constants (name, value).
    pub(crate) fn constants(self) -> [(&'static str, f64); 5] {
        std::array::from_fn(|i| (MASKS[i], f64::from(self.0[i])))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bpins_core::camera::{Intrinsics, Projection};
    use bpins_core::effects::{
        EffectSet, Model, ANALYZER_EFFECTS, MOSAIC_EFFECTS, RAY_EFFECTS, REGISTRY, SENSOR_EFFECTS, SKY_EFFECTS,
    };
    use bpins_core::sensor::Response;
    use bpins_core::twin::{ChainFrame, NoiseIndex, Scene};

    fn frame(model: &Model) -> FrameParams {
        let intr =
            Intrinsics { projection: Projection::Pinhole, f_px: 400.0, cx_px: 31.5, cy_px: 23.5, distortion: [0.0; 2] };
        let scene = Scene {
            sun_az_deg: 40.0,
            sun_el_deg: 25.0,
            heading_deg: 30.0,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            dmax: 0.6,
        };
        let f = ChainFrame::new(
            model,
            &intr,
            &scene,
            &Response::samples(3000.0),
            NoiseIndex { seed: 1, trial: 0, frame: 0 },
        );
        FrameParams::try_from(&f).expect("a lab frame")
    }

    #[test]
    fn the_ideal_frame_runs_no_hook_and_each_effect_sets_its_own_bit() {
        assert_eq!(EffectMasks::of(&[frame(&Model::default())]), EffectMasks([0; 5]));
        assert_eq!(EffectMasks::of(&[]), EffectMasks([0; 5]));
        let stages: [Vec<&str>; 5] = [
            SKY_EFFECTS.iter().map(|e| e.name).collect(),
            RAY_EFFECTS.iter().map(|e| e.name).collect(),
            ANALYZER_EFFECTS.iter().map(|e| e.name).collect(),
            SENSOR_EFFECTS.iter().map(|e| e.name).collect(),
            MOSAIC_EFFECTS.iter().map(|e| e.name).collect(),
        ];
        let mut seen = 0;
        for e in REGISTRY {
            let Some((stage, k)) =
                stages.iter().enumerate().find_map(|(i, s)| Some((i, s.iter().position(|n| *n == e.name)?)))
            else {
                continue;
            };
            // The effect at its typical strength.
            let mut set = EffectSet::new();
            for p in e.params {
                set.parse_assignment(&format!("{}.{}={}", e.name, p.name, p.typical)).expect("a registered effect");
            }
            let model = set.model();
            let mut want = [0; 5];
            want[stage] = 1 << k;
            let ideal = frame(&Model::default());
            assert_eq!(EffectMasks::of(&[ideal, frame(&model)]), EffectMasks(want), "{}", e.name);
            seen += 1;
        }
        assert_eq!(seen, stages.iter().map(Vec::len).sum::<usize>());
    }
}
