//! Eigen-decomposition of a symmetric 3 × 3 matrix by cyclic Jacobi rotations
//! (Golub & Van Loan, Matrix Computations, 4th ed., §8.5.2). Small and exact enough
//! for the E-vector scatter matrix; no linear-algebra crate needed for one 3 × 3.

use glam::{DMat3, DVec3};

/// Eigenvalues in ascending order and their unit eigenvectors.
#[allow(clippy::needless_range_loop)] // index form mirrors the textbook rotation
pub(crate) fn symmetric_eigen(m: DMat3) -> ([f64; 3], [DVec3; 3]) {
    let mut a = m.to_cols_array_2d(); // a[col][row]; symmetric, so a[i][j] = a[j][i]
    let mut v = DMat3::IDENTITY.to_cols_array_2d();
    for _sweep in 0..50 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let scale = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2] + off;
        if off <= 1e-30 * scale.max(f64::MIN_POSITIVE) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            // Rotation that zeroes a[p][q].
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    // v[row][k]: column k of the rotation product is eigenvector k.
    let mut pairs: [(f64, DVec3); 3] =
        std::array::from_fn(|k| (a[k][k], DVec3::new(v[0][k], v[1][k], v[2][k]).normalize()));
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    ([pairs[0].0, pairs[1].0, pairs[2].0], [pairs[0].1, pairs[1].1, pairs[2].1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_decomposition() {
        let r = DMat3::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 0.7);
        let d = DMat3::from_diagonal(DVec3::new(5.0, 1e-6, 2.0));
        let m = r * d * r.transpose();
        let (vals, vecs) = symmetric_eigen(m);
        assert!((vals[0] - 1e-6).abs() < 1e-12 && (vals[1] - 2.0).abs() < 1e-12 && (vals[2] - 5.0).abs() < 1e-12);
        for (val, vec) in vals.iter().zip(vecs) {
            assert!((m * vec - vec * *val).length() < 1e-12);
        }
    }

    #[test]
    fn diagonal_input_is_returned_sorted() {
        let (vals, vecs) = symmetric_eigen(DMat3::from_diagonal(DVec3::new(3.0, 1.0, 2.0)));
        assert_eq!(vals, [1.0, 2.0, 3.0]);
        assert_eq!(vecs[0].y.abs(), 1.0);
    }
}
