//! What a fit returns: the effects' parameters with their 1σ, each frame's nuisances,
//! the goodness of fit — one typed schema, serialised as is into `fit.json` and into
//! each step of `diagnosis.json` (README, "fit.json and diagnosis.json").

use crate::fit::input::noise::NoiseModel;
use crate::fit::model::radiance;
use crate::fit::model::slots::{EffectParam, PER_FRAME};

/// One fitted effect parameter.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Param {
    /// Which parameter, by the registry's names.
    #[serde(skip)]
    pub id: EffectParam,
    /// `effect.param`.
    pub name: String,
    pub unit: &'static str,
    pub value: f64,
    /// 1σ; 0 for a parameter held fixed; infinite (`null` in JSON) for one the data
    /// cannot tell from others (see [`FitResult::degenerate`]). The larger of the
    /// white-noise 1σ widened for neighbour-correlated residuals
    /// ([`FitResult::n_eff`]) and the sandwich 1σ from the residuals by cluster
    /// (`fit::robust`: a noise pattern the same in every frame, such as PRNU).
    pub sigma: f64,
    /// 1σ were the residuals the independent noise the fit weighs them by (the
    /// inverse of JᵀWJ alone): `sigma / sigma_white` is how much the data's
    /// correlations cost.
    pub sigma_white: f64,
}

impl Param {
    pub fn new(id: EffectParam, unit: &'static str, value: f64, sigma: f64) -> Param {
        Param { id, name: id.to_string(), unit, value, sigma, sigma_white: sigma }
    }
}

/// One frame's result.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FrameFit {
    pub heading_deg: f64,
    /// 1σ, degrees, with the misfit the model leaves (`fit::fit_from`'s
    /// `heading_sigma_with_misfit`: the larger of the statistical 1σ and the residual
    /// projected on the heading's sensitivity tile by tile, `fit::uncertainty::spatial`).
    pub heading_sigma_deg: f64,
    /// The statistical part alone: the white-noise 1σ widened for correlated residuals.
    pub heading_sigma_stat_deg: f64,
    pub reference_deg: Option<f64>,
    /// Fitted − reference heading, degrees, in (−180, 180].
    pub heading_error_deg: Option<f64>,
    pub scale_dn: f64,
    pub dmax: f64,
    /// The sky's radiance nuisance: coefficients of the frame's basis ([`radiance`]).
    #[serde(rename = "radiance_coefficients")]
    pub radiance: [f64; radiance::N],
    /// A mixed twilight's second sky: its fitted strength k, the factor on the model's
    /// weight of the other source's sky (1: the model's), and its 1σ (`fit::input::sky`);
    /// absent for a frame one source lights.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub twilight_strength: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub twilight_strength_sigma: Option<f64>,
    pub chi2_per_dof: f64,
}

/// The result of a fit.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FitResult {
    /// The enabled effects' parameters.
    pub params: Vec<Param>,
    pub frames: Vec<FrameFit>,
    pub chi2: f64,
    pub dof: f64,
    pub chi2_per_dof: f64,
    /// Samples used (unmasked).
    pub samples: usize,
    /// What of each frame the fit read: every pixel, or a sample within a budget
    /// (`crate::fit::input::frames`), with the factor that scales each 1σ to full resolution.
    pub sample: crate::fit::input::frames::Sample,
    /// Where the fit read more pixels than its first sample because a parameter's 1σ
    /// needed it (`crate::fit::input::resolution`), from which budget to which and for which
    /// parameters; `null` where the first sample decided.
    pub raised: Option<crate::fit::input::resolution::Raised>,
    pub noise: NoiseModel,
    /// RMS of measured − model AoP (degrees, where the model DoLP > 0.01) and DoLP,
    /// over superpixels (DoFP) or pixels (colocated), with the nominal inversion.
    pub aop_rms_deg: f64,
    pub dolp_rms: f64,
    /// RMS over frames of fitted − reference heading, degrees (None without references).
    pub heading_rms_deg: Option<f64>,
    pub iterations: usize,
    /// Effective number of independent samples of the residual ([`crate::fit::uncertainty::correlation`]):
    /// `samples` when it is white, fewer when neighbours are correlated.
    #[serde(rename = "effective_samples")]
    pub n_eff: f64,
    /// Number of independent combinations of the free parameters the data constrain
    /// (the rank of JᵀWJ); less than the free parameters when some are degenerate.
    pub rank: usize,
    /// Each combination of parameters the data cannot constrain, in words.
    pub degenerate: Vec<String>,
    /// Which source lit each frame's sky (the sun, or the moon at night), with both
    /// sources' shares, as `bpins heading` says it (`fit::input::sky`).
    pub sky: Vec<crate::fit::input::sky::FrameSky>,
    /// The fitted values, to start another fit from (not serialised).
    #[serde(skip)]
    pub state: FitState,
}

/// A fit's parameter values, for warm starts: the effects' by parameter, and each
/// frame's (heading °, scale DN, d_max, radiance coefficients) with the radiance basis
/// they are coefficients of.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FitState {
    pub effect_values: Vec<(EffectParam, f64)>,
    pub frames: Vec<[f64; PER_FRAME]>,
    pub radiance_basis: Vec<radiance::Basis>,
}
