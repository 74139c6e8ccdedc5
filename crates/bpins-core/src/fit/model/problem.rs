//! The problem a fit solves: the capture's frames (every pixel or a sample), the typed parameter
//! slots, the noise and each frame's sky mask and radiance basis; and the model it
//! evaluates — one frame's chain under a parameter vector, one pixel's model DN.
//!
//! A colour-polarization sensor (`colour_tiles`, CONVENTIONS.md) is modelled as
//! `bpins simulate` renders it (`simulate::render_colour_mosaic`): each pixel through
//! the frame of the band over it ([`ChainFrame::bands`]: the band's d_max, gain and
//! analyzer ε; `chain::colour_pixel_signal_dn` under crosstalk), so the band block's
//! parameters (`sky_spectrum`, `band_response`) are fitted like any other.

use crate::camera::Intrinsics;
use crate::capture::Capture;
use crate::capture::FrameData as Whole;
use crate::chain::{colour_pixel_signal_dn, mosaic_pixel_signal_dn, ChainFrame, NoiseIndex, Scene};
use crate::effects::Model;
use crate::error::Result;
use crate::fit::input::frames::{value_of, FitFrames};
use crate::fit::input::noise::NoiseModel;
use crate::fit::model::radiance;
use crate::fit::model::slots::{Nuisance, SlotId, Slots};
use crate::fit::model::stages::{Reuse, Stages};
use crate::fit::model::start;
use crate::fit::{FitOptions, FitState, BORDER_PX};
use crate::heading::field::SkyMask;
use crate::scene::twilight::{OtherSky, Twilight};
use crate::sensor::{ColourTiles, Layout, Response};
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
    /// Per frame: a mixed twilight's second sky (`fit::input::sky::second_skies`), its
    /// d_max set per chain to the frame's; `None` for a frame one source lights.
    pub second: Vec<Option<OtherSky>>,
}

/// One frame's chain and its radiance nuisance.
pub(crate) struct FitFrame {
    pub chain: ChainFrame,
    /// A colour sensor's band frames and filter layout; `None` on a monochrome sensor.
    pub bands: Option<Box<Bands>>,
    pub radiance: [f64; radiance::N],
    /// The same as weights of the raw functions (`radiance::Basis::weights`).
    pub radiance_weights: [f64; radiance::N + 1],
}

/// A colour-polarization frame's three band frames ([`ChainFrame::bands`], by
/// [`Band::index`](crate::sensor::Band::index)) and the filter over each tile.
pub(crate) struct Bands {
    pub frames: [ChainFrame; 3],
    pub tiles: ColourTiles,
}

impl FitFrame {
    /// The frame pixel (u, v) is rendered through: its band's on a colour sensor, the
    /// frame's own on a monochrome one.
    #[inline(always)]
    pub fn at(&self, u: usize, v: usize) -> &ChainFrame {
        match &self.bands {
            None => &self.chain,
            Some(b) => &b.frames[b.tiles.band_at(u, v).index()],
        }
    }

    /// What this frame's chain can reuse of `base`'s at the same pixel
    /// ([`Reuse::between`]; a colour frame: the least over its bands, as a pixel of
    /// any band may be asked).
    pub fn reuse_from(&self, base: &FitFrame) -> Reuse {
        match (&self.bands, &base.bands) {
            (Some(a), Some(b)) => {
                a.frames.iter().zip(&b.frames).map(|(f, g)| Reuse::between(f, g)).min().unwrap_or(Reuse::Nothing)
            }
            _ => Reuse::between(&self.chain, &base.chain),
        }
    }
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
    let second = crate::fit::input::sky::second_skies(c);
    let mut slots = Slots::new(opts, &reference);
    slots.free_twilight(&second.iter().map(Option::is_some).collect::<Vec<_>>());
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
        second,
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
        let model = set.model();
        let noise = NoiseIndex { seed: 0, trial: 0, frame: 0 };
        let chain = match self.second.get(k).copied().flatten() {
            // A mixed twilight: the other source's sky added, as the `twilight` scene
            // element renders it, at the frame's d_max and strength k.
            Some(o) => second_sky(&model, &self.nominal, &scene, &resp, o, at(Nuisance::Twilight)),
            None => ChainFrame::new(&model, &self.nominal, &scene, &resp, noise),
        };
        // A colour sensor: each band's frame, as `simulate` renders the mosaic.
        let bands = self
            .capture
            .sensor
            .colour
            .as_ref()
            .map(|tiles| Box::new(Bands { frames: chain.bands(&model, &scene), tiles: tiles.clone() }));
        let radiance: [f64; radiance::N] = std::array::from_fn(|i| at(Nuisance::Radiance(i)));
        let radiance_weights = self.basis.get(k).map_or([0.0; radiance::N + 1], |b| b.weights(&radiance));
        Ok(FitFrame { chain, bands, radiance, radiance_weights })
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
            // A mosaic effect (crosstalk): the pixel's own chain and its four neighbours'
            // (on a colour sensor each through its band's frame).
            Layout::Dofp { mosaic } if f.has_mosaic_effects() => {
                let ch = Layout::dofp_channel(mosaic, u, v).index();
                let signal = match &f.bands {
                    None => mosaic_pixel_signal_dn(f, u, v, w, h, mosaic),
                    Some(b) => colour_pixel_signal_dn(&b.frames, &b.tiles, u, v, w, h, mosaic),
                };
                let m = nonlinear(f, r * signal) + f.offset_dn[ch];
                out.push((measured(0) as f64, m));
                None
            }
            Layout::Dofp { mosaic } => {
                // mosaic_pixel_signal_dn without crosstalk: the pixel's own chain, through
                // its band's frame on a colour sensor (the sensor stage is every band's).
                let f = f.at(u, v);
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

/// The chain of `model` on `scene` with a mixed twilight's second sky `o` added: the
/// `twilight` scene element at `strength` (in the fit's range, which may pass the
/// element's `--scene` range of [0, 1]), its sky at the chain's d_max (the frame's
/// fitted d_max, `sky_depolarization` included).
fn second_sky(
    model: &Model,
    nominal: &Intrinsics,
    scene: &Scene,
    resp: &Response,
    o: OtherSky,
    strength: f64,
) -> ChainFrame {
    let noise = NoiseIndex { seed: 0, trial: 0, frame: 0 };
    let dmax = (scene.dmax * model.sky_block.dmax_factor).min(1.0);
    let other = Some(OtherSky { dmax, ..o });
    let mut field = crate::scene::FieldScene::new(0);
    field.enable(crate::scene::twilight::ELEMENT.name).expect("a registered element");
    let mut chain = ChainFrame::new_in_field(model, nominal, scene, resp, noise, Some(&field));
    debug_assert_eq!(chain.dmax, dmax);
    if let Some(f) = chain.field.as_mut() {
        f.elements = vec![Arc::new(Twilight { strength, other })];
    }
    chain
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::capture::{FrameSpec, LensSpec, SensorSpec};
    use crate::effects::EffectSet;
    use crate::sensor::{Geometry, DEFAULT_MOSAIC};
    use crate::sky::sun::SunPosition;

    /// A 64 × 48 colour capture (RGGB), one frame.
    fn colour_capture() -> Capture {
        Capture {
            dir: "/nowhere".into(),
            sensor: SensorSpec {
                colour: Some(ColourTiles::imx250myr()),
                layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
                geometry: Geometry { width_px: 64, height_px: 48, pixel_pitch_um: 130.0 },
                bit_depth: 12,
                black_level_dn: 64.0,
            },
            lens: LensSpec { projection: Projection::Pinhole, focal_length_mm: 8.0, principal_point_px: (31.5, 23.5) },
            frames: vec![FrameSpec {
                heading_deg: Some(30.0),
                ..FrameSpec::new("f.png", SunPosition::given(40.0, 25.0))
            }],
        }
    }

    /// A mixed twilight's frame (the sun at −12.4°, a 75 % moon: half the light each) is
    /// modelled as `simulate` renders it with the `twilight` element: the moon's sky
    /// added at the frame's d_max and the fitted strength (0.3 here, below the element's
    /// default); a strength of 0 is the sun's sky alone, and the strength's side reuses
    /// the ray only.
    #[test]
    fn a_mixed_twilight_frames_model_is_the_simulated_twilight_at_its_strength() {
        let (t, lat, lon) = ("2026-06-24T12:30:00Z", 36.07, 120.38);
        let sun = crate::sky::source_from_time_place(t, lat, lon).unwrap();
        let mut c = colour_capture();
        c.sensor.colour = None;
        c.frames = vec![FrameSpec { heading_deg: Some(30.0), ..FrameSpec::new("f.png", sun.clone()) }];
        let second = crate::fit::input::sky::second_skies(&c);
        assert!(second[0].is_some_and(|o| o.weight > 0.5 && o.weight < 2.0), "{second:?}");
        let (w, h) = (64, 48);
        let resp = Response { black_level_dn: 64.0, bit_depth: 12, ..Response::ideal(1000.0) };
        let scene = Scene {
            sun_az_deg: sun.azimuth_deg,
            sun_el_deg: sun.elevation_deg,
            heading_deg: 30.0,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            dmax: 0.6,
        };
        let model = EffectSet::new().model();
        let noise = NoiseIndex { seed: 0, trial: 0, frame: 0 };
        // The truth as `simulate` renders it: the element under the frame's time and place.
        let render = |strength: f64| {
            let mut field = crate::scene::FieldScene::new(1);
            field.set("twilight", "strength", strength).unwrap();
            let field = crate::scene::twilight::under(field, &sun, scene.dmax);
            let f = ChainFrame::new_in_field(&model, &c.intrinsics(), &scene, &resp, noise, Some(&field));
            (0..h)
                .flat_map(|v| (0..w).map(move |u| (u, v)))
                .map(|(u, v)| mosaic_pixel_signal_dn(&f, u, v, w, h, &DEFAULT_MOSAIC))
                .collect::<Vec<f64>>()
        };
        let opts = FitOptions { rayleigh_radiance: true, ..Default::default() };
        let data = [Whole::Mosaic { width_px: w as u32, height_px: h as u32, dn: vec![0.0; w * h] }];
        let frames = FitFrames::all(&c, &data).unwrap();
        let mut slots = Slots::new(&opts, &[true]);
        slots.free_twilight(&[true]);
        let pb = Problem {
            capture: &c,
            frames: &frames,
            nominal: c.intrinsics(),
            opts: &opts,
            slots,
            noise: NoiseModel::default(),
            full_scale_dn: c.sensor.full_scale_dn(),
            sky: Arc::new(vec![None]),
            basis: vec![Default::default()],
            second,
        };
        let mut theta = vec![0.0; pb.slots.all.len()];
        for (n, x) in [(Nuisance::Heading, 30.0), (Nuisance::Scale, 1000.0), (Nuisance::Dmax, 0.6)] {
            theta[pb.slots.at(0, n)] = x;
        }
        let mut buf = Vec::new();
        let mut model_at = |strength: f64| {
            theta[pb.slots.at(0, Nuisance::Twilight)] = strength;
            let f = pb.chain(&theta, 0).unwrap();
            let mut m = Vec::with_capacity(w * h);
            for v in 0..h {
                for u in 0..w {
                    pb.pixel(&f, 0, u, v, &mut buf);
                    m.push(buf[0].1 - 64.0);
                }
            }
            (f, m)
        };
        let (base, m03) = model_at(0.3);
        let (_, m0) = model_at(0.0);
        let (truth03, truth0) = (render(0.3), render(0.0));
        let mut moved = 0.0f64;
        for i in 0..w * h {
            assert!((m03[i] - truth03[i]).abs() < 1e-9 * truth03[i], "pixel {i}: {} vs {}", m03[i], truth03[i]);
            assert!((m0[i] - truth0[i]).abs() < 1e-9 * truth0[i], "pixel {i}: {} vs {}", m0[i], truth0[i]);
            moved = moved.max((m03[i] - m0[i]).abs() / m0[i]);
        }
        assert!(moved > 0.05, "the moon's sky moves the model: {moved}");
        theta[pb.slots.at(0, Nuisance::Twilight)] = 0.31;
        assert_eq!(pb.chain(&theta, 0).unwrap().reuse_from(&base), Reuse::Ray);
    }

    /// The fit's model of a colour frame is the mosaic `simulate` renders (noise off):
    /// each pixel through its band, crosstalk across bands; its difference columns
    /// reuse a base's stages only where every band allows.
    #[test]
    fn a_colour_frames_model_is_the_simulated_mosaic() {
        let c = colour_capture();
        let (w, h) = (64, 48);
        for crosstalk in [false, true] {
            let mut set = EffectSet::new();
            for e in ["sky_spectrum", "band_response"] {
                for p in crate::effects::find(e).unwrap().params {
                    set.set(e, p.name, p.typical).unwrap();
                }
            }
            if crosstalk {
                set.set("crosstalk", "c", 0.02).unwrap();
            }
            let model = set.model();
            // The truth, rendered as `simulate` does.
            let resp = Response { black_level_dn: 64.0, bit_depth: 12, ..Response::ideal(1000.0) };
            let scene = Scene {
                sun_az_deg: 40.0,
                sun_el_deg: 25.0,
                heading_deg: 30.0,
                tilt_x_deg: 0.0,
                tilt_y_deg: 0.0,
                dmax: 0.6,
            };
            let truth =
                ChainFrame::new(&model, &c.intrinsics(), &scene, &resp, NoiseIndex { seed: 0, trial: 0, frame: 0 });
            let tiles = ColourTiles::imx250myr();
            let dn = crate::simulate::render_colour_mosaic(&truth.bands(&model, &scene), w, h, &DEFAULT_MOSAIC, &tiles);
            let data = [Whole::Mosaic { width_px: w as u32, height_px: h as u32, dn: dn.clone() }];
            // The fit at the truth: the known effects are the model's.
            let opts = FitOptions { known: set.clone(), rayleigh_radiance: true, ..Default::default() };
            let frames = FitFrames::all(&c, &data).unwrap();
            let pb = Problem {
                capture: &c,
                frames: &frames,
                nominal: c.intrinsics(),
                opts: &opts,
                slots: Slots::new(&opts, &[true]),
                noise: NoiseModel::default(),
                full_scale_dn: c.sensor.full_scale_dn(),
                sky: Arc::new(vec![None]),
                basis: vec![Default::default()],
                second: vec![None],
            };
            let mut theta = vec![0.0; pb.slots.all.len()];
            for (n, x) in [(Nuisance::Heading, 30.0), (Nuisance::Scale, 1000.0), (Nuisance::Dmax, 0.6)] {
                theta[pb.slots.at(0, n)] = x;
            }
            let f = pb.chain(&theta, 0).unwrap();
            let mut buf = Vec::new();
            for v in 0..h {
                for u in 0..w {
                    pb.pixel(&f, 0, u, v, &mut buf);
                    let (y, m) = buf[0];
                    assert_eq!(y, dn[v * w + u] as f64);
                    assert!((m - y).abs() < 1e-3, "({u}, {v}), crosstalk {crosstalk}: model {m}, simulated {y}");
                }
            }
            // A blue d_max factor moves the blue band's sky: its side reuses the ray only.
            let mut set2 = set.clone();
            set2.set("sky_spectrum", "dmax_b", 0.8).unwrap();
            let opts2 = FitOptions { known: set2, ..opts.clone() };
            let side = Problem {
                opts: &opts2,
                slots: Slots::new(&opts2, &[true]),
                sky: pb.sky.clone(),
                basis: vec![Default::default()],
                ..pb
            };
            let want = if crosstalk { Reuse::Nothing } else { Reuse::Ray };
            assert_eq!(side.chain(&theta, 0).unwrap().reuse_from(&f), want);
        }
    }
}
