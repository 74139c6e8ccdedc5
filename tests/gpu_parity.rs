//! Parity of the GPU twin with the CPU reference, on whatever Vulkan adapter exists
//! (lavapipe in CI). Without an adapter these tests are counted as ignored, with the
//! reason and the install command below the run's summary — except with `CI` set,
//! where a missing adapter fails them (the harness is `tests/needs/mod.rs`,
//! `harness = false`).

#[path = "needs/mod.rs"]
mod needs;

use bpins_core::internal::montecarlo::{self, Source, SweepConfig};
use bpins_gpu::agree::{cases, compare, tolerances, trial_frame};
use bpins_gpu::{Gpu, Precision};
use needs::Need;
use std::sync::OnceLock;

const VULKAN: &str =
    "Debian: `apt-get install -y mesa-vulkan-drivers libvulkan1` (lavapipe, Vulkan on the CPU; `.ci/run` does)";

fn main() -> std::process::ExitCode {
    let why = |p: Precision| gpu_at(p).err().map(|e| format!("{e}; {VULKAN}"));
    // Where only one precision opens, the tests over both run on it (and say so).
    let any = why(Precision::F32).and(why(Precision::F64));
    let gl = Gpu::open(Some(Precision::F32), Some(bpins_gpu::wgpu::Backends::GL)).err().map(|e| {
        format!(
            "{e}; Debian: `apt-get install -y libegl1 libgles2 libgl1-mesa-dri` (llvmpipe through EGL; `.ci/run` does)"
        )
    });
    let gl_test: needs::Test =
        ("gl_backend_runs_the_f32_chain_within_its_tolerances", gl_backend_runs_the_f32_chain_within_its_tolerances);
    needs::run(vec![
        (
            Need::new("a GPU adapter", any),
            vec![
                ("every_registered_effect_agrees_on_both_backends", every_registered_effect_agrees_on_both_backends),
                ("whole_chain_agrees_ideal_and_with_every_effect", whole_chain_agrees_ideal_and_with_every_effect),
                ("monte_carlo_trials_agree_trial_by_trial", monte_carlo_trials_agree_trial_by_trial),
                ("sky_maps_agree_on_both_backends_for_every_effect", sky_maps_agree_on_both_backends_for_every_effect),
            ],
        ),
        (
            Need::new("a GPU adapter with f64 shaders", why(Precision::F64)),
            vec![
                ("oversized_frames_are_a_clear_error_not_a_panic", oversized_frames_are_a_clear_error_not_a_panic),
                ("the_gpu_is_a_library_backend_like_the_cpu", the_gpu_is_a_library_backend_like_the_cpu),
            ],
        ),
        (Need::new("a GL adapter", gl), vec![gl_test]),
    ])
}

/// The device at `precision` (each opened once), or why it cannot open.
fn gpu_at(precision: Precision) -> Result<&'static Gpu, &'static String> {
    static GPUS: [OnceLock<Result<Gpu, String>>; 2] = [OnceLock::new(), OnceLock::new()];
    let slot = &GPUS[precision as usize];
    slot.get_or_init(|| Gpu::with_precision(Some(precision)).map_err(|e| e.to_string())).as_ref()
}

/// The f64 kernels (the pixel-for-pixel reference twin); `main` runs the tests that
/// call this only where they open.
fn gpu() -> &'static Gpu {
    gpu_at(Precision::F64).expect("main checked for an adapter with f64 shaders")
}

/// Both precisions' devices, each checked against its own tolerances: where only one
/// opens, that one (with `CI` set, both must).
fn gpus() -> Vec<&'static Gpu> {
    let mut v = Vec::new();
    for p in [Precision::F64, Precision::F32] {
        match gpu_at(p) {
            Ok(g) => v.push(g),
            Err(e) if std::env::var_os("CI").is_some() => {
                panic!("CI is set and the GPU twin cannot run at {}: {e}", p.name())
            }
            Err(e) => eprintln!("note: only one precision runs here; {} does not open: {e}", p.name()),
        }
    }
    v
}

/// Runs `trials` trials of the case named `name` and asserts every stage's tolerance.
fn assert_case_agrees(gpu: &Gpu, name: &str, trials: u32) {
    let case = cases().into_iter().find(|c| c.name == name).unwrap();
    for trial in 0..trials {
        let t = trial_frame(&case, trial, 2026).unwrap();
        let d = compare(gpu, &t).unwrap();
        if needs::verbose() {
            eprintln!("{} ({}): {:?}", t.label, gpu.precision().name(), d);
        }
        for ((stage, tol, unit), x) in tolerances(gpu.precision(), &t).iter().zip(d) {
            assert!(
                x <= *tol,
                "{} ({}): {stage} differs by {x:e} {unit} (tolerance {tol:e})",
                t.label,
                gpu.precision().name()
            );
        }
    }
}

fn every_registered_effect_agrees_on_both_backends() {
    for gpu in gpus() {
        if needs::verbose() {
            eprintln!("adapter: {}, {} kernels", gpu.adapter_name(), gpu.precision().name());
        }
        // Neutral, typical, minimum, maximum and a draw over the range for each effect
        // of the registry (the projections cycle with the trial).
        for e in bpins_core::effects::REGISTRY {
            assert_case_agrees(gpu, e.name, 5);
        }
    }
}

fn whole_chain_agrees_ideal_and_with_every_effect() {
    for gpu in gpus() {
        assert_case_agrees(gpu, "ideal", 4);
        assert_case_agrees(gpu, "all_effects", 4);
    }
}

fn monte_carlo_trials_agree_trial_by_trial() {
    for gpu in gpus() {
        let tol = bpins_gpu::tolerance::stages(gpu.precision())[6].1;
        // A small paper sweep: every source, two azimuths, three trials each.
        let cfg = SweepConfig {
            width_px: 306,
            height_px: 256,
            sun_azimuths_deg: vec![10.0, 50.0],
            trials_per_azimuth: 3,
            ..SweepConfig::default()
        };
        let cpu = montecarlo::run_sweep(&cfg, &Source::ALL, &|_, _| {}).unwrap();
        let gpu_r = bpins_gpu::montecarlo::run_sweep(gpu, &cfg, &Source::ALL, &|_, _| {}).unwrap();
        assert_eq!(cpu.len(), gpu_r.len());
        for (c, g) in cpu.iter().zip(&gpu_r) {
            assert_eq!((c.source, c.trial, c.draw), (g.source, g.trial, g.draw));
            assert_eq!(c.errors.len(), g.errors.len());
            for (a, b) in c.errors.iter().zip(&g.errors) {
                assert_eq!((a.0, a.1), (b.0, b.1));
                assert!(
                    (a.2 - b.2).abs() <= tol,
                    "{:?} trial {} ({}): {:?} CPU {} GPU {}",
                    c.source,
                    c.trial,
                    gpu.precision().name(),
                    a.0,
                    a.2,
                    b.2
                );
            }
        }
    }
}

fn oversized_frames_are_a_clear_error_not_a_panic() {
    let gpu = gpu();
    let case = &cases()[0];
    let t = trial_frame(case, 0, 1).unwrap();
    // 2^40 pixels cannot fit any device's buffer.
    let e = gpu.render_mosaic(std::slice::from_ref(&t.frame), 1 << 20, 1 << 20, &bpins_core::sensor::DEFAULT_MOSAIC);
    let msg = e.unwrap_err().to_string();
    assert!(msg.contains("buffer"), "{msg}");
}

fn the_gpu_is_a_library_backend_like_the_cpu() {
    use bpins_core::internal::backend::{Backend, Cpu};
    let gpu = gpu();
    let t = trial_frame(&cases()[0], 1, 3).unwrap();
    let frames = std::slice::from_ref(&t.frame);
    let backends: [&dyn Backend; 2] = [&Cpu, gpu];
    let [c, g] = backends.map(|b| b.render_mosaic(frames, 64, 48, &bpins_core::sensor::DEFAULT_MOSAIC).unwrap());
    assert_eq!((Backend::name(gpu), c[0].len(), g[0].len()), ("gpu", 64 * 48, 64 * 48));
    let off =
        c[0].iter().zip(&g[0]).filter(|(a, b)| (**a - **b).abs() > bpins_gpu::tolerance::DN_MAX_ABS as f32).count();
    assert_eq!(off, 0, "DN beyond tolerance through the trait");
    // A device error comes back in the core's words.
    let e = Backend::render_mosaic(gpu, frames, 1 << 20, 1 << 20, &bpins_core::sensor::DEFAULT_MOSAIC).unwrap_err();
    assert!(matches!(e, bpins_core::Error::Backend { .. }), "{e}");
}

fn sky_maps_agree_on_both_backends_for_every_effect() {
    use bpins_core::internal::backend::{Backend, Cpu};
    use bpins_gpu::tolerance::{aop_diff_deg, stages, AOP_MIN_DOLP};
    for gpu in gpus() {
        let st = stages(gpu.precision());
        let (aop_tol, dolp_tol) = (st[1].1, st[2].1);
        // The ideal chain and every effect together, at typical strength and at a range end.
        for (name, trial) in [("ideal", 2), ("all_effects", 1), ("all_effects", 3)] {
            let case = cases().into_iter().find(|c| c.name == name).unwrap();
            let t = trial_frame(&case, trial, 11).unwrap();
            let frames = std::slice::from_ref(&t.frame);
            let (w, h) = (153, 128);
            let backends: [&dyn Backend; 2] = [&Cpu, gpu];
            let [c, g] = backends.map(|b| b.sky_maps(frames, w, h).unwrap().remove(0));
            assert_eq!((g.width_px, g.height_px, g.aop_deg.len()), (w, h, w * h));
            let (mut aop, mut aoe, mut dolp) = (0f64, 0f64, 0f64);
            for p in 0..w * h {
                dolp = dolp.max((c.dolp[p] - g.dolp[p]).abs() as f64);
                if c.dolp[p] as f64 > AOP_MIN_DOLP {
                    aop = aop.max(aop_diff_deg(c.aop_deg[p] as f64, g.aop_deg[p] as f64).abs());
                    aoe = aoe.max(aop_diff_deg(c.aoe_deg[p] as f64, g.aoe_deg[p] as f64).abs());
                }
            }
            let p = gpu.precision().name();
            if needs::verbose() {
                eprintln!("{} ({p}): sky maps differ by AoP {aop:e} deg, AoE {aoe:e} deg, DoLP {dolp:e}", t.label);
            }
            assert!(aop <= aop_tol && aoe <= aop_tol && dolp <= dolp_tol, "{} ({p})", t.label);
        }
    }
}

/// wgpu's GL backend (Mesa llvmpipe through headless EGL here) with the f32 kernels:
/// the same stages within the f32 tolerances as on Vulkan. Skipped without a GL
/// adapter (counted as ignored), except with `CI` set (`.ci/run` installs libegl1, libgles2, libgl1-mesa-dri).
fn gl_backend_runs_the_f32_chain_within_its_tolerances() {
    let gl = Gpu::open(Some(Precision::F32), Some(bpins_gpu::wgpu::Backends::GL)).expect("main checked for GL");
    if needs::verbose() {
        eprintln!("GL adapter: {}", gl.adapter_name());
    }
    assert!(gl.adapter_name().contains("Gl"), "{}", gl.adapter_name());
    assert_case_agrees(&gl, "ideal", 2);
    assert_case_agrees(&gl, "all_effects", 2);
}
