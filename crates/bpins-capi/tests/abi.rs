//! The C ABI called as C calls it (raw pointers, plain structs, status codes) on the
//! clean sample: the same headings as the Rust front door, bit for bit, for u16, u8,
//! f32 and strided buffers; and every failure a status with a message, nothing
//! written, nothing panicked.

mod common;

use bpins::*;
use bpins_core::calibration::Calibration;
use bpins_core::compass::{Compass, CompassConfig, RawImage, Sun};
use bpins_core::effects::EffectSet;
use std::ffi::{CStr, CString};
use std::mem::MaybeUninit;
use std::ptr::{null, null_mut};

fn last_error() -> String {
    unsafe { CStr::from_ptr(bpins_last_error_message()) }.to_str().unwrap().to_string()
}

fn c_config(cfg: &CompassConfig) -> BpinsCompassConfig {
    let mut c = MaybeUninit::uninit();
    assert_eq!(unsafe { bpins_compass_config_default(c.as_mut_ptr()) }, BpinsStatus::BPINS_OK);
    let mut c = unsafe { c.assume_init() };
    (c.width_px, c.height_px) = (cfg.width_px as u32, cfg.height_px as u32);
    (c.bit_depth, c.black_level_dn) = (cfg.bit_depth, cfg.black_level_dn);
    (c.focal_length_px, c.cx_px, c.cy_px) = (cfg.camera.f_px, cfg.camera.cx_px, cfg.camera.cy_px);
    c.mosaic_deg = cfg.mosaic.map(|row| row.map(|ch| ch.angle_deg() as u32));
    c
}

fn c_sun(sun: Sun) -> BpinsSun {
    let Sun::Angles { azimuth_deg, elevation_deg, sigma_deg } = sun else { unreachable!() };
    BpinsSun {
        kind: BPINS_SUN_ANGLES,
        azimuth_deg,
        elevation_deg,
        unix_time_s: f64::NAN,
        latitude_deg: f64::NAN,
        longitude_deg: f64::NAN,
        sigma_deg,
    }
}

fn c_att(s: &common::Sample) -> BpinsAttitude {
    let a = s.attitude;
    BpinsAttitude { tilt_x_deg: a.tilt_x_deg, tilt_y_deg: a.tilt_y_deg, sigma_deg: a.sigma_deg }
}

/// A new handle, or the status and the message.
fn new(cfg: &BpinsCompassConfig, calibration: Option<&str>) -> Result<*mut BpinsCompass, (BpinsStatus, String)> {
    let path = calibration.map(|p| CString::new(p).unwrap());
    let mut h: *mut BpinsCompass = std::ptr::dangling_mut(); // not NULL: the call must clear it
    let s = unsafe { bpins_compass_new_with_calibration(cfg, path.as_ref().map_or(null(), |p| p.as_ptr()), &mut h) };
    match s {
        BpinsStatus::BPINS_OK => Ok(h),
        s => {
            assert!(h.is_null(), "*out is NULL after a failure");
            Err((s, last_error()))
        }
    }
}

/// A heading through the ABI: the output struct, or the status and the message (the
/// output left as it was).
fn heading_u16(
    h: *mut BpinsCompass,
    raw: &[u16],
    (w, ht, stride): (usize, usize, usize),
    sun: &BpinsSun,
    att: &BpinsAttitude,
) -> Result<BpinsHeading, (BpinsStatus, String)> {
    let mut out = MaybeUninit::<BpinsHeading>::zeroed();
    let s = unsafe { bpins_compass_heading_u16(h, raw.as_ptr(), w, ht, stride, sun, att, out.as_mut_ptr()) };
    match s {
        BpinsStatus::BPINS_OK => Ok(unsafe { out.assume_init() }),
        s => {
            assert_eq!(unsafe { out.assume_init() }.heading_deg, 0.0, "out written on failure");
            Err((s, last_error()))
        }
    }
}

#[test]
fn the_abi_reads_every_sample_type_and_stride_as_the_rust_front_door() {
    let s = common::clean_frame(1);
    let (w, h) = (s.config.width_px, s.config.height_px);
    let mut rust = Compass::new(s.config.clone()).unwrap();
    let want = rust.heading(RawImage::packed(&s.raw, w, h), s.sun, s.attitude).unwrap();
    let (sun, att) = (c_sun(s.sun), c_att(&s));
    let handle = new(&c_config(&s.config), None).unwrap();

    let got = heading_u16(handle, &s.raw, (w, h, w), &sun, &att).unwrap();
    assert!(got.has_heading);
    assert_eq!(got.heading_deg.to_bits(), want.heading_deg().unwrap().to_bits());
    assert_eq!(got.sigma_deg.to_bits(), want.sigma_deg().unwrap().to_bits());
    assert_eq!((got.used_fraction, got.residual_rms_deg), (want.quality.used_fraction, want.quality.residual_rms_deg));
    assert_eq!(got.cells_used as usize, want.quality.cells_used);
    assert_eq!((got.reason, got.message[0]), (BpinsNoHeading::BPINS_NO_HEADING_NONE, 0));
    assert!((got.heading_deg - s.truth_deg).abs() < 2.0 * got.sigma_deg, "{} vs {}", got.heading_deg, s.truth_deg);

    // A padded buffer (a row stride of 640 samples), f32 DN: the same heading.
    let stride = 640;
    let mut padded = vec![u16::MAX; stride * h];
    for v in 0..h {
        padded[v * stride..][..w].copy_from_slice(&s.raw[v * w..][..w]);
    }
    let strided = heading_u16(handle, &padded[..(h - 1) * stride + w], (w, h, stride), &sun, &att).unwrap();
    assert_eq!(strided.heading_deg.to_bits(), got.heading_deg.to_bits());
    let f: Vec<f32> = s.raw.iter().map(|&x| x as f32).collect();
    let mut out = MaybeUninit::<BpinsHeading>::uninit();
    let st = unsafe { bpins_compass_heading_f32(handle, f.as_ptr(), w, h, w, &sun, &att, out.as_mut_ptr()) };
    assert_eq!(st, BpinsStatus::BPINS_OK);
    assert_eq!(unsafe { out.assume_init() }.heading_deg.to_bits(), got.heading_deg.to_bits());

    // An 8-bit camera: its own compass (bit depth 8, black level scaled), as in Rust.
    let mut cfg8 = s.config.clone();
    (cfg8.bit_depth, cfg8.black_level_dn) = (8, 4.0);
    let raw8: Vec<u8> = s.raw.iter().map(|&x| ((x as f64 / 16.0).round() as u8).max(1)).collect();
    let want8 = Compass::new(cfg8.clone()).unwrap().heading(RawImage::packed(&raw8, w, h), s.sun, s.attitude).unwrap();
    let h8 = new(&c_config(&cfg8), None).unwrap();
    let st = unsafe { bpins_compass_heading_u8(h8, raw8.as_ptr(), w, h, w, &sun, &att, out.as_mut_ptr()) };
    assert_eq!(st, BpinsStatus::BPINS_OK);
    assert_eq!(unsafe { out.assume_init() }.heading_deg.to_bits(), want8.heading_deg().unwrap().to_bits());
    unsafe {
        bpins_compass_free(h8);
        bpins_compass_free(handle);
        bpins_compass_free(null_mut()); // NULL is ignored
    }
}

#[test]
fn a_wrong_buffer_a_null_pointer_and_a_bad_sun_are_statuses_with_messages() {
    let s = common::clean_frame(0);
    let (w, h) = (s.config.width_px, s.config.height_px);
    let (sun, att) = (c_sun(s.sun), c_att(&s));
    let cfg = c_config(&s.config);
    let handle = new(&cfg, None).unwrap();

    // The wrong size, a stride under the width: refused before the buffer is read.
    let (st, msg) = heading_u16(handle, &s.raw[..(h - 1) * w], (w, h - 1, w), &sun, &att).unwrap_err();
    assert_eq!(st, BpinsStatus::BPINS_ERR_FRAME_SIZE);
    assert!(msg.contains("612 × 511 px") && msg.contains("612 × 512 px"), "{msg}");
    // A height of 0: no overflowed count of samples (issue 35 saw 18446744073709551615).
    let (st, msg) = heading_u16(handle, &s.raw[..0], (w, 0, w), &sun, &att).unwrap_err();
    assert_eq!(st, BpinsStatus::BPINS_ERR_FRAME_SIZE, "{msg}");
    assert!(msg.contains("height of 0") && msg.contains("612 × 512 px") && !msg.contains("18446744"), "{msg}");
    let (st, msg) = heading_u16(handle, &s.raw, (w, h, w - 2), &sun, &att).unwrap_err();
    assert_eq!(st, BpinsStatus::BPINS_ERR_FRAME_SIZE, "{msg}");
    assert!(msg.contains("stride 610"), "{msg}");
    // A buffer misaligned for u16.
    let bytes: Vec<u16> = vec![0; w * h + 1];
    let odd = unsafe { (bytes.as_ptr() as *const u8).add(1) } as *const u16;
    let mut out = MaybeUninit::<BpinsHeading>::uninit();
    let st = unsafe { bpins_compass_heading_u16(handle, odd, w, h, w, &sun, &att, out.as_mut_ptr()) };
    assert_eq!(st, BpinsStatus::BPINS_ERR_FRAME_SIZE);
    assert!(last_error().contains("not aligned"), "{}", last_error());

    // NULL for each pointer: BPINS_ERR_NULL naming the argument.
    let o = out.as_mut_ptr();
    let d = s.raw.as_ptr();
    type Call<'a> = Box<dyn Fn() -> BpinsStatus + 'a>;
    let calls: [(&str, Call); 8] = unsafe {
        [
            ("compass", Box::new(|| bpins_compass_heading_u16(null_mut(), d, w, h, w, &sun, &att, o))),
            ("data", Box::new(|| bpins_compass_heading_u16(handle, null(), w, h, w, &sun, &att, o))),
            ("sun", Box::new(|| bpins_compass_heading_u16(handle, d, w, h, w, null(), &att, o))),
            ("attitude", Box::new(|| bpins_compass_heading_u16(handle, d, w, h, w, &sun, null(), o))),
            ("out", Box::new(|| bpins_compass_heading_u16(handle, d, w, h, w, &sun, &att, null_mut()))),
            ("config", Box::new(|| bpins_compass_new(null(), &mut null_mut()))),
            ("out", Box::new(|| bpins_compass_new(&cfg, null_mut()))),
            ("out", Box::new(|| bpins_compass_config_default(null_mut()))),
        ]
    };
    for (name, call) in calls {
        assert_eq!(call(), BpinsStatus::BPINS_ERR_NULL, "{name}");
        assert_eq!(last_error(), format!("`{name}` is NULL"));
    }

    // A sun that is not a number, an unknown kind, a tilt past 90°.
    let nan = BpinsSun { elevation_deg: f64::NAN, ..sun };
    let (st, msg) = heading_u16(handle, &s.raw, (w, h, w), &nan, &att).unwrap_err();
    assert_eq!(st, BpinsStatus::BPINS_ERR_SUN);
    assert!(msg.contains("elevation NaN°"), "{msg}");
    let (st, msg) = heading_u16(handle, &s.raw, (w, h, w), &BpinsSun { kind: 7, ..sun }, &att).unwrap_err();
    assert!(st == BpinsStatus::BPINS_ERR_SUN && msg.contains("kind 7"), "{msg}");
    let tilted = BpinsAttitude { tilt_x_deg: 95.0, ..att };
    let (st, msg) = heading_u16(handle, &s.raw, (w, h, w), &sun, &tilted).unwrap_err();
    assert!(st == BpinsStatus::BPINS_ERR_ATTITUDE && msg.contains("95°"), "{msg}");

    // The handle still reads frames after all that; a sun under −10° is a frame
    // without a heading (BPINS_OK), not an error.
    assert!(heading_u16(handle, &s.raw, (w, h, w), &sun, &att).unwrap().has_heading);
    let night = heading_u16(handle, &s.raw, (w, h, w), &BpinsSun { elevation_deg: -20.0, ..sun }, &att).unwrap();
    assert!(!night.has_heading && night.heading_deg.is_nan());
    assert_eq!(night.reason, BpinsNoHeading::BPINS_NO_HEADING_SUN_TOO_LOW);
    let why = unsafe { CStr::from_ptr(night.message.as_ptr()) }.to_str().unwrap();
    assert!(why.contains("below the horizon"), "{why}");
    unsafe { bpins_compass_free(handle) };
}

/// The source added to `BpinsHeading` took padding after `has_heading`: the size and
/// every other field's offset are those of the headers without it (a caller built
/// against them still gets its fields where it looks).
#[test]
fn the_heading_struct_keeps_its_layout() {
    use std::mem::{offset_of, size_of};
    assert_eq!(size_of::<BpinsSource>(), 4);
    assert_eq!((offset_of!(BpinsHeading, has_heading), offset_of!(BpinsHeading, source)), (0, 4));
    assert_eq!(offset_of!(BpinsHeading, heading_deg), 8);
    assert_eq!(offset_of!(BpinsHeading, sun_elevation_offset_deg), 128);
    assert_eq!((offset_of!(BpinsHeading, reason), offset_of!(BpinsHeading, message)), (136, 140));
    assert_eq!(size_of::<BpinsHeading>(), 400);
}

#[test]
fn configs_and_calibrations_are_checked_and_used() {
    let s = common::clean_frame(0);
    let (w, h) = (s.config.width_px, s.config.height_px);
    let cfg = c_config(&s.config);
    for (bad, words) in [
        (BpinsCompassConfig { bit_depth: 17, ..cfg }, "bit depth 17"),
        (BpinsCompassConfig { black_level_dn: 5000.0, ..cfg }, "black level 5000"),
        (BpinsCompassConfig { focal_length_px: f64::NAN, ..cfg }, "focal length NaN"),
        (BpinsCompassConfig { width_px: 2, ..cfg }, "2 × 512"),
        (BpinsCompassConfig { projection: 9, ..cfg }, "projection 9"),
    ] {
        let (st, msg) = new(&bad, None).unwrap_err();
        assert_eq!(st, BpinsStatus::BPINS_ERR_CONFIG, "{msg}");
        assert!(msg.contains(words), "{words}: {msg}");
    }
    // The time and place form of the sun: NREL SPA in the library.
    let handle = new(&cfg, None).unwrap();
    let clock = BpinsSun {
        kind: BPINS_SUN_UNIX_TIME,
        unix_time_s: 1_782_009_000.0,
        latitude_deg: 36.07,
        longitude_deg: 120.38,
        ..c_sun(s.sun)
    };
    let r = heading_u16(handle, &s.raw, (w, h, w), &clock, &c_att(&s)).unwrap();
    let mut rust = Compass::new(s.config.clone()).unwrap();
    let t = Sun::UnixTime { time_s: 1_782_009_000.0, latitude_deg: 36.07, longitude_deg: 120.38, sigma_deg: 0.0 };
    let want = rust.heading(RawImage::packed(&s.raw, w, h), t, s.attitude).unwrap();
    assert_eq!(r.has_heading, want.result.is_ok());
    assert_eq!(r.used_fraction, want.quality.used_fraction);
    assert_eq!(r.source, BpinsSource::BPINS_SOURCE_SUN);
    // At night the clock reads the moon where it is up (2026-06-29T16:00:00Z at 20° N:
    // the full moon at 41.6°), as the Rust front door does; a moonless midnight
    // (2026-07-14T16:00:00Z at Qingdao) is a frame without a heading, typed.
    let moonlit = BpinsSun { unix_time_s: 1_782_748_800.0, latitude_deg: 20.0, ..clock };
    let r = heading_u16(handle, &s.raw, (w, h, w), &moonlit, &c_att(&s)).unwrap();
    let t = Sun::UnixTime { time_s: 1_782_748_800.0, latitude_deg: 20.0, longitude_deg: 120.38, sigma_deg: 0.0 };
    let want = rust.heading(RawImage::packed(&s.raw, w, h), t, s.attitude).unwrap();
    assert!(matches!(want.source, bpins_core::compass::SkySource::Moon(_)), "{:?}", want.source);
    assert_eq!((r.source, r.has_heading), (BpinsSource::BPINS_SOURCE_MOON, want.result.is_ok()));
    assert_eq!(r.sun_elevation_offset_deg.to_bits(), want.quality.sun_elevation_offset_deg.to_bits());
    let dark = BpinsSun { unix_time_s: 1_784_044_800.0, ..clock };
    let r = heading_u16(handle, &s.raw, (w, h, w), &dark, &c_att(&s)).unwrap();
    assert!(!r.has_heading && r.heading_deg.is_nan());
    assert_eq!((r.reason, r.source), (BpinsNoHeading::BPINS_NO_HEADING_DARK_NIGHT, BpinsSource::BPINS_SOURCE_SUN));
    let why = unsafe { CStr::from_ptr(r.message.as_ptr()) }.to_str().unwrap();
    assert!(why.starts_with("not yet: the moon is at"), "{why}");
    let bad_time = BpinsSun { unix_time_s: f64::NAN, ..clock };
    assert_eq!(
        heading_u16(handle, &s.raw, (w, h, w), &bad_time, &c_att(&s)).unwrap_err().0,
        BpinsStatus::BPINS_ERR_SUN
    );
    unsafe { bpins_compass_free(handle) };

    // A calibration: missing, malformed (named with its key), and a real one used.
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("missing.toml");
    let (st, msg) = new(&cfg, Some(missing.to_str().unwrap())).unwrap_err();
    assert!(st == BpinsStatus::BPINS_ERR_CALIBRATION && msg.contains("missing.toml"), "{msg}");
    // …and says what is wrong with it, not only its name.
    assert!(msg.contains("No such file or directory"), "{msg}");
    let broken = tmp.path().join("broken.toml");
    std::fs::write(&broken, "format = \"bpins-calibration/1\"\n[effects.no_such_effect]\nx = 1.0\n").unwrap();
    let (st, msg) = new(&cfg, Some(broken.to_str().unwrap())).unwrap_err();
    assert!(st == BpinsStatus::BPINS_ERR_CALIBRATION && msg.contains("no_such_effect"), "{msg}");
    let mut effects = EffectSet::new();
    effects.set("array_rotation", "dtheta_deg", 0.5).unwrap();
    let cal = Calibration { effects, ..Default::default() };
    let good = tmp.path().join("calibration.toml");
    std::fs::write(&good, cal.to_toml()).unwrap();
    let handle = new(&cfg, Some(good.to_str().unwrap())).unwrap();
    let got = heading_u16(handle, &s.raw, (w, h, w), &c_sun(s.sun), &c_att(&s)).unwrap();
    let mut rust = Compass::new(CompassConfig { calibration: cal, ..s.config.clone() }).unwrap();
    let want = rust.heading(RawImage::packed(&s.raw, w, h), s.sun, s.attitude).unwrap().heading_deg().unwrap();
    assert_eq!(got.heading_deg.to_bits(), want.to_bits());
    let plain = Compass::new(s.config.clone()).unwrap().heading(RawImage::packed(&s.raw, w, h), s.sun, s.attitude);
    let shift = got.heading_deg - plain.unwrap().heading_deg().unwrap();
    assert!(shift.abs() > 0.2, "the calibration's 0.5° array rotation moves the heading ({shift}°)");
    unsafe { bpins_compass_free(handle) };
}

#[test]
fn a_sun_the_sky_contradicts_is_a_reason_code_with_its_message() {
    // The sky's sun as the sample gives it; the claim 30° lower (a wrong clock): no
    // heading, BPINS_NO_HEADING_CONTRADICTS, and the message says what to check. It used
    // to read 210.001° ± 0.016° for a truth of 30°.
    let s = common::clean_frame(2);
    let (w, h) = (s.config.width_px, s.config.height_px);
    let handle = new(&c_config(&s.config), None).unwrap();
    let mut sun = c_sun(s.sun);
    sun.elevation_deg -= 30.0;
    let got = heading_u16(handle, &s.raw, (w, h, w), &sun, &c_att(&s)).unwrap();
    assert!(!got.has_heading && got.heading_deg.is_nan());
    assert_eq!(got.reason, BpinsNoHeading::BPINS_NO_HEADING_CONTRADICTS);
    let message = unsafe { CStr::from_ptr(got.message.as_ptr()) }.to_str().unwrap().to_string();
    assert!(message.contains("contradicts") && message.contains("clock"), "{message}");
    assert!(got.sun_elevation_offset_deg.abs() > 10.0, "{}", got.sun_elevation_offset_deg);
    unsafe { bpins_compass_free(handle) };
}
