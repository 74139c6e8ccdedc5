//! Cells: a frame binned into square blocks of `cell_px × cell_px` pixels, each
//! reduced to its mean Stokes vector and that mean's noise.
//!
//! ```text
//! x̄_k  = mean DN of channel k over the cell's valid pixels        (DN)
//! s²_k = within-cell variance of channel k / n_k                   (DN², of the mean)
//! (I, Q, U) = Reconstructor(x̄)                                     image frame (seed eq. 4, 13)
//! var Q = Σ_k (R_Qk / (1 + gain_k))² s²_k, likewise U
//! ```
//!
//! The reconstruction is affine, so the Stokes vector of the channel means is the
//! mean of the per-tile Stokes vectors: no information is lost for a smooth sky,
//! and the per-cell noise comes from the data itself (shot and read noise, plus the
//! texture of clouds, leaves and edges, which is what should lower a cell's weight).
//! A cell sits at its centre. In a DoFP mosaic each channel's pixels are centred half
//! a pixel off it in x and y (as a superpixel's are), which on a steep gradient would
//! bias AoP by hundredths of a degree (CONVENTIONS.md, Pixels: a sample belongs to its
//! own ray); so each channel's mean is moved to the cell centre along that channel's
//! own least-squares gradient across the cell:
//!
//! ```text
//! x_k(centre) = x̄_k + g_x,k·(½ − p_k) + g_y,k·(½ − q_k)     (p_k, q_k): channel k's place in the tile
//! g_x,k = Σ (u − ū_k)·DN / Σ (u − ū_k)²                       over channel k's pixels of the cell
//! ```
//!
//! and the noise is the scatter about that plane. Saturated or zero DN are left out
//! of the means (such a cell keeps the plain means); a cell with more than
//! [`MAX_INVALID_FRACTION`] of them is not used (the sun's disc, blown highlights).
//!
//! Frame: image pixels (CONVENTIONS.md); units DN. Only whole cells are kept: a
//! margin narrower than a cell at the right and bottom edges is not read.

use crate::pixel_analyzers::CellAnalyzers;
use crate::recon::{PolImage, Reconstructor};
use crate::sensor::{dn_is_valid, Channel, Layout};
use crate::stokes::Stokes;
use rayon::prelude::*;

/// A cell with more than this fraction of saturated or zero pixels is not used.
pub const MAX_INVALID_FRACTION: f64 = 0.05;

/// One DN sample type of a raw frame: `u8`, `u16` or `f32`.
pub trait RawDn: Copy + Send + Sync {
    /// Whether the samples are whole numbers (an integer type): what an integer
    /// demosaic rounds to (`maps::Interpolation::OpenCv`).
    const INTEGER: bool = true;
    fn dn(self) -> f64;
    /// The sample in single precision (exact for `u8`, `u16`).
    #[inline(always)]
    fn dn_f32(self) -> f32 {
        self.dn() as f32
    }
}
impl RawDn for u8 {
    #[inline(always)]
    fn dn(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn dn_f32(self) -> f32 {
        self as f32
    }
}
impl RawDn for u16 {
    #[inline(always)]
    fn dn(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn dn_f32(self) -> f32 {
        self as f32
    }
}
impl RawDn for f32 {
    const INTEGER: bool = false;
    #[inline(always)]
    fn dn(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn dn_f32(self) -> f32 {
        self
    }
}

/// A borrowed single-channel image: `width_px × height_px` samples, row `v` starting
/// at `data[v·stride]` (stride in samples, ≥ width).
///
/// ```
/// use bpins_core::internal::heading::field::RawImage;
/// // A camera driver's buffer: 8 × 4 px of 16-bit DN in rows padded to 12 samples.
/// let buffer = vec![0u16; 12 * 4];
/// let img = RawImage { data: &buffer, width_px: 8, height_px: 4, stride: 12 };
/// assert!(img.is_consistent());
/// // The last row needs only its width: 3·12 + 8 samples are enough.
/// assert!(RawImage { data: &buffer[..44], ..img }.is_consistent());
/// assert!(!RawImage { data: &buffer[..43], ..img }.is_consistent());
/// // A packed buffer of f32 DN:
/// let f = vec![0.0f32; 8 * 4];
/// assert!(RawImage::packed(&f, 8, 4).is_consistent());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct RawImage<'a, T> {
    pub data: &'a [T],
    pub width_px: usize,
    pub height_px: usize,
    pub stride: usize,
}

impl<'a, T> RawImage<'a, T> {
    /// A tightly packed row-major image (stride = width).
    pub fn packed(data: &'a [T], width_px: usize, height_px: usize) -> Self {
        RawImage { data, width_px, height_px, stride: width_px }
    }

    /// Whether the buffer holds every row the size and stride promise.
    pub fn is_consistent(&self) -> bool {
        self.stride >= self.width_px
            && (self.height_px == 0 || self.data.len() >= (self.height_px - 1) * self.stride + self.width_px)
    }

    #[inline(always)]
    fn row(&self, v: usize) -> &'a [T] {
        &self.data[v * self.stride..][..self.width_px]
    }
}

/// One usable cell: its centre, mean Stokes vector and that mean's noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Centre, pixels (image frame).
    pub x_px: f64,
    pub y_px: f64,
    /// Mean (I, Q, U) above black, DN, image frame.
    pub stokes: Stokes,
    /// Variance of the mean Q and of the mean U, DN².
    pub var_q_dn2: f64,
    pub var_u_dn2: f64,
    /// Position in the cell grid.
    pub col: u32,
    pub row: u32,
}

/// The usable cells of one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cells {
    pub cell_px: usize,
    /// Grid size (cells across, down), usable or not.
    pub cols: usize,
    pub rows: usize,
    pub cells: Vec<Cell>,
    /// Per grid cell (row-major), a colour sensor's band ratio ln(I_R/I_B) of the
    /// cell (NaN where either band has no cell): the colour cloud test's signal
    /// (`clouds.rs`, white clouds in a blue sky). Empty for a monochrome sensor; set by
    /// the colour compass once every band's cells are filled ([`Cells::tint_of`]).
    pub tint: Vec<f64>,
}

impl Cells {
    /// The cell size for a `width × height` image: even, about 1/64 of the shorter
    /// side (so the estimator's cost does not grow with the sensor), at least 4: a
    /// cell of 2 holds one pixel of each DoFP channel, so neither its gradient (the
    /// move to the cell's centre, module doc) nor its scatter (the noise) can be read
    /// from it (measured: a 128 × 128 frame of 27.6 µm pixels behind an 8 mm lens read
    /// on cells of 2 px was 0.07–0.13° off at up to 10σ; on cells of 4 px, ≤ 0.017°).
    pub fn default_cell_px(width_px: usize, height_px: usize) -> usize {
        let c = (width_px.min(height_px) as f64 / 64.0).round() as usize;
        (c.max(4) + 1) & !1
    }

    /// Grid cells in all, usable or not.
    pub fn grid_len(&self) -> usize {
        self.cols * self.rows
    }

    /// Cells of a DoFP mosaic (`cell_px` even).
    pub fn from_mosaic<T: RawDn>(
        img: &RawImage<T>,
        mosaic: &[[Channel; 2]; 2],
        rec: &Reconstructor,
        full_scale_dn: f64,
        cell_px: usize,
    ) -> Cells {
        let mut cells = Cells::default();
        cells.fill_from_mosaic(img, mosaic, rec, full_scale_dn, cell_px, &mut CellScratch::default());
        cells
    }

    /// As [`Cells::from_mosaic`], into `self`, reusing its buffers and `scratch`'s:
    /// once they have grown to the frame's grid, nothing is allocated (a live loop).
    pub fn fill_from_mosaic<T: RawDn>(
        &mut self,
        img: &RawImage<T>,
        mosaic: &[[Channel; 2]; 2],
        rec: &Reconstructor,
        full_scale_dn: f64,
        cell_px: usize,
        scratch: &mut CellScratch,
    ) {
        self.fill_mosaic(img, mosaic, CellRecon::Frame(rec), full_scale_dn, cell_px, scratch)
    }

    /// As [`Cells::fill_from_mosaic`], each cell reconstructed through its own
    /// analyzers (a per-pixel calibration, [`crate::pixel_analyzers`]); the grid is
    /// `cal`'s (its cell size, over the frame `cal` was built for).
    pub fn fill_from_mosaic_calibrated<T: RawDn>(
        &mut self,
        img: &RawImage<T>,
        mosaic: &[[Channel; 2]; 2],
        cal: &CellAnalyzers,
        full_scale_dn: f64,
        scratch: &mut CellScratch,
    ) {
        self.fill_mosaic(img, mosaic, CellRecon::PerCell(cal), full_scale_dn, cal.cell_px, scratch)
    }

    fn fill_mosaic<T: RawDn>(
        &mut self,
        img: &RawImage<T>,
        mosaic: &[[Channel; 2]; 2],
        rec: CellRecon,
        full_scale_dn: f64,
        cell_px: usize,
        scratch: &mut CellScratch,
    ) {
        let cell_px = (cell_px.max(2) + 1) & !1;
        let chan = [0, 1].map(|dv| [0, 1].map(|du| Layout::dofp_channel(mosaic, du, dv).index()));
        // Each channel's place (column, row) in the 2 × 2 tile.
        let mut place = [None; 4];
        for (dv, row) in chan.iter().enumerate() {
            for (du, &k) in row.iter().enumerate() {
                place[k] = Some((du as f64, dv as f64));
            }
        }
        self.build(img.width_px, img.height_px, cell_px, rec, Finish::Mosaic(place), scratch, |cj, acc| {
            for (dv, v) in (cj * cell_px..(cj + 1) * cell_px).enumerate() {
                let row = img.row(v);
                let ch = chan[v & 1];
                for (ci, a) in acc.iter_mut().enumerate() {
                    let u0 = ci * cell_px;
                    a.add_row(ch, dv as f64, &row[u0..u0 + cell_px], full_scale_dn);
                }
            }
        })
    }

    /// Cells of a colocated frame: one plane per channel (each `width × height`).
    pub fn from_colocated<T: RawDn>(
        planes: &[(Channel, RawImage<T>)],
        rec: &Reconstructor,
        full_scale_dn: f64,
        cell_px: usize,
    ) -> Cells {
        let Some((_, first)) = planes.first() else { return Cells::default() };
        let cell_px = cell_px.max(1);
        let mut cells = Cells::default();
        cells.build(
            first.width_px,
            first.height_px,
            cell_px,
            CellRecon::Frame(rec),
            Finish::Colocated,
            &mut CellScratch::default(),
            |cj, acc| {
                for (ch, plane) in planes {
                    for (dv, v) in (cj * cell_px..(cj + 1) * cell_px).enumerate() {
                        let row = plane.row(v);
                        for (ci, a) in acc.iter_mut().enumerate() {
                            for (du, &x) in row[ci * cell_px..(ci + 1) * cell_px].iter().enumerate() {
                                a.add(ch.index(), du as f64, dv as f64, x.dn(), full_scale_dn);
                            }
                        }
                    }
                }
            },
        );
        cells
    }

    /// Cells of an already reconstructed Stokes image: `cell_px` is in pixels and
    /// rounded to a whole number of samples. A demosaiced image (every sample at its
    /// own ray) gives what the mosaic does; a superpixel image keeps the superpixels'
    /// bias (their four rays differ), which on a fisheye reaches a tenth of a degree.
    pub fn from_pol_image(img: &PolImage, cell_px: usize) -> Cells {
        let k = ((cell_px as f64 / img.step_px).round() as usize).max(1);
        let (cols, rows) = (img.width / k, img.height / k);
        let cells = (0..rows)
            .into_par_iter()
            .flat_map_iter(|cj| {
                (0..cols).filter_map(move |ci| {
                    let (mut n, mut bad) = (0.0, 0.0);
                    let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
                    for j in cj * k..(cj + 1) * k {
                        for i in ci * k..(ci + 1) * k {
                            match img.stokes(i, j) {
                                Some(x) => {
                                    n += 1.0;
                                    for (c, v) in [x.i, x.q, x.u].into_iter().enumerate() {
                                        s[c] += v;
                                        s2[c] += v * v;
                                    }
                                }
                                None => bad += 1.0,
                            }
                        }
                    }
                    if n < 2.0 || bad > MAX_INVALID_FRACTION * (n + bad) {
                        return None;
                    }
                    let var = |c: usize| ((s2[c] - s[c] * s[c] / n) / (n - 1.0)).max(0.0) / n;
                    let (x0, y0) = img.position_px(ci * k, cj * k);
                    let half = 0.5 * (k - 1) as f64 * img.step_px;
                    Some(Cell {
                        x_px: x0 + half,
                        y_px: y0 + half,
                        stokes: Stokes::new(s[0] / n, s[1] / n, s[2] / n, 0.0),
                        var_q_dn2: var(1),
                        var_u_dn2: var(2),
                        col: ci as u32,
                        row: cj as u32,
                    })
                })
            })
            .collect();
        Cells { cell_px: (k as f64 * img.step_px).round() as usize, cols, rows, cells, tint: Vec::new() }
    }

    /// The grid of whole cells into `self`; `fill(cell_row, accumulators)` adds the
    /// pixels of one row of cells; `finish`: how each channel's value is moved to the
    /// cell centre (each DoFP channel's place in the tile, or a colour band's geometry). Rows of cells in parallel,
    /// kept in row order; `scratch`'s buffers are reused (no allocation once grown).
    #[allow(clippy::too_many_arguments)]
    fn build(
        &mut self,
        width_px: usize,
        height_px: usize,
        cell_px: usize,
        rec: CellRecon,
        finish: Finish<'_>,
        scratch: &mut CellScratch,
        fill: impl Fn(usize, &mut [Acc]) + Sync,
    ) {
        let (cols, rows) = (width_px / cell_px, height_px / cell_px);
        if let CellRecon::PerCell(cal) = rec {
            // A grid other than the calibration's has no rows: no cells (the front
            // door checks the sizes before it gets here).
            if (cal.cols, cal.rows, cal.cell_px) != (cols, rows, cell_px) {
                self.cells.clear();
                (self.cell_px, self.cols, self.rows) = (cell_px, cols, rows);
                return;
            }
        }
        let CellScratch { acc, slots } = scratch;
        acc.clear();
        acc.resize(cols * rows, Acc::default());
        slots.clear();
        slots.resize(cols * rows, None);
        if cols > 0 {
            acc.par_chunks_mut(cols).zip(slots.par_chunks_mut(cols)).enumerate().for_each(|(cj, (acc, slots))| {
                fill(cj, acc);
                for (ci, (a, slot)) in acc.iter().zip(slots.iter_mut()).enumerate() {
                    let done = match finish {
                        Finish::Colocated => a.finish(cell_px, None),
                        Finish::Mosaic(place) => a.finish(cell_px, Some(place)),
                        Finish::Band(g) => a.finish_band(g),
                    };
                    let Some((mean, mut var)) = done else { continue };
                    let (stokes, r, inv_gain) = match rec {
                        CellRecon::Frame(rec) => {
                            let (r, inv_gain, _) = rec.parts();
                            (rec.stokes(&mean), r, inv_gain)
                        }
                        CellRecon::PerCell(cal) => {
                            let c = &cal.cells[cj * cols + ci];
                            if !c.ok {
                                continue;
                            }
                            let x: [f64; 4] = std::array::from_fn(|k| mean[k] - c.offset_dn[k]);
                            let dot = |row: &[f64; 4]| (0..4).map(|k| row[k] * x[k]).sum::<f64>();
                            let s = Stokes::new(dot(&c.rows[0]), dot(&c.rows[1]), dot(&c.rows[2]), 0.0);
                            if a.bad == 0.0 && matches!(finish, Finish::Mosaic(_) | Finish::Band(_)) {
                                remove_fixed_pattern(&mut var, &a.n, &c.pattern, &s);
                            }
                            (s, c.rows, [1.0; 4])
                        }
                    };
                    let v = |row: &[f64; 4]| (0..4).map(|k| (row[k] * inv_gain[k]).powi(2) * var[k]).sum::<f64>();
                    let c = (cell_px - 1) as f64 * 0.5;
                    *slot = Some(Cell {
                        x_px: (ci * cell_px) as f64 + c,
                        y_px: (cj * cell_px) as f64 + c,
                        stokes,
                        var_q_dn2: v(&r[1]),
                        var_u_dn2: v(&r[2]),
                        col: ci as u32,
                        row: cj as u32,
                    });
                }
            });
        }
        self.cells.clear();
        self.cells.extend(slots.iter().flatten());
        self.tint.clear();
        (self.cell_px, self.cols, self.rows) = (cell_px, cols, rows);
    }

    /// Into `out`: the band ratio of a colour frame's red and blue cells (same frame
    /// and grid) for [`Cells::tint`]: ln(I_R/I_B) per grid cell, NaN where either has
    /// no cell or a radiance at or below zero (DN above black), empty when the grids
    /// differ. Keeps its buffer between frames.
    pub fn tint_of(red: &Cells, blue: &Cells, out: &mut Vec<f64>) {
        out.clear();
        if (red.cols, red.rows) != (blue.cols, blue.rows) {
            return;
        }
        out.resize(red.grid_len(), f64::NAN);
        // Both lists are in grid order (row-major): a merge join.
        let cols = red.cols;
        let key = |c: &Cell| c.row as usize * cols + c.col as usize;
        let mut blue_cells = blue.cells.iter().peekable();
        for r in &red.cells {
            let k = key(r);
            while blue_cells.peek().is_some_and(|b| key(b) < k) {
                blue_cells.next();
            }
            if let Some(b) = blue_cells.peek().filter(|b| key(b) == k) {
                if r.stokes.i > 0.0 && b.stokes.i > 0.0 {
                    out[k] = (r.stokes.i / b.stokes.i).ln();
                }
            }
        }
    }
}

/// How a cell's channel means are moved to its centre: by each DoFP channel's place in
/// the 2 × 2 tile (every tile of the cell read), or by a colour band's own pixels'
/// geometry (`cells_band.rs`).
#[derive(Clone, Copy)]
enum Finish<'a> {
    /// Every channel at every pixel: plain means.
    Colocated,
    Mosaic([Option<(f64, f64)>; 4]),
    Band(&'a BandGeom),
}

/// How a cell's channel values become Stokes: one reconstructor for the frame, or
/// one per cell (a per-pixel calibration).
#[derive(Clone, Copy)]
enum CellRecon<'a> {
    Frame(&'a Reconstructor),
    PerCell(&'a CellAnalyzers),
}

/// Takes the calibrated fixed pattern out of each channel's scatter (variance of its
/// centre value, `var`): the pattern adds `[S, 1]ᵀ M_k [S, 1]` to the sum of squares
/// about the plane (`n_k − 3` degrees of freedom). What is left keeps at least a
/// tenth of the measured variance (a cell never claims to be noise-free).
fn remove_fixed_pattern(var: &mut [f64; 4], n: &[f64; 4], pattern: &[[f64; 10]; 4], s: &Stokes) {
    let z = [s.i, s.q, s.u, 1.0];
    for k in 0..4 {
        let dof = n[k] - 3.0;
        if dof <= 0.0 || !var[k].is_finite() {
            continue;
        }
        let m = &pattern[k];
        let mut q = 0.0;
        let mut t = 0;
        for x in 0..4 {
            for y in x..4 {
                q += if x == y { 1.0 } else { 2.0 } * m[t] * z[x] * z[y];
                t += 1;
            }
        }
        var[k] = (var[k] - q / (dof * n[k])).max(0.1 * var[k]);
    }
}

/// Buffers of [`Cells::fill_from_mosaic`], kept between frames.
#[derive(Clone, Debug, Default)]
pub struct CellScratch {
    acc: Vec<Acc>,
    slots: Vec<Option<Cell>>,
}

/// Per-channel sums of one cell (positions local to the cell's top-left pixel).
#[derive(Clone, Copy, Debug, Default)]
struct Acc {
    n: [f64; 4],
    s: [f64; 4],
    s2: [f64; 4],
    su: [f64; 4],
    sv: [f64; 4],
    bad: f64,
}

impl Acc {
    /// Adds one DoFP row segment of a cell (even length, starting on an even column):
    /// channels `ch[0]` and `ch[1]` alternate. Branch-free sums, then one update per channel.
    #[inline(always)]
    fn add_row<T: RawDn>(&mut self, ch: [usize; 2], dv: f64, row: &[T], full_scale_dn: f64) {
        let (mut n, mut s, mut s2, mut su) = ([0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2]);
        for (i, pair) in row.chunks_exact(2).enumerate() {
            for k in 0..2 {
                let x = pair[k].dn();
                let ok = if dn_is_valid(x, full_scale_dn) { 1.0 } else { 0.0 };
                let xv = x * ok;
                n[k] += ok;
                s[k] += xv;
                s2[k] += xv * x;
                su[k] += (2 * i + k) as f64 * xv;
            }
        }
        for k in 0..2 {
            let c = ch[k];
            self.n[c] += n[k];
            self.s[c] += s[k];
            self.s2[c] += s2[k];
            self.su[c] += su[k];
            self.sv[c] += dv * s[k];
        }
        self.bad += row.len() as f64 - n[0] - n[1];
    }

    #[inline(always)]
    fn add(&mut self, ch: usize, du: f64, dv: f64, dn: f64, full_scale_dn: f64) {
        if dn_is_valid(dn, full_scale_dn) {
            self.n[ch] += 1.0;
            self.s[ch] += dn;
            self.s2[ch] += dn * dn;
            self.su[ch] += du * dn;
            self.sv[ch] += dv * dn;
        } else {
            self.bad += 1.0;
        }
    }

    /// Each channel's DN at the cell centre and the variance of that value (channels
    /// without pixels: 0); `None` where the cell is not usable. `place`: as `build`.
    fn finish(&self, cell_px: usize, place: Option<[Option<(f64, f64)>; 4]>) -> Option<([f64; 4], [f64; 4])> {
        let total: f64 = self.n.iter().sum();
        if total == 0.0 || self.bad > MAX_INVALID_FRACTION * (total + self.bad) {
            return None;
        }
        let b = cell_px as f64;
        let (mut mean, mut var) = ([0.0; 4], [0.0; 4]);
        for k in 0..4 {
            let n = self.n[k];
            if n == 0.0 {
                continue;
            }
            let m = self.s[k] / n;
            let mut ss = self.s2[k] - self.s[k] * m; // Σ (DN − mean)²
            let mut dof = n - 1.0;
            mean[k] = m;
            // A whole DoFP cell: the channel's (b/2)² pixels on a grid of pitch 2.
            if let (Some(Some((p, q))), 0.0) = (place.map(|pl| pl[k]), self.bad) {
                let h = 0.5 * b; // pixels per row of the channel
                let (ubar, vbar) = (p + h - 1.0, q + h - 1.0);
                let sxx = h * h * (h * h - 1.0) / 3.0; // Σ (u − ū)² over the channel's pixels
                if sxx > 0.0 {
                    let gx = (self.su[k] - ubar * self.s[k]) / sxx;
                    let gy = (self.sv[k] - vbar * self.s[k]) / sxx;
                    mean[k] = m + gx * (0.5 - p) + gy * (0.5 - q);
                    ss -= (gx * gx + gy * gy) * sxx;
                    dof -= 2.0;
                }
            }
            // Variance of the centre value ≈ that of the mean. The gradient terms add
            // ½/sxx of a pixel's variance: ×1.5 the mean's on 4 px cells (2 × 2 pixels per
            // channel), ×1.1 on 8 px, under 3 % from 16 px. Not counted here (counting it
            // moves day frames' robust fit: a flipped mosaic in tests/contradictions.rs
            // is then believed); dim frames count it (coarse.rs, `noise_factor`).
            var[k] = if dof > 0.0 { (ss / dof).max(0.0) / n } else { f64::NAN };
        }
        self.borrow_scatter(&mut var);
        Some((mean, var))
    }

    /// A channel too small to measure its scatter (`var` NaN) borrows the largest
    /// per-pixel variance of the others.
    fn borrow_scatter(&self, var: &mut [f64; 4]) {
        let per_px = (0..4).filter(|&k| var[k].is_finite()).map(|k| var[k] * self.n[k]).fold(0.0, f64::max);
        for (v, n) in var.iter_mut().zip(self.n) {
            if v.is_nan() {
                *v = per_px / n;
            }
        }
    }
}

#[path = "cells_band.rs"]
mod band;
use band::BandGeom;

#[cfg(test)]
#[path = "cells_tests.rs"]
mod tests;
