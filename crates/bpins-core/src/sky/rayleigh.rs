//! Single-scattering Rayleigh sky (CONVENTIONS.md "Sky"; seed §2 eq. 1).
//!
//! ```text
//! cos γ = s · v                          scattering angle γ between sun s and view v
//! I     = ½(1 + cos²γ)                   radiance, 1 toward the sun and anti-sun
//! d     = d_max · sin²γ / (1 + cos²γ)    degree of linear polarization
//! E     ∥ s × v                          E-vector ⊥ scattering plane
//! ```
//!
//! Frame: any right-handed frame, as long as s and v share it (the chain uses the
//! camera frame, so no per-pixel rotation is needed). The E-vector is expressed in the
//! ray's meridional basis (p, s) as the AoE φ = atan2(−e_s, e_p), and the Stokes
//! vector returned is in that meridional frame: `(I, I d cos 2φ, I d sin 2φ, 0)`.
//! Radiance units: sky radiance, 1 at the sun's direction; the sensor gain maps it to DN.
//! Cannot: multiple scattering, aerosols, neutral points (see `sky_neutral_points`),
//! ground albedo, or spectral dependence.

use crate::camera::MeridionalBasis;
use crate::stokes::Stokes;
use glam::DVec3;

/// Stokes vector of the Rayleigh sky seen along unit ray `view` (meridional frame of
/// `basis`), for the unit sun direction `sun` in the same frame (both must be unit).
#[inline(always)]
pub fn sky_stokes(sun: DVec3, dmax: f64, view: DVec3, basis: &MeridionalBasis) -> Stokes {
    // Scattering angle between sun and view.
    let cg = sun.dot(view);
    let cg2 = cg * cg;
    let radiance = 0.5 * (1.0 + cg2);
    // E-vector perpendicular to the scattering plane, in the meridional basis.
    let e = sun.cross(view);
    let ep = e.dot(basis.p);
    let es = e.dot(basis.s);
    // AoE φ = atan2(−e_s, e_p) with |e|² = e_p² + e_s² = sin²γ (unit sun and view), and
    // polarized radiance I·d = ½ d_max sin²γ: so I·d·cos 2φ = ½ d_max (e_p² − e_s²) and
    // I·d·sin 2φ = −d_max e_p e_s — no division, and 0 toward the sun or anti-sun.
    Stokes::new(radiance, 0.5 * dmax * (ep * ep - es * es), -dmax * ep * es, 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::conventions::{enu_from_az_el_deg, world_from_camera, wrap_deg_90};

    #[test]
    fn rayleigh_dolp_and_radiance() {
        let sun = DVec3::X;
        let view = DVec3::new(0.0, 0.6, 0.8);
        let b = meridional_basis(view);
        let s = sky_stokes(sun, 0.6, view, &b);
        assert!((s.i - 0.5).abs() < 1e-15);
        assert!((s.dolp() - 0.6).abs() < 1e-12, "γ = 90° gives d_max");
        let view2 = DVec3::new(0.6, 0.0, 0.8);
        let s2 = sky_stokes(sun, 0.6, view2, &meridional_basis(view2));
        let (c, sn2) = (0.6f64, 0.64f64);
        assert!((s2.dolp() - 0.6 * sn2 / (1.0 + c * c)).abs() < 1e-12);
    }

    #[test]
    fn e_vector_is_perpendicular_to_the_solar_meridian_on_it() {
        // Level camera, heading 0; sun at azimuth 40°, elevation 25°. Points on the
        // solar meridian have AoE = 90° (E-vector ⊥ the meridian plane).
        let r = world_from_camera(0.0, 0.0, 0.0);
        let sun_c = r.transpose() * enu_from_az_el_deg(40.0, 25.0);
        for (az, el) in [(40.0, 80.0), (40.0, 60.0), (220.0, 75.0)] {
            let v = r.transpose() * enu_from_az_el_deg(az, el);
            let b = meridional_basis(v);
            let s = sky_stokes(sun_c, 0.6, v, &b);
            let aoe = wrap_deg_90(s.aop_rad().to_degrees());
            assert!((aoe - 90.0).abs() < 1e-9, "AoE {aoe}");
        }
    }

    #[test]
    fn e_vector_is_transverse_to_the_view_and_the_sun() {
        let sun = DVec3::new(0.3, -0.5, 0.81).normalize();
        let v = DVec3::new(-0.2, 0.1, 0.97).normalize();
        let b = meridional_basis(v);
        let s = sky_stokes(sun, 1.0, v, &b);
        // Rebuild the E-vector from the AoE and check it is ⊥ to the sun.
        let phi = s.aop_rad();
        let e = b.p * phi.cos() - b.s * phi.sin();
        assert!(e.dot(sun).abs() < 1e-12);
        assert!(e.dot(v).abs() < 1e-12);
    }
}
