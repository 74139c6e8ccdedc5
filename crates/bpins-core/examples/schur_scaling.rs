//! Time and memory of the fit's normal-equation solve as frames are added: the block
//! pseudo-inverse (`fit::schur`, Schur complement over the frames' blocks) against
//! the dense one (`fit::linalg::PseudoInverse`) on a seeded random block-arrow JᵀJ of
//! `n_g` effect parameters and 16 nuisances a frame (BENCHMARKS.md, issue 21).
//!
//! `cargo run --release -p bpins-core --example schur_scaling -- [n_g] [frames…]`

use bpins_core::internal::fit::solver::block::BlockSystem;
use bpins_core::internal::fit::solver::linalg::PseudoInverse;
use bpins_core::internal::fit::solver::schur::BlockInverse;
use std::time::Instant;

/// splitmix64: a seeded uniform in [−1, 1).
fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// A block-arrow JᵀJ and Jᵀr from 64 random rows per frame.
fn system(n_g: usize, frames: usize, n_l: usize, seed: u64) -> BlockSystem {
    let mut s = BlockSystem::zeros(n_g, &vec![n_l; frames]);
    let mut st = seed;
    let n = n_g + n_l;
    for f in &mut s.frames {
        for _ in 0..64 {
            let row: Vec<f64> = (0..n).map(|_| uniform(&mut st)).collect();
            let r = uniform(&mut st);
            for a in 0..n {
                if a < n_g {
                    s.b_g[a] += row[a] * r;
                } else {
                    f.b_k[a - n_g] += row[a] * r;
                }
                for c in 0..n {
                    let v = row[a] * row[c];
                    match (a < n_g, c < n_g) {
                        (true, true) => s.a_gg[a * n_g + c] += v,
                        (true, false) => f.a_gk[a * n_l + c - n_g] += v,
                        (false, false) => f.a_kk[(a - n_g) * n_l + c - n_g] += v,
                        (false, true) => {}
                    }
                }
            }
        }
    }
    s
}

fn main() {
    let args: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let n_g = args.first().copied().unwrap_or(30);
    let frames = if args.len() > 1 { args[1..].to_vec() } else { vec![8, 48, 200, 1000, 10_000] };
    println!("n_g {n_g}, 16 nuisances a frame; seconds per pseudo-inverse and solve (median of 3)");
    for f in frames {
        let sys = system(n_g, f, 16, 1);
        let b = sys.b();
        let n = sys.n();
        let time = |run: &dyn Fn() -> Vec<f64>| {
            let mut t: Vec<(f64, Vec<f64>)> = (0..3)
                .map(|_| {
                    let t0 = Instant::now();
                    let x = run();
                    (t0.elapsed().as_secs_f64(), x)
                })
                .collect();
            t.sort_by(|a, b| a.0.total_cmp(&b.0));
            t.swap_remove(1)
        };
        let (tb, xb) = time(&|| BlockInverse::new(&sys).solve(&b));
        // The dense matrix: n² doubles; its eigen-decomposition O(n³).
        let dense_mb = (n * n * 8) as f64 / 1e6;
        if n <= 2000 {
            let a = sys.dense();
            let (td, xd) = time(&|| PseudoInverse::new(&a, n).solve(&b));
            let diff = xb.iter().zip(&xd).map(|(p, q)| (p - q).abs() / q.abs().max(1e-12)).fold(0.0, f64::max);
            println!("{f:>6} frames, n {n:>6}: block {tb:.4} s, dense {td:.3} s ({dense_mb:.1} MB), max rel. difference {diff:.1e}");
        } else {
            println!("{f:>6} frames, n {n:>6}: block {tb:.4} s, dense not run ({dense_mb:.0} MB matrix)");
        }
    }
}
