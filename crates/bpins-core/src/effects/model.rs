//! The chain's parameters: one block per stage, which `Apply::Frame` effects fold
//! into ([`GeometryBlock`], [`SkyBlock`], [`ChannelBlock`]), and one array per kind of
//! hook ([`Model`]); [`EffectSet`], a selection of effects with their values, folds
//! into them.

use super::{analyzer_slot, ray_slot, stage_slot, Apply, EffectDef};
use super::{
    neutral_analyzer_params, neutral_mosaic_params, neutral_ray_params, neutral_sensor_params, neutral_sky_params,
};
use super::{AnalyzerParams, RayParams, SensorParams, SkyParams};
use super::{ANALYZER_COUNT, MOSAIC_COUNT, RAY_COUNT, SENSOR_COUNT, SKY_COUNT};
#[cfg(doc)]
use super::{ANALYZER_EFFECTS, MOSAIC_EFFECTS, RAY_EFFECTS, SENSOR_EFFECTS, SKY_EFFECTS};
use crate::catalog::Selection;
use crate::error::Result;

/// The geometry stage's parameter block: the true camera and its mount relative to
/// the nominal ones (`Apply::Frame` effects fold into it: `principal_point`,
/// `focal_length`, `radial_distortion`, `mount_tilt`). Angles in degrees.
#[derive(Clone, Debug, PartialEq)]
pub struct GeometryBlock {
    /// True principal point minus nominal, (x, y) px.
    pub pp_offset_px: [f64; 2],
    /// True focal length = nominal · (1 + focal_scale).
    pub focal_scale: f64,
    /// Radial distortion (k1, k2) of the normalised coordinates, added to the nominal.
    pub distortion: [f64; 2],
    /// Camera tilt on its mount about camera x then y, degrees.
    pub mount_tilt_deg: [f64; 2],
}

impl Default for GeometryBlock {
    fn default() -> Self {
        GeometryBlock { pp_offset_px: [0.0; 2], focal_scale: 0.0, distortion: [0.0; 2], mount_tilt_deg: [0.0; 2] }
    }
}

/// The sky stage's parameter block (`sky_depolarization` folds into it); the sky's
/// per-ray effects are hooks ([`Model::sky`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyBlock {
    /// Factor on the scene's sky d_max (1: as the scene says).
    pub dmax_factor: f64,
}

impl Default for SkyBlock {
    fn default() -> Self {
        SkyBlock { dmax_factor: 1.0 }
    }
}

/// The four channels' parameter block, by channel index (0°, 45°, 90°, 135°): each
/// channel's analyzer (analyzer stage) and the gain and offset behind it (sensor
/// stage). `analyzer_angles`, `array_rotation`, `extinction_ratio` and
/// `channel_response` fold into it; per-pixel analyzer and sensor effects are hooks.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelBlock {
    /// Each analyzer's angle minus nominal, degrees.
    pub analyzer_delta_deg: [f64; 4],
    /// Each analyzer's ε = 1/ER.
    pub analyzer_eps: [f64; 4],
    /// Relative gain of each channel (1 + gain_k); channel 0 is the reference.
    pub gain: [f64; 4],
    /// Offset of each channel, DN, added to the black level.
    pub offset_dn: [f64; 4],
}

impl Default for ChannelBlock {
    fn default() -> Self {
        ChannelBlock { analyzer_delta_deg: [0.0; 4], analyzer_eps: [0.0; 4], gain: [1.0; 4], offset_dn: [0.0; 4] }
    }
}

/// The colour bands' parameter block of a colour-polarization sensor (CONVENTIONS.md
/// `colour_tiles`), by [`Band::index`](crate::sensor::Band::index) (R, G, B): what each
/// band's pixels see of the sky and how their filter, photodiode and analyzer respond.
/// `sky_spectrum` and `band_response` fold into it; the chain reads it where a frame
/// is made for one band (`ChainFrame::in_band`), so a monochrome sensor never does.
/// Green is the reference band: the scene's radiance and d_max are green's.
#[derive(Clone, Debug, PartialEq)]
pub struct BandBlock {
    /// The sky's radiance in each band relative to green's (clear sky: blue brighter).
    pub radiance: [f64; 3],
    /// Factor on the scene's d_max in each band (clear sky: blue less polarized).
    pub dmax_factor: [f64; 3],
    /// Each band's quantum efficiency × filter transmittance × gain relative to green's.
    pub gain: [f64; 3],
    /// ε = 1/ER each band's analyzers add to their channel's.
    pub eps: [f64; 3],
    /// The sky's multiple scattering in each band relative to green's, as the sky
    /// effects that model it read it from their frame (`FrameContext::multiple_scattering`:
    /// the neutral points' separation scales by it).
    pub multiple_scattering: [f64; 3],
}

impl Default for BandBlock {
    fn default() -> Self {
        BandBlock {
            radiance: [1.0; 3],
            dmax_factor: [1.0; 3],
            gain: [1.0; 3],
            eps: [0.0; 3],
            multiple_scattering: [1.0; 3],
        }
    }
}

/// The chain's parameters: one block per stage (what `Apply::Frame` effects fold
/// into) and one array per kind of hook (each effect's vector in its slot), the ideal
/// chain plus what enabled effects put in. `Model::default()` is the ideal chain. No
/// field is named after an effect.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The geometry stage: the true camera and mount.
    pub geometry: GeometryBlock,
    /// The sky stage's block: its peak DoLP.
    pub sky_block: SkyBlock,
    /// Each sky effect's vector, slot `k` for [`SKY_EFFECTS`]`[k]` (its neutral vector
    /// where the effect is off), before the frame's completion.
    pub sky: [SkyParams; SKY_COUNT],
    /// Each per-pixel effect's vector, slot `k` for [`RAY_EFFECTS`]`[k]` (its neutral
    /// vector where the effect is off). Read one through its module (e.g.
    /// `lens_diattenuation::rho2`), never by a slot number written out.
    pub ray: [RayParams; RAY_COUNT],
    /// Each analyzer effect's vector, slot `k` for [`ANALYZER_EFFECTS`]`[k]` (its
    /// neutral vector where the effect is off).
    pub analyzer: [AnalyzerParams; ANALYZER_COUNT],
    /// The analyzer and sensor stages' per-channel block.
    pub channels: ChannelBlock,
    /// Each sensor effect's vector, slot `k` for [`SENSOR_EFFECTS`]`[k]`.
    pub sensor: [SensorParams; SENSOR_COUNT],
    /// Each mosaic effect's vector, slot `k` for [`MOSAIC_EFFECTS`]`[k]`.
    pub mosaic: [SensorParams; MOSAIC_COUNT],
    /// The colour bands' block (read only for a colour sensor's band frames).
    pub bands: BandBlock,
}

impl Default for Model {
    fn default() -> Self {
        Model {
            geometry: GeometryBlock::default(),
            sky_block: SkyBlock::default(),
            sky: *neutral_sky_params(),
            ray: *neutral_ray_params(),
            analyzer: *neutral_analyzer_params(),
            channels: ChannelBlock::default(),
            sensor: *neutral_sensor_params(),
            mosaic: *neutral_mosaic_params(),
            bands: BandBlock::default(),
        }
    }
}

impl Model {
    /// The camera `nominal` with this model's geometry folded in: principal point
    /// moved, focal length scaled, radial distortion added. The chain's true camera,
    /// and the camera a heading extractor assumes when the model is a calibration.
    pub fn camera(&self, nominal: &crate::camera::Intrinsics) -> crate::camera::Intrinsics {
        let g = &self.geometry;
        crate::camera::Intrinsics {
            f_px: nominal.f_px * (1.0 + g.focal_scale),
            distortion: [nominal.distortion[0] + g.distortion[0], nominal.distortion[1] + g.distortion[1]],
            cx_px: nominal.cx_px + g.pp_offset_px[0],
            cy_px: nominal.cy_px + g.pp_offset_px[1],
            ..*nominal
        }
    }

    /// The vector of per-pixel effect `def` (its neutral vector where it is off).
    ///
    /// # Panics
    /// If `def` is a frame effect, which has no per-pixel vector: a programming error.
    pub fn ray_params(&self, def: &EffectDef) -> &RayParams {
        &self.ray[ray_slot(def).unwrap_or_else(|| panic!("{} is not a per-pixel effect", def.name))]
    }
}

/// A set of enabled effects with their values: the catalog's [`Selection`] of effects,
/// which folds into the chain's parameter block ([`EffectSet::model`]).
pub type EffectSet = Selection<EffectDef>;

impl EffectSet {
    /// Parses `effect.param=value` (as given to `--effect`) and applies it.
    pub fn parse_assignment(&mut self, spec: &str) -> Result<()> {
        self.parse(spec)
    }

    /// The chain's parameter block with every enabled effect folded in.
    pub fn model(&self) -> Model {
        let mut m = Model::default();
        for (def, vals) in self.iter() {
            match def.apply {
                Apply::Frame(fold) => fold(vals, &mut m),
                Apply::Ray { params, .. } => {
                    m.ray[ray_slot(def).expect("a per-pixel effect has a slot")] = params(vals)
                }
                Apply::Analyzer { params, .. } => {
                    m.analyzer[analyzer_slot(def).expect("an analyzer effect has a slot")] = params(vals)
                }
                Apply::Sky { params, .. } => m.sky[stage_slot(def).expect("a sky effect has a slot")] = params(vals),
                Apply::Sensor { params, .. } => {
                    m.sensor[stage_slot(def).expect("a sensor effect has a slot")] = params(vals)
                }
                Apply::Mosaic { params, .. } => {
                    m.mosaic[stage_slot(def).expect("a mosaic effect has a slot")] = params(vals)
                }
            }
        }
        m
    }
}
