//! Criterion benchmarks of the field estimator (`cargo bench -p bpins-core --bench
//! field`): a raw 16-bit DoFP mosaic in memory → cells → robust heading with its 1σ,
//! as a robot's loop runs it. Figures and the machine go to BENCHMARKS.md.
//!
//! * `field/dofp_2048x2448_u16_to_heading`: a full IMX250MZR frame (8 mm pinhole at
//!   3.45 µm, tilted 4°/−3°, sun 40°/25°); target on the 2-core dev machine ≤ 25 ms.
//! * `field/dofp_512x612_u16_to_heading`: the samples' sensor; target ≤ 2 ms.
//! * `field/*_compass`: the same through the front door (`compass::Compass`).
//! * `field/*_compass_calibrated`: the front door with a lab calibration's per-pixel
//!   maps (issue 17: ≤ 30 % more than `_compass`).
//! * `field/*_cells` and `field/*_estimate`: the two stages of the first.
//! * `field/sun_and_moon_from_clock`: what a `Sun::UnixTime` reading adds to every
//!   frame of the live loop: the sun (NREL SPA), the moon (Meeus ch. 47) and both
//!   shares of the sky's light, as numbers (`sky::SunAndMoon::at_unix_time`: what the
//!   compass runs, no timestamp text).

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
use bpins_core::effects::Model;
use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
use bpins_core::internal::heading::field::{estimate, Cells, FieldContext, FieldOptions, RawImage};
use bpins_core::internal::heading::Extractor;
use bpins_core::internal::recon::Reconstructor;
use bpins_core::internal::simulate::render_mosaic;
use bpins_core::sensor::{Channel, Response, DEFAULT_MOSAIC};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

/// A rendered u16 mosaic of `w × h` pixels at `pitch_um`, and its field context.
fn setup(w: usize, h: usize, pitch_um: f64) -> (Vec<u16>, FieldContext) {
    let intr = Intrinsics::new(Projection::Pinhole, 8000.0 / pitch_um, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let scene =
        Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 4.0, tilt_y_deg: -3.0, dmax: 0.6 };
    let resp = Response::samples(3000.0);
    let f = ChainFrame::new(&Model::default(), &intr, &scene, &resp, NoiseIndex { seed: 1, trial: 0, frame: 0 });
    let dn: Vec<u16> = render_mosaic(&f, w, h, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
    let ctx = FieldContext {
        tilt_x_deg: 4.0,
        tilt_y_deg: -3.0,
        tilt_sigma_deg: 0.1,
        ..FieldContext::new(intr, scene.sun_az_deg, scene.sun_el_deg)
    };
    (dn, ctx)
}

fn heading(dn: &[u16], w: usize, h: usize, rec: &Reconstructor, ctx: &FieldContext) -> f64 {
    let cells =
        Cells::from_mosaic(&RawImage::packed(dn, w, h), &DEFAULT_MOSAIC, rec, 4095.0, Cells::default_cell_px(w, h));
    let r = estimate(&cells, ctx, &FieldOptions::default(), &[Extractor::SunVector]);
    r[0].heading_deg().expect("a clear sky has a heading")
}

fn field(c: &mut Criterion) {
    let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).expect("four channels");
    let mut g = c.benchmark_group("field");
    for (w, h, pitch, name) in [(2448, 2048, 3.45, "dofp_2048x2448"), (612, 512, 13.8, "dofp_512x612")] {
        let (dn, ctx) = setup(w, h, pitch);
        g.bench_function(format!("{name}_u16_to_heading"), |b| b.iter(|| black_box(heading(&dn, w, h, &rec, &ctx))));
        // The same through the front door (a Compass built once, the frame borrowed).
        let mut compass = Compass::new(CompassConfig::dofp(ctx.intr, w, h, 12, 64.0)).expect("a valid sensor");
        let sun = Sun::Angles { azimuth_deg: ctx.sun_az_deg, elevation_deg: ctx.sun_el_deg, sigma_deg: 0.0 };
        let att = Attitude { tilt_x_deg: ctx.tilt_x_deg, tilt_y_deg: ctx.tilt_y_deg, sigma_deg: ctx.tilt_sigma_deg };
        g.bench_function(format!("{name}_compass"), |b| {
            b.iter(|| black_box(compass.heading(RawImage::packed(&dn, w, h), sun, att).expect("a valid frame")))
        });
        // The same with a lab calibration's per-pixel maps, every map present (their
        // values those of the sensor the frame was rendered with, so the estimator
        // sees the same sky): each cell through its own analyzers (pixel_analyzers.rs).
        let mut maps = bpins_core::internal::pixel_analyzers::PixelMaps::nominal(w, h, DEFAULT_MOSAIC);
        maps.offset_dn = Some(vec![64.0; w * h]);
        maps.gain = Some(vec![1.0; w * h]);
        maps.eps = Some(vec![0.0; w * h]);
        maps.analyzer_deg = Some(
            (0..w * h)
                .map(|i| bpins_core::sensor::Layout::dofp_channel(&DEFAULT_MOSAIC, i % w, i / w).angle_deg() as f32)
                .collect(),
        );
        let cal =
            bpins_core::calibration::Calibration { pixels: Some(std::sync::Arc::new(maps)), ..Default::default() };
        let mut calibrated =
            Compass::new(CompassConfig { calibration: cal, ..CompassConfig::dofp(ctx.intr, w, h, 12, 64.0) })
                .expect("maps of the sensor's size");
        g.bench_function(format!("{name}_compass_calibrated"), |b| {
            b.iter(|| black_box(calibrated.heading(RawImage::packed(&dn, w, h), sun, att).expect("a valid frame")))
        });
        // The same frame read as a colour-polarization sensor's (IMX250MYR order): each
        // band's cells from its own pixels, a heading per band, the fused heading
        // (issue 45's target: within 1.5× the monochrome compass).
        let mut colour = Compass::new(CompassConfig {
            colour: Some(bpins_core::sensor::ColourTiles::imx250myr()),
            ..CompassConfig::dofp(ctx.intr, w, h, 12, 64.0)
        })
        .expect("a valid sensor");
        g.bench_function(format!("{name}_compass_colour"), |b| {
            b.iter(|| black_box(colour.heading(RawImage::packed(&dn, w, h), sun, att).expect("a valid frame")))
        });
        if w == 2448 {
            let cell = Cells::default_cell_px(w, h);
            let img = RawImage::packed(dn.as_slice(), w, h);
            g.bench_function(format!("{name}_cells"), |b| {
                b.iter(|| black_box(Cells::from_mosaic(&img, &DEFAULT_MOSAIC, &rec, 4095.0, cell)))
            });
            let cells = Cells::from_mosaic(&img, &DEFAULT_MOSAIC, &rec, 4095.0, cell);
            g.bench_function(format!("{name}_estimate"), |b| {
                b.iter(|| black_box(estimate(&cells, &ctx, &FieldOptions::default(), &[Extractor::SunVector])))
            });
        }
    }
    // The ephemeris a clock-driven reading runs per frame (a night at Qingdao, moon up).
    g.bench_function("sun_and_moon_from_clock", |b| {
        b.iter(|| {
            black_box(bpins_core::internal::sky::SunAndMoon::at_unix_time(black_box(1_782_009_000.0), 36.07, 120.38))
        })
    });
    g.finish();
}

criterion_group!(benches, field);
criterion_main!(benches);
