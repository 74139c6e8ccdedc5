//! The plain structs of the boundary and their conversion to and from the front
//! door's types. Enumerations the caller writes are `uint32_t` with `#define`d values
//! (an out-of-range value is an error, not undefined behaviour); those the library
//! writes are C enums. Angles in degrees, sizes in pixels, levels in DN; frames as in
//! CONVENTIONS.md (camera frame, azimuth from North toward East).

use crate::{BpinsStatus, Failure};
use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{Attitude, CompassConfig, Extractor, FieldHeading, FieldOptions, NoHeading, SkySource, Sun};
use bpins_core::sensor::{Band, Channel, ColourTiles, DEFAULT_MOSAIC};
use std::ffi::c_char;

/// A lens projection (`BPINS_PROJECTION_*`; CONVENTIONS.md, Camera).
pub type BpinsProjection = u32;
/// r = f·tan θ: an ordinary (rectilinear) lens.
pub const BPINS_PROJECTION_PINHOLE: BpinsProjection = 0;
/// r = f·θ: the usual fisheye.
pub const BPINS_PROJECTION_EQUIDISTANT: BpinsProjection = 1;
/// r = 2f·sin(θ/2).
pub const BPINS_PROJECTION_EQUISOLID: BpinsProjection = 2;
/// r = 2f·tan(θ/2).
pub const BPINS_PROJECTION_STEREOGRAPHIC: BpinsProjection = 3;

/// A heading extractor (`BPINS_EXTRACTOR_*`).
pub type BpinsExtractor = u32;
/// Least-squares sun vector over every used E-vector (the default).
pub const BPINS_EXTRACTOR_SUN_VECTOR: BpinsExtractor = 0;
/// The solar meridian line read off the AoE image.
pub const BPINS_EXTRACTOR_MERIDIAN_LINE: BpinsExtractor = 1;

/// How a `BpinsSun` gives the sun (`BPINS_SUN_*`).
pub type BpinsSunKind = u32;
/// `azimuth_deg` and `elevation_deg` are the sun's position.
pub const BPINS_SUN_ANGLES: BpinsSunKind = 0;
/// `unix_time_s`, `latitude_deg` and `longitude_deg` give it: the source that lights
/// the sky then, as `bpins heading` reads a capture's `time_utc` and place: the sun
/// (NREL SPA) by day, the moon at night where it is up and its sky the brighter
/// (`BpinsHeading::source` says which); a twilight lit by both is read with both
/// sources (a colour sensor's band by band, each band's share fitted); a dark night
/// is a frame without a heading (`BPINS_NO_HEADING_DARK_NIGHT`).
pub const BPINS_SUN_UNIX_TIME: BpinsSunKind = 1;

/// Bytes of `BpinsHeading::message`, its terminating NUL included.
pub const BPINS_MESSAGE_LEN: usize = 256;

/// What a compass is built from. Start from `bpins_compass_config_default()`, then
/// set the sensor's size, bit depth, black level and the lens.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BpinsCompassConfig {
    /// Lens projection, one of `BPINS_PROJECTION_*`.
    pub projection: BpinsProjection,
    /// Focal length, pixels: focal length / pixel pitch (8 mm / 3.45 µm = 2318.8 px).
    pub focal_length_px: f64,
    /// Principal point, pixels from the top-left pixel's centre, x to the right and
    /// y down ((width − 1)/2, (height − 1)/2 for a centred lens).
    pub cx_px: f64,
    pub cy_px: f64,
    /// Radial distortion k1, k2 of the normalised image coordinates, dimensionless:
    /// distorted = ideal·(1 + k1 r² + k2 r⁴) (0, 0: none).
    pub distortion_k1: f64,
    pub distortion_k2: f64,
    /// Sensor size, pixels (the whole mosaic, not one channel), at least 4 × 4.
    pub width_px: u32,
    pub height_px: u32,
    /// ADC bit depth, bits, 1…16 (full scale 2^bit_depth − 1 DN).
    pub bit_depth: u32,
    /// Black level, DN, in [0, full scale).
    pub black_level_dn: f64,
    /// Analyzer angle of each pixel of the 2 × 2 tile, degrees (0, 45, 90, 135, each
    /// once), as mosaic_deg[row][column] with the tile's top-left pixel at the image's
    /// top-left: {{90, 45}, {135, 0}} for the Sony IMX250MZR (the default).
    pub mosaic_deg: [[u32; 2]; 2],
    /// Heading extractor, one of `BPINS_EXTRACTOR_*`.
    pub extractor: BpinsExtractor,
    /// Cell size of the field estimator, pixels, even; 0: about 1/64 of the shorter
    /// side (the default).
    pub cell_px: u32,
    /// Rays lower than this above the horizon (plus 3σ of the tilt) are not used,
    /// degrees (default 3).
    pub horizon_margin_deg: f64,
    /// Cells closer than this to the sun or the anti-sun are not used, degrees
    /// (default 15).
    pub sun_exclusion_deg: f64,
    /// Fewest cells, and least fraction (0…1) of the image's cells, a heading may rest
    /// on (defaults 40 and 0.005: an overcast's holes may carry a heading).
    pub min_cells: u32,
    pub min_used_fraction: f64,
    /// Used cells misfitting by more than this RMS beyond their noise give no heading,
    /// degrees (default 4).
    pub max_residual_deg: f64,
    /// Floor of the heading's 1σ, degrees (default 0.01).
    pub sigma_floor_deg: f64,
    /// Half-width of the meridian line's AoE band, degrees (default 5).
    pub band_deg: f64,
    /// A colour-polarization sensor's colour filters over the 2 × 2 analyzer tiles,
    /// row-major: {'R', 'G', 'G', 'B'} for the Sony IMX250MYR (each of R, G, B at
    /// least once). All zero (the default): a monochrome sensor. A colour compass reads
    /// each band from its own pixels; `bpins_compass_heading_*` gives the bands' fused
    /// heading, `bpins_compass_band_headings_*` each band's.
    pub colour_tiles: [c_char; 4],
}

/// The colour bands, as indices of `bpins_compass_band_headings_*`'s output and of
/// `bpins_colour_maps_*`'s (`BPINS_BAND_*`).
pub type BpinsBand = u32;
pub const BPINS_BAND_R: BpinsBand = 0;
pub const BPINS_BAND_G: BpinsBand = 1;
pub const BPINS_BAND_B: BpinsBand = 2;

/// `colour_tiles` as the core's tiles: None when all zero; each of R, G, B at least
/// once (the compass's and the maps' configs alike).
pub(crate) fn colour_tiles_of(tiles: [c_char; 4]) -> Result<Option<ColourTiles>, String> {
    if tiles.iter().all(|&c| c == 0) {
        return Ok(None);
    }
    let mut t = ColourTiles::imx250myr();
    for (k, &c) in tiles.iter().enumerate() {
        let name = (c as u8 as char).to_string();
        t.tiles[k / 2][k % 2] = Band::from_name(&name).ok_or_else(|| {
            format!("colour_tiles[{k}] = {c}: 'R', 'G' or 'B' (all four zero for a monochrome sensor)")
        })?;
    }
    if t.bands().len() < 3 {
        return Err(format!("colour_tiles {:?}: each of R, G, B at least once", t.tiles));
    }
    Ok(Some(t))
}

/// The sun of one frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BpinsSun {
    /// `BPINS_SUN_ANGLES` or `BPINS_SUN_UNIX_TIME`: which fields below are read.
    pub kind: BpinsSunKind,
    /// `BPINS_SUN_ANGLES`: azimuth from North toward East, degrees, and elevation above
    /// the horizon, degrees (−90…90).
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    /// `BPINS_SUN_UNIX_TIME`: seconds since 1970-01-01T00:00:00Z (a ROS stamp's
    /// sec + 1e-9·nanosec), and the place: WGS 84 latitude (north positive) and
    /// longitude (east positive), degrees.
    pub unix_time_s: f64,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    /// 1σ of the sun's position, degrees (0: exact); it enters the heading's 1σ 1:1.
    pub sigma_deg: f64,
}

/// The frame's attitude as an IMU reads it: tilt about the camera's x then y axis
/// (CONVENTIONS.md, Tilt), degrees, each below 90° in magnitude, and the 1σ of each
/// angle, degrees (0: exact).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BpinsAttitude {
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
    pub sigma_deg: f64,
}

/// Why a frame has no heading (`BpinsHeading::reason`).
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BpinsNoHeading {
    /// The frame has a heading.
    BPINS_NO_HEADING_NONE = 0,
    /// The sun is more than 10° below the horizon (past nautical twilight).
    BPINS_NO_HEADING_SUN_TOO_LOW = 1,
    /// The sun is within 1° of the zenith: the pattern has no azimuth.
    BPINS_NO_HEADING_SUN_AT_ZENITH = 2,
    /// Too little of the image fits the sky model (overcast, obstructed, dark).
    BPINS_NO_HEADING_TOO_LITTLE_SKY = 3,
    /// Two headings fit the pattern almost equally.
    BPINS_NO_HEADING_AMBIGUOUS = 4,
    /// The used sky misfits the model by more than `max_residual_deg` beyond its noise.
    BPINS_NO_HEADING_POOR_FIT = 5,
    /// The solver failed (see the message).
    BPINS_NO_HEADING_SOLVER = 6,
    /// The sky contradicts the given sun, attitude or mosaic layout beyond their 1σ
    /// (a wrong clock or place, a wrong tilt, a flipped mosaic).
    BPINS_NO_HEADING_CONTRADICTS = 7,
    /// The frame is too dark to tell: its polarized signal is below the noise.
    BPINS_NO_HEADING_TOO_DARK = 8,
    /// `BPINS_SUN_UNIX_TIME`: the sun and the moon both light the sky and neither gives
    /// 99 % of its light (a twilight with the moon up); the message names both shares.
    /// Kept for the ABI: the compass, monochrome or colour, now reads such a sky with
    /// both sources.
    BPINS_NO_HEADING_MIXED_SKY = 9,
    /// `BPINS_SUN_UNIX_TIME`: the sun is past −10° and no moon is up bright enough to be
    /// read alone (a dark night); the message gives both elevations.
    BPINS_NO_HEADING_DARK_NIGHT = 10,
}

/// Which source lit the sky a heading was read about (`BpinsHeading::source`).
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BpinsSource {
    /// `BPINS_SUN_ANGLES`: the caller gave the angles (of the sun or the moon).
    BPINS_SOURCE_GIVEN = 0,
    /// `BPINS_SUN_UNIX_TIME`: the sun (NREL SPA), by day or in a twilight it dominates.
    BPINS_SOURCE_SUN = 1,
    /// `BPINS_SUN_UNIX_TIME`: the moon (Meeus ch. 47), at night where it is up and its
    /// sky gives at least 99 % of the light; the sun's 1σ part then includes the moon
    /// ephemeris's 0.005°.
    BPINS_SOURCE_MOON = 2,
}

/// One frame's result. Without a heading (`has_heading` false) the heading and its
/// 1σ are NaN and `reason`, `message` say why; the quality fields are filled either
/// way.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct BpinsHeading {
    /// Whether the frame has a heading.
    pub has_heading: bool,
    /// Which source lit the sky (set with or without a heading). It lies in what was
    /// padding after `has_heading`: the struct's size and every other field's offset
    /// are those of the headers without it.
    pub source: BpinsSource,
    /// Heading: azimuth of the image top, degrees from North toward East, [0, 360).
    pub heading_deg: f64,
    /// The heading's 1σ, degrees: max(fit, jackknife, coherent) in quadrature with the
    /// misfit's, the cross-check's, the tilt's, the sun's and the floor's parts below.
    pub sigma_deg: f64,
    /// Parts of the 1σ, degrees: the extractor's residuals (χ²-scaled), the
    /// delete-one-block jackknife, the spatial sandwich over the cell grid (misfit
    /// shared by neighbouring cells: cloud rims, an unmodelled sky), the attitude's 1σ
    /// propagated, the sun's 1σ propagated, the floor.
    pub sigma_fit_deg: f64,
    pub sigma_jackknife_deg: f64,
    pub sigma_coherent_deg: f64,
    /// The used sky's misfit beyond its noise (a turn it shares), and the two
    /// extractors' disagreement beyond their 1σ, degrees.
    pub sigma_misfit_deg: f64,
    pub sigma_cross_deg: f64,
    pub sigma_tilt_deg: f64,
    pub sigma_sun_deg: f64,
    pub sigma_floor_deg: f64,
    /// Fraction (0…1) of the image's cells the heading rests on.
    pub used_fraction: f64,
    /// Fraction (0…1) of the observed cells taken for cloud.
    pub cloud_fraction: f64,
    /// Weighted RMS angle residual of the used cells, degrees.
    pub residual_rms_deg: f64,
    /// Cells of the image grid, cells past the masks, cells the final fit used.
    pub cells_total: u32,
    pub cells_valid: u32,
    pub cells_used: u32,
    /// Sun elevation the sky shows minus the given one, degrees (a check on the
    /// attitude and the sun).
    pub sun_elevation_offset_deg: f64,
    /// Why there is no heading (`BPINS_NO_HEADING_NONE` when there is one).
    pub reason: BpinsNoHeading,
    /// The reason in words, UTF-8, NUL-terminated ("" when there is a heading).
    pub message: [c_char; BPINS_MESSAGE_LEN],
}

fn config_error(m: String) -> Failure {
    Failure::new(BpinsStatus::BPINS_ERR_CONFIG, format!("the compass's configuration: {m}"))
}

/// A config's `mosaic_deg` as channels: each of 0, 45, 90, 135 exactly once (the
/// compass's and the maps' configs alike); the error says which entry is wrong.
pub(crate) fn mosaic_of_deg(mosaic_deg: [[u32; 2]; 2]) -> Result<[[Channel; 2]; 2], String> {
    let mut mosaic = DEFAULT_MOSAIC;
    let mut seen = [false; 4];
    for (r, row) in mosaic_deg.iter().enumerate() {
        for (c, &deg) in row.iter().enumerate() {
            let ch = Channel::from_angle_deg(deg as f64).filter(|ch| !seen[ch.index()]).ok_or_else(|| {
                format!("mosaic_deg {mosaic_deg:?}: each of 0, 45, 90, 135 exactly once (mosaic_deg[{r}][{c}] = {deg})")
            })?;
            seen[ch.index()] = true;
            mosaic[r][c] = ch;
        }
    }
    Ok(mosaic)
}

impl BpinsCompassConfig {
    /// The defaults: pinhole, IMX250MZR mosaic, sun-vector extractor, the field
    /// estimator's default options; size, bit depth, black level and lens zero (a
    /// compass refuses them until they are set).
    pub fn default_values() -> Self {
        let o = FieldOptions::default();
        let deg = |c: Channel| c.angle_deg() as u32;
        BpinsCompassConfig {
            projection: BPINS_PROJECTION_PINHOLE,
            focal_length_px: 0.0,
            cx_px: 0.0,
            cy_px: 0.0,
            distortion_k1: 0.0,
            distortion_k2: 0.0,
            width_px: 0,
            height_px: 0,
            bit_depth: 0,
            black_level_dn: 0.0,
            mosaic_deg: DEFAULT_MOSAIC.map(|row| row.map(deg)),
            extractor: BPINS_EXTRACTOR_SUN_VECTOR,
            cell_px: o.cell_px.unwrap_or(0) as u32,
            horizon_margin_deg: o.horizon_margin_deg,
            sun_exclusion_deg: o.sun_exclusion_deg,
            min_cells: o.min_cells as u32,
            min_used_fraction: o.min_used_fraction,
            max_residual_deg: o.max_residual_deg,
            sigma_floor_deg: o.sigma_floor_deg,
            band_deg: o.band_deg,
            colour_tiles: [0; 4],
        }
    }

    /// The front door's configuration; what `Compass::new` does not check (the
    /// enumerations, the mosaic, the options) is checked here.
    pub(crate) fn to_core(self) -> Result<CompassConfig, Failure> {
        let projection = *Projection::ALL
            .get(self.projection as usize)
            .ok_or_else(|| config_error(format!("projection {}: one of BPINS_PROJECTION_* (0…3)", self.projection)))?;
        let extractor = *Extractor::ALL
            .get(self.extractor as usize)
            .ok_or_else(|| config_error(format!("extractor {}: one of BPINS_EXTRACTOR_* (0…1)", self.extractor)))?;
        let mosaic = mosaic_of_deg(self.mosaic_deg).map_err(config_error)?;
        let [k1, k2] = [self.distortion_k1, self.distortion_k2];
        if !(k1.is_finite() && k2.is_finite()) {
            return Err(config_error(format!("distortion k1 {k1}, k2 {k2}: finite numbers")));
        }
        if self.cell_px % 2 == 1 {
            return Err(config_error(format!("cell_px {}: even (whole 2 × 2 tiles), or 0", self.cell_px)));
        }
        let o = &self;
        for (name, v) in [
            ("horizon_margin_deg", o.horizon_margin_deg),
            ("sun_exclusion_deg", o.sun_exclusion_deg),
            ("max_residual_deg", o.max_residual_deg),
            ("sigma_floor_deg", o.sigma_floor_deg),
            ("band_deg", o.band_deg),
        ] {
            if !(v.is_finite() && (0.0..90.0).contains(&v)) {
                return Err(config_error(format!("{name} {v}°: in [0°, 90°)")));
            }
        }
        if !(0.0..=1.0).contains(&o.min_used_fraction) {
            return Err(config_error(format!("min_used_fraction {}: in [0, 1]", o.min_used_fraction)));
        }
        let mut camera = Intrinsics::new(projection, self.focal_length_px, self.cx_px, self.cy_px);
        camera.distortion = [k1, k2];
        let mut cfg = CompassConfig::dofp(
            camera,
            self.width_px as usize,
            self.height_px as usize,
            self.bit_depth,
            self.black_level_dn,
        );
        cfg.mosaic = mosaic;
        cfg.extractor = extractor;
        cfg.colour = colour_tiles_of(self.colour_tiles).map_err(config_error)?;
        cfg.options = FieldOptions {
            cell_px: (o.cell_px > 0).then_some(o.cell_px as usize),
            horizon_margin_deg: o.horizon_margin_deg,
            sun_exclusion_deg: o.sun_exclusion_deg,
            min_cells: o.min_cells as usize,
            min_used_fraction: o.min_used_fraction,
            max_residual_deg: o.max_residual_deg,
            sigma_floor_deg: o.sigma_floor_deg,
            band_deg: o.band_deg,
            ..FieldOptions::default()
        };
        Ok(cfg)
    }
}

impl BpinsSun {
    pub(crate) fn to_core(self) -> Result<Sun, Failure> {
        match self.kind {
            BPINS_SUN_ANGLES => Ok(Sun::Angles {
                azimuth_deg: self.azimuth_deg,
                elevation_deg: self.elevation_deg,
                sigma_deg: self.sigma_deg,
            }),
            BPINS_SUN_UNIX_TIME => Ok(Sun::UnixTime {
                time_s: self.unix_time_s,
                latitude_deg: self.latitude_deg,
                longitude_deg: self.longitude_deg,
                sigma_deg: self.sigma_deg,
            }),
            k => Err(Failure::new(
                BpinsStatus::BPINS_ERR_SUN,
                format!("sun: kind {k}: BPINS_SUN_ANGLES (0) or BPINS_SUN_UNIX_TIME (1)"),
            )),
        }
    }
}

impl From<BpinsAttitude> for Attitude {
    fn from(a: BpinsAttitude) -> Self {
        Attitude { tilt_x_deg: a.tilt_x_deg, tilt_y_deg: a.tilt_y_deg, sigma_deg: a.sigma_deg }
    }
}

impl From<&FieldHeading> for BpinsHeading {
    fn from(h: &FieldHeading) -> Self {
        let q = &h.quality;
        let mut out = BpinsHeading {
            has_heading: h.result.is_ok(),
            source: match h.source {
                SkySource::Given => BpinsSource::BPINS_SOURCE_GIVEN,
                SkySource::Sun(_) => BpinsSource::BPINS_SOURCE_SUN,
                SkySource::Moon(_) => BpinsSource::BPINS_SOURCE_MOON,
            },
            heading_deg: f64::NAN,
            sigma_deg: f64::NAN,
            sigma_fit_deg: f64::NAN,
            sigma_jackknife_deg: f64::NAN,
            sigma_coherent_deg: f64::NAN,
            sigma_misfit_deg: f64::NAN,
            sigma_cross_deg: f64::NAN,
            sigma_tilt_deg: f64::NAN,
            sigma_sun_deg: f64::NAN,
            sigma_floor_deg: f64::NAN,
            used_fraction: q.used_fraction,
            cloud_fraction: q.cloud_fraction,
            residual_rms_deg: q.residual_rms_deg,
            cells_total: q.cells_total as u32,
            cells_valid: q.cells_valid as u32,
            cells_used: q.cells_used as u32,
            sun_elevation_offset_deg: q.sun_elevation_offset_deg,
            reason: BpinsNoHeading::BPINS_NO_HEADING_NONE,
            message: [0; BPINS_MESSAGE_LEN],
        };
        match &h.result {
            Ok((deg, s)) => {
                out.heading_deg = *deg;
                out.sigma_deg = s.total_deg();
                out.sigma_fit_deg = s.fit_deg;
                out.sigma_jackknife_deg = s.jackknife_deg;
                out.sigma_coherent_deg = s.coherent_deg;
                out.sigma_misfit_deg = s.misfit_deg;
                out.sigma_cross_deg = s.cross_deg;
                out.sigma_tilt_deg = s.tilt_deg;
                out.sigma_sun_deg = s.sun_deg;
                out.sigma_floor_deg = s.floor_deg;
            }
            Err(why) => {
                use BpinsNoHeading::*;
                out.reason = match why {
                    NoHeading::SunTooLow { .. } => BPINS_NO_HEADING_SUN_TOO_LOW,
                    NoHeading::SunAtZenith { .. } => BPINS_NO_HEADING_SUN_AT_ZENITH,
                    NoHeading::TooLittleSky { .. } => BPINS_NO_HEADING_TOO_LITTLE_SKY,
                    NoHeading::Ambiguous { .. } => BPINS_NO_HEADING_AMBIGUOUS,
                    NoHeading::PoorFit { .. } => BPINS_NO_HEADING_POOR_FIT,
                    NoHeading::Solver(_) => BPINS_NO_HEADING_SOLVER,
                    NoHeading::Contradicts { .. } => BPINS_NO_HEADING_CONTRADICTS,
                    NoHeading::TooDark { .. } => BPINS_NO_HEADING_TOO_DARK,
                    NoHeading::MixedSky { .. } => BPINS_NO_HEADING_MIXED_SKY,
                    NoHeading::DarkNight { .. } => BPINS_NO_HEADING_DARK_NIGHT,
                };
                write_message(&mut out.message, &why.to_string());
            }
        }
        out
    }
}

/// `text` into a NUL-terminated C buffer, cut at a character boundary if too long.
pub(crate) fn write_message(buf: &mut [c_char; BPINS_MESSAGE_LEN], text: &str) {
    let mut n = text.len().min(BPINS_MESSAGE_LEN - 1);
    while !text.is_char_boundary(n) {
        n -= 1;
    }
    for (d, &b) in buf.iter_mut().zip(&text.as_bytes()[..n]) {
        *d = b as c_char;
    }
    buf[n] = 0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::CStr;

    #[test]
    fn the_default_config_is_the_front_doors_and_bad_fields_are_named() {
        let mut c = BpinsCompassConfig::default_values();
        (c.width_px, c.height_px, c.bit_depth, c.black_level_dn) = (612, 512, 12, 64.0);
        (c.focal_length_px, c.cx_px, c.cy_px) = (579.7, 305.5, 255.5);
        let core = c.to_core().unwrap();
        assert_eq!(core.mosaic, DEFAULT_MOSAIC);
        assert_eq!(core.options, FieldOptions::default());
        assert_eq!(core.extractor, Extractor::SunVector);
        assert_eq!(c.mosaic_deg, [[90, 45], [135, 0]]);
        for (edit, field) in [
            (Box::new(|c: &mut BpinsCompassConfig| c.projection = 4) as Box<dyn Fn(&mut _)>, "projection 4"),
            (Box::new(|c: &mut BpinsCompassConfig| c.extractor = 9), "extractor 9"),
            (Box::new(|c: &mut BpinsCompassConfig| c.mosaic_deg = [[90, 45], [135, 45]]), "mosaic_deg[1][1] = 45"),
            (Box::new(|c: &mut BpinsCompassConfig| c.mosaic_deg[0][0] = 30), "mosaic_deg[0][0] = 30"),
            (Box::new(|c: &mut BpinsCompassConfig| c.cell_px = 7), "cell_px 7"),
            (Box::new(|c: &mut BpinsCompassConfig| c.band_deg = f64::NAN), "band_deg NaN"),
            (Box::new(|c: &mut BpinsCompassConfig| c.min_used_fraction = 2.0), "min_used_fraction 2"),
            (Box::new(|c: &mut BpinsCompassConfig| c.distortion_k2 = f64::INFINITY), "k2 inf"),
        ] {
            let mut bad = c;
            edit(&mut bad);
            let e = bad.to_core().unwrap_err();
            assert_eq!(e.status, BpinsStatus::BPINS_ERR_CONFIG);
            assert!(e.message.contains(field), "{field}: {}", e.message);
        }
    }

    #[test]
    fn messages_are_cut_at_a_character_and_terminated() {
        let mut buf = [1 as c_char; BPINS_MESSAGE_LEN];
        write_message(&mut buf, &"σ".repeat(200)); // 400 bytes of 2-byte characters
        let s = unsafe { CStr::from_ptr(buf.as_ptr()) }.to_str().unwrap();
        assert_eq!(s, "σ".repeat(127));
        write_message(&mut buf, "short");
        assert_eq!(unsafe { CStr::from_ptr(buf.as_ptr()) }.to_str().unwrap(), "short");
    }
}
