//! How an effect enters the chain ([`Apply`]: a frame fold, or a hook of one stage)
//! and, for each kind of hook, its pure per-pixel function's signature (the same as its
//! WGSL twin's) and the per-frame parameter vector it reads.

use super::Model;
use crate::camera::RayGeometry;
use crate::stokes::{Analyzer, Stokes};
use glam::{DMat3, DVec3};

/// The per-frame parameter vector of one per-pixel effect (WGSL `vec4<f64>`).
pub type RayParams = [f64; 4];

/// A per-pixel effect's function: `(its RayParams, the ray, meridional-frame Stokes) →
/// meridional-frame Stokes`, pure; WGSL `fn name(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes`.
pub type RayFn = fn(p: &RayParams, g: &RayGeometry, s: Stokes) -> Stokes;

/// What a per-pixel or sky effect may know of the frame beyond its own values
/// (`Apply::Ray`'s and `Apply::Sky`'s `frame`): the sun, a unit vector in the true
/// camera frame, the true camera's axes in the ENU world (columns), and the sky's
/// multiple scattering relative to the green band's (1 for a monochrome frame; a colour
/// band's from `BandBlock::multiple_scattering`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameContext {
    pub sun_cam: DVec3,
    pub world_from_cam: DMat3,
    pub multiple_scattering: f64,
}

/// How many 4-vectors a sky effect's frame vector holds: room for a frame's constants
/// of the sky model (the quartic sky's world axes and neutral points take all five).
pub const SKY_WIDTH: usize = 5;

/// The per-frame vector of one sky effect (WGSL `array<vec4<f64>, SKY_WIDTH>`).
pub type SkyParams = [[f64; 4]; SKY_WIDTH];

/// A sky effect's function: `(its SkyParams, the sun (unit, camera frame), the sky's
/// peak DoLP d_max, the ray, the sky's meridional-frame Stokes vector so far) → the
/// sky's meridional-frame Stokes vector`, pure; WGSL `fn name(p: array<vec4<f64>, 5>,
/// sun: vec3<f64>, dmax: f64, g: RayGeometry, s: Stokes) -> Stokes`.
pub type SkyFn = fn(p: &SkyParams, sun: DVec3, dmax: f64, g: &RayGeometry, s: Stokes) -> Stokes;

/// The per-frame vector of one sensor or mosaic effect (WGSL `vec4<f64>`).
pub type SensorParams = [f64; 4];

/// A sensor effect's function: `(its SensorParams, the photo-signal above the offset
/// (DN, after PRNU), the ADC's full scale (DN)) → the signal (DN)`, pure; WGSL
/// `fn name(p: vec4<f64>, signal_dn: f64, full_scale_dn: f64) -> f64`.
pub type SensorFn = fn(p: &SensorParams, signal_dn: f64, full_scale_dn: f64) -> f64;

/// A mosaic effect's function: `(its SensorParams, a DoFP pixel's photo-signal, its
/// four edge neighbours' (up, down, left, right; 0 outside the sensor), DN) → the
/// pixel's photo-signal (DN)`, pure; WGSL `fn name(p: vec4<f64>, own: f64, up: f64,
/// down: f64, left: f64, right: f64) -> f64`.
pub type MosaicFn = fn(p: &SensorParams, own: f64, up: f64, down: f64, left: f64, right: f64) -> f64;

/// The per-frame parameter vector of one analyzer effect (WGSL `array<vec4<f64>, 2>`:
/// `p[0]` is `(x[0], …, x[3])`, `p[1]` is `(x[4], …, x[7])`).
pub type AnalyzerParams = [f64; 8];

/// Where an analyzer sits: pixel column `u` and row `v`, its channel index `ch`, and its
/// position relative to the principal point, px (WGSL struct `PixelSite`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelSite {
    pub u: u32,
    pub v: u32,
    pub ch: u32,
    pub x_px: f64,
    pub y_px: f64,
}

/// One pixel's analyzer and the gain behind it, DN per unit radiance (WGSL struct
/// `PixelAnalyzer`): what the analyzer effects change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelAnalyzer {
    pub analyzer: Analyzer,
    pub gain: f64,
}

/// An analyzer effect's function: `(its AnalyzerParams, the pixel's site, its ray, the
/// pixel's analyzer) → the pixel's analyzer`, pure; WGSL `fn name(p: array<vec4<f64>, 2>,
/// site: PixelSite, g: RayGeometry, a: PixelAnalyzer) -> PixelAnalyzer`.
pub type AnalyzerFn = fn(p: &AnalyzerParams, site: &PixelSite, g: &RayGeometry, a: PixelAnalyzer) -> PixelAnalyzer;

/// How an effect enters the chain.
#[derive(Clone, Copy, Debug)]
pub enum Apply {
    /// Adds the effect's parameter `values` (in `params` order) into the frame's
    /// parameter block `model`, which both backends read alike.
    Frame(fn(values: &[f64], model: &mut Model)),
    /// Acts on every ray's Stokes vector in its meridional frame, after the sky and the
    /// scene and before the rotation to the image frame, in registry order. `params`
    /// turns the values into the per-pixel vector once per frame (neutral values must
    /// give a vector at which `pixel` is exactly the identity); `pixel` is the per-pixel
    /// function, named as the effect and its WGSL twin. `frame`, where given, completes
    /// the vector with the frame's context ([`FrameContext`]: the sun in the camera
    /// frame) when the chain's frame is built (`ChainFrame::new`; it must leave a
    /// neutral vector as it is), so the pixel function and its WGSL twin read the
    /// sun from their vector on both backends (`stray_light`).
    Ray {
        params: fn(values: &[f64]) -> RayParams,
        frame: Option<fn(p: RayParams, context: &FrameContext) -> RayParams>,
        pixel: RayFn,
    },
    /// Changes each pixel's analyzer (angle, ε) and the gain behind it, per pixel and
    /// channel, in the image frame: after the channel's analyzer (`analyzer_angles`,
    /// `extinction_ratio`, `array_rotation`) and gain (`channel_response`), in registry
    /// order. `params` turns the values into the per-pixel vector once per frame
    /// (neutral values must give a vector at which `pixel` is exactly the identity);
    /// `pixel` reads the pixel's site and ray (`chain::site_signal_dn`).
    Analyzer { params: fn(values: &[f64]) -> AnalyzerParams, pixel: AnalyzerFn },
    /// Changes the sky's Stokes vector along each ray, in its meridional frame: after
    /// the Rayleigh sky (`sky::sky_stokes`) and before the scene elements, in registry
    /// order. `params` turns the values into the frame vector (neutral values must give
    /// a vector at which `pixel` is exactly the identity); `frame`, where given,
    /// completes it with the frame's context ([`FrameContext`]: the sun, the camera's
    /// axes in the world; it must leave a neutral vector as it is), so the sky model's
    /// frame constants are computed once per frame on the host for both backends
    /// (`sky_neutral_points`).
    Sky {
        params: fn(values: &[f64]) -> SkyParams,
        frame: Option<fn(p: SkyParams, context: &FrameContext) -> SkyParams>,
        pixel: SkyFn,
    },
    /// Changes each pixel's photo-signal (DN above the offset, after PRNU) before the
    /// offsets, noise and rounding (`chain::sensor_dn`), in registry order; applied at
    /// every pixel on both backends, so `pixel` at the neutral vector must be exactly
    /// the identity and cheap (`sensor_nonlinearity`).
    Sensor { params: fn(values: &[f64]) -> SensorParams, pixel: SensorFn },
    /// Mixes each DoFP pixel's photo-signal with its four edge neighbours'
    /// (`chain::mosaic_pixel_signal_dn`), in registry order; where one is on, every
    /// pixel's neighbours are evaluated (`crosstalk`).
    Mosaic { params: fn(values: &[f64]) -> SensorParams, pixel: MosaicFn },
}

impl Apply {
    pub(super) const fn is_ray(&self) -> bool {
        matches!(self, Apply::Ray { .. })
    }

    pub(super) const fn is_sky(&self) -> bool {
        matches!(self, Apply::Sky { .. })
    }

    pub(super) const fn is_sensor(&self) -> bool {
        matches!(self, Apply::Sensor { .. })
    }

    pub(super) const fn is_mosaic(&self) -> bool {
        matches!(self, Apply::Mosaic { .. })
    }

    pub(super) const fn is_analyzer(&self) -> bool {
        matches!(self, Apply::Analyzer { .. })
    }
}
