//! The robust loop of the field estimator (steps 1–5 of `mod.rs`).
//! (About 540 lines: the loop reads as one sequence of its steps; its masks and order
//! statistics are in `stats.rs`.)

use super::clouds::{brighter, clear_dmax, depolarized, propagate, CellSky};
use super::spatial::coherent_sigma_deg;
use super::stats::{grown_clusters, quantile, tukey};
use super::{Cells, FieldContext, FieldHeading, FieldOptions, FieldQuality, NoHeading, SigmaParts};
use crate::camera::meridional_basis;
use crate::conventions::{heading_deg_from_level_sun, image_angle_rad, level_from_camera, wrap_deg_180};
use crate::effects::lens_diattenuation::lens_diattenuation_inverse;
use crate::heading::{meridian, sun_vector, Extractor, HeadingSums};
use crate::stokes::image_to_meridional;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// Jackknife blocks per side of the image (BLOCKS² in all).
pub(super) const BLOCKS: usize = 4;
/// Cost cap of the start search: a cell off by more than this is an outlier, radians.
const SEARCH_CAP_RAD: f64 = 2.0 * PI / 180.0;
/// Per-cell model error assumed by the start search, radians (so no cell dominates).
const SEARCH_SIGMA_RAD: f64 = 0.3 * PI / 180.0;
/// Cells the start search reads at most (evenly strided).
const SEARCH_CELLS: usize = 400;
/// A second minimum of the start cost within this of the first is ambiguous (χ² units
/// of the 1° per-cell error the search assumes).
const AMBIGUITY_CHI2: f64 = 9.0;
const MAX_ITERATIONS: usize = 8;
/// The clouds found at one sun stand while the sun moves by less than this, degrees.
const CLOUDS_SETTLED_DEG: f64 = 0.05;
/// Clustered rejections grow by this many cells (soft edges of clouds and crowns).
const DILATE_CELLS: isize = 2;

/// One cell as the estimator sees it, level frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct Obs {
    /// Unit ray and unit E-vector, level camera frame.
    pub(super) d: DVec3,
    pub(super) e: DVec3,
    dolp: f64,
    /// ln of the cell's mean radiance, DN above black.
    ln_i: f64,
    /// Noise variance of the cell's AoP, rad².
    pub(super) var_aop: f64,
    pub(super) block: usize,
    /// Index in the cell grid (row-major).
    grid: usize,
    /// The E-vector on the level ray's meridional basis: e·p and −e·s (AoE =
    /// atan2(−e·s, e·p)), and cos 2β, sin 2β of the level ray's image angle β.
    ep: f64,
    es: f64,
    cos2b: f64,
    sin2b: f64,
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

/// Wraps an axial angle in radians to (−π/2, π/2].
fn wrap_rad_90(a: f64) -> f64 {
    let r = a.rem_euclid(PI);
    if r > FRAC_PI_2 {
        r - PI
    } else {
        r
    }
}

/// The sun on its cone: level-frame direction for heading ψ (conventions:
/// `s = (cos h·sin(ψ − A), −cos h·cos(ψ − A), sin h)`).
fn cone_sun(ctx: &FieldContext, heading_deg: f64) -> DVec3 {
    let (sh, ch) = ctx.sun_el_deg.to_radians().sin_cos();
    let (sa, ca) = (heading_deg - ctx.sun_az_deg).to_radians().sin_cos();
    DVec3::new(ch * sa, -ch * ca, sh)
}

/// Angle δ of the E-vector off the Rayleigh direction ⊥(sun, ray), as sin δ (radians
/// to 1.5 % up to 17°, and bounded beyond, which is all the weights need), and
/// sin²γ, cos γ of the scattering angle γ.
#[inline]
fn residual(o: &Obs, s: DVec3) -> (f64, f64, f64) {
    let cg = o.d.dot(s);
    let sg2 = (1.0 - cg * cg).max(1e-12);
    ((o.e.dot(s) / sg2.sqrt()).clamp(-1.0, 1.0), sg2, cg)
}

/// Step 3: the start heading from a grid search on the sun's cone.
fn search(obs: &[Obs], ctx: &FieldContext, sub: &mut Vec<[f64; 7]>) -> Result<f64, NoHeading> {
    // The polarized cells (all of them if fewer than three are), thinned to SEARCH_CELLS.
    let strong = obs.iter().filter(|o| o.dolp > 0.02).count();
    let min_dolp = if strong >= 3 { 0.02 } else { f64::NEG_INFINITY };
    let stride = (if strong >= 3 { strong } else { obs.len() }).div_ceil(SEARCH_CELLS).max(1);
    // On the cone s(ψ) = cos ψ·a + sin ψ·b + c (cone_sun expanded), so each cell's e·s
    // and d·s are two trigonometric polynomials in ψ: their coefficients once, then
    // each heading costs a few multiplications per cell.
    let (sh, ch) = ctx.sun_el_deg.to_radians().sin_cos();
    let (sa, ca) = ctx.sun_az_deg.to_radians().sin_cos();
    let coef = |v: DVec3| [-ch * (sa * v.x + ca * v.y), ch * (ca * v.x - sa * v.y), sh * v.z];
    sub.clear();
    sub.extend(obs.iter().filter(|o| o.dolp > min_dolp).step_by(stride).map(|o| {
        let (e, d) = (coef(o.e), coef(o.d));
        [e[0], e[1], e[2], d[0], d[1], d[2], 1.0 / (o.var_aop + SEARCH_SIGMA_RAD * SEARCH_SIGMA_RAD)]
    }));
    // sin²δ = (e·s)²/sin²γ, capped (no arcsine: the cost is bounded anyway).
    let cap = SEARCH_CAP_RAD.sin().powi(2);
    let cost = |psi_deg: f64| {
        let (sp, cp) = psi_deg.to_radians().sin_cos();
        sub.iter()
            .map(|k| {
                let (es, ds) = (k[0] * cp + k[1] * sp + k[2], k[3] * cp + k[4] * sp + k[5]);
                k[6] * (es * es / (1.0 - ds * ds).max(1e-12)).min(cap)
            })
            .sum::<f64>()
    };
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

fn min_by_cost(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    if b.1 < a.1 {
        b
    } else {
        a
    }
}

/// Step 4's weights for the sun at `s` into `b.w`: (robust weight, σ² = σ_α² + τ²,
/// sin²γ, δ) per cell; `b.cloud` marks the cells taken for cloud (`clouds.rs`).
/// Returns τ.
fn weights(obs: &[Obs], s: DVec3, opts: &FieldOptions, cols: usize, grid_len: usize, b: &mut Bufs) -> f64 {
    let cos_excl = opts.sun_exclusion_deg.to_radians().cos();
    b.res.clear();
    b.res.extend(obs.iter().map(|o| residual(o, s)));
    // Which cells fit the sun, by the misfit scale of every cell (clouds included).
    b.t.clear();
    b.t.extend(
        obs.iter()
            .zip(&b.res)
            .filter(|(_, r)| r.2.abs() < cos_excl)
            .map(|(o, r)| (r.0.powi(2) - CHI2_1_Q25 * o.var_aop) / CHI2_1_Q25),
    );
    let tau2_all = quantile(&mut b.t, 0.25).max(0.0);
    let tau2_all = if tau2_all.is_finite() { tau2_all } else { 0.0 };
    // Clouds: depolarized against the clear sky's expectation, or brighter than the
    // smooth sky (clouds.rs); cloud cells that cluster, grown by their soft edges (a
    // cloud's rim is turned like its core but may keep its DoLP and its brightness).
    // Once the sun moves by less than CLOUDS_SETTLED_DEG between rounds, the clouds
    // found at the last sun stand.
    let settled = b.clouds_at.is_some_and(|at| at.dot(s) > CLOUDS_SETTLED_DEG.to_radians().cos());
    if !settled {
        clouds(obs, tau2_all, opts.min_cells, cols, grid_len / cols.max(1), b);
        let cloud = obs.iter().zip(&b.cloud).map(|(o, &c)| (o.grid, c));
        let (mask, kept, tmp) = (&mut b.mask, &mut b.clustered, &mut b.tmp);
        grown_clusters(cloud, grid_len, cols, DILATE_CELLS as usize, mask, kept, tmp, &mut b.cloud_grown);
        b.clouds_at = Some(s);
    }
    // τ: the lower quartile of δ²/(σ_α² + τ²) at χ²₁'s (0.1015) over the clear cells
    // away from clouds, so that up to three quarters of them may still be misfit by
    // what the cloud tests miss: δ²/(v + τ²) ≤ c ⟺ (δ² − c·v)/c ≤ τ², so τ² is the
    // lower quartile of (δ² − c·v)/c (0 where the noise explains it); the cells near
    // the sun and the anti-sun are left out of it. Where too few cells lie away from
    // clouds, every cell that is not cloud counts.
    let away = obs.iter().zip(&b.res).filter(|(o, r)| r.2.abs() < cos_excl && !b.cloud_grown[o.grid]).count();
    let min_away = opts.min_cells.min(obs.len());
    b.t.clear();
    b.t.extend(
        obs.iter()
            .zip(&b.res)
            .zip(&b.cloud)
            .filter(|((o, r), &cloud)| r.2.abs() < cos_excl && !cloud && (away < min_away || !b.cloud_grown[o.grid]))
            .map(|((o, r), _)| (r.0.powi(2) - TAU_CHI2 * o.var_aop) / TAU_CHI2),
    );
    let tau2 = quantile(&mut b.t, TAU_Q).max(0.0);
    let tau2 = if tau2.is_finite() { tau2 } else { 0.0 };
    b.w.clear();
    b.w.extend(obs.iter().zip(&b.res).zip(&b.cloud).map(|((o, &(delta, sg2, cg)), &cloud)| {
        let var = o.var_aop + tau2;
        let w = if cg.abs() < cos_excl && !cloud { tukey(delta / var.sqrt()) } else { 0.0 };
        (w, var, sg2, delta)
    }));
    // A rejected cell's neighbours are suspect: clouds and crowns have soft edges whose
    // misfit is below the cut. Rejections that come in clusters (not a lone noisy cell,
    // not the sun's disc) grow by DILATE_CELLS.
    let rejected = obs.iter().zip(&b.w).map(|(o, x)| (o.grid, x.0 < 0.5 && cg_of(x.2) < cos_excl));
    let (mask, kept, tmp) = (&mut b.mask, &mut b.clustered, &mut b.tmp);
    grown_clusters(rejected, grid_len, cols, DILATE_CELLS as usize, mask, kept, tmp, &mut b.grown);
    for (o, x) in obs.iter().zip(b.w.iter_mut()) {
        if b.grown[o.grid] {
            x.0 = 0.0;
        }
    }
    tau2.sqrt()
}

/// Into `b.cloud`: the cells the cloud tests take for cloud (`clouds.rs`) against the
/// sun of the residuals in `b.res` (δ, sin²γ, cos γ); `tau2` says which cells fit.
fn clouds(obs: &[Obs], tau2: f64, min_cells: usize, cols: usize, rows: usize, b: &mut Bufs) {
    b.sky.clear();
    b.sky.extend(obs.iter().zip(&b.res).map(|(o, r)| CellSky {
        dolp: o.dolp,
        ln_i: o.ln_i,
        cg: r.2,
        z: o.d.z,
        fits: r.0.powi(2) < 9.0 * (o.var_aop + tau2),
        grid: o.grid,
    }));
    let dmax = clear_dmax(&b.sky, min_cells, &mut b.t);
    depolarized(&b.sky, dmax, &mut b.depol);
    b.clear.clear();
    b.clear.extend(b.sky.iter().zip(&b.depol).map(|(c, &d)| c.fits && c.verifiable() && !d));
    brighter(&b.sky, &b.clear, &mut b.t, &mut b.bright);
    b.cloud.clear();
    b.cloud.extend(b.depol.iter().zip(&b.bright).map(|(&d, &br)| d || br));
    propagate(&b.sky, cols, rows, &mut b.cloud, &mut b.votes);
}

/// |cos γ| back from sin²γ.
fn cg_of(sg2: f64) -> f64 {
    (1.0 - sg2).max(0.0).sqrt()
}

/// The lower quartile of χ² with one degree of freedom.
const CHI2_1_Q25: f64 = 0.1015;
const TAU_Q: f64 = 0.25;
const TAU_CHI2: f64 = CHI2_1_Q25;

/// Per-block weighted sums of one extractor: the sun vector's scatter, or the
/// meridian band (cells with |ψ| < band inside the zenith disc).
pub(super) fn block_sums(
    obs: &[Obs],
    w: &[(f64, f64, f64, f64)],
    extractor: Extractor,
    band: (f64, f64, f64),
) -> [HeadingSums; BLOCKS * BLOCKS] {
    let mut sums = [HeadingSums::default(); BLOCKS * BLOCKS];
    let (band_rad, zmin_cos, zmax_cos) = band;
    for (o, &(rw, var, sg2, _)) in obs.iter().zip(w) {
        if rw <= 0.0 {
            continue;
        }
        let b = &mut sums[o.block];
        match extractor {
            Extractor::SunVector => b.add_scatter_weighted(o.e, rw / (var * sg2)),
            Extractor::MeridianLine => {
                // |ψ| < band, ψ = AoE − 90°: cos 2ψ = −cos 2·AoE > cos 2·band.
                let cos_2aoe = (o.ep * o.ep - o.es * o.es) / (o.ep * o.ep + o.es * o.es);
                if -cos_2aoe > (2.0 * band_rad).cos() && o.d.z <= zmin_cos && o.d.z >= zmax_cos {
                    let psi = wrap_rad_90(o.es.atan2(o.ep) - FRAC_PI_2);
                    let beta = image_angle_rad(o.d.x, o.d.y);
                    b.add_band_weighted(beta, psi, o.cos2b, o.sin2b, rw / var);
                }
            }
        }
    }
    sums
}

/// Heading (degrees) and fit 1σ of one extractor from level-frame sums, the sun's
/// branch taken nearest `hint` (level frame).
fn solve(sums: &HeadingSums, extractor: Extractor, ctx: &FieldContext, hint: DVec3) -> Result<(f64, f64), String> {
    let est = match extractor {
        Extractor::SunVector => {
            let (vals, mut vecs) = sun_vector::scatter_eigen(sums).map_err(|e| e.to_string())?;
            if vecs[0].dot(hint) < 0.0 {
                vecs[0] = -vecs[0];
            }
            sun_vector::heading_from_eigen(vals, vecs, sums.n, DMat3::IDENTITY, ctx.sun_az_deg)
        }
        Extractor::MeridianLine => meridian::solve_line(sums, image_angle_rad(hint.x, hint.y), ctx.sun_az_deg, true),
    }
    .map_err(|e| e.to_string())?;
    Ok((est.heading_deg, est.sigma_deg))
}

/// The buffers of the robust loop, kept between frames so that a live loop allocates
/// nothing once they have grown to the frame's grid.
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    pub(super) slots: Vec<Option<Obs>>,
    /// The cells that passed the masks (steps 1–2), level frame.
    pub(super) obs: Vec<Obs>,
    /// The start search's cells: e·s and d·s as cos ψ, sin ψ, 1 coefficients, weight.
    sub: Vec<[f64; 7]>,
    pub(super) b: Bufs,
    /// Per cell of the grid: whether it was seen as non-sky (a cluster of depolarized
    /// cells, grown), for the sky mask.
    sky_grown: Vec<bool>,
}

/// Step 4's buffers; `w` holds the final weights (robust weight, σ², sin²γ, δ) per
/// observed cell.
#[derive(Clone, Debug, Default)]
pub(super) struct Bufs {
    res: Vec<(f64, f64, f64)>,
    t: Vec<f64>,
    sky: Vec<CellSky>,
    depol: Vec<bool>,
    bright: Vec<bool>,
    clear: Vec<bool>,
    cloud: Vec<bool>,
    votes: Vec<[u32; 2]>,
    /// The cloud cells grown by their soft edges, and the sun they were found at
    /// (`None`: not yet for this frame).
    cloud_grown: Vec<bool>,
    clouds_at: Option<DVec3>,
    pub(super) w: Vec<(f64, f64, f64, f64)>,
    mask: Vec<bool>,
    clustered: Vec<bool>,
    tmp: Vec<bool>,
    grown: Vec<bool>,
}

/// The outcome of steps 1–4 (the cells and their final weights stay in the scratch).
pub(super) struct Robust {
    /// The sun vector's heading the weights settled on, degrees.
    pub(super) heading_deg: f64,
    /// The heading's 1σ under the spatially correlated misfit (`spatial.rs`), degrees.
    pub(super) coherent_deg: f64,
    /// The used cells' RMS angle residual beyond their noise, degrees.
    pub(super) misfit_rms_deg: f64,
    /// Step 5's misfit part: the bias the used cells beside clouds may carry, degrees.
    pub(super) misfit_deg: f64,
    pub(super) quality: FieldQuality,
}

/// Steps 1–4 on one frame's cells.
pub(super) fn robust(
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    sc: &mut Scratch,
) -> Result<Robust, (FieldQuality, NoHeading)> {
    let mut quality = FieldQuality { cells_total: cells.grid_len(), ..Default::default() };
    if ctx.sun_el_deg < -10.0 {
        return Err((quality, NoHeading::SunTooLow { sun_el_deg: ctx.sun_el_deg }));
    }
    if ctx.sun_el_deg > 89.0 {
        return Err((quality, NoHeading::SunAtZenith { sun_el_deg: ctx.sun_el_deg }));
    }
    let level = ctx.level_from_camera();
    observe(cells, ctx, opts, level, &mut sc.slots, &mut sc.obs);
    let obs = &sc.obs;
    quality.cells_valid = obs.len();
    let min_used = opts.min_cells.max((opts.min_used_fraction * quality.cells_total as f64).ceil() as usize);
    if obs.len() < min_used {
        return Err((quality, NoHeading::TooLittleSky { used: obs.len(), total: quality.cells_total }));
    }
    let mut psi = search(obs, ctx, &mut sc.sub).map_err(|r| (quality, r))?;
    // Step 4: reweight around the sun vector's heading until it settles.
    let band = meridian_band(ctx, opts, level, cells);
    let b = &mut sc.b;
    b.clouds_at = None;
    let mut tau = weights(obs, cone_sun(ctx, psi), opts, cells.cols, cells.grid_len(), b);
    for it in 1..=MAX_ITERATIONS {
        quality.iterations = it;
        let total = sum_blocks(&block_sums(obs, &b.w, Extractor::SunVector, band));
        let Ok((next, _)) = solve(&total, Extractor::SunVector, ctx, cone_sun(ctx, psi)) else { break };
        let step = wrap_deg_180(next - psi);
        psi = next;
        tau = weights(obs, cone_sun(ctx, psi), opts, cells.cols, cells.grid_len(), b);
        if step.abs() < 1e-3 {
            break;
        }
    }
    let w = &b.w;
    quality.misfit_deg = tau.to_degrees();
    quality.cells_used = w.iter().filter(|x| x.0 >= 0.5).count();
    quality.used_fraction = quality.cells_used as f64 / quality.cells_total.max(1) as f64;
    let (sw, swd2) = w.iter().filter(|x| x.0 >= 0.5).fold((0.0, 0.0), |(a, b), x| (a + x.0, b + x.0 * x.3 * x.3));
    quality.residual_rms_deg = if sw > 0.0 { (swd2 / sw).sqrt().to_degrees() } else { f64::NAN };
    // The same beyond the cells' noise: what of it the sky's pattern does not explain.
    let noise = obs.iter().zip(w.iter()).filter(|(_, x)| x.0 >= 0.5).map(|(o, x)| x.0 * o.var_aop).sum::<f64>();
    let misfit_rms_deg = if sw > 0.0 { ((swd2 - noise).max(0.0) / sw).sqrt().to_degrees() } else { f64::NAN };
    // The sky's own sun (the unconstrained sun vector), as a check on the attitude: its
    // elevation in the level frame minus the known one.
    let hint = cone_sun(ctx, psi);
    let all = sum_blocks(&block_sums(obs, w, Extractor::SunVector, band));
    if let Ok((_, vecs)) = sun_vector::scatter_eigen(&all) {
        let s = if vecs[0].dot(hint) < 0.0 { -vecs[0] } else { vecs[0] };
        quality.sun_elevation_offset_deg = s.z.clamp(-1.0, 1.0).asin().to_degrees() - ctx.sun_el_deg;
    }
    // The 1σ the residual's spatial coherence allows (spatial.rs): each used cell's
    // score on the sun's cone, a_i = ∂δ_i/∂ψ by a difference of 0.01°.
    let ahead = cone_sun(ctx, psi + 0.01);
    let coherent_deg = coherent_sigma_deg(
        obs.iter().zip(w.iter()).filter(|(_, x)| x.0 > 0.0).map(|(o, x)| {
            let wi = x.0 / x.1;
            let a = (residual(o, ahead).0 - x.3) / 0.01;
            (o.grid, wi * x.3 * a, wi * a * a)
        }),
        cells.cols,
        cells.rows,
        &mut b.t,
    );
    // The sky mask's non-sky: clusters of cloud cells (clouds.rs), grown (w is final,
    // so step 4's other buffers are free).
    b.res.clear();
    b.res.extend(obs.iter().map(|o| residual(o, hint)));
    clouds(obs, tau * tau, opts.min_cells, cells.cols, cells.rows, b);
    let cloud = obs.iter().zip(&b.cloud).map(|(o, &c)| (o.grid, c));
    let (mask, kept, tmp) = (&mut b.mask, &mut b.clustered, &mut b.tmp);
    grown_clusters(cloud, cells.grid_len(), cells.cols, DILATE_CELLS as usize, mask, kept, tmp, &mut sc.sky_grown);
    let clouded = obs.iter().filter(|o| sc.sky_grown[o.grid]).count();
    quality.cloud_fraction = clouded as f64 / obs.len().max(1) as f64;
    // The misfit part: what the used sky misfits beyond its noise and beyond what a
    // clear sky leaves. A turn shared by the used cells (rims of clouds that turn
    // together, rims of clouds whose cores lie outside the view) biases the heading by
    // up to that much, and no sandwich over the residuals can see it.
    let misfit_deg = if misfit_rms_deg.is_finite() {
        (misfit_rms_deg.powi(2) - CLEAR_RESIDUAL_DEG.powi(2)).max(0.0).sqrt()
    } else {
        0.0
    };
    Ok(Robust { heading_deg: psi, coherent_deg, misfit_rms_deg, misfit_deg, quality })
}

impl Scratch {
    /// Per cell of the grid, after [`robust`]: sky that follows the model's pattern — a
    /// cell that passed the masks (whole, unsaturated, above the horizon margin) and is
    /// not in or beside a cluster of depolarized cells (clouds, foliage, the aureole).
    /// Residuals alone never take a cell out of it: a lens or sensor effect moves AoP,
    /// and a fit must still see where it does.
    pub(super) fn sky_cells(&self, grid_len: usize) -> Vec<bool> {
        let mut sky = vec![false; grid_len];
        for o in &self.obs {
            sky[o.grid] = !self.sky_grown[o.grid];
        }
        sky
    }
}

/// Steps 1–4 and the checks on what they left: the frame's robust fit, or why it has
/// no heading.
pub(super) fn fitted(
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    sc: &mut Scratch,
) -> Result<Robust, (FieldQuality, NoHeading)> {
    let r = robust(cells, ctx, opts, sc)?;
    let quality = r.quality;
    let min_used = opts.min_cells.max((opts.min_used_fraction * quality.cells_total as f64).ceil() as usize);
    if quality.cells_used < min_used {
        return Err((quality, NoHeading::TooLittleSky { used: quality.cells_used, total: quality.cells_total }));
    }
    // The sky's own sun against the given one: a clock or place that is wrong, a tilt
    // that is wrong about the axis across the sun, or a mosaic read with the wrong
    // layout all move it by more than the inputs' 1σ can.
    let limit_deg = opts.max_sun_offset_deg.hypot(4.0 * ctx.sun_sigma_deg.hypot(ctx.tilt_sigma_deg));
    if quality.sun_elevation_offset_deg.abs() > limit_deg {
        return Err((quality, NoHeading::Contradicts { offset_deg: quality.sun_elevation_offset_deg, limit_deg }));
    }
    if r.misfit_rms_deg > opts.max_residual_deg {
        return Err((quality, NoHeading::PoorFit { residual_deg: r.misfit_rms_deg, limit_deg: opts.max_residual_deg }));
    }
    Ok(r)
}

/// Step 5 for one extractor on the fit `r` left in `sc`.
pub(super) fn heading(
    r: &Robust,
    e: Extractor,
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    sc: &Scratch,
) -> FieldHeading {
    let level = ctx.level_from_camera();
    let band = meridian_band(ctx, opts, level, cells);
    let hint = cone_sun(ctx, r.heading_deg);
    let coherent_deg = if r.coherent_deg.is_finite() { r.coherent_deg } else { 0.0 };
    let read = |e: Extractor| {
        finish(&block_sums(&sc.obs, &sc.b.w, e, band), e, ctx, opts, hint, level)
            .map(|(h, parts)| (h, SigmaParts { coherent_deg, misfit_deg: r.misfit_deg, ..parts }))
    };
    let result = read(e).map_err(NoHeading::Solver).map(|(h, parts)| {
        // The other extractor reads the same cells another way (the E-vectors' common
        // normal, or the solar meridian's line): where the two disagree beyond twice
        // the 1σ of their difference, the sky holds something neither models (a turned
        // region that one weighs more than the other), and the disagreement joins the 1σ.
        let other = match e {
            Extractor::SunVector => Extractor::MeridianLine,
            Extractor::MeridianLine => Extractor::SunVector,
        };
        let cross_deg = match read(other) {
            Ok((h2, p2)) => {
                let d = wrap_deg_180(h - h2).abs();
                if d > 2.0 * parts.total_deg().hypot(p2.total_deg()) {
                    d
                } else {
                    0.0
                }
            }
            Err(_) => 0.0,
        };
        (h, SigmaParts { cross_deg, ..parts })
    });
    FieldHeading { extractor: e, result, quality: r.quality }
}

/// What a clear sky's unmodelled structure leaves in the used cells' residual beyond
/// their noise (a Berry sky, the aureole, a tilted fisheye's skyline: ≤ 1.2° RMS in
/// the field table), degrees.
const CLEAR_RESIDUAL_DEG: f64 = 0.5;
pub(super) fn sum_blocks(blocks: &[HeadingSums]) -> HeadingSums {
    let mut t = HeadingSums::default();
    for b in blocks {
        t += *b;
    }
    t
}

/// The meridian line's band and zenith disc: (band half-width, cos z_min, cos z_max),
/// the disc the largest about the zenith inside the image, less the tilt.
fn meridian_band(ctx: &FieldContext, opts: &FieldOptions, level: DMat3, cells: &Cells) -> (f64, f64, f64) {
    let i = &ctx.intr;
    // The principal point's distance to the nearest edge of the read image, as
    // HeadingContext's r_max.
    let (w, h) = ((cells.cols * cells.cell_px) as f64, (cells.rows * cells.cell_px) as f64);
    let r_max_px = i.cx_px.min(i.cy_px).min(w - 1.0 - i.cx_px).min(h - 1.0 - i.cy_px).max(0.0);
    let disc = i.projection.angle_from_radius(r_max_px / i.f_px).unwrap_or(FRAC_PI_2);
    let off_axis = (level * DVec3::Z).z.clamp(-1.0, 1.0).acos();
    let zmax = (disc - off_axis).min(FRAC_PI_2 - opts.horizon_margin_deg.to_radians()).max(0.0);
    (opts.band_deg.to_radians(), (0.02f64).cos(), zmax.cos())
}

/// Step 5 for one extractor: heading, and its 1σ parts.
fn finish(
    blocks: &[HeadingSums],
    e: Extractor,
    ctx: &FieldContext,
    opts: &FieldOptions,
    hint: DVec3,
    level: DMat3,
) -> Result<(f64, SigmaParts), String> {
    let total = sum_blocks(blocks);
    let (heading_deg, fit_deg) = solve(&total, e, ctx, hint)?;
    // Delete-one-block jackknife over the blocks that hold samples.
    let mut used = 0;
    let mut dev = [0.0; BLOCKS * BLOCKS];
    let mut solved = 0;
    for b in blocks.iter().filter(|b| b.n > 0.0 || b.line.iter().any(|l| l[6] > 0.0)) {
        used += 1;
        if let Ok((h, _)) = solve(&total.minus(b), e, ctx, hint) {
            dev[solved] = wrap_deg_180(h - heading_deg);
            solved += 1;
        }
    }
    let (dev, k) = (&dev[..solved], used as f64);
    let jackknife_deg = if dev.len() >= 2 && dev.len() as f64 == k {
        let mean = dev.iter().sum::<f64>() / k;
        ((k - 1.0) / k * dev.iter().map(|d| (d - mean).powi(2)).sum::<f64>()).sqrt()
    } else {
        // Too few blocks to leave one out (or one that cannot be left out): the fit's
        // own σ, doubled.
        2.0 * fit_deg
    };
    // The reference tilt's error, propagated: ∂ψ/∂tilt through the camera-frame sun.
    let s_cam = level.transpose() * cone_sun(ctx, heading_deg);
    let eps = 1e-3;
    let dpsi = |dx: f64, dy: f64| {
        let l = level_from_camera(ctx.tilt_x_deg + dx, ctx.tilt_y_deg + dy)
            * level_from_camera(ctx.mount_tilt_deg[0], ctx.mount_tilt_deg[1]);
        wrap_deg_180(heading_deg_from_level_sun(l * s_cam, ctx.sun_az_deg) - heading_deg) / eps
    };
    let tilt_deg = ctx.tilt_sigma_deg * dpsi(eps, 0.0).hypot(dpsi(0.0, eps));
    Ok((
        heading_deg,
        SigmaParts {
            fit_deg,
            jackknife_deg,
            coherent_deg: 0.0,
            misfit_deg: 0.0,
            cross_deg: 0.0,
            tilt_deg,
            sun_deg: ctx.sun_sigma_deg,
            floor_deg: opts.sigma_floor_deg,
        },
    ))
}
