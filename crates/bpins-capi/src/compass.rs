//! The front door's handle: `bpins_compass_new` (or `_with_calibration`) once,
//! `bpins_compass_heading_u16` (`_u8`, `_f32`) per frame, `bpins_compass_free` at the
//! end. One handle per camera and thread: it holds the estimator's buffers between
//! frames (no allocation per frame once warm); different handles may be used on
//! different threads at once, one handle must not.

use crate::types::{BpinsAttitude, BpinsCompassConfig, BpinsHeading, BpinsSun};
use crate::{guard, BpinsStatus, Failure};
use bpins_core::calibration::Calibration;
use bpins_core::compass::{Compass, CompassError};
use bpins_core::compass::{RawDn, RawImage};
use std::ffi::{c_char, CStr};

/// A compass: the camera, the sensor and its calibration, with the estimator's
/// buffers. Opaque; made by `bpins_compass_new`, released by `bpins_compass_free`.
pub struct BpinsCompass {
    compass: Compass,
    width_px: usize,
    height_px: usize,
}

/// `ptr` as a reference, or `BPINS_ERR_NULL` naming the argument.
///
/// # Safety
/// A non-NULL `ptr` points to a valid `T` (the caller's promise).
unsafe fn arg<'a, T>(ptr: *const T, name: &str) -> Result<&'a T, Failure> {
    // SAFETY: non-NULL is checked here; validity is the caller's contract.
    unsafe { ptr.as_ref() }.ok_or_else(|| Failure::new(BpinsStatus::BPINS_ERR_NULL, format!("`{name}` is NULL")))
}

fn status_of(e: &CompassError) -> BpinsStatus {
    match e {
        CompassError::Config(_) => BpinsStatus::BPINS_ERR_CONFIG,
        CompassError::FrameSize { .. } => BpinsStatus::BPINS_ERR_FRAME_SIZE,
        CompassError::Sun(_) => BpinsStatus::BPINS_ERR_SUN,
        CompassError::Attitude(_) => BpinsStatus::BPINS_ERR_ATTITUDE,
        CompassError::Core(_) => BpinsStatus::BPINS_ERR_INTERNAL,
    }
}

fn failure(e: CompassError) -> Failure {
    Failure::new(status_of(&e), bpins_core::error::full_message(&e))
}

/// Fills `*out` with the defaults: pinhole lens, the IMX250MZR mosaic
/// {{90, 45}, {135, 0}}, the sun-vector extractor and the field estimator's default
/// options. The sensor's size, bit depth, black level and the lens's focal length and
/// principal point are left 0: set them before `bpins_compass_new`.
///
/// # Safety
/// `out` is NULL or points to writable memory for one `BpinsCompassConfig`.
#[no_mangle]
pub unsafe extern "C" fn bpins_compass_config_default(out: *mut BpinsCompassConfig) -> BpinsStatus {
    guard(|| {
        if out.is_null() {
            return Err(Failure::new(BpinsStatus::BPINS_ERR_NULL, "`out` is NULL"));
        }
        // SAFETY: non-NULL, writable by the caller's contract; `write` reads nothing.
        unsafe { out.write(BpinsCompassConfig::default_values()) };
        Ok(())
    })
}

fn build(config: &BpinsCompassConfig, calibration: Calibration) -> Result<*mut BpinsCompass, Failure> {
    let mut cfg = config.to_core()?;
    cfg.calibration = calibration;
    let (width_px, height_px) = (cfg.width_px, cfg.height_px);
    let compass = Compass::new(cfg).map_err(|e| match e {
        // Preparing the reconstruction from the sensor's settings: still the config.
        CompassError::Core(c) => {
            Failure::new(BpinsStatus::BPINS_ERR_CONFIG, format!("the compass's configuration: {c}"))
        }
        e => failure(e),
    })?;
    Ok(Box::into_raw(Box::new(BpinsCompass { compass, width_px, height_px })))
}

/// Builds a compass from `*config` without a calibration. On success `*out` is the
/// new handle (free it with `bpins_compass_free`); on failure `*out` is NULL.
///
/// # Safety
/// `config` is NULL or points to a `BpinsCompassConfig`; `out` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn bpins_compass_new(
    config: *const BpinsCompassConfig,
    out: *mut *mut BpinsCompass,
) -> BpinsStatus {
    // SAFETY: passed on under the same contract.
    unsafe { bpins_compass_new_with_calibration(config, std::ptr::null(), out) }
}

/// Builds a compass from `*config` and the calibration file at `calibration_path`
/// (UTF-8 or the platform's bytes, NUL-terminated; a `calibration.toml` as
/// `bpins fit` writes it). A NULL `calibration_path` means no calibration. On success
/// `*out` is the new handle; on failure `*out` is NULL and the message names the file
/// and the key (`BPINS_ERR_CALIBRATION`).
///
/// # Safety
/// `config` is NULL or points to a `BpinsCompassConfig`; `calibration_path` is NULL or
/// a NUL-terminated string; `out` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn bpins_compass_new_with_calibration(
    config: *const BpinsCompassConfig,
    calibration_path: *const c_char,
    out: *mut *mut BpinsCompass,
) -> BpinsStatus {
    guard(|| {
        if out.is_null() {
            return Err(Failure::new(BpinsStatus::BPINS_ERR_NULL, "`out` is NULL"));
        }
        // SAFETY: non-NULL and writable by the caller's contract.
        unsafe { out.write(std::ptr::null_mut()) };
        // SAFETY: the caller's contract.
        let config = unsafe { arg(config, "config") }?;
        let calibration = if calibration_path.is_null() {
            Calibration::default()
        } else {
            // SAFETY: a NUL-terminated string by the caller's contract.
            let bytes = unsafe { CStr::from_ptr(calibration_path) }.to_bytes();
            Calibration::load(&path_from_bytes(bytes)?).map_err(|e| {
                let e = bpins_core::error::full_message(&e);
                Failure::new(BpinsStatus::BPINS_ERR_CALIBRATION, format!("calibration: {e}"))
            })?
        };
        let handle = build(config, calibration)?;
        // SAFETY: as above.
        unsafe { out.write(handle) };
        Ok(())
    })
}

#[cfg(unix)]
fn path_from_bytes(bytes: &[u8]) -> Result<std::path::PathBuf, Failure> {
    use std::os::unix::ffi::OsStrExt;
    Ok(std::ffi::OsStr::from_bytes(bytes).into())
}

#[cfg(not(unix))]
fn path_from_bytes(bytes: &[u8]) -> Result<std::path::PathBuf, Failure> {
    std::str::from_utf8(bytes)
        .map(Into::into)
        .map_err(|_| Failure::new(BpinsStatus::BPINS_ERR_CALIBRATION, "calibration: the path is not UTF-8"))
}

/// Releases a compass. NULL is ignored; a handle must not be used after it.
///
/// # Safety
/// `compass` is NULL or a handle from `bpins_compass_new*` not yet freed.
#[no_mangle]
pub unsafe extern "C" fn bpins_compass_free(compass: *mut BpinsCompass) {
    if !compass.is_null() {
        // SAFETY: made by Box::into_raw in `build`, not yet freed (the contract).
        let _ = std::panic::catch_unwind(|| drop(unsafe { Box::from_raw(compass) }));
    }
}

/// One frame through the compass: the buffer checked against the sensor before a
/// slice is made of it, then the front door.
///
/// # Safety
/// As the exported functions below.
#[allow(clippy::too_many_arguments)]
unsafe fn heading<T: RawDn>(
    compass: *mut BpinsCompass,
    data: *const T,
    width_px: usize,
    height_px: usize,
    stride: usize,
    sun: *const BpinsSun,
    attitude: *const BpinsAttitude,
    out: *mut BpinsHeading,
    bands: bool,
) -> BpinsStatus {
    guard(|| {
        let null = |name: &str| Failure::new(BpinsStatus::BPINS_ERR_NULL, format!("`{name}` is NULL"));
        if out.is_null() {
            return Err(null("out"));
        }
        // SAFETY: non-NULL; a live handle by the caller's contract, used by one thread.
        let c = unsafe { compass.as_mut() }.ok_or_else(|| null("compass"))?;
        if data.is_null() {
            return Err(null("data"));
        }
        // SAFETY: the caller's contract.
        let sun = unsafe { arg(sun, "sun") }?.to_core()?;
        // SAFETY: the caller's contract.
        let attitude = (*unsafe { arg(attitude, "attitude") }?).into();
        // The buffer's extent, from the caller's sizes: refused unless they are the
        // sensor's, so no slice longer than the sensor's frame is ever made.
        let len = height_px.checked_sub(1).and_then(|r| r.checked_mul(stride)).and_then(|n| n.checked_add(width_px));
        let fits = width_px == c.width_px && height_px == c.height_px && stride >= width_px;
        let len = match len {
            Some(n) if fits && n.checked_mul(std::mem::size_of::<T>()).is_some_and(|b| b <= isize::MAX as usize) => n,
            Some(n) => {
                return Err(failure(CompassError::FrameSize {
                    got_w: width_px,
                    got_h: height_px,
                    stride,
                    len: n,
                    want_w: c.width_px,
                    want_h: c.height_px,
                }))
            }
            // No extent to state (a height of 0, or sizes whose product overflows).
            None => {
                let why = if height_px == 0 { "a height of 0 has no rows" } else { "its extent overflows" };
                return Err(Failure::new(
                    BpinsStatus::BPINS_ERR_FRAME_SIZE,
                    format!(
                        "frame of {width_px} × {height_px} px (stride {stride}): {why}; the sensor's frame is {} × {} px \
                         (give its width and height, a stride ≥ the width)",
                        c.width_px, c.height_px
                    ),
                ));
            }
        };
        if !(data as usize).is_multiple_of(std::mem::align_of::<T>()) {
            return Err(Failure::new(
                BpinsStatus::BPINS_ERR_FRAME_SIZE,
                format!("`data` at {data:p} is not aligned to {} bytes", std::mem::align_of::<T>()),
            ));
        }
        // SAFETY: non-NULL, aligned, and (the caller's contract) `len` readable samples:
        // rows 0…height−1 of `width` samples each, `stride` samples apart.
        let samples = unsafe { std::slice::from_raw_parts(data, len) };
        let frame = RawImage { data: samples, width_px, height_px, stride };
        if bands {
            let extractor = c.compass.extractor();
            let fix = c.compass.colour_headings(frame, sun, attitude, &[extractor]).map_err(failure)?;
            for (b, hs) in &fix.bands {
                // SAFETY: non-NULL and three writable headings by the caller's contract;
                // a band's index is 0, 1 or 2.
                unsafe { out.add(b.index()).write(BpinsHeading::from(&hs[0])) };
            }
            return Ok(());
        }
        let fix = c.compass.heading(frame, sun, attitude).map_err(failure)?;
        // SAFETY: non-NULL and writable by the caller's contract; `write` reads nothing.
        unsafe { out.write(BpinsHeading::from(&fix)) };
        Ok(())
    })
}

/// The heading of one raw DoFP frame of 16-bit samples (DN, right-aligned: a 12-bit
/// camera's values are 0…4095) under `*sun` at `*attitude`, into `*out`.
/// `width_px` × `height_px` must be the sensor's; `stride` is the distance between
/// rows' starts in samples, not bytes (≥ width; a ROS image's `step / 2`). The buffer
/// is read in place, never copied or kept. A frame whose sky gives no heading is
/// `BPINS_OK` with `out->has_heading` false; `*out` is written only on `BPINS_OK`.
///
/// # Safety
/// `compass` is NULL or a live handle not used by another thread meanwhile; `data` is
/// NULL or holds (height − 1)·stride + width readable samples; `sun`, `attitude` are
/// NULL or point to their structs; `out` is NULL or writable.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_compass_heading_u16(
    compass: *mut BpinsCompass,
    data: *const u16,
    width_px: usize,
    height_px: usize,
    stride: usize,
    sun: *const BpinsSun,
    attitude: *const BpinsAttitude,
    out: *mut BpinsHeading,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { heading(compass, data, width_px, height_px, stride, sun, attitude, out, false) }
}

/// As `bpins_compass_heading_u16`, for 8-bit samples (an 8-bit camera: DN 0…255; set
/// the config's bit depth to 8).
///
/// # Safety
/// As `bpins_compass_heading_u16`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_compass_heading_u8(
    compass: *mut BpinsCompass,
    data: *const u8,
    width_px: usize,
    height_px: usize,
    stride: usize,
    sun: *const BpinsSun,
    attitude: *const BpinsAttitude,
    out: *mut BpinsHeading,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { heading(compass, data, width_px, height_px, stride, sun, attitude, out, false) }
}

/// As `bpins_compass_heading_u16`, for `float` samples in DN (the same scale as the
/// integers: black level and full scale of the config's bit depth).
///
/// # Safety
/// As `bpins_compass_heading_u16`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_compass_heading_f32(
    compass: *mut BpinsCompass,
    data: *const f32,
    width_px: usize,
    height_px: usize,
    stride: usize,
    sun: *const BpinsSun,
    attitude: *const BpinsAttitude,
    out: *mut BpinsHeading,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { heading(compass, data, width_px, height_px, stride, sun, attitude, out, false) }
}

/// A colour compass's (config `colour_tiles` set) headings of one raw frame of 16-bit
/// samples, each band's from its own pixels: `out` holds three headings, written at
/// `BPINS_BAND_R`, `BPINS_BAND_G`, `BPINS_BAND_B` (their fused heading is
/// `bpins_compass_heading_u16`'s). Otherwise as `bpins_compass_heading_u16`; a
/// monochrome compass is `BPINS_ERR_CONFIG`.
///
/// # Safety
/// As `bpins_compass_heading_u16`, with `out` NULL or three writable headings.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_compass_band_headings_u16(
    compass: *mut BpinsCompass,
    data: *const u16,
    width_px: usize,
    height_px: usize,
    stride: usize,
    sun: *const BpinsSun,
    attitude: *const BpinsAttitude,
    out: *mut BpinsHeading,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { heading(compass, data, width_px, height_px, stride, sun, attitude, out, true) }
}

/// As `bpins_compass_band_headings_u16`, for 8-bit samples.
///
/// # Safety
/// As `bpins_compass_band_headings_u16`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_compass_band_headings_u8(
    compass: *mut BpinsCompass,
    data: *const u8,
    width_px: usize,
    height_px: usize,
    stride: usize,
    sun: *const BpinsSun,
    attitude: *const BpinsAttitude,
    out: *mut BpinsHeading,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { heading(compass, data, width_px, height_px, stride, sun, attitude, out, true) }
}

/// As `bpins_compass_band_headings_u16`, for `float` samples in DN.
///
/// # Safety
/// As `bpins_compass_band_headings_u16`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_compass_band_headings_f32(
    compass: *mut BpinsCompass,
    data: *const f32,
    width_px: usize,
    height_px: usize,
    stride: usize,
    sun: *const BpinsSun,
    attitude: *const BpinsAttitude,
    out: *mut BpinsHeading,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { heading(compass, data, width_px, height_px, stride, sun, attitude, out, true) }
}
