//! Field conditions end to end: a small fisheye DoFP capture (256 × 256 px at 13.8 µm,
//! equidistant f = 2.2 mm: ±46° across, the samples' field sky with half the pixels
//! each way) simulated in memory with every scene element, then read back as DN.
//! Frame 0 looks up with the sun (elevation 60°) in view; frame 1 is tilted 55°
//! toward azimuth 300°, away from the sun, so it sees the skyline and the ground.

use bpins_core::camera::Projection;
use bpins_core::effects::Model;
use bpins_core::internal::capture::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
use bpins_core::internal::chain::ChainFrame;
use bpins_core::internal::pipeline::{sim_chain_frame, simulate_capture, SimSensor};
use bpins_core::internal::recon::{superpixels, PolImage, Reconstructor};
use bpins_core::internal::scene::clouds::Clouds;
use bpins_core::internal::sky::sun::SunPosition;
use bpins_core::scene::FieldScene;
use bpins_core::sensor::{Channel, Geometry, Layout, DEFAULT_MOSAIC};
use glam::DVec3;
use std::path::PathBuf;

const W: usize = 256;
const FULL_DN: f32 = 4095.0;

fn capture(sun_el_deg: f64) -> Capture {
    let frame = |i: usize, heading: f64, tilt_x: Option<f64>| FrameSpec {
        file: PathBuf::from(format!("frames/f{i:03}.png")),
        sun: SunPosition::given(120.0, sun_el_deg),
        heading_deg: Some(heading),
        tilt_x_deg: tilt_x,
        tilt_y_deg: None,
        tilt_sigma_deg: None,
        sun_sigma_deg: None,
        yaw_deg: None,
        yaw_sigma_deg: None,
    };
    Capture {
        dir: PathBuf::new(),
        sensor: SensorSpec {
            colour: None,
            layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
            geometry: Geometry { width_px: W as u32, height_px: W as u32, pixel_pitch_um: 13.8 },
            bit_depth: 12,
            black_level_dn: 64.0,
        },
        lens: LensSpec {
            projection: Projection::Equidistant,
            focal_length_mm: 2.2,
            principal_point_px: bpins_core::conventions::image_centre_px(W as u32, W as u32),
        },
        frames: vec![frame(0, 7.0, None), frame(1, 300.0, Some(55.0))],
    }
}

fn sensor() -> SimSensor {
    SimSensor::samples(3)
}

/// Every element but the overcast deck (which would hide the clear sky the checks
/// below compare with), 16 clouds.
fn field(seed: u64) -> FieldScene {
    let mut f = FieldScene::all(seed).without("overcast");
    f.set("clouds", "count", 16.0).unwrap();
    f
}

fn dn(d: &FrameData) -> &[f32] {
    match d {
        FrameData::Mosaic { dn, .. } => dn,
        _ => panic!("a DoFP capture gives mosaics"),
    }
}

fn stokes(d: &FrameData) -> PolImage {
    let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap();
    superpixels(dn(d), W, W, &DEFAULT_MOSAIC, &rec, FULL_DN as f64)
}

/// The chain of frame `i` (truth: intrinsics, orientation, scene) without noise.
fn chain(c: &Capture, i: usize, f: &FieldScene) -> ChainFrame {
    let resp = bpins_core::sensor::Response::ideal(1.0);
    sim_chain_frame(c, i, &Model::default(), &resp, &sensor(), Some(f))
}

/// World (ENU) ray of pixel (u, v) of chain frame `f`.
fn world_ray(f: &ChainFrame, u: f64, v: f64) -> DVec3 {
    f.field.as_ref().unwrap().world_from_cam * f.intr.ray(u, v)
}

/// (I, DoLP) of superpixel (i, j); NaN where masked.
fn at(img: &PolImage, i: usize, j: usize) -> (f64, f64) {
    let [s0, s1, s2] = img.iqu[j * img.width + i];
    (s0, (s1 * s1 + s2 * s2).sqrt() / s0)
}

#[test]
fn a_field_capture_saturates_at_the_sun_is_unpolarized_below_the_horizon_and_depolarized_by_clouds() {
    let c = capture(60.0);
    let scene = field(5);
    let (_, frames) = simulate_capture(&c, &Model::default(), &sensor(), Some(&scene)).unwrap();

    // The sun is in view in frame 0: saturated pixels exist, all of them near the sun.
    let f0 = chain(&c, 0, &scene);
    let sun_cam = f0.sun_cam;
    let (su, sv) = f0.intr.project(sun_cam).unwrap();
    assert!((0.0..W as f64).contains(&su) && (0.0..W as f64).contains(&sv), "sun at ({su}, {sv})");
    let mut saturated = 0;
    for (k, &x) in dn(&frames[0]).iter().enumerate() {
        if x >= FULL_DN {
            saturated += 1;
            let d = f0.intr.ray((k % W) as f64, (k / W) as f64);
            let deg = d.dot(sun_cam).clamp(-1.0, 1.0).acos().to_degrees();
            assert!(deg < 15.0, "a saturated pixel {deg:.1}° from the sun");
        }
    }
    let centre = dn(&frames[0])[sv.round() as usize * W + su.round() as usize];
    assert!(saturated >= 4 && centre >= FULL_DN, "{saturated} saturated pixels, {centre} DN at the sun");

    // Below the horizon (frame 1, tilted): the ground is unpolarized, exactly in the
    // chain and within the noise in the DN; the sky above is not.
    let f1 = chain(&c, 1, &scene);
    let img = stokes(&frames[1]);
    let (mut ground, mut sky) = ([0.0; 3], [0.0; 3]);
    let (mut n_ground, mut n_sky) = (0, 0);
    for j in 0..img.height {
        for i in 0..img.width {
            let (x, y) = img.position_px(i, j);
            let el = world_ray(&f1, x, y).z.asin().to_degrees();
            let s = img.iqu[j * img.width + i];
            if el < -1.5 {
                let exact = bpins_core::internal::chain::pixel_stokes(&f1, x.floor(), y.floor());
                assert_eq!((exact.q, exact.u), (0.0, 0.0), "ground at ({x}, {y}) is polarized in the chain");
                if s[0].is_finite() {
                    (0..3).for_each(|k| ground[k] += s[k]);
                    n_ground += 1;
                }
            } else if el > 40.0 && s[0].is_finite() {
                (0..3).for_each(|k| sky[k] += s[k]);
                n_sky += 1;
            }
        }
    }
    let dolp = |s: [f64; 3]| (s[1] * s[1] + s[2] * s[2]).sqrt() / s[0];
    assert!(n_ground > 500 && n_sky > 500, "{n_ground} ground, {n_sky} sky superpixels");
    assert!(dolp(ground) < 0.005, "ground DoLP {}", dolp(ground));
    assert!(dolp(sky) > 0.1, "sky DoLP {}", dolp(sky));

    // Clouds: at each cloud core in view, the DoLP is well below the clear sky's at the
    // same pixel (the same scattering angle), rendered without the clouds.
    let clear = simulate_capture(&c, &Model::default(), &sensor(), Some(&scene.without("clouds"))).unwrap().1;
    let mut checked = 0;
    for (fi, f) in [&f0, &f1].into_iter().enumerate() {
        let (cloudy, clear) = (stokes(&frames[fi]), stokes(&clear[fi]));
        for cloud in &f.field.as_ref().unwrap().element::<Clouds>().unwrap().clouds {
            let Some((u, v)) = f.intr.project(f.field.as_ref().unwrap().cam_from_world * cloud.centre_world) else {
                continue;
            };
            let (i, j) = ((u - 0.5) / 2.0, (v - 0.5) / 2.0);
            if !(2.0..cloudy.width as f64 - 3.0).contains(&i) || !(2.0..cloudy.height as f64 - 3.0).contains(&j) {
                continue;
            }
            let (i, j) = (i.round() as usize, j.round() as usize);
            let ((i_cloud, d_cloud), (i_clear, d_clear)) = (at(&cloudy, i, j), at(&clear, i, j));
            // Skip a core hidden by the skyline or lost in the sun's saturation.
            if !(d_clear > 0.1 && i_cloud.is_finite() && i_clear.is_finite()) {
                continue;
            }
            assert!(d_cloud < 0.5 * d_clear, "frame {fi}: cloud DoLP {d_cloud:.3} vs clear {d_clear:.3}");
            checked += 1;
        }
    }
    assert!(checked >= 2, "only {checked} cloud cores in view");
}

#[test]
fn the_scene_is_seeded_and_an_empty_scene_is_the_lab_sky() {
    let c = capture(60.0);
    let run = |f: Option<&FieldScene>| simulate_capture(&c, &Model::default(), &sensor(), f).unwrap().1;
    let a = run(Some(&field(5)));
    assert_eq!(a, run(Some(&field(5))), "same seed, same DN");
    let b = run(Some(&field(6)));
    assert_ne!(a[1], b[1], "another seed, other DN");
    let clouds = |seed| chain(&c, 0, &field(seed)).field.unwrap().element::<Clouds>().unwrap().clouds.clone();
    assert!(clouds(5).iter().zip(clouds(6)).all(|(x, y)| x.centre_world != y.centre_world), "other clouds");
    // An empty scene is bitwise the lab-clean sky.
    assert_eq!(run(None), run(Some(&FieldScene::new(5))));
}

#[test]
fn a_twilight_sun_simulates_with_every_element() {
    for el in [-3.0, -6.0] {
        let c = capture(el);
        for f in [None, Some(field(2))] {
            let (resp, frames) = simulate_capture(&c, &Model::default(), &sensor(), f.as_ref()).unwrap();
            assert!(resp.gain_dn.is_finite() && resp.gain_dn > 0.0);
            let px = dn(&frames[0]);
            assert!(px.iter().all(|x| x.is_finite()) && px.iter().any(|&x| x > 64.0 + 100.0), "sun at {el}°");
        }
    }
}
