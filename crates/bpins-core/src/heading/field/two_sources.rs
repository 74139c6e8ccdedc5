//! A twilight sky lit by both the sun and the moon: the heading from two Rayleigh
//! patterns summed as Stokes vectors, the polarized share fitted beside the heading.
//!
//! ```text
//! per cell (level frame): ray d, observed E-vector e, f = d × e (both ⊥ d)
//! m_k = d × s_k(ψ)                    |m_k|² = sin²γ_k, s_k the body k on its cone at heading ψ
//! Z_k = ((m_k·e)² − (m_k·f)², 2(m_k·e)(m_k·f))   = sin²γ_k·(cos 2φ_k, sin 2φ_k), φ_k the angle of
//!                                       Rayleigh's E-vector ⊥(s_k, d) from e
//! z   = w·Z_p + (1 − w)·Z_o            the Stokes sum (Q, U ∝ d_max·½·sin²γ per unit radiance)
//! δ   = ½·atan2(z_y, z_x)              the predicted AoP off the observed one, radians
//! w   = 1/(1 + e^−θ),  θ ~ N(θ₀, σ_θ²) the frame's source's share of the polarized radiance per
//!                                       unit (θ₀ from the model's shares, [`SecondSource::share`])
//! minimize Σ ρ(δ_i/σ_i) + (θ − θ₀)²/σ_θ²  over (ψ, θ); σ_i² = σ_α,i² + τ², ρ Tukey's biweight
//! ```
//!
//! Source: the sum is the `twilight` scene element's (`scene/twilight.rs`): two
//! incoherent skies add as Stokes vectors, each Rayleigh's about its own body with the
//! frame's d_max (Cronin, Warrant & Greiner 2006 for the sun below the horizon), each
//! weighted by its zenith luminance over Rayleigh's zenith radiance about it
//! (`sky/twilight.rs`: K&S, Patat et al. 2006). Both bodies' azimuths come from the
//! ephemeris, so one heading turns both. The share is uncertain (Patat's twilight is
//! Paranal's; a lower, hazier site's is ≈ 30 % brighter; K&S's moonlit sky is good to a
//! few tens of per cent), so θ is fitted with a weak prior, σ_θ = [`SHARE_LOG_ODDS_SIGMA`]
//! (a factor e ≈ 2.7 on the ratio of the two skies), and the heading's 1σ is the
//! marginal one: the joint covariance's ψψ element, so w's uncertainty is in it. Where
//! the two bodies stand nearly in line (their patterns nearly agree) the data do not
//! tell w: the prior holds it, and the heading's 1σ carries what their correlation
//! leaves (measured, docs/night.md "Twilight": with the moon low and nearly opposite
//! the sun it widens to 0.2–0.4°, the errors alike). The start: a 1° grid search of ψ
//! at five shares about θ₀ (±1σ_θ, ±2σ_θ, with the prior's penalty), the share then
//! scanned and ψ refined in turn; then rounds of τ, Tukey's weights and Gauss–Newton.
//!
//! 1σ² = max(σ_fit, σ_jack, σ_coherent)² + σ_misfit² + σ_tilt² + σ_sun² + σ_floor² as
//! the one-source estimator's step 5 (`sigma.rs`), each on the joint fit: σ_fit from the
//! curvature (χ²-scaled), σ_jack deleting one of 4 × 4 image blocks and refitting both
//! parameters, σ_coherent the spatial sandwich of the profiled score (the heading's score
//! less its projection on θ's), σ_tilt through the frame's source.
//!
//! Units: degrees at the interface, radians inside. Frame: level camera (CONVENTIONS.md).
//! Clouds (`two_sources_clouds.rs`): `clouds.rs`'s tests on the mixed sky (DoLP under
//! 0.6 × the mixed clear sky's, brighter than the smooth sky, whiter on a colour
//! frame), weight 0, clustered and grown by 2 cells, and beside them the clustered Tukey rejections
//! grown likewise (a rim the tests missed); the frame's cloud fraction as the
//! one-source reader's. Measured (docs/night.md "Twilight", four clouds of 4–8° above
//! 72°, 2026-06-24T12:20Z, seeds 1–6, 48 frames): RMS 0.359° → 0.139°, within 2σ
//! 42 → 44 of 48, largest |err|/σ 3.0 → 2.6; clear mixed frames print what they did.
//!
//! Cannot: a cloud where the two patterns cross (the mixed DoLP near 0: the cells'
//! DoLP says nothing there, their label is their neighbours'); an overcast's holes
//! (`holes.rs` reads one source's); the smooth radiance's second body (its γ is the
//! larger share's); the other source's own depolarization or neutral points
//! (both skies carry the frame's d_max); twilight's own sky shape (the Earth's shadow,
//! its colour); the meridian-line extractor (every extractor asked for reads this fit);
//! the check of the sky's own sun elevation (`sun_elevation_offset_deg` is 0).
//!
//! Reported: the heading with its 1σ, and the fitted share w with its 1σ
//! ([`FieldHeading::fitted_share`]: w(1 − w)·σ_θ, σ_θ the larger of the joint fit's
//! marginal 1σ of θ, χ²-scaled as σ_fit, and θ's delete-one-block jackknife). A warm
//! compass reads a mixed frame without allocating ([`Scratch`], in
//! [`super::FieldScratch`]). Where things live: this file, the model, the start and the
//! fit's 1σ; `two_sources_clouds.rs`, the cloud rounds.

use super::observe::{observe, on_cone, Obs, SEARCH_CAP_RAD, SEARCH_SIGMA_RAD};
use super::robust::misfit_beyond_clear_deg;
use super::sigma::BLOCKS;
use super::stats::jackknife_sd;
use super::{
    dark::Polarized, spatial::coherent_sigma_deg, Cells, FieldContext, FieldHeading, FieldOptions, FieldQuality,
    FieldScratch, FittedShare, NoHeading, SigmaParts,
};
use crate::conventions::{heading_deg_from_level_sun, level_from_camera, wrap_deg_180, wrap_rad_90};
use crate::heading::Extractor;
use crate::sky::twilight::Shares;
use glam::DVec3;

#[path = "two_sources_clouds.rs"]
mod rounds;
use rounds::{mixed_clouds, robust_rounds, CloudBufs, Seen};

/// The prior's 1σ on the share's log-odds θ (module doc).
pub const SHARE_LOG_ODDS_SIGMA: f64 = 1.0;
/// Cells the start search reads at most (evenly strided).
const SEARCH_CELLS: usize = 600;
/// A second minimum of the start cost within this of the first is ambiguous (χ²).
const AMBIGUITY_CHI2: f64 = 9.0;
/// Robust Gauss–Newton rounds.
const ROUNDS: usize = 12;

/// The clouds found at one (ψ, θ) stand while ψ moves by less than
/// `robust.rs`'s [`CLOUDS_SETTLED_DEG`] and θ (the share's log-odds) by less than this.
const SHARE_SETTLED: f64 = 0.05;

/// The second source of a mixed twilight: where it stands and its share of the sky.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SecondSource {
    /// The other body's azimuth (from North toward East) and elevation, degrees (the
    /// frame's source is [`FieldContext`]'s sun).
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    /// The model's share of the frame's source in the polarized radiance per unit
    /// (`w` above, in (0, 1)): the fit's start and its prior's centre.
    pub share: f64,
    /// The zenith shares it was made from (for the words).
    pub shares: Shares,
}

/// One cell as the two-source fit reads it.
#[derive(Clone, Copy, Debug)]
struct Cell2 {
    d: DVec3,
    e: DVec3,
    f: DVec3,
    var: f64,
    block: usize,
    grid: usize,
}

/// The double-angle vector of body `s` at ray `d` on the basis (e, f): sin²γ·(cos 2φ, sin 2φ).
#[inline]
fn pattern(c: &Cell2, s: DVec3) -> (f64, f64) {
    let m = c.d.cross(s);
    let (a, b) = (m.dot(c.e), m.dot(c.f));
    (a * a - b * b, 2.0 * a * b)
}

/// The mixed sky's predicted AoP off the observed one, radians, for the frame's source
/// at `sp` and the other at `so` with share `w` of the frame's source.
#[inline]
fn delta(c: &Cell2, sp: DVec3, so: DVec3, w: f64) -> f64 {
    let (zp, zo) = (pattern(c, sp), pattern(c, so));
    let (x, y) = (w * zp.0 + (1.0 - w) * zo.0, w * zp.1 + (1.0 - w) * zo.1);
    0.5 * y.atan2(x)
}

/// The mixed sky's predicted double-angle vector: w·Z_p + (1 − w)·Z_o at one cell
/// (for tests and the docs).
pub fn mixed_pattern(d: DVec3, e: DVec3, sp: DVec3, so: DVec3, w: f64) -> (f64, f64) {
    let c = Cell2 { d, e, f: d.cross(e), var: 0.0, block: 0, grid: 0 };
    let (zp, zo) = (pattern(&c, sp), pattern(&c, so));
    (w * zp.0 + (1.0 - w) * zo.0, w * zp.1 + (1.0 - w) * zo.1)
}

fn logistic(t: f64) -> f64 {
    1.0 / (1.0 + (-t).exp())
}

/// The fit's model at one parameter point.
struct Model<'a> {
    ctx: &'a FieldContext,
    other: &'a SecondSource,
}

impl Model<'_> {
    fn suns(&self, psi_deg: f64) -> (DVec3, DVec3) {
        (
            on_cone(psi_deg, self.ctx.sun_az_deg, self.ctx.sun_el_deg),
            on_cone(psi_deg, self.other.azimuth_deg, self.other.elevation_deg),
        )
    }
}

/// The joint fit's state.
#[derive(Clone, Copy, Debug)]
struct Fit {
    psi_deg: f64,
    theta: f64,
    /// Inverse of the normal matrix (ψ in degrees, θ).
    cov: [[f64; 2]; 2],
    chi2_dof: f64,
}

impl Fit {
    /// The fitted share w and its 1σ w(1 − w)·σ_θ: σ_θ the larger of θ's marginal
    /// 1σ (χ²-scaled, as σ_fit) and `jackknife_theta`, θ's delete-one-block jackknife
    /// (as σ_jack: a misfit shared by neighbouring cells moves w as it moves ψ);
    /// `None` where they give no finite one.
    fn share(&self, jackknife_theta: f64) -> Option<FittedShare> {
        let w = logistic(self.theta);
        let sd_theta = (self.cov[1][1].max(0.0).sqrt() * self.chi2_dof.max(1.0).sqrt()).max(jackknife_theta);
        let sigma = w * (1.0 - w) * sd_theta;
        (w.is_finite() && sigma.is_finite()).then_some(FittedShare { share: w, sigma })
    }
}

/// Gauss–Newton on (ψ, θ) with fixed per-cell weights `wt` (robust weight / σ²) over
/// the cells `keep` admits, from `start`; returns the end point and the inverse normal
/// matrix.
fn gauss_newton(
    cells: &[Cell2],
    wt: &[f64],
    keep: &dyn Fn(usize) -> bool,
    m: &Model<'_>,
    theta0: f64,
    start: (f64, f64),
    rounds: usize,
) -> ((f64, f64), [[f64; 2]; 2]) {
    let (mut psi, mut th) = start;
    let mut cov = [[f64::INFINITY, 0.0], [0.0, SHARE_LOG_ODDS_SIGMA.powi(2)]];
    let (hp, ht) = (1e-3, 1e-4);
    for _ in 0..rounds {
        let (sp, so) = m.suns(psi);
        let (sp2, so2) = m.suns(psi + hp);
        let w = logistic(th);
        let w2 = logistic(th + ht);
        let (mut a, mut b, mut c, mut g0, mut g1) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (i, cl) in cells.iter().enumerate() {
            if wt[i] <= 0.0 || !keep(i) {
                continue;
            }
            let r = delta(cl, sp, so, w);
            let jp = wrap_rad_90(delta(cl, sp2, so2, w) - r) / hp;
            let jt = wrap_rad_90(delta(cl, sp, so, w2) - r) / ht;
            a += wt[i] * jp * jp;
            b += wt[i] * jp * jt;
            c += wt[i] * jt * jt;
            g0 += wt[i] * jp * r;
            g1 += wt[i] * jt * r;
        }
        let prior = 1.0 / SHARE_LOG_ODDS_SIGMA.powi(2);
        c += prior;
        g1 += prior * (th - theta0);
        let det = a * c - b * b;
        if !(det > 0.0 && det.is_finite()) {
            break;
        }
        cov = [[c / det, -b / det], [-b / det, a / det]];
        let (dp, dt) = (-(c * g0 - b * g1) / det, -(a * g1 - b * g0) / det);
        psi += dp.clamp(-5.0, 5.0);
        th += dt.clamp(-2.0, 2.0);
        if dp.abs() < 1e-5 && dt.abs() < 1e-5 {
            break;
        }
    }
    ((psi, th), cov)
}

/// The start: a grid search of the heading in 1° steps on the bounded cost, at the
/// model's share and at the share's log-odds ±1σ and ±2σ of the prior (so a sky whose
/// share the model misses by a factor of several still starts in the heading's basin),
/// each with the prior's penalty; the heading's profile over those shares decides, and
/// a second minimum of it more than 20° away within χ² 9 is an ambiguous frame.
/// Returns (ψ in degrees, θ).
fn search(cells: &[Cell2], m: &Model<'_>, theta0: f64) -> Result<(f64, f64), NoHeading> {
    let stride = cells.len().div_ceil(SEARCH_CELLS).max(1);
    let sub = || cells.iter().step_by(stride);
    let cap = SEARCH_CAP_RAD * SEARCH_CAP_RAD;
    let cost = |psi: f64, th: f64| {
        let (sp, so) = m.suns(psi);
        let w = logistic(th);
        let data = sub().map(|c| (delta(c, sp, so, w).powi(2)).min(cap) / (c.var + SEARCH_SIGMA_RAD.powi(2)));
        data.sum::<f64>() + ((th - theta0) / SHARE_LOG_ODDS_SIGMA).powi(2)
    };
    let thetas = [-2.0, -1.0, 0.0, 1.0, 2.0].map(|k| theta0 + k * SHARE_LOG_ODDS_SIGMA);
    // Per heading of the grid: the best of the shares, (ψ, cost, θ) (on the stack: a
    // warm compass allocates nothing).
    let grid: [(f64, f64, f64); 360] = std::array::from_fn(|k| {
        let psi = k as f64;
        thetas.iter().map(|&th| (psi, cost(psi, th), th)).fold((psi, f64::INFINITY, theta0), |a, b| {
            if b.1 < a.1 {
                b
            } else {
                a
            }
        })
    });
    let min = |a: (f64, f64), b: (f64, f64)| if b.1 < a.1 { b } else { a };
    let refine = |c: f64, th: f64| {
        let fine = |c: f64, step: f64| {
            (-6..=6).map(|k| c + step * k as f64).map(|p| (p, cost(p, th))).fold((c, f64::INFINITY), min)
        };
        fine(fine(c, 0.5).0, 0.05)
    };
    let at = grid.iter().copied().fold((0.0, f64::INFINITY, theta0), |a, b| if b.1 < a.1 { b } else { a });
    // Then the share and the heading in turn: θ in 0.1 steps about the grid's, ψ refined.
    let (mut best, mut th) = (refine(at.0, at.2), at.2);
    for _ in 0..3 {
        let scan = (-6..=6).map(|k| th + 0.1 * k as f64).map(|t| (t, cost(best.0, t)));
        th = scan.fold((th, f64::INFINITY), min).0;
        best = refine(best.0, th);
    }
    let n = grid.len();
    let other = (0..n)
        .filter(|&k| grid[k].1 <= grid[(k + 1) % n].1 && grid[k].1 <= grid[(k + n - 1) % n].1)
        .map(|k| grid[k])
        .filter(|g| wrap_deg_180(g.0 - best.0).abs() > 20.0)
        .fold((0.0, f64::INFINITY, theta0), |a, b| if b.1 < a.1 { b } else { a });
    if other.1.is_finite() {
        let o = refine(other.0, other.2);
        if o.1 - best.1 < AMBIGUITY_CHI2 {
            return Err(NoHeading::Ambiguous { best_deg: best.0.rem_euclid(360.0), other_deg: o.0.rem_euclid(360.0) });
        }
    }
    Ok((best.0, th))
}

/// The headings of a mixed twilight frame's cells: the frame's source at `ctx`'s sun
/// and `other` beside it (module doc), with buffers kept in `scratch` between frames.
/// Every extractor in `extractors` gets this one fit.
pub fn estimate_two(
    cells: &Cells,
    ctx: &FieldContext,
    other: &SecondSource,
    opts: &FieldOptions,
    extractors: &[Extractor],
    scratch: &mut FieldScratch,
) -> Vec<FieldHeading> {
    let outcome = fit_two(cells, ctx, other, opts, &mut scratch.two);
    extractors.iter().map(|&extractor| heading_of(&outcome, extractor)).collect()
}

/// [`estimate_two`] with one extractor: once `scratch` has grown to the frame's grid,
/// a mixed frame with a heading allocates nothing (a frame without one may, for its
/// reason's text), as [`super::estimate_with`] for one source.
pub fn estimate_two_with(
    cells: &Cells,
    ctx: &FieldContext,
    other: &SecondSource,
    opts: &FieldOptions,
    extractor: Extractor,
    scratch: &mut FieldScratch,
) -> FieldHeading {
    heading_of(&fit_two(cells, ctx, other, opts, &mut scratch.two), extractor)
}

/// One extractor's reading of the fit's outcome.
fn heading_of(outcome: &Outcome, extractor: Extractor) -> FieldHeading {
    let (result, quality, fitted_share) = match outcome {
        Ok((h, parts, q, share)) => (Ok((*h, *parts)), *q, *share),
        Err((q, why)) => (Err(why.clone()), *q, None),
    };
    FieldHeading { extractor, result, quality, source: crate::sky::SkySource::Given, fitted_share }
}

/// The heading, its 1σ, the quality and the fitted share, or why there is none.
type Outcome = Result<(f64, SigmaParts, FieldQuality, Option<FittedShare>), (FieldQuality, NoHeading)>;

/// The two-source reader's buffers, kept between frames ([`FieldScratch`]): once grown
/// to the frame's grid, a mixed frame allocates nothing.
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
    slots: Vec<Option<Obs>>,
    obs: Vec<Obs>,
    /// Every observed cell, and those away from both bodies.
    c2: Vec<Cell2>,
    cells2: Vec<Cell2>,
    seen: Vec<Seen>,
    /// The cloud tests' and the robust rounds' (`two_sources_clouds.rs`).
    cb: CloudBufs,
    /// The jackknife's deviations (ψ, θ) and the sandwich's sums.
    dev: Vec<f64>,
    dev_theta: Vec<f64>,
    sums: Vec<f64>,
}

fn fit_two(cells: &Cells, ctx: &FieldContext, other: &SecondSource, opts: &FieldOptions, sc: &mut Scratch) -> Outcome {
    let mut quality = FieldQuality { cells_total: cells.grid_len(), ..Default::default() };
    if ctx.sun_el_deg > 89.0 {
        return Err((quality, NoHeading::SunAtZenith { sun_el_deg: ctx.sun_el_deg }));
    }
    if !(other.share > 0.0 && other.share < 1.0) {
        return Err((quality, NoHeading::Solver(format!("a mixed sky's share {} outside (0, 1)", other.share))));
    }
    let level = ctx.level_from_camera();
    let Scratch { slots, obs, c2, cells2, seen, cb, dev, dev_theta, sums } = sc;
    observe(cells, ctx, opts, level, slots, obs);
    quality.cells_valid = obs.len();
    let polarized = Polarized::of(obs);
    if let Some(why) = polarized.too_dark() {
        return Err((quality, why));
    }
    let min_used = opts.min_cells.max((opts.min_used_fraction * quality.cells_total as f64).ceil() as usize);
    let m = Model { ctx, other };
    let cos_excl = opts.sun_exclusion_deg.to_radians().cos();
    c2.clear();
    c2.extend(obs.iter().map(|o: &Obs| Cell2 {
        d: o.d,
        e: o.e,
        f: o.d.cross(o.e),
        var: o.var_aop,
        block: o.block,
        grid: o.grid,
    }));
    if c2.len() < min_used {
        return Err((
            quality,
            polarized.explain(NoHeading::TooLittleSky { used: c2.len(), total: quality.cells_total }),
        ));
    }
    let theta0 = (other.share / (1.0 - other.share)).ln();
    let (psi0, theta_start) = search(c2, &m, theta0).map_err(|r| (quality, polarized.explain(r)))?;
    let (sp, so) = m.suns(psi0);
    let near = |c: &Cell2, sp: DVec3, so: DVec3| c.d.dot(sp) > cos_excl || c.d.dot(so) > cos_excl;
    // Cells away from both bodies (aureole, glare): sun_exclusion_deg about each, which
    // turn with ψ: taken at the start heading.
    cells2.clear();
    cells2.extend(c2.iter().copied().filter(|c| !near(c, sp, so)));
    seen.clear();
    seen.extend(obs.iter().map(|o| Seen { dolp: o.dolp, ln_i: o.ln_i, tint: o.tint }));
    let dims = (cells.cols, cells.rows);
    let r = robust_rounds(c2, cells2, seen, &m, theta0, (psi0, theta_start), opts.min_cells, dims, cb);
    let (psi, th, tau2, cov) = (r.psi_deg, r.theta, r.tau2, r.cov);
    quality.iterations = r.iterations;
    // What the fit left: used cells, residual beyond noise, χ²; the clouds at the end
    // point, clustered and grown, as the frame's cloud fraction (`robust.rs`).
    let (sp, so) = m.suns(psi);
    let w = logistic(th);
    mixed_clouds(c2, seen, (sp, so, w), tau2, opts.min_cells, cells.cols, cells.rows, cb);
    quality.cloud_fraction = c2.iter().filter(|c| cb.grown[c.grid]).count() as f64 / c2.len().max(1) as f64;
    let wt = &cb.wt;
    let (mut sw, mut swd2, mut noise, mut used, mut chi2) = (0.0, 0.0, 0.0, 0usize, 0.0);
    for (c, &x) in cells2.iter().zip(wt) {
        let rw = x * (c.var + tau2);
        if rw >= 0.5 {
            let d = delta(c, sp, so, w);
            used += 1;
            sw += rw;
            swd2 += rw * d * d;
            noise += rw * c.var;
            chi2 += x * d * d;
        }
    }
    quality.cells_used = used;
    quality.used_fraction = used as f64 / quality.cells_total.max(1) as f64;
    quality.misfit_deg = tau2.sqrt().to_degrees();
    quality.residual_rms_deg = if sw > 0.0 { (swd2 / sw).sqrt().to_degrees() } else { f64::NAN };
    if used < min_used {
        return Err((quality, polarized.explain(NoHeading::TooLittleSky { used, total: quality.cells_total })));
    }
    let misfit_rms_deg = if sw > 0.0 { ((swd2 - noise).max(0.0) / sw).sqrt().to_degrees() } else { f64::NAN };
    if misfit_rms_deg > opts.max_residual_deg {
        return Err((quality, NoHeading::PoorFit { residual_deg: misfit_rms_deg, limit_deg: opts.max_residual_deg }));
    }
    if !(cov[0][0].is_finite() && cov[0][0] > 0.0) {
        return Err((quality, NoHeading::Solver("the two-source fit's normal matrix is singular".into())));
    }
    let dof = (used as f64 - 2.0).max(1.0);
    let fit = Fit { psi_deg: psi, theta: th, cov, chi2_dof: chi2 / dof };
    let (parts, jackknife_theta) =
        sigma_parts(cells2, wt, &m, theta0, &fit, cells, opts, misfit_rms_deg, (dev, dev_theta, sums));
    Ok((psi.rem_euclid(360.0), parts, quality, fit.share(jackknife_theta)))
}

/// Step 5 on the joint fit (module doc).
#[allow(clippy::too_many_arguments)]
fn sigma_parts(
    cells2: &[Cell2],
    wt: &[f64],
    m: &Model<'_>,
    theta0: f64,
    fit: &Fit,
    cells: &Cells,
    opts: &FieldOptions,
    misfit_rms_deg: f64,
    (dev, dev_theta, t): (&mut Vec<f64>, &mut Vec<f64>, &mut Vec<f64>),
) -> (SigmaParts, f64) {
    let fit_deg = fit.cov[0][0].max(0.0).sqrt() * fit.chi2_dof.max(1.0).sqrt();
    // Delete-one-block jackknife, both parameters refitted.
    dev.clear();
    dev_theta.clear();
    for b in 0..BLOCKS * BLOCKS {
        if !cells2.iter().zip(wt).any(|(c, &x)| c.block == b && x > 0.0) {
            continue;
        }
        let keep = |i: usize| cells2[i].block != b;
        let ((p, th), _) = gauss_newton(cells2, wt, &keep, m, theta0, (fit.psi_deg, fit.theta), 4);
        dev.push(wrap_deg_180(p - fit.psi_deg));
        dev_theta.push(th - fit.theta);
    }
    let jackknife_deg = if dev.len() >= 2 { jackknife_sd(dev) } else { 2.0 * fit_deg };
    // The share's log-odds by the same jackknife ([`Fit::share`]).
    let jackknife_theta = if dev_theta.len() >= 2 { jackknife_sd(dev_theta) } else { 0.0 };
    // The spatial sandwich of the profiled score: a = a_ψ − (H_ψθ/H_θθ)·a_θ (H_θθ with
    // the prior), its curvature Σ w·a_ψ·a = H_ψψ − H_ψθ²/H_θθ, the inverse of the
    // marginal variance (the prior's score is not a draw of the sky, so not in V).
    let (sp, so) = m.suns(fit.psi_deg);
    let (sp2, so2) = m.suns(fit.psi_deg + 0.01);
    let w = logistic(fit.theta);
    let w2 = logistic(fit.theta + 1e-4);
    let (hpt, htt) = (-fit.cov[0][1], fit.cov[0][0]); // ∝ the normal matrix's ψθ, θθ (same det)
    let k = if htt > 0.0 { hpt / htt } else { 0.0 };
    let coherent_deg = coherent_sigma_deg(
        cells2.iter().zip(wt).filter(|(_, &x)| x > 0.0).map(|(c, &x)| {
            let r = delta(c, sp, so, w);
            let ap = wrap_rad_90(delta(c, sp2, so2, w) - r) / 0.01;
            let at = wrap_rad_90(delta(c, sp, so, w2) - r) / 1e-4;
            let a = ap - k * at;
            (c.grid, x * r * a, x * ap * a)
        }),
        cells.cols,
        cells.rows,
        t,
    );
    let coherent_deg = if coherent_deg.is_finite() { coherent_deg } else { 0.0 };
    let misfit_deg = misfit_beyond_clear_deg(misfit_rms_deg);
    // The reference tilt through the frame's source (as sigma.rs).
    let ctx = m.ctx;
    let level = ctx.level_from_camera();
    let s_cam = level.transpose() * sp;
    let eps = 1e-3;
    let dpsi = |dx: f64, dy: f64| {
        let l = level_from_camera(ctx.tilt_x_deg + dx, ctx.tilt_y_deg + dy)
            * level_from_camera(ctx.mount_tilt_deg[0], ctx.mount_tilt_deg[1]);
        wrap_deg_180(heading_deg_from_level_sun(l * s_cam, ctx.sun_az_deg) - fit.psi_deg) / eps
    };
    let parts = SigmaParts {
        fit_deg,
        jackknife_deg,
        coherent_deg,
        misfit_deg,
        cross_deg: 0.0,
        tilt_deg: ctx.tilt_sigma_deg * dpsi(eps, 0.0).hypot(dpsi(0.0, eps)),
        sun_deg: ctx.sun_sigma_deg,
        floor_deg: opts.sigma_floor_deg,
    };
    (parts, jackknife_theta)
}

#[cfg(test)]
#[path = "two_sources_tests.rs"]
mod tests;
