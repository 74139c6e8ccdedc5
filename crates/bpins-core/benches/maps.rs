//! Criterion benchmarks of the polarization maps (`cargo bench -p bpins-core --bench
//! maps`): a raw 16-bit DoFP mosaic in memory → AoP, DoLP, intensity (and AoE) in
//! buffers the caller keeps, as a loop over recorded frames runs it. Figures and the
//! machine go to BENCHMARKS.md (issue 36: ≤ 40 ms for a full frame on 2 cores, 4× the
//! memory-traffic limit of reading 10 MB and writing three float32 maps).
//!
//! * `maps/2448x2048_{bilinear,superpixel,opencv,opencv_ea}`: `maps::stokes_maps_into`,
//!   no AoE (opencv_ea: polanalyser's edge-aware demosaic, on a mono mosaic opencv's kernel);
//! * `maps/2448x2048_bilinear_aoe`: with the AoE map too;
//! * `maps/2448x2048_demosaic_angle_maps`: the route the maps replaced
//!   (`recon::demosaic` to f64 Stokes, then `recon::angle_maps`), for comparison;
//! * `maps/2448x2048_copy`: reading the mosaic and writing three float32 maps, the
//!   memory-traffic floor on this machine;
//! * `maps/2448x2048_colour_{bilinear,superpixel,opencv,opencv_ea}`: `colour_maps_into` of the
//!   same mosaic read as an IMX250MYR colour mosaic, the three bands' maps, no AoE
//!   (issue 45: target ≤ 1.5× the mono route of the same name).
//! * `pixel_maps/2448x2048_nominal_mosaic`: `PixelMaps::nominal_mosaic`, a raw frame
//!   read through a flawed die's four per-pixel maps into the nominal mosaic the
//!   capture readers take (`pipeline::apply_pixel_maps`). A colour-polarization frame
//!   takes the same route (each 2 × 2 tile lies under one filter), so it has no bench
//!   of its own.

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::effects::Model;
use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
use bpins_core::internal::heading::field::RawImage;
use bpins_core::internal::maps::{stokes_maps_into, Interpolation, MapsConfig, MapsOut};
use bpins_core::internal::recon::{angle_maps, demosaic, Reconstructor};
use bpins_core::internal::simulate::render_mosaic;
use bpins_core::sensor::{Channel, ColourTiles, Layout, Response, DEFAULT_MOSAIC};
use bpins_core::{colour_maps_into, colour_maps_size, ColourScratch, PixelMaps};
use criterion::{criterion_group, criterion_main, Criterion};
use rayon::prelude::*;
use std::hint::black_box;

const W: usize = 2448;
const H: usize = 2048;

fn mosaic() -> Vec<u16> {
    let intr = Intrinsics::new(Projection::Pinhole, 8000.0 / 3.45, (W as f64 - 1.0) / 2.0, (H as f64 - 1.0) / 2.0);
    let scene =
        Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 4.0, tilt_y_deg: -3.0, dmax: 0.6 };
    let f = ChainFrame::new(
        &Model::default(),
        &intr,
        &scene,
        &Response::samples(3000.0),
        NoiseIndex { seed: 1, trial: 0, frame: 0 },
    );
    render_mosaic(&f, W, H, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect()
}

fn maps(c: &mut Criterion) {
    let dn = mosaic();
    let raw = RawImage::packed(&dn, W, H);
    let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap();
    let (mut aop, mut dolp, mut int, mut aoe) =
        (vec![0f32; W * H], vec![0f32; W * H], vec![0f32; W * H], vec![0f32; W * H]);
    let mut g = c.benchmark_group("maps");
    g.sample_size(20);
    for interp in Interpolation::ALL {
        let cfg = MapsConfig {
            interpolation: interp,
            mosaic: DEFAULT_MOSAIC,
            full_scale_dn: 4095.0,
            aoe_centre_px: [(W as f64 - 1.0) / 2.0, (H as f64 - 1.0) / 2.0],
        };
        let n = {
            let (mw, mh) = interp.maps_size(W, H);
            mw * mh
        };
        g.bench_function(format!("2448x2048_{}", interp.name()), |b| {
            b.iter(|| {
                let out = MapsOut {
                    aop_deg: &mut aop[..n],
                    dolp: &mut dolp[..n],
                    intensity_dn: &mut int[..n],
                    aoe_deg: None,
                };
                stokes_maps_into(black_box(&raw), &rec, &cfg, out).unwrap();
            })
        });
        if interp == Interpolation::Bilinear {
            g.bench_function("2448x2048_bilinear_aoe", |b| {
                b.iter(|| {
                    let out =
                        MapsOut { aop_deg: &mut aop, dolp: &mut dolp, intensity_dn: &mut int, aoe_deg: Some(&mut aoe) };
                    stokes_maps_into(black_box(&raw), &rec, &cfg, out).unwrap();
                })
            });
        }
    }
    let centre = Intrinsics::new(Projection::Pinhole, 1.0, 0.0, 0.0);
    g.bench_function("2448x2048_demosaic_angle_maps", |b| {
        b.iter(|| {
            let f: Vec<f32> = dn.iter().map(|&x| x as f32).collect();
            let img = demosaic(&f, W, H, &DEFAULT_MOSAIC, &rec, f64::MAX);
            black_box(angle_maps(&img, &centre))
        })
    });
    g.bench_function("2448x2048_copy", |b| {
        b.iter(|| {
            aop.par_chunks_mut(W).zip(dolp.par_chunks_mut(W)).zip(int.par_chunks_mut(W)).enumerate().for_each(
                |(v, ((a, d), i))| {
                    for (u, &x) in dn[v * W..][..W].iter().enumerate() {
                        let x = x as f32;
                        a[u] = x;
                        d[u] = x;
                        i[u] = x;
                    }
                },
            );
            black_box(&aop);
        })
    });
    let tiles = ColourTiles::imx250myr();
    let mut scratch = ColourScratch::default();
    let mut bufs: Vec<[Vec<f32>; 3]> = tiles.bands().iter().map(|_| [(); 3].map(|_| vec![0f32; W * H])).collect();
    for interp in Interpolation::ALL {
        let cfg = MapsConfig {
            interpolation: interp,
            mosaic: DEFAULT_MOSAIC,
            full_scale_dn: 4095.0,
            aoe_centre_px: [(W as f64 - 1.0) / 2.0, (H as f64 - 1.0) / 2.0],
        };
        let n = {
            let (mw, mh) = colour_maps_size(interp, W, H);
            mw * mh
        };
        g.bench_function(format!("2448x2048_colour_{}", interp.name()), |b| {
            b.iter(|| {
                let mut outs: Vec<_> = tiles
                    .bands()
                    .into_iter()
                    .zip(bufs.iter_mut())
                    .map(|(band, [a, d, i])| {
                        let o = MapsOut {
                            aop_deg: &mut a[..n],
                            dolp: &mut d[..n],
                            intensity_dn: &mut i[..n],
                            aoe_deg: None,
                        };
                        (band, o)
                    })
                    .collect();
                colour_maps_into(black_box(&raw), &rec, &cfg, &tiles, &mut scratch, &mut outs).unwrap();
            })
        });
    }
    g.finish();
}

/// A seeded flawed die of the full sensor (analyzers ±1.5°, ε 0–0.04, gain ±10 %,
/// offsets 64 ± 5 DN, as `pixel_analyzers`' tests) and a frame it reads of a smooth
/// sky (I, Q, U in DN, changing across the frame): the conversion's cost does not
/// depend on the values, only on every map being present.
fn flawed_die_frame() -> (PixelMaps, Vec<f32>) {
    let r = |i: usize, salt: u64| {
        let x =
            (i as u64 ^ salt).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let n = W * H;
    let angle = |i: usize| Layout::dofp_channel(&DEFAULT_MOSAIC, i % W, i / W).angle_deg();
    let maps = PixelMaps {
        width_px: W,
        height_px: H,
        mosaic: DEFAULT_MOSAIC,
        offset_dn: Some((0..n).map(|i| (64.0 + 5.0 * r(i, 1)) as f32).collect()),
        gain: Some((0..n).map(|i| (1.0 + 0.1 * r(i, 2)) as f32).collect()),
        analyzer_deg: Some((0..n).map(|i| (angle(i) + 1.5 * r(i, 3)) as f32).collect()),
        eps: Some((0..n).map(|i| (0.02 + 0.02 * r(i, 4)) as f32).collect()),
    };
    maps.check().expect("valid maps");
    let dn = (0..n)
        .map(|i| {
            let (u, v) = ((i % W) as f64 / W as f64, (i / W) as f64 / H as f64);
            let s = [1500.0 + 400.0 * u - 300.0 * v, 600.0 * (3.0 * u).cos(), 500.0 * (2.0 * v + u).sin()];
            let (a, o) = maps.pixel(i % W, i / W, 64.0);
            (o + a[0] * s[0] + a[1] * s[1] + a[2] * s[2]) as f32
        })
        .collect();
    (maps, dn)
}

fn pixel_maps(c: &mut Criterion) {
    let (maps, dn) = flawed_die_frame();
    let mut g = c.benchmark_group("pixel_maps");
    g.sample_size(20);
    g.bench_function("2448x2048_nominal_mosaic", |b| {
        b.iter(|| black_box(maps.nominal_mosaic(black_box(&dn), 64.0, 4095.0)))
    });
    g.finish();
}

criterion_group!(benches, pixel_maps, maps);
criterion_main!(benches);
