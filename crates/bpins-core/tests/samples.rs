//! The sample captures in samples were made by an independent implementation
//! of CONVENTIONS.md that shares no code with bpins: reading them back pins our
//! conventions (mosaic order, angle sense, frames, Stokes) against theirs.
//! samples/ is only read.

use std::path::Path;

use bpins_core::conventions::wrap_deg_180;
use bpins_core::effects::Model;
use bpins_core::internal::capture::Capture;
use bpins_core::internal::heading::field::FieldOptions;
use bpins_core::internal::heading::Extractor;
use bpins_core::internal::pipeline::{field_headings, frame_headings, reconstruct_frame, ReconMode};
use bpins_core::internal::recon::angle_maps;
use bpins_core::sensor::{Channel, Layout, DEFAULT_MOSAIC};

const CLEAN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/clean");
const HIDDEN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/hidden-analyzer-angles");

const MODES: [ReconMode; 2] = [ReconMode::Superpixel, ReconMode::Demosaic];

fn load(dir: &str) -> Capture {
    Capture::load(Path::new(dir)).unwrap_or_else(|e| panic!("loading {dir}: {e}"))
}

/// Heading error (estimate − reference, wrapped to (−180°, 180°]) of every frame of
/// `c` with every extractor, reconstructed with `mode` and nothing compensated.
fn errors(c: &Capture, mode: ReconMode) -> Vec<(usize, Extractor, f64)> {
    let mut out = Vec::new();
    for i in 0..c.frames.len() {
        let reference = c.frames[i].heading_deg.expect("the samples give every frame's reference heading");
        for (e, r) in frame_headings(c, i, &Model::default(), mode, &Extractor::ALL).unwrap() {
            let est = r.unwrap_or_else(|err| panic!("frame {i} {}: {err}", e.name()));
            assert!(est.sigma_deg.is_finite() && est.sigma_deg > 0.0, "frame {i} {}: σ {}", e.name(), est.sigma_deg);
            out.push((i, e, wrap_deg_180(est.heading_deg - reference)));
        }
    }
    out
}

fn max_abs(errs: &[(usize, Extractor, f64)], e: Extractor) -> f64 {
    errs.iter().filter(|t| t.1 == e).map(|t| t.2.abs()).fold(0.0, f64::max)
}

#[test]
fn clean_sample_headings_match_the_references_for_every_extractor_and_recon() {
    let c = load(CLEAN);
    assert_eq!(c.frames.len(), 8);
    assert_eq!(c.sensor.layout, Layout::Dofp { mosaic: DEFAULT_MOSAIC });
    for mode in MODES {
        let errs = errors(&c, mode);
        assert_eq!(errs.len(), 8 * Extractor::ALL.len());
        for &(i, e, err) in &errs {
            assert!(
                err.abs() < 0.1,
                "{} / {}: frame {i} heading error {err:+.4}° (want < 0.1°)",
                mode.name(),
                e.name()
            );
        }
    }
}

#[test]
fn clean_sample_sun_vector_on_the_demosaiced_mosaic_is_at_the_noise_floor() {
    // Each pixel at its own ray, least squares over ~300 000 samples: a few thousandths
    // of a degree now. A misread convention (mosaic order, angle sense, a 90° or mirror
    // slip in the camera frame) shows up as tenths of a degree or more.
    let c = load(CLEAN);
    let errs = errors(&c, ReconMode::Demosaic);
    let worst = max_abs(&errs, Extractor::SunVector);
    eprintln!("sun_vector + demosaic: largest |error| {worst:.5}°");
    assert!(worst < 0.02, "sun_vector + demosaic: largest |error| {worst:.5}° (want < 0.02°): {errs:?}");
}

#[test]
fn a_mirrored_mosaic_misreads_the_clean_sample_by_degrees() {
    // The same numbers read with the mosaic's columns swapped ([[45, 90], [0, 135]]):
    // 45° and 135° trade places with 90° and 0°, which mirrors every AoP. The test
    // above can only pin the convention if such a misreading is loudly wrong.
    let mut c = load(CLEAN);
    c.sensor.layout = Layout::Dofp { mosaic: [[Channel::C45, Channel::C90], [Channel::C0, Channel::C135]] };
    for mode in MODES {
        let errs: Vec<(usize, Extractor, f64)> = (0..c.frames.len())
            .flat_map(|i| {
                let reference = c.frames[i].heading_deg.unwrap();
                frame_headings(&c, i, &Model::default(), mode, &[Extractor::SunVector])
                    .unwrap()
                    .into_iter()
                    // A failed solve is as loud as a wrong one.
                    .map(move |(e, r)| (i, e, r.map(|est| wrap_deg_180(est.heading_deg - reference)).unwrap_or(180.0)))
            })
            .collect();
        let worst = max_abs(&errs, Extractor::SunVector);
        eprintln!("{}: mirrored mosaic, largest |error| {worst:.4}°", mode.name());
        assert!(worst > 1.0, "{}: mirrored mosaic gives only {worst:.4}° of error: {errs:?}", mode.name());
    }
}

#[test]
fn hidden_analyzer_angles_are_visible_in_the_heading() {
    // d45 = +1.0°, d135 = −0.6°, read with nominal analyzers: the heading is biased
    // by more than the clean sample's noise floor on some frame.
    let c = load(HIDDEN);
    assert_eq!(c.frames.len(), 8);
    let errs = errors(&c, ReconMode::Demosaic);
    for e in Extractor::ALL {
        let worst = max_abs(&errs, e);
        assert!(worst > 0.1, "{}: largest |error| {worst:.4}°; the hidden effect should show (> 0.1°)", e.name());
        // …but it is a fraction of a degree, not a misread convention.
        assert!(worst < 1.0, "{}: largest |error| {worst:.4}°", e.name());
    }
}

#[test]
fn clean_sample_dolp_peaks_near_the_sky_dmax() {
    let c = load(CLEAN);
    let data = c.read_frame(0).unwrap();
    let img = reconstruct_frame(&c, &data, &Model::default(), ReconMode::Demosaic).unwrap();
    assert!(img.valid_count() > img.width * img.height * 9 / 10, "{} valid of {}", img.valid_count(), img.iqu.len());
    let [_, dolp, _] = angle_maps(&img, &c.intrinsics());
    let mut d: Vec<f32> = dolp.into_iter().filter(|x| !x.is_nan()).collect();
    assert!(!d.is_empty());
    d.sort_by(|a, b| a.total_cmp(b));
    let p99 = d[(d.len() - 1) * 99 / 100] as f64;
    let p01 = d[(d.len() - 1) / 100] as f64;
    assert!((0.5..=0.65).contains(&p99), "99th percentile DoLP {p99:.4} (sky d_max = 0.6)");
    // The sun is 65° from the zenith and the view reaches ~33° from it at the far
    // corner (γ ≈ 32°, d ≈ 0.10): the pattern spans a wide range but never reaches 0.
    assert!((0.05..0.25).contains(&p01), "1st percentile DoLP {p01:.4}");
    eprintln!("DoLP percentiles: 1 % {p01:.4}, 99 % {p99:.4}");
}

const FIELD: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/field-fisheye-tilted-clouds");

#[test]
fn the_tilted_cloudy_fisheye_sample_is_read_within_its_sigma() {
    // The independent generator's field sample: equidistant fisheye (±46°), a Berry sky
    // with a radiance brighter toward the sun and the horizon, eight clouds, frames
    // tilted up to 8° with an IMU's 0.1° reading of the tilt (tilt_sigma_deg).
    let c = load(FIELD);
    assert_eq!(c.frames.len(), 4);
    assert!(c.frames.iter().all(|f| f.tilt_sigma_deg == Some(0.1)), "tilt_sigma_deg is read");
    let opts = FieldOptions::default();
    let mut errs = Vec::new();
    for i in 0..c.frames.len() {
        let reference = c.frames[i].heading_deg.unwrap();
        let r = &field_headings(&c, i, &Model::default(), &opts, &[Extractor::SunVector]).unwrap()[0];
        let (h, parts) = r.result.clone().unwrap_or_else(|e| panic!("frame {i}: no heading: {e}"));
        let err = wrap_deg_180(h - reference);
        let sigma = parts.total_deg();
        eprintln!("frame {i}: error {err:+.4}°, 1σ {sigma:.4}° ({parts:?}), {:?}", r.quality);
        // The IMU's 0.1° per axis is in the 1σ: about 0.1°·tan 38° = 0.08°.
        assert!((parts.tilt_deg - 0.078).abs() < 0.01, "frame {i}: {parts:?}");
        assert!(err.abs() < 5.0 * sigma, "frame {i}: error {err:+.4}° beyond 5σ ({sigma:.4}°)");
        // Clouds and the ground are left out, the rest is used.
        assert!((0.2..0.9).contains(&r.quality.used_fraction), "frame {i}: {:?}", r.quality);
        errs.push((err, sigma));
    }
    let rms = (errs.iter().map(|e| e.0 * e.0).sum::<f64>() / errs.len() as f64).sqrt();
    let within = errs.iter().filter(|(e, s)| e.abs() <= 2.0 * s).count();
    assert!(rms < 0.3, "RMS error {rms:.4}° (want < 0.3°): {errs:?}");
    assert!(within >= 3, "{within} of 4 within 2σ: {errs:?}");
    // The meridian line through the zenith, the same frames.
    for i in 0..c.frames.len() {
        let r = &field_headings(&c, i, &Model::default(), &opts, &[Extractor::MeridianLine]).unwrap()[0];
        let (h, parts) = r.result.clone().unwrap_or_else(|e| panic!("frame {i}: meridian line, no heading: {e}"));
        let err = wrap_deg_180(h - c.frames[i].heading_deg.unwrap());
        assert!(
            err.abs() < 0.3 && err.abs() < 5.0 * parts.total_deg(),
            "frame {i}: meridian line {err:+.4}°, {parts:?}"
        );
    }
    // Read as the plain least squares over every pixel, the clouds pull it by degrees.
    let plain: Vec<f64> = (0..c.frames.len())
        .map(|i| {
            let est = frame_headings(&c, i, &Model::default(), ReconMode::Superpixel, &[Extractor::SunVector]).unwrap();
            wrap_deg_180(est[0].1.as_ref().unwrap().heading_deg - c.frames[i].heading_deg.unwrap())
        })
        .collect();
    assert!(plain.iter().any(|e| e.abs() > 1.0), "plain: {plain:?}");
}
