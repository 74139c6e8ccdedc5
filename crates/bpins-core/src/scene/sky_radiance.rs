//! # `sky_radiance` — the sky brighter toward the sun and the horizon (CIE general sky)
//!
//! ```text
//! L(Z, γ)/L_z = φ(Z)·f(γ) / (φ(0)·f(Z_s))                      relative luminance
//! φ(Z) = 1 + a·exp(b / cos Z)                                  gradation
//! f(γ) = 1 + c·(exp(d·γ) − exp(d·π/2)) + e·cos²γ                scattering indicatrix
//! k    = 1 + strength·( L/L_z · R(Z_s)/R(γ) − 1 ),  R(γ) = ½(1 + cos²γ)
//! S    ← max(k, 0)·S                                            I, Q, U, V alike
//! ```
//!
//! Z the zenith angle of the view, γ its angle from the sun, Z_s the sun's zenith
//! angle. At strength 1 the sky's radiance *is* the CIE distribution (the Rayleigh
//! radiance R it replaces is divided out), scaled to keep the Rayleigh zenith
//! radiance; DoLP and AoP are untouched (k is a scalar). The defaults are CIE type 12,
//! "CIE standard clear sky, low illuminance turbidity" (gradation V: a = −1,
//! b = −0.32; indicatrix 4: c = 10, d = −3, e = 0.45); type 13 (polluted) is
//! c = 16, d = −3, e = 0.3; type 11 has b = −0.55.
//!
//! Source: CIE S 011/E:2003 (ISO 15469:2004), "Spatial distribution of daylight — CIE
//! standard general sky", eqs. 1–3 and table 1; R. Kittler, S. Darula, "CIE general
//! sky standard defining luminance distributions", Proc. eSim 2002. Frame: world ENU
//! for Z and γ; the Stokes vector in the ray's meridional frame. Units: a, b, c, e
//! dimensionless, d per radian of γ (`d_per_rad`), strength in [0, 1].
//!
//! | param       | unit  | default | range        |
//! |-------------|-------|---------|--------------|
//! | `strength`  | 1     | 1       | [0, 1]       |
//! | `a`         | 1     | −1      | [−5, 5]      |
//! | `b`         | 1     | −0.32   | [−3, −0.05]  |
//! | `c`         | 1     | 10      | [0, 30]      |
//! | `d_per_rad` | 1/rad | −3      | [−5, 0]      |
//! | `e`         | 1     | 0.45    | [0, 2]       |
//!
//! Cannot: below the horizon the gradation is held at its horizon value (cos Z ≥
//! 10⁻³; the ground is `skyline`'s); a sun below the horizon is evaluated with the
//! same formula (CIE defines it for a sun above the horizon only); spectral
//! dependence; a sky whose radiance is not symmetric about the solar vertical.
//! f and k are clamped at ≥ 0 where extreme (c, d) pairs would make them negative.

use super::{ElementDef, FieldElement, FieldRay, Layer, ParamSpec};
use crate::stokes::Stokes;
use glam::DVec3;
use std::sync::Arc;

pub const ELEMENT: ElementDef = ElementDef {
    name: "sky_radiance",
    summary: "CIE standard general sky radiance: brighter toward the sun and the horizon (type 12 clear sky)",
    source: "CIE S 011/E:2003 eqs. 1-3; Kittler & Darula 2002",
    params: &[
        ParamSpec::shape("strength", "1", 1.0, 0.0, 1.0, "0: the Rayleigh radiance, 1: the CIE distribution")
            .vanishing_at(0.0),
        ParamSpec::shape("a", "1", -1.0, -5.0, 5.0, "gradation a"),
        ParamSpec::shape("b", "1", -0.32, -3.0, -0.05, "gradation b"),
        ParamSpec::shape("c", "1", 10.0, 0.0, 30.0, "indicatrix c (circumsolar strength)"),
        ParamSpec::shape("d_per_rad", "1", -3.0, -5.0, 0.0, "indicatrix d, per radian of the angle from the sun"),
        ParamSpec::shape("e", "1", 0.45, 0.0, 2.0, "indicatrix e (forward/back scattering)"),
    ],
    layer: Layer::Sky,
    prepare: |v, cx| Arc::new(SkyRadiance::new(v, cx.sun_world)),
};

/// The CIE sky of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyRadiance {
    pub strength: f64,
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub d_per_rad: f64,
    pub e: f64,
    /// Unit sun, ENU.
    pub sun_world: DVec3,
    /// R(Z_s) / (φ(0)·f(Z_s)): the normalisation that keeps the zenith radiance.
    pub norm: f64,
}

impl SkyRadiance {
    /// From the values in [`ELEMENT`]'s parameter order, for the unit sun `sun_world`.
    pub fn new(v: &[f64], sun_world: DVec3) -> Self {
        let mut s =
            SkyRadiance { strength: v[0], a: v[1], b: v[2], c: v[3], d_per_rad: v[4], e: v[5], sun_world, norm: 1.0 };
        let cos_zs = sun_world.z.clamp(-1.0, 1.0);
        let denom = (s.gradation(1.0) * s.indicatrix(cos_zs)).max(1e-12);
        s.norm = 0.5 * (1.0 + cos_zs * cos_zs) / denom;
        s
    }

    /// φ(Z) at cos Z = `cos_z` (held at its horizon value below it).
    #[inline]
    pub fn gradation(&self, cos_z: f64) -> f64 {
        1.0 + self.a * (self.b / cos_z.max(1e-3)).exp()
    }

    /// f(γ) at cos γ = `cos_g`, at least 0.
    #[inline]
    pub fn indicatrix(&self, cos_g: f64) -> f64 {
        let g = cos_g.clamp(-1.0, 1.0).acos();
        let d = self.d_per_rad;
        (1.0 + self.c * ((d * g).exp() - (d * std::f64::consts::FRAC_PI_2).exp()) + self.e * cos_g * cos_g).max(0.0)
    }

    /// The factor k on the sky's Stokes vector along the unit ENU ray `d_world`.
    #[inline]
    pub fn factor(&self, d_world: DVec3) -> f64 {
        let cos_g = self.sun_world.dot(d_world);
        let cie = self.gradation(d_world.z) * self.indicatrix(cos_g) * self.norm;
        let rayleigh = 0.5 * (1.0 + cos_g * cos_g);
        (1.0 + self.strength * (cie / rayleigh - 1.0)).max(0.0)
    }
}

impl FieldElement for SkyRadiance {
    /// The sky's Stokes vector `s` (any frame) with the CIE radiance distribution.
    #[inline]
    fn apply(&self, ray: &FieldRay, s: Stokes) -> Stokes {
        if self.strength == 0.0 {
            return s;
        }
        let k = self.factor(ray.d_world);
        Stokes::new(k * s.i, k * s.q, k * s.u, k * s.v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::conventions::enu_from_az_el_deg;
    use glam::DMat3;

    fn type12(strength: f64, sun_el_deg: f64) -> SkyRadiance {
        SkyRadiance::new(&[strength, -1.0, -0.32, 10.0, -3.0, 0.45], enu_from_az_el_deg(120.0, sun_el_deg))
    }

    fn apply_at(s: &SkyRadiance, az: f64, el: f64, sky: Stokes) -> Stokes {
        let d = enu_from_az_el_deg(az, el);
        let b = meridional_basis(d);
        s.apply(
            &FieldRay { d_cam: d, d_world: d, basis: &b, cam_from_world: &DMat3::IDENTITY, white_over_sky: 1.0 },
            sky,
        )
    }

    #[test]
    fn zero_strength_is_the_identity_and_polarization_is_untouched() {
        let sky = Stokes::new(0.6, 0.1, -0.2, 0.0);
        assert_eq!(apply_at(&type12(0.0, 40.0), 10.0, 20.0, sky), sky);
        let t = apply_at(&type12(1.0, 40.0), 10.0, 20.0, sky);
        assert!((t.dolp() - sky.dolp()).abs() < 1e-15 && (t.aop_rad() - sky.aop_rad()).abs() < 1e-15);
        assert!(t.i != sky.i);
    }

    #[test]
    fn type_12_matches_the_cie_formula_by_hand() {
        // Sun at Z_s = 30°, view at Z = 60°, γ = 30° (same angle from the sun as the
        // zenith): L/L_z = φ(60°)/φ(0) = (1 − e^−0.64)/(1 − e^−0.32) = 1.72584…, and
        // R(γ) = R(Z_s), so k = L/L_z.
        let s = type12(1.0, 60.0);
        let want = (1.0 - (-0.64f64).exp()) / (1.0 - (-0.32f64).exp());
        // Azimuth of the view such that γ = 30°: on the sun's vertical, 60° from the zenith.
        let d = enu_from_az_el_deg(120.0, 30.0);
        assert!((s.sun_world.dot(d) - 30f64.to_radians().cos()).abs() < 1e-12);
        assert!((s.factor(d) - want).abs() < 1e-12, "{} vs {want}", s.factor(d));
        assert!((s.factor(DVec3::Z) - 1.0).abs() < 1e-12, "the zenith keeps its radiance");
    }

    #[test]
    fn brighter_toward_the_sun_and_toward_the_horizon() {
        let s = type12(1.0, 35.0);
        let radiance = |az: f64, el: f64| apply_at(&s, az, el, Stokes::new(1.0, 0.0, 0.0, 0.0)).i;
        // Near the sun versus 90° from it at the same elevation (Rayleigh alone: 0.5 × less).
        assert!(radiance(120.0, 40.0) > 3.0 * radiance(210.0, 40.0));
        // Away from the sun, the horizon is brighter than higher up.
        assert!(radiance(300.0, 3.0) > radiance(300.0, 45.0));
        // Below the horizon: finite, held at the horizon's gradation.
        let below = radiance(300.0, -10.0);
        assert!(below.is_finite() && below > 0.0);
        // A twilight sun: finite and positive everywhere.
        let tw = type12(1.0, -6.0);
        for el in [-20.0, 0.0, 30.0, 90.0] {
            let k = apply_at(&tw, 120.0, el, Stokes::new(1.0, 0.0, 0.0, 0.0)).i;
            assert!(k.is_finite() && k >= 0.0, "{el}: {k}");
        }
    }
}
