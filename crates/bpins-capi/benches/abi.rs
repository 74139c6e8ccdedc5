//! What the C ABI costs per frame over the Rust front door: one 2448 × 2048 u16 DoFP
//! frame (an IMX250MZR's full resolution, 12 bit, behind a 4 mm lens), and a 256 × 256
//! one, read by a warm `Compass` directly and by another through
//! `bpins_compass_heading_u16`.
//!
//! ```sh
//! cargo bench -p bpins-capi --bench abi
//! ```

use bpins::{
    bpins_compass_config_default, bpins_compass_free, bpins_compass_heading_u16, bpins_compass_new, BpinsAttitude,
    BpinsCompass, BpinsCompassConfig, BpinsHeading, BpinsStatus, BpinsSun, BPINS_SUN_ANGLES,
};
use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{Attitude, Compass, CompassConfig, RawImage, Sun};
use bpins_core::render::{Renderer, RendererConfig, View};
use bpins_core::sensor::Response;
use bpins_core::NoiseIndex;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::mem::MaybeUninit;

fn abi(c: &mut Criterion) {
    // The full frame, and a small one where the compass's own work is short enough
    // that a fixed cost of the boundary would show.
    one_size(c, 2448, 2048, 4000.0 / 3.45);
    one_size(c, 256, 256, 4000.0 / 27.6);
}

fn one_size(c: &mut Criterion, w: usize, h: usize, f_px: f64) {
    #[allow(non_snake_case)]
    let (W, H) = (w, h);
    let lens = Intrinsics::new(Projection::Pinhole, f_px, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let renderer = Renderer::new(RendererConfig::dofp(lens, W, H, Response::samples(2400.0))).unwrap();
    let view =
        View { sun_azimuth_deg: 40.0, sun_elevation_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 2.0, tilt_y_deg: -1.0 };
    let mut raw = Vec::new();
    renderer.raw_frame(&view, NoiseIndex { seed: 3, trial: 0, frame: 0 }).unwrap().to_u16_into(&mut raw);
    let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
    let att = Attitude { tilt_x_deg: 2.0, tilt_y_deg: -1.0, sigma_deg: 0.1 };

    let mut rust = Compass::new(CompassConfig::dofp(lens, W, H, 12, 64.0)).unwrap();

    let mut cfg = MaybeUninit::<BpinsCompassConfig>::uninit();
    let mut cfg = unsafe {
        assert_eq!(bpins_compass_config_default(cfg.as_mut_ptr()), BpinsStatus::BPINS_OK);
        cfg.assume_init()
    };
    (cfg.width_px, cfg.height_px, cfg.bit_depth, cfg.black_level_dn) = (W as u32, H as u32, 12, 64.0);
    (cfg.focal_length_px, cfg.cx_px, cfg.cy_px) = (lens.f_px, lens.cx_px, lens.cy_px);
    let mut handle: *mut BpinsCompass = std::ptr::null_mut();
    assert_eq!(unsafe { bpins_compass_new(&cfg, &mut handle) }, BpinsStatus::BPINS_OK);
    let c_sun = BpinsSun {
        kind: BPINS_SUN_ANGLES,
        azimuth_deg: 40.0,
        elevation_deg: 25.0,
        unix_time_s: 0.0,
        latitude_deg: 0.0,
        longitude_deg: 0.0,
        sigma_deg: 0.0,
    };
    let c_att = BpinsAttitude { tilt_x_deg: 2.0, tilt_y_deg: -1.0, sigma_deg: 0.1 };

    // The same heading both ways, bit for bit, before timing either.
    let want = rust.heading(RawImage::packed(&raw, W, H), sun, att).unwrap().heading_deg().unwrap();
    let mut out = MaybeUninit::<BpinsHeading>::uninit();
    let s = unsafe { bpins_compass_heading_u16(handle, raw.as_ptr(), W, H, W, &c_sun, &c_att, out.as_mut_ptr()) };
    assert_eq!(s, BpinsStatus::BPINS_OK);
    assert_eq!(unsafe { out.assume_init() }.heading_deg.to_bits(), want.to_bits());

    let mut g = c.benchmark_group(format!("front_door_{W}x{H}_u16"));
    g.sample_size(20);
    g.bench_function("rust_compass_heading", |b| {
        b.iter(|| black_box(rust.heading(RawImage::packed(black_box(&raw), W, H), sun, att).unwrap()))
    });
    g.bench_function("c_abi_bpins_compass_heading_u16", |b| {
        b.iter(|| {
            let s = unsafe {
                bpins_compass_heading_u16(handle, black_box(raw.as_ptr()), W, H, W, &c_sun, &c_att, out.as_mut_ptr())
            };
            assert_eq!(s, BpinsStatus::BPINS_OK);
            black_box(unsafe { out.assume_init_ref() }.heading_deg)
        })
    });
    g.finish();
    unsafe { bpins_compass_free(handle) };
}

criterion_group!(benches, abi);
criterion_main!(benches);
