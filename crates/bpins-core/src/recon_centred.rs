//! Superpixels with each channel moved to its tile's centre, to first order: the
//! plain heading route's `--recon superpixel` (`pipeline::reconstruct_frame`).
//!
//! ```text
//! I_k(c) = I_k(p_k) − (p_k − c)·∇I_k(p_k)     c the tile centre (2i + ½, 2j + ½), p_k channel
//!                                            k's pixel in the tile, |p_k − c| = (½, ½) px
//! ∂I_k/∂x = (I_k(i+1) − I_k(i−1)) / 4 px     the same channel in the tiles beside it (2 px
//!                                            apart; one-sided, / 2 px, at the frame's edge or
//!                                            beside an invalid tile; 0 with neither), ∂/∂y alike
//! (I, Q, U) = Reconstructor(I_k(c))           as a superpixel's (seed eq. 4, 13)
//! ```
//!
//! Why: a 2 × 2 tile's four analyzers sit on four rays, so where the sky has a
//! gradient the tile reads it as polarization: S1 = I_0(p_0) − I_90(p_90) carries
//! ∇S0·(p_0 − p_90) to first order. On `samples/clean` (13.8 µm pixels, 8 mm) that bias
//! was the plain superpixel heading's whole error, 0.026° RMS against a statistical 1σ
//! of 0.0013° (docs/honesty.md); on 27.6 µm pixels under a CIE sky 0.13–0.25°. Moved to
//! the centre the first-order term is gone, and for a mosaic whose paired channels
//! (0°/90°, 45°/135°) sit on a diagonal, as every layout of CONVENTIONS.md's samples
//! does, the second order cancels in Q and U as well: each channel is then off by
//! −½ d_kᵀ H d_k (H the Hessian), the same for both channels of a pair. Third order
//! remains; the intensity I keeps a common second-order term (harmless to the AoP).
//!
//! The noise: each raw DN enters its own tile with weight 1 and the four tiles beside
//! it with ±⅛, so a sample's variance is 1.0625× a superpixel's and the weights' sum
//! is 1: the samples stay close to independent (a frame-wide mean's design effect is
//! 1/1.0625), and the extractor's statistical 1σ from their scatter stands, ~3 %
//! conservative. Frame: image pixels, +x right, +y down (CONVENTIONS.md). Units: DN.
//! Cannot: a gradient that changes within 4 px (a cloud's edge, the sun's disc), or
//! a channel pair not on a diagonal (its second order remains).

use super::{Reconstructor, INVALID};
use crate::recon::PolImage;
use crate::sensor::{dn_is_valid, Channel};
use rayon::prelude::*;

/// [`super::superpixels`] with each channel moved to its tile's centre (module doc):
/// one sample per 2 × 2 tile at `(2i + 0.5, 2j + 0.5)`, NaN where any of the tile's
/// own DN is clipped or saturated.
pub fn superpixels_centred(
    dn: &[f32],
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
) -> PolImage {
    centred_tiles(dn, w, h, mosaic, rec, full_scale_dn, 1, |_, _| true)
}

/// [`superpixels_centred`] of one colour band's tiles: `classes[j % 2][i % 2]` says
/// whether tile `(i, j)` lies under the band's filter (`ColourTiles::classes`,
/// CONVENTIONS.md); each channel's gradient from the band's own tiles two tiles (4 px)
/// to either side, `∂I_k/∂x = (I_k(i+2) − I_k(i−2)) / 8 px`. Every other tile is NaN.
pub fn band_superpixels_centred(
    dn: &[f32],
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
    classes: &[[bool; 2]; 2],
) -> PolImage {
    centred_tiles(dn, w, h, mosaic, rec, full_scale_dn, 2, |i, j| classes[j % 2][i % 2])
}

/// The tiles `keep` selects, each channel moved to the tile's centre by its gradient
/// over the tiles `stride` tiles to either side.
#[allow(clippy::too_many_arguments)]
fn centred_tiles(
    dn: &[f32],
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
    stride: usize,
    keep: impl Fn(usize, usize) -> bool + Sync,
) -> PolImage {
    let (tw, th) = (w / 2, h / 2);
    // Tile (i, j)'s DN at tile position (du, dv), NaN where it is not valid.
    let at = |i: usize, j: usize, du: usize, dv: usize| {
        let x = dn[(2 * j + dv) * w + 2 * i + du] as f64;
        if dn_is_valid(x, full_scale_dn) {
            x
        } else {
            f64::NAN
        }
    };
    let mut iqu = vec![INVALID; tw * th];
    iqu.par_chunks_mut(tw.max(1)).enumerate().for_each(|(j, row)| {
        for (i, out) in row.iter_mut().enumerate().filter(|(i, _)| keep(*i, j)) {
            let mut d = [0.0; 4];
            let mut ok = true;
            for (dv, mrow) in mosaic.iter().enumerate() {
                for (du, c) in mrow.iter().enumerate() {
                    let x = at(i, j, du, dv);
                    ok &= !x.is_nan();
                    // The channel's gradient at its own pixel, from its neighbours.
                    let gx = slope_per_px(x, i, tw, stride, |m| at(m, j, du, dv));
                    let gy = slope_per_px(x, j, th, stride, |n| at(i, n, du, dv));
                    // Moved by (c − p_k) = (½ − du, ½ − dv) px.
                    d[c.index()] = x + (0.5 - du as f64) * gx + (0.5 - dv as f64) * gy;
                }
            }
            if ok {
                let s = rec.stokes(&d);
                *out = [s.i, s.q, s.u];
            }
        }
    });
    PolImage { width: tw, height: th, origin_px: 0.5, step_px: 2.0, iqu }
}

/// The derivative per pixel of one channel along one axis of the tile grid at tile
/// `m` of `n` (value `x`; `g(m')` the channel in tile `m'`, NaN where invalid), from
/// the tiles `s` to either side (2s px apart): central where both are valid,
/// one-sided where one is, 0 where neither is.
#[inline]
fn slope_per_px(x: f64, m: usize, n: usize, s: usize, g: impl Fn(usize) -> f64) -> f64 {
    let prev = if m >= s { g(m - s) } else { f64::NAN };
    let next = if m + s < n { g(m + s) } else { f64::NAN };
    let span_px = 2.0 * s as f64;
    match (prev.is_nan(), next.is_nan()) {
        (false, false) => (next - prev) / (2.0 * span_px),
        (true, false) => (next - x) / span_px,
        (false, true) => (x - prev) / span_px,
        (true, true) => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::Model;
    use crate::recon::superpixels;

    const MOSAIC: [[Channel; 2]; 2] = [[Channel::C90, Channel::C45], [Channel::C135, Channel::C0]];

    fn rec() -> Reconstructor {
        Reconstructor::new(&Model::default(), 0.0, &Channel::ALL).unwrap()
    }

    /// An unpolarized field `f(x, y)` (DN, the pixel's centre) as a mosaic.
    fn unpolarized(w: usize, h: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f32> {
        (0..w * h).map(|p| f((p % w) as f64, (p / w) as f64) as f32).collect()
    }

    fn worst_qu(img: &PolImage, interior: bool) -> f64 {
        let mut worst = 0.0f64;
        for j in 0..img.height {
            for i in 0..img.width {
                let edge = i == 0 || j == 0 || i + 1 == img.width || j + 1 == img.height;
                if interior && edge {
                    continue;
                }
                let [_, q, u] = img.iqu[j * img.width + i];
                worst = worst.max(q.abs()).max(u.abs());
            }
        }
        worst
    }

    #[test]
    fn a_ramp_of_unpolarized_light_reads_unpolarized_on_every_tile() {
        // 1000 + 3x + 2y DN: exact in f32. Superpixels read a polarization of the ramp.
        let (w, h) = (12, 10);
        let dn = unpolarized(w, h, |x, y| 1000.0 + 3.0 * x + 2.0 * y);
        let plain = superpixels(&dn, w, h, &MOSAIC, &rec(), 4095.0);
        let centred = superpixels_centred(&dn, w, h, &MOSAIC, &rec(), 4095.0);
        assert!(worst_qu(&plain, false) > 1.0, "the test's control: {}", worst_qu(&plain, false));
        // Edges included: a one-sided difference is exact on a ramp too.
        assert!(worst_qu(&centred, false) < 1e-9, "{}", worst_qu(&centred, false));
        assert_eq!((centred.width, centred.height, centred.position_px(1, 1)), (6, 5, (2.5, 2.5)));
    }

    #[test]
    fn a_curved_field_leaves_q_and_u_exact_where_pairs_sit_on_a_diagonal() {
        // A quadratic with every second derivative: Q and U cancel its second order in
        // the interior; the mirrored layouts keep the pairs on diagonals.
        let (w, h) = (16, 12);
        let dn = unpolarized(w, h, |x, y| 800.0 + 2.0 * x - y + 0.25 * x * x + 0.5 * y * y - 0.5 * x * y);
        let mirrored = [[Channel::C45, Channel::C0], [Channel::C90, Channel::C135]];
        for m in [MOSAIC, mirrored] {
            let centred = superpixels_centred(&dn, w, h, &m, &rec(), 4095.0);
            assert!(worst_qu(&centred, true) < 1e-9, "{m:?}: {}", worst_qu(&centred, true));
            assert!(worst_qu(&superpixels(&dn, w, h, &m, &rec(), 4095.0), true) > 1.0);
        }
        // Pairs side by side (0° beside 90°): the second order stays.
        let side = [[Channel::C0, Channel::C90], [Channel::C45, Channel::C135]];
        assert!(worst_qu(&superpixels_centred(&dn, w, h, &side, &rec(), 4095.0), true) > 0.01);
    }

    #[test]
    fn uniform_light_reads_as_superpixels_do_and_invalid_tiles_stay_masked() {
        // Polarized, uniform: no gradient, the superpixels bit for bit.
        let (w, h) = (8, 6);
        let per_channel = |c: Channel| 500.0 + 300.0 * (2.0 * (c.angle_deg() - 30.0).to_radians()).cos();
        let mut dn: Vec<f32> = (0..w * h).map(|p| per_channel(MOSAIC[(p / w) % 2][(p % w) % 2]) as f32).collect();
        let (a, b) =
            (superpixels(&dn, w, h, &MOSAIC, &rec(), 4095.0), superpixels_centred(&dn, w, h, &MOSAIC, &rec(), 4095.0));
        assert_eq!(a.iqu, b.iqu);
        // A saturated pixel masks its own tile; the tiles beside it read their other
        // neighbour (one-sided) and stay finite.
        dn[2 * w + 2] = 4095.0;
        let c = superpixels_centred(&dn, w, h, &MOSAIC, &rec(), 4095.0);
        assert!(c.stokes(1, 1).is_none());
        for (i, j) in [(0, 1), (2, 1), (1, 0), (1, 2)] {
            let s = c.stokes(i, j).expect("a neighbour of the masked tile");
            assert_eq!([s.i, s.q, s.u], a.iqu[j * a.width + i], "({i}, {j})");
        }
        assert_eq!(c.valid_count(), 12 - 1);
    }
}
