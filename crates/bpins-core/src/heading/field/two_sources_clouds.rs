//! The two-source twilight reader's cloud rounds (`two_sources.rs`, its module doc):
//! `clouds.rs`'s tests run on the mixed sky ([`mixed_clouds`]: DoLP under 0.6 × the
//! mixed clear sky's, brighter than the smooth sky, whiter on a colour frame), cloud
//! cells weight 0, clustered and grown by 2 cells, and beside them the clustered Tukey
//! rejections grown likewise; then τ over the cells away from clouds, Tukey's weights
//! and Gauss–Newton on (ψ, θ) ([`robust_rounds`]), as `robust.rs` runs them for one
//! source.
//!
//! Units: radians inside (ψ in degrees), DoLP over d_max dimensionless. Frame: level
//! camera (CONVENTIONS.md).

use super::super::clouds::{label, CellSky, TestBufs};
use super::super::robust::{CLOUDS_SETTLED_DEG, DILATE_CELLS, TAU_CHI2, TAU_Q};
use super::super::stats::{grown_clusters, quantile, tukey};
use super::{delta, gauss_newton, logistic, pattern, Cell2, Model, ROUNDS, SHARE_SETTLED};
use crate::conventions::wrap_deg_180;
use glam::DVec3;

/// The mixed clear sky's DoLP over d_max at one cell: the Stokes sum of the two
/// Rayleigh skies (module doc), each of radiance ½(1 + cos²γ_k) and polarized part
/// ½·d_max·sin²γ_k per unit, weighted w and 1 − w:
///
/// ```text
/// D_mix = |w·Z_p + (1 − w)·Z_o| / (w·(1 + cos²γ_p) + (1 − w)·(1 + cos²γ_o))
/// ```
///
/// at w = 1 Rayleigh's sin²γ/(1 + cos²γ) (`clouds.rs`), so the cloud tests' fractions
/// and floors keep their meaning; where the patterns cross it drops toward 0 (those
/// cells unverifiable, their label voted by their neighbours'). Frame: level.
pub(super) fn mixed_shape(c: &Cell2, sp: DVec3, so: DVec3, w: f64) -> f64 {
    let (zp, zo) = (pattern(c, sp), pattern(c, so));
    let (x, y) = (w * zp.0 + (1.0 - w) * zo.0, w * zp.1 + (1.0 - w) * zo.1);
    let i = w * (1.0 + c.d.dot(sp).powi(2)) + (1.0 - w) * (1.0 + c.d.dot(so).powi(2));
    x.hypot(y) / i
}

/// What a cell offers the cloud tests beside its geometry (from [`Obs`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Seen {
    pub(super) dolp: f64,
    pub(super) ln_i: f64,
    pub(super) tint: f64,
}

/// Buffers of the cloud tests (`clouds.rs`) and of the robust rounds, kept between
/// frames ([`super::Scratch`]).
#[derive(Clone, Debug, Default)]
pub(super) struct CloudBufs {
    sky: Vec<CellSky>,
    t: Vec<f64>,
    tests: TestBufs,
    cloud: Vec<bool>,
    mask: Vec<bool>,
    kept: Vec<bool>,
    tmp: Vec<bool>,
    /// Per cell of the grid: cloud, clustered and grown by DILATE_CELLS.
    pub(super) grown: Vec<bool>,
    /// Per cell of the grid: the clustered rejections of a round, grown.
    rejected: Vec<bool>,
    /// Per cell of the rounds' cells: robust weight / σ² (0 for cloud), as the rounds
    /// leave it ([`robust_rounds`]).
    pub(super) wt: Vec<f64>,
    /// The misfit scale's quantile buffer.
    t2: Vec<f64>,
}

/// Into `b.grown` (per cell of the grid): the cells `clouds.rs`'s tests take for cloud
/// in the mixed sky at (`sp`, `so`, `w`), as `robust.rs` runs them for one source —
/// depolarized against the mixed clear sky's DoLP ([`mixed_shape`] × the clear sky's
/// d_max), brighter than the smooth sky, whiter on a colour frame, the unverifiable
/// cells voted by their neighbours — clustered and grown by DILATE_CELLS. A cell fits
/// where its residual is within 3σ (noise and `tau2`); the smooth radiance's γ is the
/// larger share's body's (the other's gradient over a view is left to the quadratic in
/// the elevation sine).
#[allow(clippy::too_many_arguments)]
pub(super) fn mixed_clouds(
    cells: &[Cell2],
    seen: &[Seen],
    (sp, so, w): (DVec3, DVec3, f64),
    tau2: f64,
    min_cells: usize,
    cols: usize,
    rows: usize,
    b: &mut CloudBufs,
) {
    let main = if w >= 0.5 { sp } else { so };
    b.sky.clear();
    b.sky.extend(cells.iter().zip(seen).map(|(c, s)| CellSky {
        dolp: s.dolp,
        ln_i: s.ln_i,
        tint: s.tint,
        cg: c.d.dot(main),
        z: c.d.z,
        shape: mixed_shape(c, sp, so, w),
        fits: delta(c, sp, so, w).powi(2) < 9.0 * (c.var + tau2),
        grid: c.grid,
    }));
    label(&b.sky, cols, rows, min_cells, &mut b.t, &mut b.tests, &mut b.cloud);
    let marked = cells.iter().zip(&b.cloud).map(|(c, &x)| (c.grid, x));
    grown_clusters(marked, cols * rows, cols, DILATE_CELLS, &mut b.mask, &mut b.kept, &mut b.tmp, &mut b.grown);
}

/// Where the robust rounds end.
pub(super) struct Rounds {
    pub(super) psi_deg: f64,
    pub(super) theta: f64,
    pub(super) tau2: f64,
    /// Inverse of the normal matrix (ψ in degrees, θ).
    pub(super) cov: [[f64; 2]; 2],
    pub(super) iterations: usize,
}

/// The robust rounds from `start` (ψ in degrees, θ) over `cells2` (the cells away from
/// both bodies); the cloud tests read `c2`, every cell, with `seen` beside it (`cb.grown`
/// is left at the last clouds found, `cb.wt` at the weights per cell of `cells2`).
#[allow(clippy::too_many_arguments)]
pub(super) fn robust_rounds(
    c2: &[Cell2],
    cells2: &[Cell2],
    seen: &[Seen],
    m: &Model<'_>,
    theta0: f64,
    start: (f64, f64),
    min_cells: usize,
    (cols, rows): (usize, usize),
    cb: &mut CloudBufs,
) -> Rounds {
    let (psi0, theta_start) = start;
    // Robust rounds: residuals at the current point, clouds (`mixed_clouds`: weight 0,
    // found again once ψ or θ moves by CLOUDS_SETTLED_DEG or SHARE_SETTLED), τ over the cells away from
    // them, Tukey's weights, Gauss–Newton.
    let (mut psi, mut th) = (psi0, theta_start);
    let mut wt = std::mem::take(&mut cb.wt);
    wt.clear();
    wt.resize(cells2.len(), 0.0);
    let mut t = std::mem::take(&mut cb.t2);
    let mut tau2 = 0.0;
    let mut cov = [[f64::INFINITY, 0.0], [0.0, 1.0]];
    let mut clouds_at: Option<(f64, f64)> = None;
    let mut iterations = 0;
    let tau2_of = |t: &mut Vec<f64>, sp: DVec3, so: DVec3, w: f64, cloud: &dyn Fn(&Cell2) -> bool| {
        t.clear();
        t.extend(
            cells2.iter().filter(|c| !cloud(c)).map(|c| (delta(c, sp, so, w).powi(2) - TAU_CHI2 * c.var) / TAU_CHI2),
        );
        let x = quantile(t, TAU_Q).max(0.0);
        if x.is_finite() {
            x
        } else {
            0.0
        }
    };
    for it in 1..=ROUNDS {
        iterations = it;
        let (sp, so) = m.suns(psi);
        let w = logistic(th);
        let settled = clouds_at
            .is_some_and(|(p, h)| wrap_deg_180(p - psi).abs() < CLOUDS_SETTLED_DEG && (h - th).abs() < SHARE_SETTLED);
        if !settled {
            // Which cells fit: at the misfit scale of every cell (clouds included).
            let tau2_all = tau2_of(&mut t, sp, so, w, &|_| false);
            mixed_clouds(c2, seen, (sp, so, w), tau2_all, min_cells, cols, rows, cb);
            clouds_at = Some((psi, th));
        }
        // τ over the cells away from clouds (every cell where fewer than min_cells are).
        let away = cells2.iter().filter(|c| !cb.grown[c.grid]).count();
        let grown = &cb.grown;
        tau2 = tau2_of(&mut t, sp, so, w, &|c| away >= min_cells.min(cells2.len()) && grown[c.grid]);
        for (x, c) in wt.iter_mut().zip(cells2) {
            let var = c.var + tau2;
            *x = if cb.grown[c.grid] { 0.0 } else { tukey(delta(c, sp, so, w) / var.sqrt()) / var };
        }
        // Beside a cloud, a rejected cell's neighbours are suspect (`robust.rs`):
        // rejections that cluster (a cloud's soft rim the tests missed) grow by
        // DILATE_CELLS. Not on a sky with no cloud found: there they are where the two
        // patterns cross, and growing them took informative cells (tried, the
        // docs/night.md "Twilight" rows: RMS 0.210° → 0.233° at 2026-06-26T12:40Z).
        if cells2.iter().any(|c| cb.grown[c.grid]) {
            let rejected = cells2.iter().zip(&wt).map(|(c, &x)| (c.grid, x * (c.var + tau2) < 0.5));
            let (mask, kept, tmp) = (&mut cb.mask, &mut cb.kept, &mut cb.tmp);
            grown_clusters(rejected, cols * rows, cols, DILATE_CELLS, mask, kept, tmp, &mut cb.rejected);
            for (x, c) in wt.iter_mut().zip(cells2) {
                if cb.rejected[c.grid] {
                    *x = 0.0;
                }
            }
        }
        let ((p2, t2), cv) = gauss_newton(cells2, &wt, &|_| true, m, theta0, (psi, th), 4);
        cov = cv;
        let step = wrap_deg_180(p2 - psi).abs() + (t2 - th).abs();
        (psi, th) = (p2, t2);
        if step < 1e-4 {
            break;
        }
    }
    (cb.wt, cb.t2) = (wt, t);
    Rounds { psi_deg: psi, theta: th, tau2, cov, iterations }
}
