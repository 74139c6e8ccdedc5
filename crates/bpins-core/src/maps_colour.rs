//! Polarization maps of a colour-polarization mosaic (Sony IMX250MYR): AoP, DoLP,
//! intensity and AoE per colour band, each band's Stokes vector from its own pixels
//! only (CONVENTIONS.md "Colour-polarization sensors"). Pixel (u, v) has the analyzer
//! `mosaic[v % 2][u % 2]` under the filter `tiles[(v / 2) % 2][(u / 2) % 2]`, a 4 × 4
//! superpixel; the maps of each band go through the mono kernels of `maps`.
//!
//! Three interpolations ([`Interpolation`]), the same names as the mono maps:
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
//! angles counter-clockwise as displayed. Cost: stage 1 writes one full-size f32
//! mosaic per band into a [`ColourScratch`] the caller may keep; stage 2 is the mono
//! opencv route once per band.

use super::{checked, lattices, Interpolation, MapsConfig, MapsError, MapsOut, PixelMap, Scratch};
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

/// Stage 1's full-size mosaics, one per band (kept by a caller mapping many frames).
#[derive(Default)]
pub struct ColourScratch {
    bands: [Vec<f32>; 3],
}

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
    scratch: &mut ColourScratch,
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
    let opencv = cfg.interpolation == Interpolation::OpenCv;
    let integer = opencv && T::INTEGER;
    for (b, l) in wanted.iter().enumerate() {
        if l.is_some() {
            scratch.bands[b].resize(w * h, 0.0);
        }
    }
    colour_stage(raw, &wanted, &mut scratch.bands, integer, (!opencv).then_some(cfg.full_scale_dn as f32));
    let px = PixelMap::new(rec, cfg, 1.0, [0.0; 2]);
    for (band, o) in out.iter_mut() {
        let m = RawImage::packed(&scratch.bands[band.index()][..w * h], w, h);
        let row = |s: &mut Scratch, v: usize, aop: &mut [f32], dolp: &mut [f32], int: &mut [f32], aoe| {
            s.opencv_row(&m, v, &lat, integer);
            px.row(&s.ch, v, aop, dolp, int, aoe);
        };
        let rows = o.aop_deg.par_chunks_mut(w).zip(o.dolp.par_chunks_mut(w)).zip(o.intensity_dn.par_chunks_mut(w));
        match o.aoe_deg.as_deref_mut() {
            Some(aoe) => rows.zip(aoe.par_chunks_mut(w)).enumerate().for_each_init(
                || Scratch::new(w),
                |s, (v, (((aop, dolp), int), aoe))| row(s, v, aop, dolp, int, Some(aoe)),
            ),
            None => rows
                .enumerate()
                .for_each_init(|| Scratch::new(w), |s, (v, ((aop, dolp), int))| row(s, v, aop, dolp, int, None)),
        }
    }
    Ok(())
}

/// Stage 1 (module docs): every wanted band's full-size mosaic, a row at a time.
/// `full_scale`: Some for the bilinear flavour (invalid samples NaN), None for opencv.
fn colour_stage<T: RawDn>(
    raw: &RawImage<T>,
    wanted: &[Option<Lattice>; 3],
    bands: &mut [Vec<f32>; 3],
    integer: bool,
    full_scale: Option<f32>,
) {
    let (w, h) = (raw.width_px, raw.height_px);
    let round = |s: f32, n: f32| if integer { ((s + 0.5 * n) / n).floor() } else { s / n };
    let [r, g, b] = bands;
    // One row of the three band mosaics at a time; an absent band gets an empty row.
    let rows: Vec<[&mut [f32]; 3]> = {
        let mut it = [r, g, b].map(|x| x.chunks_mut(w.max(1)));
        (0..h).map(|_| it.each_mut().map(|c| c.next().unwrap_or(&mut []))).collect()
    };
    rows.into_par_iter().enumerate().for_each_init(
        || [vec![0f32; w / 2 + 1], vec![0f32; w / 2 + 1], vec![0f32; w / 2 + 1]],
        |[up, mid, down], (v, out)| {
            let (j, y) = (v % 2, v / 2);
            let ph = (h - j).div_ceil(2);
            let ys = y.clamp(1, ph - 2);
            for i in 0..2 {
                let pw = (w - i).div_ceil(2);
                for (buf, yy) in [(&mut *up, ys - 1), (&mut *mid, ys), (&mut *down, ys + 1)] {
                    let src = &raw.data[(2 * yy + j) * raw.stride..][..w];
                    for (x, o) in buf[..pw].iter_mut().enumerate() {
                        let d = src[2 * x + i].dn_f32();
                        *o = match full_scale {
                            Some(fs) => checked(d, fs),
                            None => d,
                        };
                    }
                }
                for (bi, l) in wanted.iter().enumerate() {
                    let Some(l) = *l else { continue };
                    let o = &mut *out[bi];
                    let at = |x: usize| -> f32 {
                        match l {
                            Lattice::One(ox, oy) => {
                                let on_col = (x + ox).is_multiple_of(2);
                                if (ys + oy).is_multiple_of(2) {
                                    if on_col {
                                        mid[x]
                                    } else {
                                        round(mid[x - 1] + mid[x + 1], 2.0)
                                    }
                                } else if on_col {
                                    round(up[x] + down[x], 2.0)
                                } else {
                                    round(up[x - 1] + up[x + 1] + down[x - 1] + down[x + 1], 4.0)
                                }
                            }
                            Lattice::Quincunx(p) => {
                                if (x + ys) % 2 == p {
                                    mid[x]
                                } else {
                                    round(up[x] + down[x] + mid[x - 1] + mid[x + 1], 4.0)
                                }
                            }
                        }
                    };
                    for x in 1..pw - 1 {
                        o[2 * x + i] = at(x);
                    }
                    o[i] = o[2 + i];
                    o[2 * (pw - 1) + i] = o[2 * (pw - 2) + i];
                }
            }
        },
    );
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
