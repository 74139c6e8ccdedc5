//! The crate's public surface stays the front door: the modules a user reads, the
//! use cases' entry points at the root, and the house behind them private, reached
//! by the workspace's own crates through the hidden `internal` module. A new public
//! module is a decision, made here, not an accident of `pub mod` (issue 37: rustdoc's
//! index was 509 items; it is 133).

use std::collections::BTreeSet;

/// The front door's modules, and the two narrower doors named for the workspace's own
/// clients (issue 44 item 3): `twin`, the GPU twin's, and `tool`, the CLI's and Python's.
const FRONT: &[&str] = &[
    "calibration",
    "camera",
    "catalog",
    "compass",
    "conventions",
    "effects",
    "error",
    "render",
    "scene",
    "sensor",
    "tool",
    "twin",
];

fn lib_rs() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/src/lib.rs")).expect("src/lib.rs")
}

#[test]
fn only_the_front_doors_modules_are_public() {
    let text = lib_rs();
    let public: BTreeSet<&str> =
        text.lines().filter_map(|l| l.trim().strip_prefix("pub mod ")?.strip_suffix(';')).collect();
    assert_eq!(public, FRONT.iter().copied().collect(), "src/lib.rs's `pub mod` lines");
    // Every other module is private, and the house is reached through `internal`,
    // hidden from the documentation.
    let private: Vec<&str> = text.lines().filter_map(|l| l.trim().strip_prefix("mod ")?.strip_suffix(';')).collect();
    assert!(private.len() >= 15 && private.contains(&"chain") && private.contains(&"fit"), "{private:?}");
    let hidden = text.find("#[doc(hidden)]\npub mod internal").expect("a hidden `internal` module");
    // `math`, `lsq` and `stats` are helpers of the rooms (an atan2, a least-squares
    // solver, a median), not rooms.
    for m in private.iter().filter(|m| !["math", "lsq", "stats"].contains(m)) {
        let reexport = format!("pub use crate::{m}::*;");
        assert!(text[hidden..].contains(&reexport), "`internal` does not re-export `{m}`");
    }
}

#[test]
fn the_front_page_says_where_to_start() {
    let text = lib_rs();
    assert!(text.contains("//! # Where to start"), "the crate's front page lost its table");
    for entry in [
        "compass::Compass",
        "Capture",
        "fit()",
        "diagnose()",
        "calibrate",
        "SweepSpec",
        "locate()",
        "catalog",
        "render::Renderer",
    ] {
        assert!(text.contains(&format!("[`{entry}`]")), "the front page does not point at `{entry}`");
    }
}
