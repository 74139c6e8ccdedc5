//! Validates every WGSL kernel with naga at build time, so a broken shader fails
//! `cargo build` on a machine with no GPU (as Vello's `vello_shaders` does).
//!
//! A kernel module is `shaders/common/*.wgsl` + `shaders/effects/*.wgsl` +
//! `shaders/kernels/<kernel>.wgsl` (WGSL declarations are order-free). At run time
//! `shaders.rs` assembles the same module with the effects taken from the registry; a
//! test checks that the registry's WGSL twins are exactly the files validated here.

use std::fs;
use std::path::{Path, PathBuf};

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
    let mut shared = String::new();
    for dir in ["common", "effects"] {
        println!("cargo:rerun-if-changed={}", root.join(dir).display());
        for f in wgsl_files(&root.join(dir)) {
            println!("cargo:rerun-if-changed={}", f.display());
            shared += &fs::read_to_string(&f).unwrap_or_else(|e| panic!("reading {}: {e}", f.display()));
            shared.push('\n');
        }
    }
    let mut failures = Vec::new();
    for k in wgsl_files(&root.join("kernels")) {
        println!("cargo:rerun-if-changed={}", k.display());
        let src = shared.clone() + &fs::read_to_string(&k).unwrap_or_else(|e| panic!("reading {}: {e}", k.display()));
        let name = k.file_name().unwrap().to_string_lossy().to_string();
        match naga::front::wgsl::parse_str(&src) {
            Err(e) => failures.push(format!("{name}: {}", e.emit_to_string(&src))),
            Ok(module) => {
                let mut v = naga::valid::Validator::new(
                    naga::valid::ValidationFlags::all(),
                    naga::valid::Capabilities::FLOAT64,
                );
                if let Err(e) = v.validate(&module) {
                    failures.push(format!("{name}: {}", e.emit_to_string(&src)));
                }
            }
        }
    }
    if !failures.is_empty() {
        panic!("WGSL validation failed:\n{}", failures.join("\n"));
    }
}
