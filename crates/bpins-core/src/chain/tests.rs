//! The chain's tests, and the helpers the effects' tests share (`ideal_frame`,
//! `intrinsics`, `scene`, `stokes_at`, `ray_at_r2`).

use super::*;
use crate::camera::Projection;
use crate::effects::EffectSet;

/// The sample captures' camera: 612 × 512, 13.8 µm, 8 mm pinhole.
pub fn intrinsics() -> Intrinsics {
    Intrinsics {
        projection: Projection::Pinhole,
        f_px: 8000.0 / 13.8,
        cx_px: 305.5,
        cy_px: 255.5,
        distortion: [0.0; 2],
    }
}

pub fn scene() -> Scene {
    Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 }
}

pub(crate) fn ideal_frame(model: &Model) -> ChainFrame {
    ChainFrame::noise_free(model, &intrinsics(), &scene())
}

pub(crate) fn stokes_at(f: &ChainFrame, u: f64, v: f64) -> Stokes {
    pixel_stokes(f, u, v)
}

/// A ray of the samples' camera with its squared normalised radius set to `r2`
/// (what the radially symmetric lens effects read).
pub(crate) fn ray_at_r2(r2: f64) -> RayGeometry {
    RayGeometry { r2, ..intrinsics().geometry(100.0, 100.0) }
}

#[test]
fn every_registered_effect_at_neutral_gives_bitwise_the_ideal_chain() {
    let ideal = ideal_frame(&Model::default());
    for e in crate::effects::REGISTRY {
        let mut set = EffectSet::new();
        set.enable(e.name).unwrap();
        let mut f = ideal_frame(&set.model());
        assert_eq!(f.active, ideal.active, "{} at neutral is off", e.name);
        // Applied all the same (as the row kernels and the GPU do): the identity.
        f.active = ActiveEffects::all();
        for (u, v) in [(0.0, 0.0), (305.5, 255.5), (611.0, 511.0), (17.0, 400.0)] {
            let (a, b) = (pixel_stokes(&f, u, v), pixel_stokes(&ideal, u, v));
            assert_eq!(a, b, "{}", e.name);
            let g = f.intr.geometry(u, v);
            assert_eq!(ray_stokes_field::<true>(&f, &g), a, "{}", e.name);
            for ch in 0..4 {
                assert_eq!(pixel_signal_dn(&f, a, ch), pixel_signal_dn(&ideal, b, ch), "{}", e.name);
                let (uu, vv) = (u as u32, v as u32);
                let site = site_signal_dn(&f, a, &g, uu, vv, ch);
                assert_eq!(site, pixel_signal_dn(&ideal, b, ch), "{} at its site", e.name);
            }
        }
    }
}

#[test]
fn noise_free_sensor_is_gain_plus_offset() {
    let mut set = EffectSet::new();
    set.set("channel_response", "gain45", 0.1).unwrap();
    set.set("channel_response", "offset45_dn", 2.0).unwrap();
    let resp = Response { black_level_dn: 64.0, ..Response::ideal(1000.0) };
    let f = ChainFrame::new(&set.model(), &intrinsics(), &scene(), &resp, NoiseIndex { seed: 1, trial: 0, frame: 0 });
    let s = pixel_stokes(&f, 100.0, 100.0);
    let sig = pixel_signal_dn(&f, s, 1);
    let want = 1000.0 * 1.1 * analyzer_intensity(s, &f.analyzers[1]);
    assert!((sig - want).abs() < 1e-9);
    assert!((sensor_dn(&f, sig, 1, &sensor_noise(&f, 7, 1)) - (want + 66.0)).abs() < 1e-9);
}

#[test]
fn sensor_noise_has_the_emva_variance() {
    let resp =
        Response { read_noise_dn: 2.0, system_gain_dn_per_e: 0.5, black_level_dn: 100.0, ..Response::ideal(1.0) };
    let f =
        ChainFrame::new(&Model::default(), &intrinsics(), &scene(), &resp, NoiseIndex { seed: 3, trial: 1, frame: 2 });
    let n = 100_000;
    let signal = 1000.0;
    let (mut s1, mut s2) = (0.0, 0.0);
    for p in 0..n {
        let x = sensor_dn(&f, signal, 0, &sensor_noise(&f, p, 0)) - 1100.0;
        s1 += x;
        s2 += x * x;
    }
    let var = s2 / n as f64 - (s1 / n as f64).powi(2);
    let want = 4.0 + 0.5 * signal;
    assert!((var / want - 1.0).abs() < 0.02, "variance {var} DN², want {want}");
}

#[test]
fn quantization_rounds_half_up_and_clips() {
    let resp = Response { quantize: true, bit_depth: 8, ..Response::ideal(1.0) };
    let f =
        ChainFrame::new(&Model::default(), &intrinsics(), &scene(), &resp, NoiseIndex { seed: 0, trial: 0, frame: 0 });
    assert_eq!(sensor_dn(&f, 2.5, 0, &SensorNoise::default()), 3.0);
    assert_eq!(sensor_dn(&f, 2.49, 0, &SensorNoise::default()), 2.0);
    assert_eq!(sensor_dn(&f, 300.0, 0, &SensorNoise::default()), 255.0);
    assert_eq!(sensor_dn(&f, -4.0, 0, &SensorNoise::default()), 0.0);
}

#[test]
fn same_key_same_noise_other_frame_other_noise() {
    let resp = Response { read_noise_dn: 1.0, ..Response::ideal(1.0) };
    let mk = |frame| {
        ChainFrame::new(&Model::default(), &intrinsics(), &scene(), &resp, NoiseIndex { seed: 5, trial: 0, frame })
    };
    let dn = |frame| {
        let f = mk(frame);
        sensor_dn(&f, 10.0, 1, &sensor_noise(&f, 3, 1))
    };
    assert_eq!(dn(0), dn(0));
    assert_ne!(dn(0), dn(1));
}

#[test]
fn four_channel_noise_draws_the_same_numbers_as_one_channel() {
    let resp = Response { read_noise_dn: 1.0, dsnu_dn: 2.0, prnu: 0.01, ..Response::ideal(1.0) };
    let f =
        ChainFrame::new(&Model::default(), &intrinsics(), &scene(), &resp, NoiseIndex { seed: 5, trial: 2, frame: 1 });
    for p in [0, 17, 90_001] {
        let four = sensor_noise4(&f, p);
        for (ch, n) in four.iter().enumerate() {
            assert_eq!(*n, sensor_noise(&f, p, ch));
        }
    }
}
