//! Stokes vectors, frame rotations and the ideal/real linear analyzer.
//!
//! Frames (CONVENTIONS.md "Stokes and Mueller"): in the image, `Q, U` refer to image
//! +x with angles counter-clockwise as displayed, `Q = I·d·cos 2α`, `U = I·d·sin 2α`.
//! In the meridional frame of a ray the reference axis is the radial direction p and
//! the angle is the AoE φ; the image angle of p is β, so α = φ + β.
//! Units: intensities in the unit of the caller (sky radiance or DN).

/// A Stokes vector `(I, Q, U, V)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stokes {
    pub i: f64,
    pub q: f64,
    pub u: f64,
    pub v: f64,
}

impl Stokes {
    pub const fn new(i: f64, q: f64, u: f64, v: f64) -> Self {
        Stokes { i, q, u, v }
    }

    /// Degree of linear polarization `√(Q² + U²)/I` (0 where I ≤ 0).
    #[inline]
    pub fn dolp(&self) -> f64 {
        if self.i > 0.0 {
            (self.q * self.q + self.u * self.u).sqrt() / self.i
        } else {
            0.0
        }
    }

    /// Angle of polarization `½ atan2(U, Q)` in radians, in (−π/2, π/2].
    #[inline]
    pub fn aop_rad(&self) -> f64 {
        let a = 0.5 * self.u.atan2(self.q);
        if a <= -std::f64::consts::FRAC_PI_2 {
            a + std::f64::consts::PI
        } else {
            a
        }
    }
}

/// Meridional frame → image frame of a ray whose radial direction has image angle β:
/// the polarization angle grows by β, `(Q, U) ← R(2β)·(Q_p, U_p)`.
#[inline(always)]
pub fn meridional_to_image(s: Stokes, cos2b: f64, sin2b: f64) -> Stokes {
    Stokes { i: s.i, q: s.q * cos2b - s.u * sin2b, u: s.q * sin2b + s.u * cos2b, v: s.v }
}

/// Image frame → meridional frame, the inverse of [`meridional_to_image`].
#[inline(always)]
pub(crate) fn image_to_meridional(s: Stokes, cos2b: f64, sin2b: f64) -> Stokes {
    Stokes { i: s.i, q: s.q * cos2b + s.u * sin2b, u: -s.q * sin2b + s.u * cos2b, v: s.v }
}

/// One analyzer channel as the chain sees it: `cos 2θ`, `sin 2θ` of its true angle θ
/// and ε = 1/ER.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Analyzer {
    pub cos2t: f64,
    pub sin2t: f64,
    pub eps: f64,
}

impl Analyzer {
    /// An analyzer at nominal angle `nominal_deg` (a multiple of 45°) turned by
    /// `delta_deg`. The nominal cos/sin are exact, so δ = 0 gives exactly 1, 0, −1.
    pub fn at(nominal_deg: f64, delta_deg: f64, eps: f64) -> Self {
        let (cn, sn) = match (nominal_deg.rem_euclid(180.0) / 45.0).round() as i32 {
            0 => (1.0, 0.0),
            1 => (0.0, 1.0),
            2 => (-1.0, 0.0),
            3 => (0.0, -1.0),
            _ => unreachable!("rem_euclid(180)/45 rounds to 0..=4"),
        };
        let off = 2.0 * (nominal_deg - 45.0 * (nominal_deg / 45.0).round()) + 2.0 * delta_deg;
        let (so, co) = off.to_radians().sin_cos();
        Analyzer { cos2t: cn * co - sn * so, sin2t: sn * co + cn * so, eps }
    }
}

/// Intensity behind an analyzer (seed eq. 3; CONVENTIONS.md with ε = 1/ER):
/// `I_θ = ½[(1+ε) I + (1−ε)(Q cos 2θ + U sin 2θ)]`.
#[inline(always)]
pub fn analyzer_intensity(s: Stokes, a: &Analyzer) -> f64 {
    0.5 * ((1.0 + a.eps) * s.i + (1.0 - a.eps) * (s.q * a.cos2t + s.u * a.sin2t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn malus_law() {
        // Fully polarized light at α through an ideal analyzer at θ: I cos²(α − θ).
        for alpha_deg in [-80.0f64, -30.0, 0.0, 17.0, 45.0, 90.0] {
            let a = alpha_deg.to_radians();
            let s = Stokes::new(2.0, 2.0 * (2.0 * a).cos(), 2.0 * (2.0 * a).sin(), 0.0);
            for theta_deg in [0.0f64, 45.0, 90.0, 135.0, 10.0] {
                let an = Analyzer::at(0.0, theta_deg, 0.0);
                let want = 2.0 * (a - theta_deg.to_radians()).cos().powi(2);
                assert!((analyzer_intensity(s, &an) - want).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn nominal_analyzers_are_exact() {
        let c: Vec<(f64, f64)> = [0.0, 45.0, 90.0, 135.0]
            .iter()
            .map(|&d| {
                let a = Analyzer::at(d, 0.0, 0.0);
                (a.cos2t, a.sin2t)
            })
            .collect();
        assert_eq!(c, vec![(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]);
    }

    #[test]
    fn extinction_ratio_leaks_the_crossed_state() {
        let s = Stokes::new(1.0, 1.0, 0.0, 0.0); // horizontal
        let crossed = Analyzer::at(90.0, 0.0, 0.01);
        assert!((analyzer_intensity(s, &crossed) - 0.01).abs() < 1e-15);
    }

    #[test]
    fn rotations_are_inverse_and_shift_the_angle_by_beta() {
        let s = Stokes::new(1.0, 0.3, -0.2, 0.0);
        let b = 0.4f64;
        let (c, sn) = ((2.0 * b).cos(), (2.0 * b).sin());
        let back = image_to_meridional(meridional_to_image(s, c, sn), c, sn);
        assert!((back.q - s.q).abs() < 1e-15 && (back.u - s.u).abs() < 1e-15);
        let img = meridional_to_image(s, c, sn);
        assert!((img.aop_rad() - (s.aop_rad() + b)).abs() < 1e-12);
        assert!((img.dolp() - s.dolp()).abs() < 1e-15);
    }
}
