//! A lab capture of a simulated sensor, with its truth: anyone can test a
//! calibration method against known per-pixel flaws (`bpins simulate --lab`).
//!
//! ```text
//! φ_p = θ_k + Δθ_k (model) + g_x (x/W − ½) + g_y (y/H − ½) + σ_φ n₁     degrees, image frame
//! ε_p = ε_k (model) + σ_ε n₂  (clamped ≥ 0)
//! g_p = (1 + gain_k) · (1 + v2 r² + v4 r⁴) · (1 + PRNU n₃), then scaled to mean 1
//! o_p = black + offset_k + DSNU n₄                                     DN
//! DN  = o_p + s e_j a_p·(1, d cos 2θ_j, d sin 2θ_j) + noise           polarized flat j
//! ```
//!
//! Channel-level truth comes from the catalog's model (`analyzer_angles`,
//! `extinction_ratio`, `channel_response`, `array_rotation`, `vignetting`; r in focal
//! lengths), each pixel's own analyzer from the catalog's analyzer effects
//! (`polarimetric_nonuniformity`, `analyzer_incidence`: the chain's `pixel_analyzer`,
//! so a lab capture and a sky capture of one simulated sensor share its die; the lab's
//! source is seen through the lens, at each pixel's chief ray); further per-pixel
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

/// The truth maps of a `w × h` sensor with `mosaic`, channel effects `model`, lens
/// `intr` (vignetting radius) and per-pixel `flaws`; gain scaled to mean 1.
pub fn truth_maps(
    model: &Model,
    intr: &Intrinsics,
    w: usize,
    h: usize,
    mosaic: [[Channel; 2]; 2],
    black_level_dn: f64,
    flaws: &PixelFlaws,
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
    let [vig_v2, vig_v4] = crate::effects::vignetting::coefficients(model);
    let per_px: Vec<(f32, f32, f64, f32)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (u, v) = (i % w, i / w);
            let ch = Layout::dofp_channel(&mosaic, u, v);
            let k = ch.index();
            let (x, y) = ((u as f64 + 0.5) / w as f64 - 0.5, (v as f64 + 0.5) / h as f64 - 0.5);
            let p = i as u32;
            // The pixel's own analyzer against its channel's (the analyzer effects):
            // doubled-angle turn, ε and gain changes; exactly 0, 0 and 1 without them.
            let chan = frame.analyzers[k];
            let own =
                crate::chain::pixel_analyzer(&frame, &frame.intr.geometry(u as f64, v as f64), u as u32, v as u32, k);
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
            let eps =
                (model.channels.analyzer_eps[k] + (a.eps - chan.eps) + flaws.eps_sigma * key.normal(p, 1, 0)).max(0.0);
            let r2 = ((u as f64 - intr.cx_px).powi(2) + (v as f64 - intr.cy_px).powi(2)) / (intr.f_px * intr.f_px);
            let vig = crate::effects::vignetting::factor(vig_v2, vig_v4, r2).max(1e-3);
            let own_gain = own.gain / frame.gain_dn[k];
            let gain = model.channels.gain[k] * own_gain * vig * (1.0 + flaws.prnu * key.normal(p, 2, 0));
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

/// A colour-polarization sensor's truth from the monochrome `truth` of the same die
/// (`truth_maps`): each pixel through its band's response (`band_response`, the
/// model's [`crate::effects::BandBlock`]): `ε_p += ε_b`, `g_p ×= q_b`, the gain
/// scaled back to mean 1. The lab source is white (each band sees the same radiance:
/// no `sky_spectrum`), so a band's mean gain over green's is its `q_b`.
pub fn colour_truth(truth: &mut PixelMaps, model: &Model, colour: &crate::sensor::ColourTiles) {
    let w = truth.width_px;
    let band = |i: usize| colour.band_at(i % w, i / w).index();
    if let Some(e) = truth.eps.as_mut() {
        for (i, x) in e.iter_mut().enumerate() {
            *x += model.bands.eps[band(i)] as f32;
        }
    }
    if let Some(g) = truth.gain.as_mut() {
        let scaled: Vec<f64> = g.iter().enumerate().map(|(i, &x)| x as f64 * model.bands.gain[band(i)]).collect();
        let mean = scaled.iter().sum::<f64>() / scaled.len() as f64;
        for (x, s) in g.iter_mut().zip(scaled) {
            *x = (s / mean) as f32;
        }
    }
}
