//! Fitting the model to a measured capture: the enabled effects' parameters and each
//! frame's nuisances (heading unless the reference is trusted, radiance scale and
//! smooth radiance shape, sky d_max) to the raw DN of every frame, pixel by pixel at
//! each pixel's own ray.
//!
//! ```text
//! DN_model(p) = offset_k + g_f · signal(p; θ_effects, heading_f, d_max,f)   (chain::mosaic_pixel_signal_dn)
//! χ² = Σ_p (DN(p) − DN_model(p))² / σ²(p),   σ² = σ_r² + K·(DN_model − black)   (EMVA, fit::noise)
//! Levenberg–Marquardt: (JᵀWJ + λ·diag JᵀWJ) δ = JᵀW r,  J by central differences
//! ```
//!
//! JᵀWJ and JᵀWr are accumulated pixel by pixel (per frame over its own and the
//! global parameters), never a Jacobian in memory. Saturated and dark pixels are
//! masked. The noise comes from the frames themselves (`noise::estimate`), so χ²/dof
//! measures the model: ≈ 1 when it explains the data. Iterations first run on every
//! third row and column (all channels), then on every pixel until converged; the
//! reported numbers are from every pixel. 1σ from the inverse of JᵀWJ.
//!
//! The sky's radiance is a per-frame nuisance (`radiance`: × R(p), a smooth
//! orthonormal basis in the image position and the scattering angle), so a real sky's
//! radiance is never blamed on a catalog effect; `FitOptions::rayleigh_radiance` holds
//! it at Rayleigh's. Pixels within [`BORDER_PX`] of the sensor's edge are left out (a
//! misfit confined to them — crosstalk's neighbour outside the sensor — must not bias
//! a global parameter). Each parameter's 1σ is widened by √(n/n_eff), n_eff the
//! effective sample count of neighbour-correlated residuals (`correlation`).

pub mod correlation;
pub mod diagnose;
pub mod linalg;
mod masks;
pub mod noise;
pub mod profiles;
pub mod radiance;
mod residuals;
mod score;

pub use masks::sky_masks;
pub use residuals::{residual_maps, FrameMaps, ResidualMaps};
pub use score::{score_candidate, Score};

use crate::camera::Intrinsics;
use crate::capture::{Capture, FrameData};
use crate::chain::{mosaic_pixel_signal_dn, pixel_signal_dn, pixel_stokes, ChainFrame, NoiseIndex, Scene};
use crate::conventions::wrap_deg_180;
use crate::effects::{EffectDef, EffectSet};
use crate::error::{Error, Result};
use crate::heading::field::SkyMask;
use crate::sensor::{Layout, Response};
use noise::NoiseModel;
use rayon::prelude::*;

/// What to fit.
#[derive(Clone, Debug, Default)]
pub struct FitOptions {
    /// Effects whose parameters are free (at neutral to start).
    pub effects: Vec<&'static EffectDef>,
    /// Keep each frame's heading at its reference instead of fitting it.
    pub trust_reference: bool,
    /// The sky's peak degree of polarization when the user knows it: every frame's
    /// d_max is held at this value instead of being fitted (which is what makes a
    /// global `sky_depolarization` measurable at all).
    pub fixed_dmax: Option<f64>,
    /// Hold every frame's radiance shape at Rayleigh's (a1 = a2 = 0) instead of
    /// fitting it.
    pub rayleigh_radiance: bool,
    /// Effects known from a calibration (`crate::calibration`), held at their values;
    /// an effect also in `effects` is fitted instead.
    pub known: EffectSet,
    /// Fit every pixel. By default each frame's sky mask
    /// ([`crate::heading::field::sky_mask`]) leaves out what is not sky that follows
    /// the model's pattern — clouds, trees, buildings, the ground, the sun's aureole —
    /// so that a scene is never blamed on the lens or the sensor.
    pub all_pixels: bool,
    /// Each frame's sky mask, computed once ([`sky_masks`]) for many fits of the same
    /// capture (a diagnosis); `None`: computed by the fit.
    pub sky_masks: Option<std::sync::Arc<Vec<Option<SkyMask>>>>,
}

/// Pixels this close to the sensor's edge are not fitted.
pub const BORDER_PX: usize = 2;

/// One fitted parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// `effect.param`, or `frame<k>.heading_deg` / `.scale_dn` / `.dmax`.
    pub name: String,
    pub unit: &'static str,
    pub value: f64,
    /// 1σ; 0 for a parameter held fixed; infinite for one the data cannot tell from
    /// others (see [`FitResult::degenerate`]).
    pub sigma: f64,
}

/// One frame's result.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameFit {
    pub heading_deg: f64,
    pub heading_sigma_deg: f64,
    pub reference_deg: Option<f64>,
    /// Fitted − reference heading, degrees, in (−180, 180].
    pub heading_error_deg: Option<f64>,
    pub scale_dn: f64,
    pub dmax: f64,
    /// The sky's radiance nuisance: coefficients of the frame's basis ([`radiance`]).
    pub radiance: [f64; radiance::N],
    pub chi2_per_dof: f64,
}

/// The result of a fit.
#[derive(Clone, Debug, PartialEq)]
pub struct FitResult {
    /// The enabled effects' parameters.
    pub params: Vec<Param>,
    pub frames: Vec<FrameFit>,
    pub chi2: f64,
    pub dof: f64,
    pub chi2_per_dof: f64,
    /// Samples used (unmasked).
    pub samples: usize,
    pub noise: NoiseModel,
    /// RMS of measured − model AoP (degrees, where the model DoLP > 0.01) and DoLP,
    /// over superpixels (DoFP) or pixels (colocated), with the nominal inversion.
    pub aop_rms_deg: f64,
    pub dolp_rms: f64,
    /// RMS over frames of fitted − reference heading, degrees (None without references).
    pub heading_rms_deg: Option<f64>,
    pub iterations: usize,
    /// Effective number of independent samples of the residual ([`correlation`]):
    /// `samples` when it is white, fewer when neighbours are correlated.
    pub n_eff: f64,
    /// Number of independent combinations of the free parameters the data constrain
    /// (the rank of JᵀWJ); less than the free parameters when some are degenerate.
    pub rank: usize,
    /// Each combination of parameters the data cannot constrain, in words.
    pub degenerate: Vec<String>,
    /// The fitted values, to start another fit from.
    pub state: FitState,
}

/// A free or fixed scalar of the fit.
#[derive(Clone, Debug)]
struct Slot {
    name: String,
    unit: &'static str,
    min: f64,
    max: f64,
    step: f64,
    free: bool,
    /// Differentiate by a one-sided secant of `step` (else central differences):
    /// exact, at half the cost, where the model is affine in the parameter (d_max).
    secant: bool,
    /// The model is proportional to this parameter above the offsets (the radiance
    /// scale): its derivative is (model − offset)/value, no evaluation needed.
    proportional: bool,
    /// Coefficient `i` of the frame's radiance basis: its derivative is
    /// (model − offset)·ψ_i/R, no evaluation needed.
    radiance: Option<usize>,
}

/// The problem: the capture's frames and the parameter slots.
struct Problem<'a> {
    capture: &'a Capture,
    frames: &'a [FrameData],
    nominal: Intrinsics,
    opts: &'a FitOptions,
    slots: Vec<Slot>,
    /// Index of the first per-frame slot.
    n_global: usize,
    noise: NoiseModel,
    full_scale_dn: f64,
    /// Per frame: the sky mask (None: every pixel).
    sky: std::sync::Arc<Vec<Option<SkyMask>>>,
    /// Per frame: the radiance basis.
    basis: Vec<radiance::Basis>,
}

/// Per frame: heading, radiance scale, d_max, then the radiance coefficients.
pub const PER_FRAME: usize = 3 + radiance::N;

/// One frame's chain and its radiance nuisance.
pub(crate) struct FitFrame {
    chain: ChainFrame,
    radiance: [f64; radiance::N],
}

impl std::ops::Deref for FitFrame {
    type Target = ChainFrame;
    fn deref(&self) -> &ChainFrame {
        &self.chain
    }
}

impl Problem<'_> {
    fn frame_slots(&self, k: usize) -> [usize; PER_FRAME] {
        let b = self.n_global + PER_FRAME * k;
        std::array::from_fn(|i| b + i)
    }

    /// The chain of frame `k` under parameters `theta`.
    fn chain(&self, theta: &[f64], k: usize) -> Result<FitFrame> {
        let mut set = self.opts.known.clone();
        let mut i = 0;
        for e in &self.opts.effects {
            for p in e.params {
                set.set(e.name, p.name, theta[i])?;
                i += 1;
            }
        }
        let spec = &self.capture.frames[k];
        let slots = self.frame_slots(k);
        let [h, s, d] = [slots[0], slots[1], slots[2]];
        let scene = Scene {
            sun_az_deg: spec.sun.azimuth_deg,
            sun_el_deg: spec.sun.elevation_deg,
            heading_deg: theta[h],
            tilt_x_deg: spec.tilt_x_deg.unwrap_or(0.0),
            tilt_y_deg: spec.tilt_y_deg.unwrap_or(0.0),
            dmax: theta[d],
        };
        let resp = Response {
            black_level_dn: self.capture.sensor.black_level_dn,
            bit_depth: self.capture.sensor.bit_depth,
            ..Response::ideal(theta[s])
        };
        let chain =
            ChainFrame::new(&set.model(), &self.nominal, &scene, &resp, NoiseIndex { seed: 0, trial: 0, frame: 0 });
        Ok(FitFrame { chain, radiance: std::array::from_fn(|i| theta[slots[3 + i]]) })
    }

    /// The radiance nuisance of frame `k` at pixel (u, v): (R, ψ).
    #[inline]
    fn radiance(&self, f: &FitFrame, k: usize, u: usize, v: usize) -> (f64, [f64; radiance::N]) {
        let phi = radiance::raw_at(&f.intr, f.sun_cam, u, v, self.w(), self.h());
        let psi = self.basis[k].psi(&phi);
        (radiance::factor(&f.radiance, &psi), psi)
    }

    /// Model DN of the samples of pixel (u, v) of frame `k` into `out` (1 for DoFP, one
    /// per channel for colocated), with the measured values beside them.
    fn pixel(&self, f: &FitFrame, k: usize, u: usize, v: usize, out: &mut Vec<(f64, f64)>) {
        out.clear();
        let (w, h) = (self.w(), self.h());
        let r = if f.radiance == [0.0; radiance::N] { 1.0 } else { self.radiance(f, k, u, v).0 };
        match (&self.capture.sensor.layout, &self.frames[k]) {
            (Layout::Dofp { mosaic }, FrameData::Mosaic { dn, .. }) => {
                let ch = Layout::dofp_channel(mosaic, u, v).index();
                let m = r * mosaic_pixel_signal_dn(f, u, v, w, h, mosaic) + f.offset_dn[ch];
                out.push((dn[v * w + u] as f64, m));
            }
            (_, FrameData::Colocated { channels, .. }) => {
                let s = pixel_stokes(f, u as f64, v as f64);
                for (c, plane) in channels {
                    let m = r * pixel_signal_dn(f, s, c.index()) + f.offset_dn[c.index()];
                    out.push((plane[v * w + u] as f64, m));
                }
            }
            _ => {}
        }
    }

    /// The offset (black level + channel offset) of sample `q` of pixel (u, v), DN.
    fn offset_dn(&self, f: &ChainFrame, u: usize, v: usize, q: usize) -> f64 {
        match &self.capture.sensor.layout {
            Layout::Dofp { mosaic } => f.offset_dn[Layout::dofp_channel(mosaic, u, v).index()],
            Layout::Colocated { channels } => f.offset_dn[channels[q].index()],
        }
    }

    fn w(&self) -> usize {
        self.capture.sensor.geometry.width_px as usize
    }

    fn h(&self) -> usize {
        self.capture.sensor.geometry.height_px as usize
    }

    /// Whether sample value `y` of pixel (u, v) of frame `k` enters the fit: neither
    /// clipped nor saturated, not within [`BORDER_PX`] of the edge, and sky by the
    /// frame's sky mask.
    fn usable(&self, k: usize, u: usize, v: usize, y: f64) -> bool {
        let b = BORDER_PX;
        y > 0.0
            && y < self.full_scale_dn
            && u >= b
            && v >= b
            && u + b < self.w()
            && v + b < self.h()
            && self.sky[k].as_ref().is_none_or(|m| m.is_sky(u, v))
    }

    /// χ² and, with `normal`, JᵀWJ and JᵀWr over the free slots, on every `stride`-th
    /// row and column. Returns (χ², samples, A, b) with A, b in free-slot order.
    fn accumulate(&self, theta: &[f64], stride: usize, normal: bool) -> Result<Accum> {
        let free: Vec<usize> = (0..self.slots.len()).filter(|&i| self.slots[i].free).collect();
        let nf = free.len();
        let mut total = Accum::new(nf, self.frames.len());
        for k in 0..self.frames.len() {
            // The local slots of this frame: global ones and its own, free only.
            let local: Vec<usize> =
                free.iter().copied().filter(|&i| i < self.n_global || self.frame_slots(k).contains(&i)).collect();
            let base = self.chain(theta, k)?;
            let mut pm = Vec::new();
            if normal {
                for &i in &local {
                    let (h, sl) = (self.slots[i].step, &self.slots[i]);
                    if sl.proportional {
                        pm.push(Column::Proportional { value: theta[i] });
                        continue;
                    }
                    if let Some(j) = sl.radiance {
                        pm.push(Column::Radiance { index: j });
                        continue;
                    }
                    // Central differences, one-sided at a bound of the parameter.
                    let (mut tp, mut tm) = (theta.to_vec(), theta.to_vec());
                    tp[i] = (theta[i] + h).min(sl.max);
                    tm[i] = (theta[i] - h).max(sl.min);
                    if sl.secant {
                        // From θ forward, or backward where θ + h is out of range.
                        if theta[i] + h <= sl.max {
                            tm[i] = theta[i];
                        } else {
                            tp[i] = theta[i];
                        }
                    }
                    let dh = tp[i] - tm[i];
                    // A side at θ itself is the base chain (not evaluated again).
                    let side = |t: &[f64]| -> Result<Option<FitFrame>> {
                        if t[i] == theta[i] {
                            Ok(None)
                        } else {
                            self.chain(t, k).map(Some)
                        }
                    };
                    pm.push(Column::Difference { plus: side(&tp)?, minus: side(&tm)?, dh });
                }
            }
            let nl = local.len();
            let rows: Vec<Accum> = (0..self.h())
                .into_par_iter()
                .filter(|v| v % stride == 0)
                .map(|v| {
                    let mut acc = Accum::new(nl, 0);
                    let (mut s0, mut sp, mut sm) = (Vec::new(), Vec::new(), Vec::new());
                    let mut d = vec![0.0; nl];
                    for u in (0..self.w()).step_by(stride) {
                        self.pixel(&base, k, u, v, &mut s0);
                        let rad = (normal && !s0.is_empty()).then(|| self.radiance(&base, k, u, v));
                        for (q, &(y, m)) in s0.iter().enumerate() {
                            if !self.usable(k, u, v, y) {
                                continue;
                            }
                            let wgt = 1.0 / self.noise.variance_dn2(m - self.capture.sensor.black_level_dn);
                            let r = y - m;
                            acc.chi2 += wgt * r * r;
                            acc.n += 1;
                            if normal {
                                for (j, col) in pm.iter().enumerate() {
                                    d[j] = match col {
                                        Column::Proportional { value } => (m - self.offset_dn(&base, u, v, q)) / value,
                                        Column::Radiance { index } => {
                                            let (r, psi) = rad.expect("evaluated where normal");
                                            let _ = r;
                                            (m - self.offset_dn(&base, u, v, q)) * psi[*index]
                                        }
                                        Column::Difference { plus, minus, dh } => {
                                            let mp = plus.as_ref().map_or(m, |fp| {
                                                self.pixel(fp, k, u, v, &mut sp);
                                                sp[q].1
                                            });
                                            let mm = minus.as_ref().map_or(m, |fm| {
                                                self.pixel(fm, k, u, v, &mut sm);
                                                sm[q].1
                                            });
                                            (mp - mm) / dh
                                        }
                                    };
                                }
                                for a in 0..nl {
                                    acc.b[a] += wgt * d[a] * r;
                                    for c in 0..=a {
                                        acc.a[a * nl + c] += wgt * d[a] * d[c];
                                    }
                                }
                            }
                        }
                    }
                    acc
                })
                .collect();
            let mut fr = Accum::new(nl, 0);
            for r in rows {
                fr.add(&r);
            }
            // Scatter the frame's local sums into the free-slot system.
            let pos: Vec<usize> = local.iter().map(|i| free.iter().position(|f| f == i).unwrap()).collect();
            for a in 0..nl {
                total.b[pos[a]] += fr.b[a];
                for c in 0..=a {
                    let x = fr.a[a * nl + c];
                    let (i, j) = (pos[a].max(pos[c]), pos[a].min(pos[c]));
                    total.a[i * nf + j] += x;
                }
            }
            total.chi2 += fr.chi2;
            total.n += fr.n;
            total.frame_chi2[k] = (fr.chi2, fr.n);
        }
        // Symmetrize.
        for i in 0..nf {
            for j in 0..i {
                total.a[j * nf + i] = total.a[i * nf + j];
            }
        }
        Ok(total)
    }
}

/// How one parameter's column of the Jacobian is formed.
enum Column {
    /// (model at plus − model at minus)/dh; `None` is the base chain.
    Difference { plus: Option<FitFrame>, minus: Option<FitFrame>, dh: f64 },
    /// (model − offset)/value.
    Proportional { value: f64 },
    /// (model − offset)·ψ_index/R.
    Radiance { index: usize },
}

struct Accum {
    a: Vec<f64>,
    b: Vec<f64>,
    chi2: f64,
    n: usize,
    frame_chi2: Vec<(f64, usize)>,
}

impl Accum {
    fn new(n: usize, frames: usize) -> Self {
        Accum { a: vec![0.0; n * n], b: vec![0.0; n], chi2: 0.0, n: 0, frame_chi2: vec![(0.0, 0); frames] }
    }

    fn add(&mut self, o: &Accum) {
        for (x, y) in self.a.iter_mut().zip(&o.a) {
            *x += y;
        }
        for (x, y) in self.b.iter_mut().zip(&o.b) {
            *x += y;
        }
        self.chi2 += o.chi2;
        self.n += o.n;
    }
}

/// A fit's parameter values, for warm starts: the effects' by `effect.param` name, and
/// each frame's (heading °, scale DN, d_max, radiance coefficients) with the radiance
/// basis they are coefficients of.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FitState {
    pub effect_values: Vec<(String, f64)>,
    pub frames: Vec<[f64; PER_FRAME]>,
    pub radiance_basis: Vec<radiance::Basis>,
}

/// Fits `opts` to the capture `c` whose frames are `frames`; `progress(stage, step)`
/// after each iteration.
pub fn fit(c: &Capture, frames: &[FrameData], opts: &FitOptions, progress: &dyn Fn(&str, usize)) -> Result<FitResult> {
    fit_from(c, frames, opts, None, progress)
}

/// The sensor noise of a capture (photon transfer over its frames).
pub fn capture_noise(c: &Capture, frames: &[FrameData]) -> Result<NoiseModel> {
    noise::estimate(frames, c.sensor.black_level_dn, c.sensor.full_scale_dn())
        .ok_or_else(|| Error::Model("too few usable pixels to estimate the sensor noise".into()))
}

/// The problem of fitting `opts`, starting from `start` where it names a value (else
/// neutral effects, the reference or estimated heading, the best scale, d_max 0.5).
fn problem<'a>(
    c: &'a Capture,
    frames: &'a [FrameData],
    opts: &'a FitOptions,
    start: Option<&FitState>,
    noise: NoiseModel,
) -> Result<(Problem<'a>, Vec<f64>)> {
    let full_scale_dn = c.sensor.full_scale_dn();
    // Slots: the effects' parameters, then heading, scale and d_max of each frame.
    let mut slots = Vec::new();
    let mut theta = Vec::new();
    for e in &opts.effects {
        for p in e.params {
            let span = p.max - p.min;
            let name = format!("{}.{}", e.name, p.name);
            let value =
                start.and_then(|s| s.effect_values.iter().find(|(n, _)| *n == name).map(|x| x.1)).unwrap_or(p.neutral);
            slots.push(Slot {
                name,
                unit: p.unit,
                min: p.min,
                max: p.max,
                step: 1e-6 * span,
                free: true,
                secant: false,
                proportional: false,
                radiance: None,
            });
            theta.push(value);
        }
    }
    let n_global = slots.len();
    let ctx_intr = c.intrinsics();
    // Each frame's sky (and, for a frame without a reference, its first heading) from
    // the field estimator, on the frames in memory.
    let field = match &opts.sky_masks {
        Some(m) if m.len() == frames.len() => m.clone(),
        _ => std::sync::Arc::new(sky_masks(c, frames, opts)?),
    };
    for (k, f) in c.frames.iter().enumerate() {
        let warm = start.and_then(|s| s.frames.get(k));
        let heading = match (warm, f.heading_deg, &field[k]) {
            (Some(w), _, _) => w[0],
            (None, Some(h), _) => h,
            (None, None, Some(m)) => m.heading_deg,
            (None, None, None) => initial_heading(c, k)?,
        };
        let free_heading = !(opts.trust_reference && f.heading_deg.is_some());
        slots.push(Slot {
            name: format!("frame{k}.heading_deg"),
            unit: "deg",
            min: -1e6,
            max: 1e6,
            step: 1e-4,
            free: free_heading,
            secant: false,
            proportional: false,
            radiance: None,
        });
        slots.push(Slot {
            name: format!("frame{k}.scale_dn"),
            unit: "DN",
            min: 1e-9,
            max: 1e12,
            // Unused: its column is analytic.
            step: 0.0,
            free: true,
            secant: false,
            proportional: true,
            radiance: None,
        });
        slots.push(Slot {
            name: format!("frame{k}.dmax"),
            unit: "1",
            min: 0.0,
            max: 1.0,
            step: 1e-6,
            free: opts.fixed_dmax.is_none(),
            // The sky's Q and U are linear in d_max, and every later stage linear in them.
            secant: true,
            proportional: false,
            radiance: None,
        });
        for i in 0..radiance::N {
            slots.push(Slot {
                name: format!("frame{k}.radiance_c{i}"),
                unit: "1",
                min: -1e3,
                max: 1e3,
                // Unused: its column is analytic.
                step: 0.0,
                free: !opts.rayleigh_radiance,
                secant: false,
                proportional: false,
                radiance: Some(i),
            });
        }
        let dmax = opts.fixed_dmax.or(warm.map(|w| w[2])).unwrap_or(0.5);
        theta.extend([heading, warm.map_or(1.0, |w| w[1]), dmax]);
        theta.extend(
            (0..radiance::N).map(|i| if opts.rayleigh_radiance { 0.0 } else { warm.map_or(0.0, |w| w[3 + i]) }),
        );
    }
    let sky = if opts.all_pixels { std::sync::Arc::new(vec![None; frames.len()]) } else { field };
    let warm_basis = start.map(|s| &s.radiance_basis).filter(|b| b.len() == frames.len());
    let basis = warm_basis.cloned().unwrap_or_else(|| vec![Default::default(); frames.len()]);
    let mut pb =
        Problem { capture: c, frames, nominal: ctx_intr, opts, slots, n_global, noise, full_scale_dn, sky, basis };
    if warm_basis.is_none() {
        // Each frame's basis orthonormal over its sky at the start (every 4th pixel).
        pb.basis = (0..frames.len())
            .map(|k| {
                let f = pb.chain(&theta, k)?;
                let (w, h) = (pb.w(), pb.h());
                let at = (0..h).step_by(4).flat_map(|v| (0..w).step_by(4).map(move |u| (u, v)));
                let sky = at.filter(|&(u, v)| pb.usable(k, u, v, 1.0));
                Ok(radiance::Basis::orthonormal(sky.map(|(u, v)| radiance::raw_at(&f.intr, f.sun_cam, u, v, w, h))))
            })
            .collect::<Result<_>>()?;
    }
    for k in 0..frames.len() {
        let s = pb.frame_slots(k)[1];
        if start.and_then(|st| st.frames.get(k)).is_none() {
            // Radiance scale from the first guess (linear in the scale).
            theta[s] = initial_scale(&pb, &theta, k)?;
        }
    }
    Ok((pb, theta))
}

/// [`fit`] from a warm start.
pub fn fit_from(
    c: &Capture,
    frames: &[FrameData],
    opts: &FitOptions,
    start: Option<&FitState>,
    progress: &dyn Fn(&str, usize),
) -> Result<FitResult> {
    let noise = capture_noise(c, frames)?;
    let (pb, mut theta) = problem(c, frames, opts, start, noise)?;
    let n_global = pb.n_global;
    let mut iterations = 0;
    // The subsampled stage only brings the parameters near the optimum (within 1σ:
    // a Gauss–Newton decrement below 1); every pixel then converges to 0.01.
    for (stage, stride, max_iter, tol) in [("subsampled", 3usize, 30usize, 1.0), ("every pixel", 1, 20, 0.01)] {
        let mut lambda = 1e-3;
        for _ in 0..max_iter {
            iterations += 1;
            let acc = pb.accumulate(&theta, stride, true)?;
            let step = lm_step(&pb, &theta, &acc, &mut lambda, stride, tol)?;
            progress(stage, iterations);
            match step {
                Some((t, converged)) => {
                    theta = t;
                    if converged {
                        break;
                    }
                }
                None => break,
            }
        }
    }
    // Final: every pixel, covariance from JᵀWJ (its pseudo-inverse: a combination the
    // data do not constrain is reported, and its parameters get an infinite 1σ).
    let acc = pb.accumulate(&theta, 1, true)?;
    let free: Vec<usize> = (0..pb.slots.len()).filter(|&i| pb.slots[i].free).collect();
    let nf = free.len();
    let cov = linalg::PseudoInverse::new(&acc.a, nf);
    let degenerate = cov.null.iter().map(|d| describe_null(&pb, &free, d)).collect();
    // Neighbour-correlated residuals carry less information than their count.
    let n_eff = correlation::effective_samples(&pb, &theta, acc.n)?;
    let widen = (acc.n as f64 / n_eff.max(1.0)).sqrt().max(1.0);
    let sigma = |i: usize| free.iter().position(|&f| f == i).map_or(0.0, |p| widen * cov.sigma(p));
    let params = (0..n_global)
        .map(|i| Param { name: pb.slots[i].name.clone(), unit: pb.slots[i].unit, value: theta[i], sigma: sigma(i) })
        .collect();
    let dof = (acc.n as f64 - nf as f64).max(1.0);
    let frames_out: Vec<FrameFit> = (0..frames.len())
        .map(|k| {
            let slots = pb.frame_slots(k);
            let [h, s, d] = [slots[0], slots[1], slots[2]];
            let reference = c.frames[k].heading_deg;
            let (chi2, n) = acc.frame_chi2[k];
            FrameFit {
                heading_deg: theta[h].rem_euclid(360.0),
                heading_sigma_deg: sigma(h),
                reference_deg: reference,
                heading_error_deg: reference.map(|r| wrap_deg_180(theta[h] - r)),
                scale_dn: theta[s],
                dmax: theta[d],
                radiance: std::array::from_fn(|i| theta[slots[3 + i]]),
                chi2_per_dof: chi2 / (n as f64 - PER_FRAME as f64).max(1.0),
            }
        })
        .collect();
    let errs: Vec<f64> = frames_out.iter().filter_map(|f| f.heading_error_deg).collect();
    let heading_rms_deg =
        (!errs.is_empty()).then(|| (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt());
    let (aop_rms_deg, dolp_rms) = residuals::polarization_residuals(&pb, &theta)?;
    Ok(FitResult {
        params,
        frames: frames_out,
        chi2: acc.chi2,
        dof,
        chi2_per_dof: acc.chi2 / dof,
        samples: acc.n,
        noise,
        aop_rms_deg,
        dolp_rms,
        heading_rms_deg,
        iterations,
        n_eff,
        rank: cov.rank(),
        degenerate,
        state: FitState {
            effect_values: (0..n_global).map(|i| (pb.slots[i].name.clone(), theta[i])).collect(),
            frames: (0..frames.len()).map(|k| pb.frame_slots(k).map(|i| theta[i])).collect(),
            radiance_basis: pb.basis.clone(),
        },
    })
}

/// One damped Gauss–Newton step: the new parameters and whether the fit converged,
/// or `None` when no step lowers χ².
fn lm_step(
    pb: &Problem,
    theta: &[f64],
    acc: &Accum,
    lambda: &mut f64,
    stride: usize,
    tol: f64,
) -> Result<Option<(Vec<f64>, bool)>> {
    let free: Vec<usize> = (0..pb.slots.len()).filter(|&i| pb.slots[i].free).collect();
    let nf = free.len();
    // Converged when the undamped Gauss–Newton step predicts less than `tol` in χ²
    // (minimum-norm where parameters are degenerate).
    let x = linalg::PseudoInverse::new(&acc.a, nf).solve(&acc.b);
    if x.iter().zip(&acc.b).map(|(a, b)| a * b).sum::<f64>() < tol {
        return Ok(Some((theta.to_vec(), true)));
    }
    for _ in 0..12 {
        let mut a = acc.a.clone();
        for i in 0..nf {
            a[i * nf + i] *= 1.0 + *lambda;
        }
        // Pseudo-inverse: a parameter without influence here (a second-order effect at
        // its neutral value) or a degenerate combination is not moved, not thrown.
        let delta = linalg::PseudoInverse::new(&a, nf).solve(&acc.b);
        let mut t = theta.to_vec();
        for (j, &i) in free.iter().enumerate() {
            t[i] = (t[i] + delta[j]).clamp(pb.slots[i].min, pb.slots[i].max);
        }
        let chi2 = pb.accumulate(&t, stride, false)?.chi2;
        if chi2 <= acc.chi2 {
            // A nearly undamped step that gains less than a thousandth in χ² is at the
            // optimum to the precision of the differences (the decrement is not real).
            let converged = *lambda <= 1e-2 && acc.chi2 - chi2 < 1e-3;
            *lambda = (*lambda * 0.1).max(1e-9);
            return Ok(Some((t, converged)));
        }
        *lambda *= 10.0;
    }
    Ok(None)
}

/// A degenerate direction `d` (over the free slots, scaled) in words: the global
/// parameters it moves, and the per-frame ones by kind with the number of frames.
fn describe_null(pb: &Problem, free: &[usize], d: &[f64]) -> String {
    let big = 0.3 * d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut global = Vec::new();
    let mut per_frame: Vec<(&str, usize)> = Vec::new();
    for (j, &i) in free.iter().enumerate() {
        if d[j].abs() < big {
            continue;
        }
        let name = &pb.slots[i].name;
        if i < pb.n_global {
            global.push(name.clone());
        } else {
            let kind = name.split_once('.').map_or(name.as_str(), |x| x.1);
            match per_frame.iter_mut().find(|(k, _)| *k == kind) {
                Some(e) => e.1 += 1,
                None => per_frame.push((kind, 1)),
            }
        }
    }
    let mut parts = global;
    parts.extend(per_frame.iter().map(|(k, n)| format!("{k} of {n} frame{}", if *n == 1 { "" } else { "s" })));
    if parts.len() == 1 && !parts[0].contains(" of ") {
        return format!("{} does not change the model here (its first derivative vanishes at this value)", parts[0]);
    }
    format!("{} move together without changing the model: only their other combinations are measured", parts.join(", "))
}

/// First heading guess of a frame without a reference: the sun-vector extractor.
fn initial_heading(c: &Capture, k: usize) -> Result<f64> {
    let est = crate::pipeline::frame_headings(
        c,
        k,
        &Default::default(),
        crate::pipeline::ReconMode::Superpixel,
        &[crate::heading::Extractor::SunVector],
    )?;
    est.into_iter().next().expect("one extractor").1.map(|e| e.heading_deg)
}

/// The radiance scale that fits frame `k` best with the rest of `theta` (linear).
fn initial_scale(pb: &Problem, theta: &[f64], k: usize) -> Result<f64> {
    let mut t = theta.to_vec();
    t[pb.frame_slots(k)[1]] = 1.0;
    let f = pb.chain(&t, k)?;
    let (mut sy, mut ss) = (0.0, 0.0);
    let mut buf = Vec::new();
    for v in (0..pb.h()).step_by(7) {
        for u in (0..pb.w()).step_by(7) {
            pb.pixel(&f, k, u, v, &mut buf);
            for &(y, m) in &buf {
                if pb.usable(k, u, v, y) {
                    // Photo-signal at unit scale, the black level taken as the offset.
                    let black = pb.capture.sensor.black_level_dn;
                    let s = m - black;
                    sy += (y - black) * s;
                    ss += s * s;
                }
            }
        }
    }
    if ss.is_nan() || ss <= 0.0 {
        return Err(Error::Model(format!("frame {k}: no usable pixels to fit")));
    }
    Ok((sy / ss).max(1e-6))
}
