//! Clouds found from what the camera sees (step 4 of `mod.rs`), per cell:
//!
//! ```text
//! depolarized:  DoLP < DOLP_FRACTION · d_ref · D(γ),   D(γ) = sin²γ/(1 + cos²γ)  (Rayleigh, seed eq. 1)
//!               (a mixed twilight's D is its two skies' Stokes sum, `two_sources.rs`;
//!               the tests read D per cell, [`CellSky::shape`])
//!               d_ref = max(median r, UPPER_SHARE · upper r, CLEAR_DMAX_MIN)
//!               r = DoLP/D(γ) over the cells that fit the sun; `upper`: the ratio that
//!               the most polarized max(min_cells, 3 %) of them reach
//! brighter:     ln I − m(γ, z) > med + max(ln BRIGHT_FACTOR, 5 · 1.4826 · MAD₋)
//!               m a smooth radiance (ln I on 1, cos γ, z and their squares and product,
//!               centred and scaled) fitted by least squares to the reference cells,
//!               refitted without those above it by 2σ (up to 6 rounds: the clear
//!               cells' lower envelope); med the residuals' median, MAD₋ their spread
//!               below it (clouds are brighter, never darker)
//! reference:    the cells on the clear sky's DoLP plateau, r ≥ (1 − PLATEAU_TOL)·r_top,
//!               r_top the ratio the PLATEAU_TOP-th most polarized verifiable cell
//!               reaches (γ > 35° from the sun and the anti-sun), on a monochrome
//!               frame where at least min_cells are, at most half the verifiable
//!               cells are depolarized (no overcast), and either the plateau spans the
//!               view (PLATEAU_TOP cells in each of PLATEAU_SPAN of PLATEAU_BINS bins of
//!               cos²γ) or at least min_cells cells are depolarized (a cloud in view);
//!               else the clear cells that fit the sun
//! whiter:       t − m_t(γ, z) > med + max(ln WHITE_FACTOR, 5 · 1.4826 · MAD₋)   colour frames only
//!               t = ln(I_R/I_B) of the cell, m_t fitted as m is (the clear cells'
//!               lower envelope): a cloud's white light in a blue sky raises t
//! ```
//!
//! Why: a cloud adds multiply-scattered, nearly unpolarized light, so its DoLP falls
//! and its radiance rises above the sky's smooth distribution (Pomozi, Horváth &
//! Wehner, J. Exp. Biol. 204, 2933 (2001)). The DoLP test needs a clear-sky
//! expectation that an overcast cannot drag down: relative to the frame's median
//! alone, an overcast that covers most of the sky *is* the median and its holes look
//! like outliers; the upper share and an absolute floor (no clear sky at a
//! scattering angle of 90° gives less than 20 % DoLP outside dust storms and smoke;
//! Horváth & Varjú, *Polarized Light in Animal Vision* (2004), ch. 11) keep the
//! clear patches as the reference. A bright rim that stays polarized fails the DoLP
//! test and passes the brightness test, whose reference must then not be the cells that
//! fit the current sun: where a deck turns one way, its sunlit rims agree with each
//! other as tightly as the clear sky does, and a start among them makes them the cells
//! that fit (and the clear sky the misfit). The reference is read from the DoLP
//! instead, which needs no sun that is right to a degree: a rim covered by a share c
//! keeps about 1 − c of the DoLP (its depolarized part) and the clear sky keeps all of
//! it, so the most polarized cells are the clear sky and the outermost rims, and the
//! rims among them are the bright ones the envelope trims (`holes.rs` reads an
//! overcast's cores on the same plateau). Only where that plateau is the clear sky's:
//! a clear sky whose DoLP is not Rayleigh's shape (Berry's d_max·sin²γ, whose ratio
//! to Rayleigh's is 1 + cos²γ) has its most polarized cells, by Rayleigh's ratio, on a
//! thin ring of γ at the verifiable edge, and a smooth sky fitted to that ring took
//! 20–70 % of such a sky for cloud; a plateau that spans the view, or one beside a
//! cloud the DoLP test finds, is the clear sky's. On a colour sensor a cloud is also whiter
//! than the sky around it, dim or bright, polarized or not: the red-to-blue ratio that
//! all-sky cloud imagers have thresholded for decades (Long et al. 2006) joins the two
//! tests (the colour compass gives every band's cells the frame's ratio).
//!
//! Frame: the level camera frame (γ from the sun on its cone, z the ray's elevation
//! sine). Cannot: tell a cloud from haze that depolarizes the whole sky evenly (that
//! is d_max, which the extractors do not need), or a dark cloud (its radiance below
//! the sky's: it still fails the DoLP test if it depolarizes).

use super::stats::{median, quantile};
use nalgebra::{SMatrix, SVector};

/// Cells whose DoLP is below this fraction of the clear sky's expectation are cloud.
pub(super) const DOLP_FRACTION: f64 = 0.6;
/// The upper ratio counts at this share (a clear patch's own d_max, less its spread).
const UPPER_SHARE: f64 = 0.8;
/// No clear sky has a d_max below this (an absolute expectation).
const CLEAR_DMAX_MIN: f64 = 0.2;
/// Cells brighter than the smooth sky by this factor (and by 5 robust σ) are cloud.
const BRIGHT_FACTOR: f64 = 1.25;

/// Rayleigh's DoLP at scattering angle γ over d_max, from cos γ.
#[inline]
pub(super) fn rayleigh_dolp(cg: f64) -> f64 {
    (1.0 - cg * cg) / (1.0 + cg * cg)
}

/// What a cell offers the cloud tests.
#[derive(Clone, Copy, Debug)]
pub(super) struct CellSky {
    pub dolp: f64,
    /// ln of the cell's mean radiance (DN above black).
    pub ln_i: f64,
    /// A colour frame's band ratio ln(I_R/I_B); NaN for a monochrome frame.
    pub tint: f64,
    /// cos γ from the current sun, and the ray's elevation sine (level frame).
    pub cg: f64,
    pub z: f64,
    /// The clear sky's DoLP over d_max at the cell: Rayleigh's D(γ) =
    /// [`rayleigh_dolp`]`(cg)` for one source; a mixed twilight's Stokes sum for two
    /// (`two_sources.rs`).
    pub shape: f64,
    /// Whether the cell fits the current sun (its angle residual within 3σ).
    pub fits: bool,
    /// Index in the cell grid (row-major).
    pub grid: usize,
}

impl CellSky {
    /// Whether the cell's DoLP can tell cloud from sky (Rayleigh's DoLP there above
    /// VERIFIABLE of d_max).
    #[inline]
    pub fn verifiable(&self) -> bool {
        self.shape > VERIFIABLE
    }
}

/// The clear sky's d_max as the cells show it (see the module's equation); NaN when
/// no cell fits. `ratios` is a buffer.
pub(super) fn clear_dmax(cells: &[CellSky], min_cells: usize, ratios: &mut Vec<f64>) -> f64 {
    ratios.clear();
    ratios.extend(cells.iter().filter(|c| c.fits && c.shape > 0.3).map(|c| c.dolp / c.shape));
    if ratios.is_empty() {
        return f64::NAN;
    }
    let n = ratios.len();
    let top = min_cells.max((0.03 * n as f64).ceil() as usize).min(n);
    let upper = quantile(ratios, 1.0 - top as f64 / n as f64);
    let mid = median(ratios);
    mid.max(UPPER_SHARE * upper).max(CLEAR_DMAX_MIN)
}

/// A sky whose depolarized cells are more than this share of the verifiable ones is
/// an overcast to [`reference`].
const OVERCAST_SHARE: f64 = 0.5;
/// `r_top` is the ratio this many cells reach (a lone hot cell cannot set it).
pub(super) const PLATEAU_TOP: usize = 4;
/// A plateau cell's ratio is within this fraction of `r_top`: a cover of about 3 % at
/// most under a deck that keeps a few per cent of the DoLP.
pub(super) const PLATEAU_TOL: f64 = 0.03;
/// Rayleigh's DoLP over d_max above which a cell's ratio is read for the plateau (γ >
/// 35° from the sun and the anti-sun: nearer, the ratio's noise and the sky's
/// departures grow).
pub(super) const PLATEAU_VERIFIABLE: f64 = 0.3;

/// A cell's DoLP over Rayleigh's shape, where that shape is > PLATEAU_VERIFIABLE of d_max.
fn plateau_ratio(c: &CellSky) -> Option<f64> {
    let d = c.shape;
    (d > PLATEAU_VERIFIABLE).then(|| c.dolp / d)
}

/// The plateau's span is read in this many bins of cos²γ over its verifiable range …
const PLATEAU_BINS: usize = 8;
/// … and must reach this many of them (half the range of cos²γ: a band of γ some 30°
/// wide).
const PLATEAU_SPAN: usize = 4;
/// cos²γ where Rayleigh's DoLP over d_max falls to PLATEAU_VERIFIABLE: (1 − x)/(1 + x) = v.
const PLATEAU_X_MAX: f64 = (1.0 - PLATEAU_VERIFIABLE) / (1.0 + PLATEAU_VERIFIABLE);

/// Into `clear`: the reference cells of the smooth sky ([`brighter`]; the module's
/// equation) — verifiable, not depolarized (`depol`), and fitting the current sun,
/// or, on a monochrome frame that is no overcast (at most OVERCAST_SHARE of the
/// verifiable cells depolarized) whose plateau holds at least `min_cells` cells and
/// either spans the view or lies beside at least `min_cells` depolarized cells, on the
/// clear sky's DoLP plateau. Returns whether the plateau was the reference. `r` and
/// `plateau` are buffers.
pub(super) fn reference(
    cells: &[CellSky],
    depol: &[bool],
    min_cells: usize,
    r: &mut Vec<f64>,
    plateau: &mut Vec<bool>,
    clear: &mut Vec<bool>,
) -> bool {
    r.clear();
    r.extend(cells.iter().filter_map(plateau_ratio));
    plateau.clear();
    let n = r.len();
    if n >= PLATEAU_TOP {
        let r_top = *r.select_nth_unstable_by(n - PLATEAU_TOP, |a, b| a.total_cmp(b)).1;
        plateau.extend(cells.iter().map(|c| plateau_ratio(c).is_some_and(|x| x >= (1.0 - PLATEAU_TOL) * r_top)));
    } else {
        plateau.resize(cells.len(), false);
    }
    // A colour frame's whiteness test reads the rims with no sun at all ([`whiter`]'s
    // bluest cells), and its bands' cells, a quarter of the pixels each, spread wider
    // than the plateau's 3 % (tried: its turned rims 0.017° → 0.019° RMS, worst 1.7σ →
    // 2.6σ): there the cells that fit stay the reference.
    let mono = !cells.iter().any(|c| c.tint.is_finite());
    // Under an overcast (most verifiable cells depolarized) the cells that fit stay the
    // reference: the plateau is then a few holes' cores, too few to fit the radiance
    // of the whole view by (holes.rs reads them).
    let verifiable = cells.iter().filter(|c| c.verifiable()).count();
    let depolarized = depol.iter().filter(|&&d| d).count();
    let overcast = depolarized as f64 > OVERCAST_SHARE * verifiable as f64;
    let on = plateau.iter().zip(depol).filter(|(&p, &d)| p && !d).count();
    // The plateau must be the clear sky's, not the shape of a sky whose DoLP is not
    // Rayleigh's: under Berry's d_max·sin²γ the ratio, d_max·(1 + cos²γ), peaks at the
    // verifiable edge and its plateau is a thin ring of γ there, over which a smooth sky
    // fitted to it extrapolates (tried: 20–70 % of such a clear sky called cloud on 3
    // of 8 frames, `tests/real_sky_shape.rs`). It serves where it spans the view (at
    // least PLATEAU_TOP of its cells in each of PLATEAU_SPAN of the PLATEAU_BINS bins of
    // cos²γ over the verifiable range) or where the DoLP test finds a cloud (at least
    // min_cells cells depolarized: a deck's cores, beside which a start among its rims
    // may have made the ratio itself slope).
    let mut bins = [0usize; PLATEAU_BINS];
    for (c, _) in cells.iter().zip(plateau.iter()).zip(depol).filter(|((_, &p), &d)| p && !d).map(|(x, _)| x) {
        // cos²γ from the shape, (1 − D)/(1 + D): a mixed sky's effective one.
        let x = (1.0 - c.shape) / (1.0 + c.shape);
        bins[((x / PLATEAU_X_MAX * PLATEAU_BINS as f64) as usize).min(PLATEAU_BINS - 1)] += 1;
    }
    let spans = bins.iter().filter(|&&k| k >= PLATEAU_TOP).count() >= PLATEAU_SPAN;
    let clouded = depolarized >= min_cells;
    let by_plateau = mono && !overcast && (spans || clouded) && on >= min_cells;
    clear.clear();
    clear.extend(
        cells
            .iter()
            .zip(depol)
            .zip(plateau.iter())
            .map(|((c, &d), &p)| c.verifiable() && !d && if by_plateau { p } else { c.fits }),
    );
    by_plateau
}

/// Into `out`: whether each cell is depolarized against the clear sky's `dmax`, where
/// Rayleigh's DoLP there is > VERIFIABLE of d_max (γ > 23° from the sun and the
/// anti-sun; closer, a cell's DoLP says nothing).
pub(super) fn depolarized(cells: &[CellSky], dmax: f64, out: &mut Vec<bool>) {
    out.clear();
    out.extend(cells.iter().map(|c| {
        let d = c.shape;
        dmax.is_finite() && d > VERIFIABLE && c.dolp < DOLP_FRACTION * dmax * d
    }));
}

/// Rayleigh's DoLP over d_max above which a cell's DoLP can tell cloud from sky.
const VERIFIABLE: f64 = 0.08;

/// Into `out`: whether each cell is brighter than the smooth sky fitted to the clear
/// cells (`clear`: [`reference`]); only verifiable cells are
/// marked (closer to the sun the smooth sky is an extrapolation). Nothing is marked
/// when fewer than 20 cells are clear. `clear` loses the cells the envelope's fit
/// trims; `r` is a buffer. The radiance takes no sun-free reference of its dimmest
/// cells as the colour ratio does ([`whiter`]): a sky's radiance varies by more than
/// the cut across the view, and tried, the dimmest cells' envelope did read the
/// turned rims of one deck (0.36° → 0.007° RMS) but took two thirds of a sky of ten
/// coherent clouds for cloud (`clouds_coherent`: 0.79° → 3.3° RMS, 7σ). The DoLP
/// plateau ([`reference`]) needs no sun either and keeps the envelope's cells polarized
/// like the clear sky: the same deck reads 0.359° → 0.007° RMS (mono, 24 frames) and
/// `clouds_coherent` 0.79° → 0.54° RMS, 9 → 2 of 40 frames refused (docs/field.md).
pub(super) fn brighter(cells: &[CellSky], clear: &mut [bool], r: &mut Vec<f64>, out: &mut Vec<bool>) {
    above_envelope(cells, clear, r, |c| c.ln_i, BRIGHT_FACTOR.ln(), out);
}

/// Into `out`: whether each cell of a colour frame is whiter than the clear sky, its
/// band ratio t = ln(I_R/I_B) above a smooth ratio by more than ln WHITE_FACTOR and 5
/// robust σ. A cloud's light is white and the clear sky's blue, so a cloud raises t
/// however dim or polarized it is: the red-to-blue ratio of all-sky cloud imagers
/// (Long, Sabburg, Calbó & Pagès, J. Atmos. Oceanic Technol. 23, 633 (2006)). Two
/// references; a cell whiter than either is marked:
/// - the sky's bluest cells, no sun or pattern needed (clouds are whiter, never
///   bluer): the smooth ratio refitted WHITE_ROUNDS times to the WHITE_KEEP share of
///   the verifiable cells lowest against the last fit; it holds while clouds cover
///   less than 1 − WHITE_KEEP of the sky, even where the current sun is wrong and the
///   cells that "fit" are a deck's turned rims;
/// - the clear cells (`clear`: [`reference`], less the brighter; their lower
///   envelope as [`brighter`] fits it): the wider reference, so the finer cut
///   at a thin cloud's edge.
///
/// Cells without a ratio are never marked; nothing is marked on a monochrome frame (no
/// ratio anywhere). `clear` is trimmed as [`brighter`] trims it; `keep`, `r` and
/// `more` are buffers.
pub(super) fn whiter(
    cells: &[CellSky],
    clear: &mut [bool],
    keep: &mut Vec<bool>,
    r: &mut Vec<f64>,
    more: &mut Vec<bool>,
    out: &mut Vec<bool>,
) {
    above_lowest(cells, |c| c.tint, WHITE_FACTOR.ln(), keep, r, out);
    // The clear cells' envelope.
    for (k, c) in clear.iter_mut().zip(cells) {
        *k &= c.tint.is_finite();
    }
    above_envelope(cells, clear, r, |c| c.tint, WHITE_FACTOR.ln(), more);
    for ((o, &m), c) in out.iter_mut().zip(more.iter()).zip(cells) {
        *o |= m && c.tint.is_finite();
    }
}

/// Cells whose red-to-blue ratio exceeds the clear sky's by this factor (and by 5
/// robust σ) are cloud: a white cloud covering a tenth of a cell of a blue sky
/// (r_R/r_B = ½) raises it by ~1.1.
const WHITE_FACTOR: f64 = 1.1;
/// The lower envelope of the ratio: refits, each on this share of the cells.
const WHITE_ROUNDS: usize = 4;
const WHITE_KEEP: f64 = 0.4;

/// Into `out`: whether each verifiable cell's `value` (NaN: none) lies above the smooth
/// sky's fitted to its lowest cells by more than `min_step` and 5 robust σ: refitted
/// WHITE_ROUNDS times to the WHITE_KEEP share of the cells lowest against the last fit
/// (a lower envelope that needs no sun and no fit of the pattern, and holds while
/// what lies above it covers less than 1 − WHITE_KEEP of the sky). Nothing marked with
/// fewer than 20 cells. `keep` and `r` are buffers.
fn above_lowest(
    cells: &[CellSky],
    value: fn(&CellSky) -> f64,
    min_step: f64,
    keep: &mut Vec<bool>,
    r: &mut Vec<f64>,
    out: &mut Vec<bool>,
) {
    out.clear();
    out.resize(cells.len(), false);
    let candidate = |c: &CellSky| value(c).is_finite() && c.verifiable();
    keep.clear();
    keep.extend(cells.iter().map(candidate));
    if keep.iter().filter(|&&k| k).count() < 20 {
        return;
    }
    for _ in 0..WHITE_ROUNDS {
        let Some((coef, basis_at, _, _)) = smooth_sky(cells, keep, r, value) else { return };
        r.clear();
        r.extend(cells.iter().filter(|c| candidate(c)).map(|c| value(c) - basis_at(c).dot(&coef)));
        let q = quantile(r, WHITE_KEEP);
        for (k, c) in keep.iter_mut().zip(cells) {
            *k = candidate(c) && value(c) - basis_at(c).dot(&coef) <= q;
        }
    }
    if let Some((coef, basis_at, med, sigma)) = smooth_sky(cells, keep, r, value) {
        let cut = med + min_step.max(5.0 * sigma);
        for (o, c) in out.iter_mut().zip(cells) {
            *o = candidate(c) && value(c) - basis_at(c).dot(&coef) > cut;
        }
    }
}

/// Into `out`: whether each cell's `value` lies above the smooth sky's fitted to the
/// clear cells' lower envelope by more than `min_step` and 5 robust σ (verifiable
/// cells only); nothing marked when fewer than 20 cells are clear. `clear` loses the
/// cells the envelope's fit trims.
fn above_envelope(
    cells: &[CellSky],
    clear: &mut [bool],
    r: &mut Vec<f64>,
    value: fn(&CellSky) -> f64,
    min_step: f64,
    out: &mut Vec<bool>,
) {
    out.clear();
    out.resize(cells.len(), false);
    // The smooth sky as the clear cells' lower envelope: each round drops from the
    // fit the cells above it by more than TRIM_SIGMA of the lower half's spread, so
    // clouds that passed the DoLP test (bright, still polarized: rims, thin decks)
    // stop lifting it however many there are; the cut is read from the last round.
    let mut fitted = None;
    for _ in 0..BRIGHT_ROUNDS {
        let Some((coef, basis_at, med, sigma)) = smooth_sky(cells, clear, r, value) else { break };
        let mut dropped = false;
        for (c, k) in cells.iter().zip(clear.iter_mut()) {
            if *k && value(c) - basis_at(c).dot(&coef) > med + TRIM_SIGMA * sigma {
                *k = false;
                dropped = true;
            }
        }
        fitted = Some((coef, basis_at, med, sigma));
        if !dropped {
            break;
        }
    }
    let Some((coef, basis_at, med, sigma)) = fitted else { return };
    let cut = med + min_step.max(5.0 * sigma);
    for (o, c) in out.iter_mut().zip(cells) {
        *o = c.verifiable() && value(c) - basis_at(c).dot(&coef) > cut;
    }
}

/// Rounds of the smooth sky's fit, each without the cells the last one found above
/// the envelope.
const BRIGHT_ROUNDS: usize = 6;
/// Cells above the envelope by more than this many σ leave its next fit.
const TRIM_SIGMA: f64 = 2.0;

type Basis = SVector<f64, 6>;

/// The smooth sky's `value` (ln radiance, or band ratio) fitted to the `clear` cells:
/// its coefficients, the basis (on 1, cos γ, z and their squares and product, centred
/// and scaled on the clear cells), the residuals' median and their robust σ from the
/// lower half; `None` when fewer than 20 cells are clear.
fn smooth_sky(
    cells: &[CellSky],
    clear: &[bool],
    r: &mut Vec<f64>,
    value: fn(&CellSky) -> f64,
) -> Option<(Basis, impl Fn(&CellSky) -> Basis, f64, f64)> {
    let n = clear.iter().filter(|&&c| c).count();
    if n < 20 {
        return None;
    }
    // Features centred and scaled on the clear cells, so the normal equations are
    // well conditioned whatever the field of view.
    let (mut mg, mut mz) = (0.0, 0.0);
    for (c, _) in cells.iter().zip(clear).filter(|x| *x.1) {
        mg += c.cg;
        mz += c.z;
    }
    let (mg, mz) = (mg / n as f64, mz / n as f64);
    let (mut sg, mut sz) = (0.0, 0.0);
    for (c, _) in cells.iter().zip(clear).filter(|x| *x.1) {
        sg += (c.cg - mg).powi(2);
        sz += (c.z - mz).powi(2);
    }
    let (sg, sz) = ((sg / n as f64).sqrt().max(1e-3), (sz / n as f64).sqrt().max(1e-3));
    let basis = move |c: &CellSky| {
        let g = (c.cg - mg) / sg;
        let z = (c.z - mz) / sz;
        Basis::from([1.0, g, z, g * g, z * z, g * z])
    };
    let mut a = SMatrix::<f64, 6, 6>::zeros();
    let mut b = Basis::zeros();
    for (c, _) in cells.iter().zip(clear).filter(|x| *x.1) {
        let x = basis(c);
        a += x * x.transpose();
        b += x * value(c);
    }
    // A little ridge: a narrow field of view leaves the quadratic terms weak.
    let ridge = 1e-6 * a.trace().max(1e-12);
    for k in 0..6 {
        a[(k, k)] += ridge;
    }
    let coef = a.cholesky()?.solve(&b);
    r.clear();
    r.extend(cells.iter().zip(clear).filter(|x| *x.1).map(|(c, _)| value(c) - basis(c).dot(&coef)));
    // The spread from the residuals below the median only: clouds are brighter, never
    // darker, so the lower half is the sky's own scatter however many clouds the
    // clear cells still hold (for a clean sky, the usual MAD).
    let med = median(r);
    r.retain(|&x| x <= med);
    for x in r.iter_mut() {
        *x = med - *x;
    }
    let mad = 1.4826 * median(r);
    Some((coef, basis, med, mad))
}

/// Cells within this many cells of an unverifiable one vote on its label.
const VOTE_RADIUS: usize = 6;

/// Unverifiable cells (near the sun and the anti-sun, where a cell's DoLP says
/// nothing) take the label of the verifiable cells within VOTE_RADIUS of them (or
/// the nearest, the window doubling until it holds some): cloud
/// where more of those are cloud than clear (an overcast reaches into the sun's
/// region; a clear sky does too). `cloud` is read for the verifiable cells and
/// written for the others; `votes` is a buffer of the grid's summed-area tables.
pub(super) fn propagate(cells: &[CellSky], cols: usize, rows: usize, cloud: &mut [bool], votes: &mut Vec<[u32; 2]>) {
    let (w, h) = (cols + 1, rows + 1);
    votes.clear();
    votes.resize(w * h, [0, 0]);
    for (c, &cl) in cells.iter().zip(cloud.iter()) {
        if c.verifiable() {
            let (r, k) = (c.grid / cols, c.grid % cols);
            votes[(r + 1) * w + k + 1][cl as usize] += 1;
        }
    }
    // Summed-area table: votes[r][k] = counts over rows < r, columns < k.
    for r in 1..h {
        for k in 1..w {
            for j in 0..2 {
                votes[r * w + k][j] = votes[r * w + k][j] + votes[(r - 1) * w + k][j] + votes[r * w + k - 1][j]
                    - votes[(r - 1) * w + k - 1][j];
            }
        }
    }
    for (c, cl) in cells.iter().zip(cloud.iter_mut()) {
        if c.verifiable() {
            continue;
        }
        let (r, k) = (c.grid / cols, c.grid % cols);
        // The nearest verifiable cells: the window doubles until it holds some.
        let mut radius = VOTE_RADIUS;
        let (clear, clouded) = loop {
            let (r0, r1) = (r.saturating_sub(radius), (r + radius + 1).min(rows));
            let (k0, k1) = (k.saturating_sub(radius), (k + radius + 1).min(cols));
            let count = |j: usize| {
                votes[r1 * w + k1][j] + votes[r0 * w + k0][j] - votes[r0 * w + k1][j] - votes[r1 * w + k0][j]
            };
            let (clear, clouded) = (count(0), count(1));
            if clear + clouded > 0 || radius >= rows.max(cols) {
                break (clear, clouded);
            }
            radius *= 2;
        };
        *cl = clouded > clear;
    }
}

/// The cloud tests' working buffers (kept between frames by their callers).
#[derive(Clone, Debug, Default)]
pub(super) struct TestBufs {
    depol: Vec<bool>,
    keep: Vec<bool>,
    clear: Vec<bool>,
    bright: Vec<bool>,
    more: Vec<bool>,
    white: Vec<bool>,
    votes: Vec<[u32; 2]>,
}

/// Into `cloud`, per cell of `sky` (a `cols × rows` grid's cells): taken for cloud by
/// the three tests — depolarized against the clear sky's d_max ([`depolarized`]),
/// brighter ([`brighter`]) or whiter ([`whiter`]) than the smooth sky of the clear
/// reference ([`reference`]) — then the unverifiable cells labelled by their
/// neighbours ([`propagate`]). The one labelling both readers take (`robust.rs`, one
/// source; `two_sources_clouds.rs`, a mixed twilight). `t` is a scratch of ratios.
pub(super) fn label(
    sky: &[CellSky],
    cols: usize,
    rows: usize,
    min_cells: usize,
    t: &mut Vec<f64>,
    b: &mut TestBufs,
    cloud: &mut Vec<bool>,
) {
    let dmax = clear_dmax(sky, min_cells, t);
    depolarized(sky, dmax, &mut b.depol);
    // The smooth sky's reference: on a monochrome frame that is no overcast, the clear
    // sky's DoLP plateau, not the cells that fit the current sun (a start among a
    // deck's rims makes them the cells that fit; `reference`).
    reference(sky, &b.depol, min_cells, t, &mut b.keep, &mut b.clear);
    brighter(sky, &mut b.clear, t, &mut b.bright);
    // A colour frame's third test: whiter than the blue sky (`whiter`).
    whiter(sky, &mut b.clear, &mut b.keep, t, &mut b.more, &mut b.white);
    cloud.clear();
    cloud.extend(b.depol.iter().zip(&b.bright).zip(&b.white).map(|((&d, &br), &wh)| d || br || wh));
    propagate(sky, cols, rows, cloud, &mut b.votes);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clear sky of d_max `dmax` on a ring of scattering angles, radiance smooth.
    fn sky(dmax: f64, n: usize) -> Vec<CellSky> {
        (0..n)
            .map(|i| {
                let g = (40.0 + 100.0 * i as f64 / n as f64).to_radians();
                let z = 0.4 + 0.5 * ((i * 7) % n) as f64 / n as f64;
                let cg = g.cos();
                CellSky {
                    dolp: dmax * rayleigh_dolp(cg),
                    ln_i: (1.0 + cg * cg).ln() + 0.3 * z,
                    tint: -0.7 + 0.05 * z,
                    cg,
                    z,
                    shape: rayleigh_dolp(cg),
                    fits: true,
                    grid: i,
                }
            })
            .collect()
    }

    #[test]
    fn a_clear_sky_is_neither_depolarized_nor_bright() {
        let cells = sky(0.6, 500);
        let mut buf = Vec::new();
        let d = clear_dmax(&cells, 40, &mut buf);
        assert!((d - 0.6).abs() < 1e-9, "{d}");
        let (mut dep, mut br) = (Vec::new(), Vec::new());
        depolarized(&cells, d, &mut dep);
        brighter(&cells, &mut vec![true; cells.len()], &mut buf, &mut br);
        assert!(!dep.iter().any(|&x| x) && !br.iter().any(|&x| x));
    }

    #[test]
    fn an_overcast_majority_does_not_hide_its_holes() {
        // 92 % of the cells an overcast at 8 % of the sky's DoLP, 8 % clear holes.
        let mut cells = sky(0.6, 1000);
        for (i, c) in cells.iter_mut().enumerate() {
            if i % 100 >= 8 {
                c.dolp *= 0.08;
            }
        }
        let mut buf = Vec::new();
        let d = clear_dmax(&cells, 40, &mut buf);
        assert!(d > 0.4, "the holes' d_max, not the overcast's: {d}");
        let mut dep = Vec::new();
        depolarized(&cells, d, &mut dep);
        for (i, x) in dep.iter().enumerate() {
            assert_eq!(*x, i % 100 >= 8, "cell {i}");
        }
        // All overcast: the absolute floor still calls it cloud.
        for c in &mut cells {
            c.dolp = 0.6 * 0.08 * rayleigh_dolp(c.cg);
        }
        let d = clear_dmax(&cells, 40, &mut buf);
        depolarized(&cells, d, &mut dep);
        assert!(dep.iter().filter(|&&x| x).count() > 900, "an all-overcast sky is cloud");
    }

    #[test]
    fn unverifiable_cells_take_their_neighbours_label() {
        // A 20 × 20 grid; the left half overcast, the right half clear; a 4 × 4 patch
        // near the sun (γ = 10°: unverifiable) on each side.
        let (cols, rows) = (20, 20);
        let sun_cg = 10f64.to_radians().cos();
        let cells: Vec<CellSky> = (0..cols * rows)
            .map(|g| {
                let (r, k) = (g / cols, g % cols);
                let near_sun = (8..12).contains(&r) && ((2..6).contains(&k) || (14..18).contains(&k));
                let cg = if near_sun { sun_cg } else { 0.0 };
                CellSky {
                    dolp: 0.5,
                    ln_i: 0.0,
                    tint: f64::NAN,
                    cg,
                    z: 0.5,
                    shape: rayleigh_dolp(cg),
                    fits: true,
                    grid: g,
                }
            })
            .collect();
        let mut cloud: Vec<bool> = cells.iter().map(|c| c.verifiable() && c.grid % cols < 10).collect();
        let mut votes = Vec::new();
        propagate(&cells, cols, rows, &mut cloud, &mut votes);
        for c in &cells {
            let k = c.grid % cols;
            assert_eq!(cloud[c.grid], k < 10, "cell {} (verifiable {})", c.grid, c.verifiable());
        }
    }

    #[test]
    fn bright_patches_are_found_and_a_smooth_gradient_is_not() {
        let mut cells = sky(0.6, 800);
        for (i, c) in cells.iter_mut().enumerate() {
            c.ln_i += 0.8 * c.z * c.z; // a smooth brightening toward the zenith: no cloud
            if (300..340).contains(&i) {
                c.ln_i += 1.6f64.ln(); // a cloud 1.6× brighter
            }
        }
        let mut clear: Vec<bool> = (0..cells.len()).map(|i| !(300..340).contains(&i)).collect();
        let (mut buf, mut br) = (Vec::new(), Vec::new());
        brighter(&cells, &mut clear, &mut buf, &mut br);
        for (i, x) in br.iter().enumerate() {
            assert_eq!(*x, (300..340).contains(&i), "cell {i}");
        }
    }

    #[test]
    fn a_deck_s_bright_rims_that_fit_a_wrong_sun_are_found_against_the_dolp_plateau() {
        // A clear sky (d_max 0.6) of which 40 % of the cells, in runs of ten across the
        // view, are a deck's sunlit rims: 1.6× brighter, DoLP × 0.9 (inner rims, off
        // the plateau) or × 0.99 (outer rims, on it), turned alike, so that a start
        // among them makes them the cells that fit the sun and the clear cells the misfit;
        // and 5 % are its cores, depolarized (DoLP × 0.3), no brighter.
        let rim = |i: usize| (i / 10) % 5 < 2;
        let core = |i: usize| (i / 10) % 5 == 2 && i % 10 < 5;
        let mut cells = sky(0.6, 1000);
        for (i, c) in cells.iter_mut().enumerate() {
            c.tint = f64::NAN; // a monochrome frame
            c.fits = rim(i);
            if rim(i) {
                c.ln_i += 1.6f64.ln();
                c.dolp *= if i % 3 == 0 { 0.99 } else { 0.9 };
            }
            if core(i) {
                c.dolp *= 0.3;
            }
        }
        let mut depol = Vec::new();
        depolarized(&cells, 0.6, &mut depol);
        assert!(depol.iter().enumerate().all(|(i, &d)| d == core(i)));
        let (mut r, mut plateau, mut clear, mut br) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        // The cells that fit as the reference: the envelope is the rims', nothing is
        // brighter than it, the rims stay sky.
        let mut fits: Vec<bool> = cells.iter().map(|c| c.fits && c.verifiable()).collect();
        brighter(&cells, &mut fits, &mut r, &mut br);
        assert!(br.iter().filter(|&&x| x).count() < 10, "the rims' own envelope hides them");
        // The DoLP plateau as the reference: the clear sky and the outer rims, whose
        // envelope is the clear sky's; every rim is brighter, no clear cell is.
        assert!(reference(&cells, &depol, 40, &mut r, &mut plateau, &mut clear));
        let on_plateau =
            |i: usize| rayleigh_dolp(cells[i].cg) > PLATEAU_VERIFIABLE && (!rim(i) || i % 3 == 0) && !core(i);
        assert!(clear.iter().enumerate().all(|(i, &c)| c == on_plateau(i)));
        brighter(&cells, &mut clear, &mut r, &mut br);
        for (i, x) in br.iter().enumerate() {
            assert_eq!(*x, rim(i), "cell {i}");
        }
        // Without the depolarized cores (no cell depolarized: a clear sky to the DoLP
        // test) the plateau still serves: it spans the view's γ.
        let none = vec![false; cells.len()];
        assert!(reference(&cells, &none, 40, &mut r, &mut plateau, &mut clear));
        assert!(clear.iter().enumerate().all(|(i, &c)| c == on_plateau(i)));
        // An overcast (most verifiable cells depolarized) keeps the cells that fit.
        let deck: Vec<bool> = (0..cells.len()).map(|i| i % 5 < 3).collect();
        assert!(!reference(&cells, &deck, 40, &mut r, &mut plateau, &mut clear));
        assert!(clear.iter().zip(&cells).zip(&deck).all(|((&k, c), &d)| k == (c.fits && c.verifiable() && !d)));
        // A colour frame (a band ratio in every cell) keeps the cells that fit.
        let colour: Vec<CellSky> = cells.iter().map(|c| CellSky { tint: -0.7, ..*c }).collect();
        assert!(!reference(&colour, &depol, 40, &mut r, &mut plateau, &mut clear));
        assert!(clear.iter().zip(&colour).zip(&depol).all(|((&k, c), &d)| k == (c.fits && c.verifiable() && !d)));
        // A plateau of fewer than min_cells cells (every cell's DoLP spread wider than
        // the plateau's 3 %): the cells that fit the sun, as before.
        for (i, c) in cells.iter_mut().enumerate() {
            c.dolp *= 1.0 - 0.1 * ((i * 37) % 100) as f64 / 100.0;
        }
        assert!(!reference(&cells, &depol, 400, &mut r, &mut plateau, &mut clear));
        assert!(clear.iter().zip(&cells).zip(&depol).all(|((&k, c), &d)| k == (c.fits && c.verifiable() && !d)));
    }

    #[test]
    fn a_clear_sky_whose_dolp_is_not_rayleigh_s_shape_is_not_called_cloud() {
        // A clear monochrome sky whose DoLP is Berry's d_max·sin²γ (its ratio to
        // Rayleigh's shape, d_max·(1 + cos²γ), is 1.54× higher at the plateau's
        // verifiable edge, 35° from the sun and the anti-sun, than at γ = 90°) under a
        // radiance with a circumsolar aureole outside the smooth sky's basis.
        let mut cells = sky(0.6, 1000);
        for c in cells.iter_mut() {
            let g = c.cg.acos();
            c.tint = f64::NAN;
            c.dolp = 0.6 * (1.0 - c.cg * c.cg);
            c.ln_i = (1.0 + 10.0 * (-3.0 * g).exp() + 0.45 * c.cg * c.cg).ln() + 0.3 * c.z;
        }
        let mut depol = Vec::new();
        depolarized(&cells, clear_dmax(&cells, 40, &mut Vec::new()), &mut depol);
        assert!(!depol.iter().any(|&d| d), "Berry's DoLP is above Rayleigh's everywhere");
        let (mut r, mut plateau, mut clear, mut br) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let verifiable = cells.iter().filter(|c| c.verifiable()).count();
        // Its plateau spans no band of γ and no cell is depolarized: the cells that fit
        // stay the reference, and nothing is brighter than their smooth sky.
        assert!(!reference(&cells, &depol, 40, &mut r, &mut plateau, &mut clear));
        assert!(clear.iter().zip(&cells).all(|(&k, c)| k == c.verifiable()));
        brighter(&cells, &mut clear, &mut r, &mut br);
        assert!(!br.iter().any(|&x| x), "{} cells called cloud", br.iter().filter(|&&x| x).count());
        // What the guard keeps out: this sky's plateau is a thin ring of γ at the
        // verifiable edge, not its clear sky.
        let ring: Vec<bool> = plateau.iter().zip(&cells).map(|(&p, c)| p && c.verifiable()).collect();
        let on = ring.iter().filter(|&&p| p).count();
        assert!(on >= 40 && on * 10 < verifiable, "a ring of {on} of {verifiable} cells");
        assert!(cells.iter().zip(&ring).filter(|(_, &p)| p).all(|(c, _)| c.cg.abs() > 0.65));
        // The same sky with a cloud of 60 depolarized cells: the plateau takes over (as
        // beside a deck's cores above), ring and all: the guard's limit.
        for d in depol.iter_mut().skip(400).take(60) {
            *d = true;
        }
        assert!(reference(&cells, &depol, 40, &mut r, &mut plateau, &mut clear));
    }

    #[test]
    fn white_patches_are_found_on_a_colour_frame_and_nothing_on_a_mono_one() {
        // A blue sky whose ratio whitens smoothly toward the horizon (no cloud), and a
        // dim cloud (no brighter, still polarized: the other tests pass it) whose white
        // light lifts ln(I_R/I_B) by 0.25 over 40 cells.
        let mut cells = sky(0.6, 800);
        for (i, c) in cells.iter_mut().enumerate() {
            c.tint += 0.3 * (1.0 - c.z).powi(2);
            if (300..340).contains(&i) {
                c.tint += 0.25;
            }
        }
        let (mut buf, mut wh) = (Vec::new(), Vec::new());
        whiter(&cells, &mut vec![true; cells.len()], &mut Vec::new(), &mut buf, &mut Vec::new(), &mut wh);
        for (i, x) in wh.iter().enumerate() {
            assert_eq!(*x, (300..340).contains(&i), "cell {i}");
        }
        // A cell without a ratio (a band without its cell) is never marked.
        cells[310].tint = f64::NAN;
        whiter(&cells, &mut vec![true; cells.len()], &mut Vec::new(), &mut buf, &mut Vec::new(), &mut wh);
        assert!(!wh[310] && wh[311]);
        // A monochrome frame has no ratio: nothing.
        for c in &mut cells {
            c.tint = f64::NAN;
        }
        whiter(&cells, &mut vec![true; cells.len()], &mut Vec::new(), &mut buf, &mut Vec::new(), &mut wh);
        assert!(wh.iter().all(|&x| !x) && wh.len() == cells.len());
    }
}
