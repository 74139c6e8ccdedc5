//! `bpins bench`: how fast bpins runs here, on whatever adapter it finds or on the CPU.
//! Prints and writes (`--json`) the adapter (name, driver, backend) and the kernels'
//! precision; the time of one 2448 × 2048 DoFP frame from sky to heading (median of
//! `--repeats`, after a warm-up); batched frames per second; the paper sweep's time
//! (Table 3, 1 280 trials); the bytes uploaded and downloaded per frame (parameters up,
//! sums down: the frames stay on the device); and, where the adapter has timestamp
//! queries, each kernel's device time per frame.

use crate::progress::bar;
use crate::write_json;
use crate::Backend;
use anyhow::Context;
use bpins_core::tool::sweep::{run_units, unit_count};
use bpins_core::{SumsEngine, SweepSpec};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The benchmark frame: the design example's 2448 × 2048 DoFP sensor behind a 4 mm
/// fisheye, 12-bit with noise, one error source drawn per frame.
const FRAME_SWEEP: &str = r#"
format = "bpins-sweep/1"
title = "bpins bench: 2448 × 2048 DoFP frames"
seed = 7
trials = 1
extractors = ["sun_vector"]
sources = ["principal_point"]

[sensor]
layout = "dofp"
width_px = 2448
height_px = 2048
pixel_pitch_um = 3.45
bit_depth = 12
black_level_dn = 64.0

[lens]
projection = "equidistant"
focal_length_mm = 4.0

[sky]
sun_elevations_deg = [35]
sun_azimuths_deg = [40]
trials_per_azimuth = 1
dmax = 0.6

[response]
peak_dn = 3000.0
quantize = true

[[errors]]
source = "principal_point"
param = "principal_point.dx_px"
distribution = "normal"
sigma = 0.5
"#;

#[derive(clap::Args)]
pub struct Args {
    /// Compute backend (the GPU's precision: the global --gpu-precision).
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// Timed single frames (their median is reported), after one warm-up frame.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeats: u32,
    /// Frames of the batched run.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Leave out the paper sweep (1 280 trials of 1224 × 1024 px).
    #[arg(long)]
    no_sweep: bool,
    /// Write the figures as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// `n` frames of the benchmark sensor, each its own trial.
fn frames_spec(n: u32) -> anyhow::Result<SweepSpec> {
    let mut spec = SweepSpec::parse(Path::new("bpins bench"), FRAME_SWEEP).context("the benchmark frame")?;
    spec.trials = n as usize;
    Ok(spec)
}

/// Wall time of `units` of `spec` on `engine`, seconds.
fn time_units(spec: &SweepSpec, units: std::ops::Range<usize>, engine: &dyn SumsEngine) -> anyhow::Result<f64> {
    let t0 = Instant::now();
    run_units(spec, units, engine, &|_, _| {}).context("running the benchmark frames")?;
    Ok(t0.elapsed().as_secs_f64())
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let device = match a.backend {
        Backend::Gpu => Some(crate::backend::open_gpu()?),
        Backend::Cpu => None,
    };
    let gpu = device.as_ref();
    let engine: &dyn SumsEngine = match gpu {
        Some(g) => g,
        None => &bpins_core::CpuSums,
    };
    let (adapter, precision) = match gpu {
        Some(g) => (g.adapter_name(), g.precision().name()),
        None => (format!("CPU: rayon on {} threads", rayon::current_num_threads()), "f64"),
    };
    out!("adapter            {adapter}");
    out!("precision          {precision}");
    // One frame, sky to heading: a warm-up, then the median of the repeats.
    let one = frames_spec(a.repeats + 1)?;
    time_units(&one, 0..1, engine)?;
    // Count from here: the timed frames only.
    let _ = gpu.map(|g| (g.take_traffic(), g.take_kernel_times()));
    let pb = bar(a.repeats as u64, "single frames");
    let mut times_ms = Vec::new();
    for k in 1..=a.repeats as usize {
        times_ms.push(1e3 * time_units(&one, k..k + 1, engine)?);
        pb.inc(1);
    }
    pb.finish_and_clear();
    times_ms.sort_by(f64::total_cmp);
    let frame_ms = times_ms[times_ms.len() / 2];
    let n = a.repeats as u64;
    let traffic = gpu.map(|g| g.take_traffic());
    let kernels = gpu.and_then(|g| g.take_kernel_times());
    out!(
        "one frame          {frame_ms:.2} ms (2448 × 2048 DoFP, sky to heading; median of {}, {:.2}–{:.2} ms)",
        a.repeats,
        times_ms[0],
        times_ms[times_ms.len() - 1]
    );
    if let Some(t) = traffic {
        out!("per frame          {} B uploaded, {} B downloaded", t.uploaded_bytes / n, t.downloaded_bytes / n);
    }
    match &kernels {
        Some(ks) => {
            for k in ks {
                out!("kernel {:<11} {:.3} ms per frame ({} dispatches)", k.kernel, k.total_ms / n as f64, k.dispatches);
            }
        }
        None if gpu.is_some() => out!("kernel times       not available (the adapter has no timestamp queries)"),
        None => {}
    }
    // Batched frames.
    let batch = frames_spec(a.frames)?;
    let secs = time_units(&batch, 0..a.frames as usize, engine)?;
    let fps = a.frames as f64 / secs;
    out!("batched            {fps:.1} frames/s ({} frames in {secs:.2} s)", a.frames);
    // The paper sweep.
    let sweep_s = if a.no_sweep {
        None
    } else {
        let spec = crate::cmd_run::paper_spec(20, 2023)?;
        let total = unit_count(&spec);
        let pb = bar(total as u64, "paper sweep trials");
        let t0 = Instant::now();
        run_units(&spec, 0..total, engine, &|done, _| pb.set_position(done as u64)).context("the paper sweep")?;
        pb.finish_and_clear();
        let s = t0.elapsed().as_secs_f64();
        out!("paper sweep        {s:.2} s ({total} trials, 1224 × 1024 px colocated)");
        Some(s)
    };
    if let Some(path) = &a.json {
        crate::ensure_not_in_capture(path)?;
        let v = json!({
            "backend": a.backend.name(),
            "adapter": adapter,
            "precision": precision,
            "frame_px": [2448, 2048],
            "frame_ms_median": frame_ms,
            "frame_ms_all": times_ms,
            "batched_frames": a.frames,
            "batched_frames_per_s": fps,
            "paper_sweep_s": sweep_s,
            "uploaded_bytes_per_frame": traffic.map(|t| t.uploaded_bytes / n),
            "downloaded_bytes_per_frame": traffic.map(|t| t.downloaded_bytes / n),
            "kernel_ms_per_frame": kernels.map(|ks| ks.iter().map(|k| json!({
                "kernel": k.kernel, "ms_per_frame": k.total_ms / n as f64, "dispatches": k.dispatches
            })).collect::<Vec<_>>()),
        });
        write_json(path, &v)?;
        say!("wrote {}", path.display());
    }
    Ok(())
}
