//! # bpins-capi: the front door from C and C++
//!
//! A C ABI around [`bpins_core::compass::Compass`] for hosts that are not Rust (a ROS 2
//! node, a flight controller's C++): an opaque handle built once from the camera, the
//! sensor and (optionally) a `calibration.toml`; per frame the camera's buffer
//! (borrowed, `uint8_t`, `uint16_t` or `float`, with a row stride; never copied), the
//! sun and the attitude in, a plain struct with the heading and its 1σ out.
//!
//! The header is `include/bpins.h`, generated from this crate by cbindgen
//! (`cbindgen.toml`) and checked in; `tests/header.rs` fails when it is stale and says
//! how to regenerate it. The C example is `examples/c/heading.c` at the repository
//! root; `tests/c_example.rs` compiles it against `libbpins.a` and runs it on the clean
//! sample.
//!
//! Rules of the boundary:
//! - every function that can fail returns a [`BpinsStatus`]; the failure's message is
//!   [`bpins_last_error_message`] (per thread);
//! - a NULL pointer is an error ([`BpinsStatus::BPINS_ERR_NULL`]), never dereferenced;
//! - no panic crosses it: every body runs under `catch_unwind`
//!   ([`BpinsStatus::BPINS_ERR_PANIC`] if one happened, which is a bug to report);
//! - nothing is printed; nothing the caller owns is written except the `out` argument:
//!   a heading's only on success, a new handle's set to NULL on failure.

mod compass;
mod maps;
mod types;

pub use compass::*;
pub use maps::*;
pub use types::*;

use std::cell::RefCell;
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// What a call did: `BPINS_OK`, or why it failed (the message is
/// `bpins_last_error_message()`).
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BpinsStatus {
    /// Success; the `out` argument was written.
    BPINS_OK = 0,
    /// A required pointer argument was NULL (nothing was read or written through it).
    BPINS_ERR_NULL = 1,
    /// The compass's configuration is invalid (sensor size, bit depth, black level,
    /// lens, mosaic, extractor or an estimator option).
    BPINS_ERR_CONFIG = 2,
    /// The frame does not match the sensor (width, height, stride), or its buffer is
    /// not aligned for its sample type.
    BPINS_ERR_FRAME_SIZE = 3,
    /// The sun is invalid (an angle that is not a number, an elevation outside
    /// −90°…90°, a negative 1σ, an unknown kind, a time SPA cannot take).
    BPINS_ERR_SUN = 4,
    /// The attitude is invalid (a tilt of 90° or more, a negative or NaN 1σ).
    BPINS_ERR_ATTITUDE = 5,
    /// The calibration file cannot be read (missing, not `bpins-calibration/1`, an
    /// unknown effect or parameter, a value out of range); the message names the file
    /// and the key.
    BPINS_ERR_CALIBRATION = 6,
    /// An error inside the library that is none of the above.
    BPINS_ERR_INTERNAL = 7,
    /// A panic was caught at the boundary (a bug in bpins: please report the message).
    BPINS_ERR_PANIC = 8,
}

/// A failed call: its status and its message.
#[derive(Debug)]
pub(crate) struct Failure {
    pub status: BpinsStatus,
    pub message: String,
}

impl Failure {
    pub(crate) fn new(status: BpinsStatus, message: impl Into<String>) -> Self {
        Failure { status, message: message.into() }
    }
}

thread_local! {
    /// The message of this thread's last failed call (empty until one fails).
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_last_error(message: &str) {
    // An interior NUL would cut the message short: show it instead.
    let c = CString::new(message.replace('\0', "\\0")).unwrap_or_default();
    let _ = LAST_ERROR.try_with(|e| *e.borrow_mut() = c);
}

/// Runs one call's body: its status, its message kept for `bpins_last_error_message`,
/// a panic caught and turned into `BPINS_ERR_PANIC`.
pub(crate) fn guard(body: impl FnOnce() -> Result<(), Failure>) -> BpinsStatus {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => BpinsStatus::BPINS_OK,
        Ok(Err(f)) => {
            set_last_error(&f.message);
            f.status
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic without a message".into());
            set_last_error(&format!("internal error in bpins (a panic, caught at the C boundary): {what}"));
            BpinsStatus::BPINS_ERR_PANIC
        }
    }
}

/// The message of the last call on this thread that did not return `BPINS_OK`
/// (UTF-8, NUL-terminated; "" if none has failed yet). Owned by the library: valid
/// until the next failing call on the same thread; copy it to keep it. Successful
/// calls leave it as it was.
#[no_mangle]
pub extern "C" fn bpins_last_error_message() -> *const c_char {
    static EMPTY: &[u8] = b"\0";
    catch_unwind(|| LAST_ERROR.try_with(|e| e.borrow().as_ptr()).unwrap_or(EMPTY.as_ptr().cast()))
        .unwrap_or(EMPTY.as_ptr().cast())
}

/// The library's version, "major.minor.patch" (NUL-terminated, static).
#[no_mangle]
pub extern "C" fn bpins_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::CStr;

    fn last() -> String {
        unsafe { CStr::from_ptr(bpins_last_error_message()) }.to_str().unwrap().to_string()
    }

    #[test]
    fn a_panic_becomes_a_status_and_a_message_and_success_keeps_the_last_message() {
        let s = guard(|| panic!("boom {}", 42));
        assert_eq!(s, BpinsStatus::BPINS_ERR_PANIC);
        assert!(last().contains("boom 42"), "{}", last());
        assert_eq!(guard(|| Ok(())), BpinsStatus::BPINS_OK);
        assert!(last().contains("boom 42"));
        let s = guard(|| Err(Failure::new(BpinsStatus::BPINS_ERR_SUN, "a\0b")));
        assert_eq!((s, last().as_str()), (BpinsStatus::BPINS_ERR_SUN, "a\\0b"));
        // Per thread: another thread has seen no failure.
        assert_eq!(std::thread::spawn(last).join().unwrap(), "");
    }

    #[test]
    fn the_version_is_the_crates() {
        let v = unsafe { CStr::from_ptr(bpins_version()) }.to_str().unwrap();
        assert_eq!(v, env!("CARGO_PKG_VERSION"));
    }
}
