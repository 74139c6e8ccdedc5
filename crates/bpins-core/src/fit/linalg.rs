//! The small dense linear algebra a fit needs, for normal matrices of a few dozen
//! parameters: a symmetric positive-definite solve and inverse by Cholesky, and for
//! normal matrices that may be singular (parameters the data cannot tell apart) a
//! pseudo-inverse from the cyclic Jacobi eigen-decomposition of the diagonally scaled
//! matrix, which also names the degenerate directions.
//! (A crate such as nalgebra would bring a large dependency for three functions.)

/// Cholesky factor L (row-major, lower) of the n × n SPD matrix `a`; `None` if not SPD.
pub fn cholesky(a: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= l[i * n + k] * l[j * n + k];
            }
            if i == j {
                if s.is_nan() || s <= 0.0 {
                    return None;
                }
                l[i * n + i] = s.sqrt();
            } else {
                l[i * n + j] = s / l[j * n + j];
            }
        }
    }
    Some(l)
}

/// Solves L Lᵀ x = b.
pub fn cholesky_solve(l: &[f64], n: usize, b: &[f64]) -> Vec<f64> {
    let mut y = b.to_vec();
    for i in 0..n {
        for k in 0..i {
            y[i] -= l[i * n + k] * y[k];
        }
        y[i] /= l[i * n + i];
    }
    for i in (0..n).rev() {
        for k in i + 1..n {
            y[i] -= l[k * n + i] * y[k];
        }
        y[i] /= l[i * n + i];
    }
    y
}

/// Inverse of the SPD matrix with Cholesky factor `l`.
pub fn cholesky_inverse(l: &[f64], n: usize) -> Vec<f64> {
    let mut inv = vec![0.0; n * n];
    for j in 0..n {
        let mut e = vec![0.0; n];
        e[j] = 1.0;
        let col = cholesky_solve(l, n, &e);
        for i in 0..n {
            inv[i * n + j] = col[i];
        }
    }
    inv
}

/// Eigenvalues and eigenvectors (columns of the row-major `v`) of the symmetric n × n
/// matrix `a`, by cyclic Jacobi rotations (Golub & Van Loan §8.5), to machine precision.
pub fn symmetric_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut a = a.to_vec();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    for _sweep in 0..60 {
        let off: f64 = (0..n).flat_map(|i| (0..i).map(move |j| (i, j))).map(|(i, j)| a[i * n + j].powi(2)).sum();
        let diag: f64 = (0..n).map(|i| a[i * n + i].powi(2)).sum();
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                // The rotation that zeroes a[p][q].
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| a[i * n + i]).collect(), v)
}

/// Relative eigenvalue (of the diagonally scaled normal matrix, whose diagonal is 1)
/// below which a direction counts as one the data do not constrain.
pub const DEGENERATE_EIGENVALUE: f64 = 1e-9;

/// A pseudo-inverse of a symmetric positive semi-definite normal matrix.
#[derive(Clone, Debug)]
pub struct PseudoInverse {
    pub n: usize,
    /// A⁺ (row-major): the covariance of every estimable combination of parameters.
    pub inv: Vec<f64>,
    /// Unit directions the data do not constrain, in the scaled parameters p_i·√A_ii
    /// (each entry in units of that parameter's own 1σ-alone, so they compare across
    /// units): moving the parameters by D·d changes no model value to first order.
    pub null: Vec<Vec<f64>>,
}

impl PseudoInverse {
    /// The pseudo-inverse of `a`: with D = diag(A)^{−½} and D A D = V Λ Vᵀ,
    /// A⁺ = D V Λ⁺ Vᵀ D where Λ⁺ drops eigenvalues below [`DEGENERATE_EIGENVALUE`].
    /// Parameters with A_ii = 0 (no influence at all) are null directions of their own.
    pub fn new(a: &[f64], n: usize) -> Self {
        let d: Vec<f64> = (0..n).map(|i| if a[i * n + i] > 0.0 { 1.0 / a[i * n + i].sqrt() } else { 0.0 }).collect();
        let s: Vec<f64> = (0..n * n).map(|ij| a[ij] * d[ij / n] * d[ij % n]).collect();
        let (lambda, v) = symmetric_eigen(&s, n);
        let mut inv = vec![0.0; n * n];
        let mut null = Vec::new();
        for m in 0..n {
            let col: Vec<f64> = (0..n).map(|i| v[i * n + m]).collect();
            if lambda[m] > DEGENERATE_EIGENVALUE {
                for i in 0..n {
                    for j in 0..n {
                        inv[i * n + j] += d[i] * col[i] * col[j] * d[j] / lambda[m];
                    }
                }
            } else if col.iter().zip(&d).any(|(c, di)| c.abs() > 1e-6 && *di > 0.0) {
                null.push(col);
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
        (0..self.n).map(|i| (0..self.n).map(|j| self.inv[i * self.n + j] * b[j]).sum()).collect()
    }

    /// Number of constrained directions.
    pub fn rank(&self) -> usize {
        self.n - self.null.len()
    }

    /// Whether parameter `i` alone is estimable (no null direction moves it), to 1e-6.
    pub fn estimable(&self, i: usize) -> bool {
        self.null.iter().all(|d| d[i].abs() < 1e-6)
    }

    /// 1σ of parameter `i`: √A⁺_ii where estimable, else infinity.
    pub fn sigma(&self, i: usize) -> f64 {
        if self.estimable(i) {
            self.inv[i * self.n + i].max(0.0).sqrt()
        } else {
            f64::INFINITY
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_and_inverts_an_spd_matrix() {
        let a = [4.0, 2.0, 0.6, 2.0, 5.0, 1.0, 0.6, 1.0, 3.0];
        let l = cholesky(&a, 3).unwrap();
        let x = cholesky_solve(&l, 3, &[1.0, 2.0, 3.0]);
        for i in 0..3 {
            let ax: f64 = (0..3).map(|k| a[i * 3 + k] * x[k]).sum();
            assert!((ax - [1.0, 2.0, 3.0][i]).abs() < 1e-12);
        }
        let inv = cholesky_inverse(&l, 3);
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| a[i * 3 + k] * inv[k * 3 + j]).sum();
                assert!((p - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
        assert!(cholesky(&[1.0, 2.0, 2.0, 1.0], 2).is_none());
    }

    #[test]
    fn jacobi_diagonalises_a_symmetric_matrix() {
        let a = [4.0, 2.0, 0.6, 2.0, 5.0, 1.0, 0.6, 1.0, 3.0];
        let (l, v) = symmetric_eigen(&a, 3);
        for m in 0..3 {
            for i in 0..3 {
                let av: f64 = (0..3).map(|k| a[i * 3 + k] * v[k * 3 + m]).sum();
                assert!((av - l[m] * v[i * 3 + m]).abs() < 1e-12);
            }
        }
        assert!((l.iter().sum::<f64>() - 12.0).abs() < 1e-12);
    }

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
        let inv = cholesky_inverse(&cholesky(&spd, 3).unwrap(), 3);
        assert!(q.null.is_empty());
        for (x, y) in q.inv.iter().zip(&inv) {
            assert!((x - y).abs() < 1e-12);
        }
    }
}
