//! The normal equations of a fit as a block-arrow system, the way bundle adjustment
//! keeps them: the effects' parameters (global, n_g) couple to every frame, each
//! frame's nuisances (n_l ≈ 16: heading, scale, d_max, radiance coefficients) only to
//! themselves and to the globals.
//!
//! ```text
//!         ⎡ A_gg  A_g1  A_g2  …  A_gF ⎤        ⎡ b_g ⎤
//! JᵀWJ =  ⎢ A_1g  A_11                ⎥  JᵀWr = ⎢ b_1 ⎥   (free-slot order: the
//!         ⎢ A_2g        A_22          ⎥        ⎢ b_2 ⎥    globals, then frame 0's
//!         ⎣ A_Fg                A_FF  ⎦        ⎣ b_F ⎦    own slots, frame 1's, …)
//! ```
//!
//! Only the blocks are held: A_gg (n_g × n_g), and per frame A_kk (n_l × n_l), A_gk
//! (n_g × n_l) and b_k — memory O(F·(n_g·n_l + n_l²) + n_g²) where the dense matrix
//! was O((n_g + F·n_l)²) (5 MB at 48 frames, 2 GB at 1 000). The pseudo-inverse of the
//! system is formed by eliminating each frame's block (the Schur complement,
//! [`crate::fit::solver::schur`]).

/// One frame's blocks of the normal equations, in the frame's free nuisances.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameBlock {
    /// Position of the frame's first free nuisance in the free-slot order; its others
    /// follow.
    pub start: usize,
    /// A_kk: n_l × n_l, row-major.
    pub a_kk: Vec<f64>,
    /// A_gk: n_g × n_l, row-major (row g: global g against the frame's nuisances).
    pub a_gk: Vec<f64>,
    /// b_k (JᵀWr over the frame's nuisances).
    pub b_k: Vec<f64>,
}

impl FrameBlock {
    /// Number of the frame's free nuisances, n_l.
    pub fn n(&self) -> usize {
        self.b_k.len()
    }
}

/// The block-arrow normal equations: JᵀWJ and JᵀWr over the free slots.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockSystem {
    /// Number of free global (effect) parameters; they come first.
    pub n_g: usize,
    /// A_gg: n_g × n_g, row-major.
    pub a_gg: Vec<f64>,
    pub b_g: Vec<f64>,
    pub frames: Vec<FrameBlock>,
}

impl BlockSystem {
    /// Zeros: `n_g` globals and frames of `sizes[k]` free nuisances each.
    pub fn zeros(n_g: usize, sizes: &[usize]) -> BlockSystem {
        let mut start = n_g;
        let frames = sizes
            .iter()
            .map(|&n| {
                let f = FrameBlock { start, a_kk: vec![0.0; n * n], a_gk: vec![0.0; n_g * n], b_k: vec![0.0; n] };
                start += n;
                f
            })
            .collect();
        BlockSystem { n_g, a_gg: vec![0.0; n_g * n_g], b_g: vec![0.0; n_g], frames }
    }

    /// Total number of parameters.
    pub fn n(&self) -> usize {
        self.n_g + self.frames.iter().map(FrameBlock::n).sum::<usize>()
    }

    /// JᵀWr over every parameter, in order.
    pub fn b(&self) -> Vec<f64> {
        let mut b = self.b_g.clone();
        for f in &self.frames {
            b.extend_from_slice(&f.b_k);
        }
        b
    }

    /// The frame holding position `i` (≥ n_g) and its index within the frame.
    fn locate(&self, i: usize) -> (usize, usize) {
        let k = self.frames.partition_point(|f| f.start <= i) - 1;
        (k, i - self.frames[k].start)
    }

    /// Entry (i, j) of the whole matrix (zero between two frames).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (g, ng) = (self.n_g, self.n_g);
        match (i < g, j < g) {
            (true, true) => self.a_gg[i * ng + j],
            (true, false) => {
                let (k, l) = self.locate(j);
                self.frames[k].a_gk[i * self.frames[k].n() + l]
            }
            (false, true) => self.get(j, i),
            (false, false) => {
                let ((k, a), (m, c)) = (self.locate(i), self.locate(j));
                if k == m {
                    self.frames[k].a_kk[a * self.frames[k].n() + c]
                } else {
                    0.0
                }
            }
        }
    }

    /// The whole matrix, row-major (tests, and the comparison with the dense path).
    pub fn dense(&self) -> Vec<f64> {
        let n = self.n();
        (0..n * n).map(|x| self.get(x / n, x % n)).collect()
    }

    /// The block system of a dense symmetric `a` (n × n, row-major) and `b`, `n_g`
    /// globals first then frames of `sizes[k]` (entries between two frames ignored).
    pub fn from_dense(a: &[f64], b: &[f64], n_g: usize, sizes: &[usize]) -> BlockSystem {
        let n = b.len();
        let mut s = BlockSystem::zeros(n_g, sizes);
        for i in 0..n_g {
            s.b_g[i] = b[i];
            for j in 0..n_g {
                s.a_gg[i * n_g + j] = a[i * n + j];
            }
        }
        for f in &mut s.frames {
            let nl = f.n();
            for a_ in 0..nl {
                let i = f.start + a_;
                f.b_k[a_] = b[i];
                for c in 0..nl {
                    f.a_kk[a_ * nl + c] = a[i * n + f.start + c];
                }
                for g in 0..n_g {
                    f.a_gk[g * nl + a_] = a[g * n + i];
                }
            }
        }
        s
    }

    /// The system over the positions `keep` only (increasing): the parameters held out
    /// (an active bound, a candidate not scored) removed from every block.
    pub fn restrict(&self, keep: &[usize]) -> BlockSystem {
        let globals: Vec<usize> = keep.iter().copied().take_while(|&i| i < self.n_g).collect();
        let ng = globals.len();
        let mut start = ng;
        let frames = self
            .frames
            .iter()
            .map(|f| {
                let nl = f.n();
                let own: Vec<usize> =
                    keep.iter().filter(|&&i| i >= f.start && i < f.start + nl).map(|&i| i - f.start).collect();
                let out = FrameBlock {
                    start,
                    a_kk: own.iter().flat_map(|&a| own.iter().map(move |&c| f.a_kk[a * nl + c])).collect(),
                    a_gk: globals.iter().flat_map(|&g| own.iter().map(move |&l| f.a_gk[g * nl + l])).collect(),
                    b_k: own.iter().map(|&l| f.b_k[l]).collect(),
                };
                start += own.len();
                out
            })
            .collect();
        BlockSystem {
            n_g: ng,
            a_gg: globals.iter().flat_map(|&i| globals.iter().map(move |&j| self.a_gg[i * self.n_g + j])).collect(),
            b_g: globals.iter().map(|&i| self.b_g[i]).collect(),
            frames,
        }
    }

    /// The Levenberg–Marquardt system: every diagonal entry × (1 + λ).
    pub fn damped(&self, lambda: f64) -> BlockSystem {
        let mut s = self.clone();
        let ng = s.n_g;
        for i in 0..ng {
            s.a_gg[i * ng + i] *= 1.0 + lambda;
        }
        for f in &mut s.frames {
            let nl = f.n();
            for i in 0..nl {
                f.a_kk[i * nl + i] *= 1.0 + lambda;
            }
        }
        s
    }

    /// Adds `o` (same shape) to `self`.
    pub fn add(&mut self, o: &BlockSystem) {
        let add = |x: &mut [f64], y: &[f64]| x.iter_mut().zip(y).for_each(|(x, y)| *x += y);
        add(&mut self.a_gg, &o.a_gg);
        add(&mut self.b_g, &o.b_g);
        for (f, g) in self.frames.iter_mut().zip(&o.frames) {
            add(&mut f.a_kk, &g.a_kk);
            add(&mut f.a_gk, &g.a_gk);
            add(&mut f.b_k, &g.b_k);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> (Vec<f64>, Vec<f64>) {
        // 2 globals, frames of 2 and 1: a symmetric 5 × 5 with zeros between frames.
        let a = vec![
            5.0, 1.0, 0.5, 0.2, 0.1, //
            1.0, 4.0, 0.3, 0.4, 0.2, //
            0.5, 0.3, 3.0, 0.7, 0.0, //
            0.2, 0.4, 0.7, 2.0, 0.0, //
            0.1, 0.2, 0.0, 0.0, 1.5,
        ];
        (a, vec![1.0, 2.0, 3.0, 4.0, 5.0])
    }

    #[test]
    fn blocks_round_trip_the_dense_matrix_and_restrict_like_it() {
        let (a, b) = sample();
        let s = BlockSystem::from_dense(&a, &b, 2, &[2, 1]);
        assert_eq!(s.dense(), a);
        assert_eq!(s.b(), b);
        // Keep 0, 2, 4: global 0, frame 0's first nuisance, frame 1's.
        let keep = [0, 2, 4];
        let r = s.restrict(&keep);
        let a_ = &a;
        let want: Vec<f64> = keep.iter().flat_map(|&i| keep.iter().map(move |&j| a_[i * 5 + j])).collect();
        assert_eq!(r.dense(), want);
        assert_eq!(r.b(), vec![1.0, 3.0, 5.0]);
        assert_eq!((r.n_g, r.frames[1].start), (1, 2));
        // Damping scales the diagonal only.
        let d = s.damped(1.0).dense();
        for i in 0..5 {
            for j in 0..5 {
                assert_eq!(d[i * 5 + j], a[i * 5 + j] * if i == j { 2.0 } else { 1.0 });
            }
        }
    }
}
