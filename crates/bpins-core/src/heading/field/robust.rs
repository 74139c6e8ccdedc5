//! The robust loop of the field estimator: step 4 of `mod.rs` (reweight around the
//! sun vector's heading until it settles: clouds, the misfit scale τ, Tukey's
//! weights), run on the cells of steps 1–3 (`observe.rs`), and the checks on what it
//! left. The heading and its 1σ (step 5) are `sigma.rs`; the loop's masks and order
//! statistics, `stats.rs`.

use super::clouds::{label, rayleigh_dolp, CellSky, TestBufs};
use super::dark::Polarized;
use super::holes;
use super::observe::{cone_sun, observe, residual, search, sharpen, Obs};
use super::sigma::{block_sums, meridian_band, solve, sum_blocks};
use super::spatial::coherent_sigma_deg;
use super::stats::{grown_clusters, quantile, tukey};
use super::{Cells, FieldContext, FieldOptions, FieldQuality, NoHeading};
use crate::conventions::wrap_deg_180;
use crate::heading::{sun_vector, Extractor};
use glam::DVec3;

const MAX_ITERATIONS: usize = 8;
/// The clouds found at one sun stand while the sun moves by less than this, degrees.
pub(super) const CLOUDS_SETTLED_DEG: f64 = 0.05;
/// Clustered rejections grow by this many cells (soft edges of clouds and crowns).
pub(super) const DILATE_CELLS: usize = 2;
/// What a clear sky's unmodelled structure leaves in the used cells' residual beyond
/// their noise (a Berry sky, the aureole, a tilted fisheye's skyline: ≤ 1.2° RMS in
/// the field table), degrees.
pub(super) const CLEAR_RESIDUAL_DEG: f64 = 0.5;
/// A start whose misfit scale τ is within this is taken as a tight clear sky, and τ
/// stays bounded by it through the loop, degrees.
const TAU_BOUND_DEG: f64 = 1.0;
/// A frame whose cloud fraction is above this is an overcast: where the cells step 4
/// kept misfit or contradict the sun, its holes are read instead (`holes.rs`).
const OVERCAST_FRACTION: f64 = 0.9;

/// Step 4's weights for the sun at `s` into `b.w`: (robust weight, σ² = σ_α² + τ²,
/// sin²γ, δ) per cell; `b.cloud` marks the cells taken for cloud (`clouds.rs`).
/// Returns τ.
#[allow(clippy::too_many_arguments)]
fn weights(
    obs: &[Obs],
    s: DVec3,
    tau_cap: f64,
    opts: &FieldOptions,
    cols: usize,
    grid_len: usize,
    b: &mut Bufs,
) -> f64 {
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
        // Which cells fit: at the misfit scale of every cell, bounded like τ (a deck
        // whose rims all lean one way would otherwise call them fitting, and the
        // smooth sky they lift would hide them).
        clouds(obs, tau2_all.min(tau_cap * tau_cap), opts.min_cells, cols, grid_len / cols.max(1), b);
        let cloud = obs.iter().zip(&b.cloud).map(|(o, &c)| (o.grid, c));
        let (mask, kept, tmp) = (&mut b.mask, &mut b.clustered, &mut b.tmp);
        grown_clusters(cloud, grid_len, cols, DILATE_CELLS, mask, kept, tmp, &mut b.cloud_grown);
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
    // A tight start (τ bounded, below) reads τ from the lower 15 % with χ²₁'s 15 %
    // point instead: the clear sky's own misfit wherever at least 30 % of the sky in
    // view is clear, however the rest leans (clouds that turn together).
    let (q, c) = if tau_cap.is_finite() { (TIGHT_Q, TIGHT_CHI2) } else { (TAU_Q, TAU_CHI2) };
    b.t.clear();
    b.t.extend(
        obs.iter()
            .zip(&b.res)
            .zip(&b.cloud)
            .filter(|((o, r), &cloud)| r.2.abs() < cos_excl && !cloud && (away < min_away || !b.cloud_grown[o.grid]))
            .map(|((o, r), _)| (r.0.powi(2) - c * o.var_aop) / c),
    );
    let tau2 = quantile(&mut b.t, q).max(0.0).min(tau_cap * tau_cap);
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
    grown_clusters(rejected, grid_len, cols, DILATE_CELLS, mask, kept, tmp, &mut b.grown);
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
        tint: o.tint,
        cg: r.2,
        z: o.d.z,
        shape: rayleigh_dolp(r.2),
        fits: r.0.powi(2) < 9.0 * (o.var_aop + tau2),
        grid: o.grid,
    }));
    label(&b.sky, cols, rows, min_cells, &mut b.t, &mut b.tests, &mut b.cloud);
}

/// |cos γ| back from sin²γ.
fn cg_of(sg2: f64) -> f64 {
    (1.0 - sg2).max(0.0).sqrt()
}

/// The lower quartile of χ² with one degree of freedom.
pub(super) const CHI2_1_Q25: f64 = 0.1015;
pub(super) const TAU_Q: f64 = 0.25;
pub(super) const TAU_CHI2: f64 = CHI2_1_Q25;
/// τ's quantile after a tight start, and χ²₁'s value there.
const TIGHT_Q: f64 = 0.15;
const TIGHT_CHI2: f64 = 0.035_766;

/// The buffers of the robust loop, kept between frames so that a live loop allocates
/// nothing once they have grown to the frame's grid.
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    pub(super) slots: Vec<Option<Obs>>,
    /// The cells that passed the masks (steps 1–2), level frame.
    pub(super) obs: Vec<Obs>,
    /// The start search's cells: e·s and d·s as cos ψ, sin ψ, 1 coefficients, weight.
    pub(super) sub: Vec<[f64; 7]>,
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
    tests: TestBufs,
    cloud: Vec<bool>,
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
    /// The frame's polarized signal and noise (dark.rs), for naming a failed check.
    pub(super) polarized: Polarized,
    /// Factor on the jackknife's 1σ: Student's t over the normal's for the few
    /// independent groups an overcast's holes are (`holes.rs`); 1 otherwise.
    pub(super) jackknife_t: f64,
    /// 1σ of the sky's own sun elevation where few groups of cells set it (the holes'
    /// jackknife, `holes.rs`), degrees; 0 where the sky in view sets it well.
    pub(super) sun_offset_sigma_deg: f64,
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
    // A frame too dark to tell (dark.rs): refused before the fit; a dim one's failure
    // named for the dark.
    let polarized = Polarized::of(obs);
    if let Some(why) = polarized.too_dark() {
        return Err((quality, why));
    }
    if obs.len() < min_used {
        return Err((
            quality,
            polarized.explain(NoHeading::TooLittleSky { used: obs.len(), total: quality.cells_total }),
        ));
    }
    let psi = search(obs, ctx, &mut sc.sub).map_err(|r| (quality, polarized.explain(r)))?;
    let mut psi = sharpen(obs, ctx, psi, &mut sc.sub);
    // Step 4: reweight around the sun vector's heading until it settles.
    let band = meridian_band(ctx, opts, level, cells);
    let b = &mut sc.b;
    b.clouds_at = None;
    // τ at the sharpened start bounds it from here on where that start found a sky
    // as tight as a clear one (τ within TAU_BOUND_DEG): the loop may settle the misfit
    // scale lower, never let cells that lean together (the rims of a deck that turns
    // one way) widen it and walk off with the heading. A start that found no tight
    // sky (a mosaic read with the wrong layout, a sky no model here describes) leaves
    // τ free, so the misfit is seen whole and the checks below can refuse it.
    let mut tau = weights(obs, cone_sun(ctx, psi), f64::INFINITY, opts, cells.cols, cells.grid_len(), b);
    let tau_start = if tau <= TAU_BOUND_DEG.to_radians() { tau } else { f64::INFINITY };
    for it in 1..=MAX_ITERATIONS {
        quality.iterations = it;
        let total = sum_blocks(&block_sums(obs, &b.w, Extractor::SunVector, band));
        let Ok((next, _)) = solve(&total, Extractor::SunVector, ctx, cone_sun(ctx, psi)) else { break };
        let step = wrap_deg_180(next - psi);
        psi = next;
        tau = weights(obs, cone_sun(ctx, psi), tau_start, opts, cells.cols, cells.grid_len(), b);
        if step.abs() < 1e-3 {
            break;
        }
    }
    let (mut quality, coherent_deg, misfit_rms_deg, misfit_deg) =
        summary(obs, &b.w, ctx, cells, band, psi, tau, quality, &mut b.t);
    let hint = cone_sun(ctx, psi);
    // The sky mask's non-sky: clusters of cloud cells (clouds.rs), grown (w is final,
    // so step 4's other buffers are free).
    b.res.clear();
    b.res.extend(obs.iter().map(|o| residual(o, hint)));
    clouds(obs, tau * tau, opts.min_cells, cells.cols, cells.rows, b);
    let cloud = obs.iter().zip(&b.cloud).map(|(o, &c)| (o.grid, c));
    let (mask, kept, tmp) = (&mut b.mask, &mut b.clustered, &mut b.tmp);
    grown_clusters(cloud, cells.grid_len(), cells.cols, DILATE_CELLS, mask, kept, tmp, &mut sc.sky_grown);
    let clouded = obs.iter().filter(|o| sc.sky_grown[o.grid]).count();
    quality.cloud_fraction = clouded as f64 / obs.len().max(1) as f64;
    Ok(Robust {
        heading_deg: psi,
        coherent_deg,
        misfit_rms_deg,
        misfit_deg,
        quality,
        polarized,
        jackknife_t: 1.0,
        sun_offset_sigma_deg: 0.0,
    })
}

/// What step 4 left, for the checks and step 5: the used cells (robust weight ≥ ½) and
/// their residual beyond noise, the sky's own sun, σ_coherent and the misfit part.
/// Returns (quality, σ_coherent, misfit RMS beyond noise, misfit part), degrees; `t`
/// is a buffer.
#[allow(clippy::too_many_arguments)]
pub(super) fn summary(
    obs: &[Obs],
    w: &[(f64, f64, f64, f64)],
    ctx: &FieldContext,
    cells: &Cells,
    band: (f64, f64, f64),
    psi: f64,
    tau: f64,
    mut quality: FieldQuality,
    t: &mut Vec<f64>,
) -> (FieldQuality, f64, f64, f64) {
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
        t,
    );
    // The misfit part: what the used sky misfits beyond its noise and beyond what a
    // clear sky leaves. A turn shared by the used cells (rims of clouds that turn
    // together, rims of clouds whose cores lie outside the view) biases the heading by
    // up to that much, and no sandwich over the residuals can see it.
    (quality, coherent_deg, misfit_rms_deg, misfit_beyond_clear_deg(misfit_rms_deg))
}

/// The misfit part of the 1σ, degrees: the used cells' residual RMS `misfit_rms_deg`
/// beyond what a clear sky leaves ([`CLEAR_RESIDUAL_DEG`]), 0 where it is not finite.
pub(super) fn misfit_beyond_clear_deg(misfit_rms_deg: f64) -> f64 {
    if misfit_rms_deg.is_finite() {
        (misfit_rms_deg.powi(2) - CLEAR_RESIDUAL_DEG.powi(2)).max(0.0).sqrt()
    } else {
        0.0
    }
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
    let first = robust(cells, ctx, opts, sc).and_then(|r| {
        let dim = r.polarized;
        fitted_checks(r, ctx, opts).map_err(|(q, why)| (q, dim.explain(why)))
    });
    // Too little sky where step 4 grew the clouds over a deck's few holes, or an
    // overcast's few cells it kept that misfit or set their own sun poorly: the holes'
    // clear cores, if enough (holes.rs), else the first reason.
    let overcast = |q: &FieldQuality, why: &NoHeading| match why {
        NoHeading::TooLittleSky { .. } => true,
        NoHeading::Contradicts { .. } | NoHeading::PoorFit { .. } => q.cloud_fraction > OVERCAST_FRACTION,
        _ => false,
    };
    match first {
        Err((q, why)) if overcast(&q, &why) && !sc.obs.is_empty() && q.cells_valid > 0 => {
            let holes_opts = FieldOptions { min_cells: holes::MIN_CORE_CELLS, min_used_fraction: 0.0, ..*opts };
            holes::fitted(cells, ctx, opts, sc, q)
                .and_then(|r| fitted_checks(r, ctx, &holes_opts))
                .map_err(|_| (q, why))
        }
        r => r,
    }
}

/// [`fitted`]'s checks on the robust fit `r`.
fn fitted_checks(r: Robust, ctx: &FieldContext, opts: &FieldOptions) -> Result<Robust, (FieldQuality, NoHeading)> {
    let quality = r.quality;
    let min_used = opts.min_cells.max((opts.min_used_fraction * quality.cells_total as f64).ceil() as usize);
    if quality.cells_used < min_used {
        return Err((quality, NoHeading::TooLittleSky { used: quality.cells_used, total: quality.cells_total }));
    }
    // The sky's own sun against the given one: a clock or place that is wrong, a tilt
    // that is wrong about the axis across the sun, or a mosaic read with the wrong
    // layout all move it by more than the inputs' 1σ can.
    let limit_deg = opts
        .max_sun_offset_deg
        .hypot(4.0 * ctx.sun_sigma_deg.hypot(ctx.tilt_sigma_deg))
        .hypot(3.0 * r.sun_offset_sigma_deg);
    if quality.sun_elevation_offset_deg.abs() > limit_deg {
        return Err((quality, NoHeading::Contradicts { offset_deg: quality.sun_elevation_offset_deg, limit_deg }));
    }
    if r.misfit_rms_deg > opts.max_residual_deg {
        return Err((quality, NoHeading::PoorFit { residual_deg: r.misfit_rms_deg, limit_deg: opts.max_residual_deg }));
    }
    Ok(r)
}
