//! Fuzzing the readers of what users bring: `capture.toml`, its frame images,
//! `calibration.toml` and sweep files (`bpins-sweep/1`, every one of `examples/sweeps/`). proptest mutates valid files (numbers swapped for extremes,
//! lines dropped or doubled, keys renamed, bytes flipped, files cut short) and each
//! reader must answer with a value that meets every range of docs/ranges.md or with an
//! error naming the file, never a panic, and never a write into the capture.
//!
//! Bounded in the test command (64 cases per property); longer on demand:
//!
//! ```text
//! BPINS_FUZZ_CASES=20000 cargo test --release -p bpins-core --test fuzz_inputs
//! ```
//!
//! Inputs that once broke a reader, or that anyone finds, are kept as regression
//! cases in `tests/fuzz-cases/` (each must be refused with an error naming the file);
//! proptest also keeps the seeds of its own failures in `proptest-regressions/`.

use std::fs;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use bpins_core::calibration::Calibration;
use bpins_core::effects::EffectSet;
use bpins_core::internal::capture::{ranges, Capture, FrameData};
use bpins_core::internal::sky::sun::sun_from_time_place;
use bpins_core::internal::sweep::{Distribution, SweepSpec};
use proptest::prelude::*;

const CLEAN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/clean");
const SWEEPS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/sweeps");
const CASES_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fuzz-cases");
const W: u32 = 8;
const H: u32 = 6;

fn cases() -> u32 {
    std::env::var("BPINS_FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(64)
}

/// A small valid capture (8 × 6 px, three frames: PNG, TIFF, and a sun from time and
/// place with every optional key), written once; each case works on a copy.
fn base() -> &'static Path {
    static BASE: std::sync::OnceLock<(tempfile::TempDir, PathBuf)> = std::sync::OnceLock::new();
    let (_, dir) = BASE.get_or_init(|| {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("cap");
        let mut c = Capture::load(Path::new(CLEAN)).unwrap();
        c.sensor.geometry.width_px = W;
        c.sensor.geometry.height_px = H;
        c.lens.principal_point_px = (3.5, 2.5);
        c.frames.truncate(3);
        c.frames[1].file = "frames/f001.tif".into();
        let f = &mut c.frames[2];
        f.sun = sun_from_time_place("2026-06-21T18:30:00Z", 36.07, 120.38).unwrap();
        (f.tilt_x_deg, f.tilt_y_deg, f.tilt_sigma_deg, f.sun_sigma_deg) = (Some(1.5), Some(-2.0), Some(0.2), Some(0.1));
        let frames: Vec<FrameData> = (0..3)
            .map(|k| FrameData::Mosaic {
                width_px: W,
                height_px: H,
                dn: (0..W * H).map(|i| ((i * 37 + k * 11) % 4000) as f32).collect(),
            })
            .collect();
        c.write(&dir, &frames).unwrap();
        (tmp, dir)
    });
    dir
}

/// A fresh copy of the base capture.
fn copy_base() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("cap");
    fs::create_dir_all(dir.join("frames")).unwrap();
    for rel in ["capture.toml", "frames/f000.png", "frames/f001.tif", "frames/f002.png"] {
        fs::copy(base().join(rel), dir.join(rel)).unwrap();
    }
    (tmp, dir)
}

/// Values that break readers: extremes, non-finite numbers, wrong types.
const EXTREMES: [&str; 16] = [
    "0",
    "-0.0",
    "-1",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "-4294967297",
    "1e-320",
    "\"x\"",
    "[]",
    "{}",
    "true",
    "1979-05-27T07:32:00Z",
];

#[derive(Clone, Debug)]
enum Edit {
    /// Replace the value on line `line` with one of EXTREMES.
    Value {
        line: usize,
        value: usize,
    },
    /// Scale the number on line `line` by `factor`.
    Scale {
        line: usize,
        factor: f64,
    },
    /// Replace the `nth` number on line `line` (inside a list or an inline table too)
    /// with one of EXTREMES.
    Number {
        line: usize,
        nth: usize,
        value: usize,
    },
    DropLine(usize),
    DoubleLine(usize),
    /// Rename the key on line `line`.
    RenameKey(usize),
    /// Replace byte `at` by `byte`.
    Byte {
        at: usize,
        byte: u8,
    },
    Truncate(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 0..EXTREMES.len()).prop_map(|(line, value)| Edit::Value { line, value }),
        (any::<usize>(), prop_oneof![Just(-1.0), Just(1e3), Just(1e9), Just(0.5), Just(1e-9)])
            .prop_map(|(line, factor)| Edit::Scale { line, factor }),
        (any::<usize>(), 0usize..4, 0..EXTREMES.len()).prop_map(|(line, nth, value)| Edit::Number { line, nth, value }),
        any::<usize>().prop_map(Edit::DropLine),
        any::<usize>().prop_map(Edit::DoubleLine),
        any::<usize>().prop_map(Edit::RenameKey),
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Edit::Byte { at, byte }),
        any::<usize>().prop_map(Edit::Truncate),
    ]
}

/// Applies `e` to a TOML text.
fn apply(text: &str, e: &Edit) -> Vec<u8> {
    if text.is_empty() {
        return Vec::new();
    }
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        lines.push(String::new());
    }
    let n = lines.len();
    match *e {
        Edit::Value { line, value } => {
            let l = &mut lines[line % n];
            if let Some(eq) = l.find('=') {
                *l = format!("{}= {}", &l[..eq], EXTREMES[value]);
            }
        }
        Edit::Scale { line, factor } => {
            let l = &mut lines[line % n];
            if let Some(eq) = l.find('=') {
                if let Ok(v) = l[eq + 1..].trim().parse::<f64>() {
                    *l = format!("{}= {:?}", &l[..eq], v * factor);
                }
            }
        }
        Edit::Number { line, nth, value } => {
            let l = &mut lines[line % n];
            if let Some(eq) = l.find('=') {
                // Numbers after the first `=`: runs of digits, signs, points and exponents.
                let is_num = |c: char| c.is_ascii_digit() || "+-.eE".contains(c);
                let b = l.as_bytes();
                let mut spans = Vec::new();
                let mut i = eq + 1;
                while i < b.len() {
                    if b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_alphabetic()) {
                        let start = if i > 0 && (b[i - 1] == b'-' || b[i - 1] == b'+') { i - 1 } else { i };
                        let mut end = i;
                        while end < b.len() && is_num(b[end] as char) {
                            end += 1;
                        }
                        spans.push((start, end));
                        i = end;
                    } else {
                        i += 1;
                    }
                }
                if let Some(&(a, z)) = spans.get(nth % spans.len().max(1)) {
                    *l = format!("{}{}{}", &l[..a], EXTREMES[value], &l[z..]);
                }
            }
        }
        Edit::DropLine(line) => {
            lines.remove(line % n);
        }
        Edit::DoubleLine(line) => {
            let l = lines[line % n].clone();
            lines.insert(line % n, l);
        }
        Edit::RenameKey(line) => {
            let l = &mut lines[line % n];
            if let Some(eq) = l.find('=') {
                *l = format!("{}_x {}", l[..eq].trim_end(), &l[eq..]);
            }
        }
        Edit::Byte { at, byte } => {
            let mut b = text.as_bytes().to_vec();
            let i = at % b.len();
            b[i] = byte;
            return b;
        }
        Edit::Truncate(at) => return text.as_bytes()[..at % text.len()].to_vec(),
    }
    (lines.join("\n") + "\n").into_bytes()
}

/// Every file under `dir` with its bytes, to check that a reader wrote nothing.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    for rel in ["capture.toml", "frames/f000.png", "frames/f001.tif", "frames/f002.png"] {
        out.push((rel.into(), fs::read(dir.join(rel)).unwrap_or_default()));
    }
    out.push(("(entries)".into(), fs::read_dir(dir).unwrap().count().to_le_bytes().to_vec()));
    out
}

/// Loads the capture and decodes every frame; `Err(message)` where bpins refused it.
/// A panic fails the test with the input that caused it.
fn read_capture(dir: &Path) -> Result<Capture, String> {
    let before = snapshot(dir);
    let got = catch_unwind(AssertUnwindSafe(|| -> bpins_core::Result<Capture> {
        let c = Capture::load(dir)?;
        for i in 0..c.frames.len() {
            c.read_frame(i)?;
        }
        Ok(c)
    }));
    assert_eq!(snapshot(dir), before, "reading changed the capture folder");
    match got {
        Ok(Ok(c)) => Ok(c),
        Ok(Err(e)) => Err(e.to_string()),
        Err(_) => panic!("the capture reader panicked on {}", dir.display()),
    }
}

/// What an accepted capture must satisfy: every range of docs/ranges.md.
fn assert_in_range(c: &Capture) {
    let g = &c.sensor.geometry;
    assert!(ranges::WIDTH_PX.contains(g.width_px as f64) && ranges::HEIGHT_PX.contains(g.height_px as f64));
    assert!(ranges::PIXEL_PITCH_UM.contains(g.pixel_pitch_um), "pitch {}", g.pixel_pitch_um);
    assert!(ranges::FOCAL_LENGTH_MM.contains(c.lens.focal_length_mm));
    assert!(ranges::BIT_DEPTH.contains(c.sensor.bit_depth as f64));
    for f in &c.frames {
        assert!(f.sun.azimuth_deg.is_finite() && ranges::SUN_ELEVATION_DEG.contains(f.sun.elevation_deg));
        for (r, v) in [
            (ranges::HEADING_DEG, f.heading_deg),
            (ranges::TILT_X_DEG, f.tilt_x_deg),
            (ranges::TILT_Y_DEG, f.tilt_y_deg),
            (ranges::TILT_SIGMA_DEG, f.tilt_sigma_deg),
            (ranges::SUN_SIGMA_DEG, f.sun_sigma_deg),
        ] {
            assert!(v.is_none_or(|v| r.contains(v)), "{} = {v:?} accepted", r.key);
        }
    }
}

fn config() -> ProptestConfig {
    ProptestConfig { cases: cases(), ..ProptestConfig::default() }
}

proptest! {
    #![proptest_config(config())]

    /// A mutated capture.toml reads as a capture within every range, or is refused
    /// naming capture.toml (or the frame file it names).
    #[test]
    fn capture_toml_mutations(edits in prop::collection::vec(edit(), 1..4)) {
        let (_tmp, dir) = copy_base();
        let mut text = fs::read_to_string(dir.join("capture.toml")).unwrap();
        for e in &edits {
            text = String::from_utf8_lossy(&apply(&text, e)).into_owned();
        }
        fs::write(dir.join("capture.toml"), &text).unwrap();
        match read_capture(&dir) {
            Ok(c) => assert_in_range(&c),
            Err(msg) => prop_assert!(
                msg.contains("capture.toml") || msg.contains("frames/f00"),
                "an error that names no file: {msg}"
            ),
        }
    }

    /// A frame image with bytes flipped, cut short or grown is decoded or refused
    /// naming the frame file.
    #[test]
    fn frame_image_mutations(
        frame in 0usize..3,
        flips in prop::collection::vec((any::<usize>(), any::<u8>()), 0..6),
        cut in prop::option::of(any::<usize>()),
        grow in prop::option::of(prop::collection::vec(any::<u8>(), 1..64)),
    ) {
        let (_tmp, dir) = copy_base();
        let rel = ["frames/f000.png", "frames/f001.tif", "frames/f002.png"][frame];
        let mut bytes = fs::read(dir.join(rel)).unwrap();
        for (at, b) in flips {
            let n = bytes.len();
            bytes[at % n] = b;
        }
        if let Some(at) = cut {
            bytes.truncate(at % bytes.len());
        }
        if let Some(extra) = grow {
            bytes.extend(extra);
        }
        fs::write(dir.join(rel), &bytes).unwrap();
        if let Err(msg) = read_capture(&dir) {
            prop_assert!(msg.contains(rel), "an error that does not name {rel}: {msg}");
        }
    }

    /// A mutated calibration.toml parses to effects within the registry's ranges, or
    /// is refused naming the file.
    #[test]
    fn calibration_mutations(edits in prop::collection::vec(edit(), 1..4)) {
        let mut effects = EffectSet::new();
        effects.set("analyzer_angles", "d45_deg", 1.0).unwrap();
        effects.set("array_rotation", "dtheta_deg", 0.3).unwrap();
        let cal = Calibration { effects, source: "fuzz".into(), chi2_per_dof: Some(1.01), ..Default::default() };
        let mut text = cal.to_toml();
        for e in &edits {
            text = String::from_utf8_lossy(&apply(&text, e)).into_owned();
        }
        let path = Path::new("lab/calibration.toml");
        let got = catch_unwind(|| Calibration::parse(path, &text));
        match got {
            Err(_) => panic!("the calibration reader panicked on:\n{text}"),
            Ok(Err(e)) => prop_assert!(e.to_string().contains("lab/calibration.toml"), "{e}"),
            Ok(Ok(c)) => {
                // What was accepted builds a chain without panicking.
                let _ = c.model();
            }
        }
    }
}

/// The example sweep files (name, text), sorted.
fn sweep_examples() -> &'static [(String, String)] {
    static EXAMPLES: std::sync::OnceLock<Vec<(String, String)>> = std::sync::OnceLock::new();
    EXAMPLES.get_or_init(|| {
        let mut out: Vec<(String, String)> = fs::read_dir(SWEEPS)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), fs::read_to_string(&p).unwrap()))
            .collect();
        out.sort();
        assert!(out.len() >= 3, "examples/sweeps holds {} sweep files", out.len());
        out
    })
}

/// Parses a sweep file's text as `sweeps/<name>`; `Err(message)` where refused. A
/// panic fails the test with the text.
fn read_sweep(name: &str, text: &str) -> Result<SweepSpec, String> {
    let path = PathBuf::from("sweeps").join(name);
    match catch_unwind(|| SweepSpec::parse(&path, text)) {
        Ok(Ok(s)) => Ok(s),
        Ok(Err(e)) => Err(e.to_string()),
        Err(_) => panic!("the sweep reader panicked on:\n{text}"),
    }
}

/// What an accepted sweep must satisfy: the capture's ranges for its sensor and lens,
/// the sweep format's own (module doc of `bpins_core::sweep`), and draws that are
/// finite numbers for every source.
fn assert_sweep_in_range(s: &SweepSpec) {
    let g = &s.sensor.geometry;
    assert!(ranges::WIDTH_PX.contains(g.width_px as f64) && ranges::HEIGHT_PX.contains(g.height_px as f64));
    assert!(ranges::PIXEL_PITCH_UM.contains(g.pixel_pitch_um), "pitch {}", g.pixel_pitch_um);
    assert!(ranges::FOCAL_LENGTH_MM.contains(s.lens.focal_length_mm), "focal {}", s.lens.focal_length_mm);
    assert!(ranges::BIT_DEPTH.contains(s.sensor.bit_depth as f64));
    assert!(s.trials >= 1 && s.trials_per_azimuth >= 1 && !s.errors.is_empty() && !s.extractors.is_empty());
    assert!(s.sun_elevations_deg.iter().all(|e| *e > 0.0 && *e < 90.0), "{:?}", s.sun_elevations_deg);
    assert!(
        s.sun_azimuths_deg.iter().all(|a| ranges::SUN_AZIMUTH_DEG.contains(*a)),
        "sun azimuths {:?} accepted",
        s.sun_azimuths_deg
    );
    assert!(s.dmax > 0.0 && s.dmax <= 1.0 && s.peak_dn > 0.0 && s.peak_dn <= s.sensor.full_scale_dn());
    for e in &s.errors {
        match e.distribution {
            Distribution::Normal { mean, sigma } => assert!(mean.is_finite() && sigma.is_finite() && sigma >= 0.0),
            Distribution::Uniform { min, max } => assert!(min.is_finite() && max.is_finite() && min <= max),
            Distribution::Fixed { value } => assert!(value.is_finite()),
        }
    }
    assert!(bpins_core::internal::sweep::unit_count(s) >= 1);
    assert!(s.corner_r2().is_finite());
    for source in 0..s.sources.len() {
        for trial in 0..2 {
            let d = bpins_core::internal::sweep::draws(s, source, trial);
            assert!(d.iter().all(|x| x.is_finite()), "source {source} trial {trial} draws {d:?}");
        }
    }
}

proptest! {
    #![proptest_config(config())]

    /// A mutated sweep file parses to a sweep within every range, or is refused naming
    /// the file and the key.
    #[test]
    fn sweep_file_mutations(which in any::<usize>(), edits in prop::collection::vec(edit(), 1..4)) {
        let examples = sweep_examples();
        let (name, original) = &examples[which % examples.len()];
        let mut text = original.clone();
        for e in &edits {
            text = String::from_utf8_lossy(&apply(&text, e)).into_owned();
        }
        match read_sweep(name, &text) {
            Ok(s) => assert_sweep_in_range(&s),
            Err(msg) => prop_assert!(msg.starts_with(&format!("sweeps/{name}: ")), "an error that names no file: {msg}"),
        }
    }
}

/// Every example sweep file parses and meets every range (the fuzzer's starting points).
#[test]
fn example_sweeps_parse_within_range() {
    for (name, text) in sweep_examples() {
        assert_sweep_in_range(&read_sweep(name, text).unwrap_or_else(|e| panic!("{name}: {e}")));
    }
}

/// Every kept regression case is refused with an error naming its file, and reading
/// it does not panic. `capture-*.toml` replace the base capture's TOML;
/// `calibration-*.toml` are calibration files; `sweep-*.toml` sweep files.
#[test]
fn kept_regression_cases_are_refused() {
    let mut seen = 0;
    let mut entries: Vec<_> = fs::read_dir(CASES_DIR).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for path in entries {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let text = fs::read_to_string(&path).unwrap();
        if name.starts_with("capture-") {
            let (_tmp, dir) = copy_base();
            fs::write(dir.join("capture.toml"), &text).unwrap();
            let msg = read_capture(&dir).expect_err(&format!("{name} was accepted"));
            assert!(msg.contains("capture.toml"), "{name}: {msg}");
        } else if name.starts_with("calibration-") {
            let msg = Calibration::parse(&path, &text).expect_err(&format!("{name} was accepted")).to_string();
            assert!(msg.contains(&name), "{name}: {msg}");
        } else if name.starts_with("sweep-") {
            let msg = read_sweep(&name, &text).expect_err(&format!("{name} was accepted"));
            assert!(msg.starts_with(&format!("sweeps/{name}: ")), "{name}: {msg}");
        } else {
            continue;
        }
        seen += 1;
    }
    assert!(seen >= 4, "only {seen} regression cases in {CASES_DIR}");
}
