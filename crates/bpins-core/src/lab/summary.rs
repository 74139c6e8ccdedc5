//! Per-channel summaries of a per-pixel map: mean, white spread and gradient across
//! the die, each with its 1σ.
//!
//! ```text
//! value_p = m + g_x·(x/W − ½) + g_y·(y/H − ½) + e_p       per channel, least squares
//! spread  = std of e_p (n − 3 dof);  σ(m) = spread/√n;  σ(g_x) = spread/√Σ(x/W − ½ − x̄)²
//! ```
//!
//! `g_x`, `g_y` are the change of the value across the whole width and height (the
//! unit of the map). For analyzer angles the value is the offset from the channel's
//! nominal angle, degrees.

use crate::sensor::{Channel, Layout};

/// One channel's summary of one map.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ChannelSummary {
    pub channel_deg: f64,
    pub quantity: String,
    pub unit: String,
    pub pixels: usize,
    pub mean: f64,
    pub mean_sigma: f64,
    /// Standard deviation about the fitted plane (the white spread).
    pub spread: f64,
    pub gradient_x: f64,
    pub gradient_x_sigma: f64,
    pub gradient_y: f64,
    pub gradient_y_sigma: f64,
    /// RMS of the per-pixel 1σ of the map, where known (what the noise allows).
    pub pixel_sigma_rms: Option<f64>,
}

/// Summaries of `values(u, v, i)` per channel of `mosaic` over a `w × h` sensor;
/// `sigma` the per-pixel 1σ map, where known.
pub fn summarize(
    quantity: &str,
    unit: &str,
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    values: impl Fn(usize, usize, usize) -> f64,
    sigma: Option<&[f32]>,
) -> Vec<ChannelSummary> {
    Channel::ALL
        .iter()
        .map(|&ch| {
            // Normal equations of [1, x, y] with x = u/W − ½, y = v/H − ½.
            let mut a = [[0.0f64; 3]; 3];
            let mut b = [0.0f64; 3];
            let (mut n, mut s2sig) = (0usize, 0.0f64);
            let mut pts = Vec::new();
            for v in 0..h {
                for u in 0..w {
                    if Layout::dofp_channel(mosaic, u, v) != ch {
                        continue;
                    }
                    let i = v * w + u;
                    let z = values(u, v, i);
                    if !z.is_finite() {
                        continue;
                    }
                    let r = [1.0, (u as f64 + 0.5) / w as f64 - 0.5, (v as f64 + 0.5) / h as f64 - 0.5];
                    for p in 0..3 {
                        b[p] += r[p] * z;
                        for q in 0..3 {
                            a[p][q] += r[p] * r[q];
                        }
                    }
                    if let Some(s) = sigma {
                        s2sig += (s[i] as f64).powi(2);
                    }
                    n += 1;
                    pts.push((r, z));
                }
            }
            let inv = super::flat::invert3(a);
            let c: Vec<f64> = (0..3).map(|p| (0..3).map(|q| inv[p][q] * b[q]).sum()).collect();
            let rss: f64 = pts.iter().map(|(r, z)| (z - (c[0] + c[1] * r[1] + c[2] * r[2])).powi(2)).sum();
            let s2 = rss / (n as f64 - 3.0).max(1.0);
            ChannelSummary {
                channel_deg: ch.angle_deg(),
                quantity: quantity.into(),
                unit: unit.into(),
                pixels: n,
                mean: c[0],
                mean_sigma: (inv[0][0] * s2).sqrt(),
                spread: s2.sqrt(),
                gradient_x: c[1],
                gradient_x_sigma: (inv[1][1] * s2).sqrt(),
                gradient_y: c[2],
                gradient_y_sigma: (inv[2][2] * s2).sqrt(),
                pixel_sigma_rms: sigma.map(|_| (s2sig / n as f64).sqrt()),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::DEFAULT_MOSAIC;

    #[test]
    fn mean_gradient_and_spread_per_channel() {
        let (w, h) = (200, 100);
        let vals = |u: usize, v: usize, _i: usize| {
            let ch = Layout::dofp_channel(&DEFAULT_MOSAIC, u, v).index() as f64;
            let noise = if (u / 2 + v / 2) % 2 == 0 { 0.3 } else { -0.3 };
            ch + 0.6 * ((u as f64 + 0.5) / w as f64 - 0.5) - 0.4 * ((v as f64 + 0.5) / h as f64 - 0.5) + noise
        };
        let s = summarize("x", "deg", w, h, &DEFAULT_MOSAIC, vals, None);
        for (k, c) in s.iter().enumerate() {
            assert!((c.mean - k as f64).abs() < 0.01, "{c:?}");
            assert!((c.gradient_x - 0.6).abs() < 0.05 && (c.gradient_y + 0.4).abs() < 0.05, "{c:?}");
            assert!((c.spread - 0.3).abs() < 0.01, "{c:?}");
            assert!(c.mean_sigma < 0.01 && c.gradient_x_sigma < 0.05);
        }
    }
}
