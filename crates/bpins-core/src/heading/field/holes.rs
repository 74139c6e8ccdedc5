//! An overcast's holes: the heading from the clear cores of a few holes in a cloud
//! deck, where step 4 (`robust.rs`) finds too little sky.
//!
//! ```text
//! r_i      = DoLP_i / D(γ_i),  D(γ) = sin²γ/(1 + cos²γ)     a cell's d_max as Rayleigh's shape reads it
//! r_top    = the ratio the CORE_TOP-th most polarized verifiable cell reaches
//! core     = r_i ≥ (1 − CORE_TOL)·r_top                  (a plateau: the clear sky's own d_max)
//! holes    = the core's groups: core cells within JOIN_CELLS of each other (Chebyshev)
//! heading  = the sun vector on the core cells, started by the cone search on them alone
//!            and Tukey-weighted at a misfit scale τ read from them (as step 4)
//! 1σ       = step 5's parts, its jackknife deleting one hole at a time (not one image
//!            block), times t_{0.975, k−1}/1.96 for k holes (Student's t: k holes are k
//!            samples of the deck's turn, and a jackknife over few samples is itself
//!            uncertain); the misfit part ⊕ the rim turn c̄·θ: c_i = (1 − r_i/r_top)/(1 − f)
//!            the used cells' cover (f the deck's DoLP share), θ the deck's RMS turn off
//!            the fitted sky (a turn every core shares, which no jackknife sees)
//! checks   = step 5's, at MIN_CORE_CELLS and MIN_HOLES, the sky's own sun allowed 3× its
//!            delete-one-hole 1σ beside the usual limit
//! ```
//!
//! Why: a deck keeps a few per cent of the clear sky's DoLP and turns its E-vectors by
//! tens of degrees; a hole's feathered rim, covered by a fraction c, turns them by c
//! times the deck's turn and keeps about 1 − c of the DoLP (Hegedüs, Åkesson & Horváth,
//! J. Opt. Soc. Am. A 24, 2347 (2007) for the deck; `scene/overcast.rs` for the profile
//! this was tested on). Only the cores, whose DoLP is the clear sky's own, carry the
//! sky's pattern; step 4 grows every cloud cluster by two cells to cover soft edges, so
//! a hole three cells across vanishes there. Here the edge is read from the DoLP
//! itself: a core cell's cover is within CORE_TOL of none. The holes are few and each
//! one's rim turns its cells alike, so the heading's scatter is read between holes, not
//! between cells.
//!
//! Frame: the level camera frame (γ from the sun on its cone). Cannot: tell a hole from
//! a clear sky whose DoLP departs from Rayleigh's shape by more than CORE_TOL across the
//! view (the cores are then the cells nearest the shape's maximum, fewer than the sky
//! holds: the heading stays honest, the 1σ wider); remove a turn the whole deck shares
//! where it reaches into every core (the misfit part of step 5 carries what the cores'
//! residuals show of it); read a frame with fewer than MIN_HOLES holes or
//! MIN_CORE_CELLS core cells (refused as too little sky).

use super::clouds::{rayleigh_dolp, PLATEAU_TOL, PLATEAU_TOP, PLATEAU_VERIFIABLE};
use super::observe::{cone_sun, residual, search, sharpen, Obs};
use super::robust::{summary, Robust, Scratch, CHI2_1_Q25};
use super::sigma::{block_sums, meridian_band, solve, sum_blocks, BLOCKS};
use super::stats::{jackknife_sd, median, quantile, tukey};
use super::{Cells, FieldContext, FieldOptions, FieldQuality, NoHeading};
use crate::conventions::wrap_deg_180;
use crate::heading::{sun_vector, Extractor};

/// `r_top` is the ratio this many cells reach (a lone hot cell cannot set it): the
/// clear sky's plateau as the cloud tests read it (`clouds.rs`).
const CORE_TOP: usize = PLATEAU_TOP;
/// A core cell's ratio is within this fraction of `r_top`: a cover of about 3 % at
/// most (the deck keeps a few per cent of the DoLP), whose turn is 3 % of the deck's.
const CORE_TOL: f64 = PLATEAU_TOL;
/// Rayleigh's DoLP over d_max above which a cell's ratio is read (γ > 35° from the sun
/// and the anti-sun: nearer, the ratio's noise and the sky's departures grow).
const CORE_VERIFIABLE: f64 = PLATEAU_VERIFIABLE;
/// Core cells within this many cells of each other (Chebyshev) are one hole.
const JOIN_CELLS: usize = 2;
/// Fewest core cells and holes a heading may rest on.
pub(super) const MIN_CORE_CELLS: usize = 12;
const MIN_HOLES: usize = 2;
/// Rounds of (core at the current sun → cone search on the core).
const CORE_ROUNDS: usize = 3;
const MAX_ITERATIONS: usize = 8;
/// Cells whose ratio is below this share of `r_top` are the deck's.
const DECK_SHARE: f64 = 0.3;
/// The median of χ²₁.
const CHI2_1_MEDIAN: f64 = 0.4549;

/// Student's t at 97.5 % for 1…15 degrees of freedom (the 95 % two-sided interval).
const T_975: [f64; 15] =
    [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131];

/// A cell's ratio r = DoLP/D(γ) for the sun at `s` (the module's equation), where
/// Rayleigh's DoLP there is above CORE_VERIFIABLE of d_max; `None` nearer the sun and
/// the anti-sun.
fn ratio(o: &Obs, s: glam::DVec3) -> Option<f64> {
    let d = rayleigh_dolp(o.d.dot(s));
    (d > CORE_VERIFIABLE).then(|| o.dolp / d)
}

/// Into `core`: whether each cell of `obs` is a hole's clear core for the sun at `s`
/// (the module's equation). Returns the number of core cells; `t` is a buffer.
fn core_cells(obs: &[Obs], s: glam::DVec3, t: &mut Vec<f64>, core: &mut Vec<bool>) -> (usize, f64) {
    let ratio = |o: &Obs| ratio(o, s);
    t.clear();
    t.extend(obs.iter().filter_map(ratio));
    core.clear();
    if t.len() < CORE_TOP {
        core.resize(obs.len(), false);
        return (0, f64::NAN);
    }
    let n = t.len();
    let r_top = *t.select_nth_unstable_by(n - CORE_TOP, |a, b| a.total_cmp(b)).1;
    core.extend(obs.iter().map(|o| ratio(o).is_some_and(|r| r >= (1.0 - CORE_TOL) * r_top)));
    (core.iter().filter(|&&c| c).count(), r_top)
}

/// What the cores' own cover may turn, degrees: the used cells' weighted mean cover
/// c̄ (module's equation: c_i = (1 − r_i/r_top)⁺/(1 − f), f the deck's DoLP over the
/// clear sky's, the median ratio of the cells below DECK_SHARE of r_top) times the
/// deck's turn θ (the deck cells' RMS angle off the fitted sky, noise removed, from
/// their median δ² over χ²₁'s median). The deck's turn shared by every core cell is
/// what the holes' jackknife cannot see; 0 where no deck is seen. `t` is a buffer.
fn rim_turn_deg(obs: &[Obs], w: &[(f64, f64, f64, f64)], s: glam::DVec3, r_top: f64, t: &mut Vec<f64>) -> f64 {
    let ratio = |o: &Obs| ratio(o, s);
    let deck = |o: &&Obs| ratio(o).is_some_and(|r| r < DECK_SHARE * r_top);
    t.clear();
    t.extend(obs.iter().filter(deck).filter_map(ratio));
    let f = (median(t) / r_top).clamp(0.0, 0.9);
    t.clear();
    t.extend(obs.iter().filter(deck).map(|o| residual(o, s).0.asin().powi(2)));
    let d2 = median(t);
    t.clear();
    t.extend(obs.iter().filter(deck).map(|o| o.var_aop));
    let theta = ((d2 - median(t)).max(0.0) / CHI2_1_MEDIAN).sqrt();
    let (sw, swc) = obs.iter().zip(w).filter(|(_, x)| x.0 >= 0.5).fold((0.0, 0.0), |(a, b), (o, x)| {
        let c = ratio(o).map_or(0.0, |r| (1.0 - r / r_top).max(0.0) / (1.0 - f));
        (a + x.0, b + x.0 * c)
    });
    if sw > 0.0 && theta.is_finite() {
        (swc / sw * theta).to_degrees()
    } else {
        0.0
    }
}

/// The delete-one-hole jackknife 1σ of the sky's own sun elevation (the unconstrained
/// sun vector's, as `robust::summary` reads it), degrees; the holes are the blocks.
fn sun_offset_jackknife_deg(obs: &[Obs], w: &[(f64, f64, f64, f64)], band: (f64, f64, f64), hint: glam::DVec3) -> f64 {
    let blocks = block_sums(obs, w, Extractor::SunVector, band);
    let total = sum_blocks(&blocks);
    let elevation = |sums: &crate::heading::HeadingSums| {
        sun_vector::scatter_eigen(sums).ok().map(|(_, v)| {
            let s = if v[0].dot(hint) < 0.0 { -v[0] } else { v[0] };
            s.z.clamp(-1.0, 1.0).asin().to_degrees()
        })
    };
    let dev: Vec<f64> = blocks.iter().filter(|b| b.n > 0.0).filter_map(|b| elevation(&total.minus(b))).collect();
    if dev.len() < 2 {
        return 0.0;
    }
    jackknife_sd(&dev)
}

/// The holes of the core cells of `obs` on a `cols`-wide grid: a hole index per obs
/// (`usize::MAX` off the core) into `hole`, and the number of holes. `grid` is a
/// buffer (per grid cell: its obs index).
fn holes(
    obs: &[Obs],
    core: &[bool],
    cols: usize,
    grid_len: usize,
    grid: &mut Vec<usize>,
    hole: &mut Vec<usize>,
) -> usize {
    grid.clear();
    grid.resize(grid_len, usize::MAX);
    for (i, o) in obs.iter().enumerate() {
        if core[i] {
            grid[o.grid] = i;
        }
    }
    hole.clear();
    hole.resize(obs.len(), usize::MAX);
    let rows = grid_len / cols.max(1);
    let mut k = 0;
    let mut stack = Vec::new();
    for i in 0..obs.len() {
        if !core[i] || hole[i] != usize::MAX {
            continue;
        }
        hole[i] = k;
        stack.push(i);
        while let Some(j) = stack.pop() {
            let (r, c) = (obs[j].grid / cols, obs[j].grid % cols);
            for rr in r.saturating_sub(JOIN_CELLS)..=(r + JOIN_CELLS).min(rows - 1) {
                for cc in c.saturating_sub(JOIN_CELLS)..=(c + JOIN_CELLS).min(cols - 1) {
                    let n = grid[rr * cols + cc];
                    if n != usize::MAX && hole[n] == usize::MAX {
                        hole[n] = k;
                        stack.push(n);
                    }
                }
            }
        }
        k += 1;
    }
    k
}

/// The heading from the holes' cores of a frame whose step 4 found too little sky; the
/// cells observed by it are in `sc.obs`. Errs with too little sky (the cores' count)
/// where the cores are too few.
pub(super) fn fitted(
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    sc: &mut Scratch,
    mut quality: FieldQuality,
) -> Result<Robust, (FieldQuality, NoHeading)> {
    let too_few = |used: usize, q: FieldQuality| (q, NoHeading::TooLittleSky { used, total: q.cells_total });
    let obs = &mut sc.obs;
    if obs.len() < MIN_CORE_CELLS {
        return Err(too_few(0, quality));
    }
    // The start: the cone search on every cell, then on the core alone, a few rounds.
    let mut psi = search(obs, ctx, &mut sc.sub).map_err(|e| (quality, e))?;
    let (mut core, mut sub_obs, mut t) = (Vec::new(), Vec::new(), Vec::new());
    let (mut n_core, mut r_top) = (0, f64::NAN);
    for _ in 0..CORE_ROUNDS {
        (n_core, r_top) = core_cells(obs, cone_sun(ctx, psi), &mut t, &mut core);
        if n_core < MIN_CORE_CELLS {
            return Err(too_few(n_core, quality));
        }
        sub_obs.clear();
        sub_obs.extend(obs.iter().zip(&core).filter(|(_, &c)| c).map(|(o, _)| *o));
        let next = search(&sub_obs, ctx, &mut sc.sub).map_err(|e| (quality, e))?;
        let next = sharpen(&sub_obs, ctx, next, &mut sc.sub);
        let step = wrap_deg_180(next - psi);
        psi = next;
        if step.abs() < 0.01 {
            break;
        }
    }
    // The holes; each one a jackknife block where they fit the blocks' count.
    let (mut grid, mut hole) = (Vec::new(), Vec::new());
    let k = holes(obs, &core, cells.cols, cells.grid_len(), &mut grid, &mut hole);
    if k < MIN_HOLES {
        return Err(too_few(n_core, quality));
    }
    let jackknife_t = if k <= BLOCKS * BLOCKS {
        for (o, &h) in obs.iter_mut().zip(&hole) {
            if h != usize::MAX {
                o.block = h;
            }
        }
        T_975[(k - 1).min(T_975.len() - 1)] / 1.96
    } else {
        1.0
    };
    // Step 4 on the core: τ from its cells, Tukey's weights, the sun vector, until it
    // settles.
    let band = meridian_band(ctx, opts, ctx.level_from_camera(), cells);
    let b = &mut sc.b;
    let weights = |psi: f64, w: &mut Vec<(f64, f64, f64, f64)>, t: &mut Vec<f64>| {
        let s = cone_sun(ctx, psi);
        t.clear();
        t.extend(
            obs.iter()
                .zip(&core)
                .filter(|(_, &c)| c)
                .map(|(o, _)| (residual(o, s).0.powi(2) - CHI2_1_Q25 * o.var_aop) / CHI2_1_Q25),
        );
        let tau2 = quantile(t, 0.25).max(0.0);
        let tau2 = if tau2.is_finite() { tau2 } else { 0.0 };
        w.clear();
        w.extend(obs.iter().zip(&core).map(|(o, &c)| {
            let (delta, sg2, _) = residual(o, s);
            let var = o.var_aop + tau2;
            (if c { tukey(delta / var.sqrt()) } else { 0.0 }, var, sg2, delta)
        }));
        tau2.sqrt()
    };
    let mut tau = weights(psi, &mut b.w, &mut t);
    for it in 1..=MAX_ITERATIONS {
        quality.iterations = it;
        let total = sum_blocks(&block_sums(obs, &b.w, Extractor::SunVector, band));
        let Ok((next, _)) = solve(&total, Extractor::SunVector, ctx, cone_sun(ctx, psi)) else { break };
        let step = wrap_deg_180(next - psi);
        psi = next;
        tau = weights(psi, &mut b.w, &mut t);
        if step.abs() < 1e-3 {
            break;
        }
    }
    let (mut quality, coherent_deg, misfit_rms_deg, misfit_deg) =
        summary(obs, &b.w, ctx, cells, band, psi, tau, quality, &mut t);
    let rim_deg = rim_turn_deg(obs, &b.w, cone_sun(ctx, psi), r_top, &mut t);
    let misfit_deg = misfit_deg.hypot(rim_deg);
    quality.cloud_fraction = 1.0 - n_core as f64 / obs.len().max(1) as f64;
    let polarized = super::dark::Polarized::of(obs);
    let sun_offset_sigma_deg = if k <= BLOCKS * BLOCKS {
        jackknife_t * sun_offset_jackknife_deg(obs, &b.w, band, cone_sun(ctx, psi))
    } else {
        0.0
    };
    Ok(Robust {
        heading_deg: psi,
        coherent_deg,
        misfit_rms_deg,
        misfit_deg,
        quality,
        polarized,
        jackknife_t,
        sun_offset_sigma_deg,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// A cell at grid (col, row) of a 20-wide grid, its ray `d`, DoLP `dolp`.
    fn cell(col: usize, row: usize, d: DVec3, dolp: f64) -> Obs {
        Obs {
            d,
            e: DVec3::X,
            dolp,
            ln_i: 0.0,
            tint: f64::NAN,
            var_aop: 1e-6,
            block: 0,
            grid: row * 20 + col,
            ep: 1.0,
            es: 0.0,
            cos2b: 1.0,
            sin2b: 0.0,
        }
    }

    #[test]
    fn cores_are_the_cells_on_the_clear_sky_s_dolp_and_holes_their_groups() {
        // The sun at the zenith, every ray on the horizon at γ = 90°: D(γ) = 1, so a
        // cell's ratio is its DoLP. Two clear cores near 0.6 (5 cells; 3 cells five rows
        // away, beyond JOIN_CELLS), a feathered rim cell at 0.55 (8 % below: not core)
        // and the deck at 0.05.
        let (s, d) = (DVec3::Z, DVec3::X);
        let mut obs: Vec<Obs> = (0..5).map(|c| cell(c, 0, d, 0.6 + 0.001 * c as f64)).collect();
        obs.extend((10..13).map(|c| cell(c, 5, d, 0.598)));
        obs.push(cell(5, 0, d, 0.55));
        obs.extend((0..20).map(|c| cell(c, 10, d, 0.05)));
        let (mut t, mut core) = (Vec::new(), Vec::new());
        let (n, r_top) = core_cells(&obs, s, &mut t, &mut core);
        assert_eq!(n, 8, "{core:?}");
        assert!((r_top - 0.601).abs() < 1e-9, "{r_top}");
        assert!(!core[8] && core[..8].iter().all(|&c| c));
        let (mut grid, mut hole) = (Vec::new(), Vec::new());
        assert_eq!(holes(&obs, &core, 20, 20 * 11, &mut grid, &mut hole), 2);
        assert!(hole[..5].iter().all(|&h| h == hole[0]) && hole[5..8].iter().all(|&h| h == hole[5]));
        assert_ne!(hole[0], hole[5]);
        assert!(hole[8..].iter().all(|&h| h == usize::MAX));
        // Cells nearer the sun than CORE_VERIFIABLE allows are never read.
        let near: Vec<Obs> = obs.iter().map(|o| Obs { d: DVec3::new(0.2, 0.0, 1.0).normalize(), ..*o }).collect();
        assert_eq!(core_cells(&near, s, &mut t, &mut core).0, 0);
    }

    #[test]
    fn the_cores_cover_turns_them_by_that_share_of_the_deck_s_turn() {
        // Deck cells turned ±θ off the sky's E-vector (DoLP 0.05 of r_top 0.6); used core
        // cells at r = 0.6 (no cover) carry no rim turn; below it the rim turn grows with
        // the cores' cover (1 − r/r_top) and with the deck's turn θ, in proportion.
        let rim = |turn_deg: f64, r_core: f64| {
            let turn = turn_deg.to_radians();
            let mut obs: Vec<Obs> = (0..40)
                .map(|i| {
                    let e = DVec3::new(0.0, turn.cos(), if i % 2 == 0 { turn.sin() } else { -turn.sin() });
                    Obs { e, ..cell(i % 20, 10 + i / 20, DVec3::X, 0.05) }
                })
                .collect();
            let n_deck = obs.len();
            obs.extend((0..10).map(|c| Obs { e: DVec3::Y, ..cell(c, 0, DVec3::X, r_core) }));
            let mut w: Vec<(f64, f64, f64, f64)> = vec![(0.0, 1.0, 1.0, 0.0); n_deck];
            w.extend((0..10).map(|_| (1.0, 1.0, 1.0, 0.0)));
            rim_turn_deg(&obs, &w, DVec3::Z, 0.6, &mut Vec::new())
        };
        assert!(rim(20.0, 0.6).abs() < 1e-9);
        let (a, b, c) = (rim(20.0, 0.585), rim(20.0, 0.57), rim(10.0, 0.57));
        assert!(a > 0.1, "{a}");
        assert!((b / a - 2.0).abs() < 1e-6, "{a} {b}");
        assert!((b / c - 2.0).abs() < 0.01, "{b} {c}");
    }
}
