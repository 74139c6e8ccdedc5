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

const ROUTES: [Interpolation; 3] = Interpolation::ALL;

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
    assert!(colour_maps(&RawImage::packed(&raw, w, h), &rec(), &cfg(Interpolation::Superpixel), &t).is_ok());
    let small = colour_maps(&RawImage::packed(&raw[..5 * 5], 5, 5), &rec(), &cfg(Interpolation::OpenCv), &t);
    assert!(matches!(small, Err(MapsError::TooSmall { min: 6, .. })), "{small:?}");
}
