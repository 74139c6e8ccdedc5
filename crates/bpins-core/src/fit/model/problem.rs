//! The problem a fit solves: the capture's frames (every pixel or a sample), the typed parameter
//! slots, the noise and each frame's sky mask and radiance basis; and the model it
//! evaluates — one frame's chain under a parameter vector, one pixel's model DN.

use crate::camera::Intrinsics;
use crate::capture::Capture;
use crate::capture::FrameData as Whole;
use crate::chain::{mosaic_pixel_signal_dn, ChainFrame, NoiseIndex, Scene};
use crate::error::Result;
use crate::fit::input::frames::{value_of, FitFrames};
use crate::fit::input::noise::NoiseModel;
use crate::fit::model::radiance;
use crate::fit::model::slots::{Nuisance, SlotId, Slots};
use crate::fit::model::stages::{Reuse, Stages};
use crate::fit::model::start;
use crate::fit::{FitOptions, FitState, BORDER_PX};
use crate::heading::field::SkyMask;
use crate::sensor::{Layout, Response};
use std::sync::Arc;

/// The problem: the capture's frames and the parameter slots.
pub(crate) struct Problem<'a> {
    pub capture: &'a Capture,
    pub frames: &'a FitFrames<'a>,
    pub nominal: Intrinsics,
    pub opts: &'a FitOptions,
    pub slots: Slots,
    pub noise: NoiseModel,
    pub full_scale_dn: f64,
    /// Per frame: the sky mask (None: every pixel).
    pub sky: Arc<Vec<Option<SkyMask>>>,
    /// Per frame: the radiance basis.
    pub basis: Vec<radiance::Basis>,
}

/// One frame's chain and its radiance nuisance.
pub(crate) struct FitFrame {
    pub chain: ChainFrame,
    pub radiance: [f64; radiance::N],
    /// The same as weights of the raw functions (`radiance::Basis::weights`).
    pub radiance_weights: [f64; radiance::N + 1],
}

impl std::ops::Deref for FitFrame {
    type Target = ChainFrame;
    fn deref(&self) -> &ChainFrame {
        &self.chain
    }
}

/// The problem of fitting `opts`, starting from `start` where it names a value (else
/// the starting guesses of [`start`]).
pub(crate) fn problem<'a>(
    c: &'a Capture,
    frames: &'a FitFrames<'a>,
    opts: &'a FitOptions,
    warm: Option<&FitState>,
    noise: NoiseModel,
) -> Result<(Problem<'a>, Vec<f64>)> {
    let reference: Vec<bool> = c.frames.iter().map(|f| f.heading_deg.is_some()).collect();
    let slots = Slots::new(opts, &reference);
    // Each frame's sky (and, for a frame without a reference, its first heading) from
    // the field estimator, on the whole frames.
    let field = match &opts.sky_masks {
        Some(m) if m.len() == frames.len() => m.clone(),
        _ => frames.sky_masks(c, opts)?,
    };
    let sky = if opts.all_pixels { Arc::new(vec![None; frames.len()]) } else { field.clone() };
    let warm_basis = warm.map(|s| &s.radiance_basis).filter(|b| b.len() == frames.len());
    let basis = warm_basis.cloned().unwrap_or_else(|| vec![Default::default(); frames.len()]);
    let mut pb = Problem {
        capture: c,
        frames,
        nominal: c.intrinsics(),
        opts,
        slots,
        noise,
        full_scale_dn: c.sensor.full_scale_dn(),
        sky,
        basis,
    };
    let mut theta = start::theta(&pb, warm, &field)?;
    if warm_basis.is_none() {
        pb.basis = start::radiance_bases(&pb, &theta)?;
    }
    for k in 0..frames.len() {
        if warm.and_then(|st| st.frames.get(k)).is_none() {
            // Radiance scale from the first guess (linear in the scale).
            theta[pb.slots.at(k, Nuisance::Scale)] = start::scale(&pb, &theta, k)?;
        }
    }
    Ok((pb, theta))
}

impl Problem<'_> {
    /// The effects' parameters of `theta`, by name (the global slots that are effect
    /// parameters, in slot order).
    pub fn effect_values(&self, theta: &[f64]) -> Vec<(crate::fit::model::slots::EffectParam, f64)> {
        self.slots.all[..self.slots.n_global]
            .iter()
            .zip(theta)
            .filter_map(|(s, &v)| match s.id {
                SlotId::Effect(p) => Some((p, v)),
                SlotId::Frame { .. } => None,
            })
            .collect()
    }

    /// The chain of frame `k` under parameters `theta`.
    pub fn chain(&self, theta: &[f64], k: usize) -> Result<FitFrame> {
        let mut set = self.opts.known.clone();
        for (slot, value) in self.slots.all[..self.slots.n_global].iter().zip(theta) {
            if let SlotId::Effect(p) = slot.id {
                set.set(p.effect, p.param, *value)?;
            }
        }
        let spec = &self.capture.frames[k];
        let at = |n: Nuisance| theta[self.slots.at(k, n)];
        let scene = Scene {
            sun_az_deg: spec.sun.azimuth_deg,
            sun_el_deg: spec.sun.elevation_deg,
            heading_deg: at(Nuisance::Heading),
            tilt_x_deg: spec.tilt_x_deg.unwrap_or(0.0),
            tilt_y_deg: spec.tilt_y_deg.unwrap_or(0.0),
            dmax: at(Nuisance::Dmax),
        };
        let resp = Response {
            black_level_dn: self.capture.sensor.black_level_dn,
            bit_depth: self.capture.sensor.bit_depth,
            ..Response::ideal(at(Nuisance::Scale))
        };
        let chain =
            ChainFrame::new(&set.model(), &self.nominal, &scene, &resp, NoiseIndex { seed: 0, trial: 0, frame: 0 });
        let radiance: [f64; radiance::N] = std::array::from_fn(|i| at(Nuisance::Radiance(i)));
        let radiance_weights = self.basis.get(k).map_or([0.0; radiance::N + 1], |b| b.weights(&radiance));
        Ok(FitFrame { chain, radiance, radiance_weights })
    }

    /// The raw radiance functions φ of pixel (u, v) under frame `f`'s camera and sun
    /// (`radiance::raw_at`): what its radiance factor and basis are formed from.
    #[inline]
    pub fn raw_radiance(&self, f: &FitFrame, u: usize, v: usize) -> [f64; radiance::N + 1] {
        radiance::raw_at(&f.intr, f.sun_cam, u, v, self.w(), self.h())
    }

    /// The radiance factor R of frame `f` from the raw functions `phi` of a pixel: 1
    /// without a radiance nuisance, else exp(w·φ) with the frame's weights, not ψ (the
    /// fit's hottest line).
    #[inline]
    pub fn factor_of(f: &FitFrame, phi: &[f64; radiance::N + 1]) -> f64 {
        if f.radiance == [0.0; radiance::N] {
            1.0
        } else {
            radiance::factor_raw(&f.radiance_weights, phi)
        }
    }

    /// The radiance factor R of frame `f` at pixel (u, v) (φ formed only where needed).
    #[inline]
    pub fn factor_at(&self, f: &FitFrame, u: usize, v: usize) -> f64 {
        if f.radiance == [0.0; radiance::N] {
            1.0
        } else {
            Self::factor_of(f, &self.raw_radiance(f, u, v))
        }
    }

    /// Model DN of the samples of pixel (u, v) of frame `k` into `out` (1 for DoFP, one
    /// per channel for colocated), with the measured values beside them (a pixel the
    /// fit's frames hold).
    #[inline]
    pub fn pixel(&self, f: &FitFrame, k: usize, u: usize, v: usize, out: &mut Vec<(f64, f64)>) {
        self.pixel_scaled(f, k, u, v, self.factor_at(f, u, v), out)
    }

    /// [`Problem::pixel`] with the radiance factor `r` given: the same numbers where `r`
    /// is [`Problem::factor_at`] of `f` or of a frame with the same camera, sun and
    /// radiance weights (a difference column of a parameter that moves none of them).
    #[inline]
    pub fn pixel_scaled(&self, f: &FitFrame, k: usize, u: usize, v: usize, r: f64, out: &mut Vec<(f64, f64)>) {
        self.pixel_with(f, u, v, r, |q| self.frames.value(k, u, v, q), None, out);
    }

    /// [`Problem::pixel_scaled`] from a base chain's stages of this pixel, `from`
    /// (`None`: all evaluated): the stages it reuses are the base's, where `Reuse` is
    /// [`Reuse::between`] `f` and that base (the same numbers). Returns `f`'s stages
    /// (`None` under crosstalk, whose pixels are evaluated whole).
    #[inline]
    pub fn pixel_staged(
        &self,
        f: &FitFrame,
        (k, u, v): (usize, usize, usize),
        r: f64,
        from: Option<(Stages, Reuse)>,
        out: &mut Vec<(f64, f64)>,
    ) -> Option<Stages> {
        self.pixel_with(f, u, v, r, |q| self.frames.value(k, u, v, q), from, out)
    }

    /// [`Problem::pixel`] measured on `data`, a frame whole.
    pub fn pixel_of(&self, f: &FitFrame, u: usize, v: usize, data: &Whole, out: &mut Vec<(f64, f64)>) {
        let r = self.factor_at(f, u, v);
        self.pixel_with(f, u, v, r, |q| value_of(data, self.w(), u, v, q), None, out);
    }

    #[inline(always)]
    fn pixel_with(
        &self,
        f: &FitFrame,
        u: usize,
        v: usize,
        r: f64,
        measured: impl Fn(usize) -> f32,
        from: Option<(Stages, Reuse)>,
        out: &mut Vec<(f64, f64)>,
    ) -> Option<Stages> {
        out.clear();
        let (w, h) = (self.w(), self.h());
        match &self.capture.sensor.layout {
            // A mosaic effect (crosstalk): the pixel's own chain and its four neighbours'.
            Layout::Dofp { mosaic } if f.has_mosaic_effects() => {
                let ch = Layout::dofp_channel(mosaic, u, v).index();
                let m = nonlinear(f, r * mosaic_pixel_signal_dn(f, u, v, w, h, mosaic)) + f.offset_dn[ch];
                out.push((measured(0) as f64, m));
                None
            }
            Layout::Dofp { mosaic } => {
                // mosaic_pixel_signal_dn without crosstalk: the pixel's own chain.
                let st = stages_of(f, (u, v), from);
                let ch = Layout::dofp_channel(mosaic, u, v).index();
                let m = nonlinear(f, r * st.signal_dn(f, (u, v), ch)) + f.offset_dn[ch];
                out.push((measured(0) as f64, m));
                Some(st)
            }
            Layout::Colocated { channels } => {
                let st = stages_of(f, (u, v), from);
                for (q, c) in channels.iter().enumerate() {
                    let m = nonlinear(f, r * st.signal_dn(f, (u, v), c.index())) + f.offset_dn[c.index()];
                    out.push((measured(q) as f64, m));
                }
                Some(st)
            }
        }
    }

    /// The offset (black level + channel offset) of sample `q` of pixel (u, v), DN.
    pub fn offset_dn(&self, f: &ChainFrame, u: usize, v: usize, q: usize) -> f64 {
        f.offset_dn[self.channel_of(u, v, q)]
    }

    /// The channel index (0°, 45°, 90°, 135°: 0…3) sample `q` of pixel (u, v) reads.
    #[inline]
    pub fn channel_of(&self, u: usize, v: usize, q: usize) -> usize {
        match &self.capture.sensor.layout {
            Layout::Dofp { mosaic } => Layout::dofp_channel(mosaic, u, v).index(),
            Layout::Colocated { channels } => channels[q].index(),
        }
    }

    pub fn w(&self) -> usize {
        self.capture.sensor.geometry.width_px as usize
    }

    pub fn h(&self) -> usize {
        self.capture.sensor.geometry.height_px as usize
    }

    /// Whether sample value `y` of pixel (u, v) of frame `k` enters the fit: neither
    /// clipped nor saturated, not within [`BORDER_PX`] of the edge, and sky by the
    /// frame's sky mask.
    pub fn usable(&self, k: usize, u: usize, v: usize, y: f64) -> bool {
        let b = BORDER_PX;
        y > 0.0
            && y < self.full_scale_dn
            && u >= b
            && v >= b
            && u + b < self.w()
            && v + b < self.h()
            && self.sky[k].as_ref().is_none_or(|m| m.is_sky(u, v))
    }
}

/// Pixel (u, v)'s chain stages under `f`: from a base's where given, else all evaluated.
#[inline(always)]
fn stages_of(f: &ChainFrame, uv: (usize, usize), from: Option<(Stages, Reuse)>) -> Stages {
    match from {
        Some((base, reuse)) => base.from(f, uv, reuse),
        None => Stages::of(f, uv),
    }
}

/// The sensor's response to the model photo-signal `signal_dn` (the sensor effects:
/// `sensor_nonlinearity`, …; the identity at neutral), as the chain's `sensor_dn`
/// applies it.
#[inline(always)]
fn nonlinear(f: &ChainFrame, signal_dn: f64) -> f64 {
    crate::chain::sensor_effects(&f.sensor, signal_dn, f.response.full_scale_dn())
}
