//! One small least-squares room: Levenberg–Marquardt on a few parameters, the
//! covariance of its answer, what a bias every residual shares moves it by, and the
//! delete-one jackknife's spread. `locate` (the stamped and the pole routes) and the
//! sky's sun (`heading::field::sky_sun`, step 5) fit with it; each keeps its own
//! steps and stopping thresholds ([`Lm`]).
//!
//! ```text
//! χ²(p) = Σᵢ rᵢ(p)²                                  rᵢ the whitened residuals
//! J_ik = (rᵢ(p + h_k e_k) − rᵢ(p − h_k e_k)) / 2h_k   central differences, steps h
//! step:  (A + λ·diag(A) + ε·I) d = −Jᵀr,  A = JᵀJ     from λ = 10⁻³
//!        χ²(p + d) < χ²(p): taken, λ ← max(0.3·λ, 10⁻⁹); else λ ← 10·λ (`tries` times)
//! stop:  no step lowers χ², a step lowers it by less than `rel_tol`·χ², or `iterations`
//! C = (JᵀJ)⁻¹ · max(1, χ²/dof),  dof = m − n (χ²/dof taken as 1 where dof = 0)
//! shared bias b (σ_b), rᵢ moving by vᵢ·b:  Δp = −(JᵀJ)⁻¹Jᵀv per unit;  C += Δp Δpᵀ σ_b²
//! jackknife over k leave-one-out estimates dⱼ:  σ² = (k − 1)/k · Σⱼ (dⱼ − d̄)²
//! ```
//!
//! J is the final point's, recomputed there. The covariance inflation makes a fit whose
//! residuals exceed their 1σ honest about it and never narrows one whose residuals are
//! smaller. A bias shared by every residual is invisible to χ² and does not average out
//! over them, so it joins the covariance apart. Units: whatever the residuals' and the
//! parameters' are.

use nalgebra::{DMatrix, DVector};

/// How a Levenberg–Marquardt search runs (module doc): per-parameter steps of the
/// numeric Jacobian and the stopping rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lm<const N: usize> {
    /// Central-difference step of each parameter, in its unit.
    pub step: [f64; N],
    /// Jacobians (outer iterations) at most.
    pub iterations: usize,
    /// Damping increases tried per iteration before the search ends.
    pub tries: usize,
    /// A taken step that lowers χ² by less than this fraction of it ends the search.
    pub rel_tol: f64,
    /// Added to the damped diagonal (ε), keeping a flat direction solvable.
    pub ridge: f64,
}

/// The answer of [`Lm::solve`]: the parameters, χ² and the Jacobian there.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LmFit<const N: usize> {
    pub p: [f64; N],
    pub chi2: f64,
    /// ∂rᵢ/∂p_k at `p`, one row per residual.
    pub jacobian: Vec<[f64; N]>,
}

impl<const N: usize> Lm<N> {
    /// The central-difference Jacobian of `f` at `p`, one row per residual; `None`
    /// where `f` fails at a step or the steps' residuals differ in count.
    pub fn jacobian(&self, p: &[f64; N], f: &dyn Fn(&[f64; N]) -> Option<Vec<f64>>) -> Option<Vec<[f64; N]>> {
        let mut cols = Vec::with_capacity(N);
        for k in 0..N {
            let (mut a, mut b) = (*p, *p);
            a[k] += self.step[k];
            b[k] -= self.step[k];
            let (ra, rb) = (f(&a)?, f(&b)?);
            if ra.len() != rb.len() {
                return None;
            }
            cols.push(ra.iter().zip(&rb).map(|(x, y)| (x - y) / (2.0 * self.step[k])).collect::<Vec<_>>());
        }
        let m = cols.first().map_or(0, |c| c.len());
        if cols.iter().any(|c| c.len() != m) {
            return None;
        }
        Some((0..m).map(|i| std::array::from_fn(|k| cols[k][i])).collect())
    }

    /// Minimises Σ f(p)² from `p0` (module doc); `f` returns the whitened residuals,
    /// `None` where the model cannot be evaluated (a step there is refused). `None`
    /// where `f` fails at the start or the Jacobian cannot be taken.
    pub fn solve(&self, p0: [f64; N], f: &dyn Fn(&[f64; N]) -> Option<Vec<f64>>) -> Option<LmFit<N>> {
        let mut p = p0;
        let mut r = f(&p)?;
        let mut c = chi2(&r);
        let mut lambda = 1e-3;
        for _ in 0..self.iterations {
            let j = self.jacobian(&p, f)?;
            let (a, g) = normal(&j, &r);
            let mut improved = false;
            for _ in 0..self.tries {
                let mut m = a.clone();
                for x in 0..N {
                    m[(x, x)] *= 1.0 + lambda;
                    m[(x, x)] += self.ridge;
                }
                let Some(d) = m.lu().solve(&(-&g)) else { break };
                let q: [f64; N] = std::array::from_fn(|k| p[k] + d[k]);
                if let Some(rq) = f(&q) {
                    let cq = chi2(&rq);
                    if cq < c {
                        let small = c - cq < self.rel_tol * c.max(1e-30);
                        (p, r, c) = (q, rq, cq);
                        lambda = (lambda * 0.3).max(1e-9);
                        improved = !small;
                        break;
                    }
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        let jacobian = self.jacobian(&p, f)?;
        Some(LmFit { p, chi2: c, jacobian })
    }
}

impl<const N: usize> LmFit<N> {
    /// JᵀJ at the answer.
    pub fn jtj(&self) -> DMatrix<f64> {
        normal(&self.jacobian, &[]).0
    }

    /// χ² per degree of freedom (m residuals − N parameters; 1 where none is left).
    pub fn chi2_per_dof(&self) -> f64 {
        let dof = self.jacobian.len().saturating_sub(N);
        if dof > 0 {
            self.chi2 / dof as f64
        } else {
            1.0
        }
    }

    /// The parameters' covariance (JᵀJ)⁻¹·max(1, χ²/dof); `None` where JᵀJ is singular.
    pub fn covariance(&self) -> Option<[[f64; N]; N]> {
        let inv = self.jtj().try_inverse()?;
        let k = self.chi2_per_dof().max(1.0);
        Some(std::array::from_fn(|a| std::array::from_fn(|b| inv[(a, b)] * k)))
    }

    /// How the answer moves per unit of a bias that moves the residuals by `v`:
    /// Δp = −(JᵀJ)⁻¹Jᵀv; `None` where JᵀJ is singular.
    #[cfg_attr(not(feature = "io"), allow(dead_code))] // `locate`'s
    pub fn shift_per_unit(&self, v: &[f64]) -> Option<[f64; N]> {
        let (jtj, jtv) = normal(&self.jacobian, v);
        let dp = jtj.try_inverse()? * jtv;
        Some(std::array::from_fn(|a| -dp[a]))
    }

    /// Adds to `cov` the answer's spread under a bias shared by every residual, of 1σ
    /// `sigma`, that moves them by `v` per unit: Δp Δpᵀ σ² (module doc). Nothing where
    /// JᵀJ is singular.
    #[cfg_attr(not(feature = "io"), allow(dead_code))] // `locate`'s
    pub fn add_shared_bias(&self, cov: &mut [[f64; N]; N], v: &[f64], sigma: f64) {
        let Some(dp) = self.shift_per_unit(v) else { return };
        for a in 0..N {
            for b in 0..N {
                cov[a][b] += dp[a] * dp[b] * sigma * sigma;
            }
        }
    }
}

/// The delete-one (or delete-one-block) jackknife's 1σ of an estimate from its `k`
/// leave-one-out deviations `dev` (each from the full estimate, or any common
/// origin): √((k − 1)/k · Σ (d − d̄)²). `None` with fewer than two.
pub(crate) fn jackknife_sigma(dev: &[f64]) -> Option<f64> {
    if dev.len() < 2 {
        return None;
    }
    let k = dev.len() as f64;
    let mean = dev.iter().sum::<f64>() / k;
    Some(((k - 1.0) / k * dev.iter().map(|d| (d - mean).powi(2)).sum::<f64>()).sqrt())
}

fn chi2(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum::<f64>()
}

/// JᵀJ and Jᵀv (v zero where shorter than J).
fn normal<const N: usize>(j: &[[f64; N]], v: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
    let (mut a, mut g) = (DMatrix::zeros(N, N), DVector::zeros(N));
    for (i, row) in j.iter().enumerate() {
        let vi = v.get(i).copied();
        for x in 0..N {
            if let Some(vi) = vi {
                g[x] += row[x] * vi;
            }
            for y in 0..N {
                a[(x, y)] += row[x] * row[y];
            }
        }
    }
    (a, g)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LM: Lm<2> = Lm { step: [1e-4, 1e-4], iterations: 100, tries: 12, rel_tol: 1e-12, ridge: 0.0 };

    /// A straight line y = a + b·x through points with 1σ `s`: LM finds the weighted
    /// least-squares line, and its covariance is the textbook one, (XᵀWX)⁻¹ scaled by
    /// χ²/dof where that exceeds 1.
    #[test]
    fn a_line_fit_gives_the_analytic_solution_and_covariance() {
        let xs = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let ys = [1.1, 2.9, 5.2, 6.8, 9.1, 11.2, 12.8];
        let s = 0.1;
        let f = |p: &[f64; 2]| Some(xs.iter().zip(&ys).map(|(x, y)| (y - (p[0] + p[1] * x)) / s).collect());
        let fit = LM.solve([0.0, 0.0], &f).unwrap();
        // Normal equations by hand.
        let w = 1.0 / (s * s);
        let (s0, sx, sxx) = (w * 7.0, w * xs.iter().sum::<f64>(), w * xs.iter().map(|x| x * x).sum::<f64>());
        let (sy, sxy) = (w * ys.iter().sum::<f64>(), w * xs.iter().zip(&ys).map(|(x, y)| x * y).sum::<f64>());
        let det = s0 * sxx - sx * sx;
        let (a, b) = ((sxx * sy - sx * sxy) / det, (s0 * sxy - sx * sy) / det);
        assert!((fit.p[0] - a).abs() < 1e-9 && (fit.p[1] - b).abs() < 1e-9, "{:?} vs ({a}, {b})", fit.p);
        let chi2: f64 = xs.iter().zip(&ys).map(|(x, y)| ((y - a - b * x) / s).powi(2)).sum();
        assert!((fit.chi2 - chi2).abs() < 1e-9 * chi2, "{} vs {chi2}", fit.chi2);
        assert!((fit.chi2_per_dof() - chi2 / 5.0).abs() < 1e-9);
        let k = (chi2 / 5.0).max(1.0);
        let cov = fit.covariance().unwrap();
        let want = [[sxx / det * k, -sx / det * k], [-sx / det * k, s0 / det * k]];
        for i in 0..2 {
            for j in 0..2 {
                assert!((cov[i][j] - want[i][j]).abs() < 1e-9 * want[i][i].abs(), "C[{i}][{j}] {cov:?} vs {want:?}");
            }
        }
    }

    /// A circle through noisy points (a nonlinear fit from a poor start): the centre
    /// and radius are found, and a bias shared by every point's distance (a radius
    /// error) moves the radius alone, one for one.
    #[test]
    fn a_circle_fit_converges_and_a_shared_bias_moves_the_radius() {
        let (cx, cy, r0) = (1.5, -0.5, 2.0);
        let pts: Vec<(f64, f64)> = (0..24)
            .map(|i| {
                let t = i as f64 * std::f64::consts::TAU / 24.0;
                let e = 0.01 * ((7 * i % 5) as f64 - 2.0);
                (cx + (r0 + e) * t.cos(), cy + (r0 + e) * t.sin())
            })
            .collect();
        let f = |p: &[f64; 3]| Some(pts.iter().map(|(x, y)| ((x - p[0]).hypot(y - p[1]) - p[2]) / 0.01).collect());
        let lm = Lm { step: [1e-6; 3], iterations: 100, tries: 12, rel_tol: 1e-14, ridge: 0.0 };
        let fit = lm.solve([0.0, 0.0, 1.0], &f).unwrap();
        assert!((fit.p[0] - cx).abs() < 1e-2 && (fit.p[1] - cy).abs() < 1e-2, "{:?}", fit.p);
        // A symmetric set of deviations: the radius is their mean.
        let mean_e = (0..24).map(|i| 0.01 * ((7 * i % 5) as f64 - 2.0)).sum::<f64>() / 24.0;
        assert!((fit.p[2] - (r0 + mean_e)).abs() < 1e-3, "{:?}", fit.p);
        // Full circle, equal spacing: JᵀJ = diag(m/2, m/2, m)/σ², so σ_r² = σ²/m (× χ²/dof).
        let cov = fit.covariance().unwrap();
        let k = fit.chi2_per_dof().max(1.0);
        assert!((cov[2][2] - 1e-4 / 24.0 * k).abs() < 1e-2 * cov[2][2], "{cov:?}");
        assert!((cov[0][0] - 2e-4 / 24.0 * k).abs() < 1e-2 * cov[0][0], "{cov:?}");
        // Every distance read 1 unit long (v = 1/σ per unit): the radius moves by +1.
        let dp = fit.shift_per_unit(&[1.0 / 0.01; 24]).unwrap();
        assert!((dp[2] - 1.0).abs() < 1e-3 && dp[0].abs() < 1e-3 && dp[1].abs() < 1e-3, "{dp:?}");
        let mut c = cov;
        fit.add_shared_bias(&mut c, &[1.0 / 0.01; 24], 0.05);
        let want = dp[2] * dp[2] * 0.0025;
        assert!((c[2][2] - cov[2][2] - want).abs() < 1e-12 && (want - 0.0025).abs() < 1e-5, "{c:?}");
        assert!((c[0][0] - cov[0][0] - dp[0] * dp[0] * 0.0025).abs() < 1e-15);
    }

    /// Fewer residuals than parameters leave JᵀJ singular: no covariance; a fit with
    /// no degrees of freedom reports χ²/dof 1.
    #[test]
    fn an_undetermined_fit_has_no_covariance() {
        let f = |p: &[f64; 2]| Some(vec![p[0] + p[1] - 1.0]);
        let fit = LM.solve([0.0, 0.0], &f).unwrap();
        assert!(fit.chi2 < 1e-20);
        assert_eq!(fit.chi2_per_dof(), 1.0);
        assert!(fit.covariance().is_none());
        // A model that cannot be evaluated at the start: no answer.
        assert!(LM.solve([0.0, 0.0], &|_: &[f64; 2]| None).is_none());
    }

    /// The jackknife of a mean over k points is the standard error of that mean.
    #[test]
    fn the_jackknife_of_a_mean_is_its_standard_error() {
        let x = [1.0, 2.0, 4.0, 7.0, 11.0];
        let k = x.len() as f64;
        let mean = x.iter().sum::<f64>() / k;
        let dev: Vec<f64> = (0..x.len()).map(|j| (x.iter().sum::<f64>() - x[j]) / (k - 1.0) - mean).collect();
        let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0);
        let se = (var / k).sqrt();
        assert!((jackknife_sigma(&dev).unwrap() - se).abs() < 1e-12, "{:?} vs {se}", jackknife_sigma(&dev));
        assert!(jackknife_sigma(&[0.3]).is_none());
    }
}
