//! Python bindings of bpins (`import bpins`): the front door (`compass.rs`), simulated
//! frames with their truth (`sim.rs`), `fit` and `diagnose` on a capture with the
//! data of fit.json and diagnosis.json (`fit.rs`), capture folders to and from arrays and the
//! effect catalog (`capture.rs`). Every failure is a Python exception naming the
//! argument and what was expected (`ValueError` for a bad value, `TypeError` for a
//! wrong type), never a crash of the interpreter: the crate's typed errors are
//! turned into exceptions here, and bpins-core does not panic on input.
//!
//! The Python-facing docs (units, frames) are in the docstrings and in
//! `python/bpins/_bpins.pyi`.

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

mod array;
mod capture;
mod compass;
mod fit;
mod sim;

/// A bpins-core error as the Python exception a user expects: files that cannot be
/// read are `OSError`, everything else is a `ValueError` with bpins' message (which
/// names the file, key and frame).
pub(crate) fn py_err(e: bpins_core::Error) -> PyErr {
    match e {
        bpins_core::Error::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
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
    m.add_function(wrap_pyfunction!(sim::stokes_maps, m)?)?;
    m.add_function(wrap_pyfunction!(capture::read_capture, m)?)?;
    m.add_function(wrap_pyfunction!(capture::write_capture, m)?)?;
    m.add_function(wrap_pyfunction!(capture::effects, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit, m)?)?;
    m.add_function(wrap_pyfunction!(fit::diagnose, m)?)?;
    Ok(())
}
