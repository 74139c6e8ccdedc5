//! The C ABI on a colour-polarization frame (samples/colour-clear, IMX250MYR tiles):
//! `colour_tiles` in the compass config, each band's heading and the fused one bit for
//! bit as the Rust front door's, each band's maps as `colour_maps`'; refusals as
//! statuses with messages.

use bpins::*;
use bpins_core::compass::{Compass, CompassConfig, Extractor, RawImage, Sun};
use bpins_core::sensor::{Channel, Layout};
use bpins_core::{colour_maps, Capture, FrameData, Interpolation, MapsConfig, Reconstructor};
use std::ffi::{c_char, CStr};
use std::mem::MaybeUninit;
use std::ptr::{null, null_mut};

fn last_error() -> String {
    // SAFETY: the library's own NUL-terminated string.
    unsafe { CStr::from_ptr(bpins_last_error_message()) }.to_string_lossy().into_owned()
}

const RGGB: [c_char; 4] = [b'R' as c_char, b'G' as c_char, b'G' as c_char, b'B' as c_char];

struct Frame {
    config: CompassConfig,
    raw: Vec<u16>,
    sun: Sun,
}

fn colour_frame(k: usize) -> Frame {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../samples/colour-clear");
    let c = Capture::load(&dir).expect("samples/colour-clear");
    let Layout::Dofp { mosaic } = c.sensor.layout else { panic!("DoFP") };
    let g = &c.sensor.geometry;
    let mut config = CompassConfig::dofp(
        c.intrinsics(),
        g.width_px as usize,
        g.height_px as usize,
        c.sensor.bit_depth,
        c.sensor.black_level_dn,
    );
    config.mosaic = mosaic;
    config.colour = c.sensor.colour.clone();
    let FrameData::Mosaic { dn, .. } = c.read_frame(k).expect("frame") else { panic!("a mosaic") };
    let f = &c.frames[k];
    let sun = Sun::Angles { azimuth_deg: f.sun.azimuth_deg, elevation_deg: f.sun.elevation_deg, sigma_deg: 0.0 };
    Frame { config, raw: dn.iter().map(|&x| x as u16).collect(), sun }
}

fn c_config(cfg: &CompassConfig, tiles: [c_char; 4]) -> BpinsCompassConfig {
    let mut c = MaybeUninit::uninit();
    // SAFETY: writable.
    assert_eq!(unsafe { bpins_compass_config_default(c.as_mut_ptr()) }, BpinsStatus::BPINS_OK);
    // SAFETY: written above.
    let mut c = unsafe { c.assume_init() };
    assert_eq!(c.colour_tiles, [0; 4], "monochrome by default");
    (c.width_px, c.height_px) = (cfg.width_px as u32, cfg.height_px as u32);
    (c.bit_depth, c.black_level_dn) = (cfg.bit_depth, cfg.black_level_dn);
    (c.focal_length_px, c.cx_px, c.cy_px) = (cfg.camera.f_px, cfg.camera.cx_px, cfg.camera.cy_px);
    c.mosaic_deg = cfg.mosaic.map(|row| row.map(|ch| ch.angle_deg() as u32));
    c.colour_tiles = tiles;
    c
}

fn new(cfg: &BpinsCompassConfig) -> Result<*mut BpinsCompass, (BpinsStatus, String)> {
    let mut h = null_mut();
    // SAFETY: valid pointers.
    match unsafe { bpins_compass_new_with_calibration(cfg, null(), &mut h) } {
        BpinsStatus::BPINS_OK => Ok(h),
        s => Err((s, last_error())),
    }
}

#[test]
fn band_headings_through_the_abi_are_the_front_doors() {
    let f = colour_frame(2);
    let (w, h) = (f.config.width_px, f.config.height_px);
    let mut rust = Compass::new(f.config.clone()).unwrap();
    let want = rust
        .colour_headings(RawImage::packed(&f.raw, w, h), f.sun, Default::default(), &[Extractor::SunVector])
        .unwrap();
    let handle = new(&c_config(&f.config, RGGB)).unwrap();
    let Sun::Angles { azimuth_deg, elevation_deg, .. } = f.sun else { unreachable!() };
    let sun = BpinsSun {
        kind: BPINS_SUN_ANGLES,
        azimuth_deg,
        elevation_deg,
        unix_time_s: f64::NAN,
        latitude_deg: f64::NAN,
        longitude_deg: f64::NAN,
        sigma_deg: 0.0,
    };
    let att = BpinsAttitude::default();
    let mut bands = MaybeUninit::<[BpinsHeading; 3]>::uninit();
    // SAFETY: three writable headings.
    let st = unsafe {
        bpins_compass_band_headings_u16(handle, f.raw.as_ptr(), w, h, w, &sun, &att, bands.as_mut_ptr().cast())
    };
    assert_eq!(st, BpinsStatus::BPINS_OK, "{}", last_error());
    // SAFETY: written on OK.
    let bands = unsafe { bands.assume_init() };
    assert_eq!(want.bands.len(), 3);
    for (b, hs) in &want.bands {
        let got = &bands[b.index()];
        assert!(got.has_heading, "{b:?}");
        assert_eq!(got.heading_deg.to_bits(), hs[0].heading_deg().unwrap().to_bits(), "{b:?}");
        assert_eq!(got.sigma_deg.to_bits(), hs[0].sigma_deg().unwrap().to_bits(), "{b:?}");
    }
    let mut fused = MaybeUninit::<BpinsHeading>::uninit();
    // SAFETY: one writable heading.
    let st = unsafe { bpins_compass_heading_u16(handle, f.raw.as_ptr(), w, h, w, &sun, &att, fused.as_mut_ptr()) };
    assert_eq!(st, BpinsStatus::BPINS_OK);
    // SAFETY: written on OK.
    assert_eq!(unsafe { fused.assume_init() }.heading_deg.to_bits(), want.fused[0].heading_deg().unwrap().to_bits());

    // A monochrome compass has no bands; tiles that are not R, G, B are refused.
    let mono = new(&c_config(&f.config, [0; 4])).unwrap();
    let mut out = MaybeUninit::<[BpinsHeading; 3]>::uninit();
    // SAFETY: as above.
    let st =
        unsafe { bpins_compass_band_headings_u16(mono, f.raw.as_ptr(), w, h, w, &sun, &att, out.as_mut_ptr().cast()) };
    assert_eq!(st, BpinsStatus::BPINS_ERR_CONFIG);
    assert!(last_error().contains("colour"), "{}", last_error());
    let bad = [b'R' as c_char, b'G' as c_char, b'G' as c_char, b'Y' as c_char];
    let e = new(&c_config(&f.config, bad)).unwrap_err();
    assert_eq!(e.0, BpinsStatus::BPINS_ERR_CONFIG);
    assert!(e.1.contains("colour_tiles[3]"), "{}", e.1);
    // SAFETY: live handles.
    unsafe {
        bpins_compass_free(handle);
        bpins_compass_free(mono);
    }
}

#[test]
fn colour_maps_through_the_abi_are_the_kernels() {
    let f = colour_frame(0);
    let (w, h) = (f.config.width_px, f.config.height_px);
    for (code, interp) in [
        (BPINS_MAPS_OPENCV, Interpolation::OpenCv),
        (BPINS_MAPS_OPENCV_EA, Interpolation::OpenCvEa),
        (BPINS_MAPS_SUPERPIXEL, Interpolation::Superpixel),
    ] {
        let mut cfg = MaybeUninit::<BpinsMapsConfig>::uninit();
        // SAFETY: writable.
        assert_eq!(unsafe { bpins_maps_config_default(cfg.as_mut_ptr()) }, BpinsStatus::BPINS_OK);
        // SAFETY: written above.
        let mut cfg = unsafe { cfg.assume_init() };
        (cfg.interpolation, cfg.black_level_dn, cfg.full_scale_dn) = (code, 64.0, 4095.0);
        (cfg.aoe_centre_x_px, cfg.aoe_centre_y_px) = (203.5, 169.5);
        let n = if interp == Interpolation::Superpixel { (w / 4) * (h / 4) } else { w * h };
        let mut bufs: Vec<[Vec<f32>; 4]> = (0..3).map(|_| [(); 4].map(|_| vec![0f32; n])).collect();
        let mut out: Vec<BpinsBandMaps> = bufs
            .iter_mut()
            .map(|[a, d, i, e]| BpinsBandMaps {
                aop_deg: a.as_mut_ptr(),
                dolp: d.as_mut_ptr(),
                intensity_dn: i.as_mut_ptr(),
                aoe_deg: e.as_mut_ptr(),
            })
            .collect();
        out[BPINS_BAND_G as usize].aop_deg = null_mut(); // G not wanted
                                                         // SAFETY: buffers of the contract's sizes.
        let st = unsafe { bpins_colour_maps_u16(f.raw.as_ptr(), w, h, w, &cfg, RGGB.as_ptr(), out.as_ptr()) };
        assert_eq!(st, BpinsStatus::BPINS_OK, "{}", last_error());
        let rec = Reconstructor::new(&Default::default(), 64.0, &Channel::ALL).unwrap();
        let mc = MapsConfig {
            interpolation: interp,
            mosaic: f.config.mosaic,
            full_scale_dn: 4095.0,
            aoe_centre_px: [203.5, 169.5],
        };
        let want = colour_maps(&RawImage::packed(&f.raw, w, h), &rec, &mc, f.config.colour.as_ref().unwrap()).unwrap();
        for m in &want {
            let got = &bufs[m.band.index()];
            if m.band.name() == "G" {
                assert!(got[0].iter().all(|&x| x == 0.0), "G untouched");
                continue;
            }
            let same = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same(&got[0], &m.maps.aop_deg) && same(&got[1], &m.maps.dolp), "{interp:?} {:?}", m.band);
            assert!(same(&got[2], &m.maps.intensity_dn) && same(&got[3], &m.maps.aoe_deg), "{interp:?} {:?}", m.band);
        }
        // Refusals: no tiles, tiles that are not a Bayer arrangement for opencv(_ea).
        // SAFETY: as above.
        let st = unsafe { bpins_colour_maps_u16(f.raw.as_ptr(), w, h, w, &cfg, null(), out.as_ptr()) };
        assert_eq!(st, BpinsStatus::BPINS_ERR_NULL);
        let rrgb = [b'R' as c_char, b'R' as c_char, b'G' as c_char, b'B' as c_char];
        // SAFETY: as above.
        let st = unsafe { bpins_colour_maps_u16(f.raw.as_ptr(), w, h, w, &cfg, rrgb.as_ptr(), out.as_ptr()) };
        if interp != Interpolation::Superpixel {
            assert_eq!(st, BpinsStatus::BPINS_ERR_CONFIG);
            assert!(last_error().contains("Bayer"), "{}", last_error());
        } else {
            assert_eq!(st, BpinsStatus::BPINS_OK);
        }
    }
}
