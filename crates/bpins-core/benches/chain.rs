//! Criterion benchmarks (`cargo bench -p bpins-core`): the full-frame chain and the
//! paper sweep. Figures and the machine they came from go to BENCHMARKS.md.
//!
//! * `frame/dofp_2048x2448_sky_to_heading`: one full IMX250MZR-size DoFP frame,
//!   sky → DN (read + shot noise, 12-bit rounding) → 2×2 superpixel Stokes →
//!   heading sums → both heading extractors, fused per tile row
//!   (`simulate::mosaic_heading_sums`: no mosaic or Stokes image is kept).
//!   Target on the 2-core dev machine: ≤ 60 ms.
//! * `frame/dofp_2048x2448_via_mosaic`: the same frame through the whole-image
//!   stages (`render_mosaic` → `superpixels` → `HeadingSums::from_image`); the same
//!   sums, bitwise.
//! * `frame/stage_*`: the unfused frame split into its stages.
//! * `sweep/trial_*`: one seed-paper trial (1224 × 1024 colocated) per source.
//! * `sweep/paper_800_trials`: `bpins run` with the paper's 20 trials per azimuth.
//!   Target ≤ 30 s. Ten samples of it take several minutes.

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::effects::Model;
use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
use bpins_core::internal::heading::{Extractor, HeadingContext, HeadingSums};
use bpins_core::internal::montecarlo::{run_sweep, run_trial, Source, SweepConfig};
use bpins_core::internal::recon::{superpixels, superpixels_centred, Reconstructor};
use bpins_core::internal::simulate::{mosaic_heading_sums, render_colocated, render_mosaic, sky_maps};
use bpins_core::sensor::{Channel, Response, DEFAULT_MOSAIC};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

const W: usize = 2448;
const H: usize = 2048;

fn frame_setup() -> (ChainFrame, Reconstructor, HeadingContext) {
    // IMX250MZR: 3.45 µm pixels behind an 8 mm lens.
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
    let f = ChainFrame::new(&Model::default(), &intr, &scene, &resp, NoiseIndex { seed: 1, trial: 0, frame: 0 });
    let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).expect("four channels");
    let ctx = HeadingContext::new(intr, W, H, scene.sun_az_deg, scene.sun_el_deg);
    (f, rec, ctx)
}

fn frame(c: &mut Criterion) {
    let (f, rec, ctx) = frame_setup();
    let mut g = c.benchmark_group("frame");
    g.sample_size(20).measurement_time(Duration::from_secs(8));
    g.bench_function("dofp_2048x2448_sky_to_heading", |b| {
        b.iter(|| {
            let sums = mosaic_heading_sums(&f, W, H, &DEFAULT_MOSAIC, &rec, 4095.0, &ctx);
            black_box(Extractor::ALL.map(|e| sums.solve(e, &ctx).expect("heading")))
        })
    });
    g.bench_function("dofp_2048x2448_via_mosaic", |b| {
        b.iter(|| {
            let dn = render_mosaic(&f, W, H, &DEFAULT_MOSAIC);
            let img = superpixels(&dn, W, H, &DEFAULT_MOSAIC, &rec, 4095.0);
            let sums = HeadingSums::from_image(&img, &ctx);
            black_box(Extractor::ALL.map(|e| sums.solve(e, &ctx).expect("heading")))
        })
    });
    let dn = render_mosaic(&f, W, H, &DEFAULT_MOSAIC);
    let img = superpixels(&dn, W, H, &DEFAULT_MOSAIC, &rec, 4095.0);
    g.bench_function("stage_sky_to_dn", |b| b.iter(|| black_box(render_mosaic(&f, W, H, &DEFAULT_MOSAIC))));
    g.bench_function("stage_dn_to_stokes", |b| {
        b.iter(|| black_box(superpixels(&dn, W, H, &DEFAULT_MOSAIC, &rec, 4095.0)))
    });
    // The plain heading route's superpixels: each channel moved to the tile centre.
    g.bench_function("stage_dn_to_stokes_centred", |b| {
        b.iter(|| black_box(superpixels_centred(&dn, W, H, &DEFAULT_MOSAIC, &rec, 4095.0)))
    });
    g.bench_function("stage_stokes_to_heading", |b| b.iter(|| black_box(HeadingSums::from_image(&img, &ctx))));
    g.finish();
}

/// The sky's AoP/DoLP/AoE maps of a full frame (`simulate::sky_maps`, no DN) against
/// the chain that renders the same frame's four colocated channels (issue: the map
/// route within 1.2× of the chain).
fn maps(c: &mut Criterion) {
    let (f, _, _) = frame_setup();
    let mut g = c.benchmark_group("maps");
    g.sample_size(20).measurement_time(Duration::from_secs(8));
    g.bench_function("chain_colocated_2048x2448", |b| b.iter(|| black_box(render_colocated(&f, W, H, &Channel::ALL))));
    g.bench_function("sky_maps_2048x2448", |b| b.iter(|| black_box(sky_maps(&f, W, H))));
    g.finish();
}

fn sweep(c: &mut Criterion) {
    let cfg = SweepConfig::default();
    let mut g = c.benchmark_group("sweep");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for s in Source::ALL {
        g.bench_function(format!("trial_{}", s.name()), |b| {
            b.iter(|| black_box(run_trial(&cfg, s, 7).expect("trial")))
        });
    }
    g.warm_up_time(Duration::from_millis(1)).measurement_time(Duration::from_secs(30));
    g.bench_function("paper_800_trials", |b| {
        b.iter(|| black_box(run_sweep(&cfg, &Source::ALL, &|_, _| {}).expect("sweep")))
    });
    g.finish();
}

criterion_group!(benches, frame, maps, sweep);
criterion_main!(benches);
