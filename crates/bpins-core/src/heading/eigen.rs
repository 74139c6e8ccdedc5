//! Eigen-decomposition of a symmetric 3 × 3 matrix (the E-vector scatter matrix):
//! nalgebra's symmetric QR algorithm, its results sorted and returned as glam vectors.
//! (A non-finite matrix gives NaN: an unbounded iteration must never see one.)

use glam::{DMat3, DVec3};

/// Eigenvalues in ascending order and their unit eigenvectors.
pub(crate) fn symmetric_eigen(m: DMat3) -> ([f64; 3], [DVec3; 3]) {
    let a = nalgebra::Matrix3::from_fn(|i, j| m.col(j)[i]);
    // Non-finite input (or no convergence) gives NaN, which the caller refuses.
    let Some(eig) = a.try_symmetric_eigen(f64::EPSILON, 1000).filter(|_| a.iter().all(|x| x.is_finite())) else {
        return ([f64::NAN; 3], [DVec3::NAN; 3]);
    };
    let mut pairs: [(f64, DVec3); 3] = std::array::from_fn(|k| {
        let v = eig.eigenvectors.column(k);
        (eig.eigenvalues[k], DVec3::new(v[0], v[1], v[2]).normalize())
    });
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
