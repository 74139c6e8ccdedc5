//! Stokes reconstruction from analyzer channels (seed eq. 4, 13; CONVENTIONS.md).
//!
//! ```text
//! x_k = (DN_k − b − offset_k) / (1 + gain_k)                     undo the known response
//! x   = A·(I, Q, U),  A_k = ½[(1+ε_k), (1−ε_k) cos 2θ_k, (1−ε_k) sin 2θ_k]
//! (I, Q, U) = A⁻¹·x (3 channels)  or  (AᵀA)⁻¹Aᵀ·x (4 channels, least squares)
//! ```
//!
//! With nominal analyzers this is exactly the convention's closed form: four channels
//! `I = ½ΣI_k, Q = I0 − I90, U = I45 − I135`; three channels (0, 45, 90)
//! `I = I0 + I90, Q = I0 − I90, U = 2·I45 − I` (tested). Known analyzer errors and
//! channel responses (seed eq. 13) enter through the [`Model`] the reconstructor is
//! built from. Frame: image (Q, U referred to image +x). Units: DN.
//!
//! Layouts: a DoFP mosaic is reconstructed per 2 × 2 tile into one superpixel at the
//! tile centre `(2i + 0.5, 2j + 0.5)` (as the tile reads it, or with each channel moved
//! to the centre: `recon_centred.rs`), or demosaiced (bilinear per channel) onto every
//! pixel; colocated images per pixel. Saturated or zero DN mark a sample invalid (NaN).

use crate::effects::Model;
use crate::error::{Error, Result};
use crate::sensor::{dn_is_valid, Channel};
use crate::stokes::{Analyzer, Stokes};
use glam::{DMat3, DVec3};
use rayon::prelude::*;

#[path = "recon_centred.rs"]
mod centred;
pub use centred::{band_superpixels_centred, superpixels_centred};

/// Linear map from the channels' DN to (I, Q, U), built once per frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Reconstructor {
    /// Rows I, Q, U; columns by channel index; zero for channels not used.
    rows: [[f64; 4]; 3],
    inv_gain: [f64; 4],
    offset_dn: [f64; 4],
}

impl Reconstructor {
    /// Reconstruction for `channels` with the analyzers and responses of `model`
    /// (the nominal ones for `Model::default()`), black level `black_level_dn`.
    pub fn new(model: &Model, black_level_dn: f64, channels: &[Channel]) -> Result<Self> {
        let mut ch: Vec<Channel> = channels.to_vec();
        ch.sort();
        ch.dedup();
        if ch.len() < 3 {
            return Err(Error::Analyzers(format!("Stokes needs at least 3 analyzer channels, got {}", ch.len())));
        }
        let a_row = |c: Channel| {
            let a = Analyzer::at(
                c.angle_deg(),
                model.channels.analyzer_delta_deg[c.index()],
                model.channels.analyzer_eps[c.index()],
            );
            DVec3::new(0.5 * (1.0 + a.eps), 0.5 * (1.0 - a.eps) * a.cos2t, 0.5 * (1.0 - a.eps) * a.sin2t)
        };
        let rows_a: Vec<DVec3> = ch.iter().map(|&c| a_row(c)).collect();
        let mut rows = [[0.0; 4]; 3];
        let singular = || {
            Error::Analyzers(format!(
                "analyzer angles {:?} cannot resolve Q and U",
                ch.iter().map(|c| c.angle_deg()).collect::<Vec<_>>()
            ))
        };
        if ch.len() == 3 {
            // Square: invert A (its rows are the channels).
            let a = DMat3::from_cols(rows_a[0], rows_a[1], rows_a[2]).transpose();
            if a.determinant().abs() < 1e-9 {
                return Err(singular());
            }
            let inv = a.inverse();
            for (j, c) in ch.iter().enumerate() {
                let col = inv.col(j);
                for i in 0..3 {
                    rows[i][c.index()] = col[i];
                }
            }
        } else {
            // Least squares: (AᵀA)⁻¹Aᵀ.
            let mut ata = DMat3::ZERO;
            for r in &rows_a {
                ata += DMat3::from_cols(*r * r.x, *r * r.y, *r * r.z);
            }
            if ata.determinant().abs() < 1e-12 {
                return Err(singular());
            }
            let inv = ata.inverse();
            for (r, c) in rows_a.iter().zip(&ch) {
                let col = inv * *r;
                for i in 0..3 {
                    rows[i][c.index()] = col[i];
                }
            }
        }
        Ok(Reconstructor {
            rows,
            inv_gain: model.channels.gain.map(|g| 1.0 / g),
            offset_dn: model.channels.offset_dn.map(|o| o + black_level_dn),
        })
    }

    /// The map's parts, for the GPU twin: rows I, Q, U by channel index, 1/(1 + gain_k),
    /// and black level + offset_k.
    pub fn parts(&self) -> ([[f64; 4]; 3], [f64; 4], [f64; 4]) {
        (self.rows, self.inv_gain, self.offset_dn)
    }

    /// (I, Q, U) in DN from the channels' DN, indexed by channel (unused ones ignored).
    #[inline(always)]
    pub fn stokes(&self, dn: &[f64; 4]) -> Stokes {
        let mut x = [0.0; 4];
        for k in 0..4 {
            x[k] = (dn[k] - self.offset_dn[k]) * self.inv_gain[k];
        }
        let dot = |r: &[f64; 4]| r[0] * x[0] + r[1] * x[1] + r[2] * x[2] + r[3] * x[3];
        Stokes::new(dot(&self.rows[0]), dot(&self.rows[1]), dot(&self.rows[2]), 0.0)
    }
}

/// A regular grid of reconstructed Stokes samples: sample `(i, j)` sits at pixel
/// position `(origin_px + step_px·i, origin_px + step_px·j)`.
#[derive(Clone, Debug)]
pub struct PolImage {
    pub width: usize,
    pub height: usize,
    pub origin_px: f64,
    pub step_px: f64,
    /// (I, Q, U) in DN per sample, row-major; NaN where invalid.
    pub iqu: Vec<[f64; 3]>,
}

impl PolImage {
    /// Pixel position of sample `(i, j)`.
    #[inline]
    pub fn position_px(&self, i: usize, j: usize) -> (f64, f64) {
        (self.origin_px + self.step_px * i as f64, self.origin_px + self.step_px * j as f64)
    }

    #[inline]
    pub fn stokes(&self, i: usize, j: usize) -> Option<Stokes> {
        let [a, b, c] = self.iqu[j * self.width + i];
        (!a.is_nan()).then_some(Stokes::new(a, b, c, 0.0))
    }

    pub fn valid_count(&self) -> usize {
        self.iqu.iter().filter(|s| !s[0].is_nan()).count()
    }
}

const INVALID: [f64; 3] = [f64::NAN; 3];

/// Reconstructs 2 × 2 superpixels of a DoFP mosaic (`dn`, row-major `w × h`).
/// `full_scale_dn` masks saturated samples (use `f64::INFINITY` for unquantised data).
/// Each tile is bitwise [`superpixel`]; a row of tiles runs as one branch-free loop.
pub fn superpixels(
    dn: &[f32],
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
) -> PolImage {
    let (tw, th) = (w / 2, h / 2);
    let mut iqu = vec![INVALID; tw * th];
    iqu.par_chunks_mut(tw.max(1)).enumerate().for_each(|(j, row)| {
        superpixel_row(&dn[2 * j * w..][..2 * tw], &dn[(2 * j + 1) * w..][..2 * tw], mosaic, rec, full_scale_dn, row);
    });
    PolImage { width: tw, height: th, origin_px: 0.5, step_px: 2.0, iqu }
}

/// Row kernel of [`superpixels`]: the tiles of one tile row, from its two mosaic rows
/// `top` and `bottom` (DN, at least `2·out.len()` long each), into `out`.
pub fn superpixel_row(
    top: &[f32],
    bottom: &[f32],
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
    out: &mut [[f64; 3]],
) {
    tile_row(top, bottom, mosaic, rec, full_scale_dn, out, |ok, s| if ok { [s.i, s.q, s.u] } else { INVALID });
}

/// [`superpixel_row`] into Stokes vectors as [`PolImage::stokes`] reads them back
/// (and [`crate::heading::HeadingSums::from_image`] passes them on): `(I, Q, U, 0)`,
/// or `(NaN, 0, 0, 0)` where the tile is invalid.
pub(crate) fn superpixel_stokes_row(
    top: &[f32],
    bottom: &[f32],
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
    out: &mut [Stokes],
) {
    // A valid tile's DN are finite, so its I is never NaN: `ok` is `!I.is_nan()`.
    tile_row(top, bottom, mosaic, rec, full_scale_dn, out, |ok, s| {
        if ok {
            Stokes::new(s.i, s.q, s.u, 0.0)
        } else {
            Stokes::new(f64::NAN, 0.0, 0.0, 0.0)
        }
    });
}

/// The branch-free tile loop of [`superpixel_row`]: `out[i] = make(ok, stokes)` for
/// tile `i`, each tile bitwise [`superpixel`].
#[inline(always)]
fn tile_row<T>(
    top: &[f32],
    bottom: &[f32],
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
    out: &mut [T],
    make: impl Fn(bool, Stokes) -> T,
) {
    // Tile position (0: top left, 1: top right, 2: bottom left, 3: bottom right) each
    // channel is read from; 4 where the mosaic lacks the channel (it reads 0).
    let mut pos = [4usize; 4];
    for (dv, mrow) in mosaic.iter().enumerate() {
        for (du, c) in mrow.iter().enumerate() {
            pos[c.index()] = 2 * dv + du;
        }
    }
    let n = out.len();
    let (top, bottom) = (&top[..2 * n], &bottom[..2 * n]);
    for (out, (t, b)) in out.iter_mut().zip(top.chunks_exact(2).zip(bottom.chunks_exact(2))) {
        let x = [t[0] as f64, t[1] as f64, b[0] as f64, b[1] as f64];
        let ok = x.iter().fold(true, |ok, &x| ok & dn_is_valid(x, full_scale_dn));
        // Gather by channel with selects (the positions are fixed over the frame).
        let at = |p: usize| {
            if p == 0 {
                x[0]
            } else if p == 1 {
                x[1]
            } else if p == 2 {
                x[2]
            } else if p == 3 {
                x[3]
            } else {
                0.0
            }
        };
        *out = make(ok, rec.stokes(&[at(pos[0]), at(pos[1]), at(pos[2]), at(pos[3])]));
    }
}

/// (I, Q, U) of the 2 × 2 tile `(i, j)` of a DoFP mosaic (`dn`, row-major, `w` wide);
/// NaN if any of its samples is clipped or saturated. The per-tile reference of
/// [`superpixels`].
pub fn superpixel(
    dn: &[f32],
    w: usize,
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
    i: usize,
    j: usize,
) -> [f64; 3] {
    let mut d = [0.0; 4];
    let mut ok = true;
    for (dv, mrow) in mosaic.iter().enumerate() {
        for (du, c) in mrow.iter().enumerate() {
            let x = dn[(2 * j + dv) * w + 2 * i + du] as f64;
            ok &= dn_is_valid(x, full_scale_dn);
            d[c.index()] = x;
        }
    }
    if ok {
        let s = rec.stokes(&d);
        [s.i, s.q, s.u]
    } else {
        INVALID
    }
}

/// Demosaics a DoFP mosaic bilinearly per channel and reconstructs every pixel.
pub fn demosaic(
    dn: &[f32],
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
) -> PolImage {
    let mut iqu = vec![INVALID; w * h];
    // Channel k samples the sub-lattice (u_k + 2m, v_k + 2n).
    let mut offsets = [(0usize, 0usize); 4];
    for (dv, mrow) in mosaic.iter().enumerate() {
        for (du, c) in mrow.iter().enumerate() {
            offsets[c.index()] = (du, dv);
        }
    }
    let used: Vec<Channel> = mosaic.iter().flatten().copied().collect();
    let (mw, mh) = (w.div_ceil(2), h.div_ceil(2));
    iqu.par_chunks_mut(w.max(1)).enumerate().for_each(|(v, row)| {
        for (u, out) in row.iter_mut().enumerate() {
            let mut d = [0.0; 4];
            let mut ok = true;
            for &c in &used {
                let (ou, ov) = offsets[c.index()];
                // Sub-lattice coordinates of (u, v), clamped to the lattice.
                let a = ((u as f64 - ou as f64) * 0.5).clamp(0.0, ((w - ou - 1) / 2) as f64);
                let b = ((v as f64 - ov as f64) * 0.5).clamp(0.0, ((h - ov - 1) / 2) as f64);
                let (m0, n0) = (a.floor() as usize, b.floor() as usize);
                let (m1, n1) = ((m0 + 1).min((w - ou - 1) / 2).min(mw - 1), (n0 + 1).min((h - ov - 1) / 2).min(mh - 1));
                let (fa, fb) = (a - m0 as f64, b - n0 as f64);
                let at = |m: usize, n: usize| dn[(ov + 2 * n) * w + ou + 2 * m] as f64;
                let taps = [at(m0, n0), at(m1, n0), at(m0, n1), at(m1, n1)];
                ok &= taps.iter().all(|&x| dn_is_valid(x, full_scale_dn));
                d[c.index()] =
                    (1.0 - fb) * ((1.0 - fa) * taps[0] + fa * taps[1]) + fb * ((1.0 - fa) * taps[2] + fa * taps[3]);
            }
            if ok {
                let s = rec.stokes(&d);
                *out = [s.i, s.q, s.u];
            }
        }
    });
    PolImage { width: w, height: h, origin_px: 0.0, step_px: 1.0, iqu }
}

/// Reconstructs a colocated image: one plane per channel, each `w × h` row-major.
pub fn colocated(
    planes: &[(Channel, &[f32])],
    w: usize,
    h: usize,
    rec: &Reconstructor,
    full_scale_dn: f64,
) -> PolImage {
    let mut iqu = vec![INVALID; w * h];
    iqu.par_chunks_mut(w.max(1)).enumerate().for_each(|(v, row)| {
        for (u, out) in row.iter_mut().enumerate() {
            let mut d = [0.0; 4];
            let mut ok = true;
            for (c, p) in planes {
                let x = p[v * w + u] as f64;
                ok &= dn_is_valid(x, full_scale_dn);
                d[c.index()] = x;
            }
            if ok {
                let s = rec.stokes(&d);
                *out = [s.i, s.q, s.u];
            }
        }
    });
    PolImage { width: w, height: h, origin_px: 0.0, step_px: 1.0, iqu }
}

/// Maps of AoP α (degrees, (−90, 90]), DoLP (1) and AoE φ = α − β (degrees,
/// (−90, 90], β about the principal point of `intr`), NaN where invalid.
pub fn angle_maps(img: &PolImage, intr: &crate::camera::Intrinsics) -> [Vec<f32>; 3] {
    use crate::conventions::{image_angle_rad, wrap_deg_90};
    use rayon::prelude::*;
    let n = img.width * img.height;
    let (mut aop, mut dolp, mut aoe) = (vec![f32::NAN; n], vec![f32::NAN; n], vec![f32::NAN; n]);
    if img.width == 0 {
        return [aop, dolp, aoe];
    }
    // Rows in parallel (each writes its own rows of the three maps).
    aop.par_chunks_mut(img.width)
        .zip(dolp.par_chunks_mut(img.width))
        .zip(aoe.par_chunks_mut(img.width))
        .enumerate()
        .for_each(|(j, ((aop, dolp), aoe))| {
            for i in 0..img.width {
                if let Some(s) = img.stokes(i, j) {
                    let (x, y) = img.position_px(i, j);
                    let a = s.aop_rad().to_degrees();
                    let beta = image_angle_rad(x - intr.cx_px, y - intr.cy_px).to_degrees();
                    aop[i] = wrap_deg_90(a) as f32;
                    dolp[i] = s.dolp() as f32;
                    aoe[i] = wrap_deg_90(a - beta) as f32;
                }
            }
        });
    [aop, dolp, aoe]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::EffectSet;
    use crate::sensor::{Layout, DEFAULT_MOSAIC};

    fn channels_of(s: Stokes, rec_model: &Model) -> [f64; 4] {
        Channel::ALL.map(|c| {
            let a = Analyzer::at(c.angle_deg(), rec_model.channels.analyzer_delta_deg[c.index()], 0.0);
            crate::stokes::analyzer_intensity(s, &a)
        })
    }

    #[test]
    fn nominal_reconstruction_is_the_convention_closed_form() {
        let m = Model::default();
        let four = Reconstructor::new(&m, 0.0, &Channel::ALL).unwrap();
        let three = Reconstructor::new(&m, 0.0, &[Channel::C0, Channel::C45, Channel::C90]).unwrap();
        let d = [3.0, 5.0, 2.0, 7.0];
        let s4 = four.stokes(&d);
        assert_eq!((s4.i, s4.q, s4.u), (0.5 * 17.0, 1.0, -2.0));
        let s3 = three.stokes(&d);
        assert_eq!((s3.i, s3.q, s3.u), (5.0, 1.0, 10.0 - 5.0));
    }

    #[test]
    fn reconstruction_inverts_the_analyzers_including_known_errors() {
        let mut set = EffectSet::new();
        set.set("array_rotation", "dtheta_deg", 1.5).unwrap();
        let m = set.model();
        let s = Stokes::new(2.0, 0.4, -0.7, 0.0);
        for chans in [&Channel::ALL[..], &[Channel::C0, Channel::C45, Channel::C90][..]] {
            let rec = Reconstructor::new(&m, 0.0, chans).unwrap();
            let got = rec.stokes(&channels_of(s, &m));
            assert!((got.i - s.i).abs() < 1e-12 && (got.q - s.q).abs() < 1e-12 && (got.u - s.u).abs() < 1e-12);
        }
    }

    #[test]
    fn too_few_channels_is_an_error() {
        assert!(Reconstructor::new(&Model::default(), 0.0, &[Channel::C0, Channel::C90]).is_err());
    }

    #[test]
    fn uniform_light_reconstructs_on_every_layout() {
        let rec = Reconstructor::new(&Model::default(), 10.0, &Channel::ALL).unwrap();
        let s = Stokes::new(100.0, 20.0, -30.0, 0.0);
        let ch = channels_of(s, &Model::default()).map(|x| x + 10.0);
        let (w, h) = (6, 4);
        let mosaic: Vec<f32> =
            (0..w * h).map(|p| ch[Layout::dofp_channel(&DEFAULT_MOSAIC, p % w, p / w).index()] as f32).collect();
        for img in [
            superpixels(&mosaic, w, h, &DEFAULT_MOSAIC, &rec, 4095.0),
            demosaic(&mosaic, w, h, &DEFAULT_MOSAIC, &rec, 4095.0),
        ] {
            assert_eq!(img.valid_count(), img.width * img.height);
            for &[i, q, u] in &img.iqu {
                assert!((i - 100.0).abs() < 1e-4 && (q - 20.0).abs() < 1e-4 && (u + 30.0).abs() < 1e-4);
            }
        }
        let sp = superpixels(&mosaic, w, h, &DEFAULT_MOSAIC, &rec, 4095.0);
        assert_eq!(sp.position_px(1, 1), (2.5, 2.5));
    }

    #[test]
    fn superpixels_are_bitwise_the_per_tile_reference() {
        let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap();
        let (w, h) = (14, 6);
        let mosaic: Vec<f32> = (0..w * h).map(|p| (64 + (p * 37) % 4000) as f32).collect();
        let mut mosaic = mosaic;
        mosaic[17] = 4095.0; // saturated
        mosaic[40] = 0.0; // clipped
        let mirrored = [[Channel::C45, Channel::C90], [Channel::C0, Channel::C135]];
        for m in [DEFAULT_MOSAIC, mirrored] {
            let img = superpixels(&mosaic, w, h, &m, &rec, 4095.0);
            for j in 0..h / 2 {
                for i in 0..w / 2 {
                    let (a, b) = (img.iqu[j * img.width + i], superpixel(&mosaic, w, &m, &rec, 4095.0, i, j));
                    assert!(a == b || (a[0].is_nan() && b[0].is_nan()), "{a:?} {b:?}");
                }
            }
            assert_eq!(img.valid_count(), 21 - 2);
        }
    }

    #[test]
    fn saturated_tiles_are_masked() {
        let rec = Reconstructor::new(&Model::default(), 0.0, &Channel::ALL).unwrap();
        let mut mosaic = vec![100.0f32; 16];
        mosaic[0] = 4095.0;
        let sp = superpixels(&mosaic, 4, 4, &DEFAULT_MOSAIC, &rec, 4095.0);
        assert!(sp.stokes(0, 0).is_none());
        assert!(sp.stokes(1, 1).is_some());
    }
}
