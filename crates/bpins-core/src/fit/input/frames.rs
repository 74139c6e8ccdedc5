//! # The pixels a fit reads: every pixel, or a sample budget of whole 2 × 2 tiles
//!
//! ```text
//! s = ⌈√(W·H / budget)⌉        strata of s × s blocks, each block B × B px (B = 8: 4 × 4 whole tiles)
//! one block per stratum, at a seeded offset (seed, frame k, stratum i)    ≈ W·H/s² ≤ budget px per frame
//! σ_full ≈ σ_sample · √(n_sample / n_full)      the 1σ every pixel would give (noise-limited parameters)
//! ```
//!
//! What: a fit's time and memory grow with the pixels it reads. A frame no larger than
//! the budget is read whole, exactly as before the budget existed (the samples' 612 ×
//! 512 under [`DEFAULT_BUDGET_PX`]). A larger frame is read once, in full, for what
//! needs every pixel — its sky mask (the field estimator's cells), its share of the
//! photon-transfer noise estimate ([`crate::fit::input::noise::NoiseSums`]) and, for a frame
//! without a reference heading or sky, the sun-vector extractor's first heading — and
//! then only a stratified sample of it is kept: one block of B × B pixels in each
//! stratum of s × s blocks, at a seeded offset that differs from frame to frame (so
//! the frames together cover the sensor). A block holds whole 2 × 2 tiles at even
//! coordinates, so each sampled pixel has its mosaic neighbours beside it: a
//! superpixel's four channels, the lag-2 neighbours the residual correlation needs
//! ([`crate::fit::uncertainty::correlation`]), and crosstalk's four neighbours (the model evaluates
//! them from the chain, the data of the pixel itself are what is compared). Memory per
//! frame is the sample (B²·nq·4 bytes per stratum), the sky mask and the offsets; the
//! full frame is read again only for the residual maps, one frame at a time
//! ([`FitFrames::full_frame`]).
//!
//! Units: pixels. Frame: image coordinates (u right, v down). Cannot: choose the
//! resolution a parameter needs by itself — the user raises the budget (`--sample-budget`,
//! `--full`) where a parameter's 1σ must shrink; every stratum has the same weight, so a
//! misfit confined to a few pixels (a hot column) may fall between the blocks.

use crate::capture::{Capture, FrameData};
use crate::error::{Error, Result};
use crate::fit::input::noise::NoiseModel;
use crate::fit::input::sky_noise::{noise_of, noise_sums, FrameNoise};
use crate::fit::FitOptions;
use crate::heading::field::SkyMask;
use crate::pixel_analyzers::PixelMaps;
use crate::sensor::Layout;
use rayon::prelude::*;
use std::borrow::Cow;
use std::sync::Arc;

/// Pixels per frame a fit reads by default: a 612 × 512 frame is read whole, a
/// 2448 × 2048 one by a sample of 1/15.9 of it (315 392 pixels).
pub const DEFAULT_BUDGET_PX: usize = 1 << 19;

/// Side of a sampled block, pixels (even: whole 2 × 2 tiles).
pub const BLOCK_PX: usize = 8;

/// Smallest budget accepted: 16 blocks per frame.
pub const MIN_BUDGET_PX: usize = 16 * BLOCK_PX * BLOCK_PX;

/// Seed of the blocks' offsets.
const SEED: u64 = 0x6270_696e_7321;

/// Pixels [u0, u1) × [v0, v1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub u0: usize,
    pub u1: usize,
    pub v0: usize,
    pub v1: usize,
}

impl Rect {
    /// Every `stride`-th row and column of the rectangle (absolute coordinates
    /// divisible by `stride`), row by row.
    pub fn points(self, stride: usize) -> impl Iterator<Item = (usize, usize)> {
        let first = |a: usize| a.div_ceil(stride) * stride;
        let (u0, u1) = (first(self.u0), self.u1);
        (first(self.v0)..self.v1).step_by(stride).flat_map(move |v| (u0..u1).step_by(stride).map(move |u| (u, v)))
    }
}

/// What a fit read of each frame: in `fit.json` as `sample`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Sample {
    /// The budget, most pixels per frame (`null`: every pixel, `--full`).
    pub budget_px: Option<usize>,
    /// Pixels of each frame the fit read (every pixel where the frame fits the budget).
    pub pixels_per_frame: usize,
    /// Pixels of a whole frame.
    pub frame_px: usize,
    /// Side of a sampled block and of its stratum, pixels (equal: every pixel).
    pub block_px: usize,
    pub stratum_px: usize,
    /// √(pixels_per_frame / frame_px): each 1σ times this is about the 1σ every pixel
    /// would give (for a parameter the noise limits; 1 where every pixel was read).
    pub full_sigma_factor: f64,
}

/// The strata of a sampled frame.
#[derive(Clone, Copy, Debug)]
struct Grid {
    /// Blocks per stratum side.
    s: usize,
    cols: usize,
    rows: usize,
}

impl Grid {
    fn stratum_px(&self) -> usize {
        self.s * BLOCK_PX
    }

    /// Stratum `i`'s block at offset `o` (in blocks).
    fn rect(&self, i: usize, o: (u16, u16)) -> Rect {
        let sp = self.stratum_px();
        let (u0, v0) = ((i % self.cols) * sp + o.0 as usize * BLOCK_PX, (i / self.cols) * sp + o.1 as usize * BLOCK_PX);
        Rect { u0, u1: u0 + BLOCK_PX, v0, v1: v0 + BLOCK_PX }
    }
}

/// No block in this stratum (an edge stratum narrower than a block).
const NONE: (u16, u16) = (u16::MAX, u16::MAX);

/// How the pixels are held.
enum Pixels<'a> {
    /// Every pixel of every frame.
    All(Cow<'a, [FrameData]>),
    /// Per frame: each stratum's block offset and its values (block-major, row by row,
    /// `nq` per pixel; zeros where a stratum has no block).
    Sampled { grid: Grid, offsets: Vec<Vec<(u16, u16)>>, values: Vec<Vec<f32>> },
}

/// What the fit knows of each frame without its pixels (sampled frames: read once).
struct Known {
    noise: Option<NoiseModel>,
    sky: Arc<Vec<Option<SkyMask>>>,
    /// A first heading for a frame without reference or sky mask (sun vector).
    heading: Vec<Option<std::result::Result<f64, String>>>,
}

/// The frames of a capture as a fit reads them.
pub struct FitFrames<'a> {
    pixels: Pixels<'a>,
    known: Option<Known>,
    /// Per-pixel maps to apply to a frame read again from disk.
    maps: Option<Arc<PixelMaps>>,
    len: usize,
    w: usize,
    h: usize,
    nq: usize,
    sample: Sample,
}

/// Blocks per stratum side for `budget` pixels per frame of `w × h` (1: every pixel):
/// the least s ≥ 2 whose blocks (one per stratum with room for a whole block, the
/// last column and row of strata included) fit the budget.
fn blocks_per_stratum(w: usize, h: usize, budget: Option<usize>) -> usize {
    let b = match budget {
        Some(b) if w * h > b => b.max(MIN_BUDGET_PX),
        _ => return 1,
    };
    let along = |n: usize, sp: usize| n / sp + usize::from(n % sp >= BLOCK_PX);
    let mut s = (((w * h) as f64 / b as f64).sqrt().ceil() as usize).max(2);
    while along(w, s * BLOCK_PX) * along(h, s * BLOCK_PX) * BLOCK_PX * BLOCK_PX > b {
        s += 1;
    }
    s
}

/// A seeded offset in 0..n (splitmix64 of the seed, the frame and the stratum).
fn draw(k: usize, i: usize, axis: u64, n: usize) -> u16 {
    let mut z = SEED ^ ((k as u64) << 40) ^ ((i as u64) << 2) ^ axis;
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z % n as u64) as u16
}

impl<'a> FitFrames<'a> {
    /// Every pixel of `frames` (in memory), as the fit read them before budgets.
    pub fn all(c: &Capture, frames: &'a [FrameData]) -> Result<FitFrames<'a>> {
        for (k, f) in frames.iter().enumerate() {
            check(c, k, f)?;
        }
        Ok(Self::whole(c, Cow::Borrowed(frames)))
    }

    fn whole(c: &Capture, frames: Cow<'a, [FrameData]>) -> FitFrames<'a> {
        let (w, h, nq) = dims(c);
        let sample = Sample {
            budget_px: None,
            pixels_per_frame: w * h,
            frame_px: w * h,
            block_px: 1,
            stratum_px: 1,
            full_sigma_factor: 1.0,
        };
        FitFrames { len: frames.len(), pixels: Pixels::All(frames), known: None, maps: None, w, h, nq, sample }
    }

    /// `frames` (in memory) under `budget` pixels per frame (`None`: every pixel): whole
    /// where a frame fits, else sampled (sky masks read with `opts.known`).
    pub fn sampled(
        c: &Capture,
        frames: &'a [FrameData],
        budget: Option<usize>,
        opts: &FitOptions,
    ) -> Result<FitFrames<'a>> {
        let (w, h, _) = dims(c);
        if blocks_per_stratum(w, h, budget) == 1 {
            return Ok(Self::all(c, frames)?.with_budget(budget));
        }
        Self::build(c, frames.len(), budget, None, opts, &|k| Ok(Cow::Borrowed(&frames[k])), &|_| {})
    }

    /// Reads the frames of `c` (through `maps`, a calibration's per-pixel maps, where
    /// given) under `budget` pixels per frame: at most a few whole frames in memory at
    /// once where sampled; `progress(frames read)`.
    pub fn load(
        c: &Capture,
        budget: Option<usize>,
        maps: Option<Arc<PixelMaps>>,
        opts: &FitOptions,
        progress: &dyn Fn(usize),
    ) -> Result<FitFrames<'static>> {
        let (w, h, _) = dims(c);
        let read = |k: usize| read_frame(c, k, maps.as_deref());
        if blocks_per_stratum(w, h, budget) == 1 {
            let mut frames = Vec::with_capacity(c.frames.len());
            for k in 0..c.frames.len() {
                frames.push(read(k)?);
                progress(k + 1);
            }
            let mut f = FitFrames::whole(c, Cow::Owned(frames)).with_budget(budget);
            f.maps = maps.clone();
            return Ok(f);
        }
        FitFrames::build(c, c.frames.len(), budget, maps.clone(), opts, &|k| read(k).map(Cow::Owned), progress)
    }

    fn with_budget(mut self, budget: Option<usize>) -> Self {
        self.sample.budget_px = budget;
        self
    }

    /// Samples `n` frames, each read by `read`, a few at a time.
    fn build<'r>(
        c: &Capture,
        n: usize,
        budget: Option<usize>,
        maps: Option<Arc<PixelMaps>>,
        opts: &FitOptions,
        read: &(dyn Fn(usize) -> Result<Cow<'r, FrameData>> + Sync),
        progress: &dyn Fn(usize),
    ) -> Result<FitFrames<'a>> {
        let (w, h, nq) = dims(c);
        let s = blocks_per_stratum(w, h, budget);
        let sp = s * BLOCK_PX;
        let grid = Grid { s, cols: w.div_ceil(sp), rows: h.div_ceil(sp) };
        let known_model = opts.known.model();
        let full = c.sensor.full_scale_dn();
        let mut noise = FrameNoise::default();
        let (mut offsets, mut values, mut sky, mut heading) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        // As many whole frames in memory at once as there are threads (at most 4).
        let batch = rayon::current_num_threads().clamp(1, 4);
        for start in (0..n).step_by(batch) {
            let done: Vec<_> = (start..(start + batch).min(n))
                .into_par_iter()
                .map(|k| -> Result<_> {
                    let data = read(k)?;
                    check(c, k, &data)?;
                    let mask = crate::fit::input::masks::sky_mask_of(c, k, &data, &known_model)?;
                    let first = (c.frames[k].heading_deg.is_none() && mask.is_none())
                        .then(|| first_heading(c, k, &data).map_err(|e| e.to_string()));
                    let off = offsets_of(&grid, k, w, h);
                    let vals = take(&grid, &off, &data, w, nq);
                    let sums = noise_sums(c, &data, mask.as_ref());
                    Ok((sums, mask, first, off, vals))
                })
                .collect::<Result<_>>()?;
            for (sums, mask, first, off, vals) in done {
                noise.merge(&sums);
                sky.push(mask);
                heading.push(first);
                offsets.push(off);
                values.push(vals);
            }
            progress((start + batch).min(n));
        }
        let blocks: usize = offsets.iter().map(|o| o.iter().filter(|&&x| x != NONE).count()).sum();
        let per_frame = blocks * BLOCK_PX * BLOCK_PX / n.max(1);
        let sample = Sample {
            budget_px: budget,
            pixels_per_frame: per_frame,
            frame_px: w * h,
            block_px: BLOCK_PX,
            stratum_px: sp,
            full_sigma_factor: (per_frame as f64 / (w * h) as f64).sqrt(),
        };
        Ok(FitFrames {
            pixels: Pixels::Sampled { grid, offsets, values },
            known: Some(Known { noise: noise.model(full), sky: Arc::new(sky), heading }),
            maps,
            len: n,
            w,
            h,
            nq,
            sample,
        })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// What each frame's sample is.
    pub fn sample(&self) -> Sample {
        self.sample
    }

    /// Whether every pixel is read.
    pub fn is_whole(&self) -> bool {
        matches!(self.pixels, Pixels::All(_))
    }

    /// Measured value of sample `q` of pixel (u, v) of frame `k` (a pixel the frame
    /// holds: one of [`FitFrames::rects`]).
    #[inline]
    pub fn value(&self, k: usize, u: usize, v: usize, q: usize) -> f32 {
        match &self.pixels {
            Pixels::All(f) => value_of(&f[k], self.w, u, v, q),
            Pixels::Sampled { grid, offsets, values } => {
                let sp = grid.stratum_px();
                let (sx, sy) = (u / sp, v / sp);
                let i = sy * grid.cols + sx;
                let o = offsets[k][i];
                let (bu, bv) = (u - sx * sp - o.0 as usize * BLOCK_PX, v - sy * sp - o.1 as usize * BLOCK_PX);
                debug_assert!(bu < BLOCK_PX && bv < BLOCK_PX, "({u}, {v}) is not sampled");
                values[k][((i * BLOCK_PX + bv) * BLOCK_PX + bu) * self.nq + q]
            }
        }
    }

    /// The rectangles of frame `k` the fit reads: the whole frame, or each sampled
    /// block (stratum order).
    pub fn rects(&self, k: usize) -> Vec<Rect> {
        match &self.pixels {
            Pixels::All(_) => vec![Rect { u0: 0, u1: self.w, v0: 0, v1: self.h }],
            Pixels::Sampled { grid, offsets, .. } => {
                offsets[k].iter().enumerate().filter(|(_, &o)| o != NONE).map(|(i, &o)| grid.rect(i, o)).collect()
            }
        }
    }

    /// Units of parallel work over frame `k` at `stride`: each row of a whole frame
    /// (every `stride`-th), or each sampled block.
    pub(crate) fn parts(&self, k: usize, stride: usize) -> Vec<Rect> {
        match &self.pixels {
            Pixels::All(_) => {
                (0..self.h).step_by(stride).map(|v| Rect { u0: 0, u1: self.w, v0: v, v1: v + 1 }).collect()
            }
            Pixels::Sampled { .. } => self.rects(k),
        }
    }

    /// How many clusters of pixels the frames' parts fall in (`crate::fit::uncertainty::robust`): the
    /// rows (every pixel read), or the sample's strata (one block each per frame).
    pub(crate) fn n_clusters(&self) -> usize {
        match &self.pixels {
            Pixels::All(_) => self.h,
            Pixels::Sampled { grid, .. } => grid.rows * grid.cols,
        }
    }

    /// The cluster of a part of [`FitFrames::parts`] on every pixel: its row, or its
    /// block's stratum — the same pixels, or the same stretch of the sensor, in every
    /// frame.
    pub(crate) fn cluster_of(&self, r: &Rect) -> usize {
        match &self.pixels {
            Pixels::All(_) => r.v0,
            Pixels::Sampled { grid, .. } => {
                let sp = grid.stratum_px();
                (r.v0 / sp) * grid.cols + r.u0 / sp
            }
        }
    }

    /// Frame `k` whole: from memory, or read again (through the calibration's maps).
    pub fn full_frame(&self, c: &Capture, k: usize) -> Result<Cow<'_, FrameData>> {
        match &self.pixels {
            Pixels::All(f) => Ok(Cow::Borrowed(&f[k])),
            Pixels::Sampled { .. } => read_frame(c, k, self.maps.as_deref()).map(Cow::Owned),
        }
    }

    /// The sensor noise of the capture (photon transfer over every pixel of every frame;
    /// a colour capture's on each frame's sky mask, [`crate::fit::input::sky_noise`], read
    /// with `opts` as [`FitFrames::sky_masks`] reads them, or `opts.sky_masks`).
    pub fn noise(&self, c: &Capture, opts: &FitOptions) -> Result<NoiseModel> {
        let model = match (&self.pixels, &self.known) {
            (_, Some(k)) => k.noise,
            (Pixels::All(f), None) if c.sensor.colour.is_some() => {
                let masks = match &opts.sky_masks {
                    Some(m) if m.len() == f.len() => m.clone(),
                    _ => self.sky_masks(c, opts)?,
                };
                noise_of(c, f, Some(&masks))
            }
            (Pixels::All(f), None) => noise_of(c, f, None),
            (Pixels::Sampled { .. }, None) => None,
        };
        model.ok_or_else(|| Error::TooFewSamples("too few usable pixels to estimate the sensor noise".into()))
    }

    /// Each frame's sky mask, read with `opts.known` (a sampled capture's: with the
    /// known effects it was sampled under).
    pub fn sky_masks(&self, c: &Capture, opts: &FitOptions) -> Result<Arc<Vec<Option<SkyMask>>>> {
        match (&self.pixels, &self.known) {
            (_, Some(k)) => Ok(k.sky.clone()),
            (Pixels::All(f), None) => Ok(Arc::new(crate::fit::sky_masks(c, f, opts)?)),
            (Pixels::Sampled { .. }, None) => unreachable!("a sample knows its masks"),
        }
    }

    /// First heading of frame `k` without a reference: the sun-vector extractor on the
    /// whole frame.
    pub(crate) fn first_heading(&self, c: &Capture, k: usize) -> Result<f64> {
        match self.known.as_ref().and_then(|x| x.heading[k].clone()) {
            Some(h) => h.map_err(Error::Heading),
            None => first_heading(c, k, &*self.full_frame(c, k)?),
        }
    }
}

/// Frame `k` of `c` read from disk, through `maps` where given.
fn read_frame(c: &Capture, k: usize, maps: Option<&PixelMaps>) -> Result<FrameData> {
    let data = c.read_frame(k)?;
    match maps {
        Some(m) => crate::pipeline::apply_pixel_maps(c, data, m),
        None => Ok(data),
    }
}

/// (width, height, samples per pixel) of the capture's frames.
fn dims(c: &Capture) -> (usize, usize, usize) {
    let g = &c.sensor.geometry;
    let nq = match &c.sensor.layout {
        Layout::Dofp { .. } => 1,
        Layout::Colocated { channels } => channels.len(),
    };
    (g.width_px as usize, g.height_px as usize, nq)
}

/// Frame `k` matches the capture's layout and size.
fn check(c: &Capture, k: usize, f: &FrameData) -> Result<()> {
    let (w, h, nq) = dims(c);
    let ok = match (&c.sensor.layout, f) {
        (Layout::Dofp { .. }, FrameData::Mosaic { dn, .. }) => dn.len() == w * h,
        (Layout::Colocated { .. }, FrameData::Colocated { channels, .. }) => {
            channels.len() == nq && channels.iter().all(|(_, p)| p.len() == w * h)
        }
        _ => false,
    };
    let size = f.size_px();
    if !ok || size != (w as u32, h as u32) {
        return Err(Error::FrameMismatch(format!(
            "frame {k}: its pixels ({} × {}) do not match the capture's sensor ({w} × {h}, {} per pixel)",
            size.0, size.1, nq
        )));
    }
    Ok(())
}

/// Sample `q` of pixel (u, v) of a whole frame `w` wide.
#[inline]
pub(crate) fn value_of(f: &FrameData, w: usize, u: usize, v: usize, q: usize) -> f32 {
    match f {
        FrameData::Mosaic { dn, .. } => dn[v * w + u],
        FrameData::Colocated { channels, .. } => channels[q].1[v * w + u],
    }
}

/// Each stratum's block offset of frame `k`.
fn offsets_of(grid: &Grid, k: usize, w: usize, h: usize) -> Vec<(u16, u16)> {
    let sp = grid.stratum_px();
    (0..grid.rows * grid.cols)
        .map(|i| {
            let (u0, v0) = ((i % grid.cols) * sp, (i / grid.cols) * sp);
            // Whole blocks inside the frame (fewer in the last column and row).
            let nx = (sp.min(w - u0)) / BLOCK_PX;
            let ny = (sp.min(h - v0)) / BLOCK_PX;
            if nx == 0 || ny == 0 {
                NONE
            } else {
                (draw(k, i, 0, nx), draw(k, i, 1, ny))
            }
        })
        .collect()
}

/// The sampled values of `data`: each stratum's block, row by row, `nq` per pixel.
fn take(grid: &Grid, offsets: &[(u16, u16)], data: &FrameData, w: usize, nq: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; offsets.len() * BLOCK_PX * BLOCK_PX * nq];
    for (i, &o) in offsets.iter().enumerate().filter(|(_, &o)| o != NONE) {
        let r = grid.rect(i, o);
        for (p, (u, v)) in r.points(1).enumerate() {
            for q in 0..nq {
                out[(i * BLOCK_PX * BLOCK_PX + p) * nq + q] = value_of(data, w, u, v, q);
            }
        }
    }
    out
}

/// The sun-vector extractor's heading of frame `k` whose pixels are `data`.
fn first_heading(c: &Capture, k: usize, data: &FrameData) -> Result<f64> {
    let est = crate::pipeline::frame_headings_of(
        c,
        k,
        data,
        &Default::default(),
        crate::pipeline::ReconMode::Superpixel,
        &[crate::heading::Extractor::SunVector],
    )?;
    est.into_iter().next().expect("one extractor").1.map(|e| e.heading_deg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_keep_absolute_strides_inside_a_rect() {
        let r = Rect { u0: 8, u1: 16, v0: 8, v1: 16 };
        let p: Vec<_> = r.points(3).collect();
        assert_eq!(p.first(), Some(&(9, 9)));
        assert!(p.iter().all(|&(u, v)| u % 3 == 0 && v % 3 == 0 && (8..16).contains(&u) && (8..16).contains(&v)));
        assert_eq!(p.len(), 9);
        assert_eq!(r.points(1).count(), 64);
    }

    #[test]
    fn a_budget_samples_whole_blocks_one_per_stratum_differently_per_frame() {
        let (w, h) = (100, 60);
        assert_eq!(blocks_per_stratum(w, h, None), 1);
        assert_eq!(blocks_per_stratum(w, h, Some(6000)), 1);
        assert_eq!(blocks_per_stratum(w, h, Some(1500)), 3, "s = 2 keeps 6 × 4 blocks, 1536 px");
        let s = blocks_per_stratum(w, h, Some(1600));
        assert_eq!(s, 2);
        // 153 × 128 under a quarter: s = 2 would keep 10 × 8 blocks (the last column
        // of strata, 9 px wide, holds one), 5120 px > 4896; s = 3 keeps 7 × 6.
        assert_eq!(blocks_per_stratum(153, 128, Some(4896)), 3);
        let grid = Grid { s, cols: w.div_ceil(16), rows: h.div_ceil(16) };
        let (a, b) = (offsets_of(&grid, 0, w, h), offsets_of(&grid, 1, w, h));
        assert_ne!(a, b, "frames are sampled at different places");
        // Last column: 100 − 96 = 4 px, no whole block; last row: 60 − 48 = 12 px, one.
        for (i, o) in a.iter().enumerate() {
            let (c, r) = (i % grid.cols, i / grid.cols);
            if c == grid.cols - 1 {
                assert_eq!(*o, NONE);
            } else {
                assert!(o.0 < 2 && (o.1 < if r == grid.rows - 1 { 1 } else { 2 }), "{o:?} in stratum {i}");
                let rect = grid.rect(i, *o);
                assert!(rect.u0 % 2 == 0 && rect.v0 % 2 == 0 && rect.u1 <= w && rect.v1 <= h, "{rect:?}");
            }
        }
        // The values taken are the frame's.
        let dn: Vec<f32> = (0..w * h).map(|p| p as f32).collect();
        let data = FrameData::Mosaic { width_px: w as u32, height_px: h as u32, dn };
        let vals = take(&grid, &a, &data, w, 1);
        let i = 7;
        let r = grid.rect(i, a[i]);
        let sp = grid.stratum_px();
        let (u, v) = (r.u0 + 3, r.v0 + 5);
        let (bu, bv) = (
            u - (i % grid.cols) * sp - a[i].0 as usize * BLOCK_PX,
            v - (i / grid.cols) * sp - a[i].1 as usize * BLOCK_PX,
        );
        assert_eq!(vals[(i * BLOCK_PX + bv) * BLOCK_PX + bu], (v * w + u) as f32);
    }
}
