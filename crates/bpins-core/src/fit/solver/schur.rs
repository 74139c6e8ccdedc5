//! The pseudo-inverse of a block-arrow normal matrix ([`BlockSystem`]) by the Schur
//! complement over the frames' blocks (the reduced camera system of bundle
//! adjustment), giving what [`crate::fit::solver::linalg::PseudoInverse`] gives for the dense matrix
//! — the minimum-norm solution, each parameter's 1σ, the degenerate directions, the
//! rank — in time O(F·n_l³ + F·n_l·n_g² + n_g³) and memory linear in the frames.
//!
//! In the diagonally scaled parameters (D = diag(A)^{−½}, Â = D A D, as the dense
//! path; a parameter with A_ii = 0 is a null direction of its own and is left out):
//!
//! ```text
//! Â_kk = U Λ Uᵀ,  Â_kk⁺ = U Λ⁺ Uᵀ (eigenvalues ≤ 1e-9 dropped: the frame's own
//!                  degenerate directions, u padded with zeros, are null directions of Â)
//! P_k  = Â_kk⁺ Â_kg                      (n_l × n_g: frame k's response to the globals)
//! S    = Â_gg − Σ_k Â_gk P_k             (the Schur complement, n_g × n_g)
//! B    = I + Σ_k P_kᵀ P_k                (the metric of a global move with every frame
//!                                        following it: |(x_g, −P x_g)|² = x_gᵀ B x_g)
//! S v = μ B v,  vᵀ B v = 1               (generalized eigenproblem, by Cholesky of B)
//! S⁺ = Σ_{μ > 1e-9} v vᵀ / μ             (μ ≈ the dense eigenvalue of the direction
//!                                        z = (v, −P_1 v, …, −P_F v), exact where μ = 0)
//! G  = ⎡ S⁺        −S⁺ Pᵀ          ⎤    a generalized inverse of Â (Â G Â = Â)
//!      ⎣ −P S⁺   Â_kk⁺ + P S⁺ Pᵀ  ⎦
//! Â⁺ = Π G Π,  Π = I − Σ z zᵀ            (the Moore–Penrose inverse, the dense path's;
//!                                        the z over μ ≤ 1e-9 are orthonormal)
//! ```
//!
//! G z = 0 for a frame's own null direction, so only the few directions z through
//! the globals enter Π; the solution Â⁺ b̂ and the diagonal of Â⁺ (each parameter's
//! variance) are then formed block by block, never the n × n matrix. A direction that
//! trades a global against every frame's nuisance (a global rotation against every
//! heading) is a μ = 0 of S and is reported with its frames' part; a frame's own
//! (its scale and a radiance coefficient telling nothing apart) with its frame alone.

use crate::fit::solver::block::BlockSystem;
use crate::fit::solver::linalg::DEGENERATE_EIGENVALUE;
use nalgebra::{DMatrix, DVector};

/// The pseudo-inverse of a [`BlockSystem`], held by blocks.
#[derive(Clone, Debug)]
pub struct BlockInverse {
    pub n: usize,
    n_g: usize,
    /// D: 1/√A_ii, 0 where A_ii = 0 (or everywhere, where the matrix is not finite).
    d: Vec<f64>,
    /// Each frame's first position and its Â_kk⁺ and P_k (scaled).
    starts: Vec<usize>,
    kk_pinv: Vec<DMatrix<f64>>,
    p: Vec<DMatrix<f64>>,
    /// S⁺ (scaled, n_g × n_g; zero on globals without influence).
    s_pinv: DMatrix<f64>,
    /// The null directions through the globals (z above) and G z for each.
    lifted: Vec<(Vec<f64>, Vec<f64>)>,
    /// Unit directions the data do not constrain, in the scaled parameters, as
    /// [`crate::fit::solver::linalg::PseudoInverse::null`]: the lifted ones, each frame's own,
    /// then one per parameter without influence.
    pub null: Vec<Vec<f64>>,
    /// The diagonal of Â⁺ (scaled).
    diag: Vec<f64>,
}

/// The eigen-decomposition of symmetric `m`, or `None` where it is not finite or does
/// not converge.
fn eigen(m: DMatrix<f64>) -> Option<nalgebra::SymmetricEigen<f64, nalgebra::Dyn>> {
    m.iter().all(|x| x.is_finite()).then_some(())?;
    m.try_symmetric_eigen(f64::EPSILON, 10_000)
}

impl BlockInverse {
    /// The pseudo-inverse of `sys` (see the module's notes).
    pub fn new(sys: &BlockSystem) -> BlockInverse {
        Self::try_new(sys).unwrap_or_else(|| {
            // A non-finite matrix (or no convergence) constrains nothing.
            let n = sys.n();
            let null = (0..n).map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect()).collect();
            let mut empty = Self::empty(sys);
            empty.null = null;
            empty
        })
    }

    fn empty(sys: &BlockSystem) -> BlockInverse {
        let n_g = sys.n_g;
        BlockInverse {
            n: sys.n(),
            n_g,
            d: vec![0.0; sys.n()],
            starts: sys.frames.iter().map(|f| f.start).collect(),
            kk_pinv: sys.frames.iter().map(|f| DMatrix::zeros(f.n(), f.n())).collect(),
            p: sys.frames.iter().map(|f| DMatrix::zeros(f.n(), n_g)).collect(),
            s_pinv: DMatrix::zeros(n_g, n_g),
            lifted: Vec::new(),
            null: Vec::new(),
            diag: vec![0.0; sys.n()],
        }
    }

    fn try_new(sys: &BlockSystem) -> Option<BlockInverse> {
        let (n, n_g) = (sys.n(), sys.n_g);
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !finite(&sys.a_gg) || !sys.frames.iter().all(|f| finite(&f.a_kk) && finite(&f.a_gk)) {
            return None;
        }
        let mut out = Self::empty(sys);
        let diag_of = |i: usize| sys.get(i, i);
        out.d = (0..n).map(|i| if diag_of(i) > 0.0 { 1.0 / diag_of(i).sqrt() } else { 0.0 }).collect();
        let d = out.d.clone();
        let dg = &d[..n_g];
        let a_gg = DMatrix::from_fn(n_g, n_g, |i, j| sys.a_gg[i * n_g + j] * dg[i] * dg[j]);
        let mut s = a_gg;
        let mut b = DMatrix::<f64>::identity(n_g, n_g);
        let mut frame_null = Vec::new();
        for (k, f) in sys.frames.iter().enumerate() {
            let (nl, dk) = (f.n(), &d[f.start..f.start + f.n()]);
            // Only the nuisances with influence enter the eigen-decomposition.
            let act: Vec<usize> = (0..nl).filter(|&l| dk[l] > 0.0).collect();
            let m =
                DMatrix::from_fn(act.len(), act.len(), |a, c| f.a_kk[act[a] * nl + act[c]] * dk[act[a]] * dk[act[c]]);
            let eig = eigen(m)?;
            let mut pinv = DMatrix::zeros(nl, nl);
            for (e, &lambda) in eig.eigenvalues.iter().enumerate() {
                let u = eig.eigenvectors.column(e);
                if lambda > DEGENERATE_EIGENVALUE {
                    for (a, &ia) in act.iter().enumerate() {
                        for (c, &ic) in act.iter().enumerate() {
                            pinv[(ia, ic)] += u[a] * u[c] / lambda;
                        }
                    }
                } else {
                    let mut z = vec![0.0; n];
                    for (a, &ia) in act.iter().enumerate() {
                        z[f.start + ia] = u[a];
                    }
                    frame_null.push(z);
                }
            }
            let a_kg = DMatrix::from_fn(nl, n_g, |l, g| f.a_gk[g * nl + l] * dk[l] * dg[g]);
            let p = &pinv * &a_kg;
            s -= a_kg.transpose() * &p;
            b += p.transpose() * &p;
            out.kk_pinv[k] = pinv;
            out.p[k] = p;
        }
        // The generalized eigenproblem S v = μ B v over the globals with influence:
        // C = L⁻¹ S L⁻ᵀ (B = L Lᵀ), C w = μ w, v = L⁻ᵀ w.
        let act: Vec<usize> = (0..n_g).filter(|&g| dg[g] > 0.0).collect();
        let sub = |m: &DMatrix<f64>| DMatrix::from_fn(act.len(), act.len(), |i, j| m[(act[i], act[j])]);
        let (s_a, b_a) = (sub(&s), sub(&b));
        if !act.is_empty() {
            let l = b_a.clone().cholesky()?.l();
            let l_inv = l.try_inverse()?;
            let c = &l_inv * s_a * l_inv.transpose();
            let c = (&c + c.transpose()) * 0.5;
            let eig = eigen(c)?;
            let v_all = l_inv.transpose() * &eig.eigenvectors;
            for (e, &mu) in eig.eigenvalues.iter().enumerate() {
                let mut v = DVector::zeros(n_g);
                for (i, &g) in act.iter().enumerate() {
                    v[g] = v_all[(i, e)];
                }
                if mu > DEGENERATE_EIGENVALUE {
                    out.s_pinv += &v * v.transpose() / mu;
                } else {
                    // z = (v, −P_1 v, …, −P_F v): a move of the globals with every frame
                    // following it that changes no model value.
                    let mut z = vec![0.0; n];
                    z[..n_g].copy_from_slice(v.as_slice());
                    for (k, p) in out.p.iter().enumerate() {
                        let pv = p * &v;
                        for (l, x) in pv.iter().enumerate() {
                            z[out.starts[k] + l] = -x;
                        }
                    }
                    out.null.push(z);
                }
            }
        }
        out.lifted = out.null.iter().map(|z| (z.clone(), out.apply_g(z))).collect();
        out.null.extend(frame_null);
        out.null.extend((0..n).filter(|&i| d[i] == 0.0).map(|i| {
            let mut e = vec![0.0; n];
            e[i] = 1.0;
            e
        }));
        out.diag = out.pinv_diagonal(sys);
        Some(out)
    }

    /// G x̂ (scaled, unprojected; see the module's notes).
    fn apply_g(&self, x: &[f64]) -> Vec<f64> {
        let n_g = self.n_g;
        let mut r = DVector::from_column_slice(&x[..n_g]);
        let xk: Vec<DVector<f64>> = self
            .starts
            .iter()
            .zip(&self.kk_pinv)
            .map(|(&s, m)| DVector::from_column_slice(&x[s..s + m.nrows()]))
            .collect();
        for (p, xk) in self.p.iter().zip(&xk) {
            r -= p.transpose() * xk;
        }
        let yg = &self.s_pinv * r;
        let mut y = vec![0.0; self.n];
        y[..n_g].copy_from_slice(yg.as_slice());
        for (k, xk) in xk.iter().enumerate() {
            let yk = &self.kk_pinv[k] * xk - &self.p[k] * &yg;
            y[self.starts[k]..self.starts[k] + yk.len()].copy_from_slice(yk.as_slice());
        }
        y
    }

    /// Π x̂: x̂ with its part along the lifted null directions removed.
    fn project(&self, x: &mut [f64]) {
        for (z, _) in &self.lifted {
            let c: f64 = z.iter().zip(x.iter()).map(|(a, b)| a * b).sum();
            x.iter_mut().zip(z).for_each(|(x, z)| *x -= c * z);
        }
    }

    /// The diagonal of Â⁺ = Π G Π: G_ii − 2 Σ_m z_m,i (G z_m)_i + Σ z_m,i z_m',i z_mᵀ G z_m'.
    fn pinv_diagonal(&self, sys: &BlockSystem) -> Vec<f64> {
        let n_g = self.n_g;
        let mut diag = vec![0.0; self.n];
        for (g, dg) in diag.iter_mut().enumerate().take(n_g) {
            *dg = self.s_pinv[(g, g)];
        }
        for (k, f) in sys.frames.iter().enumerate() {
            let ps = &self.p[k] * &self.s_pinv;
            for l in 0..f.n() {
                let quad: f64 = (0..n_g).map(|g| ps[(l, g)] * self.p[k][(l, g)]).sum();
                diag[f.start + l] = self.kk_pinv[k][(l, l)] + quad;
            }
        }
        let m = self.lifted.len();
        let ztgz = DMatrix::from_fn(m, m, |a, c| {
            self.lifted[a].0.iter().zip(&self.lifted[c].1).map(|(x, y)| x * y).sum::<f64>()
        });
        for (i, di) in diag.iter_mut().enumerate() {
            for a in 0..m {
                let (za, gza) = (&self.lifted[a].0, &self.lifted[a].1);
                *di -= 2.0 * za[i] * gza[i];
                for c in 0..m {
                    *di += za[i] * self.lifted[c].0[i] * ztgz[(a, c)];
                }
            }
        }
        diag
    }

    /// A⁺ b: the minimum-norm (in the scaled parameters) least-squares solution.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x: Vec<f64> = b.iter().zip(&self.d).map(|(b, d)| b * d).collect();
        self.project(&mut x);
        let mut y = self.apply_g(&x);
        self.project(&mut y);
        y.iter().zip(&self.d).map(|(y, d)| y * d).collect()
    }

    /// Number of constrained directions.
    pub fn rank(&self) -> usize {
        self.n - self.null.len()
    }

    /// Whether parameter `i` alone is estimable (`linalg::estimable`).
    pub fn estimable(&self, i: usize) -> bool {
        crate::fit::solver::linalg::estimable(&self.null, i)
    }

    /// 1σ of parameter `i`: √A⁺_ii where estimable, else infinity (`linalg::sigma`).
    pub fn sigma(&self, i: usize) -> f64 {
        crate::fit::solver::linalg::sigma(&self.null, i, self.d[i] * self.d[i] * self.diag[i])
    }

    /// The globals' block of A⁺ (n_g × n_g, in the parameters' own units): the
    /// covariance of the effects' parameters, S⁺ with the lifted null directions
    /// projected out.
    pub fn global_cov(&self) -> DMatrix<f64> {
        let n_g = self.n_g;
        let mut out = DMatrix::zeros(n_g, n_g);
        for j in 0..n_g {
            // Column j of A⁺ = D Â⁺ D: Â⁺ applied to D e_j.
            let mut x = vec![0.0; self.n];
            x[j] = self.d[j];
            self.project(&mut x);
            let mut y = self.apply_g(&x);
            self.project(&mut y);
            for i in 0..n_g {
                out[(i, j)] = y[i] * self.d[i];
            }
        }
        out
    }
}

#[cfg(test)]
#[path = "schur_tests.rs"]
mod tests;
