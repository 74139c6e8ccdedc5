//! Fitting the model to a measured capture: the enabled effects' parameters and each
//! frame's nuisances (heading unless the reference is trusted, radiance scale and
//! smooth radiance shape, sky d_max) to the raw DN of every frame, pixel by pixel at
//! each pixel's own ray.
//!
//! ```text
//! DN_model(p) = offset_k + g_f · signal(p; θ_effects, heading_f, d_max,f)   (chain::mosaic_pixel_signal_dn)
//! χ² = Σ_p (DN(p) − DN_model(p))² / σ²(p),   σ² = σ_r² + K·(DN_model − black)   (EMVA, fit::noise)
//! Levenberg–Marquardt: (JᵀWJ + λ·diag JᵀWJ) δ = JᵀW r,  J by central differences
//! ```
//!
//! JᵀWJ and JᵀWr are accumulated pixel by pixel (per frame over its own and the
//! global parameters), never a Jacobian in memory. Saturated and dark pixels are
//! masked. The noise comes from the frames themselves (`noise::estimate`), so χ²/dof
//! measures the model: ≈ 1 when it explains the data. Iterations first run on every
//! third row and column (all channels), then on every pixel until converged; the
//! reported numbers are from every pixel. 1σ from the inverse of JᵀWJ. "Every pixel"
//! is every pixel the frames hold ([`frames`]): a frame larger than the sample budget
//! is read through a stratified sample of whole 2 × 2 tiles, and the result says so
//! ([`FitResult::sample`], with the factor that scales its 1σ to full resolution).
//!
//! The sky's radiance is a per-frame nuisance (`radiance`: × R(p), a smooth
//! orthonormal basis in the image position and the scattering angle), so a real sky's
//! radiance is never blamed on a catalog effect; `FitOptions::rayleigh_radiance` holds
//! it at Rayleigh's. Pixels within [`BORDER_PX`] of the sensor's edge are left out (a
//! misfit confined to them — crosstalk's neighbour outside the sensor — must not bias
//! a global parameter). Each parameter's 1σ is widened by √(n/n_eff), n_eff the
//! effective sample count of neighbour-correlated residuals (`correlation`), and an
//! effect parameter's is at least its sandwich 1σ over clusters of pixels across the
//! frames (`robust`: a sensor's fixed pattern, the same in every frame). The normal
//! equations are kept by blocks and solved by the Schur complement over the frames
//! (`block`, `schur`); a parameter the sample cannot decide but every pixel could
//! raises the sample (`resolution`).

pub mod input;
pub mod model;
pub mod output;
pub mod solver;
pub mod uncertainty;

pub use input::frames::{FitFrames, Sample, DEFAULT_BUDGET_PX};
pub use input::masks::sky_masks;
pub use input::request::{AddedEffect, FitJson, FitRequest, Loaded, COLOUR_BANDS_ADDED};
pub use model::slots::PER_FRAME;
pub use output::residuals::{residual_maps, residual_maps_of, FrameMaps, ResidualMaps};
pub use output::result::{FitResult, FitState, FrameFit, Param};
pub use uncertainty::score::{score_candidate, score_candidates, Score};

use crate::capture::{Capture, FrameData};
use crate::conventions::wrap_deg_180;
use crate::effects::{EffectDef, EffectSet};
use crate::error::{Error, Result};
use crate::heading::field::SkyMask;
use input::noise::NoiseModel;
use model::problem::problem;
use model::slots::Nuisance;

/// What to fit.
#[derive(Clone, Debug, Default)]
pub struct FitOptions {
    /// Effects whose parameters are free (at neutral to start).
    pub effects: Vec<&'static EffectDef>,
    /// Keep each frame's heading at its reference instead of fitting it.
    pub trust_reference: bool,
    /// The sky's peak degree of polarization when the user knows it: every frame's
    /// d_max is held at this value instead of being fitted (which is what makes a
    /// global `sky_depolarization` measurable at all).
    pub fixed_dmax: Option<f64>,
    /// Hold every frame's radiance shape at Rayleigh's (a1 = a2 = 0) instead of
    /// fitting it.
    pub rayleigh_radiance: bool,
    /// Effects known from a calibration (`crate::calibration`), held at their values;
    /// an effect also in `effects` is fitted instead.
    pub known: EffectSet,
    /// Fit every pixel. By default each frame's sky mask
    /// ([`crate::heading::field::sky_mask`]) leaves out what is not sky that follows
    /// the model's pattern — clouds, trees, buildings, the ground, the sun's aureole —
    /// so that a scene is never blamed on the lens or the sensor.
    pub all_pixels: bool,
    /// Each frame's sky mask, computed once ([`sky_masks`]) for many fits of the same
    /// capture (a diagnosis); `None`: computed by the fit.
    pub sky_masks: Option<std::sync::Arc<Vec<Option<SkyMask>>>>,
}

/// Pixels this close to the sensor's edge are not fitted.
pub const BORDER_PX: usize = 2;

/// Fits `opts` to the capture `c` whose frames are `frames` (every pixel);
/// `progress(stage, step)` after each iteration.
pub fn fit(c: &Capture, frames: &[FrameData], opts: &FitOptions, progress: &dyn Fn(&str, usize)) -> Result<FitResult> {
    fit_from(c, &FitFrames::all(c, frames)?, opts, None, progress)
}

/// The sensor noise of a capture (photon transfer over its frames).
pub fn capture_noise(c: &Capture, frames: &[FrameData]) -> Result<NoiseModel> {
    input::sky_noise::noise_of(c, frames, None)
        .ok_or_else(|| Error::TooFewSamples("too few usable pixels to estimate the sensor noise".into()))
}

/// [`fit`] on the frames as [`FitFrames`] hold them (every pixel or a sample), from a
/// warm start where given.
pub fn fit_from(
    c: &Capture,
    frames: &FitFrames,
    opts: &FitOptions,
    start: Option<&FitState>,
    progress: &dyn Fn(&str, usize),
) -> Result<FitResult> {
    fit_from_stages(c, frames, opts, start, false, progress)
}

/// [`fit_from`] without the subsampled stage: Levenberg–Marquardt on every pixel from
/// `start`, the model's subsampled optimum (a diagnosis's candidate converged on every
/// pixel, `diagnose::refits::converge`: the subsampled stage would stop there at once).
/// Not for a start far from the optimum: there the subsampled stage's cheap iterations
/// save every-pixel ones (a diagnosis's joint refit of two candidates: 5 every-pixel
/// iterations without it against 4 subsampled and 3 every-pixel, measured).
pub(crate) fn fit_every_pixel_from(
    c: &Capture,
    frames: &FitFrames,
    opts: &FitOptions,
    start: &FitState,
) -> Result<FitResult> {
    fit_from_stages(c, frames, opts, Some(start), true, &|_, _| {})
}

/// [`fit_from`], through the every-pixel stage only where `every_pixel_only`.
fn fit_from_stages(
    c: &Capture,
    frames: &FitFrames,
    opts: &FitOptions,
    start: Option<&FitState>,
    every_pixel_only: bool,
    progress: &dyn Fn(&str, usize),
) -> Result<FitResult> {
    // A dark night is refused; a mixed twilight is fitted with both skies (`input::sky`).
    let sky = input::sky::frame_skies(c)?;
    let noise = frames.noise(c, opts)?;
    let (pb, theta) = problem(c, frames, opts, start, noise)?;
    let (theta, iterations, last) = if every_pixel_only {
        solver::lm::minimise_every_pixel(&pb, theta, progress)?
    } else {
        solver::lm::minimise(&pb, theta, progress)?
    };
    // Final: every pixel, covariance from JᵀWJ (its pseudo-inverse: a combination the
    // data do not constrain is reported, and its parameters get an infinite 1σ) — the
    // last iteration's sums where they were taken at these parameters.
    let acc = match last {
        Some(acc) => acc,
        None => pb.accumulate(&theta, 1, true)?,
    };
    let free = pb.slots.free();
    let nf = free.len();
    let cov = solver::schur::BlockInverse::new(&acc.sys);
    let degenerate = cov.null.iter().map(|d| solver::lm::describe_null(&pb, &free, d)).collect();
    // Neighbour-correlated residuals carry less information than their count.
    let corr = uncertainty::correlation::effective_samples(&pb, &theta, acc.n)?;
    let n_eff = corr.n_eff;
    let widen = (acc.n as f64 / n_eff.max(1.0)).sqrt().max(1.0);
    // The free globals come first among the free slots: their sandwich 1σ, from the
    // residuals' own variance by cluster (a fixed pattern the same in every frame).
    let robust = acc.clusters.as_ref().map_or_else(Vec::new, |cl| cl.sigmas(&cov.global_cov()));
    let sigma_white = |i: usize| free.binary_search(&i).map_or(0.0, |p| cov.sigma(p));
    let sigma = |i: usize| {
        free.binary_search(&i).map_or(0.0, |p| {
            let s = widen * cov.sigma(p);
            robust.get(p).map_or(s, |r| if s.is_finite() { s.max(*r) } else { s })
        })
    };
    let effect_values = pb.effect_values(&theta);
    let params = effect_values
        .iter()
        .enumerate()
        .map(|(i, &(id, value))| Param {
            sigma_white: sigma_white(i),
            ..Param::new(id, pb.slots.all[i].unit, value, sigma(i))
        })
        .collect();
    let dof = (acc.n as f64 - nf as f64).max(1.0);
    // The heading's 1σ under the residual's spatial correlation, frame by frame
    // (`spatial`): its row of A⁺ over the frame's local slots (the free globals, then
    // its own), against the frame's JᵀWr by tile.
    let n_g = free.iter().take_while(|&&i| i < pb.slots.n_global).count();
    let spatial = |k: usize, h: usize| -> f64 {
        let (Some(tiles), Ok(ph)) = (acc.tiles.as_ref(), free.binary_search(&h)) else { return f64::NAN };
        let mut e = vec![0.0; nf];
        e[ph] = 1.0;
        let row = cov.solve(&e);
        let own = pb.slots.frame(k).into_iter().filter_map(|i| free.binary_search(&i).ok());
        let ell: Vec<f64> = (0..n_g).chain(own).map(|p| row[p]).collect();
        tiles.sigma(k, &ell)
    };
    let frames_out: Vec<FrameFit> = (0..frames.len())
        .map(|k| {
            let at = |n: Nuisance| pb.slots.at(k, n);
            let h = at(Nuisance::Heading);
            let reference = c.frames[k].heading_deg;
            let (chi2, n) = acc.frame_chi2[k];
            // The frame's slots: the twilight's strength counts where it has a second sky.
            let slots = PER_FRAME - usize::from(pb.second[k].is_none());
            let chi2_per_dof = chi2 / (n as f64 - slots as f64).max(1.0);
            FrameFit {
                heading_deg: theta[h].rem_euclid(360.0),
                heading_sigma_deg: heading_sigma_with_misfit(sigma(h), spatial(k, h)),
                heading_sigma_stat_deg: sigma(h),
                reference_deg: reference,
                heading_error_deg: reference.map(|r| wrap_deg_180(theta[h] - r)),
                scale_dn: theta[at(Nuisance::Scale)],
                dmax: theta[at(Nuisance::Dmax)],
                radiance: std::array::from_fn(|i| theta[at(Nuisance::Radiance(i))]),
                twilight_strength: pb.second[k].map(|_| theta[at(Nuisance::Twilight)]),
                twilight_strength_sigma: pb.second[k].map(|_| sigma(at(Nuisance::Twilight))),
                chi2_per_dof,
            }
        })
        .collect();
    let errs: Vec<f64> = frames_out.iter().filter_map(|f| f.heading_error_deg).collect();
    let heading_rms_deg =
        (!errs.is_empty()).then(|| (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt());
    let (aop_rms_deg, dolp_rms) = output::residuals::polarization_residuals(&pb, &theta)?;
    Ok(FitResult {
        params,
        frames: frames_out,
        chi2: acc.chi2,
        dof,
        chi2_per_dof: acc.chi2 / dof,
        samples: acc.n,
        sample: frames.sample(),
        raised: None,
        noise,
        aop_rms_deg,
        dolp_rms,
        heading_rms_deg,
        iterations,
        n_eff,
        rank: cov.rank(),
        degenerate,
        sky,
        state: FitState {
            effect_values,
            frames: (0..frames.len()).map(|k| pb.slots.frame(k).map(|i| theta[i])).collect(),
            radiance_basis: pb.basis.clone(),
        },
    })
}

/// A frame's heading 1σ with the misfit the model leaves, degrees:
///
/// ```text
/// σ = max(σ_stat, σ_spatial)
/// ```
///
/// σ_stat the statistical 1σ (white-noise 1σ widened for correlated residuals),
/// σ_spatial the heading's spatial sandwich (`spatial`: the residual tile by tile,
/// projected on the heading's sensitivity, its pulls correlated over neighbouring
/// tiles): what the misfit the model does not explain can move the heading by. A frame
/// whose residual is noise keeps its statistical 1σ (σ_spatial ≈ σ_white ≤ σ_stat
/// there), as the field heading takes the larger of its data 1σ
/// (`heading::field::SigmaParts::total_deg`).
fn heading_sigma_with_misfit(stat: f64, spatial: f64) -> f64 {
    if stat == 0.0 || !stat.is_finite() || !spatial.is_finite() {
        return stat;
    }
    stat.max(spatial)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::capture::{FrameSpec, LensSpec, SensorSpec};
    use crate::pipeline::{sim_response, simulate_frame, SimSensor};
    use crate::sensor::{Geometry, Layout, DEFAULT_MOSAIC};
    use crate::sky::sun::SunPosition;

    /// A diagnosis converges a candidate on every pixel from its subsampled optimum
    /// (`diagnose::refits::converge`): the subsampled stage would stop there at once
    /// (the same sums at the same θ), so skipping it changes nothing but the count.
    #[test]
    fn a_refit_from_a_subsampled_optimum_on_every_pixel_alone_is_the_two_stage_fit() {
        let (w, h) = (96u32, 80u32);
        let c = Capture {
            dir: "/nowhere".into(),
            sensor: SensorSpec {
                colour: None,
                layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
                geometry: Geometry { width_px: w, height_px: h, pixel_pitch_um: 86.0 },
                bit_depth: 12,
                black_level_dn: 64.0,
            },
            lens: LensSpec {
                projection: Projection::Pinhole,
                focal_length_mm: 8.0,
                principal_point_px: crate::conventions::image_centre_px(w, h),
            },
            frames: (0..2)
                .map(|i| FrameSpec {
                    heading_deg: Some(30.0 + 90.0 * i as f64),
                    ..FrameSpec::new("f.png", SunPosition::given(40.0, 25.0))
                })
                .collect(),
        };
        let mut truth = EffectSet::new();
        truth.set("focal_length", "scale", 0.01).unwrap();
        let sim = SimSensor::samples(7);
        let resp = sim_response(&c, &sim, None).unwrap();
        let data: Vec<FrameData> = (0..2).map(|i| simulate_frame(&c, i, &truth.model(), &resp, &sim, None)).collect();
        let frames = FitFrames::all(&c, &data).unwrap();
        let base_opts = FitOptions { all_pixels: true, ..Default::default() };
        let base = fit_from(&c, &frames, &base_opts, None, &|_, _| {}).unwrap();
        let opts = FitOptions { effects: vec![crate::effects::find("focal_length").unwrap()], ..base_opts };
        let sub = solver::subfit::fit_subsampled(&c, &frames, &opts, &base.state, base.noise).unwrap();
        let two = fit_from(&c, &frames, &opts, Some(&sub.state), &|_, _| {}).unwrap();
        let one = fit_every_pixel_from(&c, &frames, &opts, &sub.state).unwrap();
        assert_eq!((one.chi2, &one.state, &one.params), (two.chi2, &two.state, &two.params));
        assert_eq!(one.iterations + 1, two.iterations);
        // It converged: the focal length found within 3σ of the truth.
        let p = &one.params[0];
        assert!((p.value - 0.01).abs() < 3.0 * p.sigma, "{} ± {}", p.value, p.sigma);
    }
}
