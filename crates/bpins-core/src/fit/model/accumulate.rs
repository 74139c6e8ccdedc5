//! The normal equations, accumulated pixel by pixel (never a Jacobian in memory):
//! χ² and, where asked, JᵀWJ and JᵀWr over the free slots.
//!
//! Per frame: the chain at θ and, for each of the frame's free slots (the global ones
//! and its own), how its Jacobian column is formed ([`Column`]); then the rows of the
//! frame (or its sampled blocks, `crate::fit::input::frames`) in parallel, each usable sample adding w·r², w·d·r and w·d·dᵀ over those
//! local slots; then the frame's local sums kept in its blocks of the block-arrow
//! system (`crate::fit::solver::block`: a frame's nuisances couple only to themselves and to the
//! global parameters, so nothing between two frames is stored).

use crate::error::Result;
use crate::fit::input::frames::Rect;
use crate::fit::model::problem::{FitFrame, Problem};
use crate::fit::model::slots::Derivative;
use crate::fit::model::stages::{Reuse, Stages};
use crate::fit::solver::block::BlockSystem;
use crate::fit::uncertainty::robust::Clusters;
use crate::fit::uncertainty::spatial::Tiles;
use rayon::prelude::*;

/// The normal equations of a fit over some samples: JᵀWJ and JᵀWr by blocks
/// ([`BlockSystem`]: the globals' block, each frame's own and its coupling to the
/// globals; empty without `normal`), and χ².
pub(crate) struct Accum {
    pub sys: BlockSystem,
    pub chi2: f64,
    pub n: usize,
    /// Per frame: (χ², samples).
    pub frame_chi2: Vec<(f64, usize)>,
    /// On every pixel with the normal equations: each cluster's score over the free
    /// globals, for their sandwich 1σ (`crate::fit::uncertainty::robust`).
    pub clusters: Option<Clusters>,
    /// On every pixel with the normal equations: each frame's per-tile JᵀWr over its
    /// local slots, for the heading's spatial 1σ (`crate::fit::uncertainty::spatial`).
    pub tiles: Option<Tiles>,
}

/// One frame's (or one part's) sums over its local slots (the free globals, then its
/// own free nuisances): JᵀWJ (lower triangle, row-major), JᵀWr, χ², samples; and,
/// where tiles are kept, JᵀWr by tile (`(tile, sums)`, in the order met).
struct Sums {
    a: Vec<f64>,
    b: Vec<f64>,
    chi2: f64,
    n: usize,
    tiles: Vec<(usize, Vec<f64>)>,
}

impl Sums {
    fn new(n: usize) -> Self {
        Sums { a: vec![0.0; n * n], b: vec![0.0; n], chi2: 0.0, n: 0, tiles: Vec::new() }
    }

    fn add(mut self, o: Sums) -> Sums {
        self.a.iter_mut().zip(&o.a).for_each(|(x, y)| *x += y);
        self.b.iter_mut().zip(&o.b).for_each(|(x, y)| *x += y);
        self.chi2 += o.chi2;
        self.n += o.n;
        self
    }
}

/// How one parameter's column of the Jacobian is formed.
enum Column {
    /// (model at plus − model at minus)/dh; `None` is the base chain. `keeps_factor`:
    /// both sides have the base's camera, sun and radiance weights, hence its radiance
    /// factor at every pixel (an effect parameter that moves neither the camera nor
    /// the sun), which is then not formed again. `reuse`: what each side's chain takes
    /// of the base's stages at the pixel (`crate::fit::model::stages`).
    Difference {
        plus: Option<Box<FitFrame>>,
        minus: Option<Box<FitFrame>>,
        dh: f64,
        keeps_factor: bool,
        reuse: [Reuse; 2],
    },
    /// (model − offset)/value.
    Proportional { value: f64 },
    /// (model − offset)·ψ_index/R.
    Radiance { index: usize },
    /// 1 on channel `channel`'s samples, 0 elsewhere.
    Offset { channel: usize },
}

/// A pixel's samples: (measured, model) DN.
type Samples = Vec<(f64, f64)>;

/// Whether `f`'s radiance factor is `base`'s at every pixel: the same camera, sun and
/// weights (`Problem::factor_at` reads nothing else of a frame).
fn same_factor(f: &FitFrame, base: &FitFrame) -> bool {
    f.intr == base.intr && f.sun_cam == base.sun_cam && f.radiance_weights == base.radiance_weights
}

/// One frame's model and its local columns: what each of its samples needs.
struct FrameModel<'f> {
    k: usize,
    base: &'f FitFrame,
    columns: &'f [Column],
    normal: bool,
    /// The tile grid, where JᵀWr is kept by tile.
    tiles: Option<&'f Tiles>,
}

impl Problem<'_> {
    /// χ² and, with `normal`, JᵀWJ and JᵀWr over the free slots, on every `stride`-th
    /// row and column of the pixels the frames hold, in free-slot order.
    pub(crate) fn accumulate(&self, theta: &[f64], stride: usize, normal: bool) -> Result<Accum> {
        let free = self.slots.free();
        let n_global = self.slots.n_global;
        let n_g = free.iter().take_while(|&&i| i < n_global).count();
        // Each frame's own free slots (contiguous in the free order, frame by frame).
        let own: Vec<Vec<usize>> = (0..self.frames.len())
            .map(|k| self.slots.frame(k).into_iter().filter(|&i| self.slots.all[i].free).collect())
            .collect();
        let sizes: Vec<usize> = if normal { own.iter().map(Vec::len).collect() } else { Vec::new() };
        let mut total = Accum {
            sys: BlockSystem::zeros(if normal { n_g } else { 0 }, &sizes),
            chi2: 0.0,
            n: 0,
            frame_chi2: vec![(0.0, 0); self.frames.len()],
            clusters: (normal && stride == 1 && n_g > 0).then(|| Clusters::new(self.frames.n_clusters(), n_g)),
            tiles: (normal && stride == 1).then(|| {
                let (w, h) = (self.capture.sensor.geometry.width_px, self.capture.sensor.geometry.height_px);
                let n_local: Vec<usize> = own.iter().map(|o| n_g + o.len()).collect();
                Tiles::new(w as usize, h as usize, &n_local)
            }),
        };
        for (k, own) in own.iter().enumerate() {
            // The local slots of this frame: the free globals, then its own.
            let local: Vec<usize> = free[..n_g].iter().chain(own).copied().collect();
            let base = self.chain(theta, k)?;
            let columns = if normal { self.columns(theta, k, &local, &base)? } else { Vec::new() };
            let fm = FrameModel { k, base: &base, columns: &columns, normal, tiles: total.tiles.as_ref() };
            let rects = self.frames.parts(k, stride);
            let mut parts: Vec<Sums> = rects.par_iter().map(|&r| self.accumulate_part(&fm, r, stride)).collect();
            if let Some(t) = total.tiles.as_mut() {
                for p in &mut parts {
                    t.add(k, &std::mem::take(&mut p.tiles));
                }
            }
            // Each part's score, by cluster, before the parts are summed.
            let scores: Vec<(usize, Vec<f64>)> = match total.clusters {
                Some(_) => rects.iter().zip(&parts).map(|(r, p)| (self.frames.cluster_of(r), p.b.clone())).collect(),
                None => Vec::new(),
            };
            // In row (block) order: the same sums whatever the threads.
            let fr = parts.into_iter().fold(Sums::new(columns.len()), Sums::add);
            if let Some(cl) = total.clusters.as_mut() {
                cl.add_frame(&fr.a, columns.len(), &scores);
            }
            // The frame's local sums into its blocks (none without `normal`: no
            // columns): globals × globals into A_gg, own × globals into A_gk, own ×
            // own into A_kk (both triangles).
            if normal {
                let (nl, sys) = (own.len(), &mut total.sys);
                let blk = &mut sys.frames[k];
                for a in 0..columns.len() {
                    if a < n_g {
                        sys.b_g[a] += fr.b[a];
                    } else {
                        blk.b_k[a - n_g] += fr.b[a];
                    }
                    for c in 0..=a {
                        let v = fr.a[a * columns.len() + c];
                        match (a < n_g, c < n_g) {
                            (true, _) => {
                                sys.a_gg[a * n_g + c] += v;
                                if a != c {
                                    sys.a_gg[c * n_g + a] += v;
                                }
                            }
                            (false, true) => blk.a_gk[c * nl + a - n_g] += v,
                            (false, false) => {
                                let (l, m) = (a - n_g, c - n_g);
                                blk.a_kk[l * nl + m] += v;
                                if l != m {
                                    blk.a_kk[m * nl + l] += v;
                                }
                            }
                        }
                    }
                }
            }
            total.chi2 += fr.chi2;
            total.n += fr.n;
            total.frame_chi2[k] = (fr.chi2, fr.n);
        }
        Ok(total)
    }

    /// The Jacobian columns of frame `k`'s `local` slots at `theta`: analytic where the
    /// slot says so, else the chains at its two sides (a side at θ itself is the base
    /// chain, not evaluated again).
    fn columns(&self, theta: &[f64], k: usize, local: &[usize], base: &FitFrame) -> Result<Vec<Column>> {
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
                Derivative::Offset(channel) => {
                    out.push(Column::Offset { channel });
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
            let (plus, minus) = (side(hi)?, side(lo)?);
            let keeps_factor = [&plus, &minus].iter().all(|f| f.as_ref().is_none_or(|f| same_factor(f, base)));
            let reuse = [&plus, &minus].map(|f| f.as_ref().map_or(Reuse::Image, |f| f.reuse_from(base)));
            out.push(Column::Difference { plus, minus, dh: hi - lo, keeps_factor, reuse });
        }
        Ok(out)
    }

    /// The sums of part `r` of one frame (a row, a block), every `stride`-th row and
    /// column.
    fn accumulate_part(&self, fm: &FrameModel, r: Rect, stride: usize) -> Sums {
        let nl = fm.columns.len();
        let mut acc = Sums::new(nl);
        let mut bufs = (Vec::new(), Vec::new(), Vec::new());
        let mut d = vec![0.0; nl];
        let no_radiance = fm.base.radiance == [0.0; crate::fit::model::radiance::N];
        for (u, v) in r.points(stride) {
            let tile = fm.tiles.map(|t| t.of(u, v));
            // The raw radiance functions once per pixel: the base's factor, its basis ψ
            // for the radiance columns and the factor the columns that keep it reuse.
            let phi = (fm.normal || !no_radiance).then(|| self.raw_radiance(fm.base, u, v));
            let rf = phi.as_ref().map_or(1.0, |phi| Problem::factor_of(fm.base, phi));
            // The base chain's stages, for the difference columns that reuse them.
            let st = self.pixel_staged(fm.base, (fm.k, u, v), rf, None, &mut bufs.0);
            let samples = std::mem::take(&mut bufs.0);
            let psi = (fm.normal && !samples.is_empty()).then(|| self.basis[fm.k].psi(phi.as_ref().expect("normal")));
            for (q, &(y, m)) in samples.iter().enumerate().filter(|(_, s)| self.usable(fm.k, u, v, s.0)) {
                let wgt = 1.0 / self.noise.variance_dn2(m - self.capture.sensor.black_level_dn);
                let r = y - m;
                acc.chi2 += wgt * r * r;
                acc.n += 1;
                if !fm.normal {
                    continue;
                }
                for (dj, col) in d.iter_mut().zip(fm.columns) {
                    *dj = self.derivative(fm, col, (u, v, q), (m, rf, st), psi.as_ref(), &mut bufs);
                }
                // Row by row over slices (no bounds check per entry: the compiler
                // vectorises it); the same products in the same order as entry by entry.
                for (a, row) in acc.a.chunks_exact_mut(nl).enumerate() {
                    let wd = wgt * d[a];
                    acc.b[a] += wd * r;
                    row[..=a].iter_mut().zip(&d[..=a]).for_each(|(x, dc)| *x += wd * dc);
                }
                if let Some(t) = tile {
                    // Pixels come row by row: a tile's samples are met in runs.
                    if acc.tiles.last().is_none_or(|(last, _)| *last != t) {
                        acc.tiles.push((t, vec![0.0; nl]));
                    }
                    let sums = &mut acc.tiles.last_mut().expect("pushed").1;
                    sums.iter_mut().zip(&d).for_each(|(s, dj)| *s += wgt * dj * r);
                }
            }
            bufs.0 = samples;
        }
        acc
    }

    /// One Jacobian entry: ∂(model DN of sample `q` of pixel (u, v))/∂(the column's
    /// slot), `m` the model there at θ, `rf` the base's radiance factor there, `st`
    /// the base's chain stages there and `psi` its radiance basis.
    fn derivative(
        &self,
        fm: &FrameModel,
        col: &Column,
        (u, v, q): (usize, usize, usize),
        (m, rf, st): (f64, f64, Option<Stages>),
        psi: Option<&[f64; crate::fit::model::radiance::N]>,
        bufs: &mut (Samples, Samples, Samples),
    ) -> f64 {
        match col {
            Column::Proportional { value } => (m - self.offset_dn(fm.base, u, v, q)) / value,
            Column::Radiance { index } => {
                (m - self.offset_dn(fm.base, u, v, q)) * psi.expect("evaluated where normal")[*index]
            }
            Column::Offset { channel } => f64::from(u8::from(self.channel_of(u, v, q) == *channel)),
            Column::Difference { plus, minus, dh, keeps_factor, reuse } => {
                let at = |f: &Option<Box<FitFrame>>, reuse: Reuse, buf: &mut Samples| {
                    f.as_ref().map_or(m, |f| {
                        let r = if *keeps_factor { rf } else { self.factor_at(f, u, v) };
                        self.pixel_staged(f, (fm.k, u, v), r, st.map(|s| (s, reuse)), buf);
                        buf[q].1
                    })
                };
                (at(plus, reuse[0], &mut bufs.1) - at(minus, reuse[1], &mut bufs.2)) / dh
            }
        }
    }
}
