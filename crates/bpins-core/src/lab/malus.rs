//! Per-pixel Malus fit: each pixel's analyzer angle, extinction ratio and gain from
//! flat fields through a linear polarizer at known angles (Powell & Gruev 2013).
//!
//! ```text
//! y_j = (DN_j − o_p)/e_j = c0 + d_j (c1 cos 2θ_j + c2 sin 2θ_j)       pixel p, frame j
//!     = G/2 [(1+ε) + (1−ε) d_j cos 2(θ_j − φ)]
//! a_p = (c0, c1, c2)        the pixel's analyzer row (pixel_analyzers.rs), DN per unit
//! G = c0 + A,  ε = (c0 − A)/(c0 + A),  φ = ½ atan2(c2, c1),  A = √(c1² + c2²)
//! ```
//!
//! `θ_j` the polarizer's axis (degrees, image frame), `d_j` the source DoLP, `e_j`
//! the relative exposure, `o_p` the dark offset. Linear least squares with one design
//! for every pixel: the frames are streamed and each pixel keeps `Xᵀy` and `yᵀy`, so
//! memory is four numbers a pixel whatever the number of angles. Needs at least three
//! distinct polarizer angles (mod 180°) that resolve `c1, c2` (else `Err`, with the
//! reason).
//!
//! 1σ from the noise model ([`PixelNoise`]): the noise of frame j is shot noise of its
//! own signal plus read noise, `var y_j = (σ_r² + K e_j ŷ_j)/e_j²`, so it is larger
//! where the pixel is bright; the covariance of `c` is the sandwich
//! `(XᵀX)⁻¹ Xᵀ diag(var y) X (XᵀX)⁻¹` plus the offset's own error (shared by every
//! frame), then propagated to φ, ε and G. (Shot noise correlates `c0` with the
//! amplitude: ε's 1σ is about √3 below, G's √(5/3) above what equal noise would say.)

use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// Running sums of the fit over the frames, per pixel.
pub struct MalusSums {
    rows: Vec<DVec3>,
    exposures: Vec<f64>,
    /// `Xᵀy` per pixel.
    xty: Vec<[f64; 3]>,
    /// `yᵀy` per pixel.
    yty: Vec<f64>,
}

/// The noise of one pixel's frames: read noise and conversion gain, and the 1σ of
/// the offset subtracted (DN).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelNoise {
    pub read_noise_dn: f64,
    pub k_dn_per_e: f64,
    pub offset_sigma_dn: f64,
}

/// The fit of every pixel.
#[derive(Clone, Debug)]
pub struct MalusFit {
    /// `(c0, c1, c2)` per pixel, DN per unit exposure (not yet normalised).
    pub coef: Vec<[f64; 3]>,
    /// Residual variance of `y` per pixel, DN² (`N − 3` degrees of freedom).
    pub resid_var: Vec<f64>,
    /// `(XᵀX)⁻¹` of the design.
    pub cov_unit: [[f64; 3]; 3],
    /// Frames and distinct polarizer angles used.
    pub frames: usize,
    pub angles_deg: Vec<f64>,
    /// Each frame's design row and exposure.
    pub rows: Vec<DVec3>,
    pub exposures: Vec<f64>,
}

impl MalusFit {
    /// Covariance of pixel `i`'s `(c0, c1, c2)` under `noise` (see the module).
    pub fn coef_cov(&self, i: usize, noise: &PixelNoise) -> [[f64; 3]; 3] {
        let c = DVec3::from_array(self.coef[i]);
        let inv = DMat3::from_cols_array_2d(&self.cov_unit);
        let mut m = DMat3::ZERO;
        let mut v = DVec3::ZERO;
        for (x, &e) in self.rows.iter().zip(&self.exposures) {
            let signal_dn = (x.dot(c) * e).max(0.0);
            let var = (noise.read_noise_dn.powi(2) + noise.k_dn_per_e * signal_dn) / (e * e);
            m += DMat3::from_cols(*x * x.x, *x * x.y, *x * x.z) * var;
            v += *x / e;
        }
        let o = inv * v;
        let cov = inv * m * inv + DMat3::from_cols(o * o.x, o * o.y, o * o.z) * noise.offset_sigma_dn.powi(2);
        cov.to_cols_array_2d()
    }
}

impl MalusSums {
    pub fn new(pixels: usize) -> Self {
        MalusSums { rows: Vec::new(), exposures: Vec::new(), xty: vec![[0.0; 3]; pixels], yty: vec![0.0; pixels] }
    }

    /// Adds one polarized frame: `dn` the raw mosaic, `offset_dn` per pixel.
    pub fn add(&mut self, dn: &[f32], offset_dn: &[f32], angle_deg: f64, dolp: f64, exposure_rel: f64) {
        let (s, c) = (2.0 * angle_deg).to_radians().sin_cos();
        let x = DVec3::new(1.0, dolp * c, dolp * s);
        self.rows.push(x);
        self.exposures.push(exposure_rel);
        let inv_e = 1.0 / exposure_rel;
        self.xty.par_chunks_mut(4096).zip(self.yty.par_chunks_mut(4096)).enumerate().for_each(|(b, (xty, yty))| {
            let o = b * 4096;
            for (i, (a, q)) in xty.iter_mut().zip(yty.iter_mut()).enumerate() {
                let y = (dn[o + i] as f64 - offset_dn[o + i] as f64) * inv_e;
                a[0] += y;
                a[1] += x.y * y;
                a[2] += x.z * y;
                *q += y * y;
            }
        });
    }

    /// Solves every pixel, or says why the angles cannot determine the analyzers.
    pub fn solve(self, angles_deg: &[f64]) -> Result<MalusFit, String> {
        let mut distinct: Vec<f64> = Vec::new();
        for a in angles_deg {
            let m = a.rem_euclid(180.0);
            if !distinct.iter().any(|d| ((d - m + 90.0).rem_euclid(180.0) - 90.0).abs() < 1e-6) {
                distinct.push(m);
            }
        }
        if distinct.len() < 3 {
            return Err(format!(
                "the analyzer angle and extinction ratio need flat fields at 3 or more distinct polarizer angles \
                 (mod 180°); the capture has {} ({})",
                distinct.len(),
                distinct.iter().map(|a| format!("{a}°")).collect::<Vec<_>>().join(", ")
            ));
        }
        let mut xtx = DMat3::ZERO;
        for r in &self.rows {
            xtx += DMat3::from_cols(*r * r.x, *r * r.y, *r * r.z);
        }
        let n = self.rows.len() as f64;
        if xtx.determinant().abs() < 1e-9 * n.powi(3) {
            return Err("the polarizer angles and DoLPs do not resolve the analyzers (singular design)".into());
        }
        let inv = xtx.inverse();
        let dof = n - 3.0;
        let (coef, resid_var): (Vec<[f64; 3]>, Vec<f64>) = self
            .xty
            .par_iter()
            .zip(self.yty.par_iter())
            .map(|(a, &q)| {
                let b = DVec3::from_array(*a);
                let c = inv * b;
                let rss = (q - c.dot(b)).max(0.0);
                (c.to_array(), if dof > 0.0 { rss / dof } else { f64::NAN })
            })
            .unzip();
        // Symmetric: columns and rows alike.
        let cov_unit = inv.to_cols_array_2d();
        Ok(MalusFit {
            coef,
            resid_var,
            cov_unit,
            frames: self.rows.len(),
            angles_deg: distinct,
            rows: self.rows,
            exposures: self.exposures,
        })
    }
}

/// One pixel's analyzer from its coefficients: `(G, ε, φ_deg)` and their 1σ for the
/// coefficients' covariance `cov` ([`MalusFit::coef_cov`]).
pub fn analyzer_of(c: [f64; 3], cov: &[[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let amp = c[1].hypot(c[2]);
    let g = c[0] + amp;
    let eps = (c[0] - amp) / g;
    let phi_deg = 0.5 * c[2].atan2(c[1]).to_degrees();
    // Variances of c0 and of the amplitude's two directions (along and across (c1, c2)).
    let (ux, uy) = if amp > 0.0 { (c[1] / amp, c[2] / amp) } else { (1.0, 0.0) };
    let quad = |a: [f64; 3]| {
        let mut s = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                s += a[i] * cov[i][j] * a[j];
            }
        }
        s
    };
    let var_perp = quad([0.0, -uy, ux]);
    let sigma_g = quad([1.0, ux, uy]).sqrt();
    // ∂ε/∂c0 = 2A/G², ∂ε/∂A = −2c0/G² (the covariance of c0 and A kept).
    let (de0, dea) = (2.0 * amp / (g * g), -2.0 * c[0] / (g * g));
    let sigma_eps = quad([de0, dea * ux, dea * uy]).sqrt();
    let sigma_phi_deg = 0.5 * (var_perp.sqrt() / amp).to_degrees();
    ([g, eps, phi_deg], [sigma_g, sigma_eps, sigma_phi_deg])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pixel_s_analyzer_is_read_back_from_its_malus_curve() {
        // Two pixels: G 2000 DN, ε 0.02, φ 46.3°; and G 1500, ε 0.01, φ −0.4°; offset 64.
        let truth = [(2000.0, 0.02, 46.3), (1500.0, 0.01, -0.4)];
        let angles: Vec<f64> = (0..12).map(|k| 15.0 * k as f64).collect();
        let mut sums = MalusSums::new(2);
        let off = [64.0f32; 2];
        for &t in &angles {
            let dn: Vec<f32> = truth
                .iter()
                .map(|&(g, e, p): &(f64, f64, f64)| {
                    (64.0 + g / 2.0 * ((1.0 + e) + (1.0 - e) * (2.0 * (t - p)).to_radians().cos())) as f32
                })
                .collect();
            sums.add(&dn, &off, t, 1.0, 1.0);
        }
        let fit = sums.solve(&angles).unwrap();
        for (i, &(g, e, p)) in truth.iter().enumerate() {
            let ([g1, e1, p1], _) = analyzer_of(fit.coef[i], &fit.cov_unit);
            assert!((g1 - g).abs() < 0.01 && (e1 - e).abs() < 1e-5 && (p1 - p).abs() < 1e-3, "{g1} {e1} {p1}");
        }
    }

    #[test]
    fn too_few_angles_are_refused_with_the_reason() {
        let mut sums = MalusSums::new(1);
        for t in [10.0, 190.0, 100.0] {
            sums.add(&[100.0], &[0.0], t, 1.0, 1.0);
        }
        let e = sums.solve(&[10.0, 190.0, 100.0]).unwrap_err();
        assert!(e.contains("3 or more") && e.contains("has 2"), "{e}");
    }

    #[test]
    fn shot_noise_correlates_the_mean_and_the_amplitude() {
        // A pixel with c0 = A (ε = 0), shot noise only: var y_j = K·ŷ_j. Then
        // var(c0 − A) = K c0/N, var(c0 + A) = 5 K c0/N (module doc).
        let angles: Vec<f64> = (0..12).map(|k| 15.0 * k as f64).collect();
        let mut sums = MalusSums::new(1);
        for &t in &angles {
            sums.add(&[1000.0], &[0.0], t, 1.0, 1.0);
        }
        let mut fit = sums.solve(&angles).unwrap();
        fit.coef[0] = [1000.0, 1000.0, 0.0];
        let cov = fit.coef_cov(0, &PixelNoise { read_noise_dn: 0.0, k_dn_per_e: 0.1, offset_sigma_dn: 0.0 });
        let var = |a: [f64; 3]| (0..3).map(|i| (0..3).map(|j| a[i] * cov[i][j] * a[j]).sum::<f64>()).sum::<f64>();
        let unit = 0.1 * 1000.0 / 12.0;
        assert!((var([1.0, -1.0, 0.0]) / unit - 1.0).abs() < 1e-9, "{}", var([1.0, -1.0, 0.0]) / unit);
        assert!((var([1.0, 1.0, 0.0]) / unit - 5.0).abs() < 1e-9);
    }

    #[test]
    fn sigmas_follow_the_noise() {
        // 12 angles, σ_y = 10 DN: σ(c1) = 10·√(2/12); φ's 1σ = that / (2A) rad.
        let angles: Vec<f64> = (0..12).map(|k| 15.0 * k as f64).collect();
        let mut sums = MalusSums::new(1);
        for &t in &angles {
            sums.add(&[1000.0], &[0.0], t, 1.0, 1.0);
        }
        let fit = sums.solve(&angles).unwrap();
        let cov = fit.cov_unit.map(|r| r.map(|x| x * 100.0));
        let (_, s) = analyzer_of([1000.0, 900.0, 0.0], &cov);
        let want = 0.5 * (10.0 * (2.0f64 / 12.0).sqrt() / 900.0).to_degrees();
        assert!((s[2] - want).abs() < 1e-9 * want.max(1.0), "{} vs {want}", s[2]);
    }
}
