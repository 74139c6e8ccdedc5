//! Headings under real skies: tilt, clouds, trees, the sun in view — and a 1σ a
//! navigation filter can take at its word.
//!
//! The per-pixel extractors (`sun_vector`, `meridian_line` on [`super::HeadingSums`])
//! assume every sample is Rayleigh skylight and every pixel an independent draw. Under
//! a real sky neither holds: a cloud, a tree or the aureole sends samples that obey
//! no sky model, and the misfit that remains is smooth over the image, so the pixel
//! count overstates the information a thousandfold. This estimator works on
//! **cells** (`cells.rs`: blocks of ~1/64 of the shorter side, each its mean Stokes
//! vector and that mean's measured noise) and runs every extractor inside one robust
//! loop (steps 1–3 `observe.rs`, step 4 `robust.rs`, step 5 `sigma.rs`):
//!
//! ```text
//! 1. per cell: ray d, E-vector e (AoE from Q_p, U_p; known lens ρ undone, seed eq. 13),
//!    both turned into the level frame by the reference tilt ∘ mount tilt
//!    (CONVENTIONS.md, Tilt); σ_α² = (U² var Q + Q² var U)/(4P⁴) from the cell's noise
//! 2. masks: cells with saturated pixels (cells.rs); rays below horizon_margin + 3σ_tilt
//! 3. start: the sun's elevation h is known, so the sun lies on a cone and the heading
//!    is one unknown: a search of ψ ∈ [0°, 360°) in 1° steps on the bounded cost
//!    Σ min(δ², c²)/(σ_α² + 0.3°²), c = 2°, δ = the angle of each E-vector off
//!    ⊥(sun, ray): the heading the most cells agree on tightly; a second minimum as
//!    good as the first is an ambiguous frame (no heading); then sharpened: the same
//!    bounded cost with its cap shrunk 0.3° → 0.15° around that minimum, the heading
//!    the most cells agree on *tightly* (the clear sky's, where clouds that turn
//!    together lean every partly covered cell one way; observe.rs `sharpen`)
//! 4. iterate: δ_i against the current sun; clouds per cell (clouds.rs: DoLP under
//!    0.6 × an absolute, upper-share clear-sky expectation; brighter than the smooth
//!    sky fitted to the clear sky's DoLP plateau (not to the cells that fit the current
//!    sun: a deck's turned rims may be those; where that plateau spans the view or the
//!    DoLP test finds a cloud); on a colour sensor, whiter than the blue sky by the red-to-blue ratio
//!    (`Cells::tint`); near the sun the nearest verifiable cells' label), weight 0, grown by 2
//!    cells where they cluster; a model-misfit scale τ with the lower quartile of
//!    δ²/(σ_α² + τ²) at χ²₁'s (0.1015) over the clear cells away from clouds (where
//!    the start's τ is within 1°, a clear sky's: the lower 15 % at χ²₁'s 15 % point,
//!    bounded by the start's τ, so cells that lean together cannot widen it);
//!    Tukey's biweight on δ/σ (σ² = σ_α² + τ²); cells within `sun_exclusion_deg` of
//!    the sun or anti-sun get weight 0, and so does every cell within 2 cells of a
//!    cluster of rejected ones (soft cloud edges); the extractor solves from the
//!    weighted sums (weights 1/(σ² sin²γ) for the sun vector, 1/σ² for the line;
//!    the meridian line is fitted on its whole length through the zenith, both
//!    halves, and its sun's half taken from the sun's cone)
//! 4′. where step 4 leaves too little sky (or, under an overcast, a few cells that misfit
//!    or contradict the sun): the holes' clear cores instead (holes.rs: cells whose DoLP
//!    is the clear sky's own, grouped into holes; the jackknife deletes one hole at a
//!    time, by Student's t; the cores' residual cover times the deck's turn joins σ_misfit)
//! 5. 1σ² = max(σ_fit, σ_jack, σ_coherent)² + σ_misfit² + σ_cross² + σ_tilt² + σ_sun²
//!    + σ_floor²: σ_fit from the extractor's own residuals (χ²-scaled); σ_jack a
//!    delete-one-block jackknife over 4 × 4 blocks of the image; σ_coherent a spatial
//!    HAC sandwich over super-blocks of the cell grid (spatial.rs); σ_misfit =
//!    √(m² − 0.5°²), m the used cells' RMS residual beyond their noise (a turn the
//!    whole used sky shares); σ_cross the two extractors' disagreement beyond twice
//!    the 1σ of their difference; σ_tilt = |∂ψ/∂tilt|·tilt_sigma (∂ψ/∂τ ≈ tan h, per
//!    axis); σ_sun = sun_sigma (the sun's azimuth enters the heading 1:1); σ_floor
//!    for what no model here describes
//! ```
//!
//! A frame gets no heading, with a typed [`NoHeading`] reason, when too little of the
//! image fits the sky, when two headings fit as well, when the sky's own sun
//! contradicts the given one (a wrong clock, place or tilt, a flipped mosaic), when
//! the used cells still misfit by degrees, or when the sun is out of the range where
//! the pattern holds (below −10°, the end of nautical twilight, or within 1° of the
//! zenith), or when the frame is too dark to tell (`dark.rs`: its polarized signal
//! below the noise of its cells).
//!
//! # Example: a tilted frame, its IMU's attitude, a heading with its 1σ
//!
//! ```
//! use bpins_core::camera::{Intrinsics, Projection};
//! use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
//! use bpins_core::effects::Model;
//! use bpins_core::internal::heading::field::{estimate, Cells, FieldContext, FieldOptions, RawImage};
//! use bpins_core::internal::heading::Extractor;
//! use bpins_core::internal::recon::Reconstructor;
//! use bpins_core::sensor::{Channel, Response, DEFAULT_MOSAIC};
//! use bpins_core::internal::simulate::render_mosaic;
//!
//! // A 306 × 256 DoFP frame behind an 8 mm lens, tilted 6° and −4° on rough ground.
//! let (w, h) = (306, 256);
//! let camera = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
//! let scene = Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 6.0, tilt_y_deg: -4.0, dmax: 0.6 };
//! let truth = ChainFrame::new(&Model::default(), &camera, &scene, &Response::samples(2400.0), NoiseIndex { seed: 1, trial: 0, frame: 0 });
//! let raw: Vec<u16> = render_mosaic(&truth, w, h, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
//!
//! // The robot's side: the raw buffer, the sun, and the attitude its IMU reads (±0.1°).
//! let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL)?;
//! let cells = Cells::from_mosaic(&RawImage::packed(&raw, w, h), &DEFAULT_MOSAIC, &rec, 4095.0, Cells::default_cell_px(w, h));
//! let ctx = FieldContext { tilt_x_deg: 6.05, tilt_y_deg: -3.95, tilt_sigma_deg: 0.1, ..FieldContext::new(camera, 40.0, 25.0) };
//! let r = &estimate(&cells, &ctx, &FieldOptions::default(), &[Extractor::SunVector])[0];
//! let (heading_deg, sigma) = r.result.clone().expect("a clear sky has a heading");
//! // The IMU's 0.05° error per axis moves the heading by about 0.05°·tan 25°, and the
//! // 1σ says so (its tilt part is about 0.1°·tan 25° ≈ 0.05°).
//! assert!((heading_deg - 30.0).abs() < 2.0 * sigma.total_deg());
//! assert!(sigma.tilt_deg > 0.03 && sigma.tilt_deg < 0.07);
//! assert!(r.quality.used_fraction > 0.9);
//! # Ok::<(), bpins_core::Error>(())
//! ```
//!
//! What it cannot do: it needs the sun's elevation and the reference tilt to within
//! their σ (the cone search needs h; a sky that contradicts them is refused); it
//! models the clear sky as Rayleigh's pattern, so under a thick overcast only the
//! holes are read, and a turn shared by the whole used sky is carried in the 1σ
//! (σ_misfit), not removed; a lens effect that is not in the calibration biases it
//! like any extractor.

pub mod cells;
mod clouds;
mod coarse;
mod dark;
mod holes;
mod observe;
mod robust;
mod sigma;
mod sky_sun;
pub(crate) mod spatial;
mod stats;
mod two_sources;

pub use cells::{Cell, CellScratch, Cells, RawDn, RawImage};
pub use sky_sun::{sky_sun, SkySun};
pub use two_sources::{estimate_two, estimate_two_with, mixed_pattern, SecondSource, SHARE_LOG_ODDS_SIGMA};

use super::Extractor;
use crate::camera::Intrinsics;
use crate::conventions::level_from_camera;
use crate::sky::SkySource;
use glam::DMat3;

/// What the field estimator knows of one frame: the camera as believed, the sun and
/// the attitude, each with its 1σ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldContext {
    /// Assumed intrinsics (nominal principal point unless calibrated).
    pub intr: Intrinsics,
    /// Known lens diattenuation `rho2`, undone per cell (0: not compensated).
    pub lens_rho2: f64,
    /// Sun azimuth (from North toward East) and elevation, degrees, and their 1σ.
    pub sun_az_deg: f64,
    pub sun_el_deg: f64,
    pub sun_sigma_deg: f64,
    /// Reference tilt of the frame about camera x then y (an IMU), degrees, and the
    /// 1σ of each angle.
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
    pub tilt_sigma_deg: f64,
    /// Known tilt of the camera on its mount, composed after the frame's.
    pub mount_tilt_deg: [f64; 2],
}

impl FieldContext {
    /// A level camera with exactly known attitude and sun.
    pub fn new(intr: Intrinsics, sun_az_deg: f64, sun_el_deg: f64) -> Self {
        FieldContext {
            intr,
            lens_rho2: 0.0,
            sun_az_deg,
            sun_el_deg,
            sun_sigma_deg: 0.0,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            tilt_sigma_deg: 0.0,
            mount_tilt_deg: [0.0; 2],
        }
    }

    /// Camera → level-camera rotation: `Rx(tilt_x)·Ry(tilt_y)·Rx(mount_x)·Ry(mount_y)`.
    pub fn level_from_camera(&self) -> DMat3 {
        level_from_camera(self.tilt_x_deg, self.tilt_y_deg)
            * level_from_camera(self.mount_tilt_deg[0], self.mount_tilt_deg[1])
    }
}

/// Settings of the field estimator; the defaults are what the README's field table
/// was measured with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldOptions {
    /// Cell size, pixels (even for DoFP); `None`: [`Cells::default_cell_px`].
    pub cell_px: Option<usize>,
    /// Rays lower than this above the horizon (plus 3σ of the tilt) are not used:
    /// the ground and what stands on the horizon, degrees.
    pub horizon_margin_deg: f64,
    /// Cells closer than this to the sun or the anti-sun are not used (aureole, flare,
    /// bloom; the neutral points of a real sky), degrees.
    pub sun_exclusion_deg: f64,
    /// Fewest cells, and least fraction of the image's cells, a heading may rest on.
    pub min_cells: usize,
    pub min_used_fraction: f64,
    /// Used cells whose RMS angle residual beyond their noise exceeds this: the sky
    /// does not follow the model (no heading), degrees.
    pub max_residual_deg: f64,
    /// Floor of the 1σ for what no model here describes, degrees.
    pub sigma_floor_deg: f64,
    /// Half-width of the AoE band of the meridian line, degrees.
    pub band_deg: f64,
    /// The sun's elevation the sky shows may differ from the given one by this much
    /// (in quadrature with 4σ of the given sun and tilt) before the frame is refused as
    /// contradicting its inputs (a wrong clock or place, a wrong tilt, a flipped
    /// mosaic), degrees.
    pub max_sun_offset_deg: f64,
}

impl Default for FieldOptions {
    fn default() -> Self {
        FieldOptions {
            cell_px: None,
            horizon_margin_deg: 3.0,
            sun_exclusion_deg: 15.0,
            min_cells: 40,
            min_used_fraction: 0.005,
            max_residual_deg: 4.0,
            sigma_floor_deg: 0.01,
            band_deg: 5.0,
            max_sun_offset_deg: 5.0,
        }
    }
}

/// Why a frame gets no heading.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NoHeading {
    #[error("the sun is {sun_el_deg:.1}° below the horizon: past −10° the sky's pattern fades (nautical twilight)")]
    SunTooLow { sun_el_deg: f64 },
    #[error("the sun is at the zenith ({sun_el_deg:.2}°): the pattern has no azimuth")]
    SunAtZenith { sun_el_deg: f64 },
    #[error(
        "too little usable sky: {used} of {total} cells ({:.1} %) fit the sky model (overcast, obstructed or \
         under-exposed)", 100.0 * *used as f64 / (*total).max(1) as f64
    )]
    TooLittleSky { used: usize, total: usize },
    #[error(
        "ambiguous: headings {best_deg:.1}° and {other_deg:.1}° fit the pattern almost equally (the sun on \
         the horizon, or too little sky)"
    )]
    Ambiguous { best_deg: f64, other_deg: f64 },
    #[error(
        "the used sky misfits the model by {residual_deg:.2}° RMS beyond its noise (more than {limit_deg:.1}°: \
         an overcast, turned cloud rims everywhere, or a mosaic layout that is not the sensor's)"
    )]
    PoorFit { residual_deg: f64, limit_deg: f64 },
    #[error(
        "the sky contradicts the given sun or attitude: its sun stands {offset_deg:+.1}° from the given \
         elevation, more than the {limit_deg:.1}° their 1σ allow (a wrong clock or place, a wrong tilt, or a \
         mosaic layout that is not the sensor's)"
    )]
    Contradicts { offset_deg: f64, limit_deg: f64 },
    #[error(
        "too dark: the polarized signal is below the noise: {signal_dn:.3} DN of polarized light against \
         {noise_dn:.3} DN of noise per cell (signal/noise {snr:.2}; a longer exposure, a wider aperture, more \
         gain or a brighter sky)"
    )]
    TooDark { signal_dn: f64, noise_dn: f64, snr: f64 },
    #[error("{0}")]
    Solver(String),
    /// From a time and place: the sun and the moon both light the sky and neither gives
    /// 99 % of its light (`sky::Refusal::Mixed`), where one source's pattern is needed.
    /// No reader returns it today: the compass, monochrome or colour, reads such a
    /// frame with both sources (`two_sources.rs`). Kept so that the C ABI's
    /// `BPINS_NO_HEADING_MIXED_SKY` (9) keeps its meaning for callers built against it.
    #[error("{}", shares.mixed_reason())]
    MixedSky { shares: crate::sky::twilight::Shares },
    /// From a time and place: the sun past −10° and no moon up bright enough to be read
    /// alone (`sky::Refusal::Dark`); the frame is not read.
    #[error("{}", shares.dark_reason())]
    DarkNight { shares: crate::sky::twilight::Shares },
}

/// The parts of a field heading's 1σ, degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SigmaParts {
    /// From the extractor's own weighted residuals (χ²-scaled).
    pub fit_deg: f64,
    /// Delete-one-block jackknife over the image (correlated misfit).
    pub jackknife_deg: f64,
    /// Spatial HAC sandwich over the cell grid (a misfit shared by neighbouring cells:
    /// cloud rims, an unmodelled sky), `spatial.rs`.
    pub coherent_deg: f64,
    /// The used sky's misfit beyond its noise and beyond what a clear sky leaves,
    /// √(m² − 1°²) (step 5): what no sandwich sees, a turn shared by the whole used
    /// sky (the rims of clouds that turn together).
    pub misfit_deg: f64,
    /// The two extractors' disagreement on the same cells, where it exceeds twice the
    /// 1σ of their difference (0 otherwise).
    pub cross_deg: f64,
    /// The reference tilt's 1σ, propagated.
    pub tilt_deg: f64,
    /// The sun position's 1σ, propagated.
    pub sun_deg: f64,
    /// The floor.
    pub floor_deg: f64,
}

impl SigmaParts {
    /// The total: max(fit, jackknife, coherent) in quadrature with the rest.
    pub fn total_deg(&self) -> f64 {
        let data = self.fit_deg.max(self.jackknife_deg).max(self.coherent_deg);
        (data * data
            + self.misfit_deg.powi(2)
            + self.cross_deg.powi(2)
            + self.tilt_deg.powi(2)
            + self.sun_deg.powi(2)
            + self.floor_deg.powi(2))
        .sqrt()
    }
}

/// How well a frame's sky served: what was used and how well it fits.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FieldQuality {
    /// Cells of the image grid, cells that passed the masks, cells the final fit used
    /// (robust weight ≥ ½).
    pub cells_total: usize,
    pub cells_valid: usize,
    pub cells_used: usize,
    /// `cells_used / cells_total`: the fraction of the image the heading rests on.
    pub used_fraction: f64,
    /// Weighted RMS of the used cells' angle residual δ, degrees.
    pub residual_rms_deg: f64,
    /// Model-misfit scale τ (step 4), degrees.
    pub misfit_deg: f64,
    /// Robust iterations run.
    pub iterations: usize,
    /// Fraction of the observed cells (`cells_valid`) taken for cloud: depolarized
    /// against the clear sky's DoLP, or brighter than the smooth sky, where such cells
    /// cluster (grown by their soft edges).
    pub cloud_fraction: f64,
    /// Elevation of the sun the sky's pattern shows (unconstrained sun vector, level
    /// frame by the reference tilt) minus the known elevation, degrees: a check on the
    /// reference tilt and the sun (a tilt error about the horizontal axis across the
    /// sun's azimuth shows here; one about the sun's azimuth does not, and moves the
    /// heading by τ·tan h instead).
    pub sun_elevation_offset_deg: f64,
}

/// The share a mixed twilight's fit found (`two_sources.rs`): `w`, the frame's
/// source's share of the two skies' polarized radiance per unit of Rayleigh's pattern
/// (the model's is [`crate::sky::twilight::Shares::sun_unit_share`] for the sun), and
/// its 1σ, w(1 − w)·σ_θ, σ_θ the larger of the fit's marginal 1σ of the log-odds θ
/// (χ²-scaled) and θ's delete-one-block jackknife (the delta method, so only a guide
/// where w is near 0 or 1). Dimensionless, in (0, 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FittedShare {
    pub share: f64,
    pub sigma: f64,
}

/// One extractor's field heading of one frame.
///
/// ```
/// use bpins_core::internal::heading::field::{FieldHeading, FieldQuality, NoHeading, SigmaParts};
/// use bpins_core::internal::heading::Extractor;
/// // What a navigation filter does with one:
/// fn to_filter(h: &FieldHeading) -> Option<(f64, f64)> {
///     match &h.result {
///         // A heading and its 1σ; the parts say where the uncertainty comes from.
///         Ok((deg, sigma)) => Some((*deg, sigma.total_deg())),
///         // Overcast, a wall in view, an ambiguous sky: skip the update.
///         Err(NoHeading::TooLittleSky { .. } | NoHeading::Ambiguous { .. }) => None,
///         Err(_) => None,
///     }
/// }
/// let sigma = SigmaParts { fit_deg: 0.02, jackknife_deg: 0.03, tilt_deg: 0.04, ..Default::default() };
/// let h = FieldHeading {
///     extractor: Extractor::SunVector,
///     result: Ok((123.4, sigma)),
///     quality: FieldQuality::default(),
///     source: Default::default(),
///     fitted_share: None,
/// };
/// let (deg, one_sigma) = to_filter(&h).unwrap();
/// assert_eq!(deg, 123.4);
/// assert!((one_sigma - 0.05).abs() < 1e-12); // max(fit, jackknife, coherent) ⊕ tilt
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct FieldHeading {
    pub extractor: Extractor,
    /// Heading in [0°, 360°) and its 1σ, or why there is none.
    pub result: Result<(f64, SigmaParts), NoHeading>,
    pub quality: FieldQuality,
    /// Which source lit the sky it was read about (the compass sets it; the estimator,
    /// given angles, leaves [`SkySource::Given`]).
    pub source: SkySource,
    /// A mixed twilight read with both sources (`two_sources.rs`): the frame's
    /// source's share as the fit found it, with its 1σ; `None` for a one-source sky or
    /// a frame without a heading. The reading says it as the sun's
    /// ([`FieldHeading::fitted_sun_share`]).
    pub fitted_share: Option<FittedShare>,
}

impl FieldHeading {
    pub fn heading_deg(&self) -> Option<f64> {
        self.result.as_ref().ok().map(|r| r.0)
    }

    pub fn sigma_deg(&self) -> Option<f64> {
        self.result.as_ref().ok().map(|r| r.1.total_deg())
    }

    /// A mixed twilight's fitted share of the sun ([`FittedShare`]: w where the
    /// frame's source is the sun or given, 1 − w where it is the moon); `None` for a
    /// one-source sky or a frame without a heading.
    pub fn fitted_sun_share(&self) -> Option<f64> {
        let f = self.fitted_share?;
        Some(if matches!(self.source, SkySource::Moon(_)) { 1.0 - f.share } else { f.share })
    }

    /// The 1σ of [`FieldHeading::fitted_sun_share`] (the same for either source's).
    pub fn fitted_sun_share_sigma(&self) -> Option<f64> {
        self.fitted_share.map(|f| f.sigma)
    }
}

/// Field headings of one frame's cells with each of `extractors` (the robust loop runs
/// once; each extractor solves on its final weights).
pub fn estimate(cells: &Cells, ctx: &FieldContext, opts: &FieldOptions, extractors: &[Extractor]) -> Vec<FieldHeading> {
    estimate_many_with(cells, ctx, opts, extractors, &mut FieldScratch::default())
}

/// [`estimate`] with buffers kept in `scratch` between frames (a capture's frames,
/// [`crate::compass::Compass::capture_frame`]).
pub fn estimate_many_with(
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    extractors: &[Extractor],
    scratch: &mut FieldScratch,
) -> Vec<FieldHeading> {
    // A dim frame on larger cells (coarse.rs).
    let coarse = coarse::coarsened(cells);
    let cells = coarse.as_ref().unwrap_or(cells);
    match robust::fitted(cells, ctx, opts, &mut scratch.robust) {
        Ok(r) => extractors.iter().map(|&e| sigma::heading(&r, e, cells, ctx, opts, &scratch.robust)).collect(),
        Err((quality, why)) => {
            let why = coarse::explain_dim(cells, why);
            extractors
                .iter()
                .map(|&e| FieldHeading {
                    extractor: e,
                    result: Err(why.clone()),
                    quality,
                    source: SkySource::Given,
                    fitted_share: None,
                })
                .collect()
        }
    }
}

/// One extractor's field heading of one frame's cells, with buffers kept in `scratch`
/// between frames: once they have grown to the frame's grid, a clear frame allocates
/// nothing (a frame without a heading may, for its reason's text).
pub fn estimate_with(
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    extractor: Extractor,
    scratch: &mut FieldScratch,
) -> FieldHeading {
    let coarse = coarse::coarsened(cells);
    let cells = coarse.as_ref().unwrap_or(cells);
    match robust::fitted(cells, ctx, opts, &mut scratch.robust) {
        Ok(r) => sigma::heading(&r, extractor, cells, ctx, opts, &scratch.robust),
        Err((quality, why)) => {
            let result = Err(coarse::explain_dim(cells, why));
            FieldHeading { extractor, result, quality, source: SkySource::Given, fitted_share: None }
        }
    }
}

/// The field estimator's buffers, kept between frames by a live loop (see
/// [`estimate_with`] and [`Cells::fill_from_mosaic`]).
#[derive(Clone, Debug, Default)]
pub struct FieldScratch {
    /// The cells' accumulators.
    pub cells: CellScratch,
    robust: robust::Scratch,
    /// A mixed twilight's (`two_sources.rs`).
    two: two_sources::Scratch,
}

/// Which pixels of a frame show sky that follows the sky model's pattern, from the
/// field estimator's cells: what a fit of the sensor should read, so that clouds, trees,
/// the ground and the aureole are never blamed on the lens or the sensor.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyMask {
    pub cell_px: usize,
    pub cols: usize,
    pub rows: usize,
    /// Per cell (row-major): sky.
    pub sky: Vec<bool>,
    /// The field estimator's heading of the frame (sun vector), degrees.
    pub heading_deg: f64,
}

impl SkyMask {
    /// Whether pixel (u, v) lies in a sky cell (pixels beyond the whole cells: no).
    pub fn is_sky(&self, u_px: usize, v_px: usize) -> bool {
        let (c, r) = (u_px / self.cell_px.max(1), v_px / self.cell_px.max(1));
        c < self.cols && r < self.rows && self.sky[r * self.cols + c]
    }

    /// The fraction of the grid's cells that are sky.
    pub fn sky_fraction(&self) -> f64 {
        self.sky.iter().filter(|&&s| s).count() as f64 / self.sky.len().max(1) as f64
    }
}

/// The sky mask of one frame's cells (see [`SkyMask`]): cells that pass the masks
/// (whole, unsaturated, above the horizon margin) and are not in or beside a cluster of
/// depolarized cells. Residuals alone never take a cell out: a lens or sensor effect
/// moves AoP, and a fit must still see where it does. Errs where the frame has no
/// heading to read the sky's pattern by.
pub fn sky_mask(cells: &Cells, ctx: &FieldContext, opts: &FieldOptions) -> Result<SkyMask, NoHeading> {
    let mut sc = robust::Scratch::default();
    let r = robust::robust(cells, ctx, opts, &mut sc).map_err(|e| e.1)?;
    Ok(SkyMask {
        cell_px: cells.cell_px,
        cols: cells.cols,
        rows: cells.rows,
        sky: sc.sky_cells(cells.grid_len()),
        heading_deg: r.heading_deg,
    })
}

#[cfg(test)]
mod tests;
