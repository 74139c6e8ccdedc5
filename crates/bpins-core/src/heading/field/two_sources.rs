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
//! Clouds: `clouds.rs`'s tests on the mixed sky ([`mixed_clouds`]: DoLP under 0.6 × the
//! mixed clear sky's, brighter than the smooth sky, whiter on a colour frame), weight
//! 0, clustered and grown by 2 cells, and beside them the clustered Tukey rejections
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
//! the check of the sky's own sun elevation (`sun_elevation_offset_deg` is 0); a warm
//! compass's no-allocation promise (a mixed frame allocates its cells' buffers).

use super::clouds::{brighter, clear_dmax, depolarized, propagate, reference, whiter, CellSky};
use super::observe::{observe, Obs, SEARCH_CAP_RAD, SEARCH_SIGMA_RAD};
use super::robust::{misfit_beyond_clear_deg, CLOUDS_SETTLED_DEG, DILATE_CELLS, TAU_CHI2, TAU_Q};
use super::sigma::BLOCKS;
use super::stats::{grown_clusters, jackknife_sd, quantile, tukey};
use super::{
    dark::Polarized, spatial::coherent_sigma_deg, Cells, FieldContext, FieldHeading, FieldOptions, FieldQuality,
    NoHeading, SigmaParts,
};
use crate::conventions::{heading_deg_from_level_sun, level_from_camera, wrap_deg_180};
use crate::heading::Extractor;
use crate::sky::twilight::Shares;
use glam::DVec3;

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

/// The body at azimuth `az_deg`, elevation `el_deg` in the level frame at heading ψ
/// (conventions: `s = (cos h·sin(ψ − A), −cos h·cos(ψ − A), sin h)`).
pub(super) fn body(heading_deg: f64, az_deg: f64, el_deg: f64) -> DVec3 {
    let (sh, ch) = el_deg.to_radians().sin_cos();
    let (sa, ca) = (heading_deg - az_deg).to_radians().sin_cos();
    DVec3::new(ch * sa, -ch * ca, sh)
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
fn mixed_shape(c: &Cell2, sp: DVec3, so: DVec3, w: f64) -> f64 {
    let (zp, zo) = (pattern(c, sp), pattern(c, so));
    let (x, y) = (w * zp.0 + (1.0 - w) * zo.0, w * zp.1 + (1.0 - w) * zo.1);
    let i = w * (1.0 + c.d.dot(sp).powi(2)) + (1.0 - w) * (1.0 + c.d.dot(so).powi(2));
    x.hypot(y) / i
}

/// What a cell offers the cloud tests beside its geometry (from [`Obs`]).
#[derive(Clone, Copy, Debug)]
struct Seen {
    dolp: f64,
    ln_i: f64,
    tint: f64,
}

/// Buffers of the cloud tests (`clouds.rs`).
#[derive(Default)]
struct CloudBufs {
    sky: Vec<CellSky>,
    t: Vec<f64>,
    depol: Vec<bool>,
    keep: Vec<bool>,
    clear: Vec<bool>,
    bright: Vec<bool>,
    more: Vec<bool>,
    white: Vec<bool>,
    cloud: Vec<bool>,
    votes: Vec<[u32; 2]>,
    mask: Vec<bool>,
    kept: Vec<bool>,
    tmp: Vec<bool>,
    /// Per cell of the grid: cloud, clustered and grown by DILATE_CELLS.
    grown: Vec<bool>,
    /// Per cell of the grid: the clustered rejections of a round, grown.
    rejected: Vec<bool>,
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
fn mixed_clouds(
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
    let dmax = clear_dmax(&b.sky, min_cells, &mut b.t);
    depolarized(&b.sky, dmax, &mut b.depol);
    reference(&b.sky, &b.depol, min_cells, &mut b.t, &mut b.keep, &mut b.clear);
    brighter(&b.sky, &mut b.clear, &mut b.t, &mut b.bright);
    whiter(&b.sky, &mut b.clear, &mut b.keep, &mut b.t, &mut b.more, &mut b.white);
    b.cloud.clear();
    b.cloud.extend(b.depol.iter().zip(&b.bright).zip(&b.white).map(|((&d, &br), &wh)| d || br || wh));
    propagate(&b.sky, cols, rows, &mut b.cloud, &mut b.votes);
    let marked = cells.iter().zip(&b.cloud).map(|(c, &x)| (c.grid, x));
    grown_clusters(marked, cols * rows, cols, DILATE_CELLS, &mut b.mask, &mut b.kept, &mut b.tmp, &mut b.grown);
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
            body(psi_deg, self.ctx.sun_az_deg, self.ctx.sun_el_deg),
            body(psi_deg, self.other.azimuth_deg, self.other.elevation_deg),
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
            let jp = wrap_half(delta(cl, sp2, so2, w) - r) / hp;
            let jt = wrap_half(delta(cl, sp, so, w2) - r) / ht;
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

/// Wraps an angle difference of AoPs to (−π/2, π/2].
fn wrap_half(x: f64) -> f64 {
    let p = std::f64::consts::PI;
    let r = (x + 0.5 * p).rem_euclid(p) - 0.5 * p;
    if r <= -0.5 * p {
        r + p
    } else {
        r
    }
}

/// The start: a grid search of the heading in 1° steps on the bounded cost, at the
/// model's share and at the share's log-odds ±1σ and ±2σ of the prior (so a sky whose
/// share the model misses by a factor of several still starts in the heading's basin),
/// each with the prior's penalty; the heading's profile over those shares decides, and
/// a second minimum of it more than 20° away within χ² 9 is an ambiguous frame.
/// Returns (ψ in degrees, θ).
fn search(cells: &[Cell2], m: &Model<'_>, theta0: f64) -> Result<(f64, f64), NoHeading> {
    let stride = cells.len().div_ceil(SEARCH_CELLS).max(1);
    let sub: Vec<&Cell2> = cells.iter().step_by(stride).collect();
    let cap = SEARCH_CAP_RAD * SEARCH_CAP_RAD;
    let cost = |psi: f64, th: f64| {
        let (sp, so) = m.suns(psi);
        let w = logistic(th);
        let data = sub.iter().map(|c| (delta(c, sp, so, w).powi(2)).min(cap) / (c.var + SEARCH_SIGMA_RAD.powi(2)));
        data.sum::<f64>() + ((th - theta0) / SHARE_LOG_ODDS_SIGMA).powi(2)
    };
    let thetas = [-2.0, -1.0, 0.0, 1.0, 2.0].map(|k| theta0 + k * SHARE_LOG_ODDS_SIGMA);
    // Per heading of the grid: the best of the shares, (ψ, cost, θ).
    let grid: Vec<(f64, f64, f64)> = (0..360)
        .map(|k| {
            let psi = k as f64;
            thetas.iter().map(|&th| (psi, cost(psi, th), th)).fold((psi, f64::INFINITY, theta0), |a, b| {
                if b.1 < a.1 {
                    b
                } else {
                    a
                }
            })
        })
        .collect();
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

/// The heading of a mixed twilight frame's cells: the frame's source at `ctx`'s sun and
/// `other` beside it (module doc). Every extractor in `extractors` gets this one fit.
pub fn estimate_two(
    cells: &Cells,
    ctx: &FieldContext,
    other: &SecondSource,
    opts: &FieldOptions,
    extractors: &[Extractor],
) -> Vec<FieldHeading> {
    let (result, quality) = match fit_two(cells, ctx, other, opts) {
        Ok((h, parts, q)) => (Ok((h, parts)), q),
        Err((q, why)) => (Err(why), q),
    };
    extractors
        .iter()
        .map(|&extractor| FieldHeading {
            extractor,
            result: result.clone(),
            quality,
            source: crate::sky::SkySource::Given,
        })
        .collect()
}

type Outcome = Result<(f64, SigmaParts, FieldQuality), (FieldQuality, NoHeading)>;

fn fit_two(cells: &Cells, ctx: &FieldContext, other: &SecondSource, opts: &FieldOptions) -> Outcome {
    let mut quality = FieldQuality { cells_total: cells.grid_len(), ..Default::default() };
    if ctx.sun_el_deg > 89.0 {
        return Err((quality, NoHeading::SunAtZenith { sun_el_deg: ctx.sun_el_deg }));
    }
    if !(other.share > 0.0 && other.share < 1.0) {
        return Err((quality, NoHeading::Solver(format!("a mixed sky's share {} outside (0, 1)", other.share))));
    }
    let level = ctx.level_from_camera();
    let (mut slots, mut obs) = (Vec::new(), Vec::new());
    observe(cells, ctx, opts, level, &mut slots, &mut obs);
    quality.cells_valid = obs.len();
    let polarized = Polarized::of(&obs);
    if let Some(why) = polarized.too_dark() {
        return Err((quality, why));
    }
    let min_used = opts.min_cells.max((opts.min_used_fraction * quality.cells_total as f64).ceil() as usize);
    let m = Model { ctx, other };
    let cos_excl = opts.sun_exclusion_deg.to_radians().cos();
    let c2: Vec<Cell2> = obs
        .iter()
        .map(|o: &Obs| Cell2 { d: o.d, e: o.e, f: o.d.cross(o.e), var: o.var_aop, block: o.block, grid: o.grid })
        .collect();
    if c2.len() < min_used {
        return Err((
            quality,
            polarized.explain(NoHeading::TooLittleSky { used: c2.len(), total: quality.cells_total }),
        ));
    }
    let theta0 = (other.share / (1.0 - other.share)).ln();
    let (psi0, theta_start) = search(&c2, &m, theta0).map_err(|r| (quality, polarized.explain(r)))?;
    let (sp, so) = m.suns(psi0);
    let near = |c: &Cell2, sp: DVec3, so: DVec3| c.d.dot(sp) > cos_excl || c.d.dot(so) > cos_excl;
    // Cells away from both bodies (aureole, glare): sun_exclusion_deg about each, which
    // turn with ψ: taken at the start heading.
    let cells2: Vec<Cell2> = c2.iter().copied().filter(|c| !near(c, sp, so)).collect();
    let seen: Vec<Seen> = obs.iter().map(|o| Seen { dolp: o.dolp, ln_i: o.ln_i, tint: o.tint }).collect();
    let mut cb = CloudBufs::default();
    let dims = (cells.cols, cells.rows);
    let r = robust_rounds(&c2, &cells2, &seen, &m, theta0, (psi0, theta_start), opts.min_cells, dims, &mut cb);
    let (psi, th, wt, tau2, cov) = (r.psi_deg, r.theta, r.wt, r.tau2, r.cov);
    quality.iterations = r.iterations;
    // What the fit left: used cells, residual beyond noise, χ²; the clouds at the end
    // point, clustered and grown, as the frame's cloud fraction (`robust.rs`).
    let (sp, so) = m.suns(psi);
    let w = logistic(th);
    mixed_clouds(&c2, &seen, (sp, so, w), tau2, opts.min_cells, cells.cols, cells.rows, &mut cb);
    quality.cloud_fraction = c2.iter().filter(|c| cb.grown[c.grid]).count() as f64 / c2.len().max(1) as f64;
    let (mut sw, mut swd2, mut noise, mut used, mut chi2) = (0.0, 0.0, 0.0, 0usize, 0.0);
    for (c, &x) in cells2.iter().zip(&wt) {
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
    let parts = sigma_parts(&cells2, &wt, &m, theta0, &fit, cells, opts, misfit_rms_deg);
    Ok((psi.rem_euclid(360.0), parts, quality))
}

/// Where the robust rounds end.
struct Rounds {
    psi_deg: f64,
    theta: f64,
    /// Per cell of `cells2`: robust weight / σ² (0 for cloud).
    wt: Vec<f64>,
    tau2: f64,
    /// Inverse of the normal matrix (ψ in degrees, θ).
    cov: [[f64; 2]; 2],
    iterations: usize,
}

/// The robust rounds from `start` (ψ in degrees, θ) over `cells2` (the cells away from
/// both bodies); the cloud tests read `c2`, every cell, with `seen` beside it (`b.grown`
/// is left at the last clouds found).
#[allow(clippy::too_many_arguments)]
fn robust_rounds(
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
    let mut wt = vec![0.0; cells2.len()];
    let mut t = Vec::with_capacity(cells2.len());
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
    Rounds { psi_deg: psi, theta: th, wt, tau2, cov, iterations }
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
) -> SigmaParts {
    let fit_deg = fit.cov[0][0].max(0.0).sqrt() * fit.chi2_dof.max(1.0).sqrt();
    // Delete-one-block jackknife, both parameters refitted.
    let mut dev = Vec::with_capacity(BLOCKS * BLOCKS);
    for b in 0..BLOCKS * BLOCKS {
        if !cells2.iter().zip(wt).any(|(c, &x)| c.block == b && x > 0.0) {
            continue;
        }
        let keep = |i: usize| cells2[i].block != b;
        let ((p, _), _) = gauss_newton(cells2, wt, &keep, m, theta0, (fit.psi_deg, fit.theta), 4);
        dev.push(wrap_deg_180(p - fit.psi_deg));
    }
    let jackknife_deg = if dev.len() >= 2 { jackknife_sd(&dev) } else { 2.0 * fit_deg };
    // The spatial sandwich of the profiled score: a = a_ψ − (H_ψθ/H_θθ)·a_θ (H_θθ with
    // the prior), its curvature Σ w·a_ψ·a = H_ψψ − H_ψθ²/H_θθ, the inverse of the
    // marginal variance (the prior's score is not a draw of the sky, so not in V).
    let (sp, so) = m.suns(fit.psi_deg);
    let (sp2, so2) = m.suns(fit.psi_deg + 0.01);
    let w = logistic(fit.theta);
    let w2 = logistic(fit.theta + 1e-4);
    let (hpt, htt) = (-fit.cov[0][1], fit.cov[0][0]); // ∝ the normal matrix's ψθ, θθ (same det)
    let k = if htt > 0.0 { hpt / htt } else { 0.0 };
    let mut t = Vec::new();
    let coherent_deg = coherent_sigma_deg(
        cells2.iter().zip(wt).filter(|(_, &x)| x > 0.0).map(|(c, &x)| {
            let r = delta(c, sp, so, w);
            let ap = wrap_half(delta(c, sp2, so2, w) - r) / 0.01;
            let at = wrap_half(delta(c, sp, so, w2) - r) / 1e-4;
            let a = ap - k * at;
            (c.grid, x * r * a, x * ap * a)
        }),
        cells.cols,
        cells.rows,
        &mut t,
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
    SigmaParts {
        fit_deg,
        jackknife_deg,
        coherent_deg,
        misfit_deg,
        cross_deg: 0.0,
        tilt_deg: ctx.tilt_sigma_deg * dpsi(eps, 0.0).hypot(dpsi(0.0, eps)),
        sun_deg: ctx.sun_sigma_deg,
        floor_deg: opts.sigma_floor_deg,
    }
}

#[cfg(test)]
#[path = "two_sources_tests.rs"]
mod tests;
