//! Colour-polarization mosaics, which bpins does not read yet: a capture that says it
//! is one is refused by name, and a monochrome DoFP frame whose 2 × 2 tiles alternate
//! in brightness as a colour sensor's do is refused too, so that a user who deletes
//! `colour_tiles` to get past the first refusal does not get a confident wrong heading.
//!
//! What: CONVENTIONS.md's colour layout puts each 2 × 2 analyzer tile under one filter
//! of a Bayer pattern (Sony IMX250MYR: `[["R", "G"], ["G", "B"]]`), so a tile's sum
//! S0 = I0 + I45 + I90 + I135 (twice the Stokes S0, DN above black) takes one band's
//! radiance × QE, and the tiles alternate with a period of two tiles (4 px) in both
//! directions. On a monochrome sensor the four tile classes, `(tile row mod 2, tile
//! column mod 2)`, sample one smooth field shifted by 2 px, so their means agree to
//! the field's gradient over 2 px (0.2 % for a 2× brightening across 612 px).
//!
//! The test: each class's mean tile S0 over the frame against the four classes'
//! mean; a class off by more than [`COLOUR_PERIOD_LIMIT`] names the frame a colour
//! mosaic. A raw colour sensor's bands differ by tens of per cent under any daylight
//! sky (the samples' colour capture: R 0.49, G 1.00, B 0.85 of G), so the limit sits
//! far from both.
//!
//! Frame: the mosaic as stored (row v, column u; CONVENTIONS.md). Units: DN.
//!
//! Cannot: see a colour sensor whose bands happen to be equally bright in this frame
//! (grey light through a white-balanced filter set), or tell which colour order it has;
//! frames with less than [`MIN_SIGNAL_FRACTION`] of full scale above black are not
//! judged.

/// A tile class's mean S0 differing from the four classes' mean by more than this
/// fraction marks a colour mosaic.
pub const COLOUR_PERIOD_LIMIT: f64 = 0.05;

/// Frames whose mean signal above black is below this fraction of full scale are not
/// judged (their class means are noise).
pub const MIN_SIGNAL_FRACTION: f64 = 0.01;

/// What the test found in a frame that looks like a colour mosaic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColourPeriod {
    /// Each tile class's mean S0 over the four classes' mean, by
    /// `[tile row mod 2][tile column mod 2]`.
    pub class_ratio: [[f64; 2]; 2],
}

impl std::fmt::Display for ColourPeriod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = &self.class_ratio;
        write!(
            f,
            "its 2×2 tiles alternate in brightness with a 4-pixel period (tile classes [[{:.2}, {:.2}], [{:.2}, {:.2}]] \
             of their mean), as a colour-polarization sensor's do (CONVENTIONS.md: `colour_tiles`, a filter over \
             each analyzer tile); bpins does not read colour-polarization captures yet, and reading one as \
             monochrome mixes the bands' polarization",
            r[0][0], r[0][1], r[1][0], r[1][1]
        )
    }
}

/// The colour-period test on a DoFP mosaic (`dn[v·W + u]`, DN), black level and full
/// scale in DN: `Some` where the tiles alternate as a colour sensor's.
pub fn colour_period(
    dn: &[f32],
    width_px: usize,
    height_px: usize,
    black_dn: f64,
    full_dn: f64,
) -> Option<ColourPeriod> {
    let (tw, th) = (width_px / 2, height_px / 2);
    if tw < 2 || th < 2 || dn.len() < width_px * height_px {
        return None;
    }
    // Step 1: each tile's S0 above black, summed per class (row and column of the tile, mod 2).
    let mut sum = [[0.0f64; 2]; 2];
    let mut count = [[0usize; 2]; 2];
    for ty in 0..th {
        let (r0, r1) = (2 * ty * width_px, (2 * ty + 1) * width_px);
        let mut row = [0.0f64; 2];
        for tx in 0..tw {
            let u = 2 * tx;
            let s0 =
                dn[r0 + u] as f64 + dn[r0 + u + 1] as f64 + dn[r1 + u] as f64 + dn[r1 + u + 1] as f64 - 4.0 * black_dn;
            row[tx % 2] += s0;
        }
        for c in 0..2 {
            sum[ty % 2][c] += row[c];
            count[ty % 2][c] += tw / 2 + if c == 0 { tw % 2 } else { 0 };
        }
    }
    // Step 2: the class means against their mean; a dark frame is not judged.
    let mean = |r: usize, c: usize| sum[r][c] / count[r][c].max(1) as f64;
    let all = (mean(0, 0) + mean(0, 1) + mean(1, 0) + mean(1, 1)) / 4.0;
    if !(all > 4.0 * MIN_SIGNAL_FRACTION * (full_dn - black_dn).max(1.0)) {
        return None;
    }
    let class_ratio = [[mean(0, 0) / all, mean(0, 1) / all], [mean(1, 0) / all, mean(1, 1) / all]];
    let off = class_ratio.iter().flatten().any(|r| (r - 1.0).abs() > COLOUR_PERIOD_LIMIT);
    off.then_some(ColourPeriod { class_ratio })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth sky-like field: brighter toward one corner, 2× across the frame.
    fn field(w: usize, h: usize, band: impl Fn(usize, usize) -> f64) -> Vec<f32> {
        let mut dn = vec![0f32; w * h];
        for v in 0..h {
            for u in 0..w {
                let base = 400.0 * (1.0 + u as f64 / w as f64) * (1.0 + 0.3 * v as f64 / h as f64);
                // The analyzers' modulation within a tile (polarized light, 30 %).
                let m = 1.0 + 0.3 * [1.0, 0.0, -1.0, 0.0][(v % 2) * 2 + (u % 2)];
                dn[v * w + u] = (64.0 + base * m * band(v, u)) as f32;
            }
        }
        dn
    }

    #[test]
    fn a_monochrome_field_with_a_gradient_passes() {
        let dn = field(612, 512, |_, _| 1.0);
        assert_eq!(colour_period(&dn, 612, 512, 64.0, 4095.0), None);
        // Odd tile counts too.
        let dn = field(610, 506, |_, _| 1.0);
        assert_eq!(colour_period(&dn, 610, 506, 64.0, 4095.0), None);
    }

    #[test]
    fn an_rggb_mosaic_is_named_with_its_class_ratios() {
        // IMX250MYR order: [[R, G], [G, B]] over the tiles, the samples' band scales.
        let gain = [[0.30, 0.60], [0.60, 0.50]];
        let dn = field(408, 340, |v, u| gain[(v / 2) % 2][(u / 2) % 2]);
        let p = colour_period(&dn, 408, 340, 64.0, 4095.0).expect("a colour mosaic");
        let r = p.class_ratio;
        assert!((r[0][0] / r[0][1] - 0.5).abs() < 0.02 && (r[1][1] / r[1][0] - 0.833).abs() < 0.02, "{r:?}");
        assert!(p.to_string().contains("colour_tiles"));
    }

    #[test]
    fn a_band_pair_just_inside_the_limit_passes_and_a_dark_frame_is_not_judged() {
        let dn = field(200, 200, |v, u| if (v / 2) % 2 == 0 && (u / 2) % 2 == 0 { 1.03 } else { 1.0 });
        assert_eq!(colour_period(&dn, 200, 200, 64.0, 4095.0), None);
        let dn = field(200, 200, |v, u| if (v / 2) % 2 == 0 && (u / 2) % 2 == 0 { 1.3 } else { 1.0 });
        assert!(colour_period(&dn, 200, 200, 64.0, 4095.0).is_some());
        let dark: Vec<f32> = (0..200 * 200).map(|i| 64.0 + [0.0, 3.0][(i / 2) % 2]).collect();
        assert_eq!(colour_period(&dark, 200, 200, 64.0, 4095.0), None);
    }
}
