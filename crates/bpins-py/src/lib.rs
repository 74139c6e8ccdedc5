//! Python bindings of bpins (`import bpins`): the front door (`compass.rs`), simulated
//! frames with their truth (`sim.rs`), `fit` and `diagnose` on a capture with the
//! data of fit.json and diagnosis.json (`fit.rs`), capture folders to and from arrays and the
//! effect catalog (`capture.rs`). Every failure is a Python exception naming the
//! argument and what was expected (`ValueError` for a bad value, `TypeError` for a
//! wrong type, `OSError` for a file that cannot be read: `FileNotFoundError` where it
//! is not there), never a crash of the interpreter: the crate's typed errors are
//! turned into exceptions here, and bpins-core does not panic on input. Whole-number
//! arguments are taken as Python ints and checked here ([`whole`]), so a negative one
//! is a `ValueError` naming the argument, not PyO3's nameless `OverflowError`.
//!
//! The Python-facing docs (units, frames) are in the docstrings and in
//! `python/bpins/_bpins.pyi`.

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::prelude::*;

mod array;
mod capture;
mod compass;
mod fit;
mod locate;
mod maps;
mod sim;

/// A bpins-core error as the Python exception a user expects: files that cannot be
/// read are `OSError` (`FileNotFoundError` where the file or capture folder is not
/// there), everything else is a `ValueError` with bpins' message (which names the
/// file, key and frame). The message carries the error's sources: the OS's words
/// ("No such file or directory"), not the path alone.
pub(crate) fn py_err(e: bpins_core::Error) -> PyErr {
    py_err_in("", e)
}

/// [`py_err`], the message starting with `prefix` (an argument's name and ": ").
pub(crate) fn py_err_in(prefix: &str, e: bpins_core::Error) -> PyErr {
    let text = format!("{prefix}{}", bpins_core::error::full_message(&e));
    match &e {
        bpins_core::Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(text)
        }
        bpins_core::Error::Io { .. } => PyOSError::new_err(text),
        // A capture folder without capture.toml (bpins-core says so in words, as a
        // capture error): a file error to Python too.
        bpins_core::Error::Capture { message, .. } if message == bpins_core::error::CAPTURE_NOT_FOUND => {
            PyFileNotFoundError::new_err(text)
        }
        _ => PyValueError::new_err(text),
    }
}

/// A whole-number argument as the type bpins takes, or a `ValueError` naming it.
pub(crate) fn whole<T: TryFrom<i64>>(name: &str, v: i64) -> PyResult<T> {
    T::try_from(v).map_err(|_| {
        let why = if v < 0 { "expected a whole number ≥ 0" } else { "too large" };
        PyValueError::new_err(format!("{name} = {v}: {why}"))
    })
}

/// A finite-number check on a named argument.
pub(crate) fn finite(name: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(PyValueError::new_err(format!("{name} = {v}: expected a finite number")))
    }
}

#[pymodule]
fn _bpins(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<compass::Compass>()?;
    m.add_class::<compass::Heading>()?;
    m.add_function(wrap_pyfunction!(sim::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(maps::stokes_maps, m)?)?;
    m.add_function(wrap_pyfunction!(capture::read_capture, m)?)?;
    m.add_function(wrap_pyfunction!(capture::write_capture, m)?)?;
    m.add_function(wrap_pyfunction!(capture::effects, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit, m)?)?;
    m.add_function(wrap_pyfunction!(fit::diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(locate::locate, m)?)?;
    Ok(())
}
