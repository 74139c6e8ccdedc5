//! `bpins.Compass`: the front door (`bpins_core::compass`) for numpy mosaics. Built
//! once from the camera, the sensor and a calibration; per frame a 2-D mosaic, the
//! sun and the attitude in, a `Heading` out. The mosaic is read in place (no copy)
//! and the GIL is released while the compass works, so other Python threads run.

use crate::array::{Borrowed, Mosaic};
use crate::{finite, py_err, whole};
use bpins_core::calibration::Calibration;
use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{
    self as core, Attitude, CompassConfig, CompassError, Extractor, FieldHeading, RawImage, Sun,
};
use bpins_core::sensor::{Band, Channel, ColourTiles, Layout};
use bpins_core::Capture;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Mutex;

/// The heading of one frame: `heading_deg` and `sigma_deg` (1σ), both degrees, or
/// `None` with `reason` saying why the sky gave none.
#[pyclass(frozen, get_all, module = "bpins")]
pub struct Heading {
    /// Azimuth of the image top, degrees from North toward East, in [0, 360); None without a heading.
    heading_deg: Option<f64>,
    /// 1σ of the heading, degrees; None without a heading.
    sigma_deg: Option<f64>,
    /// The parts of the 1σ (fit, jackknife, coherent, misfit, cross, tilt, sun, floor), degrees.
    sigma_parts_deg: Option<std::collections::BTreeMap<String, f64>>,
    /// Fraction of the image the heading rests on (cells used / cells in the grid).
    used_fraction: f64,
    /// Fraction of the observed sky taken for cloud.
    cloud_fraction: f64,
    /// Weighted RMS angle residual of the used sky, degrees.
    residual_rms_deg: f64,
    /// Why there is no heading (None where there is one).
    reason: Option<String>,
    /// The extractor that read it ("sun_vector" or "meridian_line").
    extractor: String,
    /// Which source lit the sky: "given" (the sun's angles were given), or from
    /// `time_utc` and the place "sun" (by day, or a twilight it dominates) or "moon"
    /// (at night where it is up and its sky the brighter); given with or without a heading.
    source: String,
    /// The sun's and the moon's shares of the sky's light at the zenith, 0…1 (None for
    /// given angles); a frame is read where one source gives at least 0.99.
    sun_share: Option<f64>,
    moon_share: Option<f64>,
    /// A twilight lit by both, read with both sources: the sun's share of the two
    /// skies' polarized radiance as the fit found it (not the zenith light's
    /// `sun_share`), and its 1σ; None for a one-source sky or without a heading.
    fitted_sun_share: Option<f64>,
    fitted_sun_share_sigma: Option<f64>,
    cells_total: usize,
    cells_used: usize,
    /// Whether the mosaic was read in place (False: a copy, for arrays whose columns are not adjacent).
    zero_copy: bool,
}

#[pymethods]
impl Heading {
    fn __repr__(&self) -> String {
        match (self.heading_deg, self.sigma_deg) {
            (Some(h), Some(s)) => format!(
                "Heading(heading_deg={h:.4}, sigma_deg={s:.4}, used_fraction={:.3}, residual_rms_deg={:.3})",
                self.used_fraction, self.residual_rms_deg
            ),
            _ => format!("Heading(None, reason={:?})", self.reason.as_deref().unwrap_or("")),
        }
    }
}

fn heading_of(fix: &FieldHeading, zero_copy: bool) -> Heading {
    let q = &fix.quality;
    let (heading_deg, sigma_deg, sigma_parts_deg, reason) = match &fix.result {
        Ok((h, s)) => {
            let parts = [
                ("fit_deg", s.fit_deg),
                ("jackknife_deg", s.jackknife_deg),
                ("coherent_deg", s.coherent_deg),
                ("misfit_deg", s.misfit_deg),
                ("cross_deg", s.cross_deg),
                ("tilt_deg", s.tilt_deg),
                ("sun_deg", s.sun_deg),
                ("floor_deg", s.floor_deg),
            ];
            let parts = parts.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
            (Some(*h), Some(s.total_deg()), Some(parts), None)
        }
        Err(why) => (None, None, None, Some(why.to_string())),
    };
    Heading {
        heading_deg,
        sigma_deg,
        sigma_parts_deg,
        used_fraction: q.used_fraction,
        cloud_fraction: q.cloud_fraction,
        residual_rms_deg: q.residual_rms_deg,
        reason,
        extractor: fix.extractor.name().to_string(),
        source: fix.source.name().to_string(),
        sun_share: fix.source.shares().map(|s| s.sun_share()),
        moon_share: fix.source.shares().map(|s| s.moon_share()),
        fitted_sun_share: fix.fitted_sun_share(),
        fitted_sun_share_sigma: fix.fitted_sun_share_sigma(),
        cells_total: q.cells_total,
        cells_used: q.cells_used,
        zero_copy,
    }
}

fn compass_err(e: CompassError) -> PyErr {
    match e {
        CompassError::Core(e) => py_err(e),
        other => PyValueError::new_err(other.to_string()),
    }
}

pub(crate) fn projection(name: &str) -> PyResult<Projection> {
    Projection::ALL.into_iter().find(|p| p.name() == name).ok_or_else(|| {
        let known: Vec<_> = Projection::ALL.iter().map(|p| p.name()).collect();
        PyValueError::new_err(format!("projection = {name:?}: expected one of {}", known.join(", ")))
    })
}

fn extractor(name: &str) -> PyResult<Extractor> {
    Extractor::ALL.into_iter().find(|e| e.name() == name).ok_or_else(|| {
        PyValueError::new_err(format!("extractor = {name:?}: expected \"sun_vector\" or \"meridian_line\""))
    })
}

pub(crate) fn mosaic_of(m: [[f64; 2]; 2]) -> PyResult<[[Channel; 2]; 2]> {
    let ch = |deg: f64| {
        Channel::ALL.into_iter().find(|c| c.angle_deg() == deg).ok_or_else(|| {
            PyValueError::new_err(format!("mosaic: analyzer angle {deg}; expected 0, 45, 90 or 135 (degrees)"))
        })
    };
    let out = [[ch(m[0][0])?, ch(m[0][1])?], [ch(m[1][0])?, ch(m[1][1])?]];
    let mut seen: Vec<_> = out.iter().flatten().copied().collect();
    seen.sort();
    seen.dedup();
    if seen.len() != 4 {
        return Err(PyValueError::new_err(format!("mosaic = {m:?}: expected each of 0, 45, 90, 135 once")));
    }
    Ok(out)
}

fn calibration(path: Option<PathBuf>) -> PyResult<Calibration> {
    match path {
        None => Ok(Calibration::default()),
        Some(p) => Calibration::load(&p).map_err(|e| crate::py_err_in("calibration: ", e)),
    }
}

/// The front door: live mosaics in, headings with an honest 1σ out.
///
/// Compass(width_px, height_px, focal_length_px, *, principal_point_px=None,
///         projection="pinhole", bit_depth=12, black_level_dn=0.0,
///         mosaic=((90, 45), (135, 0)), calibration=None, extractor="sun_vector",
///         horizon_margin_deg=None)
///
/// Angles are degrees; the frame is the camera's (image +x right, +y down, analyzer
/// and polarization angles counter-clockwise as displayed; CONVENTIONS.md). One
/// compass per camera. Threads may share one: it reads one frame at a time (a lock,
/// waited on without the GIL); for frames read in parallel, make one per thread.
#[pyclass(module = "bpins", frozen)]
pub struct Compass {
    /// Locked for the length of one `heading`: the compass keeps per-frame scratch.
    inner: Mutex<core::Compass>,
    width_px: usize,
    height_px: usize,
}

#[pymethods]
impl Compass {
    #[new]
    #[pyo3(signature = (width_px, height_px, focal_length_px, *, principal_point_px=None, projection="pinhole",
        bit_depth=12, black_level_dn=0.0, mosaic=[[90.0, 45.0], [135.0, 0.0]], calibration=None,
        extractor="sun_vector", horizon_margin_deg=None, colour_tiles=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        width_px: i64,
        height_px: i64,
        focal_length_px: f64,
        principal_point_px: Option<(f64, f64)>,
        projection: &str,
        bit_depth: i64,
        black_level_dn: f64,
        mosaic: [[f64; 2]; 2],
        calibration: Option<PathBuf>,
        extractor: &str,
        horizon_margin_deg: Option<f64>,
        colour_tiles: Option<[[String; 2]; 2]>,
    ) -> PyResult<Self> {
        let (width_px, height_px): (usize, usize) = (whole("width_px", width_px)?, whole("height_px", height_px)?);
        let bit_depth: u32 = whole("bit_depth", bit_depth)?;
        let f = finite("focal_length_px", focal_length_px)?;
        let (cx, cy) = principal_point_px.unwrap_or(((width_px as f64 - 1.0) / 2.0, (height_px as f64 - 1.0) / 2.0));
        let camera = Intrinsics::new(
            self::projection(projection)?,
            f,
            finite("principal_point_px[0]", cx)?,
            finite("principal_point_px[1]", cy)?,
        );
        let mut cfg =
            CompassConfig::dofp(camera, width_px, height_px, bit_depth, finite("black_level_dn", black_level_dn)?);
        cfg.mosaic = mosaic_of(mosaic)?;
        cfg.calibration = self::calibration(calibration)?;
        cfg.extractor = self::extractor(extractor)?;
        if let Some(m) = horizon_margin_deg {
            cfg.options.horizon_margin_deg = finite("horizon_margin_deg", m)?;
        }
        if let Some(t) = colour_tiles {
            let mut c = ColourTiles::imx250myr();
            for (r, row) in t.iter().enumerate() {
                for (k, name) in row.iter().enumerate() {
                    c.tiles[r][k] = Band::from_name(name).ok_or_else(|| {
                        PyValueError::new_err(format!(
                            "colour_tiles: band {name:?} is unknown; use \"R\", \"G\" or \"B\""
                        ))
                    })?;
                }
            }
            cfg.colour = Some(c);
        }
        let inner = Mutex::new(core::Compass::new(cfg).map_err(compass_err)?);
        Ok(Compass { inner, width_px, height_px })
    }

    /// The compass for the sensor and lens a capture folder describes (its capture.toml).
    #[staticmethod]
    #[pyo3(signature = (path, *, calibration=None, extractor="sun_vector"))]
    fn from_capture(path: PathBuf, calibration: Option<PathBuf>, extractor: &str) -> PyResult<Self> {
        let c = Capture::load(&path).map_err(py_err)?;
        let Layout::Dofp { .. } = c.sensor.layout else {
            return Err(PyValueError::new_err(format!(
                "path: {} holds a colocated capture; the compass reads DoFP mosaics",
                path.display()
            )));
        };
        let g = &c.sensor.geometry;
        let (w, h) = (g.width_px as usize, g.height_px as usize);
        // The capture's own compass, as `bpins heading` reads the capture's frames.
        let compass = core::Compass::for_capture(
            &c,
            self::calibration(calibration)?,
            core::FieldOptions::default(),
            self::extractor(extractor)?,
        )
        .map_err(compass_err)?;
        let inner = Mutex::new(compass);
        Ok(Compass { inner, width_px: w, height_px: h })
    }

    /// The sensor's size, (height_px, width_px) as numpy writes a shape.
    #[getter]
    fn shape(&self) -> (usize, usize) {
        (self.height_px, self.width_px)
    }

    /// The heading of one raw mosaic.
    ///
    /// heading(mosaic, *, sun_azimuth_deg=None, sun_elevation_deg=None, time_utc=None,
    ///         latitude_deg=None, longitude_deg=None, site=None, sun_sigma_deg=0.0,
    ///         tilt_x_deg=0.0, tilt_y_deg=0.0, tilt_sigma_deg=0.0) -> Heading
    ///
    /// The sun: its azimuth (from North toward East) and elevation in degrees, or a
    /// timezone-aware `datetime` and a place (the sun through NREL SPA by day, the moon
    /// at night where it is up and its sky the brighter: `Heading.source` says which; a
    /// twilight lit by both is read with both sources (docs/night.md); a dark night is
    /// a Heading without one, `reason` naming the shares), or a `datetime` and `site`, the
    /// site file `bpins.locate` wrote (in place of a GNSS position, read by the same
    /// rule, the source's 1σ taking in the site's). The attitude: tilt about the
    /// camera's x then y axis as the IMU reads it, degrees, each with 1σ
    /// `tilt_sigma_deg`.
    #[pyo3(signature = (mosaic, *, sun_azimuth_deg=None, sun_elevation_deg=None, time_utc=None,
        latitude_deg=None, longitude_deg=None, site=None, sun_sigma_deg=0.0, tilt_x_deg=0.0, tilt_y_deg=0.0,
        tilt_sigma_deg=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn heading(
        &self,
        py: Python<'_>,
        mosaic: &Bound<'_, PyAny>,
        sun_azimuth_deg: Option<f64>,
        sun_elevation_deg: Option<f64>,
        time_utc: Option<&Bound<'_, PyAny>>,
        latitude_deg: Option<f64>,
        longitude_deg: Option<f64>,
        site: Option<std::path::PathBuf>,
        sun_sigma_deg: f64,
        tilt_x_deg: f64,
        tilt_y_deg: f64,
        tilt_sigma_deg: f64,
    ) -> PyResult<Heading> {
        let (sun, attitude) = frame_sun_attitude(
            sun_azimuth_deg,
            sun_elevation_deg,
            time_utc,
            latitude_deg,
            longitude_deg,
            site.as_deref(),
            sun_sigma_deg,
            tilt_x_deg,
            tilt_y_deg,
            tilt_sigma_deg,
        )?;
        let borrowed = Borrowed::new("mosaic", mosaic)?;
        let (h, w) = self.check_shape(mosaic)?;
        let m = borrowed.mosaic();
        let zero_copy = m.borrowed();
        let fix = py.detach(|| {
            // Another thread's frame first, if it holds the compass (no GIL held here,
            // so that thread can finish). A poisoned lock only means a panic elsewhere;
            // the compass's state is rebuilt per frame.
            let mut compass = self.inner.lock().unwrap_or_else(|p| p.into_inner());
            match &m {
                Mosaic::U8(d, s) => {
                    compass.heading(RawImage { data: d, width_px: w, height_px: h, stride: *s }, sun, attitude)
                }
                Mosaic::U16(d, s) => {
                    compass.heading(RawImage { data: d, width_px: w, height_px: h, stride: *s }, sun, attitude)
                }
                Mosaic::F32(d, s) => {
                    compass.heading(RawImage { data: d, width_px: w, height_px: h, stride: *s }, sun, attitude)
                }
            }
        });
        Ok(heading_of(&fix.map_err(compass_err)?, zero_copy))
    }

    /// A colour-polarization compass's headings of one raw mosaic: each band's from its
    /// own pixels and the fused one, as a dict {"fused": Heading, "R": …, "G": …, "B": …}
    /// (the bands the sensor has). The arguments are `heading`'s; a monochrome compass
    /// (no `colour_tiles`) raises ValueError.
    #[pyo3(signature = (mosaic, *, sun_azimuth_deg=None, sun_elevation_deg=None, time_utc=None,
        latitude_deg=None, longitude_deg=None, site=None, sun_sigma_deg=0.0, tilt_x_deg=0.0, tilt_y_deg=0.0,
        tilt_sigma_deg=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn band_headings(
        &self,
        py: Python<'_>,
        mosaic: &Bound<'_, PyAny>,
        sun_azimuth_deg: Option<f64>,
        sun_elevation_deg: Option<f64>,
        time_utc: Option<&Bound<'_, PyAny>>,
        latitude_deg: Option<f64>,
        longitude_deg: Option<f64>,
        site: Option<std::path::PathBuf>,
        sun_sigma_deg: f64,
        tilt_x_deg: f64,
        tilt_y_deg: f64,
        tilt_sigma_deg: f64,
    ) -> PyResult<std::collections::BTreeMap<String, Heading>> {
        let (sun, attitude) = frame_sun_attitude(
            sun_azimuth_deg,
            sun_elevation_deg,
            time_utc,
            latitude_deg,
            longitude_deg,
            site.as_deref(),
            sun_sigma_deg,
            tilt_x_deg,
            tilt_y_deg,
            tilt_sigma_deg,
        )?;
        let borrowed = Borrowed::new("mosaic", mosaic)?;
        let (h, w) = self.check_shape(mosaic)?;
        let m = borrowed.mosaic();
        let zero_copy = m.borrowed();
        let fix = py.detach(|| {
            let mut compass = self.inner.lock().unwrap_or_else(|p| p.into_inner());
            let e = [compass.extractor()];
            match &m {
                Mosaic::U8(d, s) => compass.colour_headings(
                    RawImage { data: d, width_px: w, height_px: h, stride: *s },
                    sun,
                    attitude,
                    &e,
                ),
                Mosaic::U16(d, s) => compass.colour_headings(
                    RawImage { data: d, width_px: w, height_px: h, stride: *s },
                    sun,
                    attitude,
                    &e,
                ),
                Mosaic::F32(d, s) => compass.colour_headings(
                    RawImage { data: d, width_px: w, height_px: h, stride: *s },
                    sun,
                    attitude,
                    &e,
                ),
            }
        });
        let fix = fix.map_err(compass_err)?;
        let mut out = std::collections::BTreeMap::new();
        out.insert("fused".to_string(), heading_of(&fix.fused[0], zero_copy));
        for (b, hs) in &fix.bands {
            out.insert(b.name().to_string(), heading_of(&hs[0], zero_copy));
        }
        Ok(out)
    }
}

impl Compass {
    /// The mosaic's shape, (height, width), refused unless it is the sensor's.
    fn check_shape(&self, mosaic: &Bound<'_, PyAny>) -> PyResult<(usize, usize)> {
        let (h, w) = crate::array::shape2("mosaic", mosaic)?;
        if (h, w) != (self.height_px, self.width_px) {
            return Err(PyValueError::new_err(format!(
                "mosaic: shape ({h}, {w}); expected the sensor's (height_px, width_px) = ({}, {})",
                self.height_px, self.width_px
            )));
        }
        Ok((h, w))
    }
}

/// A frame's sun (angles, a datetime and a place, or a datetime and a site) and
/// attitude, each number checked with its argument's name.
#[allow(clippy::too_many_arguments)]
fn frame_sun_attitude(
    sun_azimuth_deg: Option<f64>,
    sun_elevation_deg: Option<f64>,
    time_utc: Option<&Bound<'_, PyAny>>,
    latitude_deg: Option<f64>,
    longitude_deg: Option<f64>,
    site: Option<&std::path::Path>,
    sun_sigma_deg: f64,
    tilt_x_deg: f64,
    tilt_y_deg: f64,
    tilt_sigma_deg: f64,
) -> PyResult<(Sun, Attitude)> {
    let sun = match site {
        None => sun_of(sun_azimuth_deg, sun_elevation_deg, time_utc, latitude_deg, longitude_deg, sun_sigma_deg)?,
        Some(p) => {
            site_sun(p, sun_azimuth_deg, sun_elevation_deg, time_utc, latitude_deg, longitude_deg, sun_sigma_deg)?
        }
    };
    let attitude = Attitude {
        tilt_x_deg: finite("tilt_x_deg", tilt_x_deg)?,
        tilt_y_deg: finite("tilt_y_deg", tilt_y_deg)?,
        sigma_deg: finite("tilt_sigma_deg", tilt_sigma_deg)?,
    };
    if attitude.sigma_deg < 0.0 {
        return Err(PyValueError::new_err(format!("tilt_sigma_deg = {tilt_sigma_deg}: expected a 1σ ≥ 0")));
    }
    Ok((sun, attitude))
}

/// The sky's source at `time_utc` from a located site file (`Site::compass_sun`: the
/// sun, or the moon at night, by the `time_utc=` path's rule), its 1σ the site's ⊕ `sigma`.
fn site_sun(
    path: &std::path::Path,
    az: Option<f64>,
    el: Option<f64>,
    time_utc: Option<&Bound<'_, PyAny>>,
    lat: Option<f64>,
    lon: Option<f64>,
    sigma: f64,
) -> PyResult<Sun> {
    let (Some(t), None, None, None, None) = (time_utc, az, el, lat, lon) else {
        return Err(PyValueError::new_err(
            "site: give it with time_utc alone (the site replaces the place; no sun angles)",
        ));
    };
    let sigma_deg = finite("sun_sigma_deg", sigma)?;
    if sigma_deg < 0.0 {
        return Err(PyValueError::new_err(format!("sun_sigma_deg = {sigma}: expected a 1σ ≥ 0")));
    }
    let site = bpins_core::Site::load(path).map_err(|e| crate::py_err_in("site: ", e))?;
    // The site's place as a time and place: the compass reads the source by the rule
    // `time_utc=` with a place gets (the moon at night, a mixed twilight read with both
    // sources, a dark sky refused).
    match site.compass_sun(unix_time_of(t)?).map_err(|e| crate::py_err_in("site: ", e))? {
        Sun::UnixTime { time_s, latitude_deg, longitude_deg, sigma_deg: s } => {
            Ok(Sun::UnixTime { time_s, latitude_deg, longitude_deg, sigma_deg: s.hypot(sigma_deg) })
        }
        angles => Ok(angles),
    }
}

/// Seconds since 1970 of a timezone-aware `datetime`.
fn unix_time_of(t: &Bound<'_, PyAny>) -> PyResult<f64> {
    let tz = t.getattr("tzinfo").map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err("time_utc: expected a datetime.datetime with a timezone")
    })?;
    if tz.is_none() {
        return Err(PyValueError::new_err(
            "time_utc: a naive datetime; expected a timezone-aware one (e.g. tzinfo=datetime.timezone.utc)",
        ));
    }
    t.call_method0("timestamp")?.extract()
}

/// The sun from the keyword arguments: angles, or a time and a place; not both.
fn sun_of(
    az: Option<f64>,
    el: Option<f64>,
    time_utc: Option<&Bound<'_, PyAny>>,
    lat: Option<f64>,
    lon: Option<f64>,
    sigma: f64,
) -> PyResult<Sun> {
    let sigma_deg = finite("sun_sigma_deg", sigma)?;
    if sigma_deg < 0.0 {
        return Err(PyValueError::new_err(format!("sun_sigma_deg = {sigma}: expected a 1σ ≥ 0")));
    }
    match (az, el, time_utc, lat, lon) {
        (Some(az), Some(el), None, None, None) => Ok(Sun::Angles {
            azimuth_deg: finite("sun_azimuth_deg", az)?,
            elevation_deg: finite("sun_elevation_deg", el)?,
            sigma_deg,
        }),
        (None, None, Some(t), Some(lat), Some(lon)) => Ok(Sun::UnixTime {
            time_s: unix_time_of(t)?,
            latitude_deg: finite("latitude_deg", lat)?,
            longitude_deg: finite("longitude_deg", lon)?,
            sigma_deg,
        }),
        _ => Err(PyValueError::new_err(
            "the sun: give sun_azimuth_deg and sun_elevation_deg, or time_utc, latitude_deg and longitude_deg",
        )),
    }
}
