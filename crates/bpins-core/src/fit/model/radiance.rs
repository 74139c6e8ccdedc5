//! # The sky's radiance as a per-frame nuisance: a smooth, orthonormal basis
//!
//! ```text
//! DN_model(p) = offset + R_f(p) · g_f · signal(p),    R_f(p) = exp(Σ_i c_f,i · ψ_i(p))
//! φ(p) = [1, x, y, x², xy, y², x³, x²y, xy², y³, cos γ, cos²γ, cos³γ, γ]
//!        x, y ∈ [−1, 1] across the image, γ the scattering angle (rad)
//! ψ    = the rows 1… of L⁻¹·φ,  L·Lᵀ = ⟨φ φᵀ⟩ over the frame's sky pixels   (Gram–Schmidt)
//! ```
//!
//! What: a real sky's radiance is neither Rayleigh's ½(1 + cos²γ) nor any fixed
//! model: the CIE general sky (gradation in the zenith angle, a circumsolar
//! indicatrix in the scattering angle γ), haze and thin cloud change it frame to
//! frame. The radiance is a scalar on the Stokes vector, so it moves every channel
//! of a pixel alike and leaves DoLP and AoP alone: the polarization effects live in
//! the differences between channels, which R cannot imitate. x, y follow the image
//! (a camera looking up sees the zenith-angle gradation as a smooth function of the
//! image position); the cos γ powers follow the aureole and the forward scattering
//! about the sun (first terms of a phase function's expansion).
//!
//! Why a basis in the logarithm and not the CIE formula: the CIE sky is a product
//! (gradation in the zenith angle × indicatrix in γ, over Rayleigh's radiance), which
//! is a sum in log R; near the sun its indicatrix is ≈ exp(d·γ), linear in γ. The
//! Jacobian columns are analytic (`(DN_model − offset)·ψ_i`, no chain evaluation), so
//! a frame costs little more to fit than with the old two-term shape, and the basis is
//! tied to no one sky model. Chosen by evidence on a CIE type-12 sky (README:
//! diagnosis on real skies; χ²/dof after the starting model on a clean capture:
//! additive 8-term basis 1.086, log 12-term 1.028, this one 1.002). The basis is orthonormalized over each frame's sky pixels at the
//! fit's start (ψ orthogonal to the constant, which is the radiance scale's), so the
//! damped Gauss–Newton steps are well conditioned; the transform is kept in
//! [`crate::fit::FitState`] so a warm start means the same coefficients.
//!
//! Frame: image coordinates; γ between the pixel's true ray and the sun (camera
//! frame). Units: dimensionless. R is applied to the photo-signal after the lens and
//! crosstalk (a scalar commutes with the lens Mueller matrices; over a pixel's
//! neighbours R is constant to far below the noise).
//!
//! Cannot: tell an intensity-only effect from the sky (vignetting: a radial falloff
//! is the sky's own brightening toward the horizon for a camera looking up) — such
//! effects are reported as inseparable by the diagnosis, and measured with a lab
//! flat field; follow structure finer than a quadratic in the image (a cloud edge:
//! the sky mask leaves clouds out).

use crate::camera::Intrinsics;
use glam::DVec3;

/// Coefficients per frame (the basis functions beside the constant).
pub const N: usize = 13;

/// The raw functions φ at normalized image position (x, y) and cos γ; φ₀ = 1.
#[inline(always)]
pub fn raw(x: f64, y: f64, cos_gamma: f64) -> [f64; N + 1] {
    let c = cos_gamma;
    let (x2, y2) = (x * x, y * y);
    [1.0, x, y, x2, x * y, y2, x2 * x, x2 * y, x * y2, y2 * y, c, c * c, c * c * c, c.clamp(-1.0, 1.0).acos()]
}

/// One frame's orthonormal basis ψ = T·φ (T: N rows of N + 1).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Basis {
    pub t: Vec<[f64; N + 1]>,
}

impl Basis {
    /// The basis orthonormal over `samples` of φ (Cholesky of their Gram matrix). A
    /// function the others already span (a pivot below 10⁻⁹) gets a zero row: its
    /// coefficient does not move the model and the fit leaves it at 0.
    pub fn orthonormal(samples: impl Iterator<Item = [f64; N + 1]>) -> Basis {
        const M: usize = N + 1;
        let mut g = [[0.0f64; M]; M];
        let mut n = 0.0;
        for p in samples {
            for i in 0..M {
                for j in 0..=i {
                    g[i][j] += p[i] * p[j];
                }
            }
            n += 1.0;
        }
        if n < 1.0 {
            return Basis { t: vec![[0.0; M]; N] };
        }
        // Cholesky L (lower) of G/n, with dropped pivots.
        let mut l = [[0.0f64; M]; M];
        let mut keep = [true; M];
        for i in 0..M {
            for j in 0..=i {
                let mut s = g[i][j] / n;
                for k in 0..j {
                    s -= l[i][k] * l[j][k];
                }
                if i == j {
                    if s > 1e-9 * (g[i][i] / n).max(1e-300) && s > 0.0 {
                        l[i][i] = s.sqrt();
                    } else {
                        keep[i] = false;
                        l[i][i] = 1.0;
                    }
                } else if keep[j] {
                    l[i][j] = s / l[j][j];
                }
            }
            if !keep[i] {
                for k in 0..i {
                    l[i][k] = 0.0;
                }
            }
        }
        // T = L⁻¹ (forward substitution, row by row), rows of dropped pivots zero.
        let mut inv = [[0.0f64; M]; M];
        for c in 0..M {
            for i in 0..M {
                let mut s = if i == c { 1.0 } else { 0.0 };
                for k in 0..i {
                    s -= l[i][k] * inv[k][c];
                }
                inv[i][c] = s / l[i][i];
            }
        }
        let t = (1..M).map(|i| if keep[i] { inv[i] } else { [0.0; M] }).collect();
        Basis { t }
    }

    /// The weights w = Tᵀc of the raw functions for the coefficients `coeffs`: Σ c_i ψ_i
    /// = w·φ, so R at a pixel costs N + 1 products instead of N(N + 1) ([`factor_raw`]).
    pub fn weights(&self, coeffs: &[f64; N]) -> [f64; N + 1] {
        let mut w = [0.0; N + 1];
        for (c, row) in coeffs.iter().zip(&self.t) {
            for (wj, tj) in w.iter_mut().zip(row) {
                *wj += c * tj;
            }
        }
        w
    }

    /// ψ at the raw functions `phi`.
    #[inline(always)]
    pub fn psi(&self, phi: &[f64; N + 1]) -> [f64; N] {
        let mut out = [0.0; N];
        for (o, row) in out.iter_mut().zip(&self.t) {
            *o = row.iter().zip(phi).map(|(a, b)| a * b).sum();
        }
        out
    }
}

/// Normalized image position of pixel (u, v) of a `w × h` image: x, y ∈ [−1, 1].
#[inline(always)]
pub fn image_xy(u: usize, v: usize, w: usize, h: usize) -> (f64, f64) {
    let (hw, hh) = (0.5 * (w as f64 - 1.0).max(1.0), 0.5 * (h as f64 - 1.0).max(1.0));
    ((u as f64 - hw) / hw, (v as f64 - hh) / hh)
}

/// φ at pixel (u, v) through the camera `intr` with the sun at `sun_cam`.
#[inline(always)]
pub fn raw_at(intr: &Intrinsics, sun_cam: DVec3, u: usize, v: usize, w: usize, h: usize) -> [f64; N + 1] {
    let (x, y) = image_xy(u, v, w, h);
    let cos_gamma = sun_cam.dot(intr.geometry(u as f64, v as f64).d);
    raw(x, y, cos_gamma)
}

/// R = exp(w·φ) from the frame's [`Basis::weights`] `w` and the raw functions `phi`:
/// [`factor`] without forming ψ (equal to rounding).
#[inline(always)]
pub fn factor_raw(w: &[f64; N + 1], phi: &[f64; N + 1]) -> f64 {
    w.iter().zip(phi).map(|(a, b)| a * b).sum::<f64>().exp()
}

/// R = exp(Σ c_i ψ_i).
#[inline(always)]
pub fn factor(coeffs: &[f64; N], psi: &[f64; N]) -> f64 {
    coeffs.iter().zip(psi).map(|(a, b)| a * b).sum::<f64>().exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> impl Iterator<Item = [f64; N + 1]> {
        (0..40).flat_map(|j| {
            (0..50).map(move |i| raw(i as f64 / 25.0 - 1.0, j as f64 / 20.0 - 1.0, 0.1 + 0.01 * i as f64))
        })
    }

    #[test]
    fn the_basis_is_orthonormal_and_orthogonal_to_the_constant() {
        let b = Basis::orthonormal(grid());
        let n = grid().count() as f64;
        let mut g = [[0.0; N]; N];
        let mut mean = [0.0; N];
        for p in grid() {
            let s = b.psi(&p);
            for i in 0..N {
                mean[i] += s[i] / n;
                for j in 0..N {
                    g[i][j] += s[i] * s[j] / n;
                }
            }
        }
        for i in 0..N {
            assert!(mean[i].abs() < 1e-9, "ψ{i} has mean {}", mean[i]);
            for j in 0..N {
                // cos γ here is a function of x alone: one of x, cos γ, … is spanned by
                // the others and gets a zero row, the rest are orthonormal.
                let want = if i == j && b.t[i].iter().any(|&x| x != 0.0) { 1.0 } else { 0.0 };
                // γ is nearly a cubic in x here: its row keeps ~10⁻⁶ of rounding.
                assert!((g[i][j] - want).abs() < 1e-5, "⟨ψ{i} ψ{j}⟩ = {}", g[i][j]);
            }
        }
        assert!(b.t.iter().filter(|r| r.iter().all(|&x| x == 0.0)).count() >= 1);
    }

    #[test]
    fn zero_coefficients_are_the_identity() {
        let b = Basis::orthonormal(grid());
        let psi = b.psi(&raw(0.3, -0.2, 0.5));
        assert_eq!(factor(&[0.0; N], &psi), 1.0);
    }

    #[test]
    fn the_factor_from_weights_is_the_factor_from_psi() {
        let b = Basis::orthonormal(grid());
        let c: [f64; N] = std::array::from_fn(|i| 0.05 * (i as f64 - 6.0));
        let w = b.weights(&c);
        // Points of the grid's own sky (cos γ = 0.1 + 0.25(x + 1) there).
        for (x, y) in [(0.3, -0.2), (-0.9, 0.7), (0.0, 0.0)] {
            let phi = raw(x, y, 0.1 + 0.25 * (x + 1.0));
            let (a, want) = (factor_raw(&w, &phi), factor(&c, &b.psi(&phi)));
            assert!((a / want - 1.0).abs() < 1e-12, "{a} vs {want}");
        }
    }
}
