//! The sky in physical units: how bright the sky that the chain models is, in cd/m²,
//! under the sun or the moon, and a night sky's brightness in mag/arcsec².
//!
//! The chain's sky radiance is relative (Rayleigh: ½(1 + cos²γ), 1 toward the source;
//! CONVENTIONS.md "Sky"). Its absolute scale is the zenith's luminance by Krisciunas &
//! Schaefer's scattered-light model, the same for either source (the moonlit sky is
//! the sunlit sky scaled by the source's light, Gál et al. 2001):
//!
//! ```text
//! B(nL)  = f(ρ)·I*·10^(−0.4·k·X(Z_s))·[1 − 10^(−0.4·k·X(Z))]      K&S 1991, B_moon (their eq. 20)
//! f(ρ)   = 10^5.36·(1.06 + cos²ρ) + 10^(6.15 − ρ/40°)              Rayleigh + Mie, ρ ≥ 10°
//! X(Z)   = (1 − 0.96·sin²Z)^(−½)                                  airmass (K&S eq. 3)
//! L_z    = B(Z = 0, ρ = Z_s) · 1e-5/π cd/m² per nL                 zenith luminance, cd/m²
//! unit   = L_z / ½(1 + sin²h)                                     cd/m² per unit model radiance
//! L[cd/m²] = 10.8e4 · 10^(−0.4·m)                                 m in V mag/arcsec² (Garstang 1986)
//! ```
//!
//! I* is the source's illuminance outside the atmosphere in foot-candles: the sun's
//! 133.8 klx (Darula, Kittler & Gueymard 2005, the reference luminous solar constant,
//! at 1 au), the moon's from its phase and distance (`moon.rs`, K&S eqs. 8–9, at 1 au
//! from the sun); Z_s the source's zenith distance, ρ the angle between the source
//! and the view (at the zenith ρ = Z_s), k the V extinction (K&S's 0.172 mag per
//! airmass, Mauna Kea). Check: the full moon at 40° gives 4.5 mcd/m² (18.5
//! mag/arcsec²), the sun at 40° 1.8 kcd/m² at the zenith.
//!
//! Units: cd/m², lux, degrees. Frame: world ENU. Below the horizon the sun's sky is
//! twilight's (`sky/twilight.rs`: Patat et al. 2006's zenith, to about −16°). Cannot:
//! a moon below the horizon (refused, [`Error::OutOfRange`]); aerosols beyond K&S's single k; the
//! sky's own glow (airglow, starlight, light pollution: the `night_background` scene
//! element); spectral differences between sunlight and moonlight (both treated as V).

use crate::{Error, Result};
use std::f64::consts::PI;

/// The sun's illuminance outside the atmosphere at 1 au, lux (Darula, Kittler &
/// Gueymard 2005, Solar Energy 79, 559: the reference luminous solar constant).
pub const SUN_OUTSIDE_LUX: f64 = 133_800.0;
/// Lux per foot-candle (1 lm/ft²).
const LUX_PER_FOOTCANDLE: f64 = 10.763_910_4;
/// cd/m² per nanolambert: 1 L = 10⁴/π cd/m².
pub const CD_M2_PER_NL: f64 = 1e-5 / PI;
/// K&S 1991's V extinction coefficient, mag per airmass (as `moon.rs`).
pub const EXTINCTION_MAG_PER_AIRMASS: f64 = 0.172;

/// Which body lights the sky.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Light {
    Sun,
    Moon,
}

impl Light {
    pub fn name(self) -> &'static str {
        match self {
            Light::Sun => "the sun",
            Light::Moon => "the moon",
        }
    }
}

/// The sky's absolute brightness for one frame's source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyLight {
    pub light: Light,
    /// The source's elevation, degrees.
    pub elevation_deg: f64,
    /// The source's illuminance outside the atmosphere, lux (normal to the beam).
    pub outside_lux: f64,
    /// The clear sky's luminance at the zenith, cd/m².
    pub zenith_cd_m2: f64,
    /// cd/m² per unit of the chain's sky radiance (Rayleigh's, 1 toward the source).
    pub unit_cd_m2: f64,
}

impl SkyLight {
    /// The sky lit by a source of `outside_lux` at `elevation_deg` (above the horizon).
    pub fn new(light: Light, outside_lux: f64, elevation_deg: f64) -> Result<SkyLight> {
        if !(elevation_deg > 0.0 && elevation_deg <= 90.0) || !(outside_lux >= 0.0 && outside_lux.is_finite()) {
            return Err(Error::OutOfRange {
                what: format!("{}'s elevation for the sky's absolute brightness", light.name()),
                value: format!("{elevation_deg:.1}°"),
                range: "(0°, 90°] (a source above the horizon; the sun's twilight: `SkyLight::sun`)".into(),
            });
        }
        let zs = 90.0 - elevation_deg;
        let zenith_cd_m2 = ks91_scattered_nl(outside_lux / LUX_PER_FOOTCANDLE, zs, 0.0, zs) * CD_M2_PER_NL;
        let h = elevation_deg.to_radians();
        let unit_cd_m2 = zenith_cd_m2 / (0.5 * (1.0 + h.sin().powi(2)));
        Ok(SkyLight { light, elevation_deg, outside_lux, zenith_cd_m2, unit_cd_m2 })
    }

    /// The sunlit sky with the sun at `elevation_deg`: K&S above the horizon; below it
    /// the twilight sky (`sky/twilight.rs`: Patat et al. 2006) down to
    /// [`crate::sky::twilight::TWILIGHT_END_DEG`], refused past it (the sun's light is gone).
    pub fn sun(elevation_deg: f64) -> Result<SkyLight> {
        if elevation_deg > 0.0 || !elevation_deg.is_finite() {
            return SkyLight::new(Light::Sun, SUN_OUTSIDE_LUX, elevation_deg);
        }
        let zenith_cd_m2 = crate::sky::twilight::sun_zenith_cd_m2(elevation_deg);
        if !(elevation_deg > crate::sky::twilight::TWILIGHT_END_DEG && zenith_cd_m2 > 0.0) {
            return Err(Error::OutOfRange {
                what: "the sun's elevation for the sky's absolute brightness".into(),
                value: format!("{elevation_deg:.1}°"),
                range: "above the end of the sun's twilight (≈ −16°: Patat et al. 2006)".into(),
            });
        }
        // Rayleigh's zenith radiance about a sun below the horizon is ½(1 + sin²h) as above it.
        let h = elevation_deg.to_radians();
        let unit_cd_m2 = zenith_cd_m2 / (0.5 * (1.0 + h.sin().powi(2)));
        Ok(SkyLight { light: Light::Sun, elevation_deg, outside_lux: SUN_OUTSIDE_LUX, zenith_cd_m2, unit_cd_m2 })
    }

    /// One line for outputs: which source, its light, the zenith's luminance.
    pub fn describe(&self) -> String {
        format!(
            "sky lit by {} at {:.1}° ({:.3e} lx outside the atmosphere): {:.3e} cd/m² at the zenith ({:.2} mag/arcsec²)",
            self.light.name(),
            self.elevation_deg,
            self.outside_lux,
            self.zenith_cd_m2,
            mag_arcsec2_from_cd_m2(self.zenith_cd_m2)
        )
    }
}

/// The sky of a frame's source ([`crate::sky::sun::SunPosition`]): the moon from its
/// time and place (phase and distance, `moon.rs`), the sun otherwise (given angles or
/// SPA). Errs for a source at or below the horizon, or a moon that cannot be placed.
#[cfg(feature = "spa")]
pub fn sky_light(sun: &crate::sky::sun::SunPosition) -> Result<SkyLight> {
    use crate::sky::sun::SunSource;
    match &sun.source {
        SunSource::Moon { time_utc, latitude_deg, longitude_deg, .. } => {
            let m = crate::sky::moon::moon_from_time_place(time_utc, *latitude_deg, *longitude_deg)?;
            // Outside the atmosphere: K&S at the zenith with no extinction, at 1 au.
            let outside_lux = crate::sky::moon::moon_illuminance_lux(m.phase_angle_deg, m.distance_km, 1.0, 90.0, 0.0);
            SkyLight::new(Light::Moon, outside_lux, sun.elevation_deg)
        }
        _ => SkyLight::sun(sun.elevation_deg),
    }
}

/// K&S 1991's scattered moonlight (any source), nanolamberts: a source of `i_star_fc`
/// foot-candles outside the atmosphere at zenith distance `source_zenith_deg`, seen
/// at zenith distance `view_zenith_deg`, `rho_deg` from the source (module doc).
pub fn ks91_scattered_nl(i_star_fc: f64, source_zenith_deg: f64, view_zenith_deg: f64, rho_deg: f64) -> f64 {
    let k = EXTINCTION_MAG_PER_AIRMASS;
    let airmass = |z_deg: f64| (1.0 - 0.96 * z_deg.to_radians().sin().powi(2)).powf(-0.5);
    // K&S: Mie's f_M = 6.2e7/ρ² inside 10°, 10^(6.15 − ρ/40) beyond.
    let rho = rho_deg.abs();
    let mie = if rho < 10.0 { 6.2e7 / (rho * rho).max(1e-6) } else { 10f64.powf(6.15 - rho / 40.0) };
    let f = 10f64.powf(5.36) * (1.06 + rho.to_radians().cos().powi(2)) + mie;
    f * i_star_fc
        * 10f64.powf(-0.4 * k * airmass(source_zenith_deg))
        * (1.0 - 10f64.powf(-0.4 * k * airmass(view_zenith_deg)))
}

/// Luminance of a sky of `mag_arcsec2` V magnitudes per square arcsecond, cd/m²
/// (Garstang 1986; Cinzano, Falchi & Elvidge 2001: 22.0 mag/arcsec² ≈ 171 µcd/m²).
pub fn cd_m2_from_mag_arcsec2(mag_arcsec2: f64) -> f64 {
    10.8e4 * 10f64.powf(-0.4 * mag_arcsec2)
}

/// The inverse of [`cd_m2_from_mag_arcsec2`].
pub fn mag_arcsec2_from_cd_m2(cd_m2: f64) -> f64 {
    -2.5 * (cd_m2 / 10.8e4).log10()
}

/// The DoLP of skylight of DoLP `dolp` and luminance `sky_cd_m2` under an unpolarized
/// glow of `background_cd_m2`: d·L/(L + L_bg).
pub fn diluted_dolp(dolp: f64, sky_cd_m2: f64, background_cd_m2: f64) -> f64 {
    dolp * sky_cd_m2 / (sky_cd_m2 + background_cd_m2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sunlit_zenith_is_a_few_kcd_and_scales_with_the_light() {
        // Sun at 40°: clear-sky zenith luminances of 2–6 kcd/m² are measured (CIE
        // S 011 type 12 skies); K&S's Mauna Kea extinction gives the low end.
        let s = SkyLight::sun(40.0).unwrap();
        assert!(s.zenith_cd_m2 > 1000.0 && s.zenith_cd_m2 < 6000.0, "{}", s.zenith_cd_m2);
        // Linear in the source's light, and the unit is the zenith over Rayleigh's ½(1 + sin²h).
        let half = SkyLight::new(Light::Sun, SUN_OUTSIDE_LUX / 2.0, 40.0).unwrap();
        assert!((half.zenith_cd_m2 * 2.0 - s.zenith_cd_m2).abs() < 1e-9 * s.zenith_cd_m2);
        let h = 40f64.to_radians();
        assert!((s.unit_cd_m2 * 0.5 * (1.0 + h.sin().powi(2)) - s.zenith_cd_m2).abs() < 1e-9);
        // Twilight (sky/twilight.rs) down to the sun's last light; past it refused, naming it.
        let civil = SkyLight::sun(-3.0).unwrap();
        assert!(civil.zenith_cd_m2 > 1.0 && civil.zenith_cd_m2 < s.zenith_cd_m2, "{}", civil.zenith_cd_m2);
        let e = SkyLight::sun(-17.0).unwrap_err().to_string();
        assert!(e.contains("-17.0°") && e.contains("twilight"), "{e}");
    }

    #[test]
    fn ks91_by_hand_at_one_point() {
        // Full moon (I* = 10^(−0.4·(−12.73 + 16.57)) fc) at Z_s = 50°, zenith view:
        // f(50°) = 10^5.36·(1.06 + cos²50°) + 10^(6.15 − 1.25) ≈ 4.169e5;
        // X(50°) = (1 − 0.96 sin²50°)^−½ ≈ 1.5133, X(0) = 1.
        let i_star = 10f64.powf(-0.4 * (-12.73 + 16.57));
        let f = 10f64.powf(5.36) * (1.06 + 50f64.to_radians().cos().powi(2)) + 10f64.powf(4.9);
        let x = (1.0 - 0.96 * 50f64.to_radians().sin().powi(2)).powf(-0.5);
        let want = f * i_star * 10f64.powf(-0.4 * 0.172 * x) * (1.0 - 10f64.powf(-0.4 * 0.172));
        assert!((ks91_scattered_nl(i_star, 50.0, 0.0, 50.0) - want).abs() < 1e-9 * want);
        // K&S's figure: ~1400 nL for a full moon 50° away: a sky of ~18.5 mag/arcsec².
        assert!(want > 1000.0 && want < 2000.0, "{want}");
        let m = mag_arcsec2_from_cd_m2(want * CD_M2_PER_NL);
        assert!(m > 18.0 && m < 19.0, "{m}");
    }

    #[test]
    fn magnitudes_and_dilution() {
        // Falchi et al. 2016's natural sky, 22.0 mag/arcsec²: 171 µcd/m².
        assert!((cd_m2_from_mag_arcsec2(22.0) - 171e-6).abs() < 1e-6);
        assert!((mag_arcsec2_from_cd_m2(cd_m2_from_mag_arcsec2(19.5)) - 19.5).abs() < 1e-12);
        // Five magnitudes: a hundredfold.
        assert!((cd_m2_from_mag_arcsec2(16.0) / cd_m2_from_mag_arcsec2(21.0) - 100.0).abs() < 1e-9);
        assert_eq!(diluted_dolp(0.3, 1.0, 0.0), 0.3);
        assert!((diluted_dolp(0.3, 1.0, 1.0) - 0.15).abs() < 1e-15);
    }

    #[cfg(feature = "spa")]
    #[test]
    fn the_full_moon_lights_the_sky_a_million_times_less_than_the_sun() {
        // Qingdao, 2026-06-29 16:00 UTC: the moon 100 % lit at 25.5° (tests/cli.rs).
        let src = crate::sky::source_from_time_place("2026-06-29T16:00:00Z", 36.07, 120.38).unwrap();
        let moon = sky_light(&src).unwrap();
        assert_eq!(moon.light, Light::Moon);
        // Full moon outside the atmosphere: ≈ 0.3 lx at the mean distance (K&S: −12.73
        // mag); 0.246 lx here, a few degrees from full and near apogee.
        assert!(moon.outside_lux > 0.2 && moon.outside_lux < 0.4, "{}", moon.outside_lux);
        let sun = SkyLight::sun(moon.elevation_deg).unwrap();
        let ratio = sun.zenith_cd_m2 / moon.zenith_cd_m2;
        assert!(ratio > 3e5 && ratio < 6e5, "{ratio}");
        // Brighter than a dark site's own glow (21.8 mag/arcsec²), as bright as a city's.
        let m = mag_arcsec2_from_cd_m2(moon.zenith_cd_m2);
        assert!(m > 17.5 && m < 19.5, "{m}");
        assert!(moon.describe().contains("the moon"), "{}", moon.describe());
    }
}
