//! Polarization maps of a colour-polarization mosaic (Sony IMX250MYR): AoP, DoLP,
//! intensity and AoE per colour band, each band's Stokes vector from its own pixels
//! only (CONVENTIONS.md "Colour-polarization sensors"). Pixel (u, v) has the analyzer
//! `mosaic[v % 2][u % 2]` under the filter `tiles[(v / 2) % 2][(u / 2) % 2]`, a 4 × 4
//! superpixel; the maps of each band go through the mono kernels of `maps`.
//!
//! Four interpolations ([`Interpolation`]), the same names as the mono maps:
//!
//! - **opencv**: polanalyser's `demosaicing(raw, COLOR_PolarRGB)` reproduced exactly
//!   for `uint8` and `uint16` mosaics, full size, in its two stages:
//!   1. colour: each analyzer's quarter-size plane `raw[j::2, i::2]` is a Bayer image
//!      (the IMX250MYR's plane is RGGB, OpenCV's `BayerBG`), demosaiced with OpenCV's
//!      bilinear `cvtColor(plane, COLOR_BayerBG2BGR)`, and put back at its pixels: a
//!      full-size mosaic per band, each pixel still behind its own analyzer. Within a
//!      plane a band on one tile (R, B) takes its own sample, the mean of its two
//!      row or column neighbours, or of its four diagonal ones; a band on two
//!      diagonal tiles (G) its own sample or the mean of its four edge neighbours;
//!      each mean rounded half up to a whole DN, the plane's border row and column
//!      copied from the next ones inwards.
//!   2. polarization: each band's mosaic through the mono opencv route
//!      (`COLOR_PolarMono`: OpenCV's Bayer bilinear again, rounded), then Stokes.
//!
//!   Bands are never mixed: stage 1 averages samples of one band only, stage 2 works
//!   on one band's mosaic. (Analyzers are not mixed in stage 1 either: every plane is
//!   one analyzer.)
//! - **opencv_ea**: polanalyser's `demosaicing(raw, COLOR_PolarRGB_EA)` reproduced
//!   exactly (`uint8`, `uint16`): the same two stages with OpenCV's edge-aware Bayer
//!   demosaic (`COLOR_BayerBG2BGR_EA`, `maps_ea.rs`). Stage 1 differs from opencv
//!   only for the band on two diagonal tiles (G) between its own sites: the mean of
//!   its two row neighbours in the plane, or of its two column neighbours where the
//!   row pair differs more (not the mean of all four). Stage 2 is the opencv one
//!   (the edge-aware mono demosaic's analyzers are the bilinear one's, `maps_ea.rs`).
//! - **bilinear**: the same two stages with the averages kept unrounded, and a
//!   sample that is zero, at or above `full_scale_dn` or not finite makes every map
//!   pixel it weighs NaN. The border rule is OpenCV's (not the mono bilinear's
//!   lattice clamp).
//! - **superpixel**: one value per 4 × 4 superpixel and band, no interpolation: each
//!   channel of the band is its sample on the band's tile (the mean of the two on a
//!   band with two tiles, G), placed at the mean of those tiles' centres. A quarter
//!   of the size in each direction.
//!
//! Units and frame as the mono maps (module `maps`): DN above the black level,
//! angles counter-clockwise as displayed. Cost: the two stages are fused row by row.
//! Each rayon job takes a block of map rows and keeps, per band, a ring of the three
//! stage-1 mosaic rows that stage 2's row reads (the two rows either side of a block
//! are computed by both jobs), so no full-size intermediate is written; stage 2 and
//! the Stokes and angles are the mono opencv route's row kernels once per band, which
//! makes a full-size colour route at least three mono routes' work by construction.

use super::ea::edge_aware_between;
use super::{checked, lattices, opencv_mean, Interpolation, MapsConfig, MapsError, MapsOut, PixelMap, Scratch};
use crate::heading::field::{RawDn, RawImage};
use crate::recon::Reconstructor;
use crate::sensor::{Band, ColourTiles};
use rayon::prelude::*;

/// A band's maps, as [`colour_maps`] returns them.
#[derive(Clone, Debug, PartialEq)]
pub struct BandMaps {
    pub band: Band,
    pub maps: super::Maps,
}

/// Scratch a caller mapping many frames may keep. The fused route (module docs) needs
/// no full-size intermediate any more, so this holds nothing; it stays in the
/// signature so that callers keep compiling.
#[derive(Default)]
pub struct ColourScratch {
    _none: (),
}

/// Map rows per rayon job in the full-size routes: stage 1 is computed twice for the
/// two mosaic rows either side of a block (2 of 34 rows, 6 %).
const BLOCK_ROWS: usize = 32;

/// The maps' size for a `w × h` colour mosaic: the same, or a quarter each way for
/// superpixels.
pub fn colour_maps_size(interpolation: Interpolation, w: usize, h: usize) -> (usize, usize) {
    match interpolation {
        Interpolation::Superpixel => (w / 4, h / 4),
        _ => (w, h),
    }
}

/// How a band lies on the 2 × 2 colour tiles (and so on each analyzer's plane).
#[derive(Clone, Copy, Debug)]
enum Lattice {
    /// One tile, at plane offset (x, y).
    One(usize, usize),
    /// Two diagonal tiles: plane sites with (x + y) % 2 == parity.
    Quincunx(usize),
}

fn lattice(tiles: &ColourTiles, band: Band, interpolation: Interpolation) -> Result<Lattice, MapsError> {
    let on: Vec<(usize, usize)> = (0..4).map(|t| (t % 2, t / 2)).filter(|&(x, y)| tiles.tiles[y][x] == band).collect();
    match on[..] {
        [] => Err(MapsError::NoSuchBand { band: band.name() }),
        [(x, y)] => Ok(Lattice::One(x, y)),
        [(x0, y0), (x1, y1)] if x0 != x1 && y0 != y1 => Ok(Lattice::Quincunx((x0 + y0) % 2)),
        _ => Err(MapsError::NotBayer { band: band.name(), interpolation: interpolation.name() }),
    }
}

/// [`colour_maps_into`] into new buffers (AoE included), for every band of `tiles`.
pub fn colour_maps<T: RawDn>(
    raw: &RawImage<T>,
    rec: &Reconstructor,
    cfg: &MapsConfig,
    tiles: &ColourTiles,
) -> Result<Vec<BandMaps>, MapsError> {
    let (mw, mh) = colour_maps_size(cfg.interpolation, raw.width_px, raw.height_px);
    let n = mw * mh;
    let mut all: Vec<BandMaps> = tiles
        .bands()
        .into_iter()
        .map(|band| BandMaps {
            band,
            maps: super::Maps {
                width_px: mw,
                height_px: mh,
                aop_deg: vec![0.0; n],
                dolp: vec![0.0; n],
                intensity_dn: vec![0.0; n],
                aoe_deg: vec![0.0; n],
            },
        })
        .collect();
    let mut out: Vec<(Band, MapsOut)> = all
        .iter_mut()
        .map(|b| {
            let m = &mut b.maps;
            let o = MapsOut {
                aop_deg: &mut m.aop_deg,
                dolp: &mut m.dolp,
                intensity_dn: &mut m.intensity_dn,
                aoe_deg: Some(&mut m.aoe_deg),
            };
            (b.band, o)
        })
        .collect();
    colour_maps_into(raw, rec, cfg, tiles, &mut ColourScratch::default(), &mut out)?;
    drop(out);
    Ok(all)
}

/// Fills each `(band, maps)` of `out` with that band's maps of the colour mosaic `raw`
/// (module docs); each buffer [`colour_maps_size`] long. `cfg.mosaic` is the analyzer
/// layout of the 2 × 2 tile, `tiles` the colour filters over the tiles.
pub fn colour_maps_into<T: RawDn>(
    raw: &RawImage<T>,
    rec: &Reconstructor,
    cfg: &MapsConfig,
    tiles: &ColourTiles,
    _scratch: &mut ColourScratch,
    out: &mut [(Band, MapsOut)],
) -> Result<(), MapsError> {
    let (w, h) = (raw.width_px, raw.height_px);
    if !raw.is_consistent() {
        return Err(MapsError::Buffer { width_px: w, height_px: h, stride: raw.stride, len: raw.data.len() });
    }
    // Each analyzer plane at least 3 × 3 for OpenCV's stencil; a superpixel 4 × 4.
    let min = if cfg.interpolation == Interpolation::Superpixel { 4 } else { 6 };
    if w < min || h < min {
        return Err(MapsError::TooSmall { width_px: w, height_px: h, interpolation: cfg.interpolation.name(), min });
    }
    let (mw, mh) = colour_maps_size(cfg.interpolation, w, h);
    let n = mw * mh;
    for (_, o) in out.iter() {
        let check = |name: &'static str, got: usize| {
            if got == n {
                Ok(())
            } else {
                Err(MapsError::Output { name, got, want: n, width_px: mw, height_px: mh })
            }
        };
        check("aop_deg", o.aop_deg.len())?;
        check("dolp", o.dolp.len())?;
        check("intensity_dn", o.intensity_dn.len())?;
        if let Some(a) = &o.aoe_deg {
            check("aoe_deg", a.len())?;
        }
    }
    let lat = lattices(&cfg.mosaic);
    if cfg.interpolation == Interpolation::Superpixel {
        for (band, o) in out.iter_mut() {
            superpixel_band(raw, rec, cfg, tiles, *band, &lat, o)?;
        }
        return Ok(());
    }
    let mut wanted: [Option<Lattice>; 3] = [None; 3];
    for (band, _) in out.iter() {
        wanted[band.index()] = Some(lattice(tiles, *band, cfg.interpolation)?);
    }
    let opencv = cfg.interpolation.is_opencv();
    let stage1 = Stage1 {
        full_scale: (!opencv).then_some(cfg.full_scale_dn as f32),
        edge_aware: cfg.interpolation == Interpolation::OpenCvEa,
    };
    let px = PixelMap::new(rec, cfg, 1.0, [0.0; 2]);
    if opencv && T::INTEGER {
        full_size::<T, true>(raw, &wanted, stage1, &px, &lat, out);
    } else {
        full_size::<T, false>(raw, &wanted, stage1, &px, &lat, out);
    }
    Ok(())
}

/// How stage 1 interpolates, beside its rounding.
#[derive(Clone, Copy)]
struct Stage1 {
    /// Some for the bilinear flavour (invalid samples NaN).
    full_scale: Option<f32>,
    /// OpenCV's edge-aware Bayer demosaic (opencv_ea).
    edge_aware: bool,
}

/// One band's rows of the maps within a block of [`BLOCK_ROWS`] rows.
struct BlockOut<'a> {
    band: usize,
    aop_deg: &'a mut [f32],
    dolp: &'a mut [f32],
    intensity_dn: &'a mut [f32],
    aoe_deg: Option<&'a mut [f32]>,
}

/// One rayon job's rows: the raw rows as read (raw row R in slot R % 6, `read_row`
/// saying which row a slot holds: one mosaic row reads three raw rows, and the next
/// but one reads two of them again), each band's ring of stage-1 mosaic rows (row r
/// in slot r % 3), stage 2's scratch.
struct Job {
    read: [Vec<f32>; 6],
    read_row: [usize; 6],
    ring: [[Vec<f32>; 3]; 3],
    /// The first mosaic row not yet in the rings (0 at a block's start: none).
    next: usize,
    /// `pairs[k]`: k / 2 is even, the lane mask of stage 1's selects.
    pairs: Vec<bool>,
    s: Scratch,
}

/// Both full-size routes (module docs), stage 1 fused into stage 2 row by row.
/// `INT`: averages rounded to whole DN (opencv, opencv_ea on integer samples).
fn full_size<T: RawDn, const INT: bool>(
    raw: &RawImage<T>,
    wanted: &[Option<Lattice>; 3],
    stage1: Stage1,
    px: &PixelMap,
    lat: &[Option<(usize, usize)>; 4],
    out: &mut [(Band, MapsOut)],
) {
    let (w, h) = (raw.width_px, raw.height_px);
    let bw = BLOCK_ROWS * w;
    let mut blocks: Vec<Vec<BlockOut>> = (0..h.div_ceil(BLOCK_ROWS)).map(|_| Vec::new()).collect();
    for (band, o) in out.iter_mut() {
        let mut aoe = o.aoe_deg.as_deref_mut().map(|a| a.chunks_mut(bw));
        let rows = o.aop_deg.chunks_mut(bw).zip(o.dolp.chunks_mut(bw)).zip(o.intensity_dn.chunks_mut(bw));
        for (blk, ((aop_deg, dolp), intensity_dn)) in blocks.iter_mut().zip(rows) {
            let aoe_deg = aoe.as_mut().and_then(|a| a.next());
            blk.push(BlockOut { band: band.index(), aop_deg, dolp, intensity_dn, aoe_deg });
        }
    }
    blocks.into_par_iter().enumerate().for_each_init(
        || Job {
            read: std::array::from_fn(|_| vec![0.0; w]),
            read_row: [usize::MAX; 6],
            ring: std::array::from_fn(|_| std::array::from_fn(|_| vec![0.0; w])),
            next: 0,
            pairs: (0..w + 4).map(|k| (k / 2) % 2 == 0).collect(),
            s: Scratch::new(w),
        },
        |job, (bi, mut outs)| {
            job.next = 0;
            let v0 = bi * BLOCK_ROWS;
            for v in v0..(v0 + BLOCK_ROWS).min(h) {
                // Stage 2 reads mosaic rows vs − 1, vs, vs + 1 (OpenCV's border: the
                // first and last rows are those of their neighbours inwards).
                let vs = v.clamp(1, h - 2);
                for r in job.next.max(vs - 1)..vs + 2 {
                    job.mosaic_row::<T, INT>(raw, r, wanted, stage1);
                }
                job.next = vs + 2;
                let lr = (v - v0) * w;
                for o in outs.iter_mut() {
                    let [a, b, c] = &job.ring[o.band];
                    let slot = |r: usize| [a, b, c][r % 3].as_slice();
                    job.s.opencv_rows(slot(vs - 1), slot(vs), slot(vs + 1), vs, lat, INT);
                    let aoe = o.aoe_deg.as_deref_mut().map(|e| &mut e[lr..][..w]);
                    px.row(
                        &job.s.ch,
                        v,
                        &mut o.aop_deg[lr..][..w],
                        &mut o.dolp[lr..][..w],
                        &mut o.intensity_dn[lr..][..w],
                        aoe,
                    );
                }
            }
        },
    );
}

impl Job {
    /// Stage 1 (module docs): row `r` of every wanted band's full-size mosaic into
    /// its ring. Row r is row y = r / 2 of the analyzer planes of row parity j = r % 2
    /// (both column parities at once: pixel column c is plane column x = c / 2 of
    /// plane i = c % 2), their neighbours in the plane two pixels away.
    fn mosaic_row<T: RawDn, const INT: bool>(
        &mut self,
        raw: &RawImage<T>,
        r: usize,
        wanted: &[Option<Lattice>; 3],
        stage1: Stage1,
    ) {
        let (w, h) = (raw.width_px, raw.height_px);
        let (j, y) = (r % 2, r / 2);
        let ph = (h - j).div_ceil(2);
        let ys = y.clamp(1, ph - 2);
        let rows = [ys - 1, ys, ys + 1].map(|yy| 2 * yy + j);
        for rr in rows {
            if self.read_row[rr % 6] == rr {
                continue;
            }
            let (buf, src) = (&mut self.read[rr % 6], &raw.data[rr * raw.stride..][..w]);
            match stage1.full_scale {
                Some(fs) => buf.iter_mut().zip(src).for_each(|(o, &d)| *o = checked(d.dn_f32(), fs)),
                None => buf.iter_mut().zip(src).for_each(|(o, &d)| *o = d.dn_f32()),
            }
            self.read_row[rr % 6] = rr;
        }
        let read = rows.map(|rr| self.read[rr % 6].as_slice());
        for (b, l) in wanted.iter().enumerate() {
            let Some(l) = *l else { continue };
            bayer_row::<INT>(read, &self.pairs, ys, l, stage1.edge_aware, &mut self.ring[b][r % 3]);
        }
    }
}

/// One row of a band's stage-1 mosaic from its plane rows ys − 1, ys, ys + 1 (read
/// at full width, `[up, mid, down]`): OpenCV's bilinear Bayer demosaic of each
/// analyzer plane (module docs), every interior plane column x (pixel columns 2x and
/// 2x + 1) either the band's own sample or the mean of the band's neighbours, the
/// border plane columns copied from the next ones inwards. Both candidates are
/// computed at every column and one selected by x's parity, read from the lane mask
/// `pairs` (module `maps`' opencv kernel does the same), so that the loop vectorizes.
/// `edge_aware`: a band on two diagonal tiles as OpenCV's edge-aware demosaic has it.
fn bayer_row<const INT: bool>(
    read: [&[f32]; 3],
    pairs: &[bool],
    ys: usize,
    l: Lattice,
    edge_aware: bool,
    o: &mut [f32],
) {
    let w = o.len();
    // Interior pixel columns c = 2 + k, k < n, in both planes (w ≥ 6).
    let n = w - 4;
    let [up, mid, down] = read;
    // The n columns from d on: d = 0, 2, 4 are the left neighbour, the column, the right.
    fn window(row: &[f32], d: usize, n: usize) -> &[f32] {
        &row[d..d + n]
    }
    let at = |row, d| window(row, d, n);
    let (ul, u0, ur) = (at(up, 0), at(up, 2), at(up, 4));
    let (ml, m0, mr) = (at(mid, 0), at(mid, 2), at(mid, 4));
    let (dl, d0, dr) = (at(down, 0), at(down, 2), at(down, 4));
    let oi = &mut o[2..n + 2];
    // Pixel column 2 + k is plane column x = (k + 2) / 2: the band's own where
    // x + phase is even, i.e. `pairs[k + 2 + 2 (phase % 2)]`.
    let own_where = |phase: usize| &pairs[2 + 2 * (phase % 2)..][..n];
    match l {
        Lattice::One(ox, oy) if (ys + oy).is_multiple_of(2) => {
            let here = own_where(ox);
            for k in 0..n {
                let (own, nb) = (m0[k], opencv_mean::<INT>(ml[k] + mr[k], 2.0));
                oi[k] = if here[k] { own } else { nb };
            }
        }
        Lattice::One(ox, _) => {
            let here = own_where(ox);
            for k in 0..n {
                let own = opencv_mean::<INT>(u0[k] + d0[k], 2.0);
                let nb = opencv_mean::<INT>(ul[k] + ur[k] + dl[k] + dr[k], 4.0);
                oi[k] = if here[k] { own } else { nb };
            }
        }
        // Own where (x + ys) % 2 == p, i.e. x + ys + p even.
        Lattice::Quincunx(p) if edge_aware => edge_aware_between::<INT>(own_where(ys + p), [ml, m0, mr], [u0, d0], oi),
        Lattice::Quincunx(p) => {
            let here = own_where(ys + p);
            for k in 0..n {
                let (own, nb) = (m0[k], opencv_mean::<INT>(u0[k] + d0[k] + ml[k] + mr[k], 4.0));
                oi[k] = if here[k] { own } else { nb };
            }
        }
    }
    o[0] = o[2];
    o[1] = o[3];
    o[w - 2] = o[w - 4];
    o[w - 1] = o[w - 3];
}

/// Superpixel maps of one band (module docs).
fn superpixel_band<T: RawDn>(
    raw: &RawImage<T>,
    rec: &Reconstructor,
    cfg: &MapsConfig,
    tiles: &ColourTiles,
    band: Band,
    lat: &[Option<(usize, usize)>; 4],
    o: &mut MapsOut,
) -> Result<(), MapsError> {
    let on: Vec<(usize, usize)> = (0..4).map(|t| (t % 2, t / 2)).filter(|&(x, y)| tiles.tiles[y][x] == band).collect();
    if on.is_empty() {
        return Err(MapsError::NoSuchBand { band: band.name() });
    }
    let (mw, k) = (raw.width_px / 4, on.len() as f32);
    let fs = cfg.full_scale_dn as f32;
    // The band's tiles' mean centre within the superpixel, px.
    let mean = |f: fn(&(usize, usize)) -> usize| on.iter().map(|t| 2.0 * f(t) as f32 + 0.5).sum::<f32>() / k;
    let px = PixelMap::new(rec, cfg, 4.0, [mean(|t| t.0), mean(|t| t.1)]);
    let row = |s: &mut Scratch, v: usize, aop: &mut [f32], dolp: &mut [f32], int: &mut [f32], aoe| {
        for (c, at) in lat.iter().enumerate() {
            let Some((ou, ov)) = *at else { continue };
            let ch = &mut s.ch[c][..mw];
            ch.fill(0.0);
            for &(tx, ty) in &on {
                let r = &raw.data[(4 * v + 2 * ty + ov) * raw.stride..][..raw.width_px];
                for (m, x) in ch.iter_mut().enumerate() {
                    *x += checked(r[4 * m + 2 * tx + ou].dn_f32(), fs);
                }
            }
            for x in ch.iter_mut() {
                *x /= k;
            }
        }
        px.row(&s.ch, v, aop, dolp, int, aoe);
    };
    let rows = o.aop_deg.par_chunks_mut(mw).zip(o.dolp.par_chunks_mut(mw)).zip(o.intensity_dn.par_chunks_mut(mw));
    match o.aoe_deg.as_deref_mut() {
        Some(aoe) => rows.zip(aoe.par_chunks_mut(mw)).enumerate().for_each_init(
            || Scratch::new(mw),
            |s, (v, (((aop, dolp), int), aoe))| row(s, v, aop, dolp, int, Some(aoe)),
        ),
        None => rows
            .enumerate()
            .for_each_init(|| Scratch::new(mw), |s, (v, ((aop, dolp), int))| row(s, v, aop, dolp, int, None)),
    }
    Ok(())
}

#[cfg(test)]
#[path = "maps_colour_tests.rs"]
mod tests;
