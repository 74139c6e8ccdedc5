//! # `sky_dolp_shape` — the sky's DoLP does not fall off as Rayleigh's (diffuse light)
//!
//! ```text
//! DoLP = d_max · w / (1 + (1 − t)(1 − w))      w = |ω| (Berry–Dennis–Lee), sin²γ on a Rayleigh sky
//!   t = 0: d_max·w/(2 − w) = d_max·sin²γ/(1 + cos²γ)    Rayleigh, and EFFECTS.md's remap of |ω|
//!   t = 1: d_max·w = d_max·sin²γ                         Berry's |ω| itself
//! computed from the sky step's DoLP: p = DoLP/d_max = w/(2 − w)  →  p' = p / (1 − ½t(1 − p))
//! Q, U × p'/p; I unchanged
//! ```
//!
//! Physics: single scattering gives polarized radiance ½ sin²γ in a radiance
//! ½(1 + cos²γ). Add an unpolarized, isotropic radiance ½m (light scattered more
//! than once, the ground's; or the molecules' own anisotropy, whose depolarization
//! factor ρ gives m = 2ρ/(1 − ρ)) and DoLP = sin²γ/(1 + m + cos²γ). With its peak at
//! γ = 90° written d_max (the sky's d_max stays the peak DoLP), that is
//! d_max·sin²γ/(1 + (1 − t)cos²γ) with t = m/(1 + m), the unpolarized share of the
//! radiance at 90° from the sun. The DoLP falls off from its peak more slowly than
//! Rayleigh's: toward Berry's |ω| as t → 1. On the quartic sky
//! (`sky_neutral_points`) the same remap of |ω| is applied, so the two compose: the
//! neutral points stay where they are (w = 0 ⇒ p' = 0) and the orientation is not
//! touched. Source: the anisotropic Rayleigh phase matrix (Chandrasekhar 1950,
//! *Radiative Transfer* §18; Hansen & Travis 1974, Space Sci. Rev. 16:527, eq. 2.15:
//! P = sin²Θ/(1 + cos²Θ + 2ρ/(1 − ρ))); the unpolarized share of multiple scattering
//! (Coulson 1988, *Polarization and Intensity of Light in the Atmosphere*, ch. 5);
//! Berry, Dennis & Lee 2004 (New J. Phys. 6:162) for |ω|.
//!
//! Units: t dimensionless. Frame: any (it scales Q and U together, so it acts in the
//! ray's meridional frame right after the sky, before the scene elements). The
//! radiance is left as the sky's (the fit's radiance nuisance and `sky_radiance`
//! carry it). Per pixel on both backends (`shaders/effects/sky_dolp_shape.wgsl`);
//! at t = 0 the factor is exactly 1 (and the chain skips the step).
//!
//! | param     | unit | neutral | fit bounds | physical |
//! |-----------|------|---------|------------|----------|
//! | `diffuse` | 1    | 0       | [0, 1]     | bounds   |
//!
//! Cannot: a DoLP that depends on the ray's elevation rather than on the scattering
//! angle (multiple scattering lowering it toward the horizon: on a level camera
//! looking up that is radial in the image, as `lens_depolarization`), a share that
//! differs between the sun's and the anti-sun's half of the sky, a DoLP falling off
//! faster than Rayleigh's (t < 0), or any change of the E-vector's orientation.

use super::{Apply, EffectDef, ParamSpec, SkyParams, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;
use glam::DVec3;

pub const EFFECT: EffectDef = EffectDef {
    name: "sky_dolp_shape",
    summary: "DoLP = d_max·|ω|/(1 + (1 − t)(1 − |ω|)): an unpolarized diffuse share t flattens Rayleigh's fall-off toward Berry's |ω|",
    source: "anisotropic/diffuse Rayleigh sky (Hansen & Travis 1974 eq. 2.15; Coulson 1988); Berry, Dennis & Lee 2004 |ω|",
    stage: Stage::Sky,
    params: &[ParamSpec {
        name: "diffuse",
        unit: "1",
        neutral: 0.0,
        typical: 0.3,
        min: 0.0,
        max: 1.0,
        // The bounds are the physical range: t is a share (0 … 1), and t = 1, Berry's |ω|,
        // is a published model of the clear sky (Berry, Dennis & Lee 2004).
        physical: None,
        doc: "unpolarized share t of the sky's radiance at 90° from the sun (0: Rayleigh's DoLP shape, 1: Berry's |ω|)",
    }],
    apply: Apply::Sky {
        params: |v| [[v[0], 0.0, 0.0, 0.0], [0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]],
        frame: None,
        pixel: sky_dolp_shape,
    },
    wgsl: Some(include_str!("../../../../shaders/effects/sky_dolp_shape.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// The sky's Stokes vector `s` with its DoLP reshaped by the diffuse share t = `p[0][0]`
/// ([`dolp_shape`]); exactly `s` at t = 0.
#[inline(always)]
pub fn sky_dolp_shape(p: &SkyParams, _sun: DVec3, dmax: f64, _g: &RayGeometry, s: Stokes) -> Stokes {
    if p[0][0] == 0.0 {
        return s;
    }
    dolp_shape(p[0][0], dmax, s)
}

/// The sky's Stokes vector `s` (meridional frame, as the sky step gives it under the
/// peak DoLP `dmax`) with its DoLP reshaped by the diffuse share `t`; I and V kept.
#[inline(always)]
pub fn dolp_shape(t: f64, dmax: f64, s: Stokes) -> Stokes {
    // The sky step's DoLP over d_max: p = w/(2 − w) ∈ [0, 1] (0 where there is no
    // polarization to reshape).
    let den = s.i * dmax;
    let p = if den > 0.0 { ((s.q * s.q + s.u * s.u).sqrt() / den).min(1.0) } else { 0.0 };
    // p' = p/(1 − ½t(1 − p)): Q and U by the factor p'/p, exactly 1 at t = 0.
    let k = 1.0 / (1.0 - 0.5 * t * (1.0 - p));
    Stokes { i: s.i, q: k * s.q, u: k * s.u, v: s.v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::chain::tests::{ideal_frame, stokes_at};
    use crate::conventions::{enu_from_az_el_deg, world_from_camera};
    use crate::effects::sky_neutral_points::{quartic_sky, NeutralPoints};
    use crate::effects::{EffectSet, Model};
    use crate::sky::sky_stokes;
    use glam::DVec3;

    #[test]
    fn at_zero_share_it_is_exactly_the_identity() {
        let sun = DVec3::new(0.3, -0.5, 0.81).normalize();
        for v in [DVec3::new(-0.2, 0.1, 0.97), DVec3::new(0.3, -0.5, 0.81), DVec3::Z] {
            let v = v.normalize();
            let s = sky_stokes(sun, 0.6, v, &meridional_basis(v));
            assert_eq!(dolp_shape(0.0, 0.6, s), s);
        }
        // No polarization, or no d_max: nothing to reshape, and no NaN.
        let s = Stokes::new(0.7, 0.0, 0.0, 0.0);
        assert_eq!(dolp_shape(0.8, 0.0, s), s);
        assert_eq!(dolp_shape(0.8, 0.6, s), s);
    }

    #[test]
    fn the_rayleigh_sky_takes_the_diffuse_shape_and_keeps_its_peak_and_orientation() {
        let sun = DVec3::X;
        for (t, cg) in [(0.3, 0.0), (0.3, 0.5), (0.3, 0.9), (1.0, 0.6), (0.7, -0.8)] {
            let sg = f64::sqrt(1.0 - cg * cg);
            let v = DVec3::new(cg, 0.6 * sg, 0.8 * sg);
            let s = sky_stokes(sun, 0.6, v, &meridional_basis(v));
            let r = dolp_shape(t, 0.6, s);
            let want = 0.6 * sg * sg / (1.0 + (1.0 - t) * cg * cg);
            assert!((r.dolp() - want).abs() < 1e-12, "t {t}, cos γ {cg}: {} vs {want}", r.dolp());
            assert_eq!(r.i, s.i);
            assert!((r.aop_rad() - s.aop_rad()).abs() < 1e-12);
            // Never above the peak, never below Rayleigh's.
            assert!(r.dolp() <= 0.6 + 1e-15 && r.dolp() >= s.dolp() - 1e-15);
        }
        // At t = 1 it is Berry's |ω| = sin²γ times d_max.
        let v = DVec3::new(0.6, 0.0, 0.8);
        let r = dolp_shape(1.0, 0.5, sky_stokes(sun, 0.5, v, &meridional_basis(v)));
        assert!((r.dolp() - 0.5 * 0.64).abs() < 1e-12);
    }

    #[test]
    fn on_the_quartic_sky_it_remaps_berrys_omega_and_leaves_the_neutral_points() {
        // The quartic sky's DoLP is d_max·w/(2 − w): recover w, then the reshaped DoLP
        // must be d_max·w/(1 + (1 − t)(1 − w)), the orientation unchanged.
        let r = world_from_camera(30.0, 3.0, -2.0);
        let sun = r.transpose() * enu_from_az_el_deg(40.0, 30.0);
        let np = NeutralPoints::new(&r, sun, 20f64.to_radians());
        let t = 0.4;
        for (az, el) in [(40.0, 40.0), (40.0, 20.0), (40.0, 33.0), (100.0, 50.0), (220.0, 75.0), (300.0, 30.0)] {
            let v = r.transpose() * enu_from_az_el_deg(az, el);
            let s = quartic_sky(&np, sun, 0.6, v, &meridional_basis(v));
            let p = s.dolp() / 0.6;
            let w = 2.0 * p / (1.0 + p);
            let got = dolp_shape(t, 0.6, s);
            let want = 0.6 * w / (1.0 + (1.0 - t) * (1.0 - w));
            assert!((got.dolp() - want).abs() < 1e-12, "{az} {el}: {} vs {want}", got.dolp());
            if s.dolp() > 1e-9 {
                assert!((got.aop_rad() - s.aop_rad()).abs() < 1e-12);
            } else {
                assert!(got.dolp() < 1e-9, "a neutral point stays unpolarized");
            }
        }
    }

    #[test]
    fn in_the_chain_only_the_dolp_changes() {
        let mut set = EffectSet::new();
        set.set("sky_dolp_shape", "diffuse", 0.5).unwrap();
        let (shaped, ideal) = (ideal_frame(&set.model()), ideal_frame(&Model::default()));
        assert!(shaped.has_pixel_effects());
        let mut changed = 0;
        for (u, v) in [(5.0, 7.0), (305.0, 255.0), (600.0, 20.0), (100.0, 480.0)] {
            let (a, b) = (stokes_at(&shaped, u, v), stokes_at(&ideal, u, v));
            assert_eq!(a.i, b.i);
            assert!((a.aop_rad() - b.aop_rad()).abs() < 1e-12);
            assert!(a.dolp() >= b.dolp() && a.dolp() <= 0.6);
            changed += usize::from(a.dolp() > b.dolp() * (1.0 + 1e-3));
        }
        assert!(changed >= 3, "the DoLP rose at {changed} of 4 points");
    }
}
