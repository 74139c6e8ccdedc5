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
        let nominal_row = |c: Channel| {
            let (s, co) = (2.0 * c.angle_deg()).to_radians().sin_cos();
            DVec3::new(0.5, 0.5 * co, 0.5 * s)
        };
        // Tile (ti, tj)'s four pixels: offsets, rows a_p, x_p, gains; None where unusable.
        let tile = |ti: usize, tj: usize| {
            let mut px = [(0usize, 0usize, DVec3::ZERO, 0.0f64, 0.0f64); 4];
            let mut ata = DMat3::ZERO;
            for (n, (du, dv)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
                let (u, v) = (2 * ti + du, 2 * tj + dv);
                let raw = dn[v * w + u] as f64;
                if !dn_is_valid(raw, full_scale_dn) {
                    return None;
                }
                let (a, o) = self.pixel(u, v, black_level_dn);
                let a = DVec3::from_array(a);
                ata += DMat3::from_cols(a * a.x, a * a.y, a * a.z);
                px[n] = (du, dv, a, raw - o, self.gain.as_ref().map_or(1.0, |g| g[v * w + u] as f64));
            }
            (ata.determinant().abs() >= 1e-12).then(|| (px, ata.inverse()))
        };
        // First pass: each tile's S as if its pixels saw one Stokes vector.
        let first: Vec<Option<DVec3>> = (0..tw * th)
            .into_par_iter()
            .map(|t| {
                let (px, inv) = tile(t % tw, t / tw)?;
                Some(inv * px.iter().map(|p| p.2 * p.3).sum::<DVec3>())
            })
            .collect();
        let mut out = dn.to_vec();
        out.par_chunks_mut(2 * w).take(th).enumerate().for_each(|(tj, rows)| {
            for ti in 0..tw {
                let Some((px, inv)) = tile(ti, tj) else { continue };
                let [gu, gv] = tile_gradients(&first, tw, th, ti, tj);
                let at = |du: usize, dv: usize| gu * (du as f64 - 0.5) + gv * (dv as f64 - 0.5);
                let s_c = inv * px.iter().map(|&(du, dv, a, x, _)| a * (x - a.dot(at(du, dv)))).sum::<DVec3>();
                for (du, dv, a, x, g) in px {
                    let s = s_c + at(du, dv);
                    let c = Layout::dofp_channel(&self.mosaic, 2 * ti + du, 2 * tj + dv);
                    let y = black_level_dn + nominal_row(c).dot(s) + (x - a.dot(s)) / g;
                    rows[dv * w + 2 * ti + du] = y as f32;
                }
            }
        });
        out
    }
}

/// The Stokes field's change per pixel along u and v at tile `(ti, tj)` of a `tw × th`
/// grid of 2 × 2 tiles, from its neighbours' first solutions `first` (row-major): a
/// central difference over 4 px where both neighbours are usable, one-sided over 2 px
/// where one is, 0 where neither is. A tile's first solution is off its centre's by
/// its rows' mixing of the gradient (`(AᵀA)⁻¹ Σ a_p a_pᵀ ∇S·d_p`), alike in every tile
/// but for the tiles' own flaws, so the differences carry only the flaws' difference ×
/// the step: first order in the flaws, which the conversion multiplies by the flaw again.
fn tile_gradients(first: &[Option<DVec3>], tw: usize, th: usize, ti: usize, tj: usize) -> [DVec3; 2] {
    let get = |i: Option<usize>, j: Option<usize>| match (i, j) {
        (Some(i), Some(j)) if i < tw && j < th => first[j * tw + i],
        _ => None,
    };
    let diff = |lo: Option<DVec3>, here: Option<DVec3>, hi: Option<DVec3>| match (lo, here, hi) {
        (Some(l), _, Some(h)) => (h - l) / 4.0,
        (Some(l), Some(c), None) => (c - l) / 2.0,
        (None, Some(c), Some(h)) => (h - c) / 2.0,
        _ => DVec3::ZERO,
    };
    let here = get(Some(ti), Some(tj));
    [
        diff(get(ti.checked_sub(1), Some(tj)), here, get(Some(ti + 1), Some(tj))),
        diff(get(Some(ti), tj.checked_sub(1)), here, get(Some(ti), Some(tj + 1))),
    ]
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
