//! Steps 1–3 of the field estimator (`mod.rs`): each cell that passes the masks as
//! the estimator sees it ([`Obs`], level frame), the sun on its cone, a cell's angle
//! off the Rayleigh direction, and the start heading from a search on the cone. The
//! loop that reweights from there is `robust.rs`; the heading's 1σ, `sigma.rs`.

use super::sigma::BLOCKS;
use super::{Cells, FieldContext, FieldOptions, NoHeading};
use crate::camera::meridional_basis;
use crate::conventions::wrap_deg_180;
use crate::effects::lens_diattenuation::lens_diattenuation_inverse;
use crate::stokes::image_to_meridional;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Cost cap of the start search: a cell off by more than this is an outlier, radians.
pub(super) const SEARCH_CAP_RAD: f64 = 2.0 * PI / 180.0;
/// Per-cell model error assumed by the start search, radians (so no cell dominates).
pub(super) const SEARCH_SIGMA_RAD: f64 = 0.3 * PI / 180.0;
/// Cells the start search reads at most (evenly strided).
const SEARCH_CELLS: usize = 400;
/// A second minimum of the start cost within this of the first is ambiguous (χ² units
/// of the 1° per-cell error the search assumes).
const AMBIGUITY_CHI2: f64 = 9.0;

/// One cell as the estimator sees it, level frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct Obs {
    /// Unit ray and unit E-vector, level camera frame.
    pub(super) d: DVec3,
    pub(super) e: DVec3,
    pub(super) dolp: f64,
    /// ln of the cell's mean radiance, DN above black.
    pub(super) ln_i: f64,
    /// A colour frame's band ratio ln(I_R/I_B) at the cell ([`Cells::tint`]); NaN
    /// for a monochrome one.
    pub(super) tint: f64,
    /// Noise variance of the cell's AoP, rad².
    pub(super) var_aop: f64,
    pub(super) block: usize,
    /// Index in the cell grid (row-major).
    pub(super) grid: usize,
    /// The E-vector on the level ray's meridional basis: e·p and −e·s (AoE =
    /// atan2(−e·s, e·p)), and cos 2β, sin 2β of the level ray's image angle β.
    pub(super) ep: f64,
    pub(super) es: f64,
    pub(super) cos2b: f64,
    pub(super) sin2b: f64,
}

/// Step 1–2: the cells that pass the masks, in the level frame.
pub(super) fn observe(
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    level: DMat3,
    slots: &mut Vec<Option<Obs>>,
    out: &mut Vec<Obs>,
) {
    let min_el = (opts.horizon_margin_deg + 3.0 * ctx.tilt_sigma_deg).to_radians().sin();
    let block_of = |c: u32, n: usize| ((c as usize * BLOCKS) / n.max(1)).min(BLOCKS - 1);
    slots.clear();
    slots.resize(cells.cells.len(), None);
    slots.par_iter_mut().zip(cells.cells.par_iter()).for_each(|(slot, c)| {
        *slot = (|| {
            let g = ctx.intr.geometry(c.x_px, c.y_px);
            let d = level * g.d;
            if d.z < min_el {
                return None;
            }
            // Image → meridional frame of the assumed ray; a known lens undone (eq. 13).
            let mut sm = image_to_meridional(c.stokes, g.basis.cos2b, g.basis.sin2b);
            if ctx.lens_rho2 != 0.0 {
                sm = lens_diattenuation_inverse(ctx.lens_rho2, g.r2, sm);
            }
            let p2 = sm.q * sm.q + sm.u * sm.u;
            if !(p2 > 0.0 && sm.i > 0.0) {
                return None;
            }
            // E-vector e = cos φ·p − sin φ·s, φ = AoE (camera frame), then level; φ
            // from its double angle (cos 2φ = Q_p/P, sin 2φ = U_p/P) by half angles.
            let pol = p2.sqrt();
            let c2 = sm.q / pol;
            let (cos_phi, sin_phi) = ((0.5 * (1.0 + c2)).max(0.0).sqrt(), (0.5 * (1.0 - c2)).max(0.0).sqrt());
            let e = level * (cos_phi * g.basis.p - sin_phi.copysign(sm.u) * g.basis.s);
            let (q, u) = (c.stokes.q, c.stokes.u);
            let var_aop = ((u * u * c.var_q_dn2 + q * q * c.var_u_dn2) / (4.0 * p2 * p2)).max(1e-12);
            // AoE in the level frame: the angle of e from the level ray's meridian.
            let mb = meridional_basis(d);
            Some(Obs {
                d,
                e,
                dolp: pol / sm.i,
                ln_i: c.stokes.i.max(1e-9).ln(),
                tint: cells.tint.get(c.row as usize * cells.cols + c.col as usize).copied().unwrap_or(f64::NAN),
                var_aop,
                block: block_of(c.col, cells.cols) + BLOCKS * block_of(c.row, cells.rows),
                grid: c.row as usize * cells.cols + c.col as usize,
                ep: e.dot(mb.p),
                es: -e.dot(mb.s),
                cos2b: mb.cos2b,
                sin2b: mb.sin2b,
            })
        })();
    });
    out.clear();
    out.extend(slots.iter().flatten());
}

/// The sun on its cone: level-frame direction for heading ψ ([`on_cone`] at the
/// context's sun).
pub(super) fn cone_sun(ctx: &FieldContext, heading_deg: f64) -> DVec3 {
    on_cone(heading_deg, ctx.sun_az_deg, ctx.sun_el_deg)
}

/// A body at azimuth `az_deg` (from North toward East) and elevation `el_deg` on its
/// cone: its level-frame direction for heading ψ (conventions:
/// `s = (cos h·sin(ψ − A), −cos h·cos(ψ − A), sin h)`); the sun's, or a mixed
/// twilight's other body's (`two_sources.rs`).
pub(super) fn on_cone(heading_deg: f64, az_deg: f64, el_deg: f64) -> DVec3 {
    let (sh, ch) = el_deg.to_radians().sin_cos();
    let (sa, ca) = (heading_deg - az_deg).to_radians().sin_cos();
    DVec3::new(ch * sa, -ch * ca, sh)
}

/// Angle δ of the E-vector off the Rayleigh direction ⊥(sun, ray), as sin δ (radians
/// to 1.5 % up to 17°, and bounded beyond, which is all the weights need), and
/// sin²γ, cos γ of the scattering angle γ.
#[inline]
pub(super) fn residual(o: &Obs, s: DVec3) -> (f64, f64, f64) {
    let cg = o.d.dot(s);
    let sg2 = (1.0 - cg * cg).max(1e-12);
    ((o.e.dot(s) / sg2.sqrt()).clamp(-1.0, 1.0), sg2, cg)
}

/// Step 3: the start heading from a grid search on the sun's cone.
pub(super) fn search(obs: &[Obs], ctx: &FieldContext, sub: &mut Vec<[f64; 7]>) -> Result<f64, NoHeading> {
    // The polarized cells (all of them if fewer than three are), thinned to SEARCH_CELLS.
    let strong = obs.iter().filter(|o| o.dolp > 0.02).count();
    let min_dolp = if strong >= 3 { 0.02 } else { f64::NEG_INFINITY };
    let stride = (if strong >= 3 { strong } else { obs.len() }).div_ceil(SEARCH_CELLS).max(1);
    cone_terms(obs, ctx, min_dolp, stride, SEARCH_SIGMA_RAD, sub);
    let cap = SEARCH_CAP_RAD.sin().powi(2);
    let cost = |psi_deg: f64| capped_cost(sub, psi_deg, cap);
    // 1° steps: the cap is tight (a basin about 2° wide), so a coarser grid could
    // step over the sky's own minimum.
    let grid: [(f64, f64); 360] = std::array::from_fn(|k| (k as f64, cost(k as f64)));
    let refine = |centre: f64| {
        let fine = |c: f64, step: f64| {
            (-6..=6).map(|k| c + step * k as f64).map(|p| (p, cost(p))).fold((c, f64::INFINITY), min_by_cost)
        };
        fine(fine(centre, 0.5).0, 0.05)
    };
    let coarse = grid.iter().copied().fold((0.0, f64::INFINITY), min_by_cost);
    let best = refine(coarse.0);
    // The best other local minimum more than 20° away.
    let n = grid.len();
    let other = (0..n)
        .filter(|&k| grid[k].1 <= grid[(k + 1) % n].1 && grid[k].1 <= grid[(k + n - 1) % n].1)
        .map(|k| grid[k])
        .filter(|g| wrap_deg_180(g.0 - best.0).abs() > 20.0)
        .fold((0.0, f64::INFINITY), min_by_cost);
    if other.1.is_finite() {
        let other = refine(other.0);
        if other.1 - best.1 < AMBIGUITY_CHI2 {
            return Err(NoHeading::Ambiguous {
                best_deg: best.0.rem_euclid(360.0),
                other_deg: other.0.rem_euclid(360.0),
            });
        }
    }
    Ok(best.0)
}

/// Into `sub`: the cells with DoLP above `min_dolp`, every `stride`-th, as the terms
/// of their e·s and d·s on the sun's cone and their weight 1/(σ_α² + σ²). On the cone
/// s(ψ) = cos ψ·a + sin ψ·b + c (cone_sun expanded), so each cell's e·s and d·s are
/// two trigonometric polynomials in ψ: their coefficients once, then each heading
/// costs a few multiplications per cell.
fn cone_terms(obs: &[Obs], ctx: &FieldContext, min_dolp: f64, stride: usize, sigma_rad: f64, sub: &mut Vec<[f64; 7]>) {
    let (sh, ch) = ctx.sun_el_deg.to_radians().sin_cos();
    let (sa, ca) = ctx.sun_az_deg.to_radians().sin_cos();
    let coef = |v: DVec3| [-ch * (sa * v.x + ca * v.y), ch * (ca * v.x - sa * v.y), sh * v.z];
    sub.clear();
    sub.extend(obs.iter().filter(|o| o.dolp > min_dolp).step_by(stride).map(|o| {
        let (e, d) = (coef(o.e), coef(o.d));
        [e[0], e[1], e[2], d[0], d[1], d[2], 1.0 / (o.var_aop + sigma_rad * sigma_rad)]
    }));
}

/// The bounded cost at heading `psi_deg` of the terms in `sub`: Σ w·min(sin²δ, cap),
/// sin²δ = (e·s)²/sin²γ (no arcsine: the cost is bounded anyway).
fn capped_cost(sub: &[[f64; 7]], psi_deg: f64, cap: f64) -> f64 {
    let (sp, cp) = psi_deg.to_radians().sin_cos();
    sub.iter()
        .map(|k| {
            let (es, ds) = (k[0] * cp + k[1] * sp + k[2], k[3] * cp + k[4] * sp + k[5]);
            k[6] * (es * es / (1.0 - ds * ds).max(1e-12)).min(cap)
        })
        .sum::<f64>()
}

/// Cells the sharpening reads at most (evenly strided).
const SHARPEN_CELLS: usize = 2000;
/// The sharpening's stages: (cost cap, step, steps either side), degrees.
const SHARPEN_STAGES: [(f64, f64, i32); 3] = [(0.3, 0.05, 40), (0.15, 0.01, 10), (0.15, 0.002, 5)];
/// Per-cell model error the sharpening assumes beside a cell's noise, radians.
const SHARPEN_SIGMA_RAD: f64 = 0.05 * PI / 180.0;

/// Step 3b: the search's heading `psi_deg` moved to the sharpest agreement near it.
/// The search's 2° cap lets a cloud's soft edge pull its minimum: where the clouds of
/// a frame turn their E-vectors the same way (one deck lit from one side), every
/// partly covered cell leans the same way and the minimum with them, by up to about
/// a degree. The clear cells agree to their noise, the leaning ones spread, so the
/// heading most cells agree on *tightly* is the clear sky's: the same bounded cost,
/// its cap shrunk 1° → 0.4° → 0.15° around the last stage's minimum (graduated
/// non-convexity: each stage starts inside the next one's basin). A clear sky's cells
/// agree either way and the robust loop that follows ends where it did.
pub(super) fn sharpen(obs: &[Obs], ctx: &FieldContext, psi_deg: f64, sub: &mut Vec<[f64; 7]>) -> f64 {
    let strong = obs.iter().filter(|o| o.dolp > 0.02).count();
    if strong < 3 {
        return psi_deg;
    }
    let stride = strong.div_ceil(SHARPEN_CELLS).max(1);
    // At its largest from the first frame on, so a live loop allocates nothing.
    sub.clear();
    sub.reserve(SHARPEN_CELLS);
    cone_terms(obs, ctx, 0.02, stride, SHARPEN_SIGMA_RAD, sub);
    let cost = |p: f64, cap_deg: f64| capped_cost(sub, p, cap_deg.to_radians().sin().powi(2));
    let mut best = psi_deg;
    for (cap_deg, step, n) in SHARPEN_STAGES {
        let centre = best;
        best = (-n..=n)
            .map(|k| centre + step * k as f64)
            .map(|p| (p, cost(p, cap_deg)))
            .fold((centre, f64::INFINITY), min_by_cost)
            .0;
    }
    best
}

fn min_by_cost(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    if b.1 < a.1 {
        b
    } else {
        a
    }
}
