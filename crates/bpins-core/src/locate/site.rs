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
//! The sun for a later time comes from SPA at the place; its 1σ is the place's,
//! propagated: √((∂A/∂φ σ_φ)² + (∂A/∂λ σ_λ)²), and the same for the elevation, the
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
        let (Some(lon), Some(s_lon)) = (self.longitude_deg, self.longitude_sigma_deg) else {
            return Err(Error::Place(
                "the site has no longitude (located by the pole route, without a clock): the sun at a time needs one"
                    .into(),
            ));
        };
        let lat = self.latitude_deg;
        let at = |la: f64, lo: f64| {
            sun_from_unix_time(time_unix_s, la.clamp(-90.0, 90.0), crate::conventions::wrap_deg_180(lo))
        };
        let s = at(lat, lon)?;
        let d = 0.01;
        let dlat = at(lat + d, lon)?;
        let dlon = at(lat, lon + d)?;
        let da = |x: f64| crate::conventions::wrap_deg_180(x - s.azimuth_deg) / d;
        let sig_az = (da(dlat.azimuth_deg) * self.latitude_sigma_deg).hypot(da(dlon.azimuth_deg) * s_lon);
        let sig_el = ((dlat.elevation_deg - s.elevation_deg) / d * self.latitude_sigma_deg)
            .hypot((dlon.elevation_deg - s.elevation_deg) / d * s_lon);
        Ok((s.azimuth_deg, s.elevation_deg, sig_az.max(sig_el)))
    }

    /// The sun at `time_unix_s` for the [`Compass`](crate::compass::Compass), its 1σ
    /// the place's ([`Site::sun_at`]).
    pub fn compass_sun(&self, time_unix_s: f64) -> Result<crate::compass::Sun> {
        let (azimuth_deg, elevation_deg, sigma_deg) = self.sun_at(time_unix_s)?;
        Ok(crate::compass::Sun::Angles { azimuth_deg, elevation_deg, sigma_deg })
    }

    /// Gives every frame of `c` stamped without a place (read by
    /// [`Capture::load_unplaced`](crate::capture::Capture::load_unplaced)) the sun at
    /// this site, its 1σ the place's in quadrature with the frame's own
    /// `sun_sigma_deg`. Returns how many frames it placed.
    pub fn place(&self, c: &mut crate::capture::Capture) -> Result<usize> {
        let mut n = 0;
        for f in &mut c.frames {
            let crate::sky::sun::SunSource::Unplaced { time_utc } = &f.sun.source else { continue };
            let t = crate::sky::sun::parse_time_utc(time_utc)?;
            let t_s = t.timestamp() as f64 + f64::from(t.timestamp_subsec_nanos()) * 1e-9;
            let (_, _, sigma) = self.sun_at(t_s)?;
            let lon = self.longitude_deg.unwrap_or(f64::NAN);
            f.sun = crate::sky::sun::sun_from_time_place(time_utc, self.latitude_deg, lon)?;
            f.sun_sigma_deg = Some(f.sun_sigma_deg.unwrap_or(0.0).hypot(sigma));
            n += 1;
        }
        Ok(n)
    }
}
