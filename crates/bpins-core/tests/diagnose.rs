//! Diagnosis of the independent implementation's sample captures (truth in
//! shared/samples/README.md): the clean capture needs nothing; the hidden analyzer
//! angles are named first, recovered, and the error falls to the noise.

use bpins_core::capture::{Capture, FrameData};
use bpins_core::fit::diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use std::path::Path;

fn run(sample: &str, max_added: usize) -> Diagnosis {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/samples").join(sample);
    let c = Capture::load(&dir).unwrap();
    let frames: Vec<FrameData> = (0..c.frames.len()).map(|i| c.read_frame(i).unwrap()).collect();
    diagnose(&c, &frames, &DiagnoseOptions { max_added, ..Default::default() }, &|_| {}).unwrap()
}

#[test]
fn clean_sample_needs_no_effect_and_nothing_remains() {
    let d = run("clean", 1);
    assert!(d.selected.is_empty(), "selected {:?}", d.selected);
    assert!(!d.unexplained, "{}", d.unexplained_summary);
    assert!(d.rankings[0].iter().filter(|c| c.refitted).all(|c| c.delta_bic < 10.0), "{:?}", d.rankings[0]);
}

#[test]
fn hidden_analyzer_angles_are_named_first_and_the_error_falls() {
    let d = run("hidden-analyzer-angles", 2);
    assert_eq!(d.rankings[0][0].effect, "analyzer_angles", "ranking {:?}", d.rankings[0]);
    assert_eq!(d.selected, vec!["analyzer_angles"]);
    assert!(!d.unexplained, "{}", d.unexplained_summary);
    let (first, last) = (&d.steps[0].fit, &d.steps.last().unwrap().fit);
    assert!(first.chi2_per_dof > 1.2 && (last.chi2_per_dof - 1.0).abs() < 0.03);
    assert!(last.heading_rms_deg.unwrap() < first.heading_rms_deg.unwrap() / 10.0);
    for (name, want) in [("d45_deg", 1.0), ("d135_deg", -0.6)] {
        let p = last.params.iter().find(|p| p.name == format!("analyzer_angles.{name}")).unwrap();
        assert!((p.value - want).abs() < 3.0 * p.sigma, "{name}: {} ± {}", p.value, p.sigma);
    }
}

#[test]
fn an_effect_outside_the_catalog_is_reported_unexplained_and_nothing_named() {
    // The clean capture with a gain ramp across the sensor, DN × (1 + 0.02·x_n): no
    // catalog effect is a linear ramp (vignetting is radial).
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/samples/clean");
    let c = Capture::load(&dir).unwrap();
    let intr = c.intrinsics();
    let black = c.sensor.black_level_dn;
    let frames: Vec<FrameData> = (0..c.frames.len())
        .map(|i| match c.read_frame(i).unwrap() {
            FrameData::Mosaic { width_px, height_px, dn } => {
                let w = width_px as usize;
                let dn = dn
                    .iter()
                    .enumerate()
                    .map(|(p, &x)| {
                        let (xn, _) = intr.normalised((p % w) as f64, (p / w) as f64);
                        (black + (x as f64 - black) * (1.0 + 0.02 * xn)).round() as f32
                    })
                    .collect();
                FrameData::Mosaic { width_px, height_px, dn }
            }
            other => other,
        })
        .collect();
    let d = diagnose(&c, &frames, &DiagnoseOptions { max_added: 2, ..Default::default() }, &|_| {}).unwrap();
    eprintln!("selected {:?}; {}", d.selected, d.unexplained_summary);
    assert!(d.unexplained, "{}", d.unexplained_summary);
    assert!(d.selected.is_empty(), "falsely named {:?}", d.selected);
    // Described where it is: a ramp along image x is a trend in image azimuth.
    assert!(
        d.unexplained_summary.contains("residual (σ) varies most along the image azimuth"),
        "{}",
        d.unexplained_summary
    );
}
