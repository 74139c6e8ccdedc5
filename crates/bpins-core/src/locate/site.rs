//! The file `bpins locate` writes (`bpins-site/1`), which `bpins heading --site` and
//! the [`crate::compass::Compass`] (through [`Site::sun_at`]) take in place of a GNSS
//! position: the place with its 1σ, and the camera's north offset with its 1σ.
//!
//! ```toml
//! format = "bpins-site/1"
//! route = "stamped"              # or "pole" (no longitude)
//! time_utc = "2026-06-21T02:00:00Z"   # the first frame located from
//! latitude_deg = 36.07
//! latitude_sigma_deg = 0.12
//! longitude_deg = 120.38
//! longitude_sigma_deg = 0.15
//! heading_deg = 30.02            # the camera's heading (image top) at that frame
//! heading_sigma_deg = 0.05
//! ```
//!
//! The sun for a later time comes from SPA at the place (the sky's source by the
//! readers' rule, `sky::source_from_time_place`: the moon at night where its sky is the
//! brighter, through Meeus); its 1σ is the place's, propagated through that body's
//! ephemeris: √((∂A/∂φ σ_φ)² + (∂A/∂λ σ_λ)²), and the same for the elevation, the
//! larger of the two (azimuth and elevation share one 1σ in the compass).

use super::{Located, Route};
use crate::error::{Error, Result};
use crate::sky::sun::sun_from_unix_time;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The `format` this reader and writer implement.
pub const FORMAT: &str = "bpins-site/1";

/// A located site (see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Site {
    pub format: String,
    pub route: String,
    pub time_utc: Option<String>,
    pub latitude_deg: f64,
    pub latitude_sigma_deg: f64,
    pub longitude_deg: Option<f64>,
    pub longitude_sigma_deg: Option<f64>,
    pub heading_deg: f64,
    pub heading_sigma_deg: f64,
}

impl Site {
    /// The site of a [`Located`] answer, stamped with its first frame's time.
    pub fn from_located(l: &Located, time_utc: Option<String>) -> Site {
        Site {
            format: FORMAT.into(),
            route: l.route.name().into(),
            time_utc,
            latitude_deg: l.latitude_deg,
            latitude_sigma_deg: l.latitude_sigma_deg,
            longitude_deg: l.longitude_deg,
            longitude_sigma_deg: l.longitude_sigma_deg,
            heading_deg: l.heading_deg,
            heading_sigma_deg: l.heading_sigma_deg,
        }
    }

    pub fn to_toml_string(&self) -> String {
        let mut t = String::from("# written by bpins locate: the place and the camera's north offset, 1σ in degrees\n");
        t.push_str(&toml::to_string(self).expect("a site serialises"));
        t
    }

    /// Writes [`Site::to_toml_string`] to `path` whole or not at all (a temporary
    /// beside it, renamed into place), replacing a file there.
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::output::write_bytes(path, crate::output::Replace::Allowed, self.to_toml_string().as_bytes())
    }

    /// Reads and checks a `bpins-site/1` file; errors name the file and the key.
    pub fn load(path: &Path) -> Result<Site> {
        let bad = |m: String| Error::Calibration { path: path.to_path_buf(), message: m };
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.to_path_buf(), source: e })?;
        let s: Site = toml::from_str(&text).map_err(|e| bad(crate::capture::clean_toml_error(e)))?;
        if s.format != FORMAT {
            return Err(bad(format!("format = \"{}\" is not supported; this reader knows \"{FORMAT}\"", s.format)));
        }
        if s.route != Route::Stamped.name() && s.route != Route::Pole.name() {
            return Err(bad(format!("route = \"{}\": use \"stamped\" or \"pole\"", s.route)));
        }
        let checks = [
            ("latitude_deg", Some(s.latitude_deg), -90.0, 90.0),
            ("longitude_deg", s.longitude_deg, -180.0, 180.0),
            ("heading_deg", Some(s.heading_deg), -360.0, 360.0),
            ("latitude_sigma_deg", Some(s.latitude_sigma_deg), 0.0, 90.0),
            ("longitude_sigma_deg", s.longitude_sigma_deg, 0.0, 180.0),
            ("heading_sigma_deg", Some(s.heading_sigma_deg), 0.0, 180.0),
        ];
        for (key, v, lo, hi) in checks {
            if let Some(v) = v.filter(|v| !(lo..=hi).contains(v)) {
                return Err(bad(format!("{key} = {v} is outside [{lo}, {hi}]")));
            }
        }
        if s.longitude_deg.is_some() != s.longitude_sigma_deg.is_some() {
            return Err(bad("longitude_deg and longitude_sigma_deg go together".into()));
        }
        Ok(s)
    }

    /// The sun at `time_unix_s` from this site: (azimuth, elevation, 1σ), degrees.
    /// Errs on a site without longitude (the pole route: no clock, no sun).
    pub fn sun_at(&self, time_unix_s: f64) -> Result<(f64, f64, f64)> {
        self.body_at(&|la, lo| sun_from_unix_time(time_unix_s, la, lo).map(|s| (s.azimuth_deg, s.elevation_deg)))
    }

    /// The sky's source at `time_unix_s` from this site by the rule every reader uses
    /// (`sky::source_from_unix_time`: the sun, or the moon at night where its sky is the
    /// brighter), with the 1σ of its angles from the site's, propagated through that
    /// body's own ephemeris (module doc). Errs as [`Site::sun_at`].
    pub fn source_at(&self, time_unix_s: f64) -> Result<(crate::sky::sun::SunPosition, f64)> {
        let (_, lon) = self.place_of()?;
        let src = crate::sky::source_from_unix_time(time_unix_s, self.latitude_deg, lon)?;
        let (_, _, sigma_deg) = if matches!(src.source, crate::sky::sun::SunSource::Moon { .. }) {
            self.body_at(&|la, lo| {
                crate::sky::moon::moon_from_unix_time(time_unix_s, la, lo).map(|m| (m.azimuth_deg, m.elevation_deg))
            })?
        } else {
            self.sun_at(time_unix_s)?
        };
        Ok((src, sigma_deg))
    }

    /// The site's latitude and longitude, degrees; errs without a longitude.
    fn place_of(&self) -> Result<(f64, f64)> {
        match self.longitude_deg {
            Some(lon) if self.longitude_sigma_deg.is_some() => Ok((self.latitude_deg, lon)),
            _ => Err(Error::Place(
                "the site has no longitude (located by the pole route, without a clock): the sun at a time needs one"
                    .into(),
            )),
        }
    }

    /// A body's (azimuth, elevation) from `at(latitude, longitude)` at this site, with
    /// the 1σ the site's place gives them (module doc), degrees.
    fn body_at(&self, at: &dyn Fn(f64, f64) -> Result<(f64, f64)>) -> Result<(f64, f64, f64)> {
        let (lat, lon) = self.place_of()?;
        let s_lon = self.longitude_sigma_deg.unwrap_or(0.0);
        let at = |la: f64, lo: f64| at(la.clamp(-90.0, 90.0), crate::conventions::wrap_deg_180(lo));
        let (az, el) = at(lat, lon)?;
        let d = 0.01;
        let dlat = at(lat + d, lon)?;
        let dlon = at(lat, lon + d)?;
        let da = |x: f64| crate::conventions::wrap_deg_180(x - az) / d;
        let sig_az = (da(dlat.0) * self.latitude_sigma_deg).hypot(da(dlon.0) * s_lon);
        let sig_el = ((dlat.1 - el) / d * self.latitude_sigma_deg).hypot((dlon.1 - el) / d * s_lon);
        Ok((az, el, sig_az.max(sig_el)))
    }

    /// The sky at `time_unix_s` for the [`Compass`](crate::compass::Compass): this site's
    /// place as a time and place (`Sun::UnixTime`), so the compass reads the source by
    /// the readers' rule (the moon at night; a mixed twilight or a dark night refused,
    /// typed), its 1σ the place's ([`Site::source_at`]).
    pub fn compass_sun(&self, time_unix_s: f64) -> Result<crate::compass::Sun> {
        let (latitude_deg, longitude_deg) = self.place_of()?;
        let (_, sigma_deg) = self.source_at(time_unix_s)?;
        Ok(crate::compass::Sun::UnixTime { time_s: time_unix_s, latitude_deg, longitude_deg, sigma_deg })
    }

    /// Gives every frame of `c` stamped without a place (read by
    /// [`Capture::load_unplaced`](crate::capture::Capture::load_unplaced)) the sky's
    /// source at this site ([`Site::source_at`]: the moon at night), its 1σ the place's in quadrature with the frame's own
    /// `sun_sigma_deg`. Returns how many frames it placed.
    pub fn place(&self, c: &mut crate::capture::Capture) -> Result<usize> {
        let mut n = 0;
        for f in &mut c.frames {
            let crate::sky::sun::SunSource::Unplaced { time_utc } = &f.sun.source else { continue };
            let t = crate::sky::sun::parse_time_utc(time_utc)?;
            let t_s = t.timestamp() as f64 + f64::from(t.timestamp_subsec_nanos()) * 1e-9;
            let (_, sigma) = self.source_at(t_s)?;
            let lon = self.longitude_deg.unwrap_or(f64::NAN);
            f.sun = crate::sky::source_from_time_place(time_utc, self.latitude_deg, lon)?;
            f.sun_sigma_deg = Some(f.sun_sigma_deg.unwrap_or(0.0).hypot(sigma));
            n += 1;
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::sun::SunSource;

    fn site(latitude_deg: f64, longitude_deg: f64) -> Site {
        Site {
            format: FORMAT.into(),
            route: "stamped".into(),
            time_utc: None,
            latitude_deg,
            latitude_sigma_deg: 0.05,
            longitude_deg: Some(longitude_deg),
            longitude_sigma_deg: Some(0.05),
            heading_deg: 0.0,
            heading_sigma_deg: 0.1,
        }
    }

    #[test]
    fn the_site_s_source_is_the_readers_and_its_sigma_that_body_s() {
        // By day: the sun, its 1σ exactly `sun_at`'s.
        let day = site(36.07, 120.38);
        let t_day = crate::sky::sun::parse_time_utc("2026-06-21T04:00:00Z").unwrap().timestamp() as f64;
        let (src, sigma) = day.source_at(t_day).unwrap();
        assert!(matches!(src.source, SunSource::Spa { .. }), "{src:?}");
        assert_eq!((src.azimuth_deg, src.elevation_deg, sigma), day.sun_at(t_day).unwrap());
        // The full moon at 41.6° (docs/night.md): the moon, at the readers' angles, its
        // 1σ from the moon's own ephemeris: not the sun's, below the horizon.
        let night = site(20.0, 120.38);
        let t = crate::sky::sun::parse_time_utc("2026-06-29T16:00:00Z").unwrap().timestamp() as f64;
        let (moon, sigma) = night.source_at(t).unwrap();
        let want = crate::sky::source_from_unix_time(t, 20.0, 120.38).unwrap();
        assert!(matches!(moon.source, SunSource::Moon { .. }), "{moon:?}");
        assert_eq!((moon.azimuth_deg, moon.elevation_deg), (want.azimuth_deg, want.elevation_deg));
        let (_, _, sun_sigma) = night.sun_at(t).unwrap();
        assert!(
            sigma > 0.0 && sigma < 0.2 && (sigma - sun_sigma).abs() > 1e-3,
            "{sigma} against the sun's {sun_sigma}"
        );
        // The compass is given the time and place, so that it applies the rule itself.
        let crate::compass::Sun::UnixTime { latitude_deg, longitude_deg, sigma_deg, .. } =
            night.compass_sun(t).unwrap()
        else {
            panic!("a time and place");
        };
        assert_eq!((latitude_deg, longitude_deg, sigma_deg), (20.0, 120.38, sigma));
        let pole = Site { longitude_deg: None, longitude_sigma_deg: None, ..night };
        assert!(pole.source_at(t).is_err() && pole.compass_sun(t).is_err());
    }
}
