//! Dark frames and the photon-transfer curve (EMVA 1288, release 3.1/4.0 methods).
//!
//! ```text
//! o_p       = mean of the dark frames at pixel p                       offset, DN
//! σ_dark,p  = their standard deviation (2 or more dark frames)        DN
//! y_j − o   = μ_j f_p + n_j        unpolarized flat j: PRNU f_p, temporal noise n_j
//! D_ab      = (y_a − o) − r (y_b − o),  r = μ_a/μ_b                    fixed pattern cancels
//! var D_ab  = σ_d² (1 + r² + (r−1)²) + K (μ_a + r² μ_b)                 (dark frame's noise in o)
//! ```
//!
//! A single frame per exposure has no temporal pair, so the pattern is cancelled
//! between exposures instead: each pair of flats gives one equation in the read
//! noise `σ_d²` (DN²) and the conversion gain `K` (DN/e⁻), solved by weighted least
//! squares (a variance over N pixels has relative 1σ √(2/N)). Linearity error
//! (EMVA 1288): the mean signal `μ_j` against exposure, a line through the origin,
//! `LE = (max δ − min δ)/2` of the relative deviations δ, in %. Needs a dark frame
//! and 2 exposures (K, σ_d), 3 exposures (linearity): else `Err` with the reason.

use rayon::prelude::*;

/// Offsets (and, from 2 or more dark frames, per-pixel dark noise).
#[derive(Clone, Debug)]
pub struct Dark {
    pub frames: usize,
    /// Mean of the dark frames per pixel, DN.
    pub offset_dn: Vec<f32>,
    /// Temporal standard deviation per pixel, DN (2 or more dark frames).
    pub noise_dn: Option<Vec<f32>>,
    /// Mean offset and its spread over the sensor (DSNU, 1σ), DN.
    pub mean_offset_dn: f64,
    pub dsnu_dn: f64,
}

/// One point of the photon-transfer curve.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PtcPoint {
    pub exposure_rel: f64,
    /// Mean signal above the offset, DN.
    pub mean_dn: f64,
}

/// The sensor-wide result of the exposure series.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PhotonTransfer {
    pub conversion_gain_dn_per_e: f64,
    pub conversion_gain_sigma: f64,
    pub read_noise_dn: f64,
    pub read_noise_sigma_dn: f64,
    pub points: Vec<PtcPoint>,
    /// EMVA 1288 linearity error, % (3 or more exposures), with the reason where absent.
    pub linearity_error_pct: Option<f64>,
    pub linearity_note: Option<String>,
}

/// Mean and standard deviation of `x` (sample, n − 1).
fn mean_std(x: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = x.clone().count() as f64;
    let m = x.clone().sum::<f64>() / n;
    let v = x.map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, v.sqrt())
}

/// Offsets and dark noise from `frames` (at least one, equal sizes).
pub fn dark(frames: &[Vec<f32>]) -> Dark {
    let n = frames.len();
    let len = frames[0].len();
    let offset_dn: Vec<f32> =
        (0..len).into_par_iter().map(|i| (frames.iter().map(|f| f[i] as f64).sum::<f64>() / n as f64) as f32).collect();
    let noise_dn = (n >= 2).then(|| {
        (0..len)
            .into_par_iter()
            .map(|i| {
                let m = offset_dn[i] as f64;
                (frames.iter().map(|f| (f[i] as f64 - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt() as f32
            })
            .collect()
    });
    let (mean_offset_dn, dsnu_dn) = mean_std(offset_dn.iter().map(|&x| x as f64));
    Dark { frames: n, offset_dn, noise_dn, mean_offset_dn, dsnu_dn }
}

/// The photon-transfer curve from unpolarized flats `(exposure_rel, mosaic)` with the
/// offsets of `dark`; `full_scale_dn` masks saturated pixels.
pub fn photon_transfer(flats: &[(f64, &[f32])], dark: &Dark, full_scale_dn: f64) -> Result<PhotonTransfer, String> {
    let mut exposures: Vec<f64> = flats.iter().map(|f| f.0).collect();
    exposures.sort_by(f64::total_cmp);
    exposures.dedup();
    if exposures.len() < 2 {
        return Err(format!(
            "the conversion gain and read noise need unpolarized flats at 2 or more exposures; the capture has {}",
            exposures.len()
        ));
    }
    let o = &dark.offset_dn;
    let valid = |f: &[f32], i: usize| f[i] > 0.0 && (f[i] as f64) < full_scale_dn;
    let mu: Vec<f64> = flats
        .iter()
        .map(|(_, f)| {
            let (s, n) = (0..o.len())
                .into_par_iter()
                .filter(|&i| valid(f, i))
                .map(|i| (f[i] as f64 - o[i] as f64, 1.0))
                .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
            s / n
        })
        .collect();
    // One equation per pair: var D = σ_d²·a + K·b, weight 1/(var·√(2/N))².
    let (mut ata, mut atb) = ([[0.0f64; 2]; 2], [0.0f64; 2]);
    for a in 0..flats.len() {
        for b in a + 1..flats.len() {
            let r = mu[a] / mu[b];
            let (fa, fb) = (flats[a].1, flats[b].1);
            let (s, s2, n) = (0..o.len())
                .into_par_iter()
                .filter(|&i| valid(fa, i) && valid(fb, i))
                .map(|i| {
                    let d = (fa[i] as f64 - o[i] as f64) - r * (fb[i] as f64 - o[i] as f64);
                    (d, d * d, 1.0)
                })
                .reduce(|| (0.0, 0.0, 0.0), |x, y| (x.0 + y.0, x.1 + y.1, x.2 + y.2));
            let var = (s2 - s * s / n) / (n - 1.0);
            let x = [1.0 + r * r + (r - 1.0).powi(2), mu[a] + r * r * mu[b]];
            let w = 1.0 / (var * var * 2.0 / n);
            for i in 0..2 {
                atb[i] += w * x[i] * var;
                for j in 0..2 {
                    ata[i][j] += w * x[i] * x[j];
                }
            }
        }
    }
    let det = ata[0][0] * ata[1][1] - ata[0][1] * ata[1][0];
    if det.abs() < 1e-300 || !det.is_finite() {
        return Err("the exposure series does not separate read noise from shot noise (singular)".into());
    }
    let inv = [[ata[1][1] / det, -ata[0][1] / det], [-ata[1][0] / det, ata[0][0] / det]];
    let var_d = inv[0][0] * atb[0] + inv[0][1] * atb[1];
    let k = inv[1][0] * atb[0] + inv[1][1] * atb[1];
    let read = var_d.max(0.0).sqrt();
    let read_sigma = if read > 0.0 { inv[0][0].sqrt() / (2.0 * read) } else { inv[0][0].sqrt().sqrt() };
    let mut points: Vec<PtcPoint> =
        flats.iter().zip(&mu).map(|((e, _), &m)| PtcPoint { exposure_rel: *e, mean_dn: m }).collect();
    points.sort_by(|a, b| a.exposure_rel.total_cmp(&b.exposure_rel));
    let (linearity_error_pct, linearity_note) = if points.len() >= 3 {
        let slope = points.iter().map(|p| p.exposure_rel * p.mean_dn).sum::<f64>()
            / points.iter().map(|p| p.exposure_rel * p.exposure_rel).sum::<f64>();
        let d: Vec<f64> =
            points.iter().map(|p| 100.0 * (p.mean_dn - slope * p.exposure_rel) / (slope * p.exposure_rel)).collect();
        let (lo, hi) = d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
        (Some(0.5 * (hi - lo)), None)
    } else {
        (None, Some(format!("the linearity error needs 3 or more exposures; the capture has {}", points.len())))
    };
    Ok(PhotonTransfer {
        conversion_gain_dn_per_e: k,
        conversion_gain_sigma: inv[1][1].sqrt(),
        read_noise_dn: read,
        read_noise_sigma_dn: read_sigma,
        points,
        linearity_error_pct,
        linearity_note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seeded standard normal draws (Box–Muller on a splitmix64 stream).
    fn normals(seed: u64, n: usize) -> Vec<f64> {
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n).map(|_| (-2.0 * next().max(1e-300).ln()).sqrt() * (std::f64::consts::TAU * next()).cos()).collect()
    }

    #[test]
    fn conversion_gain_read_noise_and_linearity_are_recovered() {
        // 200 000 pixels, PRNU 2 %, DSNU 3 DN, read noise 1.5 DN, K = 0.1 DN/e⁻.
        let n = 200_000;
        let (prnu, dsnu, z) = (normals(1, n), normals(2, n), normals(3, 5 * n));
        let (read, k) = (1.5, 0.1);
        let offset: Vec<f64> = (0..n).map(|i| 64.0 + 3.0 * dsnu[i]).collect();
        let frame = |j: usize, mu: f64| -> Vec<f32> {
            (0..n)
                .map(|i| {
                    let s = mu * (1.0 + 0.02 * prnu[i]);
                    (offset[i] + s + (read * read + k * s).sqrt() * z[j * n + i]) as f32
                })
                .collect()
        };
        let d = dark(&[frame(0, 0.0)]);
        assert!((d.dsnu_dn - (9.0f64 + read * read).sqrt()).abs() < 0.05, "{}", d.dsnu_dn);
        assert!(d.noise_dn.is_none());
        let flats = [(0.3, frame(1, 600.0)), (0.6, frame(2, 1200.0)), (1.2, frame(3, 2400.0))];
        let refs: Vec<(f64, &[f32])> = flats.iter().map(|(e, f)| (*e, f.as_slice())).collect();
        let p = photon_transfer(&refs, &d, 4095.0).unwrap();
        assert!((p.conversion_gain_dn_per_e - k).abs() < 4.0 * p.conversion_gain_sigma, "{p:?}");
        assert!((p.read_noise_dn - read).abs() < 4.0 * p.read_noise_sigma_dn + 0.05, "{p:?}");
        assert!(p.linearity_error_pct.unwrap() < 0.1, "{p:?}");
        let e = photon_transfer(&refs[..1], &d, 4095.0).unwrap_err();
        assert!(e.contains("2 or more exposures"), "{e}");
    }
}
