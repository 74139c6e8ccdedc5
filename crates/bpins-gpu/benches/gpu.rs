//! Criterion benchmarks of the GPU twin (`cargo bench -p bpins-gpu --bench gpu`), on
//! whatever Vulkan adapter wgpu picks (its name is printed first; lavapipe is a CPU
//! rasterizer, so compare it with rayon honestly). Figures go to BENCHMARKS.md.
//!
//! * `gpu_frame/dofp_2048x2448_sky_to_heading_batch8`: eight full IMX250MZR-size DoFP
//!   frames in one dispatch — sky → DN (read + shot noise, 12-bit) → 2 × 2 superpixels
//!   → heading sums reduced on the device → both extractors on the host; the same
//!   frame as `bpins-core`'s `frame/dofp_2048x2448_sky_to_heading`. Throughput is
//!   per frame. Target on an H100: ≤ 1 ms per frame.
//! * `gpu_frame/dofp_2048x2448_render_batch8`: the mosaics alone, read back.
//! * `gpu_frame/colour_2048x2448_band_sums_batch8`: the same frames as IMX250MYR colour
//!   mosaics (each band's frame, the bands' defaults), rendered and summed band by band
//!   on the device, only the sums read back (the colour sweep's route), beside
//!   `colour_2048x2448_render_batch8`: the colour mosaics alone, read back (what the
//!   colour sweep read back before its sums moved to the device).
//! * `gpu_sweep/trials_80`: the paper sweep at 2 trials per azimuth (80 trials of
//!   1224 × 1024 colocated, every source), as `bpins run --backend gpu` runs it.
//! * `gpu_sweep/paper_800_trials`: the whole sweep (set BPINS_BENCH_SWEEP=1: on
//!   lavapipe ten samples take a quarter of an hour). Target on an H100: ≤ 1 s.

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::effects::Model;
use bpins_core::sensor::{Channel, ColourTiles, Response, DEFAULT_MOSAIC};
use bpins_core::twin::Reconstructor;
use bpins_core::twin::{ChainFrame, ColourSumsJob, NoiseIndex, Scene};
use bpins_core::twin::{Extractor, HeadingContext};
use bpins_core::twin::{Source, SweepConfig};
use bpins_gpu::{Gpu, SampleLayout, SumsJob};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;

const W: usize = 2448;
const H: usize = 2048;
const BATCH: usize = 8;

/// The CPU bench's frame (bpins-core/benches/chain.rs), frame index `k` of a batch.
fn frame(k: u32) -> (ChainFrame, Reconstructor, HeadingContext) {
    let intr = Intrinsics {
        projection: Projection::Pinhole,
        f_px: 8000.0 / 3.45,
        cx_px: 1223.5,
        cy_px: 1023.5,
        distortion: [0.0; 2],
    };
    let scene =
        Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
    let resp = Response::samples(3000.0);
    let f = ChainFrame::new(&Model::default(), &intr, &scene, &resp, NoiseIndex { seed: 1, trial: 0, frame: k });
    let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).expect("four channels");
    let ctx = HeadingContext::new(intr, W, H, scene.sun_az_deg, scene.sun_el_deg);
    (f, rec, ctx)
}

fn open() -> Option<Gpu> {
    match Gpu::new() {
        Ok(g) => {
            eprintln!("adapter: {}", g.adapter_name());
            Some(g)
        }
        Err(e) => {
            eprintln!("SKIPPED: no usable Vulkan adapter: {e}");
            None
        }
    }
}

fn gpu_frame(c: &mut Criterion) {
    let Some(gpu) = open() else { return };
    let frames: Vec<_> = (0..BATCH as u32).map(frame).collect();
    let ctx = frames[0].2;
    let jobs: Vec<SumsJob> = frames
        .iter()
        .map(|(f, rec, ctx)| SumsJob { frame: f, rec, mask_full_scale_dn: 4095.0, contexts: vec![*ctx] })
        .collect();
    let chain: Vec<ChainFrame> = frames.iter().map(|f| f.0.clone()).collect();
    let mut g = c.benchmark_group("gpu_frame");
    g.sample_size(10).measurement_time(Duration::from_secs(10)).throughput(Throughput::Elements(BATCH as u64));
    g.bench_function("dofp_2048x2448_sky_to_heading_batch8", |b| {
        b.iter(|| {
            let sums = gpu.heading_sums(&jobs, W, H, SampleLayout::Superpixels { mosaic: DEFAULT_MOSAIC }).unwrap();
            black_box(sums.iter().map(|s| Extractor::ALL.map(|e| s[0].solve(e, &ctx).unwrap())).collect::<Vec<_>>())
        })
    });
    g.bench_function("dofp_2048x2448_render_batch8", |b| {
        b.iter(|| black_box(gpu.render_mosaic(&chain, W, H, &DEFAULT_MOSAIC).unwrap()))
    });
    // The same frames on a colour sensor: each band's frame of the default model.
    let tiles = ColourTiles::imx250myr();
    let scene =
        Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
    let bands: Vec<[ChainFrame; 3]> = frames.iter().map(|f| f.0.bands(&Model::default(), &scene)).collect();
    let contexts = [ctx];
    let colour_jobs: Vec<ColourSumsJob> =
        bands.iter().zip(&frames).map(|(b, f)| ColourSumsJob { frames: b, rec: &f.1, contexts: &contexts }).collect();
    g.bench_function("colour_2048x2448_band_sums_batch8", |b| {
        b.iter(|| black_box(gpu.colour_heading_sums(&colour_jobs, W, H, &DEFAULT_MOSAIC, &tiles, 4095.0).unwrap()))
    });
    g.bench_function("colour_2048x2448_render_batch8", |b| {
        b.iter(|| black_box(gpu.render_colour_mosaic(&bands, W, H, &DEFAULT_MOSAIC, &tiles).unwrap()))
    });
    g.finish();
}

fn gpu_sweep(c: &mut Criterion) {
    let Some(gpu) = open() else { return };
    let mut g = c.benchmark_group("gpu_sweep");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    let cfg = SweepConfig { trials_per_azimuth: 2, ..SweepConfig::default() };
    g.throughput(Throughput::Elements((cfg.trials_per_source() * Source::ALL.len()) as u64));
    g.bench_function("trials_80", |b| {
        b.iter(|| black_box(bpins_gpu::montecarlo::run_sweep(&gpu, &cfg, &Source::ALL, &|_, _| {}).unwrap()))
    });
    if std::env::var_os("BPINS_BENCH_SWEEP").is_some() {
        let cfg = SweepConfig::default();
        g.throughput(Throughput::Elements((cfg.trials_per_source() * Source::ALL.len()) as u64));
        g.bench_function("paper_800_trials", |b| {
            b.iter(|| black_box(bpins_gpu::montecarlo::run_sweep(&gpu, &cfg, &Source::ALL, &|_, _| {}).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, gpu_frame, gpu_sweep);
criterion_main!(benches);
