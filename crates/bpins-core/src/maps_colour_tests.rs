use super::*;
use crate::sensor::{Channel, DEFAULT_MOSAIC};

/// A colour mosaic whose band `b` sees a uniform field of DoLP `dolp[b]` at AoP
/// `aop_deg[b]` and intensity `i_dn[b]` (ideal analyzers, CONVENTIONS.md
/// `I_θ = ½(I + Q cos 2θ + U sin 2θ)`), rounded to whole DN.
fn uniform(w: usize, h: usize, i_dn: [f64; 3], dolp: [f64; 3], aop_deg: [f64; 3]) -> Vec<u16> {
    let tiles = ColourTiles::imx250myr();
    let mut raw = vec![0u16; w * h];
    for v in 0..h {
        for u in 0..w {
            let b = tiles.band_at(u, v).index();
            let th = DEFAULT_MOSAIC[v % 2][u % 2].angle_deg().to_radians();
            let a = aop_deg[b].to_radians();
            let x = 0.5 * i_dn[b] * (1.0 + dolp[b] * (2.0 * (th - a)).cos());
            raw[v * w + u] = x.round() as u16;
        }
    }
    raw
}

fn cfg(interpolation: Interpolation) -> MapsConfig {
    MapsConfig { interpolation, mosaic: DEFAULT_MOSAIC, full_scale_dn: 4095.0, aoe_centre_px: [10.0, 8.0] }
}

fn rec() -> Reconstructor {
    Reconstructor::new(&Default::default(), 0.0, &Channel::ALL).unwrap()
}

const ROUTES: [Interpolation; 4] = Interpolation::ALL;

#[test]
fn each_band_reads_its_own_field_through_every_route() {
    let (w, h) = (24, 20);
    let (i, d, a) = ([2000.0, 1600.0, 1200.0], [0.5, 0.3, 0.2], [30.0, -60.0, 85.0]);
    let raw = uniform(w, h, i, d, a);
    for route in ROUTES {
        let maps = colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(route), &ColourTiles::imx250myr()).unwrap();
        assert_eq!(maps.iter().map(|m| m.band).collect::<Vec<_>>(), Band::ALL);
        for m in &maps {
            let b = m.band.index();
            assert_eq!((m.maps.width_px, m.maps.height_px), colour_maps_size(route, w, h));
            // Whole-DN rounding of ~1000 DN samples: AoP within a few hundredths of a degree.
            for k in 0..m.maps.aop_deg.len() {
                let da = (m.maps.aop_deg[k] as f64 - a[b] + 90.0).rem_euclid(180.0) - 90.0;
                assert!(da.abs() < 0.2, "{route:?} {:?} pixel {k}: AoP {} vs {}", m.band, m.maps.aop_deg[k], a[b]);
                assert!((m.maps.dolp[k] as f64 - d[b]).abs() < 2e-3, "{route:?} {:?}: DoLP", m.band);
                assert!((m.maps.intensity_dn[k] as f64 / i[b] - 1.0).abs() < 2e-3, "{route:?} {:?}: I", m.band);
            }
        }
    }
}

#[test]
fn a_polarized_red_tile_shows_in_the_red_band_only() {
    // The tile order pinned: only R (tile row 0, column 0 of the superpixel) polarized.
    let (w, h) = (32, 28);
    let raw = uniform(w, h, [2000.0; 3], [0.6, 0.0, 0.0], [40.0; 3]);
    for route in ROUTES {
        let maps = colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(route), &ColourTiles::imx250myr()).unwrap();
        for m in &maps {
            let mean = m.maps.dolp.iter().map(|&x| x as f64).sum::<f64>() / m.maps.dolp.len() as f64;
            if m.band == Band::R {
                assert!((mean - 0.6).abs() < 5e-3, "{route:?}: R DoLP {mean}");
            } else {
                assert!(mean < 2e-3, "{route:?}: {:?} DoLP {mean}", m.band);
            }
        }
    }
}

#[test]
fn superpixels_are_the_mono_superpixels_of_the_bands_own_tiles() {
    // Band R's tiles, gathered into a mono mosaic, give the same superpixel maps.
    let (w, h) = (24, 16);
    let mut raw: Vec<u16> = (0..w * h).map(|k| 500 + ((k * 7919) % 1013) as u16).collect();
    raw[5 * w + 1] = 0; // an invalid R sample: NaN in its superpixel (0, 1) only
    let colour =
        colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(Interpolation::Superpixel), &ColourTiles::imx250myr())
            .unwrap();
    let r: Vec<u16> = (0..h / 2)
        .flat_map(|y| (0..w / 2).map(move |x| (y, x)))
        .map(|(y, x)| raw[(4 * (y / 2) + y % 2) * w + 4 * (x / 2) + x % 2])
        .collect();
    let mut c = cfg(Interpolation::Superpixel);
    // Mono superpixel (m, n) sits at (2m + ½), the colour one at (4m + ½) for R: the
    // same direction from the centre if the mono one is at (c + ½)/2.
    c.aoe_centre_px = [5.25, 4.25];
    let mono = crate::maps::stokes_maps(&RawImage::packed(&r, w / 2, h / 2), &rec(), &c).unwrap();
    let red = &colour[0].maps;
    assert_eq!(red.aop_deg.len(), mono.aop_deg.len());
    for k in 0..red.aop_deg.len() {
        for (x, y) in [(red.aop_deg[k], mono.aop_deg[k]), (red.dolp[k], mono.dolp[k])] {
            assert!(x == y || (x.is_nan() && y.is_nan()), "pixel {k}: {x} vs {y}");
        }
        let (x, y) = (red.aoe_deg[k], mono.aoe_deg[k]);
        assert!((x - y).abs() < 1e-3 || (x.is_nan() && y.is_nan()), "pixel {k}: AoE {x} vs {y}");
    }
    assert!(
        red.aop_deg[w / 4].is_nan()
            && red.aop_deg.iter().filter(|x| x.is_nan()).count() == 1
            && colour[1].maps.aop_deg.iter().all(|x| x.is_finite())
    );
}

#[test]
fn bilinear_masks_invalid_samples_and_opencv_does_not() {
    let (w, h) = (24, 20);
    let mut raw = uniform(w, h, [2000.0; 3], [0.4; 3], [10.0; 3]);
    raw[11 * w + 11] = 4095; // saturated, under B (tile row 1, column 1 of the superpixel at (8, 8))
    let t = ColourTiles::imx250myr();
    let bil = colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(Interpolation::Bilinear), &t).unwrap();
    let ocv = colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(Interpolation::OpenCv), &t).unwrap();
    assert!(bil[2].maps.aop_deg[11 * w + 11].is_nan());
    assert!(bil[0].maps.aop_deg.iter().chain(&bil[1].maps.aop_deg).all(|x| x.is_finite()), "R, G untouched");
    assert!(ocv.iter().all(|m| m.maps.aop_deg.iter().all(|x| x.is_finite())));
}

#[test]
fn tiles_that_are_not_bayer_are_refused_but_by_superpixels() {
    let (w, h) = (16, 16);
    let raw = uniform(w, h, [2000.0; 3], [0.4; 3], [10.0; 3]);
    let t = ColourTiles { tiles: [[Band::R, Band::R], [Band::G, Band::B]], ..ColourTiles::imx250myr() };
    let e = colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(Interpolation::OpenCv), &t);
    assert_eq!(e, Err(MapsError::NotBayer { band: "R", interpolation: "opencv" }));
    let e = colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(Interpolation::OpenCvEa), &t);
    assert_eq!(e, Err(MapsError::NotBayer { band: "R", interpolation: "opencv_ea" }));
    assert!(colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(Interpolation::Superpixel), &t).is_ok());
    let small = colour_maps(&RawImage::packed(&raw[..5 * 5], 5, 5), &rec(), &cfg(Interpolation::OpenCv), &t);
    assert!(matches!(small, Err(MapsError::TooSmall { min: 6, .. })), "{small:?}");
}

/// Stage 1 as first written, one analyzer plane and one pixel at a time (module docs):
/// the reference the fused, vectorized route must equal bit for bit. `edge_aware`: the
/// band on two diagonal tiles from the pair of neighbours that differs less (maps_ea.rs).
fn stage1_reference<T: RawDn>(
    raw: &RawImage<T>,
    l: Lattice,
    integer: bool,
    full_scale: Option<f32>,
    edge_aware: bool,
) -> Vec<f32> {
    let (w, h) = (raw.width_px, raw.height_px);
    let round = |s: f32, n: f32| if integer { ((s + 0.5 * n) / n).floor() } else { s / n };
    let mut m = vec![0f32; w * h];
    for (j, i) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        let (pw, ph) = ((w - i).div_ceil(2), (h - j).div_ceil(2));
        let p = |x: usize, y: usize| {
            let d = raw.data[(2 * y + j) * raw.stride + 2 * x + i].dn_f32();
            full_scale.map_or(d, |fs| crate::maps::checked(d, fs))
        };
        for y in 0..ph {
            for x in 0..pw {
                let (xs, ys) = (x.clamp(1, pw - 2), y.clamp(1, ph - 2));
                m[(2 * y + j) * w + 2 * x + i] = match l {
                    Lattice::One(ox, oy) => {
                        let on_col = (xs + ox) % 2 == 0;
                        match ((ys + oy) % 2 == 0, on_col) {
                            (true, true) => p(xs, ys),
                            (true, false) => round(p(xs - 1, ys) + p(xs + 1, ys), 2.0),
                            (false, true) => round(p(xs, ys - 1) + p(xs, ys + 1), 2.0),
                            (false, false) => round(
                                p(xs - 1, ys - 1) + p(xs + 1, ys - 1) + p(xs - 1, ys + 1) + p(xs + 1, ys + 1),
                                4.0,
                            ),
                        }
                    }
                    Lattice::Quincunx(par) if (xs + ys) % 2 == par => p(xs, ys),
                    Lattice::Quincunx(_) if edge_aware => {
                        let (we, ns) = (p(xs - 1, ys) + p(xs + 1, ys), p(xs, ys - 1) + p(xs, ys + 1));
                        let vertical = (p(xs - 1, ys) - p(xs + 1, ys)).abs() > (p(xs, ys + 1) - p(xs, ys - 1)).abs();
                        round(if vertical { ns } else { we }, 2.0)
                    }
                    Lattice::Quincunx(_) => round(p(xs, ys - 1) + p(xs, ys + 1) + p(xs - 1, ys) + p(xs + 1, ys), 4.0),
                };
            }
        }
    }
    m
}

/// The two stages apart, as first written: each band's full-size mosaic, then the
/// per-column opencv kernel and the Stokes and angles over it.
fn two_stage_reference<T: RawDn>(raw: &RawImage<T>, cfg: &MapsConfig, band: Band) -> super::super::Maps {
    let (w, h) = (raw.width_px, raw.height_px);
    let opencv = cfg.interpolation.is_opencv();
    let integer = opencv && T::INTEGER;
    let l = lattice(&ColourTiles::imx250myr(), band, cfg.interpolation).unwrap();
    let ea = cfg.interpolation == Interpolation::OpenCvEa;
    let m = stage1_reference(raw, l, integer, (!opencv).then_some(cfg.full_scale_dn as f32), ea);
    let px = PixelMap::new(&rec(), cfg, 1.0, [0.0; 2]);
    let lat = lattices(&cfg.mosaic);
    let mut maps = super::super::Maps {
        width_px: w,
        height_px: h,
        aop_deg: vec![0.0; w * h],
        dolp: vec![0.0; w * h],
        intensity_dn: vec![0.0; w * h],
        aoe_deg: vec![0.0; w * h],
    };
    for v in 0..h {
        let ch = crate::maps::tests::opencv_row_reference(&RawImage::packed(&m, w, h), v, &lat, integer);
        let r = v * w..(v + 1) * w;
        let (a, d, i, e) = (
            &mut maps.aop_deg[r.clone()],
            &mut maps.dolp[r.clone()],
            &mut maps.intensity_dn[r.clone()],
            &mut maps.aoe_deg[r],
        );
        px.row(&ch, v, a, d, i, Some(e));
    }
    maps
}

#[test]
fn the_fused_full_size_routes_are_the_two_stages_bit_for_bit() {
    use crate::maps::tests::{same_bits, seeded_dn};
    let t = ColourTiles::imx250myr();
    // Odd sizes, the smallest, and more than two blocks of rows (BLOCK_ROWS).
    for (w, h, seed) in [(6, 6, 1), (7, 9, 2), (13, 11, 3), (26, 2 * BLOCK_ROWS + 7, 4)] {
        // 12-bit samples with zeros and saturated ones (bilinear's NaN), as u16, u8, and
        // fractional f32 with a NaN; a strided copy of the u16 ones.
        let whole = seeded_dn(w * h, seed, 0.0, 4200.0, false);
        let u16s: Vec<u16> = whole.iter().map(|&x| x as u16).collect();
        let u8s: Vec<u8> = whole.iter().map(|&x| (x as u16 >> 4).min(255) as u8).collect();
        let mut frac = seeded_dn(w * h, seed + 10, 0.0, 4200.0, true);
        frac[2 * w + 3] = f32::NAN;
        let stride = w + 3;
        let mut wide = vec![7u16; stride * h];
        for v in 0..h {
            wide[v * stride..][..w].copy_from_slice(&u16s[v * w..][..w]);
        }
        for route in [Interpolation::OpenCv, Interpolation::OpenCvEa, Interpolation::Bilinear] {
            let c = cfg(route);
            let check = |got: Vec<BandMaps>, want: [super::super::Maps; 3], what: &str| {
                for g in got {
                    let (m, r) = (&g.maps, &want[g.band.index()]);
                    for (name, x, y) in [
                        ("aop", &m.aop_deg, &r.aop_deg),
                        ("dolp", &m.dolp, &r.dolp),
                        ("intensity", &m.intensity_dn, &r.intensity_dn),
                        ("aoe", &m.aoe_deg, &r.aoe_deg),
                    ] {
                        assert!(same_bits(x, y), "{route:?} {what} {w} × {h} {:?} {name}", g.band);
                    }
                }
            };
            let wants = |raw: &dyn Fn(Band) -> super::super::Maps| Band::ALL.map(raw);
            let raw16 = RawImage::packed(&u16s, w, h);
            check(colour_maps(&raw16, &rec(), &c, &t).unwrap(), wants(&|b| two_stage_reference(&raw16, &c, b)), "u16");
            let strided = RawImage { data: &wide, width_px: w, height_px: h, stride };
            check(
                colour_maps(&strided, &rec(), &c, &t).unwrap(),
                wants(&|b| two_stage_reference(&raw16, &c, b)),
                "strided",
            );
            let raw8 = RawImage::packed(&u8s, w, h);
            check(colour_maps(&raw8, &rec(), &c, &t).unwrap(), wants(&|b| two_stage_reference(&raw8, &c, b)), "u8");
            let rawf = RawImage::packed(&frac, w, h);
            check(colour_maps(&rawf, &rec(), &c, &t).unwrap(), wants(&|b| two_stage_reference(&rawf, &c, b)), "f32");
            // Some bands, out of order, without AoE: the same rows.
            let n = w * h;
            let mut bufs = [[(); 3].map(|_| vec![0f32; n]), [(); 3].map(|_| vec![0f32; n])];
            let [[a0, d0, i0], [a1, d1, i1]] = &mut bufs;
            let mut out = [
                (Band::B, MapsOut { aop_deg: a0, dolp: d0, intensity_dn: i0, aoe_deg: None }),
                (Band::R, MapsOut { aop_deg: a1, dolp: d1, intensity_dn: i1, aoe_deg: None }),
            ];
            colour_maps_into(&raw16, &rec(), &c, &t, &mut ColourScratch::default(), &mut out).unwrap();
            for (k, band) in [Band::B, Band::R].into_iter().enumerate() {
                let r = two_stage_reference(&raw16, &c, band);
                assert!(same_bits(&bufs[k][0], &r.aop_deg) && same_bits(&bufs[k][1], &r.dolp), "{route:?} {band:?}");
            }
        }
    }
}

#[test]
fn edge_aware_stage1_is_opencvs_edge_aware_demosaic_of_each_analyzer_plane() {
    // polanalyser's COLOR_PolarRGB_EA stage 1: each analyzer plane raw[j::2, i::2] (RGGB,
    // OpenCV's BayerBG) through BayerBG2BGR_EA; its blue, green, red are bands B, G, R
    // at the plane's pixels. The full-frame reference (maps_tests) against stage 1's.
    use crate::maps::tests::{ea_bayer_reference, seeded_dn};
    let t = ColourTiles::imx250myr();
    for (w, h, seed) in [(6, 6, 1), (7, 9, 2), (26, 22, 3)] {
        let dn: Vec<u16> = seeded_dn(w * h, seed, 0.0, 4096.0, false).iter().map(|&x| x as u16).collect();
        let raw = RawImage::packed(&dn, w, h);
        let stage1 = Band::ALL.map(|b| {
            let l = lattice(&t, b, Interpolation::OpenCvEa).unwrap();
            (stage1_reference(&raw, l, true, None, true), stage1_reference(&raw, l, true, None, false))
        });
        let mut differs = false;
        for (j, i) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            let (pw, ph) = ((w - i).div_ceil(2), (h - j).div_ceil(2));
            let plane: Vec<u16> = (0..ph)
                .flat_map(|y| (0..pw).map(move |x| (x, y)))
                .map(|(x, y)| dn[(2 * y + j) * w + 2 * x + i])
                .collect();
            let bgr = ea_bayer_reference(&RawImage::packed(&plane, pw, ph), [[2, 1], [1, 0]], true);
            for (band, c) in [(Band::R, 2), (Band::G, 1), (Band::B, 0)] {
                let (ea, bilinear) = &stage1[band.index()];
                for y in 0..ph {
                    for x in 0..pw {
                        let at = (2 * y + j) * w + 2 * x + i;
                        assert_eq!(ea[at], bgr[c][y * pw + x], "{w} × {h} plane ({i}, {j}) {band:?} ({x}, {y})");
                        differs |= ea[at] != bilinear[at];
                    }
                }
            }
        }
        assert!(differs, "{w} × {h}: the edge-aware green is not the bilinear one");
    }
}
