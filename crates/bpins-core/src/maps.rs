//! Polarization maps of a raw DoFP mosaic: AoP, DoLP, intensity and AoE at every
//! pixel (or every 2 × 2 superpixel), written into buffers the caller owns, so a loop
//! over frames allocates nothing per frame. The one kernel behind Python's
//! `bpins.stokes_maps`, `bpins maps` and the C ABI's `bpins_stokes_maps`.
//!
//! ```text
//! d_k(u, v)  channel k's DN at (u, v), interpolated on its sub-lattice (below)
//! x_k = (d_k − black − offset_k) / (1 + gain_k)            (Reconstructor)
//! (I, Q, U) = R · x   (4 channels: I = ½Σx_k, Q = x_0 − x_90, U = x_45 − x_135)   seed eq. 4, 13
//! AoP α = ½ atan2(U, Q) ∈ (−90°, 90°],  DoLP = √(Q² + U²)/I,  AoE = α − β          seed eq. 5–6
//! β = atan2(−(v − c_y), u − c_x), about the given centre                           CONVENTIONS.md
//! ```
//!
//! Frame: image pixels, angles counter-clockwise as displayed (CONVENTIONS.md);
//! intensity in DN above the black level. Three interpolations ([`Interpolation`]):
//!
//! - **bilinear** (the default, the same numbers as [`crate::recon::demosaic`]):
//!   each channel interpolated on its own lattice, every sample at its own pixel,
//!   the lattice clamped at the edges (an edge pixel takes its nearest row or column
//!   of the channel). A pixel is NaN where a sample with a non-zero weight is
//!   invalid: zero, at or above `full_scale_dn` (saturated), or not finite.
//! - **superpixel**: each 2 × 2 tile one value at the tile centre, half the
//!   resolution in each direction, no interpolation (the four samples see four
//!   slightly different rays, which biases AoP by hundredths of a degree where the
//!   pattern has a gradient).
//! - **opencv**: polanalyser's `demosaicing` (OpenCV's `cvtColor` Bayer bilinear,
//!   `COLOR_BayerBG2BGR` and `COLOR_BayerGR2BGR`) reproduced exactly for `uint8` and
//!   `uint16` mosaics: the same interior weights as bilinear, each average rounded
//!   half up to a whole DN (`(a + b + 1) >> 1`, `(a + b + c + d + 2) >> 2`), and the
//!   one-pixel border copied from the next row or column inwards. No pixel is masked.
//!   (polanalyser rescales a float mosaic to `uint16` first; that route is not
//!   reproduced: float samples are averaged without rounding.)
//!
//! Rows run in parallel (rayon), each through a few row-long passes that the compiler
//! vectorizes: the two vertical interpolations of the mosaic's row parities, the four
//! channels' horizontal ones, then the per-pixel Stokes and angles (branch-free
//! `atan2`, `math.rs`). Cannot do: colour-polarization mosaics (2 × 2 colour blocks of
//! 2 × 2 analyzers), per-pixel calibration maps (see `pixel_analyzers`).

use crate::heading::field::{RawDn, RawImage};
use crate::math::{atan2, wrap_deg_90_near};
use crate::recon::Reconstructor;
use crate::sensor::Channel;
use rayon::prelude::*;

/// How each channel's DN is found at a pixel (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Interpolation {
    #[default]
    Bilinear,
    Superpixel,
    OpenCv,
}

impl Interpolation {
    pub const ALL: [Interpolation; 3] = [Interpolation::Bilinear, Interpolation::Superpixel, Interpolation::OpenCv];

    /// The name on the command line, in Python and in C.
    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Bilinear => "bilinear",
            Interpolation::Superpixel => "superpixel",
            Interpolation::OpenCv => "opencv",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == name)
    }

    /// The maps' size for a `w × h` mosaic: the same, or half for superpixels.
    pub fn maps_size(self, w: usize, h: usize) -> (usize, usize) {
        match self {
            Interpolation::Superpixel => (w / 2, h / 2),
            _ => (w, h),
        }
    }
}

/// What the maps are made with, beside the reconstruction.
#[derive(Clone, Debug, PartialEq)]
pub struct MapsConfig {
    pub interpolation: Interpolation,
    /// The 2 × 2 analyzer layout, row-major from the top-left pixel.
    pub mosaic: [[Channel; 2]; 2],
    /// Samples at or above this are saturated (bilinear, superpixel); `f64::INFINITY`
    /// checks nothing but zero and non-finite samples.
    pub full_scale_dn: f64,
    /// The centre about which AoE's β is measured, px (usually the principal point).
    pub aoe_centre_px: [f64; 2],
}

/// The caller's output buffers, each `maps_size` long (row-major, packed).
pub struct MapsOut<'a> {
    pub aop_deg: &'a mut [f32],
    pub dolp: &'a mut [f32],
    pub intensity_dn: &'a mut [f32],
    /// The angle of E-vector, if wanted.
    pub aoe_deg: Option<&'a mut [f32]>,
}

/// Maps owned by the caller that does not keep its own buffers.
#[derive(Clone, Debug, PartialEq)]
pub struct Maps {
    pub width_px: usize,
    pub height_px: usize,
    pub aop_deg: Vec<f32>,
    pub dolp: Vec<f32>,
    pub intensity_dn: Vec<f32>,
    pub aoe_deg: Vec<f32>,
}

/// Why no maps were made: sizes, never a panic.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MapsError {
    #[error(
        "mosaic of {width_px} × {height_px} px with row stride {stride} in a buffer of {len} samples: \
         the buffer must hold (height − 1) × stride + width samples and stride ≥ width"
    )]
    Buffer { width_px: usize, height_px: usize, stride: usize, len: usize },
    #[error("mosaic of {width_px} × {height_px} px: {interpolation} maps need at least {min} × {min} px")]
    TooSmall { width_px: usize, height_px: usize, interpolation: &'static str, min: usize },
    #[error("output `{name}` holds {got} values; {want} needed ({width_px} × {height_px} maps)")]
    Output { name: &'static str, got: usize, want: usize, width_px: usize, height_px: usize },
}

/// One channel's lattice: its column and row offsets in the 2 × 2 mosaic.
fn lattices(mosaic: &[[Channel; 2]; 2]) -> [Option<(usize, usize)>; 4] {
    let mut at = [None; 4];
    for (dv, row) in mosaic.iter().enumerate() {
        for (du, c) in row.iter().enumerate() {
            at[c.index()] = Some((du, dv));
        }
    }
    at
}

/// A sample as the maps read it: NaN where it is invalid (bilinear, superpixel).
#[inline(always)]
fn checked(x: f64, full_scale_dn: f64) -> f64 {
    if x > 0.0 && x < full_scale_dn {
        x
    } else {
        f64::NAN
    }
}

/// Fills `out` with the maps of `raw` through `rec` (module docs).
pub fn stokes_maps_into<T: RawDn>(
    raw: &RawImage<T>,
    rec: &Reconstructor,
    cfg: &MapsConfig,
    out: MapsOut,
) -> Result<(), MapsError> {
    let (w, h) = (raw.width_px, raw.height_px);
    if !raw.is_consistent() {
        return Err(MapsError::Buffer { width_px: w, height_px: h, stride: raw.stride, len: raw.data.len() });
    }
    let min = if cfg.interpolation == Interpolation::OpenCv { 3 } else { 2 };
    if w < min || h < min {
        return Err(MapsError::TooSmall { width_px: w, height_px: h, interpolation: cfg.interpolation.name(), min });
    }
    let (mw, mh) = cfg.interpolation.maps_size(w, h);
    let n = mw * mh;
    let check = |name: &'static str, got: usize| {
        if got == n {
            Ok(())
        } else {
            Err(MapsError::Output { name, got, want: n, width_px: mw, height_px: mh })
        }
    };
    check("aop_deg", out.aop_deg.len())?;
    check("dolp", out.dolp.len())?;
    check("intensity_dn", out.intensity_dn.len())?;
    if let Some(a) = &out.aoe_deg {
        check("aoe_deg", a.len())?;
    }
    let (rows, inv_gain, offset_dn) = rec.parts();
    let px = PixelMap { rows, inv_gain, offset_dn, centre: cfg.aoe_centre_px, superpixel: mw < w };
    let lat = lattices(&cfg.mosaic);
    // Each row of the maps with its own scratch rows (one set per rayon job).
    let row =
        |s: &mut Scratch, v: usize, aop: &mut [f32], dolp: &mut [f32], int: &mut [f32], aoe: Option<&mut [f32]>| {
            match cfg.interpolation {
                Interpolation::Bilinear => s.bilinear_row(raw, v, &lat, cfg.full_scale_dn),
                Interpolation::Superpixel => s.superpixel_row(raw, v, &lat, cfg.full_scale_dn),
                Interpolation::OpenCv => s.opencv_row(raw, v, &lat),
            }
            px.row(&s.ch, v, aop, dolp, int, aoe);
        };
    let rows = out.aop_deg.par_chunks_mut(mw).zip(out.dolp.par_chunks_mut(mw)).zip(out.intensity_dn.par_chunks_mut(mw));
    match out.aoe_deg {
        Some(aoe) => rows.zip(aoe.par_chunks_mut(mw)).enumerate().for_each_init(
            || Scratch::new(w),
            |s, (v, (((aop, dolp), int), aoe))| row(s, v, aop, dolp, int, Some(aoe)),
        ),
        None => rows
            .enumerate()
            .for_each_init(|| Scratch::new(w), |s, (v, ((aop, dolp), int))| row(s, v, aop, dolp, int, None)),
    }
    Ok(())
}

/// [`stokes_maps_into`] into new buffers (AoE included).
pub fn stokes_maps<T: RawDn>(raw: &RawImage<T>, rec: &Reconstructor, cfg: &MapsConfig) -> Result<Maps, MapsError> {
    let (mw, mh) = cfg.interpolation.maps_size(raw.width_px, raw.height_px);
    let n = mw * mh;
    let mut m = Maps {
        width_px: mw,
        height_px: mh,
        aop_deg: vec![0.0; n],
        dolp: vec![0.0; n],
        intensity_dn: vec![0.0; n],
        aoe_deg: vec![0.0; n],
    };
    let out = MapsOut {
        aop_deg: &mut m.aop_deg,
        dolp: &mut m.dolp,
        intensity_dn: &mut m.intensity_dn,
        aoe_deg: Some(&mut m.aoe_deg),
    };
    stokes_maps_into(raw, rec, cfg, out)?;
    Ok(m)
}

/// One job's rows: the two row parities' vertical interpolations and the four
/// channels' DN along the output row.
struct Scratch {
    vert: [Vec<f64>; 2],
    ch: [Vec<f64>; 4],
}

impl Scratch {
    fn new(w: usize) -> Self {
        Scratch { vert: [vec![0.0; w], vec![0.0; w]], ch: std::array::from_fn(|_| vec![0.0; w]) }
    }

    /// Step 1 (bilinear): rows of parity p interpolated to row v, the lattice clamped.
    /// Step 2: each channel along its columns, clamped likewise.
    fn bilinear_row<T: RawDn>(&mut self, raw: &RawImage<T>, v: usize, lat: &[Option<(usize, usize)>; 4], fs: f64) {
        let (w, h) = (raw.width_px, raw.height_px);
        let row = |r: usize| &raw.data[r * raw.stride..][..w];
        for p in 0..2 {
            let last = (h - p - 1) / 2;
            let b = ((v as f64 - p as f64) * 0.5).clamp(0.0, last as f64);
            let n0 = b.floor() as usize;
            let out = &mut self.vert[p];
            let r0 = row(p + 2 * n0);
            if b == n0 as f64 {
                for (o, &x) in out.iter_mut().zip(r0) {
                    *o = checked(x.dn(), fs);
                }
            } else {
                let r1 = row(p + 2 * n0 + 2);
                for ((o, &a), &c) in out.iter_mut().zip(r0).zip(r1) {
                    *o = 0.5 * (checked(a.dn(), fs) + checked(c.dn(), fs));
                }
            }
        }
        for (k, at) in lat.iter().enumerate() {
            let Some((ou, ov)) = *at else { continue };
            horizontal(&self.vert[ov], ou, &mut self.ch[k]);
        }
    }

    /// A tile's four samples, each channel from its own position in the tile.
    fn superpixel_row<T: RawDn>(&mut self, raw: &RawImage<T>, v: usize, lat: &[Option<(usize, usize)>; 4], fs: f64) {
        let mw = raw.width_px / 2;
        for (k, at) in lat.iter().enumerate() {
            let Some((ou, ov)) = *at else { continue };
            let r = &raw.data[(2 * v + ov) * raw.stride..][..raw.width_px];
            for (m, o) in self.ch[k][..mw].iter_mut().enumerate() {
                *o = checked(r[2 * m + ou].dn(), fs);
            }
        }
    }

    /// OpenCV's Bayer bilinear: interior averages rounded half up for integer samples,
    /// the border row or column a copy of the next one inwards.
    fn opencv_row<T: RawDn>(&mut self, raw: &RawImage<T>, v: usize, lat: &[Option<(usize, usize)>; 4]) {
        let (w, h) = (raw.width_px, raw.height_px);
        let vs = v.clamp(1, h - 2);
        let row = |r: usize| &raw.data[r * raw.stride..][..w];
        let (up, mid, down) = (row(vs - 1), row(vs), row(vs + 1));
        let half = |s: f64| if T::INTEGER { ((s + 1.0) * 0.5).floor() } else { s * 0.5 };
        let quarter = |s: f64| if T::INTEGER { ((s + 2.0) * 0.25).floor() } else { s * 0.25 };
        for (k, at) in lat.iter().enumerate() {
            let Some((ou, ov)) = *at else { continue };
            let on_row = (vs + ov) % 2 == 0;
            let out = &mut self.ch[k];
            for us in 1..w - 1 {
                let on_col = (us + ou) % 2 == 0;
                out[us] = match (on_col, on_row) {
                    (true, true) => mid[us].dn(),
                    (false, true) => half(mid[us - 1].dn() + mid[us + 1].dn()),
                    (true, false) => half(up[us].dn() + down[us].dn()),
                    (false, false) => {
                        quarter(up[us - 1].dn() + up[us + 1].dn() + down[us - 1].dn() + down[us + 1].dn())
                    }
                };
            }
            out[0] = out[1];
            out[w - 1] = out[w - 2];
        }
    }
}

/// Step 2 (bilinear): `src` (a row of one parity, every column) sampled on the channel's
/// columns `ou, ou + 2, …` and interpolated between them; before the first and after
/// the last the nearest is taken.
fn horizontal(src: &[f64], ou: usize, out: &mut [f64]) {
    let w = src.len();
    let last = ou + 2 * ((w - ou - 1) / 2);
    if ou == 1 {
        out[0] = src[1];
    }
    let mut u = ou;
    while u < last {
        out[u] = src[u];
        out[u + 1] = 0.5 * (src[u] + src[u + 2]);
        u += 2;
    }
    out[last] = src[last];
    if last + 1 < w {
        out[last + 1] = src[last];
    }
}

/// Step 3: the reconstruction's linear map and the angles, per pixel of a row.
struct PixelMap {
    rows: [[f64; 4]; 3],
    inv_gain: [f64; 4],
    offset_dn: [f64; 4],
    centre: [f64; 2],
    /// Superpixel maps: pixel (m, n) sits at the tile centre (2m + ½, 2n + ½).
    superpixel: bool,
}

impl PixelMap {
    fn row(
        &self,
        ch: &[Vec<f64>; 4],
        v: usize,
        aop: &mut [f32],
        dolp: &mut [f32],
        int: &mut [f32],
        aoe: Option<&mut [f32]>,
    ) {
        let used: [bool; 4] = std::array::from_fn(|k| (0..3).any(|i| self.rows[i][k] != 0.0));
        let x = |k: usize, u: usize| if used[k] { (ch[k][u] - self.offset_dn[k]) * self.inv_gain[k] } else { 0.0 };
        let (scale, shift) = if self.superpixel { (2.0, 0.5) } else { (1.0, 0.0) };
        let dy = v as f64 * scale + shift - self.centre[1];
        let mut aoe = aoe;
        for u in 0..aop.len() {
            let xs = [x(0, u), x(1, u), x(2, u), x(3, u)];
            let dot = |r: &[f64; 4]| r[0] * xs[0] + r[1] * xs[1] + r[2] * xs[2] + r[3] * xs[3];
            let (i, q, uu) = (dot(&self.rows[0]), dot(&self.rows[1]), dot(&self.rows[2]));
            let ok = (i + q + uu).is_finite();
            // α = ½ atan2(U, Q) in (−90°, 90°] (atan2's −180° of a signed zero is +180°).
            let a = 0.5 * atan2(uu, q).to_degrees();
            let a = if a <= -90.0 { a + 180.0 } else { a };
            let d = if i > 0.0 { (q * q + uu * uu).sqrt() / i } else { 0.0 };
            aop[u] = if ok { a as f32 } else { f32::NAN };
            dolp[u] = if ok { d as f32 } else { f32::NAN };
            int[u] = if ok { i as f32 } else { f32::NAN };
            if let Some(e) = aoe.as_deref_mut() {
                let dx = u as f64 * scale + shift - self.centre[0];
                let beta = atan2(-dy, dx).to_degrees();
                e[u] = if ok { wrap_deg_90_near(a - beta) as f32 } else { f32::NAN };
            }
        }
    }
}

#[cfg(test)]
#[path = "maps_tests.rs"]
mod tests;
