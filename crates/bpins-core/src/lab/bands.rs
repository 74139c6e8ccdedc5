//! A colour-polarization sensor's lab calibration band by band (CONVENTIONS.md:
//! `colour_tiles`, a Bayer filter over each 2 × 2 analyzer tile).
//!
//! ```text
//! ε_p  = ε_k + ε_b                    pixel p of channel k in band b (band_response)
//! g_p  = q_b (1 + γ_k) · vignetting · PRNU                     q_G = 1, γ_0 = 0
//! q_b  = mean_k ḡ(b, k) / ḡ(G, k)      ḡ(b, k): mean gain of band b's pixels of channel k
//! ε_k  = ε̄(ref, k),  ε_b = mean_k [ε̄(b, k) − ε̄(ref, k)]     ref: the band of least mean ε
//! ```
//!
//! The per-pixel Malus fit ([`super::malus`]) is the same for every pixel; what
//! changes on a colour sensor is that no mean, spread or normalisation takes pixels
//! of two bands together: each (band, channel) class is its own population. Units:
//! gains relative (q_b to the green band's, under the lab's source: a white source
//! gives the filter × QE response, EMVA 1288's η(λ)·K averaged over the band); ε
//! dimensionless. Only ε_k + ε_b is measured; its split takes the band of least mean
//! ε as ε_b = 0 (so every ε_b ≥ 0, as `band_response` requires). Photon transfer per
//! band runs on that band's pixels only (the conversion gain K is the pixel's, the
//! same in each band within its 1σ unless the filter is wrong).
//!
//! Cannot: separate a band's own vignetting (filters with angle-dependent passbands)
//! from the common one — the vignetting fit takes the band-normalised gain of all
//! pixels; a band's gain varying across the die is in its PRNU and gradient.

use super::photon_transfer::{self, Dark, PhotonTransfer};
use crate::effects::EffectSet;
use crate::pixel_analyzers::PixelMaps;
use crate::sensor::{Band, ColourTiles, Layout};

/// One band's calibration.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BandCalibration {
    pub band: String,
    pub centre_nm: f64,
    /// Pixels of the band used (not saturated or at zero).
    pub pixels: usize,
    /// Gain relative to the green band's (`q_b`) and its 1σ.
    pub qe: f64,
    pub qe_sigma: f64,
    /// Mean gain of each channel's pixels (0°, 45°, 90°, 135°), relative to the sensor mean.
    pub gain_by_channel: [f64; 4],
    /// Mean ε of each channel's pixels and its 1σ (the pixels' scatter over √n).
    pub eps_by_channel: [f64; 4],
    pub eps_sigma_by_channel: [f64; 4],
    /// Mean analyzer angle offset from nominal of each channel's pixels, degrees.
    pub analyzer_offset_deg: [f64; 4],
    /// Photo-response non-uniformity of the band's pixels about their (channel) means, %.
    pub prnu_pct: f64,
    /// Photon transfer on the band's pixels only.
    pub photon_transfer: Option<PhotonTransfer>,
}

/// Means and 1σ of `value(i)` over the good pixels of each (band, channel) class.
fn class_stats(
    colour: &ColourTiles,
    mosaic: &[[crate::sensor::Channel; 2]; 2],
    w: usize,
    n: usize,
    bad: &[bool],
    value: impl Fn(usize) -> f64,
) -> [[(f64, f64, usize); 4]; 3] {
    let mut acc = [[(0.0f64, 0.0f64, 0usize); 4]; 3];
    for i in (0..n).filter(|&i| !bad[i]) {
        let (u, v) = (i % w, i / w);
        let x = value(i);
        if !x.is_finite() {
            continue;
        }
        let a = &mut acc[colour.band_at(u, v).index()][Layout::dofp_channel(mosaic, u, v).index()];
        a.0 += x;
        a.1 += x * x;
        a.2 += 1;
    }
    acc.map(|row| {
        row.map(|(s, s2, c)| {
            let m = s / c as f64;
            let var = ((s2 - s * m) / (c as f64 - 1.0).max(1.0)).max(0.0);
            (m, (var / c as f64).sqrt(), c)
        })
    })
}

/// Each band's results from the per-pixel `maps` (gain, ε, analyzer angle; `bad`
/// pixels skipped), the unpolarized `flats` and the `dark` frames (photon transfer per
/// band; `None` without a dark), and the common `falloff(u, v)` of the flat field.
#[allow(clippy::too_many_arguments)]
pub fn band_calibration(
    colour: &ColourTiles,
    maps: &PixelMaps,
    bad: &[bool],
    flats: &[(f64, Vec<f32>)],
    dark: Option<&Dark>,
    full_scale_dn: f64,
    falloff: impl Fn(usize, usize) -> f64,
) -> Vec<BandCalibration> {
    let (w, n, mosaic) = (maps.width_px, maps.width_px * maps.height_px, maps.mosaic);
    let nan = |_: usize| f64::NAN;
    let gain = |i: usize| maps.gain.as_ref().map_or(f64::NAN, |g| g[i] as f64);
    let eps = |i: usize| maps.eps.as_ref().map_or(f64::NAN, |e| e[i] as f64);
    let offset = |i: usize| {
        maps.analyzer_deg.as_ref().map_or(f64::NAN, |a| {
            let nominal = Layout::dofp_channel(&mosaic, i % w, i / w).angle_deg();
            (a[i] as f64 - nominal + 90.0).rem_euclid(180.0) - 90.0
        })
    };
    let g = class_stats(colour, &mosaic, w, n, bad, gain);
    let e = if maps.eps.is_some() {
        class_stats(colour, &mosaic, w, n, bad, eps)
    } else {
        class_stats(colour, &mosaic, w, n, bad, nan)
    };
    let o = class_stats(colour, &mosaic, w, n, bad, offset);
    // Gain over the common falloff and that over its class mean: the PRNU per band.
    let flattened = |i: usize| gain(i) / falloff(i % w, i / w);
    let gf = class_stats(colour, &mosaic, w, n, bad, flattened);
    let flat = class_stats(colour, &mosaic, w, n, bad, |i| {
        let (u, v) = (i % w, i / w);
        flattened(i) / gf[colour.band_at(u, v).index()][Layout::dofp_channel(&mosaic, u, v).index()].0
    });
    let reference = if colour.bands().contains(&Band::G) { Band::G } else { colour.bands()[0] };
    let gr = g[reference.index()];
    colour
        .bands()
        .into_iter()
        .map(|b| {
            let k = b.index();
            // q_b: the mean over channels of the class ratio; 1σ from the classes' 1σ.
            let ratios: Vec<(f64, f64)> = (0..4)
                .map(|c| {
                    let r = g[k][c].0 / gr[c].0;
                    (r, r * ((g[k][c].1 / g[k][c].0).powi(2) + (gr[c].1 / gr[c].0).powi(2)).sqrt())
                })
                .collect();
            let qe = ratios.iter().map(|r| r.0).sum::<f64>() / 4.0;
            let qe_sigma =
                if b == reference { 0.0 } else { ratios.iter().map(|r| r.1 * r.1).sum::<f64>().sqrt() / 4.0 };
            let (s2, cnt) =
                flat[k].iter().fold((0.0, 0usize), |(s, c), x| (s + x.1 * x.1 * x.2 as f64 * x.2 as f64, c + x.2));
            let photon_transfer = dark.and_then(|d| {
                // The band's pixels only: the others set to 0, which the fit skips.
                let masked: Vec<Vec<f32>> = flats
                    .iter()
                    .map(|(_, f)| (0..n).map(|i| if colour.band_at(i % w, i / w) == b { f[i] } else { 0.0 }).collect())
                    .collect();
                let refs: Vec<(f64, &[f32])> =
                    flats.iter().zip(&masked).map(|((e, _), m)| (*e, m.as_slice())).collect();
                photon_transfer::photon_transfer(&refs, d, full_scale_dn).ok()
            });
            BandCalibration {
                band: b.name().into(),
                centre_nm: colour.centre_nm[k],
                pixels: g[k].iter().map(|x| x.2).sum(),
                qe,
                qe_sigma,
                gain_by_channel: g[k].map(|x| x.0),
                eps_by_channel: e[k].map(|x| x.0),
                eps_sigma_by_channel: e[k].map(|x| x.1),
                analyzer_offset_deg: o[k].map(|x| x.0),
                // Σ over classes of (σ_mean √n)² n ≈ Σ scatter² (n − 1): the pooled variance.
                prnu_pct: 100.0 * (s2 / cnt as f64).sqrt(),
                photon_transfer,
            }
        })
        .collect()
}

/// `gain` with each pixel divided by its (band, channel) class mean over the good
/// pixels: what is left is the falloff and the PRNU, common to the bands.
pub fn unband_gain(
    gain: &[f32],
    colour: &ColourTiles,
    mosaic: &[[crate::sensor::Channel; 2]; 2],
    w: usize,
    bad: &[bool],
) -> Vec<f32> {
    let s = class_stats(colour, mosaic, w, gain.len(), bad, |i| gain[i] as f64);
    (0..gain.len())
        .map(|i| {
            let (u, v) = (i % w, i / w);
            (gain[i] as f64 / s[colour.band_at(u, v).index()][Layout::dofp_channel(mosaic, u, v).index()].0) as f32
        })
        .collect()
}

/// The effects calibration of a colour sensor, which every route applies (the
/// per-pixel maps go in a file of their own: the compass applies them per band, the
/// fit not yet): `analyzer_angles` (each channel's mean
/// offset over every band: the analyzers are one grid under the filters),
/// `extinction_ratio` (the reference band's ε per channel), `band_response` (q_R, q_B
/// and each band's ε_b, module doc) and `channel_response` (green band's channel gains
/// relative to 0°'s). Values outside a parameter's fit bounds are an error naming it.
pub fn effects(bands: &[BandCalibration]) -> crate::Result<(EffectSet, Vec<(String, f64)>)> {
    let mut fx = EffectSet::new();
    let mut sig = Vec::new();
    let find = |name: &str| bands.iter().find(|b| b.band == name);
    let mean4 = |x: [f64; 4]| x.iter().sum::<f64>() / 4.0;
    let reference = bands
        .iter()
        .min_by(|a, b| mean4(a.eps_by_channel).total_cmp(&mean4(b.eps_by_channel)))
        .expect("a colour sensor has at least one band");
    let n_all: f64 = bands.iter().map(|b| b.pixels as f64).sum();
    for (c, name) in ["d0_deg", "d45_deg", "d90_deg", "d135_deg"].iter().enumerate() {
        let d = bands.iter().map(|b| b.analyzer_offset_deg[c] * b.pixels as f64).sum::<f64>() / n_all;
        fx.set("analyzer_angles", name, d)?;
    }
    for (c, name) in ["eps0", "eps45", "eps90", "eps135"].iter().enumerate() {
        fx.set("extinction_ratio", name, reference.eps_by_channel[c].max(0.0))?;
        sig.push((format!("extinction_ratio.{name}"), reference.eps_sigma_by_channel[c]));
    }
    for b in bands {
        let d: [f64; 4] = std::array::from_fn(|c| b.eps_by_channel[c] - reference.eps_by_channel[c]);
        let name = format!("eps_{}", b.band.to_lowercase());
        fx.set("band_response", &name, mean4(d).max(0.0))?;
        let s =
            (0..4).map(|c| b.eps_sigma_by_channel[c].powi(2) + reference.eps_sigma_by_channel[c].powi(2)).sum::<f64>();
        sig.push((format!("band_response.{name}"), if b.band == reference.band { 0.0 } else { s.sqrt() / 4.0 }));
    }
    for (band, name) in [("R", "qe_r"), ("B", "qe_b")] {
        if let Some(b) = find(band) {
            fx.set("band_response", name, b.qe)?;
            sig.push((format!("band_response.{name}"), b.qe_sigma));
        }
    }
    if let Some(gb) = find("G") {
        for (c, name) in [(1, "gain45"), (2, "gain90"), (3, "gain135")] {
            fx.set("channel_response", name, gb.gain_by_channel[c] / gb.gain_by_channel[0] - 1.0)?;
        }
    }
    Ok((fx, sig))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::DEFAULT_MOSAIC;

    /// Maps of a 16 × 8 RGGB sensor with ε = ε_k + ε_b and gain q_b (1 + γ_k), one bad
    /// pixel holding nonsense: each band's figures are its own pixels', and the split
    /// of ε puts the least-ε band at 0.
    #[test]
    fn each_band_is_read_from_its_own_pixels_and_split_into_effects() {
        let (w, h) = (16, 8);
        let colour = ColourTiles::imx250myr();
        let (eps_k, gamma_k) = ([0.01, 0.02, 0.005, 0.015], [0.0, 0.02, -0.01, 0.01]);
        let (qe, eps_b) = ([0.8, 1.0, 0.6], [0.004, 0.001, 0.012]);
        let mut maps = PixelMaps::nominal(w, h, DEFAULT_MOSAIC);
        let class = |i: usize| {
            let (u, v) = (i % w, i / w);
            (colour.band_at(u, v).index(), Layout::dofp_channel(&DEFAULT_MOSAIC, u, v))
        };
        maps.eps = Some((0..w * h).map(|i| (eps_k[class(i).1.index()] + eps_b[class(i).0]) as f32).collect());
        maps.gain = Some((0..w * h).map(|i| (qe[class(i).0] * (1.0 + gamma_k[class(i).1.index()])) as f32).collect());
        maps.analyzer_deg = Some((0..w * h).map(|i| (class(i).1.angle_deg() + 0.3) as f32).collect());
        let mut bad = vec![false; w * h];
        bad[5] = true;
        maps.eps.as_mut().unwrap()[5] = 0.4;
        let bands = band_calibration(&colour, &maps, &bad, &[], None, 4095.0, |_, _| 1.0);
        assert_eq!(bands.iter().map(|b| b.band.as_str()).collect::<Vec<_>>(), ["R", "G", "B"]);
        for (b, k) in bands.iter().zip(0..3) {
            assert!((b.qe - qe[k] / qe[1]).abs() < 1e-6, "{b:?}");
            for (c, e) in eps_k.iter().enumerate() {
                assert!((b.eps_by_channel[c] - (e + eps_b[k])).abs() < 1e-6, "{b:?}");
                assert!((b.analyzer_offset_deg[c] - 0.3).abs() < 1e-4, "{b:?}");
            }
            assert!(b.prnu_pct < 1e-3 && b.photon_transfer.is_none(), "{b:?}");
        }
        let (fx, _) = effects(&bands).unwrap();
        // G has the least ε: ε_k = ε_k + 0.001, ε_R = 0.003, ε_B = 0.011.
        assert!((fx.get("extinction_ratio", "eps45").unwrap() - 0.021).abs() < 1e-6);
        assert!((fx.get("band_response", "eps_r").unwrap() - 0.003).abs() < 1e-6);
        assert!((fx.get("band_response", "eps_b").unwrap() - 0.011).abs() < 1e-6);
        assert!((fx.get("band_response", "qe_b").unwrap() - 0.6).abs() < 1e-6);
        assert!((fx.get("channel_response", "gain45").unwrap() - 0.02).abs() < 1e-6);
        assert!((fx.get("analyzer_angles", "d90_deg").unwrap() - 0.3).abs() < 1e-4);
    }
}
