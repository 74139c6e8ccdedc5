//! Per-pixel analyzers: each pixel of a DoFP mosaic read through its own analyzer
//! row, gain and offset (the per-pixel form of the seed's eq. 13), as `bpins
//! calibrate` measures them in the lab (`crate::lab`).
//!
//! ```text
//! DN_p = o_p + a_p·(I, Q, U)                       pixel p, image frame, DN
//! a_p  = g_p/2 · [(1+ε_p), (1−ε_p) cos 2φ_p, (1−ε_p) sin 2φ_p]
//! ```
//!
//! `o_p` the dark offset (black level included, DN), `g_p` the relative gain (flat
//! field × PRNU, mean 1 over the sensor), `φ_p` the analyzer's transmission axis
//! (degrees, image frame, CONVENTIONS.md), `ε_p` its extinction ratio (1/ER). A map
//! the lab could not measure is absent and takes its nominal value (offset: the
//! black level; gain 1; φ the channel's angle; ε 0).
//!
//! Two ways to apply them, for a Stokes field that is planar across the region they
//! work on exact (per cell) or to second order in the flaws (per tile), with errors of
//! second order (flaw × curvature) otherwise:
//!
//! * **Per cell** ([`CellAnalyzers`], the front door): a cell reduces each channel
//!   to its value at the cell centre, `c_k = Σ_p w_p DN_p` with the plane-fit weights
//!   `w_p` of `heading::field::cells`. Since DN is affine in the Stokes vector,
//!   `c_k = O_k + A_k·S` with `O_k = Σ w_p o_p` and `A_k = Σ w_p a_p`, computed
//!   once per cell; the frame's pixels are read as before, so applying the
//!   calibration costs nothing per pixel. The fixed pattern left about each
//!   channel's plane (`Σ r_p r_pᵀ` of `[a_p, o_p]`) is taken out of the cell's
//!   scatter, so the cell's noise stays that of the photons.
//! * **Per tile** ([`PixelMaps::nominal_mosaic`], the capture readers): each 2 × 2
//!   tile's Stokes vector at its centre `S_c` is solved through its four rows, each
//!   pixel's own `S_p = S_c + ∇S·d_p` (`d_p` = (±½, ±½) px, `∇S` from the neighbouring
//!   tiles); each pixel becomes what a nominal pixel would read, `b + a_nom,k·S_p +
//!   (x_p − a_p·S_p)/g_p`, so `heading`, `fit` and `diagnose` read a calibrated mosaic
//!   with their usual (nominal) analyzers; what is left is flaw² × the field's step
//!   across the tile. One `S` for the whole tile left `(a_nom,k − a_p/g_p)·(S − S_p)`:
//!   the flaw × that step, first order in each, of one sign tile after tile where a
//!   channel's mean analyzer is off (issue 45: 0.4°/px and analyzers 1–2° off turned
//!   a fitted heading by up to 2σ, `tests/calibrate.rs`).

use crate::sensor::{dn_is_valid, Channel, Layout};
use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// The least ε a map may hold. A map is a measurement: a pixel whose true ε is near 0
/// is measured at 0 ± its noise (σ_ε ≈ 0.001 from a 12-angle lab capture), and a
/// clamp at 0 would bias the mean of such pixels up by 0.4 σ_ε (E[max(n, 0)] = σ/√2π),
/// a channel's mean ε by up to 3·10⁻⁴ on a die whose ε spread reaches 0, enough to
/// turn a heading by 0.006° where the channels' ε differ (docs/calibrate.md). The row
/// `a_p` is linear in ε, so a slightly negative estimate is as good as any.
pub(crate) const EPS_MAP_MIN: f64 = -0.1;

/// Names of the maps, as the calibration's EXR file names its channels.
pub const MAP_NAMES: [&str; 4] = ["offset_dn", "gain", "analyzer_deg", "eps"];

/// A sensor's per-pixel maps (row-major, `width_px × height_px`; `None`: not measured).
#[derive(Clone, Debug, PartialEq)]
pub struct PixelMaps {
    pub width_px: usize,
    pub height_px: usize,
    /// The mosaic the maps were measured with.
    pub mosaic: [[Channel; 2]; 2],
    /// Dark offset per pixel, DN (black level included).
    pub offset_dn: Option<Vec<f32>>,
    /// Relative gain (flat field × PRNU), mean 1 over the sensor.
    pub gain: Option<Vec<f32>>,
    /// Analyzer transmission axis, degrees, image frame (near the channel's nominal angle).
    pub analyzer_deg: Option<Vec<f32>>,
    /// Extinction ratio ε (= 1/ER), 0 … 1; an estimate may fall below 0 by its noise
    /// (`EPS_MAP_MIN`).
    pub eps: Option<Vec<f32>>,
}

/// A per-cell reconstruction built from [`PixelMaps`] (see the module).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CellAnalyzer {
    /// `O_k`: each channel's offset at the cell centre, DN.
    pub offset_dn: [f64; 4],
    /// Rows I, Q, U of the least-squares inverse of `[A_k]`, by channel index.
    pub rows: [[f64; 4]; 3],
    /// Per channel, the fixed pattern about its plane: upper triangle of
    /// `Σ r_p r_pᵀ` over `r = [a, o]` residuals (00 01 02 03 11 12 13 22 23 33), DN².
    pub pattern: [[f64; 10]; 4],
    /// False where the cell's rows cannot resolve Q and U.
    pub ok: bool,
}

impl CellAnalyzer {
    /// `rows`, `ok` from the cell's analyzer rows `a_rows` (by channel index): least
    /// squares over the four channels, (AᵀA)⁻¹Aᵀ; `ok` false where AᵀA is singular.
    fn solve_rows(&mut self, a_rows: &[DVec3; 4]) {
        let mut ata = DMat3::ZERO;
        for r in a_rows {
            ata += DMat3::from_cols(*r * r.x, *r * r.y, *r * r.z);
        }
        if ata.determinant().abs() > 1e-12 {
            let inv = ata.inverse();
            for (k, r) in a_rows.iter().enumerate() {
                let col = inv * *r;
                for i in 0..3 {
                    self.rows[i][k] = col[i];
                }
            }
            self.ok = true;
        }
    }
}

/// One [`CellAnalyzer`] per cell of a grid of `cell_px` cells, row-major.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CellAnalyzers {
    pub cell_px: usize,
    pub cols: usize,
    pub rows: usize,
    pub cells: Vec<CellAnalyzer>,
}

/// `x` as degrees wrapped to (−90°, 90°] (an axis angle difference).
fn wrap_axis_deg(x: f64) -> f64 {
    let y = x.rem_euclid(180.0);
    if y > 90.0 {
        y - 180.0
    } else {
        y
    }
}

impl PixelMaps {
    /// No maps: every pixel nominal.
    pub fn nominal(width_px: usize, height_px: usize, mosaic: [[Channel; 2]; 2]) -> Self {
        PixelMaps { width_px, height_px, mosaic, offset_dn: None, gain: None, analyzer_deg: None, eps: None }
    }

    /// The maps present, by name ([`MAP_NAMES`]).
    pub fn present(&self) -> Vec<(&'static str, &[f32])> {
        let maps = [&self.offset_dn, &self.gain, &self.analyzer_deg, &self.eps];
        MAP_NAMES.iter().zip(maps).filter_map(|(n, m)| m.as_deref().map(|m| (*n, m))).collect()
    }

    /// Checks the maps' lengths and values; `Err` says which map and pixel.
    pub fn check(&self) -> Result<(), String> {
        let n = self.width_px * self.height_px;
        for (name, m) in self.present() {
            if m.len() != n {
                return Err(format!(
                    "map {name} has {} pixels, the sensor {} × {}",
                    m.len(),
                    self.width_px,
                    self.height_px
                ));
            }
            if let Some(i) = m.iter().position(|x| !x.is_finite()) {
                return Err(format!("map {name}: pixel ({}, {}) is not finite", i % self.width_px, i / self.width_px));
            }
        }
        if let Some(g) = &self.gain {
            if let Some(i) = g.iter().position(|&x| x <= 0.0) {
                return Err(format!(
                    "map gain: pixel ({}, {}) is {} (must be > 0)",
                    i % self.width_px,
                    i / self.width_px,
                    g[i]
                ));
            }
        }
        if let Some(e) = &self.eps {
            if let Some(i) = e.iter().position(|&x| !(EPS_MAP_MIN as f32..1.0).contains(&x)) {
                return Err(format!(
                    "map eps: pixel ({}, {}) is {} (must be in [{EPS_MAP_MIN}, 1))",
                    i % self.width_px,
                    i / self.width_px,
                    e[i]
                ));
            }
        }
        if let Some(a) = &self.analyzer_deg {
            for (i, &x) in a.iter().enumerate() {
                let (u, v) = (i % self.width_px, i / self.width_px);
                let nominal = Layout::dofp_channel(&self.mosaic, u, v).angle_deg();
                let d = wrap_axis_deg(x as f64 - nominal);
                if d.abs() > 10.0 {
                    return Err(format!(
                        "map analyzer_deg: pixel ({u}, {v}) is {x}°, {d:.1}° from its channel's {nominal}°: \
                         another mosaic order?"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Checks the maps against a sensor of `width_px × height_px` and `mosaic`; the
    /// message names both sizes.
    pub fn check_sensor(&self, width_px: usize, height_px: usize, mosaic: &[[Channel; 2]; 2]) -> Result<(), String> {
        if (width_px, height_px) != (self.width_px, self.height_px) {
            return Err(format!(
                "the calibration's pixel maps are {} × {} px but the sensor is {width_px} × {height_px} px",
                self.width_px, self.height_px
            ));
        }
        if *mosaic != self.mosaic {
            return Err(format!(
                "the calibration's pixel maps were measured with mosaic {:?}, the sensor's is {:?}",
                angles(&self.mosaic),
                angles(mosaic)
            ));
        }
        Ok(())
    }

    /// Pixel `(u, v)`'s analyzer row `a_p` (DN per unit I, Q, U) and offset `o_p`
    /// (`black_level_dn` where not measured).
    #[inline]
    pub fn pixel(&self, u: usize, v: usize, black_level_dn: f64) -> ([f64; 3], f64) {
        let i = v * self.width_px + u;
        let g = self.gain.as_ref().map_or(1.0, |m| m[i] as f64);
        let eps = self.eps.as_ref().map_or(0.0, |m| m[i] as f64);
        let phi = match &self.analyzer_deg {
            Some(m) => m[i] as f64,
            None => Layout::dofp_channel(&self.mosaic, u, v).angle_deg(),
        };
        let (s, c) = (2.0 * phi).to_radians().sin_cos();
        let o = self.offset_dn.as_ref().map_or(black_level_dn, |m| m[i] as f64);
        ([0.5 * g * (1.0 + eps), 0.5 * g * (1.0 - eps) * c, 0.5 * g * (1.0 - eps) * s], o)
    }

    /// Sensor row `v`'s analyzer rows, offsets and gains into `r`, as [`Self::pixel`]
    /// gives them pixel by pixel but a row at a time and without libm, so the loop
    /// vectorizes: sin 2φ and cos 2φ as the quadrant of the pixel's nominal 2φ (90° q,
    /// exactly) turned by 2(φ − 45° q) through `math::sin_cos_quarter` (within 1 ulp),
    /// libm's where a map strays beyond ±22.5° of its channel (maps not `check`ed).
    fn row_into(&self, v: usize, black_level_dn: f64, r: &mut PixelRow) {
        let w = self.width_px;
        let span = v * w..(v + 1) * w;
        let fill = |dst: &mut Vec<f64>, map: &Option<Vec<f32>>, absent: f64| {
            dst.clear();
            match map {
                Some(m) => dst.extend(m[span.clone()].iter().map(|&x| x as f64)),
                None => dst.resize(w, absent),
            }
        };
        let nominal_deg = [0, 1].map(|u| Layout::dofp_channel(&self.mosaic, u, v).angle_deg());
        fill(&mut r.g, &self.gain, 1.0);
        fill(&mut r.eps, &self.eps, 0.0);
        fill(&mut r.o, &self.offset_dn, black_level_dn);
        match &self.analyzer_deg {
            Some(_) => fill(&mut r.phi, &self.analyzer_deg, 0.0),
            None => {
                r.phi.clear();
                r.phi.extend((0..w).map(|u| nominal_deg[u & 1]));
            }
        }
        // 2φ = 90° q + 2d: q from the channel's nominal angle, (cos, sin) of 90° q exact.
        let q = nominal_deg.map(|a| ((a / 45.0).round() as i64).rem_euclid(4) as usize);
        let base_deg = q.map(|q| 45.0 * q as f64);
        let turn = q.map(|q| [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][q]);
        for a in &mut r.a {
            a.resize(w, 0.0);
        }
        let [a0, a1, a2] = &mut r.a;
        let pixels = a0.iter_mut().zip(a1.iter_mut()).zip(a2.iter_mut()).zip(r.g.iter().zip(&r.eps).zip(&r.phi));
        for (u, (((a0, a1), a2), ((&g, &eps), &phi))) in pixels.enumerate() {
            // Selects, not indexing by u & 1: the loop vectorizes.
            let odd = u & 1 == 1;
            let base = if odd { base_deg[1] } else { base_deg[0] };
            let (cq, sq) = if odd { turn[1] } else { turn[0] };
            let (sd, cd) = crate::math::sin_cos_quarter((2.0 * (phi - base)).to_radians());
            let (s, c) = (cq * sd + sq * cd, cq * cd - sq * sd);
            *a0 = 0.5 * g * (1.0 + eps);
            *a1 = 0.5 * g * (1.0 - eps) * c;
            *a2 = 0.5 * g * (1.0 - eps) * s;
        }
        for u in 0..w {
            let near = (r.phi[u] - base_deg[u & 1]).abs() <= 22.5; // false for NaN too
            if !near {
                let (s, c) = (2.0 * r.phi[u]).to_radians().sin_cos();
                r.a[1][u] = 0.5 * r.g[u] * (1.0 - r.eps[u]) * c;
                r.a[2][u] = 0.5 * r.g[u] * (1.0 - r.eps[u]) * s;
            }
        }
    }

    /// The per-cell reconstruction of a grid of `cell_px` cells (even, ≥ 2) over the
    /// whole sensor (see the module); `black_level_dn` stands in for an unmeasured offset.
    pub fn cell_analyzers(&self, cell_px: usize, black_level_dn: f64) -> CellAnalyzers {
        let cell_px = (cell_px.max(2) + 1) & !1;
        let (cols, rows) = (self.width_px / cell_px, self.height_px / cell_px);
        let h = cell_px / 2;
        let n = (h * h) as f64;
        let sxx = n * (n - 1.0) / 3.0;
        let cells = (0..cols * rows)
            .into_par_iter()
            .map(|idx| {
                let (u0, v0) = ((idx % cols) * cell_px, (idx / cols) * cell_px);
                let mut cell = CellAnalyzer::default();
                let mut a_rows = [DVec3::ZERO; 4];
                for (q, mrow) in self.mosaic.iter().enumerate() {
                    for (p, ch) in mrow.iter().enumerate() {
                        let k = ch.index();
                        let (ubar, vbar) = ((p + h - 1) as f64, (q + h - 1) as f64);
                        // Plane fit of z = [a, o] over the channel's pixels: mean and slopes.
                        let (mut zs, mut zu, mut zv) = ([0.0; 4], [0.0; 4], [0.0; 4]);
                        let mut eff = [0.0; 4];
                        for j in 0..h {
                            for i in 0..h {
                                let (du, dv) = ((p + 2 * i) as f64, (q + 2 * j) as f64);
                                let (a, o) = self.pixel(u0 + p + 2 * i, v0 + q + 2 * j, black_level_dn);
                                let z = [a[0], a[1], a[2], o];
                                let w = if sxx > 0.0 {
                                    1.0 / n + ((du - ubar) * (0.5 - p as f64) + (dv - vbar) * (0.5 - q as f64)) / sxx
                                } else {
                                    1.0 / n
                                };
                                for c in 0..4 {
                                    eff[c] += w * z[c];
                                    zs[c] += z[c];
                                    zu[c] += (du - ubar) * z[c];
                                    zv[c] += (dv - vbar) * z[c];
                                }
                            }
                        }
                        a_rows[k] = DVec3::new(eff[0], eff[1], eff[2]);
                        cell.offset_dn[k] = eff[3];
                        let mut m = [0.0; 10];
                        for j in 0..h {
                            for i in 0..h {
                                let (du, dv) = ((p + 2 * i) as f64 - ubar, (q + 2 * j) as f64 - vbar);
                                let (a, o) = self.pixel(u0 + p + 2 * i, v0 + q + 2 * j, black_level_dn);
                                let z = [a[0], a[1], a[2], o];
                                let mut r = [0.0; 4];
                                for c in 0..4 {
                                    let (gx, gy) = if sxx > 0.0 { (zu[c] / sxx, zv[c] / sxx) } else { (0.0, 0.0) };
                                    r[c] = z[c] - zs[c] / n - gx * du - gy * dv;
                                }
                                let mut t = 0;
                                for x in 0..4 {
                                    for y in x..4 {
                                        m[t] += r[x] * r[y];
                                        t += 1;
                                    }
                                }
                            }
                        }
                        cell.pattern[k] = m;
                    }
                }
                cell.solve_rows(&a_rows);
                cell
            })
            .collect();
        CellAnalyzers { cell_px, cols, rows, cells }
    }

    /// The mosaic `dn` (row-major, this size) as nominal pixels would read it (see
    /// the module): per tile, the Stokes vector at the tile's centre `S_c` through
    /// the four pixels' own rows, each pixel's own `S_p = S_c + ∇S·d_p` (`d_p` its
    /// offset from the centre, ±½ px; `∇S` from the neighbouring tiles' first
    /// solutions, `tile_gradients`), then each pixel `b + a_nom,k·S_p + (x_p −
    /// a_p·S_p)/g_p` with `x_p = DN_p − o_p`. For a Stokes field planar over three
    /// tiles the error left is of second order in the flaws (flaw² × the field's step
    /// across a tile), where one `S` per tile left the first. Tiles with a saturated or
    /// zero sample, and a last odd row or column, are left as they are.
    pub fn nominal_mosaic(&self, dn: &[f32], black_level_dn: f64, full_scale_dn: f64) -> Vec<f32> {
        let (w, tw, th) = (self.width_px, self.width_px / 2, self.height_px / 2);
        let mut out = dn.to_vec();
        if tw == 0 || th == 0 {
            return out;
        }
        // Each pixel's nominal row, by its place in the tile (TILE_PLACES order).
        let nominal = TILE_PLACES.map(|(du, dv)| {
            let (s, co) = (2.0 * Layout::dofp_channel(&self.mosaic, du, dv).angle_deg()).to_radians().sin_cos();
            DVec3::new(0.5, 0.5 * co, 0.5 * s)
        });
        // Tile (ti, tj)'s four pixels, from its two sensor rows `px`; None where unusable.
        let tile = |ti: usize, tj: usize, px: &[PixelRow; 2]| -> Option<Tile> {
            let mut t = Tile { a: [DVec3::ZERO; 4], x: [0.0; 4], g: [0.0; 4], inv: DMat3::ZERO, first: DVec3::ZERO };
            let mut ata = DMat3::ZERO;
            for (n, (du, dv)) in TILE_PLACES.into_iter().enumerate() {
                let u = 2 * ti + du;
                let raw = dn[(2 * tj + dv) * w + u] as f64;
                if !dn_is_valid(raw, full_scale_dn) {
                    return None;
                }
                let r = &px[dv];
                let a = DVec3::new(r.a[0][u], r.a[1][u], r.a[2][u]);
                ata += DMat3::from_cols(a * a.x, a * a.y, a * a.z);
                (t.a[n], t.x[n], t.g[n]) = (a, raw - r.o[u], r.g[u]);
            }
            if ata.determinant().abs() < 1e-12 {
                return None;
            }
            t.inv = ata.inverse();
            // The first solution: one S for the whole tile.
            t.first = t.inv * (0..4).map(|n| t.a[n] * t.x[n]).sum::<DVec3>();
            Some(t)
        };
        let tile_row = |tj: usize, px: &mut [PixelRow; 2], row: &mut Vec<Option<Tile>>| {
            row.clear();
            if tj < th {
                for (dv, r) in px.iter_mut().enumerate() {
                    self.row_into(2 * tj + dv, black_level_dn, r);
                }
                row.extend((0..tw).map(|ti| tile(ti, tj, px)));
            }
        };
        // Bands of tile rows in parallel; within a band the tile rows above, here and
        // below in a rolling window, so each tile is solved once (twice at a band's
        // edges) and its pixels read once.
        out.par_chunks_mut(2 * w * BAND_TILE_ROWS).take(th.div_ceil(BAND_TILE_ROWS)).enumerate().for_each(
            |(b, rows)| {
                let tj0 = b * BAND_TILE_ROWS;
                let mut win: [Vec<Option<Tile>>; 3] = Default::default();
                let mut px: [PixelRow; 2] = Default::default();
                if tj0 > 0 {
                    tile_row(tj0 - 1, &mut px, &mut win[0]);
                }
                tile_row(tj0, &mut px, &mut win[1]);
                for tj in tj0..(tj0 + BAND_TILE_ROWS).min(th) {
                    tile_row(tj + 1, &mut px, &mut win[2]);
                    let out_rows = &mut rows[(tj - tj0) * 2 * w..];
                    for ti in 0..tw {
                        let Some(t) = &win[1][ti] else { continue };
                        let [gu, gv] = tile_gradients(&win, ti);
                        let at = |n: usize| {
                            let (du, dv) = TILE_PLACES[n];
                            gu * (du as f64 - 0.5) + gv * (dv as f64 - 0.5)
                        };
                        let s_c = t.inv * (0..4).map(|n| t.a[n] * (t.x[n] - t.a[n].dot(at(n)))).sum::<DVec3>();
                        for (n, (du, dv)) in TILE_PLACES.into_iter().enumerate() {
                            let s = s_c + at(n);
                            let y = black_level_dn + nominal[n].dot(s) + (t.x[n] - t.a[n].dot(s)) / t.g[n];
                            out_rows[dv * w + 2 * ti + du] = y as f32;
                        }
                    }
                    win.rotate_left(1);
                }
            },
        );
        out
    }
}

/// Tile rows per parallel task of [`PixelMaps::nominal_mosaic`]: 32 rows of a
/// 2448-px-wide frame are 0.16 Mpx, 32 tasks per 2048-px frame; the rows above and
/// below each band (solved twice) add 1/16.
const BAND_TILE_ROWS: usize = 32;

/// A 2 × 2 tile's pixels (u, v) offsets from its top-left pixel, in the order of [`Tile`].
const TILE_PLACES: [(usize, usize); 4] = [(0, 0), (1, 0), (0, 1), (1, 1)];

/// One sensor row of [`PixelMaps::row_into`], by pixel: the analyzer row `a_p` by
/// component (I, Q, U), offset `o_p` and gain `g_p` as [`PixelMaps::pixel`] has them,
/// and the maps' ε and φ (degrees) they came from.
#[derive(Default)]
struct PixelRow {
    a: [Vec<f64>; 3],
    o: Vec<f64>,
    g: Vec<f64>,
    eps: Vec<f64>,
    phi: Vec<f64>,
}

/// One usable 2 × 2 tile of [`PixelMaps::nominal_mosaic`], by pixel in
/// [`TILE_PLACES`] order: the rows `a_p` (DN per unit I, Q, U), `x_p = DN_p − o_p`
/// (DN) and gains `g_p`; `(Σ a_p a_pᵀ)⁻¹` and the first solution `S` (one Stokes
/// vector for the tile, DN).
#[derive(Clone, Copy)]
struct Tile {
    a: [DVec3; 4],
    x: [f64; 4],
    g: [f64; 4],
    inv: DMat3,
    first: DVec3,
}

/// The Stokes field's change per pixel along u and v at tile `ti` of the middle row
/// of `win` (tile rows above, here, below; an empty row: none there), from its
/// neighbours' first solutions: a central difference over 4 px where both neighbours
/// are usable, one-sided over 2 px where one is, 0 where neither is. A tile's first
/// solution is off its centre's by its rows' mixing of the gradient (`(AᵀA)⁻¹ Σ a_p
/// a_pᵀ ∇S·d_p`), alike in every tile but for the tiles' own flaws, so the differences
/// carry only the flaws' difference × the step: first order in the flaws, which the
/// conversion multiplies by the flaw again.
fn tile_gradients(win: &[Vec<Option<Tile>>; 3], ti: usize) -> [DVec3; 2] {
    let get = |row: usize, i: Option<usize>| i.and_then(|i| win[row].get(i)).and_then(|t| t.as_ref()).map(|t| t.first);
    let diff = |lo: Option<DVec3>, here: Option<DVec3>, hi: Option<DVec3>| match (lo, here, hi) {
        (Some(l), _, Some(h)) => (h - l) / 4.0,
        (Some(l), Some(c), None) => (c - l) / 2.0,
        (None, Some(c), Some(h)) => (h - c) / 2.0,
        _ => DVec3::ZERO,
    };
    let here = get(1, Some(ti));
    [diff(get(1, ti.checked_sub(1)), here, get(1, Some(ti + 1))), diff(get(0, Some(ti)), here, get(2, Some(ti)))]
}

#[path = "pixel_analyzers_band.rs"]
mod band;

fn angles(m: &[[Channel; 2]; 2]) -> [[f64; 2]; 2] {
    m.map(|r| r.map(|c| c.angle_deg()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::DEFAULT_MOSAIC;

    /// Seeded flawed maps of a `w × h` sensor: angle offsets up to ±1.5°, ε up to
    /// 0.04, gain ±10 %, offsets 64 ± 5 DN.
    pub(super) fn flawed(w: usize, h: usize) -> PixelMaps {
        let r = |i: usize, salt: u64| {
            let x = (i as u64 ^ salt)
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .rotate_left(17)
                .wrapping_mul(0xBF58_476D_1CE4_E5B9);
            (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let n = w * h;
        let nominal: Vec<f64> =
            (0..n).map(|i| Layout::dofp_channel(&DEFAULT_MOSAIC, i % w, i / w).angle_deg()).collect();
        PixelMaps {
            width_px: w,
            height_px: h,
            mosaic: DEFAULT_MOSAIC,
            offset_dn: Some((0..n).map(|i| (64.0 + 5.0 * r(i, 1)) as f32).collect()),
            gain: Some((0..n).map(|i| (1.0 + 0.1 * r(i, 2)) as f32).collect()),
            analyzer_deg: Some((0..n).map(|i| (nominal[i] + 1.5 * r(i, 3)) as f32).collect()),
            eps: Some((0..n).map(|i| (0.02 + 0.02 * r(i, 4)) as f32).collect()),
        }
    }

    /// A planar Stokes field (I, Q, U of pixel position), DN.
    fn field(u: f64, v: f64) -> [f64; 3] {
        [2000.0 + 3.0 * u - 2.0 * v, 400.0 + 1.5 * u, -300.0 + 2.0 * v - 0.5 * u]
    }

    fn render(m: &PixelMaps) -> Vec<f32> {
        (0..m.width_px * m.height_px)
            .map(|i| {
                let (u, v) = (i % m.width_px, i / m.width_px);
                let (a, o) = m.pixel(u, v, 64.0);
                let s = field(u as f64, v as f64);
                (o + a[0] * s[0] + a[1] * s[1] + a[2] * s[2]) as f32
            })
            .collect()
    }

    #[test]
    fn nominal_maps_are_the_identity() {
        let m = PixelMaps::nominal(16, 8, DEFAULT_MOSAIC);
        let dn: Vec<f32> = (0..128).map(|i| 100.0 + i as f32).collect();
        let out = m.nominal_mosaic(&dn, 64.0, 4095.0);
        assert!(dn.iter().zip(&out).all(|(a, b)| (a - b).abs() < 1e-3));
        let ca = m.cell_analyzers(8, 64.0);
        for c in &ca.cells {
            assert!(c.ok && c.offset_dn.iter().all(|&o| (o - 64.0).abs() < 1e-12));
            // Nominal rows: I = ½ΣI_k, Q = I0 − I90, U = I45 − I135.
            assert!((c.rows[1][0] - 1.0).abs() < 1e-9 && (c.rows[1][2] + 1.0).abs() < 1e-9, "{c:?}");
            assert!(c.pattern.iter().flatten().all(|&x| x.abs() < 1e-18));
        }
    }

    #[test]
    fn a_flawed_sensor_reads_back_its_planar_field_per_cell() {
        let m = flawed(32, 24);
        m.check().unwrap();
        let dn = render(&m);
        let ca = m.cell_analyzers(8, 64.0);
        assert_eq!((ca.cols, ca.rows), (4, 3));
        // Channel centre values as the cells compute them (plane fit), then the rows.
        for (idx, c) in ca.cells.iter().enumerate() {
            let (u0, v0) = ((idx % 4) * 8, (idx / 4) * 8);
            let mut val = [0.0; 4];
            for (q, mrow) in DEFAULT_MOSAIC.iter().enumerate() {
                for (p, ch) in mrow.iter().enumerate() {
                    let (ubar, vbar) = ((p + 3) as f64, (q + 3) as f64);
                    let sxx = 16.0 * 15.0 / 3.0;
                    let (mut s, mut su, mut sv) = (0.0, 0.0, 0.0);
                    for j in 0..4 {
                        for i in 0..4 {
                            let x = dn[(v0 + q + 2 * j) * 32 + u0 + p + 2 * i] as f64;
                            s += x;
                            su += ((p + 2 * i) as f64 - ubar) * x;
                            sv += ((q + 2 * j) as f64 - vbar) * x;
                        }
                    }
                    val[ch.index()] = s / 16.0 + su / sxx * (0.5 - p as f64) + sv / sxx * (0.5 - q as f64);
                }
            }
            let st: Vec<f64> =
                (0..3).map(|r| (0..4).map(|k| c.rows[r][k] * (val[k] - c.offset_dn[k])).sum::<f64>()).collect();
            let want = field(u0 as f64 + 3.5, v0 as f64 + 3.5);
            for r in 0..3 {
                // Exact up to the second-order term Σ w_p δa_p·(∇S·d_p) (flaw × gradient ×
                // offset, here 10 % × 3 DN/px × 3 px, averaged over 16 pixels): < 0.2 DN
                // of 2000 (1e-4).
                assert!((st[r] - want[r]).abs() < 0.2, "cell {idx}: {st:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn a_flawed_mosaic_becomes_the_nominal_one_per_tile() {
        let m = flawed(32, 24);
        let dn = render(&m);
        let out = m.nominal_mosaic(&dn, 64.0, 65535.0);
        let ideal = render(&PixelMaps::nominal(32, 24, DEFAULT_MOSAIC));
        // Within a tile the field varies by a pixel's gradient (up to 3 DN/px here):
        // each pixel is converted at its own S_p, so a planar field comes out to second
        // order in the flaws, flaw² × that step: 0.005 DN (one S per tile left the
        // flaw × that step, 0.14 DN).
        let worst = out.iter().zip(&ideal).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        let before = dn.iter().zip(&ideal).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(worst < 0.02 && before > 50.0, "after {worst} DN, before {before} DN");
    }

    #[test]
    fn a_row_at_a_time_is_pixel_by_pixel() {
        let mut m = flawed(34, 4);
        // Unchecked maps: analyzers 35° and more from their channels take libm's route.
        let phi = m.analyzer_deg.as_mut().unwrap();
        (phi[3], phi[4], phi[40]) = (170.0, 0.0, -80.0);
        let mut r = PixelRow::default();
        for maps in [
            m.clone(),
            PixelMaps { analyzer_deg: None, eps: None, ..m.clone() },
            PixelMaps::nominal(34, 4, DEFAULT_MOSAIC),
        ] {
            for v in 0..4 {
                maps.row_into(v, 64.0, &mut r);
                for u in 0..34 {
                    let (a, o) = maps.pixel(u, v, 64.0);
                    assert_eq!((r.o[u], r.g[u]), (o, maps.gain.as_ref().map_or(1.0, |g| g[v * 34 + u] as f64)));
                    // `pixel` rounds 2φ·π/180 near π/2 (ulp 2.2e-16) before its sin_cos,
                    // `row_into` the small 2(φ − 45° q): a few 1e-16 apart, of a row ≈ 0.5.
                    for (k, (row, want)) in r.a.iter().zip(a).enumerate() {
                        assert!((row[u] - want).abs() < 1e-15, "({u}, {v}) {k}: {} vs {want}", row[u]);
                    }
                }
            }
        }
    }

    #[test]
    fn wrong_sizes_mosaics_and_values_are_named() {
        let m = flawed(32, 24);
        let e = m.check_sensor(30, 24, &DEFAULT_MOSAIC).unwrap_err();
        assert!(e.contains("32 × 24") && e.contains("30 × 24"), "{e}");
        let other = [[Channel::C0, Channel::C45], [Channel::C135, Channel::C90]];
        assert!(m.check_sensor(32, 24, &other).unwrap_err().contains("mosaic"));
        let mut bad = m.clone();
        bad.eps.as_mut().unwrap()[5] = 1.5;
        assert!(bad.check().unwrap_err().contains("eps"));
        // An estimate of a small ε may fall below 0 by its noise; far below is refused.
        bad.eps.as_mut().unwrap()[5] = -0.002;
        bad.check().unwrap();
        bad.eps.as_mut().unwrap()[5] = -0.2;
        assert!(bad.check().unwrap_err().contains("eps"));
        let mut bad = m.clone();
        bad.mosaic = other;
        assert!(bad.check().unwrap_err().contains("analyzer_deg"));
    }
}
