//! The core builds without its default features (a robot's build: buffers in,
//! headings out), and that build pulls in none of the I/O crates. Runs cargo itself,
//! into its own target folder so that it never waits on the test run's lock.

use std::path::{Path, PathBuf};
use std::process::Command;

fn cargo(args: &[&str]) -> std::process::Output {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target"))
        .join("no-default-features");
    Command::new(env!("CARGO"))
        .args(args)
        .current_dir(&root)
        .env("CARGO_TARGET_DIR", target)
        .output()
        .expect("cargo runs")
}

#[test]
fn the_core_without_default_features_has_no_io_crates_and_builds() {
    let tree =
        cargo(&["tree", "-p", "bpins-core", "--no-default-features", "-e", "normal", "--prefix", "none", "--locked"]);
    assert!(tree.status.success(), "{}", String::from_utf8_lossy(&tree.stderr));
    let tree = String::from_utf8_lossy(&tree.stdout);
    let names: Vec<&str> = tree.lines().filter_map(|l| l.split_whitespace().next()).collect();
    assert!(names.contains(&"glam") && names.contains(&"rayon"), "{tree}");
    for io in ["image", "exr", "toml", "chrono", "solar-positioning", "serde_json", "png", "tiff"] {
        assert!(!names.contains(&io), "{io} in the no-default-features tree:\n{tree}");
    }
    // The same crate with its defaults does pull them in (the check above could fail).
    let full = cargo(&["tree", "-p", "bpins-core", "-e", "normal", "--prefix", "none", "--locked"]);
    assert!(String::from_utf8_lossy(&full.stdout).lines().any(|l| l.starts_with("toml ")));

    let build = cargo(&["check", "-p", "bpins-core", "--no-default-features", "--lib", "--locked", "--quiet"]);
    assert!(build.status.success(), "{}", String::from_utf8_lossy(&build.stderr));
}
