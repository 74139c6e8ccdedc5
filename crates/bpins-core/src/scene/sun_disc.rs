//! # `sun_disc` — the sun's disc and its aureole (Buie sunshape)
//!
//! ```text
//! θ = 2·asin(|d − s|/2)                      angle from the sun's centre, mrad
//! φ(θ) = cos(0.326 θ)/cos(0.308 θ)           θ ≤ 4.65 mrad: the limb-darkened disc
//! φ(θ) = e^κ · θ^γ                           θ > 4.65 mrad: the aureole (∝ θ^−2 … θ^−2.6)
//! κ = 0.9 ln(13.5 χ) χ^−0.3,  γ = 2.2 ln(0.52 χ) χ^0.43 − 0.1     χ: circumsolar ratio
//! I ← I + disc_radiance · L_z · w · φ(θ)     unpolarized: Q, U, V unchanged; w = 1/r_band
//!                                           (white light in a colour band frame; 1 for mono)
//! ```
//!
//! L_z is the Rayleigh sky's zenith radiance of the frame, so `disc_radiance` is the
//! radiance at the disc's centre in units of the zenith sky (the real sun is some
//! 10⁵–10⁶ times the blue sky: the disc saturates any exposure set on the sky, and
//! the aureole's saturated region grows with χ). The disc's radius is 4.65 mrad
//! (0.266°). The circumsolar ratio χ is the aureole's share of the power within
//! 43.6 mrad; the law reproduces it to ~15 % for χ ≥ 0.05 (tested) and is too faint
//! below χ ≈ 0.02; χ = 0 gives no aureole.
//!
//! Source: D. Buie, A. G. Monger, C. J. Dey, "Sunshape distributions for terrestrial
//! solar simulations", Solar Energy 74, 113 (2003), eqs. 1–4. Units: θ in mrad inside
//! the law, `disc_radiance` and `csr` dimensionless. Frame: sun and view in world ENU;
//! the added radiance is unpolarized, so any Stokes frame.
//!
//! | param           | unit | default | range      |
//! |-----------------|------|---------|------------|
//! | `disc_radiance` | 1    | 1e5     | [0, 1e8]   |
//! | `csr`           | 1    | 0.05    | [0, 0.4]   |
//!
//! Cannot: lens flare and ghosts (a real lens spreads the sun over the image), the
//! sun dimmed by a cloud in front of it (it is added after the clouds), the
//! aureole's weak polarization, refraction's flattening of a low sun, and the disc
//! sampled finer than one ray per pixel (a pixel sees the sun only where its ray
//! falls inside 0.266°).

use super::{ElementDef, FieldElement, FieldRay, Layer, ParamSpec};
use crate::stokes::Stokes;
use glam::DVec3;
use std::sync::Arc;

/// Angular radius of the sun's disc in the law, mrad.
pub const DISC_RADIUS_MRAD: f64 = 4.65;

pub const ELEMENT: ElementDef = ElementDef {
    name: "sun_disc",
    summary: "the sun's limb-darkened disc (0.266°) far above the sky, and its unpolarized aureole",
    source: "Buie, Monger & Dey, Solar Energy 74, 113 (2003)",
    params: &[
        ParamSpec::shape(
            "disc_radiance",
            "1",
            1e5,
            0.0,
            1e8,
            "radiance at the disc's centre over the sky's zenith radiance",
        )
        .vanishing_at(0.0),
        ParamSpec::shape(
            "csr",
            "1",
            0.05,
            0.0,
            0.4,
            "circumsolar ratio: the aureole's share (strength; the saturated region grows with it)",
        )
        .vanishing_at(0.0),
    ],
    layer: Layer::Sun,
    prepare: |v, cx| Arc::new(SunDisc::new(v, cx.sun_world, cx.zenith_radiance)),
};

/// The sun of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunDisc {
    /// Unit sun, ENU.
    pub sun_world: DVec3,
    /// disc_radiance · L_z: the radiance added at the disc's centre.
    pub scale: f64,
    /// e^κ and γ of the aureole law (0 and 0 without an aureole).
    pub aureole_amp: f64,
    pub aureole_exp: f64,
}

impl SunDisc {
    /// From the values in [`ELEMENT`]'s parameter order, for the unit sun `sun_world`
    /// and the frame's zenith radiance `zenith_radiance`.
    pub fn new(v: &[f64], sun_world: DVec3, zenith_radiance: f64) -> Self {
        let (disc, chi) = (v[0], v[1]);
        let (aureole_amp, aureole_exp) = if chi > 0.0 {
            let kappa = 0.9 * (13.5 * chi).ln() * chi.powf(-0.3);
            let gamma = 2.2 * (0.52 * chi).ln() * chi.powf(0.43) - 0.1;
            (kappa.exp(), gamma)
        } else {
            (0.0, 0.0)
        };
        SunDisc { sun_world, scale: disc * zenith_radiance, aureole_amp, aureole_exp }
    }

    /// Buie's φ(θ) at `theta_mrad` from the sun's centre (1 at the centre).
    #[inline]
    pub fn sunshape(&self, theta_mrad: f64) -> f64 {
        if theta_mrad <= DISC_RADIUS_MRAD {
            (0.326 * theta_mrad).cos() / (0.308 * theta_mrad).cos()
        } else if self.aureole_amp > 0.0 {
            self.aureole_amp * theta_mrad.powf(self.aureole_exp)
        } else {
            0.0
        }
    }

    /// Angle between the unit ENU ray `d` and the sun, mrad (accurate near the sun).
    #[inline]
    pub fn angle_mrad(&self, d: DVec3) -> f64 {
        2000.0 * (0.5 * (d - self.sun_world).length()).min(1.0).asin()
    }
}

impl FieldElement for SunDisc {
    /// The Stokes vector `s` with the sun's radiance along `ray` added (unpolarized).
    #[inline]
    fn apply(&self, ray: &FieldRay, s: Stokes) -> Stokes {
        if self.scale == 0.0 {
            return s;
        }
        // The sun's light is white: over the band's sky by w = white_over_sky (1 for mono).
        let add = self.scale * ray.white_over_sky * self.sunshape(self.angle_mrad(ray.d_world));
        Stokes::new(s.i + add, s.q, s.u, s.v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::conventions::enu_from_az_el_deg;
    use glam::DMat3;

    fn sun(disc: f64, csr: f64) -> SunDisc {
        SunDisc::new(&[disc, csr], enu_from_az_el_deg(120.0, 38.0), 0.5)
    }

    fn add_at(s: &SunDisc, d: DVec3) -> Stokes {
        let b = meridional_basis(d);
        let sky = Stokes::new(0.7, 0.2, -0.1, 0.0);
        s.apply(
            &FieldRay { d_cam: d, d_world: d, basis: &b, cam_from_world: &DMat3::IDENTITY, white_over_sky: 1.0 },
            sky,
        )
    }

    /// The direction `deg` from the sun toward the zenith.
    fn off_sun(s: &SunDisc, deg: f64) -> DVec3 {
        let side = s.sun_world.cross(DVec3::Z).cross(s.sun_world).normalize();
        let a = deg.to_radians();
        s.sun_world * a.cos() + side * a.sin()
    }

    #[test]
    fn zero_strength_is_the_identity_and_the_sun_adds_unpolarized_light() {
        let off = sun(0.0, 0.05);
        let d = off_sun(&off, 0.0);
        assert_eq!(add_at(&off, d), Stokes::new(0.7, 0.2, -0.1, 0.0));
        let on = sun(1e5, 0.05);
        let s = add_at(&on, d);
        assert!((s.i - (0.7 + 1e5 * 0.5)).abs() < 1e-6, "centre radiance {}", s.i);
        assert_eq!((s.q, s.u, s.v), (0.2, -0.1, 0.0));
    }

    #[test]
    fn the_disc_is_limb_darkened_and_ends_at_its_radius() {
        let s = sun(1e5, 0.0);
        assert!((s.angle_mrad(off_sun(&s, 0.2)) - 0.2f64.to_radians() * 1000.0).abs() < 1e-9);
        let limb = s.sunshape(4.6);
        assert!(limb > 0.3 && limb < 0.6, "limb {limb}");
        assert_eq!(s.sunshape(4.7), 0.0, "no aureole at χ = 0");
        assert_eq!(add_at(&s, off_sun(&s, 0.3)).i, 0.7);
    }

    #[test]
    fn the_aureole_falls_as_its_power_law_and_holds_the_circumsolar_ratio() {
        for chi in [0.05, 0.1, 0.2, 0.3] {
            let s = sun(1.0, chi);
            // Slope of log φ between 2° and 4°: γ.
            let (a, b) = (s.sunshape(2f64.to_radians() * 1e3), s.sunshape(4f64.to_radians() * 1e3));
            assert!(((b / a).ln() / 2f64.ln() - s.aureole_exp).abs() < 1e-9);
            assert!((-2.7..=-2.2).contains(&s.aureole_exp), "γ {}", s.aureole_exp);
            // ∫φ θ dθ over the aureole (to 43.6 mrad) over the whole: χ.
            let integral = |lo: f64, hi: f64| {
                let n = 20_000;
                let h = (hi - lo) / n as f64;
                (0..n).map(|i| lo + (i as f64 + 0.5) * h).map(|t| s.sunshape(t) * t * h).sum::<f64>()
            };
            let (disc, aureole) = (integral(0.0, DISC_RADIUS_MRAD), integral(DISC_RADIUS_MRAD + 1e-9, 43.6));
            let got = aureole / (disc + aureole);
            assert!((got / chi - 1.0).abs() < 0.15, "χ {chi}: the law gives {got}");
        }
    }

    #[test]
    fn the_saturated_region_grows_with_the_circumsolar_ratio() {
        // Radius where the added radiance exceeds 2× the zenith sky.
        let radius = |chi: f64| {
            let s = sun(1e5, chi);
            (1..2000).map(|i| i as f64 * 0.01).find(|&deg| add_at(&s, off_sun(&s, deg)).i - 0.7 < 1.0).unwrap()
        };
        let (faint, strong) = (radius(0.02), radius(0.2));
        assert!(faint >= 0.26 && strong > 2.0 * faint, "{faint}° vs {strong}°");
    }
}
