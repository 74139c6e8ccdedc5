//! Memory bounded by the frame, not the capture: `simulate` and `heading` on a capture
//! three times as long peak at the same resident memory; so do `fit` and `diagnose`
//! under a sample budget (each frame held as its sample, residual maps written frame
//! by frame). The peak is the child's
//! VmHWM (Linux's high-water mark of resident memory, /proc/PID/status), read until it
//! exits. Frames are the samples' 612 × 512: a command that kept every frame (f32, 1.25
//! MB each, more with its buffers) would grow by 40 MB or more from 16 to 48 frames;
//! the bound allowed is 12 MB.

use std::process::{Command, Stdio};
use std::time::Duration;

/// Runs bpins with `args` to success and returns its peak resident memory in MB.
fn peak_mb(args: &[&str]) -> f64 {
    let mut child = Command::new(env!("CARGO_BIN_EXE_bpins"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("bpins starts");
    let status_path = format!("/proc/{}/status", child.id());
    let mut peak_kb = 0u64;
    loop {
        // VmHWM only grows: the last reading before the process ends is its peak to
        // within the last few milliseconds.
        if let Ok(s) = std::fs::read_to_string(&status_path) {
            if let Some(kb) = s
                .lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse::<u64>().ok())
            {
                peak_kb = peak_kb.max(kb);
            }
        }
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
            assert!(status.success(), "bpins {args:?} failed: {err}");
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(peak_kb > 0, "no VmHWM read for bpins {args:?}");
    peak_kb as f64 / 1024.0
}

fn headings(n: usize) -> String {
    (0..n).map(|k| format!("{}", (k * 7) % 360)).collect::<Vec<_>>().join(",")
}

#[test]
#[cfg_attr(not(target_os = "linux"), ignore = "reads /proc")]
fn simulate_and_heading_peak_the_same_on_16_and_48_frames() {
    let t = tempfile::tempdir().unwrap();
    let mut peaks = Vec::new();
    for n in [16, 48] {
        let cap = t.path().join(format!("cap{n}"));
        let c = cap.to_str().unwrap();
        let hs = headings(n);
        let sim = peak_mb(&["simulate", "--out", c, "--headings-deg", &hs]);
        let head = peak_mb(&["heading", c, "--extractor", "sun_vector"]);
        peaks.push((n, sim, head));
    }
    let [(_, sim16, head16), (_, sim48, head48)] = peaks[..] else { unreachable!() };
    println!(
        "peak resident: simulate {sim16:.1} → {sim48:.1} MB, heading {head16:.1} → {head48:.1} MB (16 → 48 frames)"
    );
    assert!(sim48 - sim16 < 12.0, "simulate grows with the frames: {sim16:.1} MB → {sim48:.1} MB");
    assert!(head48 - head16 < 12.0, "heading grows with the frames: {head16:.1} MB → {head48:.1} MB");
}

#[test]
#[cfg_attr(not(target_os = "linux"), ignore = "reads /proc")]
fn fit_and_diagnose_under_a_budget_peak_the_same_on_8_and_24_frames() {
    // 16 384 px of each 612 × 512 frame: one 8 × 8 block per 40 × 40 stratum, 13 312
    // px (52 kB) held per frame instead of 1.25 MB. Growth allowed from 8 to 24
    // frames: 12 MB (the normal matrix over 16 nuisances a frame grows too: 1.2 MB at
    // 24 frames); holding every frame and its maps would add 16 × ≈ 3 MB.
    let t = tempfile::tempdir().unwrap();
    let mut peaks = Vec::new();
    for n in [8, 24] {
        let cap = t.path().join(format!("cap{n}"));
        let c = cap.to_str().unwrap();
        peak_mb(&["simulate", "--out", c, "--headings-deg", &headings(n)]);
        let out = |what: &str| t.path().join(format!("{what}{n}")).to_str().unwrap().to_string();
        let budget = ["--sample-budget", "16384"];
        let fit = peak_mb(&[&["fit", c, "--out", &out("fit")][..], &budget].concat());
        let diag = peak_mb(&[&["diagnose", c, "--max-added", "1", "--out", &out("diag")][..], &budget].concat());
        let json = std::fs::read_to_string(t.path().join(format!("fit{n}/fit.json"))).unwrap();
        assert!(json.contains("\"pixels_per_frame\": 13312"), "fit.json states the sample: {json:.2000}");
        assert!(t.path().join(format!("fit{n}/frames/f{}_residual_dn.exr", n - 1)).is_file());
        peaks.push((fit, diag));
    }
    let [(fit8, diag8), (fit24, diag24)] = peaks[..] else { unreachable!() };
    println!("peak resident: fit {fit8:.1} → {fit24:.1} MB, diagnose {diag8:.1} → {diag24:.1} MB (8 → 24 frames)");
    assert!(fit24 - fit8 < 12.0, "fit grows with the frames: {fit8:.1} MB → {fit24:.1} MB");
    assert!(diag24 - diag8 < 12.0, "diagnose grows with the frames: {diag8:.1} MB → {diag24:.1} MB");
}
