//! `bpins_stokes_maps_*` against the Rust kernel it wraps, on a seeded mosaic; its
//! refusals as statuses with messages.

use bpins::*;
use bpins_core::compass::RawImage;
use bpins_core::sensor::{Channel, DEFAULT_MOSAIC};
use bpins_core::{stokes_maps, Interpolation, MapsConfig, Reconstructor};
use std::ffi::CStr;

fn last_error() -> String {
    // SAFETY: the library's own NUL-terminated string.
    unsafe { CStr::from_ptr(bpins_last_error_message()) }.to_string_lossy().into_owned()
}

/// A seeded 12-bit mosaic with structure (an AoP ramp), in a buffer with padded rows.
fn mosaic(w: usize, h: usize, stride: usize) -> Vec<u16> {
    let mut x = 12345u64;
    let mut dn = vec![0u16; stride * h];
    for v in 0..h {
        for u in 0..w {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let theta = DEFAULT_MOSAIC[v % 2][u % 2].angle_deg();
            let alpha = 0.5 * u as f64 - 0.3 * v as f64;
            let s = 1500.0 * (1.0 + 0.4 * (2.0 * (theta - alpha)).to_radians().cos());
            dn[v * stride + u] = (64.0 + s + (x >> 60) as f64) as u16;
        }
    }
    dn
}

#[test]
fn the_abi_gives_the_kernels_maps_for_each_interpolation() {
    let (w, h, stride) = (40, 30, 44);
    let dn = mosaic(w, h, stride);
    for (code, interp) in [
        (BPINS_MAPS_BILINEAR, Interpolation::Bilinear),
        (BPINS_MAPS_SUPERPIXEL, Interpolation::Superpixel),
        (BPINS_MAPS_OPENCV, Interpolation::OpenCv),
        (BPINS_MAPS_OPENCV_EA, Interpolation::OpenCvEa),
    ] {
        let mut cfg = std::mem::MaybeUninit::<BpinsMapsConfig>::uninit();
        // SAFETY: a writable config.
        assert_eq!(unsafe { bpins_maps_config_default(cfg.as_mut_ptr()) }, BpinsStatus::BPINS_OK);
        // SAFETY: written just above.
        let mut cfg = unsafe { cfg.assume_init() };
        cfg.interpolation = code;
        cfg.black_level_dn = 64.0;
        cfg.full_scale_dn = 4095.0;
        cfg.aoe_centre_x_px = 19.5;
        cfg.aoe_centre_y_px = 14.5;
        let (mw, mh) = interp.maps_size(w, h);
        let n = mw * mh;
        let (mut a, mut d, mut i, mut e) = (vec![0f32; n], vec![0f32; n], vec![0f32; n], vec![0f32; n]);
        // SAFETY: buffers of the sizes the contract asks.
        let st = unsafe {
            bpins_stokes_maps_u16(
                dn.as_ptr(),
                w,
                h,
                stride,
                &cfg,
                a.as_mut_ptr(),
                d.as_mut_ptr(),
                i.as_mut_ptr(),
                e.as_mut_ptr(),
            )
        };
        assert_eq!(st, BpinsStatus::BPINS_OK, "{}", last_error());
        let rec = Reconstructor::new(&Default::default(), 64.0, &Channel::ALL).unwrap();
        let core_cfg = MapsConfig {
            interpolation: interp,
            mosaic: DEFAULT_MOSAIC,
            full_scale_dn: 4095.0,
            aoe_centre_px: [19.5, 14.5],
        };
        let m = stokes_maps(&RawImage { data: &dn, width_px: w, height_px: h, stride }, &rec, &core_cfg).unwrap();
        assert_eq!((a, d, i, e), (m.aop_deg, m.dolp, m.intensity_dn, m.aoe_deg), "{}", interp.name());
    }
}

#[test]
fn a_null_map_a_wrong_stride_and_a_bad_config_are_statuses_with_messages() {
    let (w, h) = (8, 6);
    let dn = mosaic(w, h, w);
    let mut cfg = std::mem::MaybeUninit::<BpinsMapsConfig>::uninit();
    // SAFETY: a writable config.
    unsafe { bpins_maps_config_default(cfg.as_mut_ptr()) };
    // SAFETY: written just above.
    let mut cfg = unsafe { cfg.assume_init() };
    let (mut a, mut d, mut i) = (vec![0f32; w * h], vec![0f32; w * h], vec![0f32; w * h]);
    let null = std::ptr::null_mut();
    // SAFETY: NULL where the test says; otherwise buffers of the right size.
    let st = unsafe { bpins_stokes_maps_u16(dn.as_ptr(), w, h, w, &cfg, a.as_mut_ptr(), null, i.as_mut_ptr(), null) };
    assert_eq!(st, BpinsStatus::BPINS_ERR_NULL);
    assert!(last_error().contains("`dolp`"), "{}", last_error());
    // SAFETY: as above.
    let st = unsafe {
        bpins_stokes_maps_u16(dn.as_ptr(), w, h, w - 1, &cfg, a.as_mut_ptr(), d.as_mut_ptr(), i.as_mut_ptr(), null)
    };
    assert_eq!(st, BpinsStatus::BPINS_ERR_FRAME_SIZE);
    assert!(last_error().contains("stride"), "{}", last_error());
    cfg.mosaic_deg = [[90, 45], [45, 0]];
    // SAFETY: as above.
    let st = unsafe {
        bpins_stokes_maps_u16(dn.as_ptr(), w, h, w, &cfg, a.as_mut_ptr(), d.as_mut_ptr(), i.as_mut_ptr(), null)
    };
    assert_eq!(st, BpinsStatus::BPINS_ERR_CONFIG);
    assert!(last_error().contains("mosaic_deg"), "{}", last_error());
}
