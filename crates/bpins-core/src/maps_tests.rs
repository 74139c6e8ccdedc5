//! The maps against the reconstruction they stand for, Malus's law, OpenCV's
//! integer demosaic worked by hand, and refusals.

use super::*;
use crate::camera::{Intrinsics, Projection};
use crate::chain::{ChainFrame, NoiseIndex, Scene};
use crate::effects::Model;
use crate::recon::{angle_maps, demosaic};
use crate::sensor::{Response, DEFAULT_MOSAIC};
use crate::simulate::render_mosaic;

const FS: f64 = 4095.0;

fn config(interpolation: Interpolation, w: usize, h: usize) -> MapsConfig {
    MapsConfig {
        interpolation,
        mosaic: DEFAULT_MOSAIC,
        full_scale_dn: FS,
        aoe_centre_px: [(w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0],
    }
}

/// A 12-bit sky frame with noise (seeded), as u16 DN.
fn sky(w: usize, h: usize) -> (Vec<u16>, Intrinsics) {
    let camera = Intrinsics::new(Projection::Pinhole, 300.0, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let scene =
        Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 3.0, tilt_y_deg: 0.0, dmax: 0.6 };
    let sensor = Response {
        gain_dn: 3000.0,
        black_level_dn: 64.0,
        read_noise_dn: 2.0,
        bit_depth: 12,
        quantize: true,
        ..Response::ideal(1.0)
    };
    let frame =
        ChainFrame::new(&Model::default(), &camera, &scene, &sensor, NoiseIndex { seed: 7, trial: 0, frame: 0 });
    let dn = render_mosaic(&frame, w, h, &DEFAULT_MOSAIC);
    (dn.iter().map(|&x| x as u16).collect(), camera)
}

fn rec() -> Reconstructor {
    Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap()
}

#[test]
fn bilinear_maps_are_the_reconstruction_that_heading_uses() {
    let (w, h) = (61, 47); // odd sizes: both edges of both lattices clamp
    let (dn, camera) = sky(w, h);
    let m = stokes_maps(&RawImage::packed(&dn, w, h), &rec(), &config(Interpolation::Bilinear, w, h)).unwrap();
    let f: Vec<f32> = dn.iter().map(|&x| x as f32).collect();
    let img = demosaic(&f, w, h, &DEFAULT_MOSAIC, &rec(), FS);
    let [aop, dolp, aoe] = angle_maps(&img, &camera);
    let mut compared = 0;
    for k in 0..w * h {
        if aop[k].is_nan() {
            continue;
        }
        compared += 1;
        assert!((m.aop_deg[k] - aop[k]).abs() < 2e-4, "pixel {k}: AoP {} vs {}", m.aop_deg[k], aop[k]);
        assert!((m.dolp[k] - dolp[k]).abs() < 1e-6, "pixel {k}: DoLP");
        let d_aoe = (m.aoe_deg[k] - aoe[k] + 90.0).rem_euclid(180.0) - 90.0;
        assert!(d_aoe.abs() < 2e-4, "pixel {k}: AoE {} vs {}", m.aoe_deg[k], aoe[k]);
        let i = img.iqu[k][0] as f32;
        assert!((m.intensity_dn[k] - i).abs() <= 1e-6 * i.abs().max(1.0), "pixel {k}: I");
    }
    assert!(compared > w * h * 9 / 10, "only {compared} pixels valid");
}

#[test]
fn malus_a_uniform_field_gives_its_angle_and_degree_everywhere() {
    // I_θ = ½ I (1 + d cos 2(θ − α)) above a black level, for each interpolation.
    let (w, h, alpha_deg, d, i0) = (16, 12, -33.0f64, 0.4, 2000.0);
    let mut dn = vec![0u16; w * h];
    for v in 0..h {
        for u in 0..w {
            let theta = DEFAULT_MOSAIC[v % 2][u % 2].angle_deg();
            let x = 64.0 + 0.5 * i0 * (1.0 + d * (2.0 * (theta - alpha_deg)).to_radians().cos());
            dn[v * w + u] = x.round() as u16;
        }
    }
    for interp in Interpolation::ALL {
        let m = stokes_maps(&RawImage::packed(&dn, w, h), &rec(), &config(interp, w, h)).unwrap();
        for k in 0..m.aop_deg.len() {
            assert!((m.aop_deg[k] as f64 - alpha_deg).abs() < 0.05, "{}: AoP {}", interp.name(), m.aop_deg[k]);
            assert!((m.dolp[k] as f64 - d).abs() < 1e-3, "{}: DoLP {}", interp.name(), m.dolp[k]);
            assert!((m.intensity_dn[k] as f64 - i0).abs() < 1.0, "{}: I {}", interp.name(), m.intensity_dn[k]);
        }
    }
}

#[test]
fn superpixels_read_each_tile_once_at_its_centre() {
    let (w, h) = (9, 7); // the odd last column and row are not read
    let (dn, _) = sky(w, h);
    let cfg = config(Interpolation::Superpixel, w, h);
    let m = stokes_maps(&RawImage::packed(&dn, w, h), &rec(), &cfg).unwrap();
    assert_eq!((m.width_px, m.height_px), (4, 3));
    let r = rec();
    for n in 0..3 {
        for mm in 0..4 {
            let mut d = [0.0; 4];
            for dv in 0..2 {
                for du in 0..2 {
                    d[DEFAULT_MOSAIC[dv][du].index()] = dn[(2 * n + dv) * w + 2 * mm + du] as f64;
                }
            }
            let s = r.stokes(&d);
            let k = n * 4 + mm;
            assert!((m.aop_deg[k] as f64 - s.aop_rad().to_degrees()).abs() < 1e-4);
            // β at the tile centre (2m + ½, 2n + ½).
            let beta = crate::conventions::image_angle_rad(
                2.0 * mm as f64 + 0.5 - cfg.aoe_centre_px[0],
                2.0 * n as f64 + 0.5 - cfg.aoe_centre_px[1],
            );
            let want = crate::conventions::wrap_deg_90(s.aop_rad().to_degrees() - beta.to_degrees());
            assert!((m.aoe_deg[k] as f64 - want).abs() < 1e-4, "tile ({mm}, {n})");
        }
    }
}

#[test]
fn opencv_rounds_each_average_half_up_and_copies_the_border() {
    // 0° sits at (1, 1) of each tile (DEFAULT_MOSAIC); a 5 × 4 mosaic of odd sums.
    let (w, h) = (5, 4);
    let dn: Vec<u16> = (0..w * h).map(|k| (100 + 7 * k + (k * k) % 5) as u16).collect();
    let at = |u: usize, v: usize| dn[v * w + u] as f32;
    let mut got = [[0.0f32; 5]; 4];
    let lat = lattices(&DEFAULT_MOSAIC);
    let mut s = Scratch::new(w);
    for (v, row) in got.iter_mut().enumerate() {
        s.opencv_row(&RawImage::packed(&dn, w, h), v, &lat, true);
        row.copy_from_slice(&s.ch[Channel::C0.index()][..w]);
    }
    // Interior: own site, horizontal pair, vertical pair, four diagonals, each rounded.
    assert_eq!(got[1][1], at(1, 1));
    assert_eq!(got[1][2], ((at(1, 1) + at(3, 1) + 1.0) / 2.0).floor());
    assert_eq!(got[2][1], ((at(1, 1) + at(1, 3) + 1.0) / 2.0).floor());
    assert_eq!(got[2][2], ((at(1, 1) + at(3, 1) + at(1, 3) + at(3, 3) + 2.0) / 4.0).floor());
    // Border: a copy of the next row or column inwards, corners diagonally.
    assert_eq!(got[0][2], got[1][2]);
    assert_eq!(got[3][2], got[2][2]);
    assert_eq!(got[2][0], got[2][1]);
    assert_eq!(got[2][4], got[2][3]);
    assert_eq!(got[0][0], got[1][1]);
    // Float samples are averaged without rounding.
    let f: Vec<f32> = dn.iter().map(|&x| x as f32).collect();
    s.opencv_row(&RawImage::packed(&f, w, h), 2, &lat, false);
    assert_eq!(s.ch[Channel::C0.index()][2], (at(1, 1) + at(3, 1) + at(1, 3) + at(3, 3)) / 4.0);
}

#[test]
fn strided_and_typed_buffers_give_the_same_maps() {
    let (w, h) = (20, 14);
    let (dn, _) = sky(w, h);
    let cfg = config(Interpolation::Bilinear, w, h);
    let packed = stokes_maps(&RawImage::packed(&dn, w, h), &rec(), &cfg).unwrap();
    let stride = w + 6;
    let mut wide = vec![9u16; stride * h];
    for v in 0..h {
        wide[v * stride..][..w].copy_from_slice(&dn[v * w..][..w]);
    }
    let strided = stokes_maps(&RawImage { data: &wide, width_px: w, height_px: h, stride }, &rec(), &cfg).unwrap();
    assert_eq!(packed, strided);
    let f: Vec<f32> = dn.iter().map(|&x| x as f32).collect();
    assert_eq!(packed, stokes_maps(&RawImage::packed(&f, w, h), &rec(), &cfg).unwrap());
}

#[test]
fn an_invalid_sample_spoils_only_the_pixels_that_weigh_it() {
    let (w, h) = (12, 10);
    let (mut dn, _) = sky(w, h);
    dn[4 * w + 5] = 4095; // saturated, channel at (1, 0) of its tile: 45°
    let m = stokes_maps(&RawImage::packed(&dn, w, h), &rec(), &config(Interpolation::Bilinear, w, h)).unwrap();
    let nan: Vec<(usize, usize)> = (0..w * h).filter(|&k| m.aop_deg[k].is_nan()).map(|k| (k % w, k / w)).collect();
    // The sample itself and its 3 × 3 neighbourhood, where its weight is non-zero.
    let want: Vec<(usize, usize)> = (3..6).flat_map(|v| (4..7).map(move |u| (u, v))).collect();
    assert_eq!(nan, want); // both row-major
}

#[test]
fn wrong_buffers_are_refused_with_their_sizes() {
    let dn = vec![100u16; 40];
    let mut a = vec![0.0; 40];
    let (mut d, mut i) = (vec![0.0; 40], vec![0.0; 39]);
    let out = MapsOut { aop_deg: &mut a, dolp: &mut d, intensity_dn: &mut i, aoe_deg: None };
    let e = stokes_maps_into(&RawImage::packed(&dn, 8, 5), &rec(), &config(Interpolation::Bilinear, 8, 5), out);
    assert_eq!(e, Err(MapsError::Output { name: "intensity_dn", got: 39, want: 40, width_px: 8, height_px: 5 }));
    let e = stokes_maps(
        &RawImage { data: &dn, width_px: 8, height_px: 6, stride: 8 },
        &rec(),
        &config(Interpolation::Bilinear, 8, 6),
    );
    assert!(matches!(e, Err(MapsError::Buffer { .. })), "{e:?}");
    let e = stokes_maps(&RawImage::packed(&dn[..4], 2, 2), &rec(), &config(Interpolation::OpenCv, 2, 2));
    assert!(e.unwrap_err().to_string().contains("at least 3 × 3"));
}

/// The opencv row kernel as first written, a branch and a division per column: the
/// reference the vectorized kernel must equal bit for bit (also stage 2 of the
/// colour routes' reference, `maps_colour_tests`).
pub(crate) fn opencv_row_reference<T: RawDn>(
    raw: &RawImage<T>,
    v: usize,
    lat: &[Option<(usize, usize)>; 4],
    integer: bool,
) -> [Vec<f32>; 4] {
    let (w, h) = (raw.width_px, raw.height_px);
    let vs = v.clamp(1, h - 2);
    let row = |r: usize| &raw.data[r * raw.stride..][..w];
    let (up, mid, down) = (row(vs - 1), row(vs), row(vs + 1));
    let round = |s: f32, n: f32| if integer { ((s + 0.5 * n) / n).floor() } else { s / n };
    let mut vert = [vec![0f32; w], vec![0f32; w]];
    let mut on_row = [false; 2];
    for p in 0..2 {
        on_row[p] = (vs + p) % 2 == 0;
        for u in 0..w {
            vert[p][u] = if on_row[p] { mid[u].dn_f32() } else { up[u].dn_f32() + down[u].dn_f32() };
        }
    }
    let mut ch: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0f32; w]);
    for (k, at) in lat.iter().enumerate() {
        let Some((ou, ov)) = *at else { continue };
        let (src, out) = (&vert[ov], &mut ch[k]);
        let (n_on, n_off) = if on_row[ov] { (1.0, 2.0) } else { (2.0, 4.0) };
        for us in 1..w - 1 {
            out[us] = if (us + ou) % 2 == 0 { round(src[us], n_on) } else { round(src[us - 1] + src[us + 1], n_off) };
        }
        out[0] = out[1];
        out[w - 1] = out[w - 2];
    }
    ch
}

/// Seeded samples in `lo..hi` (splitmix64), fractional if `frac`.
pub(crate) fn seeded_dn(n: usize, seed: u64, lo: f32, hi: f32, frac: bool) -> Vec<f32> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            let x = lo + (hi - lo) * ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32;
            if frac {
                x
            } else {
                x.floor()
            }
        })
        .collect()
}

/// Bit for bit, NaN for NaN.
pub(crate) fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}

#[test]
fn the_vectorized_opencv_row_is_the_per_column_kernel_bit_for_bit() {
    let lat = lattices(&DEFAULT_MOSAIC);
    for (w, h, seed) in [(3, 3, 1), (7, 5, 2), (24, 9, 3), (41, 12, 4)] {
        let whole = seeded_dn(w * h, seed, 0.0, 4096.0, false);
        let u16s: Vec<u16> = whole.iter().map(|&x| x as u16).collect();
        let u8s: Vec<u8> = whole.iter().map(|&x| (x as u16 >> 4) as u8).collect();
        let mut frac = seeded_dn(w * h, seed + 10, 0.0, 4096.0, true);
        frac[w + 1] = f32::NAN;
        let mut s = Scratch::new(w);
        for v in 0..h {
            s.opencv_row(&RawImage::packed(&u16s, w, h), v, &lat, true);
            let want = opencv_row_reference(&RawImage::packed(&u16s, w, h), v, &lat, true);
            assert!((0..4).all(|k| same_bits(&s.ch[k][..w], &want[k])), "u16 {w} × {h} row {v}");
            s.opencv_row(&RawImage::packed(&u8s, w, h), v, &lat, true);
            let want = opencv_row_reference(&RawImage::packed(&u8s, w, h), v, &lat, true);
            assert!((0..4).all(|k| same_bits(&s.ch[k][..w], &want[k])), "u8 {w} × {h} row {v}");
            s.opencv_row(&RawImage::packed(&frac, w, h), v, &lat, false);
            let want = opencv_row_reference(&RawImage::packed(&frac, w, h), v, &lat, false);
            assert!((0..4).all(|k| same_bits(&s.ch[k][..w], &want[k])), "f32 {w} × {h} row {v}");
        }
    }
}

#[test]
fn the_paired_bilinear_row_is_the_per_channel_one_bit_for_bit() {
    // `horizontal` (one channel at a time, the first kernel) against both channels of
    // a row parity in one pass, on the same vertical step; invalid samples included.
    let lat = lattices(&DEFAULT_MOSAIC);
    for (w, h, seed) in [(2, 2, 1), (3, 4, 2), (8, 5, 3), (25, 12, 4)] {
        let dn: Vec<u16> = seeded_dn(w * h, seed, 0.0, 4200.0, false).iter().map(|&x| x as u16).collect();
        let mut s = Scratch::new(w);
        for v in 0..h {
            s.bilinear_row(&RawImage::packed(&dn, w, h), v, &lat, FS as f32);
            for (k, at) in lat.iter().enumerate() {
                let (ou, ov) = at.unwrap();
                let mut want = vec![0f32; w];
                horizontal(&s.vert[ov], ou, &mut want);
                assert!(same_bits(&s.ch[k][..w], &want), "{w} × {h} row {v} channel {k}");
            }
        }
    }
}

/// OpenCV's edge-aware Bayer demosaic (`COLOR_Bayer**2BGR_EA`) of a whole frame, one
/// pixel at a time as `maps_ea.rs` states it: `pattern[y % 2][x % 2]` the colour at
/// (x, y), 0 blue, 1 green, 2 red (`BayerBG`: [[2, 1], [1, 0]], `BayerGR`: [[1, 0],
/// [2, 1]]); returns the blue, green and red planes. Also the reference of the colour
/// route's stage 1 (`maps_colour_tests`).
pub(crate) fn ea_bayer_reference<T: RawDn>(
    raw: &RawImage<T>,
    pattern: [[usize; 2]; 2],
    integer: bool,
) -> [Vec<f32>; 3] {
    let (w, h) = (raw.width_px, raw.height_px);
    let p = |x: usize, y: usize| raw.data[y * raw.stride + x].dn_f32();
    let mean = |s: f32, n: f32| if integer { ((s + 0.5 * n) / n).floor() } else { s / n };
    let mut bgr: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0f32; w * h]);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let c = pattern[y % 2][x % 2];
            let (we, ns) = (p(x - 1, y) + p(x + 1, y), p(x, y - 1) + p(x, y + 1));
            bgr[c][y * w + x] = p(x, y);
            if c == 1 {
                bgr[pattern[y % 2][(x + 1) % 2]][y * w + x] = mean(we, 2.0);
                bgr[pattern[(y + 1) % 2][x % 2]][y * w + x] = mean(ns, 2.0);
            } else {
                let diag = p(x - 1, y - 1) + p(x + 1, y - 1) + p(x - 1, y + 1) + p(x + 1, y + 1);
                bgr[2 - c][y * w + x] = mean(diag, 4.0);
                let vertical = (p(x - 1, y) - p(x + 1, y)).abs() > (p(x, y + 1) - p(x, y - 1)).abs();
                bgr[1][y * w + x] = if vertical { mean(ns, 2.0) } else { mean(we, 2.0) };
            }
        }
    }
    for plane in &mut bgr {
        for y in 1..h - 1 {
            plane[y * w] = plane[y * w + 1];
            plane[y * w + w - 1] = plane[y * w + w - 2];
        }
        plane.copy_within(w..2 * w, 0);
        plane.copy_within((h - 2) * w..(h - 1) * w, (h - 1) * w);
    }
    bgr
}

#[test]
fn the_edge_aware_reference_takes_green_along_the_smaller_difference() {
    // BayerBG 3 × 3: the centre is blue; green from the pair that differs less, a tie
    // along the row (bilinear: the 4-mean, 14, 15, 19); every pixel copies the centre
    // (OpenCV's border). Worked by hand.
    const BG: [[usize; 2]; 2] = [[2, 1], [1, 0]];
    for (w_e, n_s, green) in [((10, 31), (12, 15), 14.0), ((10, 13), (20, 17), 12.0), ((7, 30), (9, 30), 20.0)] {
        let dn: [u16; 9] = [1, n_s.0, 3, w_e.0, 100, w_e.1, 5, n_s.1, 9];
        let [b, g, r] = ea_bayer_reference(&RawImage::packed(&dn, 3, 3), BG, true);
        assert!(g.iter().all(|&x| x == green), "{w_e:?} {n_s:?}: {g:?}");
        assert!(b.iter().all(|&x| x == 100.0) && r.iter().all(|&x| x == 5.0), "{b:?} {r:?}");
        // (1+3+5+9+2)>>2
    }
}

#[test]
fn opencv_ea_mono_maps_are_the_edge_aware_demosaics_analyzers_bit_for_bit() {
    // polanalyser's COLOR_PolarMono_EA: blue and red of BayerBG2BGR_EA (0°, 90°) and of
    // BayerGR2BGR_EA (45°, 135°), the analyzers of bpins' default mosaic.
    let lat = lattices(&DEFAULT_MOSAIC);
    let (bg, gr) = ([[2, 1], [1, 0]], [[1, 0], [2, 1]]);
    for (w, h, seed) in [(3, 3, 1), (7, 5, 2), (24, 9, 3), (41, 12, 4)] {
        let whole = seeded_dn(w * h, seed, 0.0, 4096.0, false);
        let u16s: Vec<u16> = whole.iter().map(|&x| x as u16).collect();
        let u8s: Vec<u8> = whole.iter().map(|&x| (x as u16 >> 4) as u8).collect();
        let mut s = Scratch::new(w);
        let mut green_differs = false;
        let mut check = |raw: &RawImage<u16>, what: &str| {
            let [b0, g0, r90] = ea_bayer_reference(raw, bg, true);
            let [b45, _, r135] = ea_bayer_reference(raw, gr, true);
            for v in 0..h {
                s.opencv_row(raw, v, &lat, true);
                for (k, want) in [&b0, &b45, &r90, &r135].into_iter().enumerate() {
                    assert!(same_bits(&s.ch[k][..w], &want[v * w..][..w]), "{what} {w} × {h} row {v} channel {k}");
                }
            }
            // The green plane (dropped by polanalyser) is edge-aware: not the bilinear 4-mean.
            green_differs |= (1..h - 1).any(|y| {
                (1..w - 1).any(|x| {
                    let p = |x: usize, y: usize| raw.data[y * w + x].dn_f32();
                    (x + y) % 2 == 0
                        && g0[y * w + x]
                            != ((p(x - 1, y) + p(x + 1, y) + p(x, y - 1) + p(x, y + 1) + 2.0) / 4.0).floor()
                })
            });
        };
        check(&RawImage::packed(&u16s, w, h), "u16");
        let raw8 = RawImage::packed(&u8s, w, h);
        let [b0, _, _] = ea_bayer_reference(&raw8, bg, true);
        for v in 0..h {
            s.opencv_row(&raw8, v, &lat, true);
            assert!(same_bits(&s.ch[0][..w], &b0[v * w..][..w]), "u8 {w} × {h} row {v}");
        }
        assert!(green_differs, "{w} × {h}");
        // …so the route's maps are the opencv route's.
        let raw = RawImage::packed(&u16s, w, h);
        let ea = stokes_maps(&raw, &rec(), &config(Interpolation::OpenCvEa, w, h)).unwrap();
        let ocv = stokes_maps(&raw, &rec(), &config(Interpolation::OpenCv, w, h)).unwrap();
        assert!(same_bits(&ea.aop_deg, &ocv.aop_deg) && same_bits(&ea.dolp, &ocv.dolp), "{w} × {h}");
    }
}
