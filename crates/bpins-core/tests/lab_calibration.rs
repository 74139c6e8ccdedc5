//! Lab calibration end to end: the sample `lab-flawed-sensor` (an independent
//! implementation's flawed sensor, with truth in samples/README.md) calibrated from
//! its lab capture and its sky headings read through the calibration.

mod common;

use std::path::Path;
use std::sync::Arc;

use bpins_core::calibration::Calibration;
use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
use bpins_core::conventions::wrap_deg_180;
use bpins_core::effects::EffectSet;
use bpins_core::internal::capture::{Capture, FrameData, LabCapture};
use bpins_core::internal::capture::{LabFrame, LensSpec, SensorSpec};
use bpins_core::internal::heading::field::RawImage;
use bpins_core::internal::lab::simulate::{lab_frames, truth_maps, LabPlan, LabSensor, PixelFlaws};
use bpins_core::internal::lab::{calibrate, LabCalibration};
use bpins_core::internal::pipeline::apply_pixel_maps;
use bpins_core::internal::pixel_analyzers::PixelMaps;
use bpins_core::sensor::{Geometry, Layout, DEFAULT_MOSAIC};

const LAB: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/lab-flawed-sensor/lab");
const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/lab-flawed-sensor/sky");

fn sample_calibration() -> LabCalibration {
    let lab = LabCapture::load(Path::new(LAB)).unwrap();
    calibrate(&lab, &|_, _| {}).unwrap()
}

/// RMS heading error of the sky frames through the front door with `cal`.
fn compass_rms(sky: &Capture, cal: Calibration) -> f64 {
    let g = &sky.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let cfg = CompassConfig {
        calibration: cal,
        ..CompassConfig::dofp(sky.intrinsics(), w, h, sky.sensor.bit_depth, sky.sensor.black_level_dn)
    };
    let mut compass = Compass::new(cfg).unwrap();
    let mut s2 = 0.0;
    for (i, f) in sky.frames.iter().enumerate() {
        let FrameData::Mosaic { dn, .. } = sky.read_frame(i).unwrap() else { panic!() };
        let sun = Sun::Angles { azimuth_deg: f.sun.azimuth_deg, elevation_deg: f.sun.elevation_deg, sigma_deg: 0.0 };
        let fix = compass.heading(RawImage::packed(&dn, w, h), sun, Attitude::default()).unwrap();
        let e = wrap_deg_180(fix.heading_deg().unwrap() - f.heading_deg.unwrap());
        s2 += e * e;
    }
    (s2 / sky.frames.len() as f64).sqrt()
}

#[test]
fn the_flawed_sample_sensor_is_calibrated_and_its_sky_headings_fall_to_the_noise() {
    let cal = sample_calibration();
    for s in &cal.summary {
        eprintln!("{s:?}");
    }
    eprintln!("{:?}\n{:?}\n{:?}", cal.photon_transfer, cal.flat, cal.left_out);
    let sky = Capture::load(Path::new(SKY)).unwrap();
    let raw = compass_rms(&sky, Calibration::default());
    let pixels = Calibration { pixels: Some(Arc::new(cal.maps.clone())), ..Default::default() };
    let calibrated = compass_rms(&sky, pixels);
    eprintln!("heading RMS: nominal {raw:.4}°, calibrated {calibrated:.4}°");
    // samples/README.md: 0.4° RMS read nominally, to the noise (~0.01°) calibrated.
    assert!(raw > 0.3, "{raw}");
    assert!(calibrated < 0.015, "{calibrated}");

    // The truth the sample was made with (samples/README.md), read back per channel:
    // analyzer offsets 0, +0.7, −0.4, +0.5°, gradient +0.6° across x and −0.4° down y,
    // white spread 0.3° (plus the fit's own noise); ε 0.010, 0.020, 0.012, 0.025.
    let want_offset = [0.0, 0.7, -0.4, 0.5];
    let want_eps = [0.010, 0.020, 0.012, 0.025];
    for (k, s) in cal.summary.iter().filter(|s| s.quantity == "analyzer angle offset").enumerate() {
        assert!((s.mean - want_offset[k]).abs() < 4.0 * s.mean_sigma + 0.005, "{s:?}");
        assert!((s.gradient_x - 0.6).abs() < 4.0 * s.gradient_x_sigma + 0.01, "{s:?}");
        assert!((s.gradient_y + 0.4).abs() < 4.0 * s.gradient_y_sigma + 0.01, "{s:?}");
        let white = (s.spread.powi(2) - s.pixel_sigma_rms.unwrap().powi(2)).sqrt();
        assert!((white - 0.3).abs() < 0.02, "white spread {white}: {s:?}");
    }
    for (k, s) in cal.summary.iter().filter(|s| s.quantity == "extinction ratio ε").enumerate() {
        assert!((s.mean - want_eps[k]).abs() < 4.0 * s.mean_sigma + 2e-4, "{s:?}");
    }
    let p = cal.photon_transfer.as_ref().unwrap();
    assert!((p.conversion_gain_dn_per_e - 0.1).abs() < 4.0 * p.conversion_gain_sigma, "{p:?}");
    assert!((p.read_noise_dn - 1.0).abs() < 4.0 * p.read_noise_sigma_dn, "{p:?}");
    let f = cal.flat.as_ref().unwrap();
    assert!((f.v2 + 0.25).abs() < 4.0 * f.v2_sigma + 0.005 && (f.prnu_pct - 1.0).abs() < 0.15, "{f:?}");
    // Only the per-pixel dark noise (one dark frame) is left out.
    assert_eq!(cal.left_out.len(), 1, "{:?}", cal.left_out);
    assert!(cal.left_out[0].reason.contains("2 or more dark frames"));

    // The capture readers' path (heading, fit, diagnose): each frame made nominal per
    // tile, then the plain field estimator.
    let maps = Arc::new(cal.maps.clone());
    let mut s2 = 0.0;
    for (i, f) in sky.frames.iter().enumerate() {
        let data = apply_pixel_maps(&sky, sky.read_frame(i).unwrap(), &maps).unwrap();
        let hs = bpins_core::internal::pipeline::field_headings_of(
            &sky,
            i,
            &data,
            &Default::default(),
            &Default::default(),
            &[bpins_core::internal::heading::Extractor::SunVector],
        )
        .unwrap();
        let e = wrap_deg_180(hs[0].heading_deg().unwrap() - f.heading_deg.unwrap());
        s2 += e * e;
    }
    let rms = (s2 / sky.frames.len() as f64).sqrt();
    eprintln!("heading RMS through the nominal mosaic: {rms:.4}°");
    assert!(rms < 0.015, "{rms}");
}

fn sim_lab(
    w: u32,
    h: u32,
    plan: &LabPlan,
    model: &bpins_core::effects::Model,
    flaws: &PixelFlaws,
) -> (LabCapture, PixelMaps, tempfile::TempDir) {
    let intr = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let truth = truth_maps(model, &intr, w as usize, h as usize, DEFAULT_MOSAIC, 64.0, flaws);
    let sensor = LabSensor { signal_dn: 2400.0, k_dn_per_e: 0.1, read_noise_dn: 1.0, full_scale_dn: 4095.0, seed: 7 };
    let frames = lab_frames(&truth, plan, &sensor);
    let dir = tempfile::tempdir().unwrap();
    let lab = LabCapture {
        dir: dir.path().join("lab"),
        sensor: SensorSpec {
            colour: None,
            layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
            geometry: Geometry { width_px: w, height_px: h, pixel_pitch_um: 27.6 },
            bit_depth: 12,
            black_level_dn: 64.0,
        },
        lens: LensSpec {
            projection: Projection::Pinhole,
            focal_length_mm: 8.0,
            principal_point_px: (intr.cx_px, intr.cy_px),
        },
        frames: plan.frames(),
    };
    lab.write(&lab.dir, &frames).unwrap();
    let back = LabCapture::load(&lab.dir).unwrap();
    assert_eq!(back, lab);
    (back, truth, dir)
}

fn rms(x: impl Iterator<Item = f64>) -> f64 {
    let (n, s) = x.fold((0.0, 0.0), |(n, s), v| (n + 1.0, s + v * v));
    (s / n).sqrt()
}

#[test]
fn a_simulated_flawed_sensor_is_calibrated_back_pixel_by_pixel_to_the_photon_noise() {
    // Channel-level truth from the catalog plus per-pixel spreads and a die gradient.
    let mut fx = EffectSet::new();
    for a in [
        "analyzer_angles.d45_deg=0.8",
        "analyzer_angles.d135_deg=-0.5",
        "extinction_ratio.eps0=0.02",
        "vignetting.v2=-0.2",
    ] {
        fx.parse_assignment(a).unwrap();
    }
    let flaws = PixelFlaws {
        angle_sigma_deg: 0.5,
        angle_gradient_deg: [0.4, -0.3],
        eps_sigma: 0.005,
        prnu: 0.015,
        dsnu_dn: 2.0,
        seed: 3,
    };
    let plan = LabPlan::default();
    let (lab, truth, _dir) = sim_lab(128, 96, &plan, &fx.model(), &flaws);
    let cal = calibrate(&lab, &|_, _| {}).unwrap();
    let (m, t) = (&cal.maps, &truth);
    let sig = cal.sigma.as_ref().unwrap();
    let n = m.width_px * m.height_px;
    let err_angle =
        rms((0..n).map(|i| (m.analyzer_deg.as_ref().unwrap()[i] - t.analyzer_deg.as_ref().unwrap()[i]) as f64));
    let err_eps = rms((0..n).map(|i| (m.eps.as_ref().unwrap()[i] - t.eps.as_ref().unwrap()[i]) as f64));
    let err_gain = rms((0..n).map(|i| (m.gain.as_ref().unwrap()[i] / t.gain.as_ref().unwrap()[i] - 1.0) as f64));
    let (sa, se, sg) = (
        rms(sig.analyzer_deg.iter().map(|&x| x as f64)),
        rms(sig.eps.iter().map(|&x| x as f64)),
        rms(sig.gain.iter().map(|&x| x as f64)),
    );
    // What the photon count allows: 12 angles, a pixel's mean signal ȳ ≈ s·g/2 ≈ 1200
    // DN above offset, σ_y² = σ_read² + K·ȳ (+ the dark frame's read noise in o_p);
    // the Malus amplitude A ≈ s·g/2, so σ_φ = ½·√(2/12)·σ_y/A rad, σ_G = √(1/12 + 2/12)·σ_y.
    let sy = (1.0f64 + 0.1 * 1200.0).sqrt();
    let photon_phi_deg = (0.5 * (2.0f64 / 12.0).sqrt() * sy / 1200.0).to_degrees();
    eprintln!(
        "per-pixel RMS error: angle {err_angle:.4}° (stated 1σ {sa:.4}°, photon count {photon_phi_deg:.4}°), \
         ε {err_eps:.5} (stated {se:.5}), gain {:.4} % (stated {:.4} %)",
        100.0 * err_gain,
        100.0 * sg
    );
    assert!((sa / photon_phi_deg - 1.0).abs() < 0.3, "stated {sa}, photon count {photon_phi_deg}");
    for (err, stated, what) in [(err_angle, sa, "angle"), (err_eps, se, "eps"), (err_gain, sg, "gain")] {
        assert!(err < 1.3 * stated && err > 0.7 * stated, "{what}: RMS error {err} vs stated 1σ {stated}");
    }
    // Offsets: the dark frame's read noise (1 DN).
    let err_off = rms((0..n).map(|i| (m.offset_dn.as_ref().unwrap()[i] - t.offset_dn.as_ref().unwrap()[i]) as f64));
    assert!((err_off - 1.0).abs() < 0.1, "offset RMS error {err_off} DN");
}

/// ε maps are measurements, unclamped at 0 (issue 45): on a die whose ε spread reaches
/// 0 (channels 45°, 90°, 135°: half their pixels at ε = 0), a clamp biased each such
/// channel's mean ε up by 0.25 of a pixel's 1σ (2.6·10⁻⁴ on the simulated die of
/// `tests/calibrate.rs`) against the channel whose ε stands clear of 0, which turns a
/// heading by up to 0.01°. Each channel's mean error stays within its own noise.
#[test]
fn a_die_whose_eps_reaches_zero_is_calibrated_without_bias() {
    let mut fx = EffectSet::new();
    fx.parse_assignment("extinction_ratio.eps0=0.03").unwrap();
    let flaws = PixelFlaws { eps_sigma: 0.01, seed: 5, ..PixelFlaws::none() };
    let (lab, truth, _dir) = sim_lab(128, 96, &LabPlan::default(), &fx.model(), &flaws);
    let cal = calibrate(&lab, &|_, _| {}).unwrap();
    let (m, t) = (cal.maps.eps.as_ref().unwrap(), truth.eps.as_ref().unwrap());
    let sig = &cal.sigma.as_ref().unwrap().eps;
    let w = truth.width_px;
    let mut by = [(0.0, 0.0, 0.0, 0.0); 4];
    for i in 0..m.len() {
        let k = Layout::dofp_channel(&DEFAULT_MOSAIC, i % w, i / w).index();
        let b = &mut by[k];
        *b = (b.0 + 1.0, b.1 + (m[i] - t[i]) as f64, b.2 + (sig[i] as f64).powi(2), b.3 + f64::from(t[i] == 0.0));
    }
    for (k, (n, d, s2, zeros)) in by.into_iter().enumerate() {
        let (bias, se) = (d / n, (s2 / n).sqrt() / n.sqrt());
        eprintln!("channel {k}: mean ε error {bias:.2e} (its 1σ {se:.1e}), truth at 0: {zeros}/{n}");
        // The clamp's bias was ~10 σ of a channel's mean here.
        assert!(bias.abs() < 4.0 * se, "channel {k}: mean ε error {bias} vs its 1σ {se}");
        assert!(k == 0 || zeros > 0.3 * n, "channel {k}: {zeros} of {n} at 0");
    }
    // Some estimates fall below 0, as a measurement of 0 should.
    assert!(m.iter().any(|&e| e < 0.0));
}

#[test]
fn captures_that_cannot_determine_a_quantity_are_partly_calibrated_with_the_reason() {
    let flaws = PixelFlaws { angle_sigma_deg: 0.3, ..PixelFlaws::none() };
    let model = bpins_core::effects::Model::default();
    // A single polarizer angle: no analyzers, the gain from the unpolarized flats.
    let one = LabPlan { angles_deg: vec![30.0], ..LabPlan::default() };
    let (lab, _, _d) = sim_lab(64, 48, &one, &model, &flaws);
    let cal = calibrate(&lab, &|_, _| {}).unwrap();
    assert!(cal.maps.analyzer_deg.is_none() && cal.maps.eps.is_none() && cal.maps.gain.is_some());
    assert!(
        cal.left_out.iter().any(|l| l.quantity.contains("analyzer_deg") && l.reason.contains("has 1 (30°)")),
        "{:?}",
        cal.left_out
    );
    assert!(cal.summary.iter().all(|s| s.quantity != "analyzer angle offset"));
    // No exposure series and no dark frame: analyzers yes, photon transfer and offsets no.
    let none = LabPlan { exposures: vec![], darks: 0, ..LabPlan::default() };
    let (lab, _, _d) = sim_lab(64, 48, &none, &model, &flaws);
    let cal = calibrate(&lab, &|_, _| {}).unwrap();
    assert!(cal.maps.analyzer_deg.is_some() && cal.maps.offset_dn.is_none() && cal.photon_transfer.is_none());
    let why: Vec<&str> = cal.left_out.iter().map(|l| l.reason.as_str()).collect();
    assert!(why.iter().any(|r| r.contains("no dark frame")), "{why:?}");
    assert!(why.iter().any(|r| r.contains("photon transfer needs a dark frame")), "{why:?}");
    // Two exposures and a dark: K and read noise, but no linearity error.
    let two = LabPlan { exposures: vec![0.5, 1.0], ..LabPlan::default() };
    let (lab, _, _d) = sim_lab(64, 48, &two, &model, &flaws);
    let cal = calibrate(&lab, &|_, _| {}).unwrap();
    let p = cal.photon_transfer.as_ref().unwrap();
    assert!(p.linearity_error_pct.is_none() && cal.left_out.iter().any(|l| l.quantity == "linearity error"));
}

#[test]
fn a_calibration_file_round_trips_and_one_for_another_sensor_is_refused() {
    let flaws = PixelFlaws { angle_sigma_deg: 0.3, eps_sigma: 0.002, prnu: 0.01, dsnu_dn: 1.0, ..PixelFlaws::none() };
    let (lab, _, dir) = sim_lab(64, 48, &LabPlan::default(), &Default::default(), &flaws);
    let cal = calibrate(&lab, &|_, _| {}).unwrap();
    let file = Calibration { source: "test".into(), pixels: Some(Arc::new(cal.maps.clone())), ..Default::default() };
    let out = dir.path().join("cal");
    std::fs::create_dir_all(&out).unwrap();
    file.write_pixels(&out).unwrap();
    std::fs::write(out.join("calibration.toml"), file.to_toml()).unwrap();
    let back = Calibration::load(&out.join("calibration.toml")).unwrap();
    assert_eq!(back.pixels.as_deref(), Some(&cal.maps));
    // The front door and the capture readers refuse it for a sensor of another size,
    // naming both sizes.
    let lens = Intrinsics::new(Projection::Pinhole, 290.0, 39.5, 31.5);
    let e = Compass::new(CompassConfig { calibration: back.clone(), ..CompassConfig::dofp(lens, 80, 64, 12, 64.0) })
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("64 × 48") && e.contains("80 × 64"), "{e}");
    let sky = Capture::load(Path::new(SKY)).unwrap();
    let e = apply_pixel_maps(&sky, sky.read_frame(0).unwrap(), back.pixels.as_ref().unwrap()).unwrap_err().to_string();
    assert!(e.contains("64 × 48") && e.contains("306 × 256") && e.contains("capture.toml"), "{e}");
    // A [pixels] table whose size disagrees with its EXR, or that names a map it lacks.
    let text = file.to_toml();
    for (bad, want) in [
        (text.replace("width_px = 64", "width_px = 65"), "65 × 48"),
        (text.replace("\"eps\"", "\"eps\", \"nope\""), "nope"),
        (format!("{text}\n[effects.analyzer_angles]\nd45_deg = 0.5\n"), "replace the analyzer"),
        // A colour band's gain is in the maps' gain: band_response beside them counts it twice.
        (format!("{text}\n[effects.band_response]\nqe_b = 0.6\n"), "band_response"),
    ] {
        std::fs::write(out.join("bad.toml"), bad).unwrap();
        let e = Calibration::load(&out.join("bad.toml")).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains(want), "{e}");
    }
    let _ = LabFrame::describe;
}

/// RMS heading error (sun-vector extractor) of the frames of `c`, each made nominal
/// through `maps` where given.
fn sky_rms(c: &Capture, frames: &[FrameData], maps: Option<&PixelMaps>) -> f64 {
    let mut s2 = 0.0;
    for (i, f) in c.frames.iter().enumerate() {
        let data = match maps {
            Some(m) => apply_pixel_maps(c, frames[i].clone(), m).unwrap(),
            None => frames[i].clone(),
        };
        let hs = bpins_core::internal::pipeline::field_headings_of(
            c,
            i,
            &data,
            &Default::default(),
            &Default::default(),
            &[bpins_core::internal::heading::Extractor::SunVector],
        )
        .unwrap();
        let e = wrap_deg_180(hs[0].heading_deg().unwrap() - f.heading_deg.unwrap());
        s2 += e * e;
    }
    (s2 / c.frames.len() as f64).sqrt()
}

#[test]
fn a_lab_capture_of_the_nonuniform_die_calibrates_the_sky_capture_of_the_same_sensor() {
    // One simulated sensor with the catalog's per-pixel polarimetric non-uniformity:
    // a lab capture of it calibrated back, then its sky capture read through the maps.
    let mut set = EffectSet::new();
    for a in [
        "polarimetric_nonuniformity.angle_sigma_deg=0.5",
        "polarimetric_nonuniformity.angle_grad_x_deg=3",
        "polarimetric_nonuniformity.angle_grad_y_deg=-2",
        "polarimetric_nonuniformity.eps_sigma=0.005",
        "polarimetric_nonuniformity.gain_sigma=0.01",
    ] {
        set.parse_assignment(a).unwrap();
    }
    let sky = common::small_capture();
    let (w, h) = (sky.sensor.geometry.width_px, sky.sensor.geometry.height_px);
    let (lab, truth, _dir) = sim_lab(w, h, &LabPlan::default(), &set.model(), &PixelFlaws::none());
    let cal = calibrate(&lab, &|_, _| {}).unwrap();
    // The lab truth is the chain's die: the calibration recovers its angles.
    let n = (w * h) as usize;
    let (m, t) = (cal.maps.analyzer_deg.as_ref().unwrap(), truth.analyzer_deg.as_ref().unwrap());
    let truth_spread = rms((0..n).map(|i| {
        let nominal = 45.0 * (t[i] / 45.0).round();
        (t[i] - nominal) as f64
    }));
    let err_angle = rms((0..n).map(|i| (m[i] - t[i]) as f64));
    let frames = common::simulate(&sky, &set, 31);
    let clean = sky_rms(&sky, &common::simulate(&sky, &EffectSet::new(), 31), None);
    let raw = sky_rms(&sky, &frames, None);
    let calibrated = sky_rms(&sky, &frames, Some(&cal.maps));
    eprintln!(
        "die angle spread {truth_spread:.3}°, per-pixel error {err_angle:.4}°; heading RMS: clean sensor \
         {clean:.4}°, nonuniform {raw:.4}°, calibrated {calibrated:.4}°"
    );
    // Each pixel's angle to its photon count (as in the test above: ½·√(2/12)·σ_y/A rad).
    let photon_phi_deg = (0.5 * (2.0f64 / 12.0).sqrt() * (1.0f64 + 0.1 * 1200.0).sqrt() / 1200.0).to_degrees();
    assert!(err_angle < 1.3 * photon_phi_deg, "angle error {err_angle}°, photon count {photon_phi_deg}°");
    assert!(truth_spread > 4.0 * photon_phi_deg, "the die's spread must exceed the noise: {truth_spread}°");
    assert!(raw > 3.0 * clean, "the die must matter: {raw} vs {clean}");
    assert!(calibrated < 1.5 * clean + 0.005, "calibrated {calibrated} vs clean {clean}");
}
