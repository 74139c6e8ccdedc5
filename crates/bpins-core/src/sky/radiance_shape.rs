//! # The sky's smooth radiance shape — a per-frame nuisance of the fit
//!
//! ```text
//! S_out = S_sky · max(1 + a1·cos γ + a2·cos²γ, 0)        γ: scattering angle (ray, sun)
//! ```
//!
//! Why: the model's sky radiance is Rayleigh's ½(1 + cos²γ); real skies are brighter
//! toward the sun (aerosol forward scattering) and differ frame to frame (haze, thin
//! cloud). Left out, such a radiance misfit is blamed on the nearest catalog effect.
//! `fit` frees (a1, a2) per frame beside the radiance scale (EFFECTS.md: per-frame
//! nuisances), unless the user holds the radiance at Rayleigh's. Source: the
//! low-order expansion of a smooth phase function in cos γ (a Henyey–Greenstein
//! forward lobe to first order is 1 + 3g·cos γ). Units: dimensionless. Frame: any
//! (a scalar on every Stokes component, so DoLP and AoP are untouched — tested).
//! 0 in simulation; on both backends (`radiance_shape` in `shaders/common/sky.wgsl`).
//!
//! Cannot: a shape that is not symmetric about the sun (horizon brightening, a
//! cloud): a shape that depends on the zenith angle would, for a camera looking up,
//! be radial in the image and indistinguishable from `vignetting`.

use crate::stokes::Stokes;

/// The sky Stokes vector `s` with its radiance shaped by (a1, a2) at cos γ = `cos_gamma`.
#[inline(always)]
pub fn radiance_shape(a1: f64, a2: f64, cos_gamma: f64, s: Stokes) -> Stokes {
    // Shape factor 1 + a1 cos γ + a2 cos²γ, at least 0; exactly 1 at a1 = a2 = 0.
    let k = (1.0 + a1 * cos_gamma + a2 * cos_gamma * cos_gamma).max(0.0);
    Stokes { i: k * s.i, q: k * s.q, u: k * s.u, v: k * s.v }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_shape_is_the_identity_and_polarization_is_untouched() {
        let s = Stokes::new(0.8, 0.2, -0.1, 0.0);
        assert_eq!(radiance_shape(0.0, 0.0, 0.37, s), s);
        let t = radiance_shape(0.3, -0.1, 0.5, s);
        assert!((t.i / s.i - (1.0 + 0.15 - 0.025)).abs() < 1e-15);
        assert!((t.dolp() - s.dolp()).abs() < 1e-15 && (t.aop_rad() - s.aop_rad()).abs() < 1e-15);
        assert_eq!(radiance_shape(-2.0, 0.0, 1.0, s).i, 0.0);
    }
}
