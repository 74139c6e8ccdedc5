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
//! intensity in DN above the black level. Four interpolations ([`Interpolation`]):
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
//! - **opencv_ea**: polanalyser's edge-aware `COLOR_PolarMono_EA` (OpenCV's
//!   `COLOR_Bayer**2BGR_EA`), exactly: on a mono mosaic the same maps as opencv, since
//!   the analyzers polanalyser keeps are the Bayer demosaic's blue and red, which the
//!   edge-aware one computes as the bilinear one does (`maps_ea.rs`); it differs on
//!   colour mosaics (`maps_colour`).
//!
//! Rows run in parallel (rayon), each through a few row-long passes that the compiler
//! vectorizes: the two vertical interpolations of the mosaic's row parities, the four
//! channels' horizontal ones, then the per-pixel Stokes and angles (branch-free
//! `atan2`, `math.rs`), in single precision (whole-DN sums and their halves are
//! exact there; the angles carry float32 rounding, as their output does). Colour-polarization
//! mosaics (2 × 2 colour blocks of 2 × 2 analyzers): `maps_colour`, through these
//! kernels. Cannot do: per-pixel calibration maps (see `pixel_analyzers`).

use crate::heading::field::{RawDn, RawImage};
use crate::math::atan2_f32;
use crate::recon::Reconstructor;
use crate::sensor::Channel;
use rayon::prelude::*;

#[path = "maps_colour.rs"]
pub mod colour;
pub use colour::{colour_maps, colour_maps_into, colour_maps_size, BandMaps, ColourScratch};

#[path = "maps_ea.rs"]
mod ea;

/// How each channel's DN is found at a pixel (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Interpolation {
    #[default]
    Bilinear,
    Superpixel,
    OpenCv,
    /// polanalyser's edge-aware demosaic (`COLOR_PolarMono_EA`, `COLOR_PolarRGB_EA`).
    OpenCvEa,
}

impl Interpolation {
    pub const ALL: [Interpolation; 4] =
        [Interpolation::Bilinear, Interpolation::Superpixel, Interpolation::OpenCv, Interpolation::OpenCvEa];

    /// The name on the command line, in Python and in C.
    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Bilinear => "bilinear",
            Interpolation::Superpixel => "superpixel",
            Interpolation::OpenCv => "opencv",
            Interpolation::OpenCvEa => "opencv_ea",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == name)
    }

    /// One of polanalyser's OpenCV routes: whole-DN rounding, OpenCV's border, no masking.
    pub(crate) fn is_opencv(self) -> bool {
        matches!(self, Interpolation::OpenCv | Interpolation::OpenCvEa)
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
    #[error(
        "band {band}: the {interpolation} colour route needs each band on one tile or on two diagonal tiles \
         of the 2 × 2 colour tiles (a Bayer arrangement); superpixel maps take any"
    )]
    NotBayer { band: &'static str, interpolation: &'static str },
    #[error("band {band}: none of the colour tiles carries it")]
    NoSuchBand { band: &'static str },
}

/// One channel's lattice: its column and row offsets in the 2 × 2 mosaic.
pub(crate) fn lattices(mosaic: &[[Channel; 2]; 2]) -> [Option<(usize, usize)>; 4] {
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
pub(crate) fn checked(x: f32, full_scale_dn: f32) -> f32 {
    if x > 0.0 && x < full_scale_dn {
        x
    } else {
        f32::NAN
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
    let min = if cfg.interpolation.is_opencv() { 3 } else { 2 };
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
    // Superpixel maps: pixel (m, n) sits at the tile centre (2m + ½, 2n + ½).
    let px = if mw < w { PixelMap::new(rec, cfg, 2.0, [0.5; 2]) } else { PixelMap::new(rec, cfg, 1.0, [0.0; 2]) };
    let fs = cfg.full_scale_dn as f32;
    let lat = lattices(&cfg.mosaic);
    // Each row of the maps with its own scratch rows (one set per rayon job).
    let row =
        |s: &mut Scratch, v: usize, aop: &mut [f32], dolp: &mut [f32], int: &mut [f32], aoe: Option<&mut [f32]>| {
            match cfg.interpolation {
                Interpolation::Bilinear => s.bilinear_row(raw, v, &lat, fs),
                Interpolation::Superpixel => s.superpixel_row(raw, v, &lat, fs),
                // Edge-aware on a mono mosaic: the same channels (maps_ea.rs).
                Interpolation::OpenCv | Interpolation::OpenCvEa => s.opencv_row(raw, v, &lat, T::INTEGER),
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
pub(crate) struct Scratch {
    vert: [Vec<f32>; 2],
    pub(crate) ch: [Vec<f32>; 4],
    /// `even[k]`: k is even; the row kernels' selects read it as a lane mask.
    even: Vec<bool>,
}

impl Scratch {
    pub(crate) fn new(w: usize) -> Self {
        Scratch {
            vert: [vec![0.0; w], vec![0.0; w]],
            ch: std::array::from_fn(|_| vec![0.0; w]),
            even: (0..w + 1).map(|k| k % 2 == 0).collect(),
        }
    }

    /// Step 1 (bilinear): rows of parity p interpolated to row v, the lattice clamped.
    /// Step 2: each channel along its columns, clamped likewise.
    fn bilinear_row<T: RawDn>(&mut self, raw: &RawImage<T>, v: usize, lat: &[Option<(usize, usize)>; 4], fs: f32) {
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
                    *o = checked(x.dn_f32(), fs);
                }
            } else {
                let r1 = row(p + 2 * n0 + 2);
                for ((o, &a), &c) in out.iter_mut().zip(r0).zip(r1) {
                    *o = 0.5 * (checked(a.dn_f32(), fs) + checked(c.dn_f32(), fs));
                }
            }
        }
        let mut done = [false; 4];
        for p in 0..2 {
            let Some([k0, k1]) = row_pair(lat, p) else { continue };
            let [a, b] = self.ch.get_disjoint_mut([k0, k1]).expect("two channels");
            let src = &self.vert[p][..w];
            // The interior as `horizontal` makes it, both channels in one pass.
            take_turns(src, &self.even[1..], &mut a[..w], &mut b[..w], |x| x, |l, r| 0.5 * (l + r));
            // Before the first and after the last of a channel's columns, the nearest.
            (a[0], b[0]) = (src[0], src[1]);
            a[w - 1] = if (w - 1) % 2 == 0 { src[w - 1] } else { src[w - 2] };
            b[w - 1] = if w % 2 == 0 { src[w - 1] } else { src[w - 2] };
            (done[k0], done[k1]) = (true, true);
        }
        for (k, at) in lat.iter().enumerate() {
            let Some((ou, ov)) = *at else { continue };
            if !done[k] {
                horizontal(&self.vert[ov], ou, &mut self.ch[k]);
            }
        }
    }

    /// A tile's four samples, each channel from its own position in the tile.
    fn superpixel_row<T: RawDn>(&mut self, raw: &RawImage<T>, v: usize, lat: &[Option<(usize, usize)>; 4], fs: f32) {
        let mw = raw.width_px / 2;
        for (k, at) in lat.iter().enumerate() {
            let Some((ou, ov)) = *at else { continue };
            let r = &raw.data[(2 * v + ov) * raw.stride..][..raw.width_px];
            for (m, o) in self.ch[k][..mw].iter_mut().enumerate() {
                *o = checked(r[2 * m + ou].dn_f32(), fs);
            }
        }
    }

    /// OpenCV's Bayer bilinear: interior averages rounded half up for integer samples,
    /// the border row or column a copy of the next one inwards. Step 1: for each row
    /// parity, the mosaic's row itself (a channel's own row) or the sum of the rows
    /// above and below; step 2: along the channel's columns, its own column or the
    /// pair of neighbours, each sum divided (and rounded, if `integer`) once, as OpenCV does.
    pub(crate) fn opencv_row<T: RawDn>(
        &mut self,
        raw: &RawImage<T>,
        v: usize,
        lat: &[Option<(usize, usize)>; 4],
        integer: bool,
    ) {
        let (w, h) = (raw.width_px, raw.height_px);
        let vs = v.clamp(1, h - 2);
        let row = |r: usize| &raw.data[r * raw.stride..][..w];
        self.opencv_rows(row(vs - 1), row(vs), row(vs + 1), vs, lat, integer);
    }

    /// [`Self::opencv_row`] from the rows `vs − 1`, `vs`, `vs + 1` of a mosaic (each
    /// its full width), `vs` the interior row the map row reads (its own index clamped
    /// to 1..h − 2).
    pub(crate) fn opencv_rows<T: RawDn>(
        &mut self,
        up: &[T],
        mid: &[T],
        down: &[T],
        vs: usize,
        lat: &[Option<(usize, usize)>; 4],
        integer: bool,
    ) {
        if integer {
            self.opencv_rows_with::<T, true>(up, mid, down, vs, lat)
        } else {
            self.opencv_rows_with::<T, false>(up, mid, down, vs, lat)
        }
    }

    #[inline(always)]
    fn opencv_rows_with<T: RawDn, const INT: bool>(
        &mut self,
        up: &[T],
        mid: &[T],
        down: &[T],
        vs: usize,
        lat: &[Option<(usize, usize)>; 4],
    ) {
        let w = mid.len();
        let (up, down) = (&up[..w], &down[..w]);
        let mut on_row = [false; 2];
        for p in 0..2 {
            on_row[p] = (vs + p) % 2 == 0;
            let out = &mut self.vert[p][..w];
            if on_row[p] {
                for (o, &x) in out.iter_mut().zip(mid) {
                    *o = x.dn_f32();
                }
            } else {
                for ((o, &a), &b) in out.iter_mut().zip(up).zip(down) {
                    *o = a.dn_f32() + b.dn_f32();
                }
            }
        }
        // The two channels of a row parity (columns ou = 0 and 1) share their
        // candidates, own column and neighbour pair, and take them in turns.
        let n = w - 2;
        let mut done = [false; 4];
        for p in 0..2 {
            let Some([k0, k1]) = row_pair(lat, p) else { continue };
            let [a, b] = self.ch.get_disjoint_mut([k0, k1]).expect("two channels");
            let (n_on, n_off) = if on_row[p] { (1.0, 2.0) } else { (2.0, 4.0) };
            let own = |x: f32| opencv_mean::<INT>(x, n_on);
            take_turns(&self.vert[p][..w], &self.even[1..], &mut a[..w], &mut b[..w], own, |l, r| {
                opencv_mean::<INT>(l + r, n_off)
            });
            for o in [a, b] {
                o[0] = o[1];
                o[w - 1] = o[w - 2];
            }
            (done[k0], done[k1]) = (true, true);
        }
        for (k, at) in lat.iter().enumerate() {
            let Some((ou, ov)) = *at else { continue };
            if done[k] {
                continue;
            }
            let (src, out) = (&self.vert[ov][..w], &mut self.ch[k][..w]);
            // A row sum holds two samples: its own column halves it, a pair quarters it.
            let (n_on, n_off) = if on_row[ov] { (1.0, 2.0) } else { (2.0, 4.0) };
            // Column us = k + 1 (k < w − 2) is the channel's own where us + ou is even,
            // i.e. `even[k + (1 + ou) % 2]`. Both candidates are computed at every
            // column and one selected by a mask read from memory, so that the loop
            // vectorizes without a branch or index arithmetic.
            let (l, c, r, o) = (&src[..n], &src[1..n + 1], &src[2..n + 2], &mut out[1..n + 1]);
            let own_here = &self.even[(1 + ou) % 2..][..n];
            for k in 0..n {
                let own = opencv_mean::<INT>(c[k], n_on);
                let pair = opencv_mean::<INT>(l[k] + r[k], n_off);
                o[k] = if own_here[k] { own } else { pair };
            }
            out[0] = out[1];
            out[w - 1] = out[w - 2];
        }
    }
}

/// The channels at columns ou = 0 and 1 of row parity `p`, if the mosaic has both.
fn row_pair(lat: &[Option<(usize, usize)>; 4], p: usize) -> Option<[usize; 2]> {
    let on = |ou: usize| (0..4).find(|&k| lat[k] == Some((ou, p)));
    Some([on(0)?, on(1)?])
}

/// The interior columns us (1..w − 1) of the two channels of one row parity, `a` at
/// columns ou = 0 and `b` at ou = 1: each takes `own(src[us])` on its own column and
/// `pair(src[us − 1], src[us + 1])` between two of them, so both share one pair of
/// candidates per column. `even_us[k]`: column k + 1 is even (`a`'s own). A select,
/// not a branch, so that the loop vectorizes; the border columns are the caller's.
#[inline(always)]
fn take_turns(
    src: &[f32],
    even_us: &[bool],
    a: &mut [f32],
    b: &mut [f32],
    own: impl Fn(f32) -> f32,
    pair: impl Fn(f32, f32) -> f32,
) {
    let n = src.len() - 2;
    let (l, c, r, even_us) = (&src[..n], &src[1..n + 1], &src[2..n + 2], &even_us[..n]);
    let (a, b) = (&mut a[1..n + 1], &mut b[1..n + 1]);
    for k in 0..n {
        let (x, y) = (own(c[k]), pair(l[k], r[k]));
        (a[k], b[k]) = if even_us[k] { (x, y) } else { (y, x) };
    }
}

/// OpenCV's mean of `n` whole-DN samples summing to `s`, rounded half up
/// (`(s + n/2) >> log2 n`), or the plain mean `s / n` when not `INT`. `n` is 1, 2 or 4:
/// a multiplication by the exact `1/n` rounds as the division does (both are the
/// correctly rounded `s / n`), and vectorizes cheaper. Whole-DN sums below 2^24 are
/// exact in f32, and so are their halves and quarters.
#[inline(always)]
pub(crate) fn opencv_mean<const INT: bool>(s: f32, n: f32) -> f32 {
    let inv = 1.0 / n;
    if INT {
        ((s + 0.5 * n) * inv).floor()
    } else {
        s * inv
    }
}

/// Step 2 (bilinear): `src` (a row of one parity, every column) sampled on the channel's
/// columns `ou, ou + 2, …` and interpolated between them; before the first and after
/// the last the nearest is taken.
fn horizontal(src: &[f32], ou: usize, out: &mut [f32]) {
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
pub(crate) struct PixelMap {
    rows: [[f32; 4]; 3],
    inv_gain: [f32; 4],
    offset_dn: [f32; 4],
    centre: [f32; 2],
    /// Map pixel (m, n) sits at mosaic pixel (scale·m + shift[0], scale·n + shift[1]).
    scale: f32,
    shift: [f32; 2],
}

impl PixelMap {
    pub(crate) fn new(rec: &Reconstructor, cfg: &MapsConfig, scale: f32, shift: [f32; 2]) -> Self {
        let (rows, inv_gain, offset_dn) = rec.parts();
        PixelMap {
            rows: rows.map(|r| r.map(|x| x as f32)),
            inv_gain: inv_gain.map(|x| x as f32),
            offset_dn: offset_dn.map(|x| x as f32),
            centre: cfg.aoe_centre_px.map(|x| x as f32),
            scale,
            shift,
        }
    }

    pub(crate) fn row(
        &self,
        ch: &[Vec<f32>; 4],
        v: usize,
        aop: &mut [f32],
        dolp: &mut [f32],
        int: &mut [f32],
        aoe: Option<&mut [f32]>,
    ) {
        match aoe {
            Some(e) => self.row_with::<true>(ch, v, aop, dolp, int, e),
            None => self.row_with::<false>(ch, v, aop, dolp, int, &mut []),
        }
    }

    /// The row's pixels, straight-line and bounds-check free so that the loop
    /// vectorizes (a channel the mosaic lacks has zero weights and a zero row).
    #[inline(always)]
    fn row_with<const AOE: bool>(
        &self,
        ch: &[Vec<f32>; 4],
        v: usize,
        aop: &mut [f32],
        dolp: &mut [f32],
        int: &mut [f32],
        aoe: &mut [f32],
    ) {
        let n = aop.len();
        let (dolp, int) = (&mut dolp[..n], &mut int[..n]);
        let aoe = if AOE { &mut aoe[..n] } else { aoe };
        let (c0, c1, c2, c3) = (&ch[0][..n], &ch[1][..n], &ch[2][..n], &ch[3][..n]);
        let [r0, r1, r2] = self.rows;
        let (g, o) = (self.inv_gain, self.offset_dn);
        let (scale, shift) = (self.scale, self.shift);
        let dy = v as f32 * scale + shift[1] - self.centre[1];
        for u in 0..n {
            let xs = [(c0[u] - o[0]) * g[0], (c1[u] - o[1]) * g[1], (c2[u] - o[2]) * g[2], (c3[u] - o[3]) * g[3]];
            let dot = |r: [f32; 4]| r[0] * xs[0] + r[1] * xs[1] + r[2] * xs[2] + r[3] * xs[3];
            let (i, q, uu) = (dot(r0), dot(r1), dot(r2));
            let ok = (i + q + uu).is_finite();
            // α = ½ atan2(U, Q) in (−90°, 90°] (atan2's −180° of a signed zero is +180°).
            let a = 0.5 * atan2_f32(uu, q).to_degrees();
            let a = if a <= -90.0 { a + 180.0 } else { a };
            let d = if i > 0.0 { (q * q + uu * uu).sqrt() / i } else { 0.0 };
            aop[u] = if ok { a } else { f32::NAN };
            dolp[u] = if ok { d } else { f32::NAN };
            int[u] = if ok { i } else { f32::NAN };
            if AOE {
                let dx = u as f32 * scale + shift[0] - self.centre[0];
                // α − β ∈ (−270°, 270°) wrapped into (−90°, 90°] with selects.
                let e = a - atan2_f32(-dy, dx).to_degrees();
                let e = if e > 90.0 { e - 180.0 } else { e };
                let e = if e <= -90.0 { e + 180.0 } else { e };
                aoe[u] = if ok { e } else { f32::NAN };
            }
        }
    }
}

#[cfg(test)]
#[path = "maps_tests.rs"]
mod tests;
