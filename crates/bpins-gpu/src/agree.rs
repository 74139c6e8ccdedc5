//! `bpins agree`: seeded trials over every effect of the registry (one at a time, then
//! all together) on both backends, compared stage by stage against [`crate::tolerance`].
//!
//! A trial sets the effect's parameters at neutral, typical, the range's minimum and
//! maximum, then (trial 4, 9, …) a uniform draw over the range, cycling; it draws a sun,
//! a heading and one of the four projections (cycling with the trial), and renders the
//! samples' 612 × 512 DoFP sensor with read, shot, DSNU and PRNU noise, 12-bit. Stages:
//!
//! | stage          | compared                                                    |
//! |----------------|-------------------------------------------------------------|
//! | `intensity`    | noise-free photo-signal of every pixel and channel, relative |
//! | `aop_deg`      | AoP reaching the analyzers, where DoLP > 0.01                |
//! | `dolp`         | DoLP reaching the analyzers                                  |
//! | `aoe_deg`      | AoE (AoP − β about the principal point), where DoLP > 0.01   |
//! | `dn`           | rounded DN, DoFP mosaic and all four colocated channels      |
//! | `dn_off_fraction` | fraction of those DN that differ at all                   |
//! | `heading_deg`  | both extractors, from superpixel sums and from colocated sums with the lens ρ unknown and known |

use crate::precision::Precision;
use crate::sums::{SampleLayout, SumsJob};
use crate::tolerance::*;
use crate::{Gpu, Result};
use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::conventions::{image_angle_rad, wrap_deg_90};
use bpins_core::effects::{EffectSet, REGISTRY};
use bpins_core::sensor::{Channel, Response, DEFAULT_MOSAIC};
use bpins_core::twin::Reconstructor;
use bpins_core::twin::{colocated_heading_sums, mosaic_heading_sums, peak_intensity, render_colocated, render_mosaic};
use bpins_core::twin::{ray_stokes, site_signal_dn, ChainFrame, NoiseIndex, Scene};
use bpins_core::twin::{stream, FrameKey};
use bpins_core::twin::{Extractor, HeadingContext, HeadingSums};
use rayon::prelude::*;

/// One stage's largest difference over every case and trial.
#[derive(Clone, Debug, PartialEq)]
pub struct StageDiff {
    pub stage: &'static str,
    pub max_abs_diff: f64,
    pub tolerance: f64,
    pub unit: &'static str,
    pub ok: bool,
    /// The case and trial of the largest difference.
    pub worst: String,
}

/// A case: a name and the effect parameters it sets.
#[derive(Clone, Debug)]
pub struct Case {
    pub name: String,
    pub effects: Vec<&'static str>,
}

/// "ideal", every registry effect alone, then "all_effects".
pub fn cases() -> Vec<Case> {
    let mut v = vec![Case { name: "ideal".into(), effects: vec![] }];
    v.extend(REGISTRY.iter().map(|e| Case { name: e.name.into(), effects: vec![e.name] }));
    v.push(Case { name: "all_effects".into(), effects: REGISTRY.iter().map(|e| e.name).collect() });
    v
}

/// The sensor of every trial: the samples' 612 × 512 DoFP camera.
pub const WIDTH_PX: usize = 612;
pub const HEIGHT_PX: usize = 512;

/// What one trial of one case compares: the frame both backends render, and the
/// inversion and contexts both reduce with.
pub struct TrialFrame {
    pub frame: ChainFrame,
    pub rec: Reconstructor,
    pub contexts: Vec<HeadingContext>,
    pub label: String,
    /// How much the lens's diattenuation amplifies rounding: κ = 1/(1 − ρ²) at the
    /// largest |ρ| over the sensor (1 without diattenuation, 500 at ρ = 0.999, a lens
    /// that is nearly a polarizer). The f32 bounds of the intensity and the heading
    /// grow with it ([`tolerances`]).
    pub conditioning: f64,
}

/// The stages with the bounds that apply to trial `t` at `precision`: as
/// [`stages`], the f32 intensity and heading bounds times `t.conditioning` (f32 loses
/// the digits the diattenuation's inversion amplifies; f64 has them to spare).
pub fn tolerances(precision: Precision, t: &TrialFrame) -> [(&'static str, f64, &'static str); 7] {
    let mut s = stages(precision);
    if precision == Precision::F32 {
        for (name, tol, _) in s.iter_mut() {
            if *name == "intensity" || *name == "heading_deg" {
                *tol *= t.conditioning;
            }
        }
    }
    s
}

/// Builds trial `trial` of `case` under `seed` (pure function of its arguments).
pub fn trial_frame(case: &Case, trial: u32, seed: u64) -> Result<TrialFrame> {
    let key = FrameKey::new(seed, trial, 0xA9EE_0000 | fxhash(&case.name));
    let mut k = 0u32;
    let mut uniform = || {
        k += 1;
        key.uniform(k, 0, stream::TRIAL)
    };
    let mut set = EffectSet::new();
    for name in &case.effects {
        let e = bpins_core::effects::find(name)?;
        for p in e.params {
            // Trials cycle through the strengths that matter: neutral, typical (as real
            // sensors show it), the range's ends, then a uniform draw over the range.
            let value = match trial % 5 {
                0 => p.neutral,
                1 => p.typical,
                2 => p.min,
                3 => p.max,
                _ => p.min + (p.max - p.min) * uniform(),
            };
            set.set(name, p.name, value)?;
        }
    }
    let model = set.model();
    let projection = Projection::ALL[trial as usize % 4];
    let f_px = if projection == Projection::Pinhole { 8000.0 / 13.8 } else { 300.0 };
    let nominal = Intrinsics { projection, f_px, cx_px: 305.5, cy_px: 255.5, distortion: [0.0; 2] };
    let scene = Scene {
        sun_az_deg: 360.0 * uniform(),
        sun_el_deg: 20.0 + 50.0 * uniform(),
        heading_deg: 360.0 * uniform(),
        tilt_x_deg: 0.0,
        tilt_y_deg: 0.0,
        dmax: 0.6,
    };
    let peak = peak_intensity(&model, &nominal, &scene, WIDTH_PX, HEIGHT_PX, 8);
    let response = Response {
        gain_dn: 3000.0 / peak,
        black_level_dn: 64.0,
        read_noise_dn: 2.0,
        system_gain_dn_per_e: 0.25,
        dsnu_dn: 0.5,
        prnu: 0.005,
        bit_depth: 12,
        quantize: true,
    };
    let frame = ChainFrame::new(&model, &nominal, &scene, &response, NoiseIndex { seed, trial, frame: 0 });
    let rec = Reconstructor::new(&Default::default(), response.black_level_dn, &Channel::ALL)?;
    let ctx = HeadingContext::new(nominal, WIDTH_PX, HEIGHT_PX, scene.sun_az_deg, scene.sun_el_deg);
    let contexts = vec![ctx, HeadingContext { lens_rho2: bpins_core::twin::rho2(&model), ..ctx }];
    let rho2 = bpins_core::twin::rho2(&model);
    let max_r2 = [(0.0, 0.0), (WIDTH_PX as f64, 0.0), (0.0, HEIGHT_PX as f64), (WIDTH_PX as f64, HEIGHT_PX as f64)]
        .map(|(u, v)| frame.intr.geometry(u, v).r2)
        .into_iter()
        .fold(0.0, f64::max);
    let rho = bpins_core::twin::rho_at(rho2, max_r2);
    let conditioning = 1.0 / (1.0 - rho * rho);
    Ok(TrialFrame {
        frame,
        rec,
        contexts,
        label: format!("{} trial {trial} ({})", case.name, projection.name()),
        conditioning,
    })
}

fn fxhash(s: &str) -> u32 {
    s.bytes().fold(0x811c_9dc5u32, |h, b| (h ^ b as u32).wrapping_mul(0x0100_0193)) & 0xFFFF
}

/// Largest difference of each stage for one trial frame, in [`stages`] order.
pub fn compare(gpu: &Gpu, t: &TrialFrame) -> Result<[f64; 7]> {
    let (w, h) = (WIDTH_PX, HEIGHT_PX);
    let f = &t.frame;
    let mut d = [0.0f64; 7];
    // Noise-free chain: photo-signal, AoP and DoLP per pixel.
    let maps = gpu.chain_maps(std::slice::from_ref(f), w, h)?.remove(0);
    // Relative to the pixel's value; at f32, to a share of the frame's peak where darker.
    let floor = match gpu.precision() {
        Precision::F64 => 1e-300,
        Precision::F32 => {
            let peak = maps.iter().flat_map(|m| m.signal_dn).fold(0.0f32, f32::max) as f64;
            (f32::INTENSITY_FLOOR * peak).max(1e-300)
        }
    };
    let cpu: Vec<[f64; 4]> = (0..w * h)
        .into_par_iter()
        .map(|p| {
            let (u, v) = ((p % w) as f64, (p / w) as f64);
            let ray = f.intr.geometry(u, v);
            let s = ray_stokes(f, &ray);
            let g = &maps[p];
            let mut rel: f64 = 0.0;
            for ch in 0..4 {
                let c = site_signal_dn(f, s, &ray, u as u32, v as u32, ch);
                rel = rel.max((g.signal_dn[ch] as f64 - c).abs() / c.abs().max(floor));
            }
            // AoP and AoE (as recon::angle_maps forms them) where the light is polarized.
            let a = s.aop_rad().to_degrees();
            let beta = image_angle_rad(u - f.intr.cx_px, v - f.intr.cy_px).to_degrees();
            let polarized = s.dolp() > AOP_MIN_DOLP;
            let angle = |gpu_deg: f32, cpu_deg: f64| {
                if polarized {
                    aop_diff_deg(gpu_deg as f64, wrap_deg_90(cpu_deg)).abs()
                } else {
                    0.0
                }
            };
            [rel, angle(g.aop_deg, a), (g.dolp as f64 - s.dolp()).abs(), angle(g.aoe_deg, a - beta)]
        })
        .collect();
    for c in &cpu {
        for k in 0..4 {
            d[k] = d[k].max(c[k]);
        }
    }
    // Rounded DN: DoFP mosaic and colocated channels.
    let mut dn = vec![dn_diff(
        &render_mosaic(f, w, h, &DEFAULT_MOSAIC),
        &gpu.render_mosaic(std::slice::from_ref(f), w, h, &DEFAULT_MOSAIC)?[0],
    )];
    let gpu_planes = gpu.render_colocated(std::slice::from_ref(f), w, h, &Channel::ALL)?.remove(0);
    for (c, g) in render_colocated(f, w, h, &Channel::ALL).iter().zip(&gpu_planes) {
        dn.push(dn_diff(c, g));
    }
    for (max, frac) in dn {
        d[4] = d[4].max(max);
        d[5] = d[5].max(frac);
    }
    // Heading: superpixel sums (lens unknown), colocated sums (unknown and known).
    let full_scale = f.response.full_scale_dn();
    let cpu_sp = [mosaic_heading_sums(f, w, h, &DEFAULT_MOSAIC, &t.rec, full_scale, &t.contexts[0])];
    let cpu_co = colocated_heading_sums(f, w, h, [true; 4], &t.rec, &t.contexts);
    let gpu_sp = gpu.heading_sums(
        &[SumsJob { frame: f, rec: &t.rec, mask_full_scale_dn: full_scale, contexts: vec![t.contexts[0]] }],
        w,
        h,
        SampleLayout::Superpixels { mosaic: DEFAULT_MOSAIC },
    )?;
    let gpu_co = gpu.heading_sums(
        &[SumsJob { frame: f, rec: &t.rec, mask_full_scale_dn: 0.0, contexts: t.contexts.clone() }],
        w,
        h,
        SampleLayout::Colocated,
    )?;
    let pairs = cpu_sp
        .iter()
        .zip(&gpu_sp[0])
        .map(|p| (p, &t.contexts[0]))
        .chain(cpu_co.iter().zip(&gpu_co[0]).zip(&t.contexts));
    for ((c, g), ctx) in pairs {
        d[6] = d[6].max(heading_gap(c, g, ctx, gpu.precision()));
    }
    Ok(d)
}

/// Largest heading difference over the extractors; both failing alike is agreement.
/// At f32 an estimate's difference counts against the bound of the stage in
/// proportion to how well the estimate is determined: the bound is
/// max([`f32::HEADING_DEG`], σ/[`f32::HEADING_SIGMA_SHARE`]) for an estimate of 1σ σ,
/// so what is reported is |Δ| scaled to the stage's bound (a meridian line with the
/// sun near the zenith, σ = 6°, may move 0.6°: a tenth of its own uncertainty).
fn heading_gap(cpu: &HeadingSums, gpu: &HeadingSums, ctx: &HeadingContext, precision: Precision) -> f64 {
    Extractor::ALL
        .iter()
        .map(|&e| match (cpu.solve(e, ctx), gpu.solve(e, ctx)) {
            (Ok(a), Ok(b)) => {
                let d = heading_diff_deg(a.heading_deg, b.heading_deg).abs();
                match precision {
                    Precision::F64 => d,
                    Precision::F32 => {
                        d * f32::HEADING_DEG / f32::HEADING_DEG.max(a.sigma_deg / f32::HEADING_SIGMA_SHARE)
                    }
                }
            }
            (Err(_), Err(_)) => 0.0,
            _ => f64::INFINITY,
        })
        .fold(0.0, f64::max)
}

/// The whole comparison: `trials` trials of every case, `progress(done, total)`.
pub fn agree(gpu: &Gpu, trials: u32, seed: u64, progress: &dyn Fn(usize, usize)) -> Result<Vec<StageDiff>> {
    let cases = cases();
    let total = cases.len() * trials as usize;
    let stages = stages(gpu.precision());
    // Worst as a fraction of each trial's own bound, with its difference and bound.
    let mut worst: Vec<(f64, f64, f64, String)> = vec![(0.0, 0.0, 0.0, String::new()); stages.len()];
    let mut done = 0;
    for case in &cases {
        for trial in 0..trials {
            let t = trial_frame(case, trial, seed)?;
            let d = compare(gpu, &t)?;
            let bounds = tolerances(gpu.precision(), &t);
            for (k, x) in d.iter().enumerate() {
                let share = x / bounds[k].1;
                // (NaN counts as the worst difference.)
                if share.is_nan() || share > worst[k].0 {
                    worst[k] = (if share.is_nan() { f64::INFINITY } else { share }, *x, bounds[k].1, t.label.clone());
                }
            }
            done += 1;
            progress(done, total);
        }
    }
    Ok(stages
        .iter()
        .zip(worst)
        .map(|(&(stage, tolerance, unit), (share, max, bound, at))| StageDiff {
            stage,
            max_abs_diff: max,
            // The bound of the worst trial (the stage's own, unless its lens's
            // conditioning widened it: f32 only).
            tolerance: if share > 0.0 { bound } else { tolerance },
            unit,
            ok: share <= 1.0,
            worst: at,
        })
        .collect())
}
