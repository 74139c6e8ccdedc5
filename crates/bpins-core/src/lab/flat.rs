//! Flat field and vignetting from the per-pixel gain (EMVA 1288 non-uniformity).
//!
//! ```text
//! gain_p ≈ s_k · (1 + v2 r² + v4 r⁴) · f_p      r = |pixel − principal point| / f_px (focal lengths)
//! ```
//!
//! The radial falloff is the `vignetting` effect's polynomial (EFFECTS.md), fitted
//! by linear least squares to 8 × 8-pixel block means (each block holds every channel
//! alike, so per-channel gains `s_k` average out); 1σ from the blocks' scatter about
//! the fit. PRNU is what is left per pixel: the standard deviation of `gain_p` over
//! its channel's mean times the falloff, in %.

/// The flat field's smooth part and what is left per pixel.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FlatField {
    pub v2: f64,
    pub v2_sigma: f64,
    pub v4: f64,
    pub v4_sigma: f64,
    /// Photo-response non-uniformity left after the falloff and the channel means, %.
    pub prnu_pct: f64,
}

/// Fits the falloff to `gain` (`w × h`, row-major) of a lens with `f_px`, principal
/// point `(cx, cy)` px; `channel_of(u, v)` the pixel's channel index.
pub fn flat_field(
    gain: &[f32],
    w: usize,
    h: usize,
    f_px: f64,
    cx: f64,
    cy: f64,
    channel_of: impl Fn(usize, usize) -> usize,
) -> FlatField {
    let b = 8;
    let (mut ata, mut atb, mut rows) = ([[0.0f64; 3]; 3], [0.0f64; 3], Vec::new());
    for bj in 0..h / b {
        for bi in 0..w / b {
            let mut s = 0.0;
            for v in bj * b..(bj + 1) * b {
                for u in bi * b..(bi + 1) * b {
                    s += gain[v * w + u] as f64;
                }
            }
            let m = s / (b * b) as f64;
            let (x, y) = ((bi * b) as f64 + 3.5 - cx, (bj * b) as f64 + 3.5 - cy);
            let r2 = (x * x + y * y) / (f_px * f_px);
            let a = [1.0, r2, r2 * r2];
            for i in 0..3 {
                atb[i] += a[i] * m;
                for j in 0..3 {
                    ata[i][j] += a[i] * a[j];
                }
            }
            rows.push((a, m));
        }
    }
    let inv = invert3(ata);
    let c: Vec<f64> = (0..3).map(|i| (0..3).map(|j| inv[i][j] * atb[j]).sum()).collect();
    let n = rows.len() as f64;
    let rss: f64 = rows.iter().map(|(a, m)| (m - (a[0] * c[0] + a[1] * c[1] + a[2] * c[2])).powi(2)).sum();
    let s2 = rss / (n - 3.0).max(1.0);
    let (v2, v4) = (c[1] / c[0], c[2] / c[0]);
    // 1σ of the ratios (the scale's own error is negligible against the slopes').
    let (v2_sigma, v4_sigma) = ((inv[1][1] * s2).sqrt() / c[0], (inv[2][2] * s2).sqrt() / c[0]);
    // PRNU: the gain over its channel's mean and the falloff.
    let falloff = |u: usize, v: usize| {
        let (x, y) = (u as f64 - cx, v as f64 - cy);
        let r2 = (x * x + y * y) / (f_px * f_px);
        1.0 + v2 * r2 + v4 * r2 * r2
    };
    let mut sums = [(0.0f64, 0.0f64, 0.0f64); 4];
    for v in 0..h {
        for u in 0..w {
            let x = gain[v * w + u] as f64 / falloff(u, v);
            let k = channel_of(u, v);
            sums[k].0 += 1.0;
            sums[k].1 += x;
            sums[k].2 += x * x;
        }
    }
    let mut var = 0.0;
    let mut n_all = 0.0;
    for (n, s, s2) in sums {
        if n > 1.0 {
            let m = s / n;
            var += (s2 - s * m) / (m * m);
            n_all += n - 1.0;
        }
    }
    FlatField { v2, v2_sigma, v4, v4_sigma, prnu_pct: 100.0 * (var / n_all).sqrt() }
}

pub(crate) fn invert3(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    // Columns of (mᵀ)⁻¹ = (m⁻¹)ᵀ are the rows of m⁻¹.
    glam::DMat3::from_cols_array_2d(&m).inverse().to_cols_array_2d()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_radial_falloff_and_a_pixel_pattern_are_told_apart() {
        let (w, h, f) = (160, 128, 100.0);
        let (cx, cy) = (79.5, 63.5);
        let gain: Vec<f32> = (0..w * h)
            .map(|i| {
                let (u, v) = ((i % w) as f64, (i / w) as f64);
                let r2 = ((u - cx).powi(2) + (v - cy).powi(2)) / (f * f);
                let pattern = if (i * 7919) % 3 == 0 { 1.01 } else { 0.995 };
                ((1.0 - 0.25 * r2) * pattern) as f32
            })
            .collect();
        let ff = flat_field(&gain, w, h, f, cx, cy, |u, v| (u & 1) + 2 * (v & 1));
        assert!((ff.v2 + 0.25).abs() < 0.01 && ff.v4.abs() < 0.02, "{ff:?}");
        // The pattern 1.01 / 0.995 in 1 : 2 has σ = 0.707 %.
        assert!((ff.prnu_pct - 0.707).abs() < 0.05, "{ff:?}");
    }
}
