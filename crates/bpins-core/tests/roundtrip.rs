//! A simulated capture read back gives the numbers that were written: captures built
//! in memory (as `bpins simulate` builds them), simulated through the chain with an
//! effect, written to a temporary folder, loaded and decoded again. Simulation is a
//! pure function of (capture, model, sensor, seed): the same seed gives the same DN
//! whatever the thread count, another seed other DN.

use std::path::{Path, PathBuf};

use bpins_core::camera::Projection;
use bpins_core::conventions::image_centre_px;
use bpins_core::effects::{EffectSet, Model};
use bpins_core::internal::capture::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
use bpins_core::internal::pipeline::{sim_response, simulate_frame, SimSensor};
use bpins_core::internal::sky::sun::SunPosition;
use bpins_core::sensor::{Channel, Geometry, Layout, DEFAULT_MOSAIC};

/// A capture as `bpins simulate` builds one (cmd_simulate.rs `build_capture`), with
/// values that do not print short, so the toml must round-trip every bit.
fn capture(layout: Layout, width_px: u32, height_px: u32, projection: Projection, headings_deg: &[f64]) -> Capture {
    let ext = match layout {
        Layout::Dofp { .. } => "png",
        Layout::Colocated { .. } => "exr",
    };
    let frames = headings_deg
        .iter()
        .enumerate()
        .map(|(i, &h)| FrameSpec {
            file: PathBuf::from(format!("frames/f{i:03}.{ext}")),
            sun: SunPosition::given(40.0 + 0.1 * i as f64, 25.0 + 1.0 / 3.0),
            heading_deg: Some(h),
            tilt_x_deg: (i % 2 == 1).then_some(0.7),
            tilt_y_deg: (i % 2 == 1).then_some(-0.3),
            tilt_sigma_deg: (i % 2 == 1).then_some(0.1),
            sun_sigma_deg: None,
            yaw_deg: None,
            yaw_sigma_deg: None,
        })
        .collect();
    let (cx, cy) = image_centre_px(width_px, height_px);
    Capture {
        dir: PathBuf::new(),
        sensor: SensorSpec {
            colour: None,
            layout,
            geometry: Geometry { width_px, height_px, pixel_pitch_um: 13.8 * 612.0 / width_px as f64 },
            bit_depth: 12,
            black_level_dn: 64.0,
        },
        lens: LensSpec { projection, focal_length_mm: 8.0, principal_point_px: (cx + 0.1, cy - 0.2) },
        frames,
    }
}

fn dofp() -> Capture {
    capture(Layout::Dofp { mosaic: DEFAULT_MOSAIC }, 64, 48, Projection::Pinhole, &[0.0, 137.25, 301.0])
}

fn colocated() -> Capture {
    let layout = Layout::Colocated { channels: vec![Channel::C0, Channel::C45, Channel::C90] };
    capture(layout, 40, 30, Projection::Equidistant, &[12.5, 200.0])
}

fn sensor(seed: u64) -> SimSensor {
    SimSensor {
        peak_fraction: 0.7,
        read_noise_dn: 1.0,
        system_gain_dn_per_e: 0.1,
        dsnu_dn: 0.5,
        prnu: 0.01,
        dmax: 0.6,
        seed,
    }
}

fn model() -> Model {
    let mut set = EffectSet::new();
    set.parse_assignment("array_rotation.dtheta_deg=0.3").unwrap();
    let m = set.model();
    assert_ne!(m, Model::default());
    m
}

fn simulate(c: &Capture, seed: u64) -> Vec<FrameData> {
    let s = sensor(seed);
    let resp = sim_response(c, &s, None).unwrap();
    (0..c.frames.len()).map(|i| simulate_frame(c, i, &model(), &resp, &s, None)).collect()
}

/// Every DN of a frame, in one list (planes concatenated for colocated frames).
fn values(d: &FrameData) -> Vec<f32> {
    match d {
        FrameData::Mosaic { dn, .. } => dn.clone(),
        FrameData::Colocated { channels, .. } => channels.iter().flat_map(|(_, p)| p.iter().copied()).collect(),
    }
}

/// The frame is what the sensor declares and holds a real picture: integer DN inside
/// the ADC range, not constant.
fn check_plausible(c: &Capture, d: &FrameData) {
    let g = &c.sensor.geometry;
    assert_eq!(d.size_px(), (g.width_px, g.height_px));
    let v = values(d);
    let n = (g.width_px * g.height_px) as usize;
    match (d, &c.sensor.layout) {
        (FrameData::Mosaic { dn, .. }, Layout::Dofp { .. }) => assert_eq!(dn.len(), n),
        (FrameData::Colocated { channels, .. }, Layout::Colocated { channels: want }) => {
            assert_eq!(channels.iter().map(|c| c.0).collect::<Vec<_>>(), *want);
            assert!(channels.iter().all(|(_, p)| p.len() == n));
        }
        _ => panic!("frame data does not match the layout"),
    }
    let full = c.sensor.full_scale_dn() as f32;
    assert!(v.iter().all(|&x| x.fract() == 0.0 && x > 0.0 && x < full), "DN outside (0, {full}) or not integer");
    let (lo, hi) = v.iter().fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    // Peak at 70 % of the range above black on the first frame.
    assert!(hi > 64.0 + 0.5 * (full - 64.0) && lo < hi - 100.0, "DN span {lo}…{hi}");
}

fn write_and_read_back(c: &Capture, frames: &[FrameData], dir: &Path) -> Capture {
    c.write(dir, frames).unwrap();
    assert!(dir.join("capture.toml").is_file());
    let back = Capture::load(dir).unwrap();
    assert_eq!(back.dir, dir);
    assert_eq!(back.sensor, c.sensor, "[sensor] changed on the way through capture.toml");
    assert_eq!(back.lens, c.lens, "[lens] changed on the way through capture.toml");
    assert_eq!(back.frames, c.frames, "[[frames]] changed on the way through capture.toml");
    assert_eq!(back, Capture { dir: dir.to_path_buf(), ..c.clone() });
    for (i, want) in frames.iter().enumerate() {
        let got = back.read_frame(i).unwrap();
        assert!(got == *want, "frame {i} ({}) reads back different DN", c.frames[i].file.display());
    }
    back
}

#[test]
fn simulated_dofp_capture_reads_back_exactly() {
    let c = dofp();
    let frames = simulate(&c, 42);
    for f in &frames {
        check_plausible(&c, f);
    }
    let tmp = tempfile::tempdir().unwrap();
    let back = write_and_read_back(&c, &frames, &tmp.path().join("dofp"));
    // The capture read back simulates to the same DN as the one in memory.
    assert_eq!(simulate(&back, 42), frames);
}

#[test]
fn simulated_colocated_capture_reads_back_exactly() {
    let c = colocated();
    let frames = simulate(&c, 42);
    for f in &frames {
        check_plausible(&c, f);
    }
    let tmp = tempfile::tempdir().unwrap();
    let back = write_and_read_back(&c, &frames, &tmp.path().join("nested/colocated"));
    assert_eq!(simulate(&back, 42), frames);
}

#[test]
fn frames_differ_from_each_other_and_the_effect_is_in_them() {
    let c = dofp();
    let frames = simulate(&c, 42);
    assert_ne!(frames[0], frames[1], "different headings, same DN");
    // Same noise draw, no effect: the array rotation alone changes the DN.
    let s = sensor(42);
    let resp = sim_response(&c, &s, None).unwrap();
    let ideal = simulate_frame(&c, 0, &Model::default(), &resp, &s, None);
    assert_ne!(ideal, frames[0]);
}

#[test]
fn same_seed_same_frames_other_seed_other_frames() {
    for c in [dofp(), colocated()] {
        let a = simulate(&c, 7);
        assert_eq!(a, simulate(&c, 7), "{:?}: same seed, different DN", c.sensor.layout);
        let b = simulate(&c, 8);
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert_ne!(x, y, "{:?}: frame {i} identical under seeds 7 and 8", c.sensor.layout);
            // Noise only: the two draws differ by a few DN, not by a different picture.
            let (vx, vy) = (values(x), values(y));
            let differing = vx.iter().zip(&vy).filter(|(p, q)| p != q).count();
            assert!(differing > vx.len() / 2, "only {differing} of {} DN differ", vx.len());
            let rms = (vx.iter().zip(&vy).map(|(p, q)| ((p - q) as f64).powi(2)).sum::<f64>() / vx.len() as f64).sqrt();
            assert!(rms < 50.0, "seeds 7 and 8 differ by {rms:.1} DN rms");
        }
    }
}

#[test]
fn simulation_is_bit_identical_on_one_and_two_threads() {
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    for c in [dofp(), colocated()] {
        let one = pool(1).install(|| simulate(&c, 11));
        let two = pool(2).install(|| simulate(&c, 11));
        assert!(one == two, "{:?}: 1 and 2 threads give different DN", c.sensor.layout);
        assert_eq!(one, simulate(&c, 11));
    }
}
