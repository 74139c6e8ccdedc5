//! The normal equations, accumulated pixel by pixel (never a Jacobian in memory):
//! χ² and, where asked, JᵀWJ and JᵀWr over the free slots.
//!
//! Per frame: the chain at θ and, for each of the frame's free slots (the global ones
//! and its own), how its Jacobian column is formed ([`Column`]); then the rows of the
//! frame (or its sampled blocks, `super::frames`) in parallel, each usable sample adding w·r², w·d·r and w·d·dᵀ over those
//! local slots; then the frame's local sums scattered into the free-slot system.

use super::frames::Rect;
use super::problem::{FitFrame, Problem};
use super::slots::Derivative;
use crate::error::Result;
use rayon::prelude::*;

/// Sums of the normal equations over some samples.
pub(crate) struct Accum {
    /// JᵀWJ (n × n, row-major; lower triangle until symmetrised).
    pub a: Vec<f64>,
    /// JᵀWr.
    pub b: Vec<f64>,
    pub chi2: f64,
    pub n: usize,
    /// Per frame: (χ², samples).
    pub frame_chi2: Vec<(f64, usize)>,
}

impl Accum {
    fn new(n: usize, frames: usize) -> Self {
        Accum { a: vec![0.0; n * n], b: vec![0.0; n], chi2: 0.0, n: 0, frame_chi2: vec![(0.0, 0); frames] }
    }

    fn add(mut self, o: Accum) -> Accum {
        self.a.iter_mut().zip(&o.a).for_each(|(x, y)| *x += y);
        self.b.iter_mut().zip(&o.b).for_each(|(x, y)| *x += y);
        self.chi2 += o.chi2;
        self.n += o.n;
        self
    }
}

/// How one parameter's column of the Jacobian is formed.
enum Column {
    /// (model at plus − model at minus)/dh; `None` is the base chain.
    Difference { plus: Option<Box<FitFrame>>, minus: Option<Box<FitFrame>>, dh: f64 },
    /// (model − offset)/value.
    Proportional { value: f64 },
    /// (model − offset)·ψ_index/R.
    Radiance { index: usize },
}

/// A pixel's samples: (measured, model) DN.
type Samples = Vec<(f64, f64)>;

/// One frame's model and its local columns: what each of its samples needs.
struct FrameModel<'f> {
    k: usize,
    base: &'f FitFrame,
    columns: &'f [Column],
    normal: bool,
}

impl Problem<'_> {
    /// χ² and, with `normal`, JᵀWJ and JᵀWr over the free slots, on every `stride`-th
    /// row and column of the pixels the frames hold, in free-slot order.
    pub(crate) fn accumulate(&self, theta: &[f64], stride: usize, normal: bool) -> Result<Accum> {
        let free = self.slots.free();
        let nf = free.len();
        let mut total = Accum::new(nf, self.frames.len());
        for k in 0..self.frames.len() {
            // The local slots of this frame: global ones and its own, free only.
            let own = self.slots.frame(k);
            let local: Vec<usize> =
                free.iter().copied().filter(|&i| i < self.slots.n_global || own.contains(&i)).collect();
            let base = self.chain(theta, k)?;
            let columns = if normal { self.columns(theta, k, &local)? } else { Vec::new() };
            let fm = FrameModel { k, base: &base, columns: &columns, normal };
            let fr = self
                .frames
                .parts(k, stride)
                .into_par_iter()
                .map(|r| self.accumulate_part(&fm, r, stride))
                .collect::<Vec<_>>()
                .into_iter()
                // In row (block) order: the same sums whatever the threads.
                .fold(Accum::new(columns.len(), 0), Accum::add);
            // Scatter the frame's local sums into the free-slot system (none without
            // `normal`: no columns).
            let pos: Vec<usize> = local.iter().map(|i| free.binary_search(i).expect("a free slot")).collect();
            for (a, &pa) in pos.iter().enumerate().take(columns.len()) {
                total.b[pa] += fr.b[a];
                for (c, &pc) in pos.iter().enumerate().take(a + 1) {
                    total.a[pa.max(pc) * nf + pa.min(pc)] += fr.a[a * columns.len() + c];
                }
            }
            total.chi2 += fr.chi2;
            total.n += fr.n;
            total.frame_chi2[k] = (fr.chi2, fr.n);
        }
        // Symmetrise.
        for i in 0..nf {
            for j in 0..i {
                total.a[j * nf + i] = total.a[i * nf + j];
            }
        }
        Ok(total)
    }

    /// The Jacobian columns of frame `k`'s `local` slots at `theta`: analytic where the
    /// slot says so, else the chains at its two sides (a side at θ itself is the base
    /// chain, not evaluated again).
    fn columns(&self, theta: &[f64], k: usize, local: &[usize]) -> Result<Vec<Column>> {
        let mut out = Vec::with_capacity(local.len());
        for &i in local {
            let sl = &self.slots.all[i];
            let (lo, hi) = match sl.derivative {
                Derivative::Proportional => {
                    out.push(Column::Proportional { value: theta[i] });
                    continue;
                }
                Derivative::Radiance(index) => {
                    out.push(Column::Radiance { index });
                    continue;
                }
                // Central differences, one-sided at a bound of the parameter.
                Derivative::Central => ((theta[i] - sl.step).max(sl.min), (theta[i] + sl.step).min(sl.max)),
                // From θ forward, or backward where θ + h is out of range.
                Derivative::Secant if theta[i] + sl.step <= sl.max => (theta[i], theta[i] + sl.step),
                Derivative::Secant => ((theta[i] - sl.step).max(sl.min), theta[i]),
            };
            let side = |x: f64| -> Result<Option<Box<FitFrame>>> {
                if x == theta[i] {
                    return Ok(None);
                }
                let mut t = theta.to_vec();
                t[i] = x;
                self.chain(&t, k).map(|f| Some(Box::new(f)))
            };
            out.push(Column::Difference { plus: side(hi)?, minus: side(lo)?, dh: hi - lo });
        }
        Ok(out)
    }

    /// The sums of part `r` of one frame (a row, a block), every `stride`-th row and
    /// column.
    fn accumulate_part(&self, fm: &FrameModel, r: Rect, stride: usize) -> Accum {
        let nl = fm.columns.len();
        let mut acc = Accum::new(nl, 0);
        let mut bufs = (Vec::new(), Vec::new(), Vec::new());
        let mut d = vec![0.0; nl];
        for (u, v) in r.points(stride) {
            self.pixel(fm.base, fm.k, u, v, &mut bufs.0);
            let samples = std::mem::take(&mut bufs.0);
            let psi = (fm.normal && !samples.is_empty()).then(|| self.radiance(fm.base, fm.k, u, v).1);
            for (q, &(y, m)) in samples.iter().enumerate().filter(|(_, s)| self.usable(fm.k, u, v, s.0)) {
                let wgt = 1.0 / self.noise.variance_dn2(m - self.capture.sensor.black_level_dn);
                let r = y - m;
                acc.chi2 += wgt * r * r;
                acc.n += 1;
                if !fm.normal {
                    continue;
                }
                for (dj, col) in d.iter_mut().zip(fm.columns) {
                    *dj = self.derivative(fm, col, (u, v, q), m, psi.as_ref(), &mut bufs);
                }
                for a in 0..nl {
                    acc.b[a] += wgt * d[a] * r;
                    for c in 0..=a {
                        acc.a[a * nl + c] += wgt * d[a] * d[c];
                    }
                }
            }
            bufs.0 = samples;
        }
        acc
    }

    /// One Jacobian entry: ∂(model DN of sample `q` of pixel (u, v))/∂(the column's
    /// slot), `m` the model there at θ and `psi` its radiance basis.
    fn derivative(
        &self,
        fm: &FrameModel,
        col: &Column,
        (u, v, q): (usize, usize, usize),
        m: f64,
        psi: Option<&[f64; super::radiance::N]>,
        bufs: &mut (Samples, Samples, Samples),
    ) -> f64 {
        match col {
            Column::Proportional { value } => (m - self.offset_dn(fm.base, u, v, q)) / value,
            Column::Radiance { index } => {
                (m - self.offset_dn(fm.base, u, v, q)) * psi.expect("evaluated where normal")[*index]
            }
            Column::Difference { plus, minus, dh } => {
                let at = |f: &Option<Box<FitFrame>>, buf: &mut Samples| {
                    f.as_ref().map_or(m, |f| {
                        self.pixel(f, fm.k, u, v, buf);
                        buf[q].1
                    })
                };
                (at(plus, &mut bufs.1) - at(minus, &mut bufs.2)) / dh
            }
        }
    }
}
