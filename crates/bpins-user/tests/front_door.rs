//! bpins-core's front door, used from outside: each entry of the crate page's "where
//! to start" table called with public paths only, every type it takes built and every
//! error it returns matched (issue 44). A type a user cannot name or build fails to
//! compile here.

use std::path::{Path, PathBuf};

use bpins_core::calibration::Calibration;
use bpins_core::compass::{Attitude, Compass, CompassConfig, Extractor, FieldOptions, RawImage, Sun};
use bpins_core::conventions::wrap_deg_180;
use bpins_core::effects::{find, EffectSet, Model};
use bpins_core::sensor::DEFAULT_MOSAIC;
use bpins_core::{
    calibrate, diagnose, fit, locate, run_to_dir, stokes_maps, Capture, CpuSums, DiagnoseOptions, Diagnosis,
    FitOptions, FitResult, FrameData, Interpolation, LabCalibration, LabCapture, LocateError, LocateOptions, Located,
    Maps, MapsConfig, MapsError, Outcome, Reconstructor, Shard, SumsEngine, SunObs, SweepSpec,
};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(rel)
}

/// `samples/clean`, cut to its first `n` frames (a quick test).
fn clean(n: usize) -> (Capture, Vec<FrameData>) {
    let mut c = Capture::load(&repo("samples/clean")).expect("samples/clean");
    c.frames.truncate(n);
    let frames = (0..c.frames.len()).map(|i| c.read_frame(i).expect("a frame")).collect();
    (c, frames)
}

/// A mosaic frame's DN as a robot's camera hands them over.
fn raw_u16(data: &FrameData) -> Vec<u16> {
    let FrameData::Mosaic { dn, .. } = data else { panic!("samples/clean is DoFP") };
    dn.iter().map(|&x| x as u16).collect()
}

#[test]
fn a_heading_from_a_cameras_raw_frames() {
    let (c, frames) = clean(2);
    let (w, h) = (c.sensor.geometry.width_px as usize, c.sensor.geometry.height_px as usize);
    let cfg = CompassConfig::dofp(c.intrinsics(), w, h, c.sensor.bit_depth, c.sensor.black_level_dn);
    let mut compass = Compass::new(CompassConfig { calibration: Calibration::default(), ..cfg }).expect("a compass");
    for (f, data) in c.frames.iter().zip(&frames) {
        let raw = raw_u16(data);
        let sun = Sun::Angles { azimuth_deg: f.sun.azimuth_deg, elevation_deg: f.sun.elevation_deg, sigma_deg: 0.0 };
        let fix = compass.heading(RawImage::packed(&raw, w, h), sun, Attitude::default()).expect("a fix");
        let (heading_deg, sigma) = fix.result.expect("a heading");
        let err = wrap_deg_180(heading_deg - f.heading_deg.unwrap());
        assert!(err.abs() < 5.0 * sigma.total_deg() + 0.05, "{err}° off");
    }
}

#[test]
fn a_heading_from_a_capture_on_disk() {
    let (c, frames) = clean(2);
    let mut compass =
        Compass::for_capture(&c, Calibration::default(), FieldOptions::default(), Extractor::SunVector).unwrap();
    for (f, data) in c.frames.iter().zip(&frames) {
        let fix = &compass.capture_frame(data, f, &[Extractor::SunVector]).unwrap()[0];
        let err = wrap_deg_180(fix.heading_deg().unwrap() - f.heading_deg.unwrap());
        assert!(err.abs() < 5.0 * fix.sigma_deg().unwrap() + 0.05, "{err}° off");
    }
}

#[test]
fn fit_and_diagnose_measured_frames() {
    let (c, frames) = clean(3);
    let opts = FitOptions { effects: vec![find("analyzer_angles").unwrap()], ..Default::default() };
    let r: FitResult = fit(&c, &frames, &opts, &|_, _| {}).expect("a fit");
    assert!(r.chi2_per_dof.is_finite() && !r.params.is_empty());
    for p in &r.params {
        let _: (&str, f64, f64) = (p.name.as_str(), p.value, p.sigma);
    }
    let d_opts = DiagnoseOptions { max_added: 1, refit_top: 1, score_stride: 8, ..Default::default() };
    let d: Diagnosis = diagnose(&c, &frames, &d_opts, &|_| {}).expect("a diagnosis");
    assert!(d.steps.len() <= 2, "{} steps", d.steps.len());
    for step in &d.steps {
        let _: &bpins_core::Step = step;
    }
}

#[test]
fn a_sensors_effects_from_lab_frames() {
    let lab = LabCapture::load(&repo("samples/lab-flawed-sensor/lab")).expect("a lab capture");
    let cal: LabCalibration = calibrate(&lab, &|_, _| {}).expect("a lab calibration");
    let _: &bpins_core::PixelMaps = &cal.maps;
    let _: Option<&bpins_core::Dark> = cal.dark.as_ref();
    assert!(!cal.summary.is_empty());
}

#[test]
fn the_papers_error_analysis_over_a_sensor() {
    let spec = SweepSpec::load(&repo("examples/sweeps/tiny.toml")).expect("the tiny sweep");
    let dir = std::env::temp_dir().join(format!("bpins-user-sweep-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let engine: &dyn SumsEngine = &CpuSums;
    let shard = Shard::parse("0/4").expect("a shard");
    let outcome = run_to_dir(&spec, shard, engine, &dir, &|_, _| {}).expect("a sweep");
    match outcome {
        Outcome::Computed(summary) => {
            let _: &bpins_core::Summary = &summary;
        }
        Outcome::AlreadyComplete => panic!("a fresh directory"),
    }
    let again = run_to_dir(&spec, shard, engine, &dir, &|_, _| {}).unwrap();
    assert!(matches!(again, Outcome::AlreadyComplete));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn north_and_place_from_the_sky_over_time() {
    let obs = |i: usize| SunObs {
        time_unix_s: Some(1.7e9 + 600.0 * i as f64),
        yaw_deg: 0.0,
        yaw_sigma_deg: 0.1,
        bearing_deg: 10.0 + 2.5 * i as f64,
        bearing_sigma_deg: 0.2,
        elevation_deg: 30.0 + 1.5 * i as f64,
        elevation_sigma_deg: 0.3,
        elevation_nuisance_sigma_deg: 0.0,
        separation_deg: 0.0,
        separation_sigma_deg: 0.0,
        given_sun_deg: None,
    };
    // Too few frames: a typed error the caller can match on.
    match locate(&[obs(0)], &LocateOptions::default()) {
        Err(LocateError::TooFewFrames { needed, .. }) => assert!(needed > 1),
        other => panic!("{other:?}"),
    }
    let all: Vec<SunObs> = (0..6).map(obs).collect();
    match locate(&all, &LocateOptions::default()) {
        Ok(Located { route, heading_deg, .. }) => {
            let _: bpins_core::Route = route;
            assert!((0.0..360.0).contains(&heading_deg));
        }
        Err(e) => {
            let _: LocateError = e;
        }
    }
}

#[test]
fn aop_and_dolp_maps_of_a_raw_frame() {
    let (c, frames) = clean(1);
    let (w, h) = (c.sensor.geometry.width_px as usize, c.sensor.geometry.height_px as usize);
    let raw = raw_u16(&frames[0]);
    let model: Model = EffectSet::new().model();
    let rec = Reconstructor::new(&model, c.sensor.black_level_dn, &c.sensor.channels()).expect("a reconstructor");
    let cfg = MapsConfig {
        interpolation: Interpolation::Superpixel,
        mosaic: DEFAULT_MOSAIC,
        full_scale_dn: f64::INFINITY,
        aoe_centre_px: c.lens.principal_point_px.into(),
    };
    let maps: Maps = stokes_maps(&RawImage::packed(&raw, w, h), &rec, &cfg).expect("maps");
    assert_eq!(maps.aop_deg.len(), maps.width_px * maps.height_px);
    assert!(maps.dolp.iter().any(|&d| d > 0.0));
    // A buffer that is not the size it claims: an error the caller can match on.
    match stokes_maps(&RawImage::packed(&raw[..10], w, h), &rec, &cfg) {
        Err(MapsError::Buffer { .. }) => {}
        other => panic!("{:?}", other.map(|m| m.width_px)),
    }
}

#[test]
fn what_can_be_simulated_and_fitted() {
    assert!(!bpins_core::catalog::markdown().is_empty());
    assert!(find("analyzer_angles").is_ok());
    let mut set = EffectSet::new();
    set.parse_assignment("analyzer_angles.d45_deg=1.0").unwrap();
    let _: Model = set.model();
}

#[test]
fn never_the_house_behind_the_front_door() {
    // A user's crate cannot reach the hidden house behind the door: nor does this one.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![root.join("Cargo.toml"), root.join("src/lib.rs")];
    for e in std::fs::read_dir(root.join("tests")).unwrap() {
        files.push(e.unwrap().path());
    }
    let word = ["inter", "nal"].concat();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        assert!(!text.contains(&word), "{} names `{word}`", f.display());
    }
}

#[test]
fn a_skys_maps_and_a_sensors_raw_frames_simulated() {
    use bpins_core::camera::{Intrinsics, Projection};
    use bpins_core::render::{
        paper_trial, ErrorSource, PaperConfig, RawFrame, RenderError, Renderer, RendererConfig, SkyMaps, Stage,
        TrialResult, View,
    };
    use bpins_core::scene::FieldScene;
    use bpins_core::sensor::Response;
    use bpins_core::NoiseIndex;

    let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
    let mut cfg = RendererConfig::dofp(lens, 306, 256, Response::samples(1.0));
    cfg.effects.parse_assignment("array_rotation.dtheta_deg=0.2").unwrap();
    let mut scene = FieldScene::new(3);
    scene.enable("sky_radiance").unwrap();
    cfg.scene = scene;
    let mut renderer = Renderer::new(cfg).expect("a renderer");
    let view = View { sun_azimuth_deg: 40.0, sun_elevation_deg: 25.0, heading_deg: 30.0, ..View::default() };
    assert!(renderer.expose(&view, 0.7).unwrap() > 0.0);

    // Maps into the caller's buffers, kept from frame to frame.
    let mut maps = SkyMaps::default();
    for stage in [Stage::Sky, Stage::Analyzers] {
        renderer.sky_maps_into(&view, stage, &mut maps).unwrap();
        assert_eq!(maps.aop_deg.len(), 306 * 256);
        assert!(maps.s0.iter().all(|&s| s > 0.0) && maps.dolp.iter().any(|&d| d > 0.3));
    }

    // The raw frame: the same seed, the same bits; read back by the compass.
    let mut frame = RawFrame::default();
    let noise = NoiseIndex { seed: 11, trial: 0, frame: 0 };
    renderer.raw_frame_into(&view, noise, &mut frame).unwrap();
    assert_eq!(frame, renderer.raw_frame(&view, noise).unwrap());
    let mut raw = Vec::new();
    frame.to_u16_into(&mut raw);
    let mut compass = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
    let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
    let fix = compass.heading(RawImage::packed(&raw, 306, 256), sun, Attitude::default()).unwrap();
    let err = wrap_deg_180(fix.heading_deg().unwrap() - 30.0);
    // The compass knows nothing of the array's 0.2° turn: within it and 3σ.
    assert!(err.abs() < 0.2 + 3.0 * fix.sigma_deg().unwrap(), "{err}° off");

    // A view out of range: an error the caller can match on.
    match renderer.raw_frame(&View { sun_elevation_deg: 95.0, ..view }, noise) {
        Err(RenderError::View(_)) => {}
        other => panic!("{:?}", other.map(|f| f.width_px)),
    }

    // One trial of the seed paper's Monte Carlo, at a quarter of its resolution.
    let paper = PaperConfig { width_px: 306, height_px: 256, pixel_pitch_um: 13.8, ..PaperConfig::default() };
    let t: TrialResult = paper_trial(&paper, ErrorSource::ChannelResponse, 0).expect("a trial");
    assert!(!t.errors.is_empty() && t.errors.iter().all(|(_, _, e)| e.abs() < 1.0));
}
