//! `bpins.locate`: north, latitude and longitude from a capture folder of frames over
//! time without a place (bpins_core::locate; docs/locate.md), as `bpins locate` finds
//! them; the answer as a dict, "not yet" as a `ValueError` saying why.

use crate::{finite, py_err};
use bpins_core::compass::FieldOptions;
use bpins_core::effects::EffectSet;
use bpins_core::{locate as locate_obs, measure, Capture, LocateError, LocateOptions, Site, SunObs};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// A locate error as the Python exception: files as `OSError`, the rest `ValueError`.
fn locate_err(e: LocateError) -> PyErr {
    match e {
        LocateError::Core(e) => py_err(e),
        e => PyValueError::new_err(e.to_string()),
    }
}

/// Locates the camera from a capture folder whose frames carry `time_utc`.
///
/// locate(capture, *, calibration=None, pole=False, max_heading_sigma_deg=2.0,
///        max_latitude_sigma_deg=2.0, max_longitude_sigma_deg=3.0, site_out=None) -> dict
///
/// Returns {"route": "stamped" | "pole", "heading_deg" (the camera's heading at the
/// first frame), "heading_sigma_deg", "latitude_deg", "latitude_sigma_deg",
/// "longitude_deg", "longitude_sigma_deg" (None on the pole route), "frames_used",
/// "span_s", "chi2_per_dof", "frames": per frame "index", "time_unix_s", "yaw_deg" and
/// "sun" (bearing_deg, elevation_deg and their 1σ) or "no_sun" (why)}. Degrees
/// throughout, 1σ. A sequence too short or too cloudy for the asked bounds raises
/// `ValueError` ("not yet: …"). `site_out`: also write the site file (bpins-site/1)
/// that `Compass.heading(site=…)` and `bpins heading --site` take. The GIL is
/// released while it reads the frames.
#[pyfunction]
#[pyo3(signature = (capture, *, calibration=None, pole=false, max_heading_sigma_deg=2.0,
    max_latitude_sigma_deg=2.0, max_longitude_sigma_deg=3.0, site_out=None))]
#[allow(clippy::too_many_arguments)]
pub fn locate<'py>(
    py: Python<'py>,
    capture: PathBuf,
    calibration: Option<PathBuf>,
    pole: bool,
    max_heading_sigma_deg: f64,
    max_latitude_sigma_deg: f64,
    max_longitude_sigma_deg: f64,
    site_out: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let opts = LocateOptions {
        max_heading_sigma_deg: finite("max_heading_sigma_deg", max_heading_sigma_deg)?,
        max_latitude_sigma_deg: finite("max_latitude_sigma_deg", max_latitude_sigma_deg)?,
        max_longitude_sigma_deg: finite("max_longitude_sigma_deg", max_longitude_sigma_deg)?,
        pole_only: pole,
    };
    let (located, frames, first_time) = py.detach(|| -> PyResult<_> {
        let known = match &calibration {
            Some(p) => bpins_core::calibration::Calibration::load(p).map_err(py_err)?.effects,
            None => EffectSet::new(),
        }
        .model();
        let c = Capture::load_unplaced(&capture).map_err(py_err)?;
        let frames = measure(&c, &known, &FieldOptions::default(), |_| {}).map_err(locate_err)?;
        let obs: Vec<SunObs> = frames.iter().filter_map(|f| f.obs()).collect();
        let first_time = frames
            .iter()
            .find(|f| f.sun.is_ok())
            .and_then(|f| c.frames[f.index].sun.source.time_utc().map(str::to_string));
        Ok((locate_obs(&obs, &opts).map_err(locate_err)?, frames, first_time))
    })?;
    if let Some(p) = &site_out {
        Site::from_located(&located, first_time).write(p).map_err(py_err)?;
    }
    let mut v = serde_json::to_value(&located).map_err(|e| PyValueError::new_err(e.to_string()))?;
    v["frames"] = frames
        .iter()
        .map(|f| match &f.sun {
            Ok(s) => {
                serde_json::json!({ "index": f.index, "time_unix_s": f.time_unix_s, "yaw_deg": f.yaw_deg, "sun": s })
            }
            Err(why) => {
                serde_json::json!({ "index": f.index, "time_unix_s": f.time_unix_s, "no_sun": why.to_string() })
            }
        })
        .collect();
    py.import("json")?.call_method1("loads", (v.to_string(),))
}
