//! `bpins.fit` and `bpins.diagnose`: the model fitted to a capture folder, and the
//! catalog searched for what the model misses. They take what `bpins fit` and `bpins
//! diagnose` take ([`FitRequest`]) and return what those write to `fit.json` and
//! `diagnosis.json`, as a dict: one schema, serialised by the same structs
//! ([`FitJson`], [`DiagnosisJson`]; README, "fit.json and diagnosis.json").

use crate::{finite, py_err, whole};
use bpins_core::tool::diagnose::diagnose_frames;
use bpins_core::tool::diagnose::DiagnosisJson;
use bpins_core::tool::fit::{fit_from, FitJson, FitRequest};
use bpins_core::DiagnoseOptions;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// The request, its numbers checked with the argument's name.
fn request(
    capture: PathBuf,
    effects: Option<Vec<String>>,
    calibration: Option<PathBuf>,
    fixed_dmax: Option<f64>,
    trust_reference: bool,
    rayleigh_radiance: bool,
    all_pixels: bool,
    sample_budget_px: Option<usize>,
    model_colour_bands: bool,
) -> PyResult<FitRequest> {
    let min = bpins_core::tool::fit::MIN_BUDGET_PX;
    if let Some(b) = sample_budget_px.filter(|&b| b < min) {
        return Err(PyValueError::new_err(format!(
            "sample_budget_px = {b}: expected at least {min} (or None: every pixel)"
        )));
    }
    if let Some(d) = fixed_dmax {
        if !(0.0..=1.0).contains(&finite("fixed_dmax", d)?) {
            return Err(PyValueError::new_err(format!("fixed_dmax = {d}: expected a value in [0, 1]")));
        }
    }
    let effects = effects.unwrap_or_default();
    for name in &effects {
        bpins_core::effects::find(name).map_err(|e| PyValueError::new_err(format!("effects: {e}")))?;
    }
    Ok(FitRequest {
        capture,
        effects,
        trust_reference,
        fixed_dmax,
        rayleigh_radiance,
        calibration,
        all_pixels,
        sample_budget_px,
        model_colour_bands,
    })
}

/// A result serialised as its JSON file is (or the error doing so), as the dict
/// `json.loads` makes of it.
fn to_dict<'py>(py: Python<'py>, json: serde_json::Result<String>) -> PyResult<Bound<'py, PyAny>> {
    let text = json.map_err(|e| PyValueError::new_err(format!("serialising the result: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// Fits the model to a capture folder.
///
/// fit(capture, effects=None, *, calibration=None, fixed_dmax=None,
///     trust_reference=False, rayleigh_radiance=False, all_pixels=False,
///     sample_budget_px=524288) -> dict
///
/// `effects`: the catalog effects whose parameters are fitted (names of
/// `bpins.effects()`; default none: only each frame's heading, scale, radiance shape
/// and d_max; a colour capture's fit adds "sky_spectrum" where neither it nor
/// "band_response" is named, as "added" says). `calibration`: a calibration.toml whose effects are held at their values
/// and whose per-pixel maps are applied. `fixed_dmax`: the sky's peak DoLP in [0, 1]
/// when known. `sample_budget_px`: most pixels of each frame read (a larger frame
/// is fitted on a seeded sample of whole 2 × 2 tiles, its 1σ grown as "sample" says;
/// None reads every pixel). Returns the dict `bpins fit` writes as fit.json: "capture", "effects",
/// "params" (name with unit suffix, value, sigma (1σ), unit), "chi2_per_dof", "noise",
/// "aop_rms_deg", "dolp_rms", "frames" (per frame: heading_deg and its 1σ, reference,
/// error, scale_dn, dmax, radiance, chi2_per_dof), ... The GIL is released while it fits.
#[pyfunction]
#[pyo3(signature = (capture, effects=None, *, calibration=None, fixed_dmax=None, trust_reference=false,
    rayleigh_radiance=false, all_pixels=false, sample_budget_px=Some(bpins_core::tool::fit::DEFAULT_BUDGET_PX as i64)))]
#[allow(clippy::too_many_arguments)]
pub fn fit<'py>(
    py: Python<'py>,
    capture: PathBuf,
    effects: Option<Vec<String>>,
    calibration: Option<PathBuf>,
    fixed_dmax: Option<f64>,
    trust_reference: bool,
    rayleigh_radiance: bool,
    all_pixels: bool,
    sample_budget_px: Option<i64>,
) -> PyResult<Bound<'py, PyAny>> {
    let sample_budget_px = sample_budget_px.map(|b| whole("sample_budget_px", b)).transpose()?;
    let req = request(
        capture,
        effects,
        calibration,
        fixed_dmax,
        trust_reference,
        rayleigh_radiance,
        all_pixels,
        sample_budget_px,
        true,
    )?;
    let text = py
        .detach(|| {
            let l = req.load(&|_, _| {})?;
            let first = fit_from(&l.capture, &l.frames, &l.options, None, &|_, _| {})?;
            // Where the sample cannot decide a parameter every pixel could: more pixels.
            let (l, r) = req.raise_where_needed(l, first, &|_, _| {})?;
            Ok::<_, bpins_core::Error>(serde_json::to_string(&FitJson::new(&req.capture, &l.options, &l.added, &r)))
        })
        .map_err(py_err)?;
    to_dict(py, text)
}

/// Diagnoses a capture: fits the given model, asks every other catalog effect how
/// much it would explain, adds the winner while the evidence pays for it, and says
/// what remains unexplained and what the capture cannot separate.
///
/// diagnose(capture, effects=None, *, max_added=3, calibration=None,
///          fixed_dmax=None, trust_reference=False, rayleigh_radiance=False,
///          all_pixels=False, sample_budget_px=524288) -> dict
///
/// The arguments are `fit`'s (`effects`: the model to start from and keep) and
/// `max_added`, the most effects added. Returns the dict `bpins diagnose` writes as
/// diagnosis.json: "selected" (effect names named, in order), "negligible" (effects
/// detected but too small to matter), "steps" (each "model" beside a fit.json's
/// fields), "rankings" (the candidates of each step with delta_chi2, delta_bic,
/// "evidence" ("score", "subsample_refit", "every_pixel_score" or "every_pixel_refit":
/// what those figures rest on), "size" (heading, AoP, DoLP and DN change) and
/// "outside_physical" (each fitted value outside its physical range as numbers: name,
/// value, sigma, min, max, unit, and the same in "words")), "remains" (what the final
/// model leaves; its "unphysical" as "outside_physical"), "inseparable" ([effect,
/// reason] pairs), "confusable" (pairs: first, second, what separates them),
/// "unexplained" (bool) and "unexplained_summary" (words). The GIL is released.
#[pyfunction]
#[pyo3(signature = (capture, effects=None, *, max_added=3, calibration=None, fixed_dmax=None,
    trust_reference=false, rayleigh_radiance=false, all_pixels=false,
    sample_budget_px=Some(bpins_core::tool::fit::DEFAULT_BUDGET_PX as i64)))]
#[allow(clippy::too_many_arguments)]
pub fn diagnose<'py>(
    py: Python<'py>,
    capture: PathBuf,
    effects: Option<Vec<String>>,
    max_added: i64,
    calibration: Option<PathBuf>,
    fixed_dmax: Option<f64>,
    trust_reference: bool,
    rayleigh_radiance: bool,
    all_pixels: bool,
    sample_budget_px: Option<i64>,
) -> PyResult<Bound<'py, PyAny>> {
    let max_added_n: usize = whole("max_added", max_added)?;
    let sample_budget_px = sample_budget_px.map(|b| whole("sample_budget_px", b)).transpose()?;
    let req = request(
        capture,
        effects,
        calibration,
        fixed_dmax,
        trust_reference,
        rayleigh_radiance,
        all_pixels,
        sample_budget_px,
        // The search starts from the model given (no band effect added).
        false,
    )?;
    let text = py
        .detach(|| {
            let l = req.load(&|_, _| {})?;
            let opts = DiagnoseOptions { base: l.options.clone(), max_added: max_added_n, ..Default::default() };
            let d = diagnose_frames(&l.capture, &l.frames, &opts, &|_| {})?;
            // The final model on more pixels where its 1σ needs them, as the CLI does.
            let (_, d) = req.raise_diagnosis_where_needed(l, d, &|_, _| {})?;
            Ok::<_, bpins_core::Error>(serde_json::to_string(&DiagnosisJson::new(&req.capture, &d)))
        })
        .map_err(py_err)?;
    to_dict(py, text)
}
