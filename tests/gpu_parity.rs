//! Parity of the GPU twin with the CPU reference, on whatever Vulkan adapter exists
//! (lavapipe in CI). Without an adapter these tests are counted as ignored, with the
//! reason and the install command below the run's summary — except with `CI` set,
//! where a missing adapter fails them (the harness is `tests/needs/mod.rs`,
//! `harness = false`).

#[path = "needs/mod.rs"]
mod needs;

use bpins_core::internal::montecarlo::{self, Source, SweepConfig};
use bpins_gpu::agree::{cases, compare, tolerances, trial_frame, Case, TrialFrame};
use bpins_gpu::{Gpu, Precision, SampleLayout, SumsJob};
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
                (
                    "a_neutral_effect_left_out_of_a_dispatch_changes_no_output_bit",
                    a_neutral_effect_left_out_of_a_dispatch_changes_no_output_bit,
                ),
                ("a_colour_sensor_agrees_on_both_backends", a_colour_sensor_agrees_on_both_backends),
                ("each_bands_neutral_points_agree_on_both_backends", each_bands_neutral_points_agree_on_both_backends),
                (
                    "colour_band_sums_on_the_device_equal_the_hosts_of_the_same_mosaic",
                    colour_band_sums_on_the_device_equal_the_hosts_of_the_same_mosaic,
                ),
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

/// A colour-polarization sensor (IMX250MYR tiles): the band model's effects
/// (`sky_spectrum`, `band_response`) at typical strength beside a lens effect, each
/// pixel in its band, with noise; the GPU's DN within its tolerance of the CPU's. Then
/// crosstalk across bands (issue 45) on a small mosaic: each neighbour through its own
/// band's frame, as the CPU renders it, and not as a band-at-a-time render would.
fn a_colour_sensor_agrees_on_both_backends() {
    use bpins_core::camera::{Intrinsics, Projection};
    use bpins_core::effects::{find, EffectSet};
    use bpins_core::internal::backend::{Backend, Cpu};
    use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
    use bpins_core::sensor::{ColourTiles, Response, DEFAULT_MOSAIC};
    let (w, h) = (96, 64);
    let intr = Intrinsics::new(Projection::Pinhole, 120.0, 47.5, 31.5);
    let resp = Response {
        black_level_dn: 64.0,
        read_noise_dn: 1.0,
        system_gain_dn_per_e: 0.1,
        quantize: true,
        bit_depth: 12,
        ..Response::ideal(2500.0)
    };
    let tiles = ColourTiles::imx250myr();
    let band_set = || {
        let mut set = EffectSet::new();
        for name in ["sky_spectrum", "band_response"] {
            for p in find(name).unwrap().params {
                set.set(name, p.name, p.typical).unwrap();
            }
        }
        set.set("lens_diattenuation", "rho2", 0.2).unwrap();
        set
    };
    let frames = |set: &EffectSet| -> Vec<[ChainFrame; 3]> {
        let model = set.model();
        (0..2u32)
            .map(|i| {
                let sc = Scene {
                    sun_az_deg: 200.0,
                    sun_el_deg: 45.0,
                    heading_deg: 7.0 + 90.0 * i as f64,
                    tilt_x_deg: 0.0,
                    tilt_y_deg: 0.0,
                    dmax: 0.7,
                };
                ChainFrame::new(&model, &intr, &sc, &resp, NoiseIndex { seed: 9, trial: 0, frame: i })
                    .bands(&model, &sc)
            })
            .collect()
    };
    // Pixels more than 1 DN apart, and pixels apart at all.
    let apart = |a: &[f32], b: &[f32]| {
        let beyond = a.iter().zip(b).filter(|(x, y)| (**x - **y).abs() > bpins_gpu::tolerance::DN_MAX_ABS as f32);
        (beyond.count(), a.iter().zip(b).filter(|(x, y)| x != y).count())
    };
    let fr = frames(&band_set());
    let cpu = Cpu.render_colour_mosaic(&fr, w, h, &DEFAULT_MOSAIC, &tiles).unwrap();
    // Crosstalk: c = 0.02 on a 32 × 24 mosaic (five rays per pixel on lavapipe).
    let (xw, xh) = (32, 24);
    let mut set = band_set();
    set.set("crosstalk", "c", 0.02).unwrap();
    let fx = frames(&set);
    let cpu_xt = Cpu.render_colour_mosaic(&fx, xw, xh, &DEFAULT_MOSAIC, &tiles).unwrap();
    // The check can fail: each pixel from its band's own crosstalk mosaic (neighbours
    // through the pixel's band, not theirs) is several DN off on most pixels.
    let per_band: Vec<Vec<f32>> =
        fx[0].iter().map(|f| bpins_core::twin::render_mosaic(f, xw, xh, &DEFAULT_MOSAIC)).collect();
    let one_band: Vec<f32> = (0..xw * xh).map(|k| per_band[tiles.band_at(k % xw, k / xw).index()][k]).collect();
    let (wrong, _) = apart(&cpu_xt[0], &one_band);
    if needs::verbose() {
        eprintln!("colour crosstalk: a band-at-a-time render is over 1 DN off on {wrong} of {} pixels", xw * xh);
    }
    assert!(wrong > xw * xh / 2, "only {wrong} pixels tell the bands' crosstalk from a band-at-a-time one");
    for gpu in gpus() {
        let g = Backend::render_colour_mosaic(gpu, &fr, w, h, &DEFAULT_MOSAIC, &tiles).unwrap();
        for (c, g) in cpu.iter().zip(&g) {
            assert_eq!(apart(c, g).0, 0, "{}: colour DN beyond tolerance", gpu.precision().name());
        }
        // The bands differ (red darker than green by its radiance and QE).
        assert!(g[0][0] < g[0][2], "a red pixel {} is darker than the green one beside it {}", g[0][0], g[0][2]);
        let g = Backend::render_colour_mosaic(gpu, &fx, xw, xh, &DEFAULT_MOSAIC, &tiles).unwrap();
        let stages = bpins_gpu::tolerance::stages(gpu.precision());
        let off_fraction = stages.iter().find(|s| s.0 == "dn_off_fraction").unwrap().1;
        for (c, g) in cpu_xt.iter().zip(&g) {
            let (beyond, off) = apart(c, g);
            if needs::verbose() {
                eprintln!("colour crosstalk ({}): {beyond} pixels beyond 1 DN, {off} off", gpu.precision().name());
            }
            assert_eq!(beyond, 0, "{}: colour DN under crosstalk beyond tolerance", gpu.precision().name());
            assert!(
                off as f64 <= (off_fraction * c.len() as f64).max(1.0),
                "{}: {off} of {} colour DN under crosstalk differ",
                gpu.precision().name(),
                c.len()
            );
        }
    }
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

/// A dispatch runs only the registry hooks some frame of it has on (pipeline masks,
/// `crates/bpins-gpu/src/masks.rs`): a frame's every output (DN, maps, heading sums)
/// is the same rendered alone (no hook run), beside a frame with one effect, and beside
/// a frame with every hook on (every hook run, at neutral for it).
///
/// The same means bit for bit with the f64 kernels, and on a CPU adapter (lavapipe) at
/// either precision. A vendor's compiler may contract `a * b + c` into one fused
/// multiply-add differently once other hooks are compiled in around it, so its f32
/// kernels may differ in the last bits: on an NVIDIA H200 (driver 580.159.04) the ideal
/// frame's DN mosaic, colocated planes and heading sums were bitwise the same, and its
/// chain and sky maps differed by up to 4 ulp (7.6e-6° of AoP, 1.2e-7 of DoLP,
/// 2.4e-4 DN of signal). There the bound is 1e-6 of each output's largest magnitude.
fn a_neutral_effect_left_out_of_a_dispatch_changes_no_output_bit() {
    let (w, h) = (96, 64);
    for gpu in gpus() {
        let frame =
            |name: &str, effects: Vec<&'static str>| trial_frame(&Case { name: name.into(), effects }, 1, 5).unwrap();
        let ideal = frame("ideal", vec![]);
        let lens = frame("lens_diattenuation", vec!["lens_diattenuation"]);
        let hooks: Vec<&str> =
            bpins_core::effects::REGISTRY.iter().filter(|e| e.wgsl.is_some()).map(|e| e.name).collect();
        let every = frame("every_hook", hooks);
        let [a, b, c] =
            [vec![&ideal], vec![&ideal, &lens], vec![&ideal, &lens, &every]].map(|d| outputs(gpu, &d, w, h));
        let p = gpu.precision().name();
        let bitwise = gpu.precision() == Precision::F64 || gpu.is_cpu();
        let of_scale = if bitwise { 0.0 } else { 1e-6 };
        assert!(!differences(&c[0], &c[1], 0.0).is_empty(), "({p}) the lens changes the frame's outputs");
        let cases = [("the ideal frame, alone", &a[0], &c[0]), ("the ideal frame, beside the lens", &b[0], &c[0])];
        for (what, x, y) in cases.into_iter().chain([("the lens frame", &b[1], &c[1])]) {
            let d = differences(x, y, of_scale);
            assert!(d.is_empty(), "({p}) {what}: the outputs depend on the dispatch's hooks:\n{}", d.join("\n"));
        }
    }
}

/// One frame's outputs, by name, each value widened to f64 (exactly).
type Outputs = Vec<(String, Vec<f64>)>;

/// The outputs where two frames differ by more than `of_scale` × the output's largest
/// magnitude (`0.0`: in any bit): how many values differ, and by how much at most.
fn differences(x: &Outputs, y: &Outputs, of_scale: f64) -> Vec<String> {
    x.iter()
        .zip(y)
        .filter_map(|((name, u), (_, v))| {
            let scale = u.iter().chain(v).map(|a| a.abs()).fold(0.0, f64::max);
            let apart: Vec<f64> =
                u.iter().zip(v).filter(|(a, b)| a.to_bits() != b.to_bits()).map(|(a, b)| (a - b).abs()).collect();
            let most = apart.iter().copied().fold(0.0, f64::max);
            (!apart.is_empty() && most >= of_scale * scale).then(|| {
                let n = (apart.len(), u.len());
                format!("  {name}: {} of {} values differ, by at most {most:e} (largest magnitude {scale:e})", n.0, n.1)
            })
        })
        .collect()
}

/// Every output of each frame of one dispatch of `frames` (`w × h`): the mosaic, the
/// colocated planes, the chain and sky maps, and the heading sums of both layouts.
fn outputs(gpu: &Gpu, frames: &[&TrialFrame], w: usize, h: usize) -> Vec<Outputs> {
    use bpins_core::sensor::{Channel, DEFAULT_MOSAIC};
    let chain: Vec<_> = frames.iter().map(|t| t.frame.clone()).collect();
    let wide = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>();
    let sums = |layout, both: bool| {
        let jobs: Vec<SumsJob> = frames
            .iter()
            .map(|t| SumsJob {
                frame: &t.frame,
                rec: &t.rec,
                mask_full_scale_dn: t.frame.response.full_scale_dn(),
                contexts: if both { t.contexts.clone() } else { vec![t.contexts[0]] },
            })
            .collect();
        gpu.heading_sums(&jobs, w, h, layout).unwrap()
    };
    let mosaic = gpu.render_mosaic(&chain, w, h, &DEFAULT_MOSAIC).unwrap();
    let planes = gpu.render_colocated(&chain, w, h, &Channel::ALL).unwrap();
    let maps = gpu.chain_maps(&chain, w, h).unwrap();
    let sky = gpu.sky_maps(&chain, w, h).unwrap();
    let superpixels = sums(SampleLayout::Superpixels { mosaic: DEFAULT_MOSAIC }, false);
    let colocated = sums(SampleLayout::Colocated, true);
    (0..frames.len())
        .map(|k| {
            let mut v: Outputs = vec![("mosaic DN".into(), wide(&mosaic[k]))];
            planes[k].iter().enumerate().for_each(|(i, p)| v.push((format!("colocated plane {i} DN"), wide(p))));
            let pixels = &maps[k];
            v.push(("chain maps' signal DN".into(), pixels.iter().flat_map(|m| wide(&m.signal_dn)).collect()));
            v.push(("chain maps' AoP°".into(), pixels.iter().map(|m| f64::from(m.aop_deg)).collect()));
            v.push(("chain maps' DoLP".into(), pixels.iter().map(|m| f64::from(m.dolp)).collect()));
            v.push(("chain maps' AoE°".into(), pixels.iter().map(|m| f64::from(m.aoe_deg)).collect()));
            v.push(("sky map AoP°".into(), wide(&sky[k].aop_deg)));
            v.push(("sky map DoLP".into(), wide(&sky[k].dolp)));
            v.push(("sky map AoE°".into(), wide(&sky[k].aoe_deg)));
            for (layout, s) in [("superpixel", &superpixels[k]), ("colocated", &colocated[k])] {
                for (j, s) in s.iter().enumerate() {
                    let values = s.scatter.iter().chain([&s.n]).chain(s.line.iter().flatten()).copied();
                    v.push((format!("{layout} heading sums {j}"), values.collect()));
                }
            }
            v
        })
        .collect()
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

/// A colour sensor under a Berry sky whose neutral points split wider in the blue and
/// narrower in the red (`sky_neutral_spectrum`): each band's frame carries its own
/// quartic sky, and the GPU renders each pixel through it as the CPU does (32 × 24,
/// noise-free DN, one frame).
fn each_bands_neutral_points_agree_on_both_backends() {
    use bpins_core::camera::{Intrinsics, Projection};
    use bpins_core::effects::EffectSet;
    use bpins_core::internal::backend::{Backend, Cpu};
    use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
    use bpins_core::sensor::{ColourTiles, Response, DEFAULT_MOSAIC};
    let (w, h) = (32, 24);
    let intr = Intrinsics::new(Projection::Pinhole, 20.0, 15.5, 11.5);
    let tiles = ColourTiles::imx250myr();
    let render = |spectrum: bool, backend: &dyn Backend| {
        let mut set = EffectSet::new();
        set.set("sky_neutral_points", "separation_deg", 30.0).unwrap();
        if spectrum {
            set.set("sky_neutral_spectrum", "separation_r", 0.6).unwrap();
            set.set("sky_neutral_spectrum", "separation_b", 1.6).unwrap();
        }
        let model = set.model();
        // The sun low in the view's edge: the Babinet and Brewster points in the field.
        let sc =
            Scene { sun_az_deg: 0.0, sun_el_deg: 50.0, heading_deg: 0.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.7 };
        let f =
            ChainFrame::new(&model, &intr, &sc, &Response::ideal(2000.0), NoiseIndex { seed: 3, trial: 0, frame: 0 });
        backend.render_colour_mosaic(&[f.bands(&model, &sc)], w, h, &DEFAULT_MOSAIC, &tiles).unwrap().remove(0)
    };
    let (cpu, cpu_one) = (render(true, &Cpu), render(false, &Cpu));
    let tol = bpins_gpu::tolerance::DN_MAX_ABS as f32;
    let beyond = |a: &[f32], b: &[f32]| a.iter().zip(b).filter(|(x, y)| (**x - **y).abs() > tol).count();
    // The check can fail: one separation for every band is more than 1 DN off on the
    // red and blue pixels near the neutral points.
    let moved = beyond(&cpu, &cpu_one);
    assert!(moved > 20, "only {moved} pixels tell each band's separation from green's");
    for gpu in gpus() {
        let g = render(true, gpu);
        assert_eq!(beyond(&cpu, &g), 0, "{}: band neutral points beyond tolerance", gpu.precision().name());
    }
}

/// A colour sensor's band sums reduced on the device (issue 45). Two noisy trials of a
/// 64 × 48 RGGB sensor (band model at typical strength, a lens ρ), their mosaics
/// rendered on the device and read back; each band's sums of those very mosaics, two
/// contexts (lens ρ unknown and known), summed on the host (the CPU's
/// `colour_mosaic_heading_sums`), on the device from the uploaded mosaics, and on the
/// device from mosaics rendered in place and never read back (the sweep's route: two
/// readings per trial sharing its mosaic, the second with one context). Counts equal;
/// every other sum within 1e-10 (f64 kernels: only the order of the additions differs)
/// or 1e-3 (f32) of the largest of its kind, and at f32 one band sample's worth (≤ 1)
/// more for the band sums (a sample on the other side of the band's edge); both
/// extractors' headings within the heading tolerance (at f32 as `bpins agree` bounds them).
fn colour_band_sums_on_the_device_equal_the_hosts_of_the_same_mosaic() {
    use bpins_core::camera::{Intrinsics, Projection};
    use bpins_core::effects::{find, EffectSet};
    use bpins_core::sensor::{Channel, ColourTiles, Response, DEFAULT_MOSAIC};
    use bpins_core::twin::{
        colour_mosaic_heading_sums, Backend, ChainFrame, ColourSumsJob, Extractor, HeadingContext, HeadingSums,
        NoiseIndex, Reconstructor, Scene,
    };
    let (w, h) = (64, 48);
    let intr = Intrinsics::new(Projection::Pinhole, 40.0, 31.5, 23.5);
    let resp = Response {
        black_level_dn: 64.0,
        read_noise_dn: 2.0,
        system_gain_dn_per_e: 0.1,
        quantize: true,
        bit_depth: 12,
        ..Response::ideal(3000.0)
    };
    let tiles = ColourTiles::imx250myr();
    let mut set = EffectSet::new();
    for name in ["sky_spectrum", "band_response"] {
        for p in find(name).unwrap().params {
            set.set(name, p.name, p.typical).unwrap();
        }
    }
    set.set("lens_diattenuation", "rho2", 0.05).unwrap();
    let model = set.model();
    let scenes: Vec<Scene> = (0..2)
        .map(|i| Scene {
            sun_az_deg: 200.0,
            sun_el_deg: 40.0 + 20.0 * i as f64,
            heading_deg: 30.0 + 100.0 * i as f64,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            dmax: 0.7,
        })
        .collect();
    let frames: Vec<[ChainFrame; 3]> = scenes
        .iter()
        .enumerate()
        .map(|(i, sc)| {
            ChainFrame::new(&model, &intr, sc, &resp, NoiseIndex { seed: 45, trial: i as u32, frame: 0 })
                .bands(&model, sc)
        })
        .collect();
    let rec = Reconstructor::new(&Default::default(), resp.black_level_dn, &Channel::ALL).unwrap();
    let ctx = |sc: &Scene, rho2: f64| HeadingContext {
        lens_rho2: rho2,
        ..HeadingContext::new(intr, w, h, sc.sun_az_deg - sc.heading_deg, sc.sun_el_deg)
    };
    // Both trials are read under the first trial's contexts by the given-mosaic route.
    let contexts = [ctx(&scenes[0], 0.0), ctx(&scenes[0], 0.05)];
    let full_scale = resp.full_scale_dn();
    for gpu in gpus() {
        let name = gpu.precision().name();
        let f64_kernels = gpu.precision() == Precision::F64;
        let dn = Backend::render_colour_mosaic(gpu, &frames, w, h, &DEFAULT_MOSAIC, &tiles).unwrap();
        let given: Vec<&[f32]> = dn.iter().map(|d| d.as_slice()).collect();
        let device =
            gpu.colour_mosaic_heading_sums(&given, w, h, &DEFAULT_MOSAIC, &tiles, &rec, full_scale, &contexts).unwrap();
        let jobs: Vec<ColourSumsJob> = frames
            .iter()
            .flat_map(|f| {
                [
                    ColourSumsJob { frames: f, rec: &rec, contexts: &contexts },
                    ColourSumsJob { frames: f, rec: &rec, contexts: &contexts[..1] },
                ]
            })
            .collect();
        let in_place = gpu.colour_heading_sums(&jobs, w, h, &DEFAULT_MOSAIC, &tiles, full_scale).unwrap();
        assert_eq!((device.len(), in_place.len()), (2, 4), "{name}");
        // (sums, their values' largest magnitude per kind: scatter, band sums)
        let scale = |s: &HeadingSums| {
            let max = |v: &mut dyn Iterator<Item = f64>| v.fold(0.0, |m: f64, x| m.max(x.abs()));
            (max(&mut s.scatter.iter().copied()), max(&mut s.line.iter().flatten().copied()))
        };
        let close = |host: &HeadingSums, dev: &HeadingSums, what: &str| {
            assert_eq!(host.n, dev.n, "{name} {what}: sample counts");
            let (scatter, line) = scale(host);
            let rel = if f64_kernels { 1e-10 } else { 1e-3 };
            for (a, b) in host.scatter.iter().zip(&dev.scatter) {
                assert!((a - b).abs() <= rel * scatter, "{name} {what}: scatter {a} on the host, {b} on the device");
            }
            let slack = if f64_kernels { 0.0 } else { 1.0 };
            for (k, (a, b)) in host.line.iter().flatten().zip(dev.line.iter().flatten()).enumerate() {
                assert!(
                    (a - b).abs() <= rel * line + slack,
                    "{name} {what}: band sum {k} {a} on the host, {b} on the device"
                );
            }
        };
        for (k, d) in dn.iter().enumerate() {
            let host = colour_mosaic_heading_sums(d, w, h, &DEFAULT_MOSAIC, &tiles, &rec, full_scale, &contexts);
            assert_eq!(device[k].len(), 2, "{name}");
            for (c, (hc, dc)) in host.iter().zip(&device[k]).enumerate() {
                for b in 0..3 {
                    let what = format!("trial {k} context {c} band {b}");
                    close(&hc[b], &dc[b], &what);
                    // The mosaics summed in place (never read back) are the same mosaics.
                    close(&hc[b], &in_place[2 * k][c][b], &format!("{what}, rendered in place"));
                    if c == 0 {
                        close(&hc[b], &in_place[2 * k + 1][0][b], &format!("{what}, second reading"));
                    }
                    // The check can fail: each band reads its own quarter (R, B) or half (G).
                    let share = if b == 1 { 2.0 } else { 1.0 };
                    let n_px = (w / 2 * h / 2) as f64 / 4.0 * share;
                    assert!(hc[b].n > 0.9 * n_px && hc[b].n <= n_px, "{what}: {} of {n_px} superpixels", hc[b].n);
                    for e in Extractor::ALL {
                        let (x, y) = (hc[b].solve(e, &contexts[c]), dc[b].solve(e, &contexts[c]));
                        if let (Ok(x), Ok(y)) = (&x, &y) {
                            let diff = bpins_gpu::tolerance::heading_diff_deg(x.heading_deg, y.heading_deg).abs();
                            // At f32 as `bpins agree` bounds it: a tenth of a loosely determined estimate's 1σ.
                            use bpins_gpu::tolerance::f32 as f32_tol;
                            let tol = match gpu.precision() {
                                Precision::F64 => bpins_gpu::tolerance::HEADING_DEG,
                                Precision::F32 => f32_tol::HEADING_DEG.max(x.sigma_deg / f32_tol::HEADING_SIGMA_SHARE),
                            };
                            assert!(diff <= tol, "{name} {what} {e:?}: headings {diff}° apart");
                        } else {
                            assert_eq!(x.is_ok(), y.is_ok(), "{name} {what} {e:?}: one side solves, one not");
                        }
                    }
                }
            }
        }
    }
}
