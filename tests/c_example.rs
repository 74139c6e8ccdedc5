//! examples/c/heading.c, compiled with the system's C compiler against `libbpins.a`
//! and run on the clean sample's frame 0 as raw little-endian u16, as a camera SDK's
//! buffer (shipped as `examples/c/f000.u16`, checked here to be that frame): its heading equals the Rust front door's to 1e-9° and the
//! sample's truth within 2σ. Without a C compiler the test is counted as ignored,
//! with the reason and the install command below the run's summary, except under CI
//! (env `CI` set), where it fails (the harness is `tests/needs/mod.rs`, `harness = false`).

// The C ABI tests' sample frames (crates/bpins-capi/tests/common).
#[path = "../crates/bpins-capi/tests/common/mod.rs"]
mod common;
#[path = "needs/mod.rs"]
mod needs;

use bpins_core::compass::{Compass, Sun};
use bpins_core::conventions::wrap_deg_180;
use bpins_core::internal::heading::field::RawImage;
use std::path::{Path, PathBuf};
use std::process::Command;

fn main() -> std::process::ExitCode {
    let missing =
        c_compiler().err().map(|why| format!("{why}; install one (Debian: `apt-get install -y gcc libc6-dev`)"));
    needs::run(vec![(
        needs::Need::new("a C compiler", missing),
        vec![(
            "the_c_example_reads_the_clean_sample_as_the_rust_front_door_does",
            the_c_example_reads_the_clean_sample_as_the_rust_front_door_does,
        )],
    )])
}

/// The C compiler: `$CC`, else `cc`; Err (with why) if it does not run.
fn c_compiler() -> Result<String, String> {
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    match Command::new(&cc).arg("--version").output() {
        Ok(o) if o.status.success() => Ok(cc),
        Ok(o) => Err(format!("`{cc} --version` exited with {}", o.status)),
        Err(e) => Err(format!("no C compiler `{cc}` ($CC or cc): {e}")),
    }
}

/// The folder holding this build's `libbpins.a`. Under `cargo test` cargo builds the
/// crate's staticlib beside the test binary (`target/<profile>/deps/`) and does not
/// copy it up, so that folder first; then `target/<profile>/` (a `cargo build`), then
/// `$CARGO_TARGET_DIR/debug` or the workspace's `target/debug`.
fn lib_dir() -> PathBuf {
    let exe = std::env::current_exe().ok();
    let deps = exe.as_deref().and_then(Path::parent);
    let candidates = [deps.map(Path::to_path_buf), deps.and_then(Path::parent).map(Path::to_path_buf)];
    if let Some(d) = candidates.into_iter().flatten().find(|d| d.join("libbpins.a").is_file()) {
        return d;
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target"));
    target.join("debug")
}

/// `key value` from the example's output.
fn value(stdout: &str, key: &str) -> f64 {
    let line = stdout.lines().find_map(|l| l.strip_prefix(key).and_then(|r| r.strip_prefix(' ')));
    line.unwrap_or_else(|| panic!("no `{key}` in the output:\n{stdout}")).trim().parse().expect(key)
}

fn the_c_example_reads_the_clean_sample_as_the_rust_front_door_does() {
    let cc = c_compiler().expect("main checked for a C compiler");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf();
    let lib = lib_dir().join("libbpins.a");
    assert!(lib.is_file(), "{} missing: cargo builds it with the crate", lib.display());
    if needs::verbose() {
        eprintln!("linking {}", lib.display());
    }

    let s = common::clean_frame(0);
    let (w, h) = (s.config.width_px, s.config.height_px);
    let tmp = tempfile::tempdir().unwrap();
    // The frame shipped beside the example (so a newcomer can run it as the README
    // says) is the clean sample's frame 0, byte for byte.
    let raw_path = root.join("examples/c/f000.u16");
    let want: Vec<u8> = s.raw.iter().flat_map(|x| x.to_le_bytes()).collect();
    let shipped = std::fs::read(&raw_path).unwrap_or_else(|e| panic!("{}: {e}", raw_path.display()));
    assert!(shipped == want, "{} is not samples/clean's frame 0 as raw little-endian u16", raw_path.display());

    let exe = tmp.path().join("heading");
    let out = Command::new(&cc)
        .args(["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-I"])
        .arg(root.join("crates/bpins-capi/include"))
        .arg(root.join("examples/c/heading.c"))
        .arg(&lib)
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&exe)
        .output()
        .expect("running the C compiler");
    assert!(out.status.success(), "{cc} failed:\n{}", String::from_utf8_lossy(&out.stderr));

    let Sun::Angles { azimuth_deg, elevation_deg, .. } = s.sun else { unreachable!() };
    let cam = s.config.camera;
    let a = s.attitude;
    let args: Vec<String> = [w as f64, h as f64, s.config.bit_depth as f64, s.config.black_level_dn]
        .into_iter()
        .chain([cam.f_px, cam.cx_px, cam.cy_px, azimuth_deg, elevation_deg, a.tilt_x_deg, a.tilt_y_deg, a.sigma_deg])
        .map(|x| x.to_string())
        .collect();
    let run = Command::new(&exe).arg(&raw_path).args(&args).output().expect("running the example");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "the example failed: {}{stdout}", String::from_utf8_lossy(&run.stderr));
    if needs::verbose() {
        eprintln!("$ heading f000.u16 {}\n{stdout}", args.join(" "));
    }
    let (c_deg, c_sigma) = (value(&stdout, "heading_deg"), value(&stdout, "sigma_deg"));

    let mut rust = Compass::new(s.config.clone()).unwrap();
    let fix = rust.heading(RawImage::packed(&s.raw, w, h), s.sun, s.attitude).unwrap();
    let (r_deg, r_sigma) = (fix.heading_deg().unwrap(), fix.sigma_deg().unwrap());
    assert!((c_deg - r_deg).abs() <= 1e-9, "C {c_deg}° vs Rust {r_deg}°");
    assert!((c_sigma - r_sigma).abs() <= 1e-9, "C 1σ {c_sigma}° vs Rust {r_sigma}°");
    let err = wrap_deg_180(c_deg - s.truth_deg);
    assert!(err.abs() < 2.0 * c_sigma, "C heading {c_deg}° vs truth {}° (1σ {c_sigma}°)", s.truth_deg);

    // A calibration file that is not there: exit status 1 and bpins's message naming it.
    let missing = tmp.path().join("no-such-calibration.toml");
    let run = Command::new(&exe).arg(&raw_path).args(&args).arg(&missing).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("no-such-calibration.toml"), "{stderr}");
}
