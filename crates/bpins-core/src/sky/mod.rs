//! The sky: sun position and the polarization pattern.

#[cfg(feature = "spa")]
pub mod moon;
pub mod radiometry;
pub mod rayleigh;
#[cfg(feature = "spa")]
pub mod sun;

pub use rayleigh::sky_stokes;

/// Below this solar elevation, degrees (nautical twilight's middle), the sun's own
/// pattern has faded (the field estimator refuses it: `NoHeading::SunTooLow`) and a
/// moon that is up lights the sky instead.
pub const NIGHT_SUN_ELEVATION_DEG: f64 = -10.0;

/// The source that lights the sky at `time_utc` and a place: the sun (NREL SPA) while
/// it is above [`NIGHT_SUN_ELEVATION_DEG`]; below it the moon (`moon.rs`) where the
/// moon is above the horizon ([`sun::SunSource::Moon`]); otherwise the sun, which the
/// readers then refuse as too low, naming it. Frames need only the time and place.
#[cfg(feature = "spa")]
pub fn source_from_time_place(
    time_utc: &str,
    latitude_deg: f64,
    longitude_deg: f64,
) -> crate::Result<sun::SunPosition> {
    let sun = sun::sun_from_time_place(time_utc, latitude_deg, longitude_deg)?;
    night_source(sun, moon::moon_from_time_place(time_utc, latitude_deg, longitude_deg)?)
}

/// [`source_from_time_place`] at `time_unix_s` seconds since 1970 (a bag's stamps).
#[cfg(feature = "spa")]
pub fn source_from_unix_time(
    time_unix_s: f64,
    latitude_deg: f64,
    longitude_deg: f64,
) -> crate::Result<sun::SunPosition> {
    let sun = sun::sun_from_unix_time(time_unix_s, latitude_deg, longitude_deg)?;
    night_source(sun, moon::moon_from_unix_time(time_unix_s, latitude_deg, longitude_deg)?)
}

/// Why a frame has no source at night: the sun (from SPA) past
/// [`NIGHT_SUN_ELEVATION_DEG`] and the moon below the horizon at its time and place;
/// `None` where the sun is high enough or the sun's angles are not SPA's (a moon that is
/// up was already taken as the source by [`source_from_time_place`]).
#[cfg(feature = "spa")]
pub fn dark_night(sun: &sun::SunPosition) -> Option<String> {
    let sun::SunSource::Spa { time_utc, latitude_deg, longitude_deg } = &sun.source else { return None };
    if sun.elevation_deg >= NIGHT_SUN_ELEVATION_DEG {
        return None;
    }
    let moon = moon::moon_from_time_place(time_utc, *latitude_deg, *longitude_deg).ok()?;
    Some(format!(
        "not yet: the moon is at {:.1}° and the sun at {:.1}°: neither lights the sky (the moon is read from \
         the time and place once it rises)",
        moon.elevation_deg, sun.elevation_deg
    ))
}

#[cfg(feature = "spa")]
fn night_source(sun: sun::SunPosition, moon: moon::MoonPosition) -> crate::Result<sun::SunPosition> {
    if sun.elevation_deg >= NIGHT_SUN_ELEVATION_DEG || moon.elevation_deg <= 0.0 {
        return Ok(sun);
    }
    let sun::SunSource::Spa { time_utc, latitude_deg, longitude_deg } = sun.source else {
        return Ok(sun);
    };
    Ok(sun::SunPosition {
        azimuth_deg: moon.azimuth_deg,
        elevation_deg: moon.elevation_deg,
        source: sun::SunSource::Moon {
            time_utc,
            latitude_deg,
            longitude_deg,
            illuminated_fraction: moon.illuminated_fraction,
            sun_elevation_deg: sun.elevation_deg,
        },
    })
}

#[cfg(all(test, feature = "spa"))]
mod tests {
    use super::*;

    #[test]
    fn the_sun_by_day_and_twilight_the_moon_at_night_when_it_is_up() {
        // Qingdao, 2026-06-21: 04:00 UTC is noon; 16:00 UTC is midnight.
        let day = source_from_time_place("2026-06-21T04:00:00Z", 36.07, 120.38).unwrap();
        assert!(matches!(day.source, sun::SunSource::Spa { .. }), "{day:?}");
        // Every hour of a night and a month of nights: where the sun is below −10° and
        // the moon up, the moon; never the moon by day or below the horizon.
        let (mut moonlit, mut dark) = (0, 0);
        for hour in 0..(30 * 24) {
            let t = 1_782_000_000.0 + 3600.0 * hour as f64;
            let s = source_from_unix_time(t, 36.07, 120.38).unwrap();
            let sun = sun::sun_from_unix_time(t, 36.07, 120.38).unwrap();
            let moon = moon::moon_from_unix_time(t, 36.07, 120.38).unwrap();
            match &s.source {
                sun::SunSource::Moon { sun_elevation_deg, illuminated_fraction, .. } => {
                    moonlit += 1;
                    assert!(*sun_elevation_deg < NIGHT_SUN_ELEVATION_DEG && moon.elevation_deg > 0.0);
                    assert_eq!((s.azimuth_deg, s.elevation_deg), (moon.azimuth_deg, moon.elevation_deg));
                    assert_eq!(*illuminated_fraction, moon.illuminated_fraction);
                    assert!(s.source.describe().contains("the moon"), "{}", s.source.describe());
                }
                _ => {
                    assert_eq!(s, sun);
                    if sun.elevation_deg < NIGHT_SUN_ELEVATION_DEG {
                        dark += 1;
                        assert!(moon.elevation_deg <= 0.0);
                    }
                }
            }
        }
        // About half the night hours have the moon up over a lunar month.
        assert!(moonlit > 60 && dark > 60, "{moonlit} moonlit hours, {dark} dark ones");
    }
}
