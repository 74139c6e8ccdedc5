//! Colour-polarization captures (samples/colour-clear, an IMX250MYR-like RGGB layout
//! made by an independent implementation of the spec): `heading` reads each band from
//! its own pixels and fuses the bands; the readers that do not read bands yet (fit,
//! diagnose, maps, the plain estimator) say so by name; and the frames are never read
//! as monochrome when the `colour_tiles` key is deleted (read as mono the plain
//! estimator is off by 0.24° RMS at up to 8σ on this capture).

mod common;
use common::*;
use std::fs;

const COLOUR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/colour-clear");

#[test]
fn every_band_of_the_colour_sample_reads_its_heading_and_the_fused_one_is_honest() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("colour.json");
    bpins(&["heading", COLOUR, "--json", &s(&json)]).ok();
    let v: serde_json::Value = serde_json::from_slice(&fs::read(&json).unwrap()).unwrap();
    let rows = v["frames"].as_array().unwrap();
    let of = |band: &str| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r["band"] == band)
            .map(|r| (r["error_deg"].as_f64().unwrap(), r["sigma_deg"].as_f64().unwrap()))
            .collect()
    };
    for band in ["fused", "R", "G", "B"] {
        let e = of(band);
        assert_eq!(e.len(), 4, "{band}: {v}");
        // The truth within 3σ every frame (the sample's noise: hundredths of a degree).
        for (err, sigma) in &e {
            assert!(err.abs() < 3.0 * sigma && err.abs() < 0.06, "{band}: error {err}°, 1σ {sigma}°");
        }
    }
    // The fused heading's 1σ lies within the bands' (the floor, shared by all, dominates
    // here, and bands that disagree beyond their noise widen it), and its error is no
    // larger than the worst band's.
    for i in 0..4 {
        let fused = of("fused")[i];
        let bands: Vec<(f64, f64)> = ["R", "G", "B"].iter().map(|b| of(b)[i]).collect();
        let widest = bands.iter().map(|b| b.1).fold(0.0, f64::max);
        assert!(fused.1 <= widest, "frame {i}: fused 1σ {} over every band's (widest {widest})", fused.1);
        let worst = bands.iter().map(|b| b.0.abs()).fold(0.0, f64::max);
        assert!(fused.0.abs() <= worst, "frame {i}");
    }
    // One summary line per band.
    let bands: Vec<&str> = v["summary"].as_array().unwrap().iter().map(|x| x["band"].as_str().unwrap()).collect();
    assert_eq!(bands, ["fused", "R", "G", "B"]);
}

#[test]
fn readers_that_do_not_read_bands_yet_refuse_a_colour_capture_by_name() {
    for cmd in [
        &["fit", COLOUR, "--out", "/nonexistent/never-written"][..],
        &["diagnose", COLOUR, "--out", "/nonexistent/never-written"][..],
        &["maps", COLOUR, "--out", "/nonexistent/never-written"][..],
        &["heading", COLOUR, "--estimator", "plain"][..],
    ] {
        bpins(cmd).fails().stderr_has("colour");
    }
}

#[test]
fn a_colour_mosaic_read_as_monochrome_is_refused_and_names_the_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let cap = tmp.path().join("colour-as-mono");
    fs::create_dir_all(cap.join("frames")).unwrap();
    for f in fs::read_dir(format!("{COLOUR}/frames")).unwrap() {
        let f = f.unwrap();
        fs::copy(f.path(), cap.join("frames").join(f.file_name())).unwrap();
    }
    let toml = fs::read_to_string(format!("{COLOUR}/capture.toml")).unwrap();
    let mono: String = toml.lines().filter(|l| !l.starts_with("colour_tiles")).map(|l| format!("{l}\n")).collect();
    assert_ne!(mono, toml);
    fs::write(cap.join("capture.toml"), mono).unwrap();
    for estimator in ["plain", "field"] {
        bpins(&["heading", &s(&cap), "--estimator", estimator])
            .fails()
            .stderr_has("frames[0] (frames/f000.png)")
            .stderr_has("4-pixel period")
            .stderr_has("colour_tiles");
    }
    // A monochrome capture of the same spec passes the same test.
    bpins(&["heading", concat!(env!("CARGO_MANIFEST_DIR"), "/samples/clean")]).ok();
}
