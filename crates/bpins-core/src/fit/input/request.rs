//! What a fit (and a diagnosis, which reads its capture the same way) is asked, and
//! what a fit writes, in one place for every front end (the CLI, the Python package): a
//! [`FitRequest`] names the capture, the model's effects, the options and a
//! calibration, and [`FitRequest::load`] checks it and reads the capture into
//! [`FitOptions`] and frames (a fit of a colour capture adding `sky_spectrum` where
//! the request names no band effect: [`AddedEffect`]); [`FitJson`] is `fit.json`
//! (`diagnosis.json`, the diagnosis's own type, carries the same fields in each step;
//! docs/diagnose.md, "fit.json and diagnosis.json"), so every front end writes the
//! same schema.

use crate::calibration::Calibration;
use crate::capture::Capture;
use crate::error::{Error, Result};
use crate::fit::input::frames::{FitFrames, MIN_BUDGET_PX};
use crate::fit::{FitOptions, FitResult};
use std::path::PathBuf;

/// A fit or a diagnosis to run on a capture.
#[derive(Clone, Debug, Default)]
pub struct FitRequest {
    /// The capture folder (bpins-capture/1).
    pub capture: PathBuf,
    /// Effects whose parameters are fitted, by registry name (`bpins effects`).
    pub effects: Vec<String>,
    /// Hold each frame's heading at its reference instead of fitting it.
    pub trust_reference: bool,
    /// The sky's peak degree of linear polarization when known, in [0, 1].
    pub fixed_dmax: Option<f64>,
    /// Hold every frame's sky radiance at Rayleigh's instead of fitting its shape.
    pub rayleigh_radiance: bool,
    /// A calibration (bpins-calibration/1): its effects are known and held at their
    /// values (an effect also in `effects` is fitted); its per-pixel maps, if any, are
    /// applied to every frame.
    pub calibration: Option<PathBuf>,
    /// Fit every pixel, including those each frame's sky mask leaves out.
    pub all_pixels: bool,
    /// Most pixels of each frame the fit reads (`fit::frames`: a larger frame is read
    /// through a seeded sample of whole 2 × 2 tiles); `None` reads every pixel.
    /// [`crate::fit::DEFAULT_BUDGET_PX`] is the CLI's default.
    pub sample_budget_px: Option<usize>,
    /// On a colour capture (`colour_tiles`) whose fitted effects include neither
    /// `sky_spectrum` nor `band_response` (and whose calibration holds no
    /// `sky_spectrum`), fit `sky_spectrum` too ([`COLOUR_BANDS_ADDED`]): `bpins fit`'s
    /// and `bpins.fit`'s default. A diagnosis leaves it off: its search starts from
    /// the model it is given and scores the two as a confusable pair.
    pub model_colour_bands: bool,
}

/// An effect a fit added to those it was asked for, and why (`fit.json`'s `added`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AddedEffect {
    /// Its registry name (`bpins effects`).
    pub effect: &'static str,
    /// Why, in words (for a colour capture: [`COLOUR_BANDS_ADDED`]).
    pub why: &'static str,
}

/// Why a fit of a colour capture adds `sky_spectrum` ([`FitRequest::model_colour_bands`]).
pub const COLOUR_BANDS_ADDED: &str = "a colour capture (colour_tiles): its bands differ in level (the sky's colour × \
     the filters' QE) and in DoLP (d_max falls toward the blue), which one level and one d_max per frame cannot fit; \
     sky_spectrum fits each band's level and d_max factor relative to green (name sky_spectrum or band_response \
     in the effects to choose)";

/// A checked request with its capture read (each frame whole, or its sample).
pub struct Loaded {
    pub options: FitOptions,
    pub capture: Capture,
    pub frames: FitFrames<'static>,
    /// Effects the fit added to the request's ([`FitRequest::model_colour_bands`]);
    /// they are in `options.effects` too.
    pub added: Vec<AddedEffect>,
}

impl FitRequest {
    /// Checks the request (every effect named in the registry, d_max in [0, 1], the
    /// budget at least [`MIN_BUDGET_PX`]), reads the calibration and the capture's
    /// frames as the fit holds them (whole, or sampled within the budget; the
    /// calibration's per-pixel maps applied); `progress(frames_read, frames)`. A colour
    /// capture's fit may add `sky_spectrum` ([`FitRequest::model_colour_bands`]).
    pub fn load(&self, progress: &dyn Fn(usize, usize)) -> Result<Loaded> {
        let mut effects = self
            .effects
            .iter()
            .map(|s| s.trim())
            .filter(|s| !s.is_empty())
            .map(crate::effects::find)
            .collect::<Result<Vec<_>>>()?;
        if let Some(d) = self.fixed_dmax.filter(|d| !(0.0..=1.0).contains(d)) {
            return Err(Error::OutOfRange { what: "fixed d_max".into(), value: d.to_string(), range: "[0, 1]".into() });
        }
        if let Some(b) = self.sample_budget_px.filter(|&b| b < MIN_BUDGET_PX) {
            return Err(Error::OutOfRange {
                what: "sample budget".into(),
                value: format!("{b} px"),
                range: format!("[{MIN_BUDGET_PX}, ∞) px (at least 16 blocks of 8 × 8)"),
            });
        }
        let capture = Capture::load(&self.capture)?;
        // A frame no source lights alone is refused before its pixels are read.
        crate::fit::input::sky::frame_skies(&capture)?;
        let cal = self.calibration.as_deref().map(Calibration::load).transpose()?;
        let pixels = cal.as_ref().and_then(|c| c.pixels.clone());
        // A colour sensor's bands see the sky through different filters: each band's
        // level is its sky radiance × its filter's QE, and a clear sky's d_max falls
        // toward the blue (`sky_spectrum`'s doc block). A model of one level and one
        // d_max per frame misfits every band but one (χ²/dof ~750 on
        // samples/colour-clear), and its 1σ takes the misfit for noise.
        let mut added = Vec::new();
        let names_bands = |name: &str| name == "sky_spectrum" || name == "band_response";
        let known_sky = cal.as_ref().is_some_and(|c| c.effects.iter().any(|(d, _)| d.name == "sky_spectrum"));
        if self.model_colour_bands
            && capture.sensor.colour.is_some()
            && !effects.iter().any(|e| names_bands(e.name))
            && !known_sky
        {
            let sky = crate::effects::find("sky_spectrum")?;
            effects.push(sky);
            added.push(AddedEffect { effect: sky.name, why: COLOUR_BANDS_ADDED });
        }
        let options = FitOptions {
            effects,
            trust_reference: self.trust_reference,
            fixed_dmax: self.fixed_dmax,
            rayleigh_radiance: self.rayleigh_radiance,
            all_pixels: self.all_pixels,
            sky_masks: None,
            known: cal.map(|c| c.effects).unwrap_or_default(),
        };
        let n = capture.frames.len();
        let frames = FitFrames::load(&capture, self.sample_budget_px, pixels, &options, &|k| progress(k, n))?;
        Ok(Loaded { options, capture, frames, added })
    }
}

/// `fit.json`: the capture, the model's effects (those the fit added among them, with
/// why, in `added`; absent where none) and the fit's own fields ([`FitResult`], the
/// schema every fit result shares).
#[derive(serde::Serialize)]
pub struct FitJson<'a> {
    pub capture: String,
    pub effects: Vec<&'static str>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub added: Vec<AddedEffect>,
    #[serde(flatten)]
    pub fit: &'a FitResult,
}

impl<'a> FitJson<'a> {
    pub fn new(capture: &std::path::Path, options: &FitOptions, added: &[AddedEffect], fit: &'a FitResult) -> Self {
        let effects = options.effects.iter().map(|e| e.name).collect();
        FitJson { capture: capture.display().to_string(), effects, added: added.to_vec(), fit }
    }
}
