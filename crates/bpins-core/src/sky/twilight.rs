//! Twilight: the sun below the horizon still lights the sky, and a moon that is up
//! lights it too. Which of the two a frame's sky is read about, and why.
//!
//! ```text
//! L_sun(h)  = K&S's zenith (radiometry.rs)                                  h > 0
//!           = L_0 · (L_5/L_0)^(−h/5°)                                       −5° ≤ h ≤ 0   (log-linear bridge)
//!           = max(0, 10.8e4·10^(−0.4·m_V(ζ)) − 10.8e4·10^(−0.4·21.6))       h < −5°, ζ = 90° − h
//! m_V(ζ)    = 11.84 + 1.518·(ζ − 95°) − 0.057·(ζ − 95°)²                     V mag/arcsec², zenith
//! L_moon    = K&S's zenith under the moon (radiometry.rs)                    moon above the horizon, else 0
//! P = L_sun/(L_sun + L_moon),  Q = 1 − P                                     the sources' shares at the zenith
//! ```
//!
//! Source: Patat, Ugolnikov & Postylyakov 2006 (A&A 455, 385), the zenith's twilight
//! sky in V at Paranal against the sun's zenith distance ζ, their second-order fit over
//! 95°–105° (measured over 94°–112°); their brightness includes Paranal's dark night sky,
//! V = 21.6 mag/arcsec² (Patat 2003, A&A 400, 1183), which is taken out here so that
//! L_sun is the sun's scattered light alone (it reaches 0 at ζ ≈ 106°, h ≈ −16°: the
//! sky is then the night's). Between the horizon and h = −5° (ζ = 95°, where Patat's
//! fit starts) the luminance is bridged log-linearly from K&S's sun on the horizon
//! (L_0 ≈ 650 cd/m², their model with the sun's airmass 5) to Patat's 2.0 cd/m²: a
//! slope of 1.26 mag per degree against Patat's 1.52 at 95°, so no step and no kink
//! larger than the data's scatter. (The fit's three coefficients are the V row of the
//! paper's Table 4, checked against an independent transcription of that table in a
//! public astronomy package's `Paranal_sky_brightness` — U 11.78/1.376/−0.039, B
//! 11.84/1.411/−0.041, V 11.84/1.518/−0.057, R 11.40/1.567/−0.064, I 10.93/1.470/−0.062,
//! valid for ζ ≥ 95° and held at 106° beyond — since this workplace cannot reach the
//! paper itself; the shape, ~1.5 mag per degree at ζ = 95°, is the paper's Fig. 5.)
//! The twilight sky's polarization is taken as
//! Rayleigh's about the sun below the horizon (the E-vector ⊥ the sun–view plane, as
//! Cronin et al. 2006 measured it through civil twilight), with the day's d_max.
//!
//! The reader's rule (`sky::source_from_time_place`, `sky::dark_night`): the frame's
//! source is the source with the larger share. A sky lit by both has two patterns,
//! about two points, summed as Stokes vectors, and no single source's pattern fits it:
//! the heading reads it with both (`heading::field::two_sources`: both bodies from the
//! ephemeris, the share fitted beside the heading) wherever the smaller share is at
//! least [`READ_BOTH_SHARE`] ([`Shares::reads_both`]); what needs one source's pattern
//! (`bpins fit`, `bpins diagnose`, a colour compass) refuses a frame where neither
//! share reaches [`DOMINANT_SHARE`], naming both.
//!
//! Units: cd/m², degrees, shares in [0, 1]. Frame: world ENU (elevations). Cannot: the
//! twilight sky's own shape (its brightening toward the sun's azimuth, its colour, the
//! Earth's shadow; only the zenith's luminance sets the share); a site lower or hazier
//! than Paranal (≈ 30 % brighter twilight, Patat et al. 2006); the moon's own twilight
//! (its sky uses K&S, a source above the horizon).

use crate::sky::radiometry::{cd_m2_from_mag_arcsec2, SkyLight, SUN_OUTSIDE_LUX};

/// The sun's elevation below which it lights the sky no more, degrees (astronomical
/// twilight's end; Patat's remainder is already 0 from about −16°).
pub const TWILIGHT_END_DEG: f64 = -18.0;

/// The share of the sky's light at the zenith one source must give for what reads one
/// source's pattern (`bpins fit`, `bpins diagnose`, a colour compass) to read the frame;
/// below it those refuse it ([`Dominant::Mixed`], `sky::Refusal::Mixed`), while the
/// heading reads it with both sources ([`READ_BOTH_SHARE`]). Measured (docs/night.md "Twilight", `bpins simulate --scene twilight.strength=…`
/// read with the dominant source's angles given): an unmodelled second source of share
/// q turns the read heading by 30–50·q degrees RMS where the two stand 70–145° apart in
/// azimuth (7·q where they stand opposite), and the reported 1σ seldom covers it (0–3 of 8
/// frames within 2σ at 1–5 %). At 90 % that is 3–5°; at 99 %, 0.3–0.45° RMS, about the
/// night's own 1σ (0.1–0.3°, docs/night.md) and the published night compass's 0.32°.
pub const DOMINANT_SHARE: f64 = 0.99;

/// The smaller share from which the compass reads a sky with both sources
/// (`heading::field::two_sources`), where the two light it and the frame is not refused:
/// measured (docs/night.md "Twilight", the sun's pattern read alone, 1σ 0.011°): the
/// moon at 0.24 % turned it 0.050° RMS (0/8 within 2σ), at 0.08 % 0.017° (23/24).
pub const READ_BOTH_SHARE: f64 = 0.001;

/// Patat et al. 2006's V fit at the zenith (their Table 4): a0, a1 (per degree), a2 (per
/// degree²), about ζ = 95°.
const PATAT_V: [f64; 3] = [11.84, 1.518, -0.057];
/// Paranal's dark-time zenith V, mag/arcsec² (Patat 2003): inside Patat's twilight values.
const PARANAL_NIGHT_V_MAG: f64 = 21.6;
/// Where Patat's fit starts: the sun's elevation, degrees (ζ = 95°).
const BRIDGE_DEG: f64 = -5.0;

/// The clear sky's luminance at the zenith under the sun at `elevation_deg`, cd/m²:
/// K&S above the horizon, twilight below it (module doc), 0 past [`TWILIGHT_END_DEG`].
pub fn sun_zenith_cd_m2(elevation_deg: f64) -> f64 {
    if elevation_deg > 0.0 {
        return SkyLight::new(crate::sky::radiometry::Light::Sun, SUN_OUTSIDE_LUX, elevation_deg.min(90.0))
            .map_or(f64::NAN, |l| l.zenith_cd_m2);
    }
    if elevation_deg >= BRIDGE_DEG {
        let (l0, l5) = (horizon_cd_m2(), patat_cd_m2(90.0 - BRIDGE_DEG));
        return l0 * (l5 / l0).powf(elevation_deg / BRIDGE_DEG);
    }
    if elevation_deg <= TWILIGHT_END_DEG {
        return 0.0;
    }
    patat_cd_m2(90.0 - elevation_deg)
}

/// K&S's zenith with the sun on the horizon (its limit from above), cd/m².
fn horizon_cd_m2() -> f64 {
    let i_fc = SUN_OUTSIDE_LUX / 10.763_910_4;
    crate::sky::radiometry::ks91_scattered_nl(i_fc, 90.0, 0.0, 90.0) * crate::sky::radiometry::CD_M2_PER_NL
}

/// Patat et al. 2006's twilight at the zenith less the night sky inside it, cd/m² (≥ 0).
fn patat_cd_m2(sun_zenith_deg: f64) -> f64 {
    let x = sun_zenith_deg - 95.0;
    let m = PATAT_V[0] + PATAT_V[1] * x + PATAT_V[2] * x * x;
    (cd_m2_from_mag_arcsec2(m) - cd_m2_from_mag_arcsec2(PARANAL_NIGHT_V_MAG)).max(0.0)
}

/// The two sources' light at the zenith for one time and place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shares {
    pub sun_elevation_deg: f64,
    /// The moon's elevation, degrees (NaN where no moon was placed).
    pub moon_elevation_deg: f64,
    /// Fraction of the moon's disc lit.
    pub moon_illuminated_fraction: f64,
    /// The sun's sky at the zenith, cd/m² ([`sun_zenith_cd_m2`]).
    pub sun_cd_m2: f64,
    /// The moon's sky at the zenith, cd/m² (0 below the horizon).
    pub moon_cd_m2: f64,
}

/// Which source a frame's sky is read about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dominant {
    Sun,
    Moon,
    /// Neither gives [`DOMINANT_SHARE`].
    Mixed,
}

impl Shares {
    /// The shares under the sun at `sun_elevation_deg` and a moon at `moon_elevation_deg`
    /// giving `moon_outside_lux` outside the atmosphere (K&S, `moon.rs`).
    pub fn new(sun_elevation_deg: f64, moon_elevation_deg: f64, moon_outside_lux: f64, lit_fraction: f64) -> Shares {
        let moon_cd_m2 = if moon_elevation_deg > 0.0 {
            SkyLight::new(crate::sky::radiometry::Light::Moon, moon_outside_lux, moon_elevation_deg.min(90.0))
                .map_or(0.0, |l| l.zenith_cd_m2)
        } else {
            0.0
        };
        Shares {
            sun_elevation_deg,
            moon_elevation_deg,
            moon_illuminated_fraction: lit_fraction,
            sun_cd_m2: sun_zenith_cd_m2(sun_elevation_deg),
            moon_cd_m2,
        }
    }

    /// The sun's share P of the sky's light at the zenith (1 where neither lights it).
    pub fn sun_share(&self) -> f64 {
        let total = self.sun_cd_m2 + self.moon_cd_m2;
        if total > 0.0 {
            self.sun_cd_m2 / total
        } else {
            1.0
        }
    }

    /// The moon's share Q = 1 − P.
    pub fn moon_share(&self) -> f64 {
        1.0 - self.sun_share()
    }

    /// The sun's share of the two skies' radiance per unit of Rayleigh's pattern,
    /// u_sun/(u_sun + u_moon) with u = L_zenith/½(1 + sin²h) (the `twilight` scene
    /// element's weights): with one d_max for both, the sun's share w of the polarized
    /// radiance the two-source heading fits (`heading::field::two_sources`); 1 where
    /// neither lights the sky.
    pub fn sun_unit_share(&self) -> f64 {
        let unit = |cd_m2: f64, el_deg: f64| cd_m2 / (0.5 * (1.0 + el_deg.to_radians().sin().powi(2)));
        let u_sun = unit(self.sun_cd_m2, self.sun_elevation_deg);
        let u_moon = if self.moon_cd_m2 > 0.0 { unit(self.moon_cd_m2, self.moon_elevation_deg) } else { 0.0 };
        if u_sun + u_moon > 0.0 {
            u_sun / (u_sun + u_moon)
        } else {
            1.0
        }
    }

    /// Whether both sources light the sky and the smaller gives at least
    /// [`READ_BOTH_SHARE`]: a sky the compass reads with both (where it reads it at all).
    pub fn reads_both(&self) -> bool {
        let p = self.sun_share();
        self.sun_cd_m2 > 0.0 && self.moon_cd_m2 > 0.0 && p.min(1.0 - p) >= READ_BOTH_SHARE
    }

    /// Which source gives at least [`DOMINANT_SHARE`], if either.
    pub fn dominant(&self) -> Dominant {
        let p = self.sun_share();
        if p >= DOMINANT_SHARE {
            Dominant::Sun
        } else if 1.0 - p >= DOMINANT_SHARE {
            Dominant::Moon
        } else {
            Dominant::Mixed
        }
    }

    /// Whether both sources light the sky (the sun above [`TWILIGHT_END_DEG`] and below
    /// the horizon, or the moon up with the sun's twilight).
    pub fn is_twilight(&self) -> bool {
        self.sun_elevation_deg <= 0.0 && self.sun_elevation_deg > TWILIGHT_END_DEG
    }

    /// "twilight: the sun at −4.0° gives 100 % of the sky's light, the moon 0 % (below the horizon)".
    pub fn describe(&self) -> String {
        let moon = if self.moon_elevation_deg > 0.0 {
            format!("at {:.1}°, {:.0} % lit", self.moon_elevation_deg, 100.0 * self.moon_illuminated_fraction)
        } else if self.moon_elevation_deg.is_finite() {
            format!("at {:.1}°, below the horizon", self.moon_elevation_deg)
        } else {
            "not placed".to_string()
        };
        format!(
            "twilight: the sun at {:.1}° gives {} of the sky's light, the moon ({moon}) {}",
            self.sun_elevation_deg,
            percent(self.sun_share()),
            percent(self.moon_share())
        )
    }

    /// Why a mixed frame is not read where one source's pattern is needed (for
    /// [`Dominant::Mixed`]: a one-source reader's typed refusal; `bpins fit` and `bpins
    /// diagnose` model both skies instead, `fit::input::sky`).
    pub fn mixed_reason(&self) -> String {
        format!(
            "{}: a sky lit by both has two polarization patterns (one about each source) and no single source's \
             E-vector pattern; read here when one gives at least {:.0} % (refused by this one-source reader; `bpins \
             heading`, the compass, monochrome or colour, and `bpins fit` read it with both sources)",
            self.describe(),
            100.0 * DOMINANT_SHARE
        )
    }

    /// Why a dark frame is not read: the sun past `sky::NIGHT_SUN_ELEVATION_DEG` (its
    /// pattern faded) and the moon below the horizon, or up but too faint to be read
    /// alone (`sky::Refusal::Dark`).
    pub fn dark_reason(&self) -> String {
        if self.moon_elevation_deg > 0.0 {
            return format!(
                "{}: the sun's pattern has faded past {:.0}° and the moon's sky is too faint to be read alone \
                 (refused)",
                self.describe(),
                crate::sky::NIGHT_SUN_ELEVATION_DEG
            );
        }
        format!(
            "not yet: the moon is at {:.1}° and the sun at {:.1}°: neither lights the sky (the moon is read from \
             the time and place once it rises)",
            self.moon_elevation_deg, self.sun_elevation_deg
        )
    }
}

/// A share as a percentage: whole numbers, with "< 1 %" and "> 99 %" at the ends.
fn percent(share: f64) -> String {
    let p = 100.0 * share;
    if p > 0.0 && p < 0.5 {
        "< 1 %".into()
    } else if p < 100.0 && p > 99.5 {
        "> 99 %".into()
    } else {
        format!("{p:.0} %")
    }
}

/// The shares at `time_utc` and a place (SPA for the sun, `moon.rs` for the moon).
#[cfg(feature = "spa")]
pub fn shares_at(time_utc: &str, latitude_deg: f64, longitude_deg: f64) -> crate::Result<Shares> {
    let time = crate::sky::sun::parse_time_utc(time_utc)?;
    Ok(crate::sky::SunAndMoon::at(&time, latitude_deg, longitude_deg)?.shares)
}

/// The shares under the sun at `sun_elevation_deg` and `moon`.
#[cfg(feature = "spa")]
pub fn shares_of(sun_elevation_deg: f64, moon: &crate::sky::moon::MoonPosition) -> Shares {
    // Outside the atmosphere: K&S at the zenith with no extinction, at 1 au (as radiometry.rs).
    let outside = crate::sky::moon::moon_illuminance_lux(moon.phase_angle_deg, moon.distance_km, 1.0, 90.0, 0.0);
    Shares::new(sun_elevation_deg, moon.elevation_deg, outside, moon.illuminated_fraction)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sun_s_sky_is_continuous_across_the_horizon_and_the_bridge_and_fades_to_nothing() {
        // Across the horizon: K&S's limit from above meets the bridge.
        let (above, below) = (sun_zenith_cd_m2(1e-6), sun_zenith_cd_m2(0.0));
        assert!((above / below - 1.0).abs() < 1e-4, "{above} vs {below}");
        assert!(below > 300.0 && below < 1500.0, "the zenith at sunset: {below} cd/m²");
        // Across −5°: the bridge meets Patat's fit (11.84 mag/arcsec², ≈ 2.0 cd/m²).
        let (a, b) = (sun_zenith_cd_m2(-5.0 + 1e-9), sun_zenith_cd_m2(-5.0 - 1e-9));
        assert!((a / b - 1.0).abs() < 1e-6, "{a} vs {b}");
        assert!((a - cd_m2_from_mag_arcsec2(11.84)).abs() < 0.01 * a, "{a}");
        // No step anywhere: within 0.05° the luminance changes by under 8 % (the steepest
        // slope is Patat's near its end, ≈ 1.5 mag per degree → 7 % per 0.05°).
        let mut h = 10.0;
        while h > TWILIGHT_END_DEG {
            let (l1, l2) = (sun_zenith_cd_m2(h), sun_zenith_cd_m2(h - 0.05));
            assert!(l2 <= l1, "not monotonic at {h}°");
            if l2 > 1e-3 {
                assert!(l2 / l1 > 0.92, "a step at {h}°: {l1} → {l2}");
            }
            h -= 0.05;
        }
        // Nautical twilight's middle (−10°): ≈ 18.4 mag/arcsec², a full moon's sky;
        // astronomical twilight's end: nothing of the sun's.
        let m10 = crate::sky::radiometry::mag_arcsec2_from_cd_m2(sun_zenith_cd_m2(-10.0));
        assert!(m10 > 18.0 && m10 < 19.0, "{m10}");
        assert_eq!(sun_zenith_cd_m2(-17.0), 0.0);
        assert_eq!(sun_zenith_cd_m2(-30.0), 0.0);
    }

    #[test]
    fn shares_sum_to_one_and_name_the_dominant_source() {
        // A full moon (0.3 lx outside) at 40° against the sun at −4° (civil twilight),
        // −10° and −14°.
        let civil = Shares::new(-4.0, 40.0, 0.3, 1.0);
        assert_eq!(civil.dominant(), Dominant::Sun);
        assert!(civil.sun_share() > 0.999, "{}", civil.sun_share());
        let mid = Shares::new(-10.0, 40.0, 0.3, 1.0);
        assert_eq!(mid.dominant(), Dominant::Mixed);
        assert!((mid.sun_share() + mid.moon_share() - 1.0).abs() < 1e-15);
        let late = Shares::new(-15.8, 40.0, 0.3, 1.0);
        assert_eq!(late.dominant(), Dominant::Moon, "{}", late.describe());
        assert_eq!(Shares::new(-14.0, 40.0, 0.3, 1.0).dominant(), Dominant::Mixed);
        // No moon: the sun's, whatever its elevation; neither: the sun's (1, refused elsewhere).
        assert_eq!(Shares::new(-12.0, -5.0, 0.3, 1.0).dominant(), Dominant::Sun);
        assert_eq!(Shares::new(-40.0, -5.0, 0.3, 1.0).sun_share(), 1.0);
        // The words name both shares.
        let why = mid.mixed_reason();
        let (p, q) = (format!("{:.0} %", 100.0 * mid.sun_share()), format!("{:.0} %", 100.0 * mid.moon_share()));
        assert!(why.contains(&p) && why.contains(&q) && why.contains("-10.0°") && why.contains("40.0°"), "{why}");
        assert!(why.contains("no single source"), "{why}");
        assert!(civil.describe().contains("> 99 %") && civil.describe().contains("< 1 %"), "{}", civil.describe());
    }
}
