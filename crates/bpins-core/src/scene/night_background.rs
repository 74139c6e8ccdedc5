//! # `night_background` — the night sky's own unpolarized glow: airglow, starlight, a city
//!
//! ```text
//! L_bg(Z, A) = L_z · [(1 − a) + a·V(Z)] · C(e, A)           cd/m², Z the view's zenith angle
//! L_z     = 10.8e4 · 10^(−0.4·m)                            m in V mag/arcsec² (Garstang 1986)
//! V(Z)    = [1 − (R/(R + H))²·sin²Z]^(−½)                   van Rhijn, R = 6371 km, H = 90 km
//! C(e, A) = 1 + g·exp(−e/h)·exp(−ΔA²/(2w²))                 a city's dome: e = 90° − Z the
//!                                                           elevation, ΔA from the city's azimuth
//! S       ← S + strength · (L_bg(Z)/unit, 0, 0, 0)          unit: cd/m² per unit sky radiance
//! d_eff   = d · L/(L + L_bg)                                the sky's DoLP, diluted
//! ```
//!
//! An unpolarized glow added to the sky's Stokes vector: it lowers the DoLP and leaves
//! the AoP alone. Against the sunlit sky it is nothing (10⁻⁷ of it); against the
//! moonlit sky (≈ 18.5 mag/arcsec² at the zenith under a full moon at 40°, a million
//! times fainter) it is what sets the DoLP a camera sees: Kyba et al. 2011 measured
//! lunar skylight 29 % polarized at a dark site and 11 % in a city. `unit` comes from
//! the frame's source (`sky::radiometry`: the sun's or the moon's sky, set by the
//! capture pipeline per frame), so the same magnitude dims a moonlit sky's DoLP and
//! leaves a sunlit one's.
//!
//! | preset   | m (mag/arcsec²) | source                                                          |
//! |----------|-----------------|-----------------------------------------------------------------|
//! | dark     | 21.8            | natural sky 21.6–22.0 (Falchi et al. 2016, Sci. Adv. 2, e1600377) |
//! | rural    | 21.0            | Falchi et al. 2016's artificial brightness ≈ natural            |
//! | suburban | 19.5            | ≈ 4 × natural (Falchi et al. 2016's classes)                    |
//! | city     | 18.0            | Kyba et al. 2011 (Berlin: 16.5–18.5 at the zenith on clear nights) |
//!
//! Source: Garstang 1986 / Cinzano, Falchi & Elvidge 2001 for the magnitude's
//! luminance; van Rhijn 1921 for airglow's brightening toward the horizon (a thin
//! layer at 90 km); Kyba et al. 2011 (PLoS ONE 6, e17307) and Gál et al. 2001 for the
//! moonlit sky's DoLP under a glow. Units: m in mag/arcsec², a (`airglow_share`) and
//! strength dimensionless. Frame: world ENU for Z; the added Stokes vector is
//! unpolarized, so any frame.
//!
//! | param            | unit        | default | range      |
//! |------------------|-------------|---------|------------|
//! | `strength`       | 1           | 1       | [0, 1]     |
//! | `mag_arcsec2`    | mag/arcsec² | 21.8    | [14, 23]   |
//! | `airglow_share`  | 1           | 0.5     | [0, 1]     |
//! | `city_gain`      | 1           | 0       | [0, 100]   |
//! | `city_azimuth_deg` | deg       | 0       | [0, 360]   |
//! | `city_height_deg`  | deg       | 10      | [1, 45]    |
//! | `city_width_deg`   | deg       | 30      | [5, 180]   |
//!
//! A city beyond the horizon lights a dome over it: the glow grows toward the horizon
//! in the city's azimuth, many times its zenith value (all-sky photometry of light
//! domes: Duriscoe, Luginbuhl & Moore 2007, PASP 119, 192; Kocifaj 2007's model of a
//! distant source's sky glow). `C` is a phenomenological form of that dome, not a
//! radiative-transfer model: `city_gain` is the horizon's glow in the city's direction
//! over the zenith's (g = 0: no dome), falling with elevation over `city_height_deg` and
//! with azimuth over `city_width_deg` (1σ); at the zenith C = 1 + g·e^(−90°/h), so the
//! zenith magnitude stays what is given to within that term. No published fit of g, h
//! and w is taken; choose them from an all-sky image of the site.
//!
//! Cannot: a dome's shape from a city's distance and size (choose g, h, w); more than
//! one city; the Milky Way, zodiacal light,
//! stars as points; clouds lit by a city (clouds here hide the glow behind them like
//! the sky); the glow's own slight polarization; twilight's sky. Below the horizon it is
//! held at its horizon value (the ground is `skyline`'s).

use super::{ElementDef, FieldElement, FieldRay, Layer, ParamSpec};
use crate::sky::radiometry::cd_m2_from_mag_arcsec2;
use crate::stokes::Stokes;
use std::sync::Arc;

/// The Earth's mean radius and the airglow layer's height, km (van Rhijn's factor).
const EARTH_RADIUS_KM: f64 = 6371.0;
const AIRGLOW_HEIGHT_KM: f64 = 90.0;

pub const ELEMENT: ElementDef = ElementDef {
    name: "night_background",
    summary: "the night sky's own unpolarized glow (airglow, starlight, light pollution) in mag/arcsec²",
    source: "Garstang 1986 (mag/arcsec² to cd/m²); van Rhijn 1921; Falchi et al. 2016; Kyba et al. 2011",
    params: &[
        ParamSpec::shape("strength", "1", 1.0, 0.0, 1.0, "0: no glow, 1: the glow as given").vanishing_at(0.0),
        ParamSpec::shape(
            "mag_arcsec2",
            "mag/arcsec²",
            21.8,
            14.0,
            23.0,
            "the sky's brightness at the zenith, V mag/arcsec² (dark 21.8, rural 21, suburban 19.5, city 18)",
        ),
        ParamSpec::shape("airglow_share", "1", 0.5, 0.0, 1.0, "share of the zenith glow that is airglow (van Rhijn)"),
        ParamSpec::shape(
            "city_gain",
            "1",
            0.0,
            0.0,
            100.0,
            "a city's dome: the horizon's glow toward it over the zenith's",
        ),
        ParamSpec::shape("city_azimuth_deg", "deg", 0.0, 0.0, 360.0, "the city's azimuth, from North toward East"),
        ParamSpec::shape("city_height_deg", "deg", 10.0, 1.0, 45.0, "the dome's e-folding height in elevation"),
        ParamSpec::shape("city_width_deg", "deg", 30.0, 5.0, 180.0, "the dome's 1σ half-width in azimuth"),
    ],
    layer: Layer::Sky,
    prepare: |v, cx| Arc::new(NightBackground::new(v, cx.sky_unit_cd_m2)),
};

/// The glow of one frame, in the chain's sky units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NightBackground {
    pub strength: f64,
    /// The glow at the zenith, units of the chain's sky radiance.
    pub zenith_glow: f64,
    pub airglow_share: f64,
    /// The city's dome: gain, azimuth (rad), e-folding height (rad), 1σ width (rad).
    pub city_gain: f64,
    pub city_azimuth_rad: f64,
    pub city_height_rad: f64,
    pub city_width_rad: f64,
}

impl NightBackground {
    /// From the values in [`ELEMENT`]'s order, under a sky of `unit_cd_m2` cd/m² per
    /// unit radiance (no glow where the unit is not a positive number).
    pub fn new(v: &[f64], unit_cd_m2: f64) -> Self {
        let zenith_glow =
            if unit_cd_m2 > 0.0 && unit_cd_m2.is_finite() { cd_m2_from_mag_arcsec2(v[1]) / unit_cd_m2 } else { 0.0 };
        NightBackground {
            strength: v[0],
            zenith_glow,
            airglow_share: v[2],
            city_gain: v[3],
            city_azimuth_rad: v[4].to_radians(),
            city_height_rad: v[5].to_radians(),
            city_width_rad: v[6].to_radians(),
        }
    }

    /// The glow along a ray whose zenith angle has cosine `cos_z`, sky units (no dome).
    #[inline]
    pub fn glow(&self, cos_z: f64) -> f64 {
        let c = cos_z.clamp(0.0, 1.0);
        let k = EARTH_RADIUS_KM / (EARTH_RADIUS_KM + AIRGLOW_HEIGHT_KM);
        let van_rhijn = 1.0 / (1.0 - k * k * (1.0 - c * c)).sqrt();
        self.strength * self.zenith_glow * ((1.0 - self.airglow_share) + self.airglow_share * van_rhijn)
    }

    /// The city's dome C along the unit ENU ray `d` (1 where `city_gain` is 0); below
    /// the horizon held at its horizon value.
    #[inline]
    pub fn dome(&self, d: glam::DVec3) -> f64 {
        if self.city_gain == 0.0 {
            return 1.0;
        }
        // Elevation e ≥ 0 and the azimuth from North toward East (CONVENTIONS.md, ENU).
        let e = d.z.clamp(-1.0, 1.0).asin().max(0.0);
        let da = (d.x.atan2(d.y) - self.city_azimuth_rad + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        let w = self.city_width_rad;
        1.0 + self.city_gain * (-e / self.city_height_rad).exp() * (-da * da / (2.0 * w * w)).exp()
    }
}

impl FieldElement for NightBackground {
    /// The sky's Stokes vector `s` with the glow added (unpolarized: any frame).
    #[inline]
    fn apply(&self, ray: &FieldRay, s: Stokes) -> Stokes {
        if self.strength == 0.0 {
            return s;
        }
        Stokes::new(s.i + self.glow(ray.d_world.z) * self.dome(ray.d_world), s.q, s.u, s.v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::conventions::enu_from_az_el_deg;
    use crate::sky::radiometry::{diluted_dolp, SkyLight};
    use crate::sky::sky_stokes;
    use glam::DMat3;

    fn apply_at(b: &NightBackground, az: f64, el: f64, sky: Stokes) -> Stokes {
        let d = enu_from_az_el_deg(az, el);
        let basis = meridional_basis(d);
        b.apply(
            &FieldRay { d_cam: d, d_world: d, basis: &basis, cam_from_world: &DMat3::IDENTITY, white_over_sky: 1.0 },
            sky,
        )
    }

    #[test]
    fn zero_strength_is_the_identity_and_the_glow_moves_no_angle() {
        let sky = Stokes::new(0.6, 0.1, -0.2, 0.0);
        let off = NightBackground::new(&[0.0, 18.0, 0.5, 0.0, 0.0, 10.0, 30.0], 1e-3);
        assert_eq!(apply_at(&off, 10.0, 20.0, sky), sky);
        let on = NightBackground::new(&[1.0, 18.0, 0.5, 0.0, 0.0, 10.0, 30.0], 1e-3);
        let t = apply_at(&on, 10.0, 20.0, sky);
        assert!(t.i > sky.i && t.q == sky.q && t.u == sky.u);
        assert!((t.aop_rad() - sky.aop_rad()).abs() < 1e-15 && t.dolp() < sky.dolp());
        // No unit, no glow.
        assert_eq!(NightBackground::new(&[1.0, 18.0, 0.5, 0.0, 0.0, 10.0, 30.0], f64::NAN).zenith_glow, 0.0);
    }

    #[test]
    fn the_dolp_is_diluted_by_l_over_l_plus_l_bg_and_airglow_brightens_the_horizon() {
        let unit = 2e-3;
        let b = NightBackground::new(&[1.0, 19.5, 0.0, 0.0, 0.0, 10.0, 30.0], unit);
        let sky = Stokes::new(0.8, 0.3, 0.1, 0.0);
        let t = apply_at(&b, 0.0, 89.99, sky);
        let want = diluted_dolp(sky.dolp(), sky.i * unit, cd_m2_from_mag_arcsec2(19.5));
        assert!((t.dolp() - want).abs() < 1e-12, "{} vs {want}", t.dolp());
        // van Rhijn: ×1 at the zenith, ≈ ×5.6 at the horizon for a 90 km layer.
        let a = NightBackground::new(&[1.0, 19.5, 1.0, 0.0, 0.0, 10.0, 30.0], unit);
        assert!((a.glow(1.0) - a.zenith_glow).abs() < 1e-15);
        let h = a.glow(0.0) / a.zenith_glow;
        assert!(h > 5.0 && h < 6.5, "{h}");
        assert_eq!(a.glow(-0.5), a.glow(0.0), "held below the horizon");
    }

    #[test]
    fn a_full_moon_s_sky_loses_polarization_from_a_dark_site_to_a_city_as_kyba_measured() {
        // Full moon (0.31 lx outside, K&S) at 40°, the zenith: Rayleigh's DoLP there
        // with d_max 0.6 (γ = 50°) is 0.6·sin²γ/(1 + cos²γ) = 0.249.
        let moon = SkyLight::new(crate::sky::radiometry::Light::Moon, 0.313, 40.0).unwrap();
        let sun = crate::conventions::enu_from_az_el_deg(0.0, 40.0);
        let zenith = enu_from_az_el_deg(90.0, 89.99);
        let s = sky_stokes(sun, 0.6, zenith, &meridional_basis(zenith));
        let dolp_at = |m: f64| {
            apply_at(&NightBackground::new(&[1.0, m, 0.5, 0.0, 0.0, 10.0, 30.0], moon.unit_cd_m2), 90.0, 89.99, s)
                .dolp()
        };
        let (clean, dark, city) = (s.dolp(), dolp_at(21.8), dolp_at(18.0));
        assert!((clean - 0.249).abs() < 0.002, "{clean}");
        // A dark site keeps ≥ 90 % of it; a city keeps under half (Kyba: 29 % → 11 %, 0.38).
        assert!(dark / clean > 0.9 && dark / clean < 1.0, "{dark}");
        assert!(city / clean > 0.25 && city / clean < 0.5, "{city}");
    }

    #[test]
    fn a_city_dome_brightens_the_horizon_toward_the_city_and_leaves_the_zenith() {
        // A city due East (90°) whose horizon glows 20 × the zenith, over 10° and ±30°.
        let b = NightBackground::new(&[1.0, 19.5, 0.0, 20.0, 90.0, 10.0, 30.0], 2e-3);
        let plain = NightBackground::new(&[1.0, 19.5, 0.0, 0.0, 90.0, 10.0, 30.0], 2e-3);
        let sky = Stokes::new(0.8, 0.3, 0.1, 0.0);
        let glow = |b: &NightBackground, az: f64, el: f64| apply_at(b, az, el, sky).i - sky.i;
        // Toward the city at the horizon: 1 + 20 of the plain glow; at 10°, 1 + 20/e.
        assert!((glow(&b, 90.0, 0.0) / glow(&plain, 90.0, 0.0) - 21.0).abs() < 1e-9);
        let at10 = glow(&b, 90.0, 10.0) / glow(&plain, 90.0, 10.0);
        assert!((at10 - (1.0 + 20.0 / std::f64::consts::E)).abs() < 1e-9, "{at10}");
        // 30° off in azimuth (1σ): e^(−½) of the gain; opposite the city: nothing.
        let off = glow(&b, 120.0, 0.0) / glow(&plain, 120.0, 0.0);
        assert!((off - (1.0 + 20.0 * (-0.5f64).exp())).abs() < 1e-9, "{off}");
        assert!((glow(&b, 270.0, 0.0) / glow(&plain, 270.0, 0.0) - 1.0).abs() < 1e-6);
        // The zenith within e^(−9) of the magnitude given; the angle of polarization kept.
        assert!((glow(&b, 0.0, 90.0) / glow(&plain, 0.0, 90.0) - 1.0).abs() < 20.0 * (-9.0f64).exp() + 1e-12);
        assert!((apply_at(&b, 90.0, 5.0, sky).aop_rad() - sky.aop_rad()).abs() < 1e-15);
        // Symmetric about the city's azimuth, across North (a city at 350°).
        let n = NightBackground::new(&[1.0, 19.5, 0.0, 20.0, 350.0, 10.0, 30.0], 2e-3);
        assert!((glow(&n, 340.0, 3.0) - glow(&n, 0.0, 3.0)).abs() < 1e-12 * glow(&n, 0.0, 3.0));
    }
}
