//! The pseudo-inverse a fit needs for normal matrices of a few dozen parameters that
//! may be singular (parameters the data cannot tell apart): from the symmetric
//! eigen-decomposition (nalgebra) of the diagonally scaled matrix, which also names
//! the degenerate directions.

use nalgebra::{DMatrix, DVector};

/// Relative eigenvalue (of the diagonally scaled normal matrix, whose diagonal is 1)
/// below which a direction counts as one the data do not constrain.
pub const DEGENERATE_EIGENVALUE: f64 = 1e-9;

/// A pseudo-inverse of a symmetric positive semi-definite normal matrix.
#[derive(Clone, Debug)]
pub struct PseudoInverse {
    pub n: usize,
    /// A⁺: the covariance of every estimable combination of parameters.
    pub inv: DMatrix<f64>,
    /// Unit directions the data do not constrain, in the scaled parameters p_i·√A_ii
    /// (each entry in units of that parameter's own 1σ-alone, so they compare across
    /// units): moving the parameters by D·d changes no model value to first order.
    pub null: Vec<Vec<f64>>,
}

impl PseudoInverse {
    /// The pseudo-inverse of the row-major n × n `a`: with D = diag(A)^{−½} and
    /// D A D = V Λ Vᵀ, A⁺ = D V Λ⁺ Vᵀ D where Λ⁺ drops eigenvalues below
    /// [`DEGENERATE_EIGENVALUE`]. Parameters with A_ii = 0 (no influence at all) are
    /// null directions of their own.
    pub fn new(a: &[f64], n: usize) -> Self {
        let a = DMatrix::from_row_slice(n, n, a);
        let d = DVector::from_iterator(n, (0..n).map(|i| if a[(i, i)] > 0.0 { 1.0 / a[(i, i)].sqrt() } else { 0.0 }));
        let s = DMatrix::from_fn(n, n, |i, j| a[(i, j)] * d[i] * d[j]);
        let mut inv = DMatrix::zeros(n, n);
        let mut null = Vec::new();
        // A non-finite matrix (or no convergence) constrains nothing.
        let finite = s.iter().all(|x| x.is_finite());
        let Some(eig) = s.try_symmetric_eigen(f64::EPSILON, 10_000).filter(|_| finite) else {
            let null = (0..n).map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect()).collect();
            return PseudoInverse { n, inv, null };
        };
        for (m, &lambda) in eig.eigenvalues.iter().enumerate() {
            let col = eig.eigenvectors.column(m);
            if lambda > DEGENERATE_EIGENVALUE {
                let dc = col.component_mul(&d);
                inv += &dc * dc.transpose() / lambda;
            } else if col.iter().zip(d.iter()).any(|(c, di)| c.abs() > 1e-6 && *di > 0.0) {
                null.push(col.iter().copied().collect());
            }
        }
        for (i, di) in d.iter().enumerate() {
            if *di == 0.0 {
                let mut e = vec![0.0; n];
                e[i] = 1.0;
                null.push(e);
            }
        }
        PseudoInverse { n, inv, null }
    }

    /// A⁺ b: the minimum-norm (in the scaled parameters) least-squares solution.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        (&self.inv * DVector::from_column_slice(b)).iter().copied().collect()
    }

    /// Number of constrained directions.
    pub fn rank(&self) -> usize {
        self.n - self.null.len()
    }

    /// Whether parameter `i` alone is estimable ([`estimable`]).
    pub fn estimable(&self, i: usize) -> bool {
        estimable(&self.null, i)
    }

    /// 1σ of parameter `i`: √A⁺_ii where estimable, else infinity ([`sigma`]).
    pub fn sigma(&self, i: usize) -> f64 {
        sigma(&self.null, i, self.inv[(i, i)])
    }
}

/// Whether parameter `i` alone is estimable: no direction of `null` (unit, scaled
/// parameters) moves it, to 1e-6 — the rule of both pseudo-inverses (this dense one
/// and `schur::BlockInverse`).
pub fn estimable(null: &[Vec<f64>], i: usize) -> bool {
    null.iter().all(|d| d[i].abs() < 1e-6)
}

/// 1σ of parameter `i` from its variance `var` (A⁺_ii): √var where [`estimable`], else
/// infinity.
pub fn sigma(null: &[Vec<f64>], i: usize, var: f64) -> f64 {
    if estimable(null, i) {
        var.max(0.0).sqrt()
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pseudo_inverse_names_the_degenerate_combination() {
        // Parameters 0 and 1 enter only as their sum (columns equal, different units);
        // parameter 2 is independent.
        let cols = [[1.0, 2.0, 0.0, 1.0], [1.0, 2.0, 0.0, 1.0], [0.5, 0.0, 1.0, 3.0]];
        let scale = [1.0, 1000.0, 1.0];
        let n = 3;
        let mut a = vec![0.0; 9];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = (0..4).map(|r| cols[i][r] / scale[i] * cols[j][r] / scale[j]).sum();
            }
        }
        let p = PseudoInverse::new(&a, n);
        assert_eq!(p.rank(), 2);
        assert_eq!(p.null.len(), 1);
        assert!(!p.estimable(0) && !p.estimable(1) && p.estimable(2));
        assert!(p.sigma(0).is_infinite() && p.sigma(2).is_finite());
        // In the scaled parameters the null direction is (1, −1, 0)/√2: it moves the
        // sum p0 + p1/1000 not at all.
        let d = &p.null[0];
        assert!((d[0] + d[1]).abs() < 1e-9 && (d[0].abs() - 0.5f64.sqrt()).abs() < 1e-9 && d[2].abs() < 1e-9, "{d:?}");
        // A A⁺ b = b for b in the range of A.
        let b: Vec<f64> = (0..n).map(|i| a[i * n] * 0.3 + a[i * n + 2] * -1.2).collect();
        let x = p.solve(&b);
        for i in 0..n {
            let ax: f64 = (0..n).map(|k| a[i * n + k] * x[k]).sum();
            assert!((ax - b[i]).abs() < 1e-9, "{ax} vs {}", b[i]);
        }
        // Full rank: the pseudo-inverse is the inverse.
        let spd = [4.0, 2.0, 0.6, 2.0, 5.0, 1.0, 0.6, 1.0, 3.0];
        let q = PseudoInverse::new(&spd, 3);
        let inv = DMatrix::from_row_slice(3, 3, &spd).try_inverse().unwrap();
        assert!(q.null.is_empty());
        for (x, y) in q.inv.iter().zip(inv.iter()) {
            assert!((x - y).abs() < 1e-12);
        }
    }
}
