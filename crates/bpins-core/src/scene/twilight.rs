//! # `twilight` — the other source's sky: the sun below the horizon under a moon, or the moon in twilight
//!
//! ```text
//! S ← S + strength · w · S_R(s_o, d_max, v)          Stokes sum (the two skies are incoherent)
//! S_R(s, d_max, v) = Rayleigh about s (sky/rayleigh.rs): ½(1 + cos²γ), E ⊥ (s, v)
//! w = u_o / u_p                                        u = L_zenith / ½(1 + sin²h): cd/m² per unit radiance
//! ```
//!
//! The chain's sky is Rayleigh's about the frame's source p (the brighter of the sun and
//! the moon at the frame's time and place: `sky::source_from_time_place`); this element
//! adds the other source o's sky, its own Rayleigh pattern about its own direction
//! s_o (the sun below the horizon keeps its pattern through twilight: Cronin, Warrant &
//! Greiner 2006), scaled by the ratio w of the two skies' luminances: each source's
//! zenith luminance L_zenith (`sky/twilight.rs`: K&S above the horizon, Patat et al.
//! 2006's twilight below it) over Rayleigh's zenith radiance about it. Two skies add as
//! Stokes vectors: the radiances add, the polarized parts add with their own angles, so
//! where the patterns cross the DoLP drops and the AoP turns toward the brighter.
//!
//! Source: Patat, Ugolnikov & Postylyakov 2006 (twilight zenith, V), Krisciunas &
//! Schaefer 1991 (the moonlit sky), Cronin et al. 2006 (Appl. Opt. 45, 5582: the
//! twilight sky's E-vector pattern about the sun below the horizon). Units: strength
//! and w dimensionless; the chain's sky units (1 toward the frame's source). Frame: s_o
//! in world ENU, turned into the camera frame per ray; the Stokes vector in the ray's
//! meridional frame, as `sky_stokes` returns it.
//!
//! | param      | unit | default | range  |
//! |------------|------|---------|--------|
//! | `strength` | 1    | 1       | [0, 1] |
//!
//! Cannot: a frame without a time and place (nothing to add: the element is the
//! identity); the sky depolarization and neutral-point effects on the other source's
//! sky (the frame's d_max, nothing else); twilight's own sky shape (the Earth's shadow,
//! its colour); the GPU backend (a field scene is CPU only).

use super::{ElementDef, FieldElement, FieldRay, Layer, ParamSpec};
use crate::sky::sky_stokes;
use crate::stokes::Stokes;
use glam::DVec3;
use std::sync::Arc;

pub const ELEMENT: ElementDef = ElementDef {
    name: "twilight",
    summary: "the other source's sky from the frame's time and place: the sun below the horizon, or the moon",
    source: "Patat et al. 2006 (twilight zenith); Krisciunas & Schaefer 1991; Cronin et al. 2006",
    params: &[ParamSpec::shape("strength", "1", 1.0, 0.0, 1.0, "0: the frame's source alone, 1: both skies")
        .vanishing_at(0.0)],
    layer: Layer::Sky,
    prepare: |v, cx| Arc::new(Twilight { strength: v[0], other: cx.other_sky }),
};

/// The other source's sky for one frame, set by the capture pipeline from the frame's
/// time and place ([`under`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OtherSky {
    /// Unit direction of the other source, world ENU (below the horizon for the sun).
    pub direction_enu: DVec3,
    /// Its sky's cd/m² per unit radiance over the frame's source's, w.
    pub weight: f64,
    /// The frame's sky d_max.
    pub dmax: f64,
}

/// The element folded for one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Twilight {
    pub strength: f64,
    pub other: Option<OtherSky>,
}

impl FieldElement for Twilight {
    #[inline]
    fn apply(&self, ray: &FieldRay, s: Stokes) -> Stokes {
        let Some(o) = self.other.filter(|_| self.strength != 0.0) else { return s };
        let src_cam = *ray.cam_from_world * o.direction_enu;
        let t = sky_stokes(src_cam, o.dmax, ray.d_cam, ray.basis);
        let k = self.strength * o.weight;
        Stokes::new(s.i + k * t.i, s.q + k * t.q, s.u + k * t.u, s.v)
    }
}

/// `field` with the other source of `sun`'s time and place set (its direction and its
/// sky's weight against the frame's source's, [`OtherSky`]), where the `twilight`
/// element is enabled and the other source lights the sky; unchanged otherwise.
#[cfg(feature = "spa")]
pub(crate) fn under(field: super::FieldScene, sun: &crate::sky::sun::SunPosition, dmax: f64) -> super::FieldScene {
    if !field.iter().any(|(d, _)| d.name == ELEMENT.name) {
        return field;
    }
    match other_sky_of(sun, dmax) {
        Some(o) => field.with_other_sky(o),
        None => field,
    }
}

/// The other source's sky of `sun`'s time and place ([`OtherSky`]: its direction, its
/// sky's weight w = u_o/u_p against the frame's source's, d_max `dmax`); `None` for
/// given or unplaced angles, where the ephemeris fails, or where the other source adds
/// no light (w not positive and finite). What `simulate` renders (the element, [`under`])
/// and what `fit` models a mixed twilight's frame with (`fit::input::sky`).
#[cfg(feature = "spa")]
pub(crate) fn other_sky_of(sun: &crate::sky::sun::SunPosition, dmax: f64) -> Option<OtherSky> {
    use crate::sky::sun::SunSource;
    let (SunSource::Spa { time_utc, latitude_deg, longitude_deg }
    | SunSource::Moon { time_utc, latitude_deg, longitude_deg, .. }) = &sun.source
    else {
        return None;
    };
    let (Ok(s), Ok(m)) = (
        crate::sky::sun::sun_from_time_place(time_utc, *latitude_deg, *longitude_deg),
        crate::sky::moon::moon_from_time_place(time_utc, *latitude_deg, *longitude_deg),
    ) else {
        return None;
    };
    let shares = crate::sky::twilight::shares_of(s.elevation_deg, &m);
    let unit = |zenith_cd_m2: f64, el_deg: f64| zenith_cd_m2 / (0.5 * (1.0 + el_deg.to_radians().sin().powi(2)));
    let (u_sun, u_moon) = (unit(shares.sun_cd_m2, s.elevation_deg), unit(shares.moon_cd_m2, m.elevation_deg));
    let (direction_enu, u_o, u_p) = match sun.source {
        SunSource::Moon { .. } => (s.direction_enu(), u_sun, u_moon),
        _ => (m.direction_enu(), u_moon, u_sun),
    };
    let weight = u_o / u_p;
    (weight > 0.0 && weight.is_finite()).then_some(OtherSky { direction_enu, weight, dmax })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::conventions::enu_from_az_el_deg;
    #[cfg(feature = "spa")]
    use crate::scene::FieldScene;
    use glam::DMat3;

    fn apply_at(t: &Twilight, az: f64, el: f64, sky: Stokes) -> Stokes {
        let d = enu_from_az_el_deg(az, el);
        let basis = meridional_basis(d);
        t.apply(
            &FieldRay { d_cam: d, d_world: d, basis: &basis, cam_from_world: &DMat3::IDENTITY, white_over_sky: 1.0 },
            sky,
        )
    }

    #[test]
    fn zero_strength_or_no_other_source_is_the_identity_and_the_sum_is_the_stokes_sum() {
        let moon = enu_from_az_el_deg(200.0, 35.0);
        let sun = enu_from_az_el_deg(290.0, -8.0);
        let other = OtherSky { direction_enu: sun, weight: 0.7, dmax: 0.6 };
        let (az, el) = (120.0, 60.0);
        let d = enu_from_az_el_deg(az, el);
        let b = meridional_basis(d);
        let primary = sky_stokes(moon, 0.6, d, &b);
        assert_eq!(apply_at(&Twilight { strength: 0.0, other: Some(other) }, az, el, primary), primary);
        assert_eq!(apply_at(&Twilight { strength: 1.0, other: None }, az, el, primary), primary);
        // Both: each sky with its own weight, summed component by component.
        let t = apply_at(&Twilight { strength: 0.5, other: Some(other) }, az, el, primary);
        let o = sky_stokes(sun, 0.6, d, &b);
        for (got, want) in [(t.i, primary.i + 0.35 * o.i), (t.q, primary.q + 0.35 * o.q), (t.u, primary.u + 0.35 * o.u)]
        {
            assert!((got - want).abs() < 1e-15, "{got} vs {want}");
        }
        // Where the two patterns cross, the sum is less polarized than either alone would be
        // at the same total radiance: the E-vectors are not parallel.
        let pol = |s: Stokes| (s.q * s.q + s.u * s.u).sqrt();
        assert!(pol(t) < pol(primary) + 0.35 * pol(o) - 1e-6);
    }

    #[cfg(feature = "spa")]
    #[test]
    fn the_other_source_is_the_moon_under_a_twilight_sun_and_the_sun_under_a_moon_weighted_by_luminance() {
        // Qingdao: 2026-06-21T11:40Z the sun at −4.5°, a 46 % moon at 43.6° (the sun's
        // sky, the moon's added); 2026-06-24T12:40Z the sun at −13.9°, a 75 % moon at
        // 34.9° (the moon's sky, the sun's twilight added).
        let (lat, lon) = (36.07, 120.38);
        let mut scene = FieldScene::new(1);
        scene.enable("twilight").unwrap();
        let u = |z: f64, h: f64| z / (0.5 * (1.0 + h.to_radians().sin().powi(2)));
        for (t, moon_is_source) in [("2026-06-21T11:40:00Z", false), ("2026-06-24T12:40:00Z", true)] {
            let src = crate::sky::source_from_time_place(t, lat, lon).unwrap();
            assert_eq!(matches!(src.source, crate::sky::sun::SunSource::Moon { .. }), moon_is_source, "{t}");
            let sh = crate::sky::twilight::shares_at(t, lat, lon).unwrap();
            let o = under(scene.clone(), &src, 0.6).other_sky().expect("both light the sky");
            let s = crate::sky::sun::sun_from_time_place(t, lat, lon).unwrap();
            let m = crate::sky::moon::moon_from_time_place(t, lat, lon).unwrap();
            let (u_sun, u_moon) = (u(sh.sun_cd_m2, sh.sun_elevation_deg), u(sh.moon_cd_m2, sh.moon_elevation_deg));
            let (dir, want) =
                if moon_is_source { (s.direction_enu(), u_sun / u_moon) } else { (m.direction_enu(), u_moon / u_sun) };
            assert!((o.direction_enu - dir).length() < 1e-12, "{t}");
            assert!((o.weight / want - 1.0).abs() < 1e-12, "{t}: {} vs {want}", o.weight);
            assert!(o.weight > 0.0 && o.weight < 1.0 && o.dmax == 0.6, "{t}: {o:?}");
        }
        // Not enabled, or no time and place: nothing set.
        let src = crate::sky::source_from_time_place("2026-06-21T11:40:00Z", lat, lon).unwrap();
        assert_eq!(under(FieldScene::new(1), &src, 0.6).other_sky(), None);
        let given = crate::sky::sun::SunPosition::given(300.0, -4.5);
        assert_eq!(under(scene, &given, 0.6).other_sky(), None);
    }
}
