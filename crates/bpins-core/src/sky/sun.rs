//! Sun position for a frame: either given in `capture.toml` (`sun_azimuth_deg`,
//! `sun_elevation_deg`) or computed from UTC time and place with NREL SPA
//! (Reda & Andreas 2003, ±0.0003°), as CONVENTIONS.md "Sky" and CAPTURE.md require.
//! Every position carries its [`SunSource`] so that outputs can say which it was.
//!
//! Angles follow CONVENTIONS.md: azimuth in degrees from North toward East, wrapped to
//! [0°, 360°); elevation in degrees above the horizon.
//!
//! SPA choices (crate `solar-positioning` 0.7.2, SPA model):
//!
//! * the observer stands at 0 m above sea level (captures carry no altitude);
//! * ΔT = TT − UT1 from the crate's Espenak–Meeus estimator (`delta_t`), UTC ≈ UT1;
//! * the **apparent** sun, as a camera sees it: SPA's refraction correction for a
//!   standard atmosphere (1013.25 hPa, 15 °C). Refraction lifts the sun by ≈ 0.5° at
//!   the horizon, ≈ 0.02° at 45°; SPA applies it only while the sun is above the
//!   horizon (less its radius and the refraction).
//!
//! Time: an RFC 3339 timestamp (`2026-06-21T18:30:00Z`). An explicit offset other
//! than `Z` (`…T20:30:00+02:00`) names the same instant and is accepted and converted
//! to UTC; a timestamp without an offset, or a leap second, is an error
//! ([`crate::Error::Time`]).
//!
//! Cannot: model the observer's altitude, local pressure and temperature, or
//! refraction below the horizon; the ΔT estimate is an extrapolation after 2026.

use chrono::{DateTime, SecondsFormat, Utc};
use solar_positioning::{delta_t, Location, RefractionCorrection, SolarPositions};

use crate::conventions::{enu_from_az_el_deg, wrap_deg_360};
use crate::{Error, Result};

/// Where a frame's sun position comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum SunSource {
    /// `sun_azimuth_deg` and `sun_elevation_deg` given in `capture.toml`.
    Given,
    /// NREL SPA from UTC time and place (see the module doc for the choices).
    Spa {
        /// RFC 3339 timestamp in UTC (`Z`), normalised from what the file said.
        time_utc: String,
        latitude_deg: f64,
        longitude_deg: f64,
    },
    /// Night: the sun more than [`crate::sky::NIGHT_SUN_ELEVATION_DEG`] below the
    /// horizon and the moon up, so the moonlit sky's pattern (the day's, about the
    /// moon) is the one read: the angles are the moon's (Meeus ch. 47, `sky::moon`), from
    /// the same time and place.
    Moon {
        /// RFC 3339 timestamp in UTC (`Z`).
        time_utc: String,
        latitude_deg: f64,
        longitude_deg: f64,
        /// Fraction of the moon's disc lit, in [0, 1].
        illuminated_fraction: f64,
        /// The sun's elevation at that time and place, degrees (below the horizon).
        sun_elevation_deg: f64,
    },
    /// A UTC stamp and no place (a robot without GNSS): the sun's angles are unknown
    /// (NaN) until a place is found (`bpins locate`) or given. Only
    /// [`crate::capture::Capture::load_unplaced`] reads such frames; every reader that
    /// needs the sun refuses them.
    Unplaced {
        /// RFC 3339 timestamp in UTC (`Z`), normalised from what the file said.
        time_utc: String,
    },
}

impl SunSource {
    /// One line for reports: how the sun position was obtained.
    pub fn describe(&self) -> String {
        match self {
            SunSource::Given => "given in capture.toml".to_string(),
            SunSource::Spa { time_utc, latitude_deg, longitude_deg } => format!(
                "NREL SPA from {time_utc} at {}, ±0.0003° (apparent sun, standard refraction, 0 m){}",
                place_text(*latitude_deg, *longitude_deg),
                twilight_clause(time_utc, *latitude_deg, *longitude_deg).map_or(String::new(), |t| format!("; {t}"))
            ),
            SunSource::Moon { time_utc, latitude_deg, longitude_deg, illuminated_fraction, sun_elevation_deg } => {
                let when = twilight_clause(time_utc, *latitude_deg, *longitude_deg)
                    .unwrap_or_else(|| format!("night: the sun at {sun_elevation_deg:.1}°"));
                format!(
                    "the moon ({when}), {:.0} % lit, from {time_utc} at {} \
                     (Meeus ch. 47, topocentric, standard refraction, 0 m)",
                    100.0 * illuminated_fraction,
                    place_text(*latitude_deg, *longitude_deg)
                )
            }
            SunSource::Unplaced { time_utc } => format!("unknown: {time_utc} without a place"),
        }
    }

    /// The frame's UTC stamp, where it has one.
    pub fn time_utc(&self) -> Option<&str> {
        match self {
            SunSource::Given => None,
            SunSource::Spa { time_utc, .. } | SunSource::Moon { time_utc, .. } | SunSource::Unplaced { time_utc } => {
                Some(time_utc)
            }
        }
    }
}

/// The sources' shares where the sun is in twilight (below the horizon, above
/// [`crate::sky::twilight::TWILIGHT_END_DEG`]): "twilight: the sun at −4.0° gives > 99 % of
/// the sky's light, the moon (…) < 1 %" (`sky/twilight.rs`); `None` by day and at night.
fn twilight_clause(time_utc: &str, latitude_deg: f64, longitude_deg: f64) -> Option<String> {
    let sun = sun_from_time_place(time_utc, latitude_deg, longitude_deg).ok()?;
    if sun.elevation_deg > 0.0 || sun.elevation_deg <= crate::sky::twilight::TWILIGHT_END_DEG {
        return None; // day or night: no moon to place
    }
    let moon = crate::sky::moon::moon_from_time_place(time_utc, latitude_deg, longitude_deg).ok()?;
    Some(crate::sky::twilight::shares_of(sun.elevation_deg, &moon).describe())
}

/// A place as the sources describe it: `36.07°N 120.38°E`.
fn place_text(latitude_deg: f64, longitude_deg: f64) -> String {
    let ns = if latitude_deg < 0.0 { 'S' } else { 'N' };
    let ew = if longitude_deg < 0.0 { 'W' } else { 'E' };
    format!("{}°{ns} {}°{ew}", latitude_deg.abs(), longitude_deg.abs())
}

/// The sun's direction for one frame, and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct SunPosition {
    /// Degrees from North toward East, in [0, 360).
    pub azimuth_deg: f64,
    /// Degrees above the horizon, in [−90, 90].
    pub elevation_deg: f64,
    pub source: SunSource,
}

impl SunPosition {
    /// A position given directly (azimuth wrapped to [0°, 360°)).
    pub fn given(azimuth_deg: f64, elevation_deg: f64) -> Self {
        SunPosition { azimuth_deg: wrap_deg_360(azimuth_deg), elevation_deg, source: SunSource::Given }
    }

    /// A frame stamped `time_utc` (RFC 3339, converted to UTC) whose place is unknown:
    /// NaN angles, [`SunSource::Unplaced`].
    pub fn unplaced(time_utc: &str) -> Result<Self> {
        let t = parse_time_utc(time_utc)?;
        let time_utc = t.to_rfc3339_opts(SecondsFormat::AutoSi, true);
        Ok(SunPosition { azimuth_deg: f64::NAN, elevation_deg: f64::NAN, source: SunSource::Unplaced { time_utc } })
    }

    /// Whether the sun's angles are known (given, or SPA from time and place).
    pub fn is_known(&self) -> bool {
        !matches!(self.source, SunSource::Unplaced { .. })
    }

    /// Unit vector toward the sun in ENU (CONVENTIONS.md).
    pub fn direction_enu(&self) -> glam::DVec3 {
        enu_from_az_el_deg(self.azimuth_deg, self.elevation_deg)
    }
}

/// The apparent sun at `time_utc` (RFC 3339) seen from `latitude_deg` (north
/// positive) and `longitude_deg` (east positive) at sea level, by NREL SPA.
///
/// Errors: [`Error::Time`] for an unparsable timestamp, one without offset, a leap
/// second or a year outside the ΔT estimator's range (−500 … 3000) or SPA's
/// (−2000 … 6000); [`Error::Place`] for coordinates out of range or not finite.
pub fn sun_from_time_place(time_utc: &str, latitude_deg: f64, longitude_deg: f64) -> Result<SunPosition> {
    sun_at(&parse_time_utc(time_utc)?, latitude_deg, longitude_deg)
}

/// [`sun_from_time_place`] at `time_unix_s` seconds since 1970-01-01T00:00:00Z (UTC,
/// leap seconds not counted, as every Unix clock and ROS time).
pub fn sun_from_unix_time(time_unix_s: f64, latitude_deg: f64, longitude_deg: f64) -> Result<SunPosition> {
    sun_at(&unix_time(time_unix_s)?, latitude_deg, longitude_deg)
}

/// `time_unix_s` seconds since 1970-01-01T00:00:00Z as a UTC time (nanoseconds kept);
/// [`Error::Time`] where it is not finite or not representable.
pub(crate) fn unix_time(time_unix_s: f64) -> Result<DateTime<Utc>> {
    let bad =
        || Error::Time { time: format!("time {time_unix_s} s since 1970"), message: "not a representable time".into() };
    if !time_unix_s.is_finite() {
        return Err(bad());
    }
    let (secs, frac) = (time_unix_s.floor(), time_unix_s - time_unix_s.floor());
    DateTime::<Utc>::from_timestamp(secs as i64, (frac * 1e9) as u32).ok_or_else(bad)
}

/// The sun at `time` with its timestamp's text, the [`SunPosition`] the captures and
/// the CLI report: [`sun_angles_at`]'s numbers.
fn sun_at(time: &DateTime<Utc>, latitude_deg: f64, longitude_deg: f64) -> Result<SunPosition> {
    let (azimuth_deg, elevation_deg) = sun_angles_at(time, latitude_deg, longitude_deg)?;
    Ok(SunPosition {
        azimuth_deg,
        elevation_deg,
        source: SunSource::Spa {
            time_utc: time.to_rfc3339_opts(SecondsFormat::AutoSi, true),
            latitude_deg,
            longitude_deg,
        },
    })
}

/// The apparent sun's (azimuth, elevation), degrees, at `time` from a place at sea
/// level: NREL SPA with the module doc's choices, as numbers. The one computation of
/// the sun: [`sun_from_time_place`] and [`sun_from_unix_time`] add the timestamp's
/// text; a clock-given frame (`sky::SunAndMoon`, the compass) takes the numbers alone
/// and allocates nothing. Its errors ([`Error::Time`], [`Error::Place`], [`Error::Sun`])
/// build their text, allocating: a refused time or place is not the per-frame path.
pub(crate) fn sun_angles_at(time: &DateTime<Utc>, latitude_deg: f64, longitude_deg: f64) -> Result<(f64, f64)> {
    check_place(latitude_deg, longitude_deg)?;
    let dt_s = delta_t::estimate_from_date_like(time).map_err(|e| Error::Time {
        time: format!("time {}", time.to_rfc3339_opts(SecondsFormat::AutoSi, true)),
        message: format!("ΔT: {e}"),
    })?;
    spa_apparent(time, latitude_deg, longitude_deg, 0.0, dt_s, Some(RefractionCorrection::standard()))
}

/// Parses an RFC 3339 timestamp with an explicit offset and converts it to UTC.
pub fn parse_time_utc(s: &str) -> Result<DateTime<Utc>> {
    let t = DateTime::parse_from_rfc3339(s.trim()).map_err(|e| Error::Time {
        time: format!("time_utc `{s}`"),
        message: format!("not an RFC 3339 timestamp with offset, like 2026-06-21T18:30:00Z ({e})"),
    })?;
    Ok(t.with_timezone(&Utc))
}

/// Refuses a latitude outside [−90°, 90°] or a longitude outside [−180°, 180°] (NaN too).
pub(crate) fn check_place(latitude_deg: f64, longitude_deg: f64) -> Result<()> {
    if !(-90.0..=90.0).contains(&latitude_deg) {
        return Err(Error::Place(format!("latitude_deg = {latitude_deg} is outside [−90°, 90°]")));
    }
    if !(-180.0..=180.0).contains(&longitude_deg) {
        return Err(Error::Place(format!("longitude_deg = {longitude_deg} is outside [−180°, 180°]")));
    }
    Ok(())
}

/// SPA (azimuth, elevation) in degrees, with every input explicit (tests use the
/// SPA paper's height, ΔT and atmosphere).
fn spa_apparent(
    time: &DateTime<Utc>,
    latitude_deg: f64,
    longitude_deg: f64,
    height_m: f64,
    delta_t_s: f64,
    refraction: Option<RefractionCorrection>,
) -> Result<(f64, f64)> {
    let location = Location { latitude: latitude_deg, longitude: longitude_deg };
    let p = SolarPositions::new()
        .at(time, location, height_m, delta_t_s, refraction)
        .map_err(|e| Error::Time { time: format!("time {time}"), message: format!("SPA: {e}") })?;
    let az = wrap_deg_360(p.azimuth());
    let el = p.elevation_angle();
    if !(az.is_finite() && el.is_finite()) {
        return Err(Error::Sun(format!("SPA at {time} gave a non-finite position")));
    }
    Ok((az, el))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SPA paper (Reda & Andreas 2003, Table A4.1): 2003-10-17 12:30:30 at −7 h,
    /// 39.742476°N 105.1786°W, 1830.14 m, ΔT 67 s, 820 hPa, 11 °C:
    /// zenith 50.11162°, azimuth 194.34024°.
    #[test]
    fn reproduces_the_spa_paper_example() {
        let t = parse_time_utc("2003-10-17T12:30:30-07:00").unwrap();
        let (az, el) = spa_apparent(
            &t,
            39.742476,
            -105.1786,
            1830.14,
            67.0,
            Some(RefractionCorrection::new(820.0, 11.0).unwrap()),
        )
        .unwrap();
        assert!((az - 194.34024).abs() < 1e-5, "{az}");
        assert!((90.0 - el - 50.11162).abs() < 1e-5, "{el}");
    }

    #[test]
    fn public_function_is_close_to_the_paper_at_sea_level() {
        // 0 m instead of 1830 m (parallax ≪ 0.001°), ΔT estimated (~64 s instead of
        // 67 s: < 0.001°), standard instead of 820 hPa atmosphere (refraction
        // 0.0146° instead of 0.0118° at 40° elevation).
        let p = sun_from_time_place("2003-10-17T12:30:30-07:00", 39.742476, -105.1786).unwrap();
        assert!((p.azimuth_deg - 194.34024).abs() < 0.005, "{}", p.azimuth_deg);
        assert!((90.0 - p.elevation_deg - 50.11162).abs() < 0.005, "{}", p.elevation_deg);
        assert_eq!(
            p.source,
            SunSource::Spa {
                time_utc: "2003-10-17T19:30:30Z".to_string(),
                latitude_deg: 39.742476,
                longitude_deg: -105.1786
            }
        );
        assert!(p.source.describe().contains("39.742476°N 105.1786°W"));
    }

    #[test]
    fn refraction_lifts_the_sun() {
        let t = parse_time_utc("2026-06-21T18:30:00Z").unwrap();
        let dt = delta_t::estimate_from_date_like(&t).unwrap();
        let (_, geo) = spa_apparent(&t, 36.07, 120.38, 0.0, dt, None).unwrap();
        let p = sun_from_time_place("2026-06-21T18:30:00Z", 36.07, 120.38).unwrap();
        // Sun well below the horizon at 02:30 local in Qingdao: no refraction applied.
        assert!(p.elevation_deg < -10.0);
        assert_eq!(p.elevation_deg, geo);
        let t = parse_time_utc("2026-06-21T04:00:00Z").unwrap();
        let dt = delta_t::estimate_from_date_like(&t).unwrap();
        let (_, geo) = spa_apparent(&t, 36.07, 120.38, 0.0, dt, None).unwrap();
        let p = sun_from_time_place("2026-06-21T04:00:00Z", 36.07, 120.38).unwrap();
        assert!(p.elevation_deg > geo && p.elevation_deg - geo < 0.05, "{} {geo}", p.elevation_deg);
        assert!((0.0..360.0).contains(&p.azimuth_deg));
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        for s in [
            "",
            "yesterday",
            "2026-06-21 18:30:00",
            "2026-06-21T18:30:00",
            "2026-13-01T00:00:00Z",
            "2026-02-30T00:00:00Z",
            "2026-06-21T24:30:00Z",
            "2016-12-31T23:59:60Z",
            "9999-01-01T00:00:00Z",
            "-9999-01-01T00:00:00Z",
        ] {
            let r = sun_from_time_place(s, 10.0, 10.0);
            assert!(matches!(r, Err(Error::Time { .. })), "{s:?}: {r:?}");
        }
        for (lat, lon) in [(91.0, 0.0), (0.0, 181.0), (f64::NAN, 0.0), (0.0, f64::INFINITY)] {
            let r = sun_from_time_place("2026-06-21T18:30:00Z", lat, lon);
            assert!(matches!(r, Err(Error::Place(_))), "{lat} {lon}: {r:?}");
        }
    }

    #[test]
    fn describes_its_source() {
        assert_eq!(SunSource::Given.describe(), "given in capture.toml");
        let p = sun_from_time_place("2026-06-21T20:30:00+02:00", 36.07, 120.38).unwrap();
        let d = p.source.describe();
        assert!(d.starts_with("NREL SPA from 2026-06-21T18:30:00Z at 36.07°N 120.38°E, ±0.0003°"), "{d}");
        assert_eq!(SunPosition::given(-20.0, 5.0).azimuth_deg, 340.0);
    }
}
