//! Validates every WGSL kernel with naga at build time, so a broken shader fails
//! `cargo build` on a machine with no GPU (as Vello's `vello_shaders` does).
//!
//! A kernel module is `shaders/common/*.wgsl` + `shaders/effects/*.wgsl` + the
//! per-pixel effects' dispatch (`ray_dispatch.rs`, here over the effect files that
//! define a per-pixel function) + `shaders/kernels/<kernel>.wgsl` (WGSL declarations
//! are order-free). At run time `shaders.rs` assembles the same module with the effects
//! and the dispatch order taken from the registry; a test checks that the registry's
//! WGSL twins and per-pixel effects are exactly the files and functions validated here.

use std::fs;
use std::path::{Path, PathBuf};

#[path = "src/precision.rs"]
#[allow(dead_code)]
mod precision;
#[path = "src/ray_dispatch.rs"]
mod ray_dispatch;

fn wgsl_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "wgsl"))
        .collect();
    v.sort();
    v
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    println!("cargo:rerun-if-changed={}", root.display());
    println!("cargo:rerun-if-changed=src/precision.rs");
    println!("cargo:rerun-if-changed=src/ray_dispatch.rs");
    let mut shared = String::new();
    let mut effects = Vec::new();
    for dir in ["common", "effects"] {
        println!("cargo:rerun-if-changed={}", root.join(dir).display());
        for f in wgsl_files(&root.join(dir)) {
            println!("cargo:rerun-if-changed={}", f.display());
            let src = fs::read_to_string(&f).unwrap_or_else(|e| panic!("reading {}: {e}", f.display()));
            shared += &src;
            shared.push('\n');
            if dir == "effects" {
                effects.push((f.file_stem().unwrap().to_string_lossy().into_owned(), src));
            }
        }
    }
    shared += &ray_dispatch::ray_effects_wgsl(&ray_dispatch::ray_effects_in(&effects));
    shared += &ray_dispatch::analyzer_effects_wgsl(&ray_dispatch::analyzer_effects_in(&effects));
    shared += &ray_dispatch::sky_effects_wgsl(&ray_dispatch::sky_effects_in(&effects));
    shared += &ray_dispatch::sensor_effects_wgsl(&ray_dispatch::sensor_effects_in(&effects));
    shared += &ray_dispatch::mosaic_effects_wgsl(&ray_dispatch::mosaic_effects_in(&effects));
    let mut failures = Vec::new();
    for k in wgsl_files(&root.join("kernels")) {
        println!("cargo:rerun-if-changed={}", k.display());
        let src64 = shared.clone() + &fs::read_to_string(&k).unwrap_or_else(|e| panic!("reading {}: {e}", k.display()));
        let name = k.file_name().unwrap().to_string_lossy().to_string();
        // Each kernel at both precisions: f64 with the FLOAT64 capability, the f32 twin
        // (precision.rs) without it, so an f64 left in the f32 module fails the build.
        for (tag, src, caps) in [
            ("f64", src64.clone(), naga::valid::Capabilities::FLOAT64),
            ("f32", precision::to_f32(&src64), naga::valid::Capabilities::empty()),
        ] {
            match naga::front::wgsl::parse_str(&src) {
                Err(e) => failures.push(format!("{name} ({tag}): {}", e.emit_to_string(&src))),
                Ok(module) => {
                    let mut v = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps);
                    if let Err(e) = v.validate(&module) {
                        failures.push(format!("{name} ({tag}): {}", e.emit_to_string(&src)));
                    }
                }
            }
        }
    }
    if !failures.is_empty() {
        panic!("WGSL validation failed:\n{}", failures.join("\n"));
    }
}
