//! The block pseudo-inverse against the dense one ([`PseudoInverse`]) on seeded random
//! block-arrow systems JᵀJ: full rank, and singular in the ways a fit is (a global
//! traded against every frame's nuisance, a frame's own degeneracy, a parameter
//! without influence).

use super::*;
use crate::fit::solver::linalg::PseudoInverse;

/// splitmix64: a seeded uniform in [−1, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// A block-arrow JᵀJ, Jᵀr: `n_g` globals, frames of `sizes` nuisances, 40 rows per
/// frame; columns in units from 1e-3 to 1e3. `shape(frame, rows × columns)` edits
/// each frame's Jacobian (globals first) before the sums.
fn system(seed: u64, n_g: usize, sizes: &[usize], shape: impl Fn(usize, &mut [Vec<f64>])) -> (Vec<f64>, Vec<f64>) {
    let mut rng = Rng(seed);
    let n = n_g + sizes.iter().sum::<usize>();
    let unit: Vec<f64> = (0..n).map(|_| 10f64.powf(3.0 * rng.next())).collect();
    let (mut a, mut b) = (vec![0.0; n * n], vec![0.0; n]);
    let mut start = n_g;
    for (k, &nl) in sizes.iter().enumerate() {
        let cols: Vec<usize> = (0..n_g).chain(start..start + nl).collect();
        let mut j: Vec<Vec<f64>> = (0..40).map(|_| cols.iter().map(|&c| rng.next() * unit[c]).collect()).collect();
        shape(k, &mut j);
        for row in &j {
            let r = rng.next();
            for (x, &cx) in cols.iter().enumerate() {
                b[cx] += row[x] * r;
                for (y, &cy) in cols.iter().enumerate() {
                    a[cx * n + cy] += row[x] * row[y];
                }
            }
        }
        start += nl;
    }
    (a, b)
}

/// Relative difference, 0 for two infinities.
fn rel(x: f64, y: f64, scale: f64) -> f64 {
    if x.is_infinite() && y.is_infinite() {
        0.0
    } else {
        (x - y).abs() / scale
    }
}

/// Compares every figure the fit reads of the two pseudo-inverses.
fn compare(a: &[f64], b: &[f64], n_g: usize, sizes: &[usize]) -> (PseudoInverse, BlockInverse) {
    let n = b.len();
    let dense = PseudoInverse::new(a, n);
    let sys = BlockSystem::from_dense(a, b, n_g, sizes);
    let blk = BlockInverse::new(&sys);
    assert_eq!(blk.rank(), dense.rank(), "rank");
    let (xd, xb) = (dense.solve(b), blk.solve(b));
    for i in 0..n {
        // Each parameter against its own scale (the units differ by 10⁶).
        let scale = (dense.inv[(i, i)].abs().sqrt() * b.iter().map(|x| x * x).sum::<f64>().sqrt()).max(1e-300);
        assert!(rel(xd[i], xb[i], scale.max(xd[i].abs())) < 1e-9, "solve {i}: {} vs {}", xd[i], xb[i]);
        assert_eq!(dense.estimable(i), blk.estimable(i), "estimable {i}");
        let (sd, sb) = (dense.sigma(i), blk.sigma(i));
        assert!(rel(sd, sb, sd) < 1e-9, "sigma {i}: {sd} vs {sb}");
    }
    // The same null space: the projectors Σ z zᵀ agree.
    let proj = |null: &[Vec<f64>]| DMatrix::from_fn(n, n, |i, j| null.iter().map(|z| z[i] * z[j]).sum::<f64>());
    let (pd, pb) = (proj(&dense.null), proj(&blk.null));
    assert!((pd - pb).abs().max() < 1e-8, "null spaces differ");
    // The globals' covariance where estimable.
    let cov = blk.global_cov();
    for i in (0..n_g).filter(|&i| dense.estimable(i)) {
        for j in (0..n_g).filter(|&j| dense.estimable(j)) {
            let s = (dense.inv[(i, i)] * dense.inv[(j, j)]).sqrt();
            assert!(rel(cov[(i, j)], dense.inv[(i, j)], s) < 1e-9, "cov {i},{j}");
        }
    }
    (dense, blk)
}

#[test]
fn full_rank_block_arrow_matches_the_dense_pseudo_inverse() {
    let sizes = [5, 4, 5, 3, 5, 5];
    let (a, b) = system(7, 4, &sizes, |_, _| {});
    let (dense, blk) = compare(&a, &b, 4, &sizes);
    assert!(dense.null.is_empty() && blk.null.is_empty());
    let sys = BlockSystem::from_dense(&a, &b, 4, &sizes);
    // Damped, as LM solves it: still the same.
    let damped = sys.damped(0.1);
    let dd = PseudoInverse::new(&damped.dense(), sys.n());
    let (xd, xb) = (dd.solve(&b), BlockInverse::new(&damped).solve(&b));
    for (x, y) in xd.iter().zip(&xb) {
        assert!((x - y).abs() <= 1e-9 * x.abs().max(1e-300), "{x} vs {y}");
    }
}

/// Global 0 is each frame's nuisance 0 times a frame factor (a global rotation
/// against every heading); frame 1's nuisances 1 and 2 enter only as a sum (its own
/// degeneracy); with `dead`, frame 2's nuisance 3 and global 3 have no influence.
fn singular(dead: bool) -> (Vec<f64>, Vec<f64>) {
    system(11, 4, &[5, 5, 4, 5], |k, j| {
        for row in j.iter_mut() {
            row[0] = row[4] * (1.0 + 0.5 * k as f64);
            if k == 1 {
                row[6] = 3.0 * row[5];
            }
            if dead {
                row[3] = 0.0;
                if k == 2 {
                    row[7] = 0.0;
                }
            }
        }
    })
}

#[test]
fn singular_block_arrow_matches_the_dense_pseudo_inverse_and_names_the_same_nulls() {
    let sizes = [5, 5, 4, 5];
    let (a, b) = singular(false);
    let (dense, blk) = compare(&a, &b, 4, &sizes);
    // Global rotation ↔ headings, and frame 1's pair.
    assert_eq!((dense.null.len(), blk.null.len()), (2, 2));
    // The trade moves global 0 and every frame's heading: none of them estimable.
    let headings = [4, 9, 14, 18];
    assert!(blk.null[0][0].abs() > 0.1 && headings.iter().all(|&h| blk.null[0][h].abs() > 1e-6), "{:?}", blk.null[0]);
    assert!(headings.iter().chain(&[0, 10, 11]).all(|&i| !blk.estimable(i) && blk.sigma(i).is_infinite()));
    assert!(blk.estimable(1) && blk.estimable(12) && blk.sigma(12).is_finite());
}

#[test]
fn parameters_without_influence_are_null_directions_of_their_own() {
    // The dense path's eigenvectors of the exact zero eigenvalues mix the parameters
    // without influence into the other degenerate directions and count them twice
    // (6 null directions here, for a null space of dimension 4); the block path keeps
    // them apart. Against the dense path on the others, then the four directions.
    let sizes = [5, 5, 4, 5];
    let (a, b) = singular(true);
    let n = b.len();
    let keep: Vec<usize> = (0..n).filter(|&i| i != 3 && i != 17).collect();
    let a_kept: Vec<f64> =
        keep.iter().flat_map(|&i| keep.iter().map(move |&j| (i, j))).map(|(i, j)| a[i * n + j]).collect();
    let b_kept: Vec<f64> = keep.iter().map(|&i| b[i]).collect();
    compare(&a_kept, &b_kept, 3, &[5, 5, 3, 5]);
    let blk = BlockInverse::new(&BlockSystem::from_dense(&a, &b, 4, &sizes));
    let kept = BlockInverse::new(&BlockSystem::from_dense(&a_kept, &b_kept, 3, &[5, 5, 3, 5]));
    assert_eq!(blk.null.len(), 4);
    assert_eq!(blk.rank(), kept.rank());
    for i in [3, 17] {
        assert!(blk.null.iter().any(|z| z[i] == 1.0) && blk.sigma(i).is_infinite());
    }
    // Their step is zero, the others' the same as without them.
    let (x, xk) = (blk.solve(&b), kept.solve(&b_kept));
    assert!(x[3] == 0.0 && x[17] == 0.0);
    for (j, &i) in keep.iter().enumerate() {
        assert!((x[i] - xk[j]).abs() <= 1e-12 * xk[j].abs().max(1e-300), "{i}");
    }
}

#[test]
fn no_frames_is_the_dense_pseudo_inverse_and_a_non_finite_system_constrains_nothing() {
    let (a, b) = system(3, 6, &[], |_, _| {});
    compare(&a, &b, 6, &[]);
    let (mut a, b) = system(5, 2, &[3, 3], |_, _| {});
    a[2 * 8 + 2] = f64::NAN;
    let blk = BlockInverse::new(&BlockSystem::from_dense(&a, &b, 2, &[3, 3]));
    assert_eq!(blk.rank(), 0);
    assert!(blk.sigma(0).is_infinite() && blk.solve(&b).iter().all(|&x| x == 0.0));
}
