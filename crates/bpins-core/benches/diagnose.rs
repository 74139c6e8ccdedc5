//! The diagnosis of a 612 × 512 capture outside the catalog (issue 46 item 5: back to
//! ≤ 30 s on 2 cores, idle; 341 s measured before): `cargo bench -p bpins-core --bench
//! diagnose`. Figures and the machine go to BENCHMARKS.md.
//!
//! * `diagnose/612x512_8frames_glare`: `diagnose` on every pixel of the samples' setup
//!   (samples/README.md: pinhole f = 8 mm, 13.8 µm pitch, Rayleigh sky, d_max 0.6, sun
//!   at azimuth 40°, elevation 25°, eight turntable frames) with an unpolarized off-axis
//!   veil of glare (900 DN at (0.8 W, 0.25 H), a Lorentzian of half width 1.5 W, its shot
//!   noise added: `tests/glare_and_ghost.rs`'s, at the samples' size). It ends
//!   unexplained after adding sky_dolp_shape, then channel_response and principal_point
//!   together, with `channel_response`'s offsets flagged unphysical (−990 to −1000 DN).
//!
//! Before measuring, one run prints its verdict, each step's iterations and effect
//! parameters (value ± 1σ), the top of each step's ranking and where it spent its time
//! (`Diagnosis::timings`) to stderr (what a speed-up must leave as it was);
//! `BPINS_BENCH_CAPTURE=DIR` runs that probe on a capture on disk instead
//! (`cargo bench … -- nomatch` to skip the measurement).

#[path = "../tests/common/mod.rs"]
mod common;

use bpins_core::effects::EffectSet;
use bpins_core::internal::capture::{Capture, FrameData};
use bpins_core::internal::diagnose::{diagnose, DiagnoseOptions};
use bpins_core::internal::noise::{stream, FrameKey};
use bpins_core::sensor::Geometry;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

/// The small capture of the tests at the samples' 612 × 512 px of 13.8 µm.
fn samples_size_capture() -> Capture {
    let mut c = common::small_capture();
    let (w, h) = (612u32, 512u32);
    c.sensor.geometry = Geometry { width_px: w, height_px: h, pixel_pitch_um: 13.8 };
    c.lens.principal_point_px = bpins_core::conventions::image_centre_px(w, h);
    c
}

/// `frames` with an unpolarized veil of glare (module doc) and its shot noise added,
/// rounded and clipped to the ADC's range (`tests/glare_and_ghost.rs`'s `glare`).
fn with_glare(c: &Capture, frames: &[FrameData], peak_dn: f64, half_w: f64) -> Vec<FrameData> {
    let full = c.sensor.full_scale_dn();
    let k_dn_per_e = common::sim_sensor(0, 0.0).system_gain_dn_per_e;
    let (w, h) = (c.sensor.geometry.width_px as f64, c.sensor.geometry.height_px as f64);
    let (x0, y0, half) = (0.8 * w, 0.25 * h, half_w * w);
    frames
        .iter()
        .enumerate()
        .map(|(i, f)| match f {
            FrameData::Mosaic { width_px, height_px, dn } => {
                let key = FrameKey::new(0x6c69_6768_74, 0, i as u32);
                let wi = *width_px as usize;
                let out = (0..dn.len())
                    .map(|p| {
                        let (u, v) = ((p % wi) as f64, (p / wi) as f64);
                        let x = peak_dn / (1.0 + ((u - x0).powi(2) + (v - y0).powi(2)) / (half * half));
                        let shot = (k_dn_per_e * x).sqrt() * key.normal(p as u32, 0, stream::TRIAL);
                        (dn[p] as f64 + x + shot).round().clamp(0.0, full) as f32
                    })
                    .collect();
                FrameData::Mosaic { width_px: *width_px, height_px: *height_px, dn: out }
            }
            FrameData::Colocated { .. } => unreachable!("a DoFP capture"),
        })
        .collect()
}

fn bench(cr: &mut Criterion) {
    // BPINS_BENCH_CAPTURE=DIR: a capture on disk instead (its probe run only, to see
    // where another capture's time goes).
    let (c, frames) = match std::env::var_os("BPINS_BENCH_CAPTURE") {
        Some(dir) => {
            let c = Capture::load(std::path::Path::new(&dir)).expect("a capture");
            let frames = (0..c.frames.len()).map(|i| c.read_frame(i).expect("a frame")).collect();
            (c, frames)
        }
        None => {
            let c = samples_size_capture();
            let clean = common::simulate(&c, &EffectSet::new(), 51);
            let frames = with_glare(&c, &clean, 900.0, 1.5);
            (c, frames)
        }
    };
    let opts = DiagnoseOptions::default();
    let t0 = std::time::Instant::now();
    let say = |what: &str| eprintln!("  {:7.2} s  {what}", t0.elapsed().as_secs_f64());
    let d = diagnose(&c, &frames, &opts, &say).expect("a diagnosis");
    for s in &d.steps {
        eprintln!("  step {:?}: {} iterations, χ²/dof {:.4}", s.model, s.fit.iterations, s.fit.chi2_per_dof);
        for p in &s.fit.params {
            eprintln!("    {} = {:.6} ± {:.6} {}", p.name, p.value, p.sigma, p.unit);
        }
    }
    for (i, r) in d.rankings.iter().enumerate() {
        let top: Vec<String> =
            r.iter().take(3).map(|c| format!("{} Δχ² {:.1} ({:?})", c.effect, c.delta_chi2, c.evidence)).collect();
        eprintln!("  ranking {i}: {}", top.join(", "));
    }
    eprintln!(
        "glare 612×512: unexplained {}, named {:?}, steps {:?}\n  {}",
        d.unexplained(),
        d.selected,
        d.steps.iter().map(|s| s.model.join("+")).collect::<Vec<_>>(),
        d.summary()
    );
    for (stage, s) in d.timings.stages() {
        eprintln!("  {stage:<20} {s:8.2} s");
    }
    eprintln!("  {:<20} {:8.2} s", "total", d.timings.total_s);
    let mut g = cr.benchmark_group("diagnose");
    g.sample_size(10);
    g.bench_function("612x512_8frames_glare", |b| {
        b.iter(|| black_box(diagnose(&c, &frames, &opts, &|_| {}).expect("a diagnosis")))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
