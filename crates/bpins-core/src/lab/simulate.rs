//! A lab capture of a simulated sensor, with its truth: anyone can test a
//! calibration method against known per-pixel flaws (`bpins simulate --lab`).
//!
//! ```text
//! φ_p = θ_k + Δθ_k (model) + g_x (x/W − ½) + g_y (y/H − ½) + σ_φ n₁     degrees, image frame
//! ε_p = max(ε_die(p) + σ_ε n₂, 0),  ε_die(p) = max(ε_k + ε_b + σ_die n, 0)  (the chain's)
//! g_p = (1 + gain_k) · q_b · (1 + v2 r² + v4 r⁴) · (1 + PRNU n₃), then scaled to mean 1
//! o_p = black + offset_k + DSNU n₄                                     DN
//! DN  = o_p + s e_j a_p·(1, d cos 2θ_j, d sin 2θ_j) + noise           polarized flat j
//! ```
//!
//! Channel-level truth comes from the catalog's model (`analyzer_angles`,
//! `extinction_ratio`, `channel_response`, `array_rotation`, `vignetting`; r in focal
//! lengths), each pixel's own analyzer from the catalog's analyzer effects
//! (`polarimetric_nonuniformity`, `analyzer_incidence`: the chain's `pixel_analyzer`,
//! so a lab capture and a sky capture of one simulated sensor share its die; the lab's
//! source is seen through the lens, at each pixel's chief ray). On a colour sensor each
//! pixel's analyzer is its band's (`ChainFrame::in_band`: ε_b added to the channel's ε
//! before the die's spread and its clip at 0, q_b its gain; ε_b, q_b from
//! `band_response`, no `sky_spectrum`: the lab's source is white), as in the sky's
//! chain, so a colour die is one die in both captures too; further per-pixel
//! spreads from [`PixelFlaws`]. Not simulated here: `sensor_nonlinearity` (the lab
//! calibration assumes a linear sensor). Noise: shot noise
//! `K·signal` (DN²), read noise, rounding, clipping to `[0, full scale]`, seeded per
//! pixel and frame ([`crate::noise::FrameKey`]). An unpolarized flat is the same
//! source without the polarizer (`I = 1`, `Q = U = 0`); a dark frame is `o_p` plus read
//! noise.

use crate::camera::Intrinsics;
use crate::capture::LabFrame;
use crate::effects::Model;
use crate::noise::FrameKey;
use crate::pixel_analyzers::PixelMaps;
use crate::sensor::{Channel, Layout};
use rayon::prelude::*;
use std::path::PathBuf;

/// Per-pixel non-uniformity beyond the catalog's per-channel effects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFlaws {
    /// White spread of the analyzer angle, degrees (1σ).
    pub angle_sigma_deg: f64,
    /// Change of the analyzer angle across the width and the height, degrees.
    pub angle_gradient_deg: [f64; 2],
    /// White spread of ε (1σ).
    pub eps_sigma: f64,
    /// Photo-response non-uniformity (1σ, fraction).
    pub prnu: f64,
    /// Dark-signal non-uniformity (1σ), DN.
    pub dsnu_dn: f64,
    pub seed: u64,
}

impl PixelFlaws {
    /// No per-pixel flaw.
    pub fn none() -> Self {
        PixelFlaws {
            angle_sigma_deg: 0.0,
            angle_gradient_deg: [0.0; 2],
            eps_sigma: 0.0,
            prnu: 0.0,
            dsnu_dn: 0.0,
            seed: 0,
        }
    }
}

/// What the lab records: polarizer angles, exposures of the unpolarized flats, dark frames.
#[derive(Clone, Debug, PartialEq)]
pub struct LabPlan {
    pub angles_deg: Vec<f64>,
    pub source_dolp: f64,
    pub exposures: Vec<f64>,
    pub darks: usize,
}

impl Default for LabPlan {
    /// The sample's plan: 12 angles 0°, 15°, …, 165°, flats at 0.3×, 0.6×, 1.2×, one dark.
    fn default() -> Self {
        LabPlan {
            angles_deg: (0..12).map(|k| 15.0 * k as f64).collect(),
            source_dolp: 1.0,
            exposures: vec![0.3, 0.6, 1.2],
            darks: 1,
        }
    }
}

impl LabPlan {
    /// The plan's `[[frames]]`: `frames/pNNN.png` in order (polarized, unpolarized, dark).
    pub fn frames(&self) -> Vec<LabFrame> {
        let pol = self.angles_deg.iter().map(|&a| (Some(a), 1.0, false));
        let unpol = self.exposures.iter().map(|&e| (None, e, false));
        let dark = (0..self.darks).map(|_| (None, 1.0, true));
        pol.chain(unpol)
            .chain(dark)
            .enumerate()
            .map(|(i, (a, e, d))| LabFrame {
                file: PathBuf::from(format!("frames/p{i:03}.png")),
                polarizer_angle_deg: a,
                source_dolp: if a.is_some() { self.source_dolp } else { 1.0 },
                exposure_rel: e,
                dark: d,
            })
            .collect()
    }
}

/// The truth maps of a monochrome `w × h` sensor with `mosaic`, channel effects
/// `model`, lens `intr` (vignetting radius) and per-pixel `flaws`; gain scaled to mean 1.
pub fn truth_maps(
    model: &Model,
    intr: &Intrinsics,
    w: usize,
    h: usize,
    mosaic: [[Channel; 2]; 2],
    black_level_dn: f64,
    flaws: &PixelFlaws,
) -> PixelMaps {
    truth_maps_in_bands(model, intr, w, h, mosaic, black_level_dn, flaws, None)
}

/// [`truth_maps`] of a colour-polarization sensor with filters `colour`: each pixel's
/// analyzer is its band's, as the sky's chain has it (`ChainFrame::in_band`, then the
/// analyzer effects: ε_p = max(ε_k + ε_b + σ n, 0) with `polarimetric_nonuniformity`),
/// and its gain is times the band's response `q_b` (`band_response`; the lab's source is
/// white, so no `sky_spectrum`): a band's mean gain over green's is its `q_b`.
#[allow(clippy::too_many_arguments)]
pub fn colour_truth_maps(
    model: &Model,
    intr: &Intrinsics,
    w: usize,
    h: usize,
    mosaic: [[Channel; 2]; 2],
    black_level_dn: f64,
    flaws: &PixelFlaws,
    colour: &crate::sensor::ColourTiles,
) -> PixelMaps {
    truth_maps_in_bands(model, intr, w, h, mosaic, black_level_dn, flaws, Some(colour))
}

/// [`truth_maps`], each pixel in its band's frame where `colour` is given.
#[allow(clippy::too_many_arguments)]
fn truth_maps_in_bands(
    model: &Model,
    intr: &Intrinsics,
    w: usize,
    h: usize,
    mosaic: [[Channel; 2]; 2],
    black_level_dn: f64,
    flaws: &PixelFlaws,
    colour: Option<&crate::sensor::ColourTiles>,
) -> PixelMaps {
    let key = FrameKey::new(flaws.seed, 0xF1A5, 0);
    let n = w * h;
    // The chain's frame, for each pixel's analyzer (the scene does not matter here).
    let scene = crate::chain::Scene {
        sun_az_deg: 0.0,
        sun_el_deg: 90.0,
        heading_deg: 0.0,
        tilt_x_deg: 0.0,
        tilt_y_deg: 0.0,
        dmax: 0.0,
    };
    let frame = crate::chain::ChainFrame::noise_free(model, intr, &scene);
    // A colour sensor's pixels see their band's frame (the band's ε in each channel's
    // analyzer, before the analyzer effects), exactly as the sky's chain renders them
    // (`chain::colour_pixel_signal_dn`); a monochrome sensor's the frame itself.
    let bands;
    let frames: &[crate::chain::ChainFrame] = match colour {
        Some(_) => {
            bands = frame.bands(model, &scene);
            &bands
        }
        None => std::slice::from_ref(&frame),
    };
    let [vig_v2, vig_v4] = crate::effects::vignetting::coefficients(model);
    let per_px: Vec<(f32, f32, f64, f32)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (u, v) = (i % w, i / w);
            let ch = Layout::dofp_channel(&mosaic, u, v);
            let k = ch.index();
            let (x, y) = ((u as f64 + 0.5) / w as f64 - 0.5, (v as f64 + 0.5) / h as f64 - 0.5);
            let p = i as u32;
            let b = colour.map_or(0, |c| c.band_at(u, v).index());
            let frame = &frames[b];
            // The pixel's own analyzer against its channel's (the analyzer effects):
            // doubled-angle turn, ε and gain changes; exactly 0, ε_k + ε_b and 1 without them.
            let chan = frame.analyzers[k];
            let own =
                crate::chain::pixel_analyzer(frame, &frame.intr.geometry(u as f64, v as f64), u as u32, v as u32, k);
            let a = own.analyzer;
            let turn_deg = 0.5
                * (a.sin2t * chan.cos2t - a.cos2t * chan.sin2t)
                    .atan2(a.cos2t * chan.cos2t + a.sin2t * chan.sin2t)
                    .to_degrees();
            let angle = ch.angle_deg()
                + model.channels.analyzer_delta_deg[k]
                + turn_deg
                + flaws.angle_gradient_deg[0] * x
                + flaws.angle_gradient_deg[1] * y
                + flaws.angle_sigma_deg * key.normal(p, 0, 0);
            // The chain's ε of this pixel (its band's added before the die's clip), then
            // the lab-only spread and its own clip.
            let eps = (a.eps + flaws.eps_sigma * key.normal(p, 1, 0)).max(0.0);
            let r2 = ((u as f64 - intr.cx_px).powi(2) + (v as f64 - intr.cy_px).powi(2)) / (intr.f_px * intr.f_px);
            let vig = crate::effects::vignetting::factor(vig_v2, vig_v4, r2).max(1e-3);
            // The die's gain change (the band frame's radiance × response cancels here),
            // then the band's response under the lab's white source.
            let own_gain = own.gain / frame.gain_dn[k];
            let q_b = if colour.is_some() { model.bands.gain[b] } else { 1.0 };
            let gain = model.channels.gain[k] * q_b * own_gain * vig * (1.0 + flaws.prnu * key.normal(p, 2, 0));
            let offset = black_level_dn + model.channels.offset_dn[k] + flaws.dsnu_dn * key.normal(p, 3, 0);
            (angle as f32, eps as f32, gain, offset as f32)
        })
        .collect();
    let mean_gain = per_px.iter().map(|p| p.2).sum::<f64>() / n as f64;
    PixelMaps {
        width_px: w,
        height_px: h,
        mosaic,
        offset_dn: Some(per_px.iter().map(|p| p.3).collect()),
        gain: Some(per_px.iter().map(|p| (p.2 / mean_gain) as f32).collect()),
        analyzer_deg: Some(per_px.iter().map(|p| p.0).collect()),
        eps: Some(per_px.iter().map(|p| p.1).collect()),
    }
}

/// Sensor noise and signal of a simulated lab capture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabSensor {
    /// Signal of a mean-gain pixel with ε = 0 for the unit source at exposure 1, DN
    /// (`s` of the module: a polarized flat peaks near it, an unpolarized one is half).
    pub signal_dn: f64,
    pub k_dn_per_e: f64,
    pub read_noise_dn: f64,
    pub full_scale_dn: f64,
    pub seed: u64,
}

/// The frames of `plan` (in [`LabPlan::frames`] order) of a sensor with `truth` maps.
pub fn lab_frames(truth: &PixelMaps, plan: &LabPlan, sensor: &LabSensor) -> Vec<Vec<f32>> {
    let frames = plan.frames();
    frames
        .iter()
        .enumerate()
        .map(|(j, f)| {
            let key = FrameKey::new(sensor.seed, 0x1AB, j as u32);
            let stokes = match (f.dark, f.polarizer_angle_deg) {
                (true, _) => [0.0; 3],
                (false, Some(a)) => {
                    let (s, c) = (2.0 * a).to_radians().sin_cos();
                    [1.0, f.source_dolp * c, f.source_dolp * s]
                }
                (false, None) => [1.0, 0.0, 0.0],
            };
            let scale = sensor.signal_dn * f.exposure_rel;
            (0..truth.width_px * truth.height_px)
                .into_par_iter()
                .map(|i| {
                    let (u, v) = (i % truth.width_px, i / truth.width_px);
                    let (a, o) = truth.pixel(u, v, 0.0);
                    let signal = scale * (a[0] * stokes[0] + a[1] * stokes[1] + a[2] * stokes[2]);
                    let sd = (sensor.read_noise_dn.powi(2) + sensor.k_dn_per_e * signal.max(0.0)).sqrt();
                    let dn = o + signal + sd * key.normal(i as u32, 0, 0);
                    dn.round().clamp(0.0, sensor.full_scale_dn) as f32
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::{pixel_analyzer, ChainFrame};
    use crate::effects::EffectSet;
    use crate::sensor::{Band, ColourTiles, DEFAULT_MOSAIC};

    /// A colour die whose ε spread reaches 0 (`polarimetric_nonuniformity` σ_ε 0.02 about
    /// the blue band's ε_b 0.012): the lab truth's ε of every pixel is the one the sky's
    /// chain gives it (its band's frame, then the die's spread and clip), so a lab capture
    /// and a sky capture of the sensor share one die; the blue mean is
    /// E[max(μ + σn, 0)] = μΦ(μ/σ) + σφ(μ/σ) = 0.01537 (μ 0.012, σ 0.02), not the
    /// clip-then-add 0.02·φ(0) + 0.012 = 0.01998.
    #[test]
    fn a_colour_dies_lab_truth_has_the_sky_chains_eps_pixel_for_pixel() {
        let mut set = EffectSet::new();
        set.set("polarimetric_nonuniformity", "eps_sigma", 0.02).unwrap();
        set.set("polarimetric_nonuniformity", "angle_sigma_deg", 1.0).unwrap();
        set.set("band_response", "eps_b", 0.012).unwrap();
        set.set("band_response", "eps_r", 0.004).unwrap();
        set.set("band_response", "qe_b", 0.6).unwrap();
        let model = set.model();
        let (intr, sc, colour) = (intrinsics(), scene(), ColourTiles::imx250myr());
        let (w, h) = (96, 96);
        let truth = colour_truth_maps(&model, &intr, w, h, DEFAULT_MOSAIC, 64.0, &PixelFlaws::none(), &colour);
        // The sky's chain: each pixel's analyzer in its band's frame (a sky scene).
        let sky = ChainFrame::noise_free(&model, &intr, &sc).bands(&model, &sc);
        let eps = truth.eps.as_ref().unwrap();
        let gain = truth.gain.as_ref().unwrap();
        let (mut blue, mut blue_gain, mut green_gain) = (vec![], vec![], vec![]);
        for (i, &e) in eps.iter().enumerate() {
            let (u, v) = (i % w, i / w);
            let b = colour.band_at(u, v);
            let f = &sky[b.index()];
            let k = Layout::dofp_channel(&DEFAULT_MOSAIC, u, v).index();
            let chain = pixel_analyzer(f, &f.intr.geometry(u as f64, v as f64), u as u32, v as u32, k);
            assert_eq!(e, chain.analyzer.eps as f32, "pixel ({u}, {v}), {b:?}");
            match b {
                Band::B => {
                    blue.push(e as f64);
                    blue_gain.push(gain[i] as f64);
                }
                Band::G => green_gain.push(gain[i] as f64),
                Band::R => {}
            }
        }
        let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
        // Some blue pixels clipped at 0, some between 0 and ε_b: the spread reaches 0.
        assert!(blue.contains(&0.0) && blue.iter().any(|&e| e > 0.0 && e < 0.012));
        assert!((mean(&blue) - 0.01537).abs() < 0.0012, "blue mean ε {}", mean(&blue));
        // The band's response under the white source: blue's gain over green's is q_b.
        assert!((mean(&blue_gain) / mean(&green_gain) - 0.6).abs() < 1e-5);
    }
}
