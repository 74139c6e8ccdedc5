//! The sky: sun position and the polarization pattern.

#[cfg(feature = "spa")]
pub mod moon;
pub mod radiometry;
pub mod rayleigh;
#[cfg(feature = "spa")]
pub mod sun;
pub mod twilight;

pub use rayleigh::sky_stokes;

/// Below this solar elevation, degrees (nautical twilight's middle), the sun's own
/// pattern has faded (the field estimator refuses it: `NoHeading::SunTooLow`); whether
/// a moon that is up lights the sky instead is [`twilight`]'s shares.
pub const NIGHT_SUN_ELEVATION_DEG: f64 = -10.0;

/// The source that lights the sky at `time_utc` and a place: of the sun (NREL SPA) and
/// the moon (`moon.rs`), the one whose sky is the brighter at the zenith
/// ([`twilight::Shares`]: K&S above the horizon, the sun's twilight below it); the sun
/// where neither lights it, which the readers then refuse as too low, naming it. The
/// moon's is [`sun::SunSource::Moon`]. Whether the frame may be read (one source giving
/// [`twilight::DOMINANT_SHARE`] of the light, the sun above [`NIGHT_SUN_ELEVATION_DEG`])
/// is [`dark_night`]'s, for what reads one source's pattern; the heading reads a
/// twilight lit by both with both (`compass::Sun::mixed_twilight`,
/// `heading::field::two_sources`), the fit and the diagnosis model both skies
/// (`fit::input::sky`). Frames need only the time and place.
#[cfg(feature = "spa")]
pub fn source_from_time_place(
    time_utc: &str,
    latitude_deg: f64,
    longitude_deg: f64,
) -> crate::Result<sun::SunPosition> {
    let time = sun::parse_time_utc(time_utc)?;
    Ok(SunAndMoon::at(&time, latitude_deg, longitude_deg)?.source(&time, latitude_deg, longitude_deg))
}

/// [`source_from_time_place`] at `time_unix_s` seconds since 1970 (a bag's stamps).
#[cfg(feature = "spa")]
pub fn source_from_unix_time(
    time_unix_s: f64,
    latitude_deg: f64,
    longitude_deg: f64,
) -> crate::Result<sun::SunPosition> {
    Ok(source_and_shares_from_unix_time(time_unix_s, latitude_deg, longitude_deg)?.0)
}

/// Why a frame's sky from its time and place cannot be read, or `None`: where the sun
/// and the moon both light it and neither gives [`twilight::DOMINANT_SHARE`] of the
/// light (naming both shares: a mixed sky has no single source's pattern); where the
/// sun is the source past [`NIGHT_SUN_ELEVATION_DEG`] (its pattern faded) and the moon
/// is below the horizon or too faint to be read alone. `None` also where the angles are
/// not from a time and place (given, unplaced). [`refusal`] is the same, typed.
#[cfg(feature = "spa")]
pub fn dark_night(sun: &sun::SunPosition) -> Option<String> {
    let (sun::SunSource::Spa { time_utc, latitude_deg, longitude_deg }
    | sun::SunSource::Moon { time_utc, latitude_deg, longitude_deg, .. }) = &sun.source
    else {
        return None;
    };
    let shares = twilight::shares_at(time_utc, *latitude_deg, *longitude_deg).ok()?;
    refusal(sun, &shares).map(|r| r.to_string())
}

/// Why a sky cannot be read, typed: [`dark_night`]'s reasons, each with the shares it
/// was decided on (its words are the shares' [`twilight::Shares::mixed_reason`] and
/// [`twilight::Shares::dark_reason`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Refusal {
    /// Both sources light the sky and neither gives [`twilight::DOMINANT_SHARE`].
    Mixed(twilight::Shares),
    /// The sun past [`NIGHT_SUN_ELEVATION_DEG`] and no moon to read alone (below the
    /// horizon, or up but too faint).
    Dark(twilight::Shares),
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::Mixed(s) => f.write_str(&s.mixed_reason()),
            Refusal::Dark(s) => f.write_str(&s.dark_reason()),
        }
    }
}

/// [`dark_night`]'s rule on a source `sun` from [`source_from_time_place`] or
/// [`source_from_unix_time`] and the `shares` of its time and place; `None` where it
/// may be read, and for given or unplaced angles.
#[cfg(feature = "spa")]
pub fn refusal(sun: &sun::SunPosition, shares: &twilight::Shares) -> Option<Refusal> {
    use sun::SunSource;
    match sun.source {
        // A sun source's angles are the sun's: its elevation is the rule's.
        SunSource::Spa { .. } => refusal_rule(false, sun.elevation_deg, shares),
        SunSource::Moon { sun_elevation_deg, .. } => refusal_rule(true, sun_elevation_deg, shares),
        _ => None,
    }
}

/// [`refusal`]'s rule on numbers: whether the moon is the source, the sun's elevation
/// (degrees) and the shares.
#[cfg(feature = "spa")]
fn refusal_rule(moon_is_source: bool, sun_elevation_deg: f64, shares: &twilight::Shares) -> Option<Refusal> {
    if shares.dominant() == twilight::Dominant::Mixed {
        return Some(Refusal::Mixed(*shares));
    }
    if moon_is_source || sun_elevation_deg >= NIGHT_SUN_ELEVATION_DEG {
        return None;
    }
    Some(Refusal::Dark(*shares))
}

/// The source of `time_unix_s` at a place ([`source_from_unix_time`]) with the two
/// sources' shares of the sky's light there ([`twilight::shares_of`]), each ephemeris
/// run once: what the live compass reads a frame's clock and fix through.
#[cfg(feature = "spa")]
pub fn source_and_shares_from_unix_time(
    time_unix_s: f64,
    latitude_deg: f64,
    longitude_deg: f64,
) -> crate::Result<(sun::SunPosition, twilight::Shares)> {
    let time = sun::unix_time(time_unix_s)?;
    let both = SunAndMoon::at(&time, latitude_deg, longitude_deg)?;
    Ok((both.source(&time, latitude_deg, longitude_deg), both.shares))
}

/// The sun and the moon at one instant and place, and their shares of the sky's light,
/// as numbers: the one ephemeris computation behind every time-and-place reading (SPA
/// for the sun, Meeus ch. 47 for the moon, `twilight.rs` for the shares). The live
/// compass reads a frame's clock through it and builds no text, so a warm compass
/// allocates nothing per clock-given frame; [`source_and_shares_from_unix_time`] and
/// [`source_from_time_place`] add the source's timestamp text ([`sun::SunSource`]) for
/// the captures and the CLI. Units: degrees; frame: the observer's horizon (azimuth
/// from North toward East).
#[cfg(feature = "spa")]
#[derive(Clone, Debug, PartialEq)]
pub struct SunAndMoon {
    /// The apparent sun (NREL SPA, standard refraction, 0 m), degrees.
    pub sun_azimuth_deg: f64,
    pub sun_elevation_deg: f64,
    pub moon: moon::MoonPosition,
    /// The two sources' shares of the sky's light at the zenith ([`twilight::shares_of`]).
    pub shares: twilight::Shares,
}

#[cfg(feature = "spa")]
impl SunAndMoon {
    /// Both bodies at `time_unix_s` seconds since 1970 (UTC, leap seconds not counted)
    /// at a place. Allocates nothing on success; its errors (a time not representable,
    /// a place out of range: [`crate::Error`]) build their text, not the per-frame path.
    pub fn at_unix_time(time_unix_s: f64, latitude_deg: f64, longitude_deg: f64) -> crate::Result<SunAndMoon> {
        SunAndMoon::at(&sun::unix_time(time_unix_s)?, latitude_deg, longitude_deg)
    }

    fn at(time: &chrono::DateTime<chrono::Utc>, latitude_deg: f64, longitude_deg: f64) -> crate::Result<SunAndMoon> {
        let (sun_azimuth_deg, sun_elevation_deg) = sun::sun_angles_at(time, latitude_deg, longitude_deg)?;
        let moon = moon::moon_at(time, latitude_deg, longitude_deg)?;
        let shares = twilight::shares_of(sun_elevation_deg, &moon);
        Ok(SunAndMoon { sun_azimuth_deg, sun_elevation_deg, moon, shares })
    }

    /// Whether the moon is the sky's source ([`source_from_time_place`]'s rule): up, and
    /// its sky the brighter at the zenith (ties go to the sun).
    pub fn moon_is_source(&self) -> bool {
        // Written as the rule has always read (the sun unless the moon is up and not the
        // fainter), so that a NaN decides as before.
        !(self.moon.elevation_deg <= 0.0 || self.shares.moon_share() <= self.shares.sun_share())
    }

    /// The source's (azimuth, elevation), degrees: the moon's where it is the source,
    /// else the sun's.
    pub fn source_deg(&self) -> (f64, f64) {
        if self.moon_is_source() {
            (self.moon.azimuth_deg, self.moon.elevation_deg)
        } else {
            (self.sun_azimuth_deg, self.sun_elevation_deg)
        }
    }

    /// Why the sky cannot be read, or `None` ([`refusal`]'s rule on these numbers).
    pub fn refusal(&self) -> Option<Refusal> {
        refusal_rule(self.moon_is_source(), self.sun_elevation_deg, &self.shares)
    }

    /// The source as the captures report it, with its timestamp's text (allocates).
    fn source(&self, time: &chrono::DateTime<chrono::Utc>, latitude_deg: f64, longitude_deg: f64) -> sun::SunPosition {
        let time_utc = time.to_rfc3339_opts(chrono::SecondsFormat::AutoSi, true);
        let (azimuth_deg, elevation_deg) = self.source_deg();
        let source = if self.moon_is_source() {
            sun::SunSource::Moon {
                time_utc,
                latitude_deg,
                longitude_deg,
                illuminated_fraction: self.moon.illuminated_fraction,
                sun_elevation_deg: self.sun_elevation_deg,
            }
        } else {
            sun::SunSource::Spa { time_utc, latitude_deg, longitude_deg }
        };
        sun::SunPosition { azimuth_deg, elevation_deg, source }
    }
}

/// Which source lit the sky a reading is about, as the reading says it (the
/// [`crate::compass::Compass`]'s [`crate::compass::FieldHeading::source`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SkySource {
    /// Angles the caller gave: which body they are is the caller's to say.
    #[default]
    Given,
    /// The sun from the time and place (NREL SPA), by day or in a twilight it
    /// dominates, with both sources' shares of the sky's light at the zenith.
    Sun(twilight::Shares),
    /// The moon from the time and place (Meeus ch. 47): at night, up, and its sky the
    /// brighter; with the shares.
    Moon(twilight::Shares),
}

impl SkySource {
    /// "given", "sun" or "moon".
    pub fn name(&self) -> &'static str {
        match self {
            SkySource::Given => "given",
            SkySource::Sun(_) => "sun",
            SkySource::Moon(_) => "moon",
        }
    }

    /// The source of a capture's `sun` ([`sun::SunSource`]): the sun or the moon with the
    /// shares of its time and place (`Given` for given or unplaced angles, and where the
    /// shares cannot be computed).
    #[cfg(feature = "spa")]
    pub fn of(sun: &sun::SunPosition) -> SkySource {
        use sun::SunSource;
        let (SunSource::Spa { time_utc, latitude_deg, longitude_deg }
        | SunSource::Moon { time_utc, latitude_deg, longitude_deg, .. }) = &sun.source
        else {
            return SkySource::Given;
        };
        match (twilight::shares_at(time_utc, *latitude_deg, *longitude_deg), &sun.source) {
            (Ok(s), SunSource::Moon { .. }) => SkySource::Moon(s),
            (Ok(s), _) => SkySource::Sun(s),
            (Err(_), _) => SkySource::Given,
        }
    }

    /// The shares of the sky's light at the zenith, where the source came from a time
    /// and place.
    pub fn shares(&self) -> Option<&twilight::Shares> {
        match self {
            SkySource::Given => None,
            SkySource::Sun(s) | SkySource::Moon(s) => Some(s),
        }
    }
}

#[cfg(all(test, feature = "spa"))]
mod tests {
    use super::*;

    #[test]
    fn the_sun_by_day_and_twilight_the_moon_at_night_when_it_is_up() {
        // Qingdao, 2026-06-21: 04:00 UTC is noon; 16:00 UTC is midnight.
        let day = source_from_time_place("2026-06-21T04:00:00Z", 36.07, 120.38).unwrap();
        assert!(matches!(day.source, sun::SunSource::Spa { .. }), "{day:?}");
        assert_eq!(dark_night(&day), None);
        // Every hour of a month of days and nights: the moon where it is up and its sky
        // the brighter (twilight.rs), never by day or below the horizon; the frames the
        // readers refuse (dark_night) are those with the sun past −10° and no moon to
        // read alone, and the mixed twilight ones, naming both shares.
        let (mut moonlit, mut dark, mut mixed) = (0, 0, 0);
        for hour in 0..(30 * 24) {
            let t = 1_782_000_000.0 + 3600.0 * hour as f64;
            let s = source_from_unix_time(t, 36.07, 120.38).unwrap();
            let sun = sun::sun_from_unix_time(t, 36.07, 120.38).unwrap();
            let moon = moon::moon_from_unix_time(t, 36.07, 120.38).unwrap();
            let shares = twilight::shares_of(sun.elevation_deg, &moon);
            let why = dark_night(&s);
            match &s.source {
                sun::SunSource::Moon { sun_elevation_deg, illuminated_fraction, .. } => {
                    moonlit += 1;
                    assert!(*sun_elevation_deg < 0.0 && moon.elevation_deg > 0.0);
                    assert!(shares.moon_share() > 0.5, "{}", shares.describe());
                    assert_eq!((s.azimuth_deg, s.elevation_deg), (moon.azimuth_deg, moon.elevation_deg));
                    assert_eq!(*illuminated_fraction, moon.illuminated_fraction);
                    assert!(s.source.describe().contains("the moon"), "{}", s.source.describe());
                    assert_eq!(why.is_some(), shares.moon_share() < twilight::DOMINANT_SHARE, "{why:?}");
                }
                _ => {
                    assert_eq!(s, sun);
                    assert!(moon.elevation_deg <= 0.0 || shares.sun_share() >= 0.5, "{}", shares.describe());
                    if shares.dominant() == twilight::Dominant::Mixed {
                        mixed += 1;
                        assert!(why.as_deref().unwrap().contains("no single source"), "{why:?}");
                    } else if sun.elevation_deg < NIGHT_SUN_ELEVATION_DEG {
                        dark += 1;
                        assert!(why.is_some());
                    } else {
                        assert_eq!(why, None, "{}", shares.describe());
                    }
                }
            }
        }
        // About half the night hours have the moon up over a lunar month; a mixed sky
        // lasts minutes a day, so few whole hours fall in it.
        assert!(moonlit > 60 && dark > 60, "{moonlit} moonlit hours, {dark} dark ones");
        assert!(mixed > 0 && mixed < 60, "{mixed} mixed hours");
    }

    #[test]
    fn sun_and_moon_are_the_text_route_s_numbers_bit_for_bit() {
        // Every 2 h 17 min 0.37 s over a month at two places (days, moonlit nights, dark
        // ones, mixed twilights): the numbers a clock-given frame is read with are each
        // ephemeris's own, and the source the text route reports (its stamp parsed back
        // from its text, too) is the one they name.
        let (mut moon_source, mut mixed) = (0, 0);
        for k in 0..320 {
            for (lat, lon) in [(36.07, 120.38), (20.0, 120.38)] {
                let t = 1_782_000_000.0 + 8220.37 * k as f64;
                let both = SunAndMoon::at_unix_time(t, lat, lon).unwrap();
                let sun = sun::sun_from_unix_time(t, lat, lon).unwrap();
                let moon = moon::moon_from_unix_time(t, lat, lon).unwrap();
                assert_eq!((both.sun_azimuth_deg, both.sun_elevation_deg), (sun.azimuth_deg, sun.elevation_deg));
                assert_eq!(both.moon, moon);
                assert_eq!(both.shares, twilight::shares_of(sun.elevation_deg, &moon));
                let (src, shares) = source_and_shares_from_unix_time(t, lat, lon).unwrap();
                assert_eq!(shares, both.shares);
                assert_eq!((src.azimuth_deg, src.elevation_deg), both.source_deg(), "{t}");
                assert_eq!(matches!(src.source, sun::SunSource::Moon { .. }), both.moon_is_source(), "{t}");
                assert_eq!(refusal(&src, &shares), both.refusal(), "{t}");
                let text = src.source.time_utc().unwrap();
                assert_eq!(source_from_time_place(text, lat, lon).unwrap(), src, "{text}");
                assert_eq!(twilight::shares_at(text, lat, lon).unwrap(), shares, "{text}");
                moon_source += usize::from(both.moon_is_source());
                mixed += usize::from(matches!(both.refusal(), Some(Refusal::Mixed(_))));
            }
        }
        assert!(moon_source > 50 && mixed > 0, "{moon_source} moonlit, {mixed} mixed");
    }

    #[test]
    fn a_civil_twilight_is_the_sun_s_and_a_mixed_one_is_refused_naming_both() {
        // Shares at a time and place agree with the rule's source and refusal.
        let t = "2026-06-21T11:40:00Z"; // Qingdao after sunset
        let s = source_from_time_place(t, 36.07, 120.38).unwrap();
        let sh = twilight::shares_at(t, 36.07, 120.38).unwrap();
        assert!(sh.sun_elevation_deg < 0.0 && sh.sun_elevation_deg > -10.0, "{}", sh.describe());
        assert!(matches!(s.source, sun::SunSource::Spa { .. }) && sh.dominant() == twilight::Dominant::Sun);
        assert_eq!(dark_night(&s), None);
        assert!(s.source.describe().contains("twilight: the sun at"), "{}", s.source.describe());
        // 2026-06-24T12:30Z: the sun at −12.4° and a 75 % moon at 35.5° give about half each.
        let t = "2026-06-24T12:30:00Z";
        let sh = twilight::shares_at(t, 36.07, 120.38).unwrap();
        assert_eq!(sh.dominant(), twilight::Dominant::Mixed, "{}", sh.describe());
        let why = dark_night(&source_from_time_place(t, 36.07, 120.38).unwrap()).unwrap();
        let (p, q) = (format!("{:.0} %", 100.0 * sh.sun_share()), format!("{:.0} %", 100.0 * sh.moon_share()));
        assert!(why.contains(&format!("the sun at -12.4° gives {p}")) && why.contains(&q), "{why}");
        assert!(why.contains("no single source") && why.contains("refused"), "{why}");
    }
}
