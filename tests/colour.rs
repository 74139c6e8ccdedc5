//! Colour-polarization captures (samples/colour-clear, an IMX250MYR-like RGGB layout
//! made by an independent implementation of the spec): bpins does not read them yet,
//! so it must say so by name, and must not read their frames as monochrome when the
//! `colour_tiles` key is deleted (read as mono the plain estimator is off by 0.24° RMS
//! at up to 8σ on this capture).

mod common;
use common::*;
use std::fs;

const COLOUR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/colour-clear");

#[test]
fn a_colour_capture_is_refused_by_name() {
    for cmd in [&["heading", COLOUR][..], &["fit", COLOUR, "--out", "/nonexistent/never-written"][..]] {
        bpins(cmd).fails().stderr_has("colour_tiles").stderr_has("does not read colour-polarization captures yet");
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
