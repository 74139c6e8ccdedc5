//! Lab calibration of a DoFP sensor (`bpins calibrate`): from a lab capture
//! ([`crate::capture::LabCapture`]) to per-pixel maps ([`PixelMaps`]) and the
//! sensor-wide EMVA 1288 figures, each with its 1σ.
//!
//! | step | from | gives | module |
//! |---|---|---|---|
//! | offsets | dark frames (else the intercept of the exposure series, else the nominal black level) | `offset_dn`, DSNU, dark noise per pixel (2+ darks) | [`photon_transfer`] |
//! | Malus fit | flats through the polarizer, 3+ distinct angles | `analyzer_deg`, `eps`, `gain` per pixel, 1σ | [`malus`] |
//! | photon transfer | unpolarized flats, 2+ exposures, a dark | K (DN/e⁻), read noise, linearity error (3+) | [`photon_transfer`] |
//! | flat field | the gain map (else the brightest unsaturated unpolarized flat) | vignetting v2, v4, PRNU | [`flat`] |
//! | summary | the maps | per channel mean, spread, gradient across the die | [`summary`] |
//! | bands (colour sensor) | the maps, flats, darks | per band: gain q_b, ε per channel, PRNU, photon transfer | [`bands`] |
//!
//! On a colour-polarization sensor (`colour_tiles`) every summary is per band and
//! channel (the quantity named with its band, e.g. `extinction ratio ε [B]`) and the
//! flat field is fitted to the gain over each (band, channel) mean: no figure mixes
//! the bands.
//!
//! A quantity the capture cannot determine is left out with the reason
//! ([`LabCalibration::left_out`]); nothing is guessed. A pixel saturated or at zero in
//! any frame it needs takes its channel's mean (on a colour sensor, its band's
//! channel's; counted in `left_out`).

pub mod bands;
pub mod flat;
pub mod malus;
pub mod output;
pub mod photon_transfer;
pub mod report;
pub mod simulate;
pub mod summary;

use crate::capture::LabCapture;
use crate::pixel_analyzers::{PixelMaps, EPS_MAP_MIN};
use crate::sensor::{Layout, DEFAULT_MOSAIC};
use crate::Result;
use flat::FlatField;
use photon_transfer::{Dark, PhotonTransfer};
use rayon::prelude::*;
use summary::ChannelSummary;

/// A quantity the capture could not determine, and why.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LeftOut {
    pub quantity: String,
    pub reason: String,
}

/// Per-pixel 1σ of the Malus maps.
#[derive(Clone, Debug, Default)]
pub struct SigmaMaps {
    pub analyzer_deg: Vec<f32>,
    pub eps: Vec<f32>,
    pub gain: Vec<f32>,
}

/// Everything `calibrate` measured.
#[derive(Clone, Debug)]
pub struct LabCalibration {
    pub maps: PixelMaps,
    pub sigma: Option<SigmaMaps>,
    pub dark: Option<Dark>,
    pub photon_transfer: Option<PhotonTransfer>,
    pub flat: Option<FlatField>,
    /// Per channel summaries of each measured map.
    pub summary: Vec<ChannelSummary>,
    /// Residual 1σ of the Malus fit per channel (DN, at unit exposure), where fitted.
    pub malus_residual_dn: Option<[f64; 4]>,
    /// Where the offsets came from.
    pub offset_source: String,
    /// A colour-polarization sensor's results per band (`None`: monochrome).
    pub bands: Option<Vec<bands::BandCalibration>>,
    pub left_out: Vec<LeftOut>,
}

/// Calibrates `lab`; `progress(done, total)` after each frame read.
pub fn calibrate(lab: &LabCapture, progress: &dyn Fn(usize, usize)) -> Result<LabCalibration> {
    let g = &lab.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let n = w * h;
    let mosaic = match &lab.sensor.layout {
        Layout::Dofp { mosaic } => *mosaic,
        Layout::Colocated { .. } => DEFAULT_MOSAIC,
    };
    let full = lab.sensor.full_scale_dn();
    let black = lab.sensor.black_level_dn;
    let total = lab.frames.len();
    let mut done = 0;
    let mut read = |i: usize| -> Result<Vec<f32>> {
        let f = lab.read_frame(i);
        done += 1;
        progress(done, total);
        f
    };
    let mut left_out = Vec::new();
    let mut leave = |q: &str, r: String| left_out.push(LeftOut { quantity: q.into(), reason: r });
    let idx = |p: &dyn Fn(&crate::capture::LabFrame) -> bool| -> Vec<usize> {
        lab.frames.iter().enumerate().filter(|(_, f)| p(f)).map(|(i, _)| i).collect()
    };
    let darks = idx(&|f| f.dark);
    let pols = idx(&|f| !f.dark && f.polarizer_angle_deg.is_some());
    let unpols = idx(&|f| !f.dark && f.polarizer_angle_deg.is_none());
    // A pixel is bad where any frame it needs is saturated or at zero.
    let mut bad = vec![false; n];
    let mark = |bad: &mut Vec<bool>, dn: &[f32]| {
        bad.par_iter_mut().zip(dn.par_iter()).for_each(|(b, &x)| *b |= !(x > 0.0 && (x as f64) < full));
    };

    // Offsets.
    let unpol_frames: Vec<(f64, Vec<f32>)> =
        unpols.iter().map(|&i| Ok((lab.frames[i].exposure_rel, read(i)?))).collect::<Result<_>>()?;
    let dark = if darks.is_empty() {
        None
    } else {
        Some(photon_transfer::dark(&darks.iter().map(|&i| read(i)).collect::<Result<Vec<_>>>()?))
    };
    let mut exposures: Vec<f64> = unpol_frames.iter().map(|f| f.0).collect();
    exposures.sort_by(f64::total_cmp);
    exposures.dedup();
    let (offset_dn, offset_source) = match &dark {
        Some(d) => (d.offset_dn.clone(), format!("mean of {} dark frame(s)", d.frames)),
        None if exposures.len() >= 2 => {
            (intercepts(&unpol_frames, n), "intercept of the unpolarized exposure series (no dark frame)".into())
        }
        None => {
            leave("offset_dn", "no dark frame and fewer than 2 exposures: offsets are the nominal black level".into());
            (vec![black as f32; n], format!("nominal black level {black} DN"))
        }
    };
    match &dark {
        Some(d) if d.noise_dn.is_none() => {
            leave("dark_noise_dn (per pixel)", "needs 2 or more dark frames; the capture has 1".into())
        }
        None => leave("dark_noise_dn, dsnu_dn", "the capture has no dark frame".into()),
        _ => {}
    }

    // Malus fit.
    let mut sums = malus::MalusSums::new(n);
    let mut angles = Vec::new();
    for &i in &pols {
        let f = &lab.frames[i];
        let dn = read(i)?;
        mark(&mut bad, &dn);
        let a = f.polarizer_angle_deg.unwrap_or(0.0);
        angles.push(a);
        sums.add(&dn, &offset_dn, a, f.source_dolp, f.exposure_rel);
    }
    let mut maps = PixelMaps::nominal(w, h, mosaic);
    let mut sigma = None;
    let mut malus_residual_dn = None;
    let fit = sums.solve(&angles);
    // Photon transfer.
    let photon_transfer = match &dark {
        None => {
            leave("conversion gain, read noise, linearity", "photon transfer needs a dark frame".into());
            None
        }
        Some(d) => {
            let refs: Vec<(f64, &[f32])> = unpol_frames.iter().map(|(e, f)| (*e, f.as_slice())).collect();
            match photon_transfer::photon_transfer(&refs, d, full) {
                Ok(p) => {
                    if let Some(note) = &p.linearity_note {
                        leave("linearity error", note.clone());
                    }
                    Some(p)
                }
                Err(why) => {
                    leave("conversion gain, read noise, linearity", why);
                    None
                }
            }
        }
    };

    let chan = |i: usize| Layout::dofp_channel(&mosaic, i % w, i / w).index();
    // A bad pixel's stand-in class: its channel, and on a colour sensor its band too.
    let class = |i: usize| chan(i) + 4 * lab.sensor.colour.as_ref().map_or(0, |c| c.band_at(i % w, i / w).index());
    match fit {
        Ok(fit) => {
            // Pooled residual variance per channel (good pixels).
            let mut pool = [(0.0f64, 0.0f64); 4];
            for i in 0..n {
                if !bad[i] && fit.resid_var[i].is_finite() {
                    pool[chan(i)].0 += fit.resid_var[i];
                    pool[chan(i)].1 += 1.0;
                }
            }
            let var_k = pool.map(|(s, c)| if c > 0.0 { s / c } else { f64::NAN });
            malus_residual_dn = Some(var_k.map(f64::sqrt));
            // The noise model: photon transfer's, else each channel's residual taken as
            // shot noise of its mean signal (K_eff = σ²/ȳ).
            // The offset's own 1σ: the dark frames' read noise over their number (not
            // known without photon transfer or 2+ dark frames: then left out).
            let offset_sigma_dn = match (&dark, &photon_transfer) {
                (Some(d), Some(p)) => p.read_noise_dn / (d.frames as f64).sqrt(),
                (Some(d), None) => d.noise_dn.as_ref().map_or(0.0, |m| {
                    (m.iter().map(|&x| (x as f64).powi(2)).sum::<f64>() / m.len() as f64 / d.frames as f64).sqrt()
                }),
                _ => 0.0,
            };
            let noise_k: Vec<malus::PixelNoise> = (0..4)
                .map(|k| match &photon_transfer {
                    Some(p) => malus::PixelNoise {
                        read_noise_dn: p.read_noise_dn,
                        k_dn_per_e: p.conversion_gain_dn_per_e,
                        offset_sigma_dn,
                    },
                    None => {
                        let (s, c) = (0..n)
                            .filter(|&i| !bad[i] && chan(i) == k)
                            .fold((0.0, 0.0), |(s, c), i| (s + fit.coef[i][0], c + 1.0));
                        malus::PixelNoise { read_noise_dn: 0.0, k_dn_per_e: var_k[k] / (s / c), offset_sigma_dn }
                    }
                })
                .collect();
            let per_px: Vec<([f64; 3], [f64; 3])> = (0..n)
                .into_par_iter()
                .map(|i| malus::analyzer_of(fit.coef[i], &fit.coef_cov(i, &noise_k[chan(i)])))
                .collect();
            let mean_g = mean_good(&bad, |i| per_px[i].0[0]);
            let classes = if lab.sensor.colour.is_some() { 12 } else { 4 };
            let ch_means: Vec<[f64; 3]> = (0..classes)
                .map(|k| {
                    let pick = |j: usize| {
                        let (cnt, s) = (0..n)
                            .filter(|&i| !bad[i] && class(i) == k)
                            .fold((0.0, 0.0), |(c, s), i| (c + 1.0, s + per_px[i].0[j]));
                        s / cnt
                    };
                    [pick(0), pick(1), pick(2)]
                })
                .collect();
            let val = |i: usize, j: usize| if bad[i] { ch_means[class(i)][j] } else { per_px[i].0[j] };
            maps.gain = Some((0..n).map(|i| (val(i, 0) / mean_g) as f32).collect());
            // Unclamped at 0: an unbiased estimate of a small ε (`EPS_MAP_MIN`).
            maps.eps = Some((0..n).map(|i| val(i, 1).clamp(EPS_MAP_MIN, 0.999) as f32).collect());
            maps.analyzer_deg = Some(
                (0..n)
                    .map(|i| {
                        let nominal = Layout::dofp_channel(&mosaic, i % w, i / w).angle_deg();
                        let d = (val(i, 2) - nominal + 90.0).rem_euclid(180.0) - 90.0;
                        (nominal + d) as f32
                    })
                    .collect(),
            );
            sigma = Some(SigmaMaps {
                analyzer_deg: per_px.iter().map(|p| p.1[2] as f32).collect(),
                eps: per_px.iter().map(|p| p.1[1] as f32).collect(),
                gain: per_px.iter().map(|p| (p.1[0] / mean_g) as f32).collect(),
            });
        }
        Err(why) => {
            leave("analyzer_deg, eps", why.clone());
            // The gain still comes from an unpolarized flat: the brightest unsaturated one.
            let best = unpol_frames
                .iter()
                .filter(|(_, f)| f.iter().all(|&x| x > 0.0 && (x as f64) < full))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            match best {
                Some((_, f)) => {
                    let m = (0..n).map(|i| f[i] as f64 - offset_dn[i] as f64).sum::<f64>() / n as f64;
                    maps.gain = Some((0..n).map(|i| ((f[i] as f64 - offset_dn[i] as f64) / m) as f32).collect());
                    leave(
                        "gain (polarimetric)",
                        "taken from the unpolarized flat: it includes each pixel's (1 + ε)".into(),
                    );
                }
                None => leave("gain", format!("{why}; and no unsaturated unpolarized flat field")),
            }
        }
    }
    if dark.is_some() || exposures.len() >= 2 {
        maps.offset_dn = Some(offset_dn.clone());
    }
    let bad_count = bad.iter().filter(|&&b| b).count();
    if bad_count > 0 && maps.analyzer_deg.is_some() {
        leave(
            "per-pixel analyzers of saturated pixels",
            format!("{bad_count} pixel(s) saturated or at zero in a polarized flat: given their channel's mean"),
        );
    }

    // Flat field.
    let intr = crate::camera::Intrinsics {
        projection: lab.lens.projection,
        f_px: lab.lens.focal_length_mm * 1000.0 / g.pixel_pitch_um,
        cx_px: lab.lens.principal_point_px.0,
        cy_px: lab.lens.principal_point_px.1,
        distortion: [0.0; 2],
    };
    let colour = lab.sensor.colour.as_ref();
    let flat = maps.gain.as_ref().map(|gm| {
        let unbanded = colour.map(|c| bands::unband_gain(gm, c, &mosaic, w, &bad));
        flat::flat_field(unbanded.as_deref().unwrap_or(gm), w, h, intr.f_px, intr.cx_px, intr.cy_px, |u, v| {
            Layout::dofp_channel(&mosaic, u, v).index()
        })
    });

    // Summaries.
    let mut summ = Vec::new();
    // On a colour sensor, each band's pixels apart (`out`: the pixel is not in it).
    let band_list: Vec<Option<crate::sensor::Band>> = match colour {
        Some(c) => c.bands().into_iter().map(Some).collect(),
        None => vec![None],
    };
    for band in band_list {
        let named = |q: &str| match band {
            Some(b) => format!("{q} [{}]", b.name()),
            None => q.to_string(),
        };
        let out = |u: usize, v: usize| match (band, colour) {
            (Some(b), Some(c)) => c.band_at(u, v) != b,
            _ => false,
        };
        if let Some(a) = &maps.analyzer_deg {
            summ.extend(summary::summarize(
                &named("analyzer angle offset"),
                "deg",
                w,
                h,
                &mosaic,
                |u, v, i| {
                    let nominal = Layout::dofp_channel(&mosaic, u, v).angle_deg();
                    if bad[i] || out(u, v) {
                        f64::NAN
                    } else {
                        a[i] as f64 - nominal
                    }
                },
                sigma.as_ref().map(|s| s.analyzer_deg.as_slice()),
            ));
        }
        if let Some(e) = &maps.eps {
            summ.extend(summary::summarize(
                &named("extinction ratio ε"),
                "1",
                w,
                h,
                &mosaic,
                |u, v, i| if bad[i] || out(u, v) { f64::NAN } else { e[i] as f64 },
                sigma.as_ref().map(|s| s.eps.as_slice()),
            ));
        }
        if let Some(gm) = &maps.gain {
            summ.extend(summary::summarize(
                &named("gain"),
                "1",
                w,
                h,
                &mosaic,
                |u, v, i| if bad[i] || out(u, v) { f64::NAN } else { gm[i] as f64 },
                sigma.as_ref().map(|s| s.gain.as_slice()),
            ));
        }
        if let Some(o) = &maps.offset_dn {
            summ.extend(summary::summarize(
                &named("offset"),
                "DN",
                w,
                h,
                &mosaic,
                |u, v, i| if out(u, v) { f64::NAN } else { o[i] as f64 },
                None,
            ));
        }
    }
    let bands = colour.map(|c| {
        let falloff = |u: usize, v: usize| {
            let r2 = ((u as f64 - intr.cx_px).powi(2) + (v as f64 - intr.cy_px).powi(2)) / (intr.f_px * intr.f_px);
            flat.as_ref().map_or(1.0, |f| 1.0 + f.v2 * r2 + f.v4 * r2 * r2)
        };
        bands::band_calibration(c, &maps, &bad, &unpol_frames, dark.as_ref(), full, falloff)
    });
    maps.check()
        .map_err(|m| crate::Error::Capture { path: lab.toml_path(), message: format!("calibration result: {m}") })?;
    Ok(LabCalibration {
        maps,
        sigma,
        dark,
        photon_transfer,
        flat,
        summary: summ,
        malus_residual_dn,
        offset_source,
        bands,
        left_out,
    })
}

fn mean_good(bad: &[bool], f: impl Fn(usize) -> f64) -> f64 {
    let (c, s) = (0..bad.len()).filter(|&i| !bad[i]).fold((0.0, 0.0), |(c, s), i| (c + 1.0, s + f(i)));
    s / c
}

/// Per-pixel intercept at zero exposure of the unpolarized series (least squares).
fn intercepts(frames: &[(f64, Vec<f32>)], n: usize) -> Vec<f32> {
    let m = frames.len() as f64;
    let se: f64 = frames.iter().map(|f| f.0).sum();
    let see: f64 = frames.iter().map(|f| f.0 * f.0).sum();
    let det = m * see - se * se;
    (0..n)
        .into_par_iter()
        .map(|i| {
            let sy: f64 = frames.iter().map(|f| f.1[i] as f64).sum();
            let sey: f64 = frames.iter().map(|f| f.0 * f.1[i] as f64).sum();
            ((see * sy - se * sey) / det) as f32
        })
        .collect()
}
