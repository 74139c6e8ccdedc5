//! The front door for a robot: a [`Compass`] built once from the camera, the sensor
//! and a calibration; per frame it takes the raw mosaic as the camera delivers it
//! (borrowed `u8`, `u16` or `f32` with a row stride, no copy), the sun (angles, or a
//! Unix time and a place through NREL SPA) and the attitude with its 1σ, and returns
//! the heading with an honest 1σ, how much of the sky it used, or why there is none
//! (the field estimator, [`crate::heading::field`]).
//!
//! ```
//! use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
//! use bpins_core::camera::{Intrinsics, Projection};
//! use bpins_core::compass::RawImage;
//! # use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
//! # use bpins_core::sensor::{Response, DEFAULT_MOSAIC};
//! # let (w, h) = (306, 256);
//! # let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
//! # let scene = Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 2.0, tilt_y_deg: -1.0, dmax: 0.6 };
//! # let f = ChainFrame::new(&Default::default(), &lens, &scene, &Response::samples(2400.0), NoiseIndex { seed: 1, trial: 0, frame: 0 });
//! # let raw: Vec<u16> = bpins_core::internal::simulate::render_mosaic(&f, w, h, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
//! // Once: the camera (an IMX250MZR-like DoFP sensor behind an 8 mm lens, binned) and
//! // its calibration (here none: `Calibration::load("calibration.toml")` for a real one).
//! let mut compass = Compass::new(CompassConfig::dofp(
//!     Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5),
//!     306, 256, 12, 64.0,
//! ))?;
//! // Per frame: the camera's buffer, the sun, the IMU's attitude.
//! let fix = compass.heading(
//!     RawImage { data: &raw, width_px: 306, height_px: 256, stride: 306 },
//!     Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 },
//!     Attitude { tilt_x_deg: 2.0, tilt_y_deg: -1.0, sigma_deg: 0.1 },
//! )?;
//! let (heading_deg, sigma_deg) = (fix.heading_deg().unwrap(), fix.sigma_deg().unwrap());
//! assert!((heading_deg - 30.0).abs() < 2.0 * sigma_deg);
//! # Ok::<(), bpins_core::compass::CompassError>(())
//! ```
//!
//! Frame: the camera's (CONVENTIONS.md); the attitude is the frame's tilt about the
//! camera's x then y axis (an IMU's roll and pitch in that convention), the heading
//! the azimuth of the image top, degrees from North toward East in [0°, 360°).
//! Errors are typed ([`CompassError`]); nothing here panics on input or aborts the
//! host: buffers that do not match the sensor are refused with their sizes.

pub use crate::heading::field::{FieldHeading, FieldOptions, FieldQuality, NoHeading, RawDn, RawImage, SigmaParts};
pub use crate::heading::Extractor;

use crate::calibration::Calibration;
use crate::camera::Intrinsics;
use crate::effects::Model;
use crate::heading::field::{self, Cells, FieldContext, FieldScratch};
use crate::pixel_analyzers::CellAnalyzers;
use crate::recon::Reconstructor;
use crate::sensor::{Channel, DEFAULT_MOSAIC};
#[cfg(feature = "spa")]
use crate::sky::sun::sun_from_unix_time;

/// Why the compass cannot read a frame (a frame that it reads but whose sky gives no
/// heading is not an error: [`FieldHeading::result`] says why).
///
/// ```
/// # use bpins_core::camera::{Intrinsics, Projection};
/// # use bpins_core::compass::{Attitude, Compass, CompassConfig, CompassError, Sun};
/// # use bpins_core::internal::heading::field::RawImage;
/// # let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
/// # let scene = bpins_core::internal::chain::Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
/// # let f = bpins_core::internal::chain::ChainFrame::new(&Default::default(), &lens, &scene, &bpins_core::sensor::Response::samples(2400.0), bpins_core::internal::chain::NoiseIndex { seed: 1, trial: 0, frame: 0 });
/// # let raw: Vec<u16> = bpins_core::internal::simulate::render_mosaic(&f, 306, 256, &bpins_core::sensor::DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
/// let mut compass = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0))?;
/// let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
/// // A buffer cut short (a dropped packet) is refused with its sizes, not read past.
/// let short = RawImage { data: &raw[..1000], width_px: 306, height_px: 256, stride: 306 };
/// match compass.heading(short, sun, Attitude::default()) {
///     Err(CompassError::FrameSize { len, want_w, want_h, .. }) => assert_eq!((len, want_w, want_h), (1000, 306, 256)),
///     other => panic!("{other:?}"),
/// }
/// // A sun angle that is not a number is an error too; a sky that gives no heading is not.
/// let bad = Sun::Angles { azimuth_deg: 40.0, elevation_deg: f64::NAN, sigma_deg: 0.0 };
/// assert!(matches!(compass.heading(RawImage::packed(&raw, 306, 256), bad, Attitude::default()), Err(CompassError::Sun(_))));
/// # Ok::<(), CompassError>(())
/// ```
#[derive(Debug, thiserror::Error)]
pub enum CompassError {
    #[error("the compass's configuration: {0}")]
    Config(String),
    #[error(
        "frame of {got_w} × {got_h} px (stride {stride}, {len} samples) does not match the sensor's {want_w} × {want_h} px: \
         give the sensor's width and height, a stride ≥ the width, and at least (height − 1)·stride + width samples"
    )]
    FrameSize { got_w: usize, got_h: usize, stride: usize, len: usize, want_w: usize, want_h: usize },
    #[error("sun: {0}")]
    Sun(String),
    #[error("attitude: {0}")]
    Attitude(String),
    #[error(transparent)]
    Core(#[from] crate::Error),
}

/// The sun's angles, each against its range: the error names the first one outside.
fn check_sun(az: f64, el: f64, sigma: f64) -> Result<(), CompassError> {
    let why = if !az.is_finite() {
        format!("azimuth {az}° is not a number (degrees from North toward East; any finite value)")
    } else if !(-90.0..=90.0).contains(&el) {
        format!("elevation {el}° is outside [−90, 90]° (degrees above the horizon)")
    } else if !(sigma >= 0.0 && sigma.is_finite()) {
        format!("1σ {sigma}° must be a finite number ≥ 0 (0 for an exactly known sun)")
    } else {
        return Ok(());
    };
    Err(CompassError::Sun(why))
}

/// The attitude's angles, each against its range: the error names the first one outside.
fn check_attitude(a: &Attitude) -> Result<(), CompassError> {
    let why = if !(a.tilt_x_deg.abs() < 90.0) {
        format!("tilt about x {}° is outside (−90, 90)° (a camera tilted past the horizon sees no sky)", a.tilt_x_deg)
    } else if !(a.tilt_y_deg.abs() < 90.0) {
        format!("tilt about y {}° is outside (−90, 90)° (a camera tilted past the horizon sees no sky)", a.tilt_y_deg)
    } else if !(a.sigma_deg >= 0.0 && a.sigma_deg.is_finite()) {
        format!("1σ {}° must be a finite number ≥ 0 (0 for an exactly known attitude)", a.sigma_deg)
    } else {
        return Ok(());
    };
    Err(CompassError::Attitude(why))
}

/// The sun of one frame.
///
/// ```
/// use bpins_core::compass::Sun;
/// // From an ephemeris or a sun sensor: azimuth from North toward East, elevation, 1σ.
/// let given = Sun::Angles { azimuth_deg: 135.2, elevation_deg: 31.4, sigma_deg: 0.05 };
/// # #[cfg(feature = "spa")] {
/// // From the clock and a GNSS fix (2026-06-21T02:30:00Z at 36.07° N, 120.38° E): the
/// // compass runs NREL SPA itself; 0.01° for a clock good to a couple of seconds.
/// let clock = Sun::UnixTime { time_s: 1_782_009_000.0, latitude_deg: 36.07, longitude_deg: 120.38, sigma_deg: 0.01 };
/// # let _ = clock;
/// # }
/// # let _ = given;
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sun {
    /// Azimuth (from North toward East) and elevation, degrees, with their 1σ.
    Angles { azimuth_deg: f64, elevation_deg: f64, sigma_deg: f64 },
    /// A time (seconds since 1970-01-01T00:00:00Z, as Unix and ROS clocks give it) and
    /// a place, through NREL SPA (±0.0003°); `sigma_deg` for the clock's and the
    /// position's error, in degrees of sun angle. (Feature `spa`, on by default.)
    #[cfg(feature = "spa")]
    UnixTime { time_s: f64, latitude_deg: f64, longitude_deg: f64, sigma_deg: f64 },
}

/// The frame's attitude as an IMU reads it: tilt about the camera's x then y axis,
/// degrees, and the 1σ of each angle.
///
/// ```
/// use bpins_core::compass::Attitude;
/// // An IMU's roll and pitch in the camera's axes (CONVENTIONS.md, Tilt), good to 0.1°:
/// // the heading's 1σ takes in 0.1°·|∂ψ/∂tilt| (about tan of the sun's elevation).
/// let imu = Attitude { tilt_x_deg: 2.4, tilt_y_deg: -0.8, sigma_deg: 0.1 };
/// // A camera held level on a gimbal, attitude known exactly:
/// let level = Attitude::default();
/// assert_eq!((level.tilt_x_deg, level.sigma_deg), (0.0, 0.0));
/// # let _ = imu;
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Attitude {
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
    pub sigma_deg: f64,
}

/// What a [`Compass`] is built from.
///
/// ```
/// use bpins_core::camera::{Intrinsics, Projection};
/// use bpins_core::compass::{Compass, CompassConfig};
/// use bpins_core::internal::heading::Extractor;
/// use bpins_core::sensor::Channel::*;
/// // A 2448 × 2048 IMX250MZR (3.45 µm pixels, 12 bit, black level 64 DN) behind a
/// // 4 mm lens, principal point at the image centre.
/// let lens = Intrinsics::new(Projection::Pinhole, 4000.0 / 3.45, 1223.5, 1023.5);
/// let mut cfg = CompassConfig::dofp(lens, 2448, 2048, 12, 64.0);
/// // Another mosaic order (90° 45° / 135° 0° is the default), the meridian-line
/// // extractor, a larger horizon margin for a robot among buildings:
/// cfg.mosaic = [[C0, C45], [C135, C90]];
/// cfg.extractor = Extractor::MeridianLine;
/// cfg.options.horizon_margin_deg = 10.0;
/// let compass = Compass::new(cfg)?;
/// # let _ = compass;
/// # Ok::<(), bpins_core::compass::CompassError>(())
/// ```
#[derive(Clone, Debug)]
pub struct CompassConfig {
    /// The camera's nominal intrinsics (the calibration's geometry is folded in).
    pub camera: Intrinsics,
    pub width_px: usize,
    pub height_px: usize,
    /// DoFP analyzer angles by tile row and column (default Sony IMX250MZR).
    pub mosaic: [[Channel; 2]; 2],
    pub bit_depth: u32,
    pub black_level_dn: f64,
    /// The sensor's known effects (`bpins fit`'s calibration.toml) and per-pixel
    /// maps (`bpins calibrate`'s), which must be of this sensor's size and mosaic.
    pub calibration: Calibration,
    pub options: FieldOptions,
    pub extractor: Extractor,
}

impl CompassConfig {
    /// A DoFP sensor with the default mosaic, no calibration, the default options and
    /// the `sun_vector` extractor.
    pub fn dofp(camera: Intrinsics, width_px: usize, height_px: usize, bit_depth: u32, black_level_dn: f64) -> Self {
        CompassConfig {
            camera,
            width_px,
            height_px,
            mosaic: DEFAULT_MOSAIC,
            bit_depth,
            black_level_dn,
            calibration: Calibration::default(),
            options: FieldOptions::default(),
            extractor: Extractor::SunVector,
        }
    }
}

/// A colocated capture's planes: their inversion and the cell size (`capture.rs`).
#[cfg_attr(not(feature = "io"), allow(dead_code))]
struct Colocated {
    rec: Reconstructor,
    cell_px: usize,
}

/// Live frames in, headings out: build once, then one call per frame (the module's
/// example shows a whole frame). Holds its buffers between frames, so a warm compass
/// allocates nothing per frame; one compass per camera and thread (it is `Send`).
///
/// ```
/// # use bpins_core::camera::{Intrinsics, Projection};
/// # use bpins_core::compass::{Attitude, Compass, CompassConfig, CompassError, Sun};
/// # use bpins_core::internal::heading::field::RawImage;
/// # let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
/// # let scene = bpins_core::internal::chain::Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
/// # let f = bpins_core::internal::chain::ChainFrame::new(&Default::default(), &lens, &scene, &bpins_core::sensor::Response::samples(2400.0), bpins_core::internal::chain::NoiseIndex { seed: 1, trial: 0, frame: 0 });
/// # let raw: Vec<u16> = bpins_core::internal::simulate::render_mosaic(&f, 306, 256, &bpins_core::sensor::DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
/// let mut compass = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0))?;
/// let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
/// let fix = compass.heading(RawImage::packed(&raw, 306, 256), sun, Attitude::default())?;
/// match &fix.result {
///     Ok((heading_deg, sigma)) => assert!((heading_deg - 30.0).abs() < 3.0 * sigma.total_deg()),
///     Err(why) => panic!("no heading: {why}"),
/// }
/// fn shared<T: Send>(_: &T) {}
/// shared(&compass);
/// # Ok::<(), CompassError>(())
/// ```
pub struct Compass {
    cfg: CompassConfig,
    known: Model,
    intr: Intrinsics,
    rec: Reconstructor,
    full_scale_dn: f64,
    cell_px: usize,
    /// Each cell's own reconstruction where the calibration has per-pixel maps.
    cell_analyzers: Option<CellAnalyzers>,
    /// A colocated capture's reconstruction (`None`: DoFP; `capture.rs`).
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    colocated: Option<Colocated>,
    /// The last frame's cells and the estimator's buffers, reused: no allocation per
    /// frame once they have grown to the sensor's grid.
    cells: Cells,
    scratch: FieldScratch,
}

impl Compass {
    /// Checks the configuration and prepares what every frame shares.
    pub fn new(cfg: CompassConfig) -> Result<Compass, CompassError> {
        let known = cfg.calibration.model();
        Compass::with_known(cfg, known)
    }

    /// [`Compass::new`] with the known effects given as the chain's parameter block
    /// rather than as `cfg.calibration`'s (whose per-pixel maps are still used).
    fn with_known(cfg: CompassConfig, known: Model) -> Result<Compass, CompassError> {
        let bad = |m: String| Err(CompassError::Config(m));
        if cfg.width_px < 4 || cfg.height_px < 4 {
            return bad(format!("sensor of {} × {} px: at least 4 × 4", cfg.width_px, cfg.height_px));
        }
        if !(1..=16).contains(&cfg.bit_depth) {
            return bad(format!("bit depth {} outside 1…16", cfg.bit_depth));
        }
        let full_scale_dn = ((1u32 << cfg.bit_depth) - 1) as f64;
        if !(cfg.black_level_dn >= 0.0 && cfg.black_level_dn < full_scale_dn) {
            return bad(format!("black level {} DN outside [0, {full_scale_dn})", cfg.black_level_dn));
        }
        let c = &cfg.camera;
        if !(c.f_px > 0.0 && c.f_px.is_finite()) {
            return bad(format!(
                "focal length {} px must be a finite number > 0 (the lens's focal length over the pixel pitch)",
                c.f_px
            ));
        }
        if !(c.cx_px.is_finite() && c.cy_px.is_finite()) {
            return bad(format!(
                "principal point ({}, {}) px must be finite (usually near the image centre)",
                c.cx_px, c.cy_px
            ));
        }
        let intr = known.camera(c);
        let rec = Reconstructor::new(&known, cfg.black_level_dn, &Channel::ALL)?;
        let cell_px = cfg.options.cell_px.unwrap_or_else(|| Cells::default_cell_px(cfg.width_px, cfg.height_px));
        let cell_px = (cell_px.max(2) + 1) & !1;
        let cell_analyzers = match &cfg.calibration.pixels {
            None => None,
            Some(px) => {
                if let Some(m) = cfg.calibration.pixels_conflict() {
                    return bad(m);
                }
                px.check_sensor(cfg.width_px, cfg.height_px, &cfg.mosaic).map_err(CompassError::Config)?;
                Some(px.cell_analyzers(cell_px, cfg.black_level_dn))
            }
        };
        Ok(Compass {
            cfg,
            known,
            intr,
            rec,
            full_scale_dn,
            cell_px,
            cell_analyzers,
            colocated: None,
            cells: Cells::default(),
            scratch: FieldScratch::default(),
        })
    }

    /// The heading of one raw DoFP frame under `sun` at `attitude`.
    pub fn heading<T: RawDn>(
        &mut self,
        frame: RawImage<T>,
        sun: Sun,
        attitude: Attitude,
    ) -> Result<FieldHeading, CompassError> {
        self.check_size(&frame)?;
        let (az, el, sun_sigma) = match sun {
            Sun::Angles { azimuth_deg, elevation_deg, sigma_deg } => (azimuth_deg, elevation_deg, sigma_deg),
            #[cfg(feature = "spa")]
            Sun::UnixTime { time_s, latitude_deg, longitude_deg, sigma_deg } => {
                let s = sun_from_unix_time(time_s, latitude_deg, longitude_deg)
                    .map_err(|e| CompassError::Sun(e.to_string()))?;
                (s.azimuth_deg, s.elevation_deg, sigma_deg)
            }
        };
        check_sun(az, el, sun_sigma)?;
        check_attitude(&attitude)?;
        self.fill_mosaic_cells(&frame);
        let ctx = field_context(self.intr, &self.known, (az, el, sun_sigma), &attitude);
        Ok(field::estimate_with(&self.cells, &ctx, &self.cfg.options, self.cfg.extractor, &mut self.scratch))
    }

    /// Whether `frame` is a buffer of the sensor's size: refused with its sizes if not.
    fn check_size<T>(&self, frame: &RawImage<T>) -> Result<(), CompassError> {
        let (w, h) = (self.cfg.width_px, self.cfg.height_px);
        if frame.width_px != w || frame.height_px != h || !frame.is_consistent() {
            return Err(CompassError::FrameSize {
                got_w: frame.width_px,
                got_h: frame.height_px,
                stride: frame.stride,
                len: frame.data.len(),
                want_w: w,
                want_h: h,
            });
        }
        Ok(())
    }

    /// Fills `self.cells` from a DoFP frame of the sensor's size (checked by the caller).
    fn fill_mosaic_cells<T: RawDn>(&mut self, frame: &RawImage<T>) {
        match &self.cell_analyzers {
            Some(cal) => self.cells.fill_from_mosaic_calibrated(
                frame,
                &self.cfg.mosaic,
                cal,
                self.full_scale_dn,
                &mut self.scratch.cells,
            ),
            None => self.cells.fill_from_mosaic(
                frame,
                &self.cfg.mosaic,
                &self.rec,
                self.full_scale_dn,
                self.cell_px,
                &mut self.scratch.cells,
            ),
        }
    }
}

/// What the field estimator knows about a frame: the camera `intr` as calibrated, the
/// known lens diattenuation and mount tilt of `known`, the sun `(azimuth, elevation,
/// 1σ)` in degrees and the reference attitude. The one place a heading's context is
/// made: the compass's frames, a capture's (`bpins heading`), the fit's masks and the
/// locator's sun all take theirs from here.
pub(crate) fn field_context(
    intr: Intrinsics,
    known: &Model,
    sun: (f64, f64, f64),
    attitude: &Attitude,
) -> FieldContext {
    FieldContext {
        intr,
        lens_rho2: crate::effects::lens_diattenuation::rho2(known),
        sun_az_deg: sun.0,
        sun_el_deg: sun.1,
        sun_sigma_deg: sun.2,
        tilt_x_deg: attitude.tilt_x_deg,
        tilt_y_deg: attitude.tilt_y_deg,
        tilt_sigma_deg: attitude.sigma_deg,
        mount_tilt_deg: known.geometry.mount_tilt_deg,
    }
}

#[cfg(feature = "io")]
mod capture;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::chain::{ChainFrame, NoiseIndex, Scene};
    use crate::sensor::Response;
    use crate::simulate::render_mosaic;

    pub(super) fn frame(truth: &Model, tilt: [f64; 2]) -> (Vec<u16>, Intrinsics) {
        frame_under(truth, tilt, 40.0, 25.0)
    }

    fn frame_under(truth: &Model, tilt: [f64; 2], sun_az_deg: f64, sun_el_deg: f64) -> (Vec<u16>, Intrinsics) {
        let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
        let scene =
            Scene { sun_az_deg, sun_el_deg, heading_deg: 30.0, tilt_x_deg: tilt[0], tilt_y_deg: tilt[1], dmax: 0.6 };
        let f = ChainFrame::new(
            truth,
            &lens,
            &scene,
            &Response::samples(2400.0),
            NoiseIndex { seed: 2, trial: 0, frame: 0 },
        );
        (render_mosaic(&f, 306, 256, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect(), lens)
    }

    #[test]
    fn u8_u16_f32_and_strided_buffers_give_the_same_heading() {
        let (raw, lens) = frame(&Model::default(), [1.0, 2.0]);
        let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
        let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
        let att = Attitude { tilt_x_deg: 1.0, tilt_y_deg: 2.0, sigma_deg: 0.0 };
        let a = c.heading(RawImage::packed(&raw, 306, 256), sun, att).unwrap();
        let f: Vec<f32> = raw.iter().map(|&x| x as f32).collect();
        let b = c.heading(RawImage::packed(&f, 306, 256), sun, att).unwrap();
        let mut padded = vec![0u16; 320 * 256];
        for v in 0..256 {
            padded[v * 320..][..306].copy_from_slice(&raw[v * 306..][..306]);
        }
        let s = c.heading(RawImage { data: &padded, width_px: 306, height_px: 256, stride: 320 }, sun, att).unwrap();
        assert_eq!(a, b);
        assert_eq!(a, s);
        let (h, sigma) = (a.heading_deg().unwrap(), a.sigma_deg().unwrap());
        assert!((h - 30.0).abs() < 0.02 && (h - 30.0).abs() < 3.0 * sigma, "{h} ± {sigma}");
        // An 8-bit camera: the DN scaled to 8 bits, black level too.
        let mut c8 = Compass::new(CompassConfig::dofp(lens, 306, 256, 8, 4.0)).unwrap();
        let raw8: Vec<u8> = raw.iter().map(|&x| ((x as f64 / 16.0).round() as u8).max(1)).collect();
        let r8 = c8.heading(RawImage::packed(&raw8, 306, 256), sun, att).unwrap();
        assert!((r8.heading_deg().unwrap() - 30.0).abs() < 0.1, "{r8:?}");
    }

    #[test]
    #[cfg(feature = "spa")]
    fn the_calibration_and_the_sun_from_a_clock_are_used() {
        use crate::effects::EffectSet;
        let mut truth = EffectSet::new();
        truth.set("array_rotation", "dtheta_deg", 0.5).unwrap();
        let (raw, lens) = frame(&truth.model(), [0.0, 0.0]);
        let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
        let read = |cal: Calibration| {
            let mut c =
                Compass::new(CompassConfig { calibration: cal, ..CompassConfig::dofp(lens, 306, 256, 12, 64.0) })
                    .unwrap();
            c.heading(RawImage::packed(&raw, 306, 256), sun, Attitude::default()).unwrap().heading_deg().unwrap()
        };
        let raw_err = read(Calibration::default()) - 30.0;
        let cal_err = read(Calibration { effects: truth.clone(), ..Default::default() }) - 30.0;
        assert!(raw_err.abs() > 0.3 && cal_err.abs() < 0.02, "uncalibrated {raw_err}, calibrated {cal_err}");
        // A clock and a place: 2026-06-21T02:30:00Z (10:30 local) at Qingdao, the sun
        // from SPA; the frame rendered under that sun reads back at its heading.
        let (time_s, lat, lon) = (1_782_009_000.0, 36.07, 120.38);
        let s = crate::sky::sun::sun_from_unix_time(time_s, lat, lon).unwrap();
        assert!(s.elevation_deg > 30.0 && s.elevation_deg < 80.0, "{s:?}");
        let (raw, lens) = frame_under(&Model::default(), [0.0, 0.0], s.azimuth_deg, s.elevation_deg);
        let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
        let t = Sun::UnixTime { time_s, latitude_deg: lat, longitude_deg: lon, sigma_deg: 0.0 };
        let r = c.heading(RawImage::packed(&raw, 306, 256), t, Attitude::default()).unwrap();
        assert!((r.heading_deg().unwrap() - 30.0).abs() < 0.03, "{r:?}");
        let bad = Sun::UnixTime { time_s: f64::NAN, latitude_deg: 0.0, longitude_deg: 0.0, sigma_deg: 0.0 };
        assert!(matches!(
            c.heading(RawImage::packed(&raw, 306, 256), bad, Attitude::default()),
            Err(CompassError::Sun(_))
        ));
    }

    #[test]
    fn compasses_on_several_threads_read_what_one_reads() {
        // Frames under three attitudes; one compass reads them in turn, then three
        // compasses, each on its own thread (and the first moved there), read them
        // at once: the same headings, bit for bit.
        let frames: Vec<(Vec<u16>, [f64; 2])> =
            [[0.0, 0.0], [3.0, -2.0], [-4.0, 1.0]].into_iter().map(|t| (frame(&Model::default(), t).0, t)).collect();
        let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
        let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
        let read_all = |c: &mut Compass| -> Vec<FieldHeading> {
            frames
                .iter()
                .map(|(raw, t)| {
                    let att = Attitude { tilt_x_deg: t[0], tilt_y_deg: t[1], sigma_deg: 0.05 };
                    c.heading(RawImage::packed(raw, 306, 256), sun, att).unwrap()
                })
                .collect()
        };
        let mut one = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
        let alone = read_all(&mut one);
        let together: Vec<Vec<FieldHeading>> = std::thread::scope(|s| {
            let mut handles = vec![s.spawn(|| read_all(&mut one))];
            for _ in 0..2 {
                handles.push(
                    s.spawn(|| read_all(&mut Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap())),
                );
            }
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for r in &together {
            assert_eq!(r, &alone);
        }
        assert!(alone.iter().all(|h| (h.heading_deg().unwrap() - 30.0).abs() < 0.05), "{alone:?}");
    }

    #[test]
    fn wrong_buffers_and_configurations_are_refused_not_panicked_on() {
        let (raw, lens) = frame(&Model::default(), [0.0, 0.0]);
        let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
        let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
        let short = c.heading(
            RawImage { data: &raw[..1000], width_px: 306, height_px: 256, stride: 306 },
            sun,
            Attitude::default(),
        );
        assert!(matches!(short, Err(CompassError::FrameSize { len: 1000, .. })), "{short:?}");
        let small = c.heading(RawImage::packed(&raw[..300 * 200], 300, 200), sun, Attitude::default());
        assert!(small.unwrap_err().to_string().contains("300 × 200"));
        let att = Attitude { tilt_x_deg: 95.0, ..Default::default() };
        assert!(matches!(c.heading(RawImage::packed(&raw, 306, 256), sun, att), Err(CompassError::Attitude(_))));
        for cfg in [
            CompassConfig::dofp(lens, 2, 2, 12, 64.0),
            CompassConfig::dofp(lens, 306, 256, 17, 64.0),
            CompassConfig::dofp(lens, 306, 256, 12, 5000.0),
            CompassConfig::dofp(Intrinsics { f_px: -1.0, ..lens }, 306, 256, 12, 64.0),
        ] {
            assert!(matches!(Compass::new(cfg), Err(CompassError::Config(_))));
        }
    }

    /// Each refusal names the value that is wrong and the range it must lie in, not
    /// only the values given (issue 35: "sun: azimuth 40°, elevation 95°, 1σ 0°").
    #[test]
    fn refusals_name_the_wrong_value_and_its_range() {
        let (raw, lens) = frame(&Model::default(), [0.0, 0.0]);
        let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
        let sun = |az, el, s| Sun::Angles { azimuth_deg: az, elevation_deg: el, sigma_deg: s };
        let msg = |c: &mut Compass, s: Sun, a: Attitude| {
            c.heading(RawImage::packed(&raw, 306, 256), s, a).unwrap_err().to_string()
        };
        let ok = sun(40.0, 25.0, 0.0);
        let level = Attitude::default();
        for (s, want) in [
            (sun(40.0, 95.0, 0.0), "elevation 95° is outside [−90, 90]°"),
            (sun(f64::NAN, 25.0, 0.0), "azimuth NaN° is not a number"),
            (sun(40.0, 25.0, -1.0), "1σ -1° must be a finite number ≥ 0"),
        ] {
            let m = msg(&mut c, s, level);
            assert!(m.starts_with("sun: ") && m.contains(want), "{m}");
        }
        for (a, want) in [
            (Attitude { tilt_x_deg: 95.0, ..level }, "tilt about x 95° is outside (−90, 90)°"),
            (Attitude { tilt_y_deg: -90.0, ..level }, "tilt about y -90° is outside (−90, 90)°"),
            (Attitude { sigma_deg: f64::INFINITY, ..level }, "1σ inf° must be a finite number ≥ 0"),
        ] {
            let m = msg(&mut c, ok, a);
            assert!(m.starts_with("attitude: ") && m.contains(want), "{m}");
        }
        let refusal = |cfg| Compass::new(cfg).err().expect("refused").to_string();
        let m = refusal(CompassConfig::dofp(Intrinsics { f_px: -5.0, ..lens }, 306, 256, 12, 64.0));
        assert!(m.contains("focal length -5 px must be a finite number > 0") && !m.contains("principal"), "{m}");
        let m = refusal(CompassConfig::dofp(Intrinsics { cx_px: f64::NAN, ..lens }, 306, 256, 12, 64.0));
        assert!(m.contains("principal point (NaN, 127.5) px must be finite"), "{m}");
        let m = c.heading(RawImage::packed(&raw[..300 * 200], 300, 200), ok, level).unwrap_err().to_string();
        assert!(m.contains("give the sensor's width and height"), "{m}");
    }
}
