//! What a [`Compass`] is given — its configuration, each frame's sun and attitude —
//! with each input's range, and the typed error that refuses one outside it.

#[cfg(doc)]
use super::{Compass, FieldHeading, NoHeading};
use super::{Extractor, FieldOptions};
use crate::calibration::Calibration;
use crate::camera::Intrinsics;
use crate::sensor::{Channel, ColourTiles, DEFAULT_MOSAIC};

/// Why the compass cannot read a frame (a frame that it reads but whose sky gives no
/// heading is not an error: [`FieldHeading::result`] says why).
///
/// ```
/// # use bpins_core::camera::{Intrinsics, Projection};
/// # use bpins_core::compass::{Attitude, Compass, CompassConfig, CompassError, Sun};
/// # use bpins_core::compass::RawImage;
/// # let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
/// # let scene = bpins_core::twin::Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
/// # let f = bpins_core::twin::ChainFrame::new(&Default::default(), &lens, &scene, &bpins_core::sensor::Response::samples(2400.0), bpins_core::twin::NoiseIndex { seed: 1, trial: 0, frame: 0 });
/// # let raw: Vec<u16> = bpins_core::twin::render_mosaic(&f, 306, 256, &bpins_core::sensor::DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
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
pub(super) fn check_sun(az: f64, el: f64, sigma: f64) -> Result<(), CompassError> {
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
pub(super) fn check_attitude(a: &Attitude) -> Result<(), CompassError> {
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

/// The sun of one frame: its angles given, or a time and place from which the compass
/// finds the source that lights the sky (the sun, or at night the moon).
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
    /// a place, read by the rule `bpins heading` reads a capture's `time_utc` by
    /// (`sky::source_from_unix_time`): the sun through NREL SPA (±0.0003°) by day and in
    /// a twilight it dominates; the moon (Meeus ch. 47, 1σ ⊕ 0.005°) at night where it is
    /// up and its sky gives ≥ 99 % of the light; a twilight lit by both read with both
    /// sources where the smaller gives ≥ 0.1 % (`Shares::reads_both`; on a colour
    /// sensor band by band, each band's share fitted); a dark night a reading without a
    /// heading ([`NoHeading::DarkNight`]).
    /// The reading's [`FieldHeading::source`] says which. `sigma_deg` for the clock's
    /// and the position's error, in degrees of the source's angle. (Feature `spa`, on
    /// by default.)
    #[cfg(feature = "spa")]
    UnixTime { time_s: f64, latitude_deg: f64, longitude_deg: f64, sigma_deg: f64 },
}

impl Sun {
    /// The time and place of `sun` as [`Sun::UnixTime`] where they give a twilight lit
    /// by both the sun and the moon, the smaller share at least
    /// [`crate::sky::twilight::READ_BOTH_SHARE`] (`Shares::reads_both`), and the frame is
    /// not a dark night: a sky the compass reads with both sources; `None` otherwise
    /// (angles given, unplaced, one source's sky, a dark night, or a time that does not
    /// parse). A capture's frame or a bag's stamp gives its source as a
    /// [`crate::sky::sun::SunPosition`]: `bpins heading` reads such frames through this.
    #[cfg(feature = "spa")]
    pub fn mixed_twilight(sun: &crate::sky::sun::SunPosition, sigma_deg: f64) -> Option<Sun> {
        use crate::sky::sun::SunSource;
        let (SunSource::Spa { time_utc, latitude_deg, longitude_deg }
        | SunSource::Moon { time_utc, latitude_deg, longitude_deg, .. }) = &sun.source
        else {
            return None;
        };
        let shares = crate::sky::twilight::shares_at(time_utc, *latitude_deg, *longitude_deg).ok()?;
        if !shares.reads_both() || matches!(crate::sky::refusal(sun, &shares), Some(crate::sky::Refusal::Dark(_))) {
            return None;
        }
        let t = crate::sky::sun::parse_time_utc(time_utc).ok()?;
        let time_s = t.timestamp() as f64 + f64::from(t.timestamp_subsec_nanos()) * 1e-9;
        Some(Sun::UnixTime { time_s, latitude_deg: *latitude_deg, longitude_deg: *longitude_deg, sigma_deg })
    }
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
/// use bpins_core::compass::Extractor;
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
    /// A colour-polarization sensor's filters over the analyzer tiles (`None`:
    /// monochrome): each band is read from its own pixels, and [`Compass::heading`]
    /// returns the bands' fused heading ([`Compass::colour_headings`] each band's).
    ///
    /// [`Compass::heading`]: crate::compass::Compass::heading
    /// [`Compass::colour_headings`]: crate::compass::Compass::colour_headings
    pub colour: Option<ColourTiles>,
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
            colour: None,
        }
    }
}
