//! polanalyser's edge-aware demosaics (`COLOR_PolarMono_EA`, `COLOR_PolarRGB_EA`):
//! OpenCV's `cvtColor(…, COLOR_Bayer**2BGR_EA)` in place of its bilinear Bayer demosaic,
//! as [`super::Interpolation::OpenCvEa`] reproduces them (`uint8` and `uint16` mosaics,
//! bit for bit on the demosaiced channels).
//!
//! What OpenCV's edge-aware Bayer demosaic computes (its current
//! `imgproc/src/demosaicing.cpp`, `Bayer2RGB_EdgeAware_T`; checked against cv2 5.0.0
//! on impulses, ramps, edges, ties and random `uint8`/`uint16` frames of odd and even
//! sizes, for BG, GR, RG and GB):
//!
//! ```text
//! interior pixel (1 ≤ x ≤ w − 2, 1 ≤ y ≤ h − 2), W E N S its 4 neighbours, samples whole DN:
//!   own colour                         its sample
//!   green site, the other two          (W + E + 1) >> 1 along its row, (N + S + 1) >> 1 along its column
//!   red/blue site, the other of them   (NW + NE + SW + SE + 2) >> 2
//!   red/blue site, green               |W − E| > |S − N| ? (N + S + 1) >> 1 : (W + E + 1) >> 1
//! border: column 0 a copy of column 1, column w − 1 of w − 2, then row 0 of row 1 and
//!   row h − 1 of row h − 2 (as the bilinear one); a frame of ≤ 2 rows or columns is all 0
//! ```
//!
//! Only green at a red or blue site differs from OpenCV's bilinear demosaic (which takes
//! `(W + E + N + S + 2) >> 2` there), interpolated along the direction of the smaller
//! difference; a tie takes the row. (An older OpenCV divided with truncation, `/ 2`,
//! `/ 4`; cv2 5.0.0 rounds half up as above, as its bilinear demosaic does.) Consequences:
//!
//! - **mono** (`COLOR_PolarMono_EA`): polanalyser keeps the blue and red channels of
//!   `BayerBG2BGR_EA` (0°, 90°) and `BayerGR2BGR_EA` (45°, 135°) and drops green. Blue
//!   and red are the bilinear demosaic's to the bit, so the mono edge-aware maps are the
//!   mono opencv maps: the same row kernel, no second one.
//! - **colour** (`COLOR_PolarRGB_EA`): stage 1 keeps all three channels of each
//!   analyzer plane's `BayerBG2BGR_EA`, so the band on two diagonal tiles (green on the
//!   IMX250MYR) is interpolated edge-aware between its sites ([`edge_aware_between`]);
//!   the bands on one tile and stage 2 (mono, above) are the opencv route's.
//!
//! `COLOR_Bayer**2BGR_VNG` (and so polanalyser's `_VNG` codes) is 8-bit only in this
//! OpenCV (cv2 5.0.0 asserts `depth == CV_8U` for a `uint16` frame) and is not built.
//!
//! Float samples (polanalyser rescales them to `uint16` first; not reproduced) take
//! the plain means, unrounded, and the same edge-aware choice.

use super::opencv_mean;

/// Stage 1 of the colour edge-aware route on a row of one band on two diagonal tiles:
/// at each of the `n` pixel columns, the band's own sample `m0[k]` where `own[k]`,
/// else the mean of its row neighbours `ml`, `mr` or, if their difference is larger
/// than that of its column neighbours `u0`, `d0`, of those (module docs; neighbours
/// in the analyzer plane, two pixels away). `INT`: means rounded half up to whole DN.
/// A select, not a branch, so that the loop vectorizes.
#[inline(always)]
pub(crate) fn edge_aware_between<const INT: bool>(
    own: &[bool],
    [ml, m0, mr]: [&[f32]; 3],
    [u0, d0]: [&[f32]; 2],
    out: &mut [f32],
) {
    let n = out.len();
    let (own, ml, m0, mr, u0, d0) = (&own[..n], &ml[..n], &m0[..n], &mr[..n], &u0[..n], &d0[..n]);
    for k in 0..n {
        let along_row = opencv_mean::<INT>(ml[k] + mr[k], 2.0);
        let along_col = opencv_mean::<INT>(u0[k] + d0[k], 2.0);
        let nb = if (ml[k] - mr[k]).abs() > (d0[k] - u0[k]).abs() { along_col } else { along_row };
        out[k] = if own[k] { m0[k] } else { nb };
    }
}
