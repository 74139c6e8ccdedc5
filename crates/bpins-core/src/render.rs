//! Simulation from the front door: a sky, a camera, a sensor, effects and an attitude
//! in; the sky's Stokes, AoP and DoLP maps and the sensor's raw DN frame (its noise
//! seeded: the same seed gives the same bits) out; and one trial of the seed paper's
//! Monte Carlo error analysis.
//!
//! A [`Renderer`] is built once from a [`RendererConfig`] (the camera's nominal
//! [`Intrinsics`], the sensor's size, [`Layout`] and [`Response`], the lens and sensor
//! effects as an [`EffectSet`] of the catalog, the scene elements as a [`FieldScene`]
//! of the catalog, the sky's peak DoLP); per frame it takes a [`View`] (the sun's
//! azimuth and elevation, the camera's heading and tilt) and, for the DN, the
//! frame's [`NoiseIndex`] (seed, trial, frame). Where a caller renders many frames the
//! `_into` forms write into its buffers ([`SkyMaps`], [`RawFrame`]), which keep their
//! allocation from frame to frame.
//!
//! It is the per-pixel chain the CLI's `bpins simulate`, the Python `bpins.simulate`,
//! the fit and the sweep run (`chain`, `simulate`: private), not a copy of it.
//!
//! ```
//! use bpins_core::camera::{Intrinsics, Projection};
//! use bpins_core::compass::{Attitude, Compass, CompassConfig, RawImage, Sun};
//! use bpins_core::render::{Renderer, RendererConfig, SkyMaps, Stage, View};
//! use bpins_core::sensor::Response;
//! use bpins_core::NoiseIndex;
//!
//! // A DoFP camera (an IMX250MZR-like sensor, binned, behind an 8 mm lens) with the
//! // sample captures' 12-bit response; the gain puts the sky's peak at 70 % of range.
//! let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
//! let mut renderer = Renderer::new(RendererConfig::dofp(lens, 306, 256, Response::samples(1.0)))?;
//! let view = View { sun_azimuth_deg: 40.0, sun_elevation_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 2.0, tilt_y_deg: -1.0 };
//! renderer.expose(&view, 0.7)?;
//!
//! // The sky reaching the analyzers: Stokes, AoP (image frame) and DoLP per pixel.
//! let mut maps = SkyMaps::default();
//! renderer.sky_maps_into(&view, Stage::Analyzers, &mut maps)?;
//! assert!(maps.dolp.iter().all(|&d| (0.0..=0.6001).contains(&d)));
//!
//! // The raw frame, with shot and read noise keyed by the seed, read back by the compass.
//! let frame = renderer.raw_frame(&view, NoiseIndex { seed: 7, trial: 0, frame: 0 })?;
//! let mut compass = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0))?;
//! let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
//! let tilt = Attitude { tilt_x_deg: 2.0, tilt_y_deg: -1.0, sigma_deg: 0.0 };
//! let fix = compass.heading(RawImage::packed(&frame.dn, 306, 256), sun, tilt)?;
//! assert!((fix.heading_deg().unwrap() - 30.0).abs() < 3.0 * fix.sigma_deg().unwrap());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Frames and angles are CONVENTIONS.md's (`conventions`): the heading is the azimuth
//! of the image top, the tilt is about the camera's x then y axis, AoP runs
//! counter-clockwise as displayed from image +x, in (−90°, 90°].

use crate::camera::Intrinsics;
use crate::chain::{pixel_stokes, sky_along, ChainFrame, NoiseIndex, Scene};
use crate::effects::{EffectSet, Model};
use crate::scene::FieldScene;
use crate::sensor::{Channel, Layout, Response};
use crate::stokes::{meridional_to_image, Stokes};
use rayon::prelude::*;

/// The seed paper's Monte Carlo, one trial at a time ([`paper_trial`]): its
/// configuration (`Default` is the paper's Table 2), its error sources, what a trial
/// drew and the heading errors it gave.
pub use crate::montecarlo::{Source as ErrorSource, SweepConfig as PaperConfig, TrialDraw, TrialResult};

/// Why a [`Renderer`] cannot be built or cannot render a frame.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The configuration: the camera, the sensor's size or response, the sky.
    #[error("the renderer's configuration: {0}")]
    Config(String),
    /// A view's angle outside its range or not a number.
    #[error("view: {0}")]
    View(String),
    /// The Monte Carlo's configuration ([`paper_trial`]).
    #[error("the paper's Monte Carlo: {0}")]
    Trial(String),
    /// An error of the chain below (the analyzers, an effect's value).
    #[error(transparent)]
    Core(#[from] crate::Error),
}

/// What one frame looks at: the sun, and the camera's attitude (CONVENTIONS.md).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct View {
    /// Sun azimuth from North toward East, degrees (any finite value).
    pub sun_azimuth_deg: f64,
    /// Sun elevation above the horizon, degrees, [−90°, 90°].
    pub sun_elevation_deg: f64,
    /// Camera heading: the azimuth of the image top, degrees (any finite value).
    pub heading_deg: f64,
    /// Frame tilt about camera x then y, degrees, each in (−90°, 90°).
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
}

impl View {
    fn check(&self) -> Result<(), RenderError> {
        let why = if !self.sun_azimuth_deg.is_finite() {
            format!("sun azimuth {}° is not a number (degrees from North toward East)", self.sun_azimuth_deg)
        } else if !(-90.0..=90.0).contains(&self.sun_elevation_deg) {
            format!("sun elevation {}° is outside [−90, 90]°", self.sun_elevation_deg)
        } else if !self.heading_deg.is_finite() {
            format!("heading {}° is not a number (the azimuth of the image top)", self.heading_deg)
        } else if self.tilt_x_deg.is_nan() || self.tilt_x_deg.abs() >= 90.0 {
            format!("tilt about x {}° is outside (−90, 90)°", self.tilt_x_deg)
        } else if self.tilt_y_deg.is_nan() || self.tilt_y_deg.abs() >= 90.0 {
            format!("tilt about y {}° is outside (−90, 90)°", self.tilt_y_deg)
        } else {
            return Ok(());
        };
        Err(RenderError::View(why))
    }

    fn scene(&self, dmax: f64) -> Scene {
        Scene {
            sun_az_deg: self.sun_azimuth_deg,
            sun_el_deg: self.sun_elevation_deg,
            heading_deg: self.heading_deg,
            tilt_x_deg: self.tilt_x_deg,
            tilt_y_deg: self.tilt_y_deg,
            dmax,
        }
    }
}

/// What a [`Renderer`] is built from.
#[derive(Clone, Debug)]
pub struct RendererConfig {
    /// The camera's nominal intrinsics (geometry effects in `effects` move the true one).
    pub camera: Intrinsics,
    pub width_px: usize,
    pub height_px: usize,
    /// DoFP (one analyzer per pixel in 2 × 2 tiles) or colocated (every listed channel
    /// at every pixel).
    pub layout: Layout,
    /// Gain (DN per unit sky radiance: [`Renderer::expose`] sets it from a peak),
    /// black level, noise, bit depth and rounding.
    pub response: Response,
    /// The lens and sensor effects, the truth the frame is rendered with (catalog names).
    pub effects: EffectSet,
    /// The scene elements (clouds, the skyline, …); empty: the clear Rayleigh sky.
    pub scene: FieldScene,
    /// The sky's peak degree of linear polarization (Rayleigh d_max), [0, 1].
    pub dmax: f64,
}

impl RendererConfig {
    /// A DoFP sensor with the default mosaic (90° 45° / 135° 0°), no effects, the
    /// clear sky with d_max 0.6.
    pub fn dofp(camera: Intrinsics, width_px: usize, height_px: usize, response: Response) -> Self {
        RendererConfig {
            camera,
            width_px,
            height_px,
            layout: Layout::Dofp { mosaic: crate::sensor::DEFAULT_MOSAIC },
            response,
            effects: EffectSet::new(),
            scene: FieldScene::default(),
            dmax: 0.6,
        }
    }
}

/// Where along the chain a [`SkyMaps`] is taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// The sky as it arrives at the camera along each pixel's true ray: Rayleigh, the
    /// sky effects and the scene elements, before the lens's effects, in the image frame.
    Sky,
    /// After the lens's per-pixel effects (diattenuation, retardance, vignetting, stray
    /// light, …): what reaches the pixel's analyzer, noise-free.
    Analyzers,
}

/// Per-pixel polarization maps of a `width_px × height_px` frame, row-major, f32. The
/// Stokes components are in the image frame (CONVENTIONS.md), in sky radiance units
/// (a pixel's photo-signal in DN is about the response's gain times its analyzer's
/// intensity); no NaN (an unpolarized pixel has DoLP 0).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkyMaps {
    pub width_px: usize,
    pub height_px: usize,
    /// Stokes S0 (total intensity).
    pub s0: Vec<f32>,
    /// Stokes S1 (Q, along image x).
    pub s1: Vec<f32>,
    /// Stokes S2 (U, at 45° counter-clockwise from image x as displayed).
    pub s2: Vec<f32>,
    /// Angle of polarization α, degrees, (−90°, 90°], counter-clockwise from image +x.
    pub aop_deg: Vec<f32>,
    /// Degree of linear polarization, 1.
    pub dolp: Vec<f32>,
    /// Angle of the E-vector to the local meridian, α − β (β: the pixel's image angle
    /// about the true principal point), degrees, (−90°, 90°].
    pub aoe_deg: Vec<f32>,
}

/// A raw frame as the sensor reads it out, DN (f32; whole numbers where the response
/// rounds): DoFP, one `width_px × height_px` plane, row-major; colocated, one such
/// plane per channel of the layout, in its order, one after the other.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawFrame {
    pub width_px: usize,
    pub height_px: usize,
    /// The channel of each plane (DoFP: none, the mosaic says which pixel is which).
    pub channels: Vec<Channel>,
    pub dn: Vec<f32>,
}

impl RawFrame {
    /// Plane `k` (DoFP: 0 only), `width_px × height_px` DN.
    pub fn plane(&self, k: usize) -> &[f32] {
        let n = self.width_px * self.height_px;
        &self.dn[k * n..(k + 1) * n]
    }

    /// The DN as `u16` into `out` (resized to fit): exact where the response rounds to
    /// a bit depth of at most 16, as a camera delivers them; a saturating cast otherwise.
    pub fn to_u16_into(&self, out: &mut Vec<u16>) {
        out.clear();
        out.extend(self.dn.iter().map(|&x| x as u16));
    }
}

/// A simulated camera: build once ([`Renderer::new`]), then render frames of any view.
/// `Send` and `Sync`: one renderer may serve many threads.
#[derive(Clone, Debug)]
pub struct Renderer {
    cfg: RendererConfig,
    model: Model,
}

impl Renderer {
    /// Checks the configuration and folds the effects.
    pub fn new(cfg: RendererConfig) -> Result<Renderer, RenderError> {
        let bad = |m: String| Err(RenderError::Config(m));
        let (w, h) = (cfg.width_px, cfg.height_px);
        if w == 0 || h == 0 || w.checked_mul(h).is_none_or(|n| n > u32::MAX as usize) {
            return bad(format!("sensor of {w} × {h} px: each side at least 1, at most 2³² pixels in all"));
        }
        let c = &cfg.camera;
        if !(c.f_px > 0.0 && c.f_px.is_finite()) {
            return bad(format!("focal length {} px must be a finite number > 0", c.f_px));
        }
        if !(c.cx_px.is_finite() && c.cy_px.is_finite() && c.distortion.iter().all(|k| k.is_finite())) {
            return bad(format!(
                "principal point ({}, {}) px and distortion {:?} must be finite",
                c.cx_px, c.cy_px, c.distortion
            ));
        }
        if let Layout::Colocated { channels } = &cfg.layout {
            let mut seen = [false; 4];
            if channels.is_empty() || channels.iter().any(|c| std::mem::replace(&mut seen[c.index()], true)) {
                return bad(format!("colocated channels {channels:?}: at least one, each at most once"));
            }
        }
        let r = &cfg.response;
        if !(1..=32).contains(&r.bit_depth) {
            return bad(format!("bit depth {} outside 1…32", r.bit_depth));
        }
        for (name, v) in [
            ("gain_dn", r.gain_dn),
            ("black_level_dn", r.black_level_dn),
            ("read_noise_dn", r.read_noise_dn),
            ("system_gain_dn_per_e", r.system_gain_dn_per_e),
            ("dsnu_dn", r.dsnu_dn),
            ("prnu", r.prnu),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return bad(format!("response {name} {v} must be a finite number ≥ 0"));
            }
        }
        if !(0.0..=1.0).contains(&cfg.dmax) {
            return bad(format!("sky d_max {} outside [0, 1]", cfg.dmax));
        }
        let model = cfg.effects.model();
        Ok(Renderer { cfg, model })
    }

    pub fn config(&self) -> &RendererConfig {
        &self.cfg
    }

    /// Sets the response's gain so that the nominal sensor's brightest channel under
    /// `view` (no effects; with scene elements, their sky without the sun's disc and
    /// aureole, which then saturate where in view) sits at `peak_fraction` of the range
    /// above the black level, as `bpins simulate --peak-fraction` does; returns the
    /// gain (DN per unit sky radiance).
    pub fn expose(&mut self, view: &View, peak_fraction: f64) -> Result<f64, RenderError> {
        view.check()?;
        if !(peak_fraction > 0.0 && peak_fraction <= 1.0) {
            return Err(RenderError::Config(format!("peak fraction {peak_fraction} outside (0, 1]")));
        }
        let (w, h) = (self.cfg.width_px, self.cfg.height_px);
        let scene = view.scene(self.cfg.dmax);
        let peak = if self.cfg.scene.is_empty() {
            crate::simulate::peak_intensity(&Model::default(), &self.cfg.camera, &scene, w, h, 8)
        } else {
            let sky = self.cfg.scene.without(crate::scene::sun_disc::ELEMENT.name);
            let idx = NoiseIndex { seed: 0, trial: 0, frame: 0 };
            let f = ChainFrame::new_in_field(
                &Model::default(),
                &self.cfg.camera,
                &scene,
                &Response::ideal(1.0),
                idx,
                Some(&sky),
            );
            crate::simulate::peak_signal(&f, w, h, 8)
        };
        if !(peak > 0.0 && peak.is_finite()) {
            return Err(RenderError::Config(format!(
                "the view's peak signal {peak} is not positive: nothing to expose"
            )));
        }
        let r = &mut self.cfg.response;
        r.gain_dn = peak_fraction * (r.full_scale_dn() - r.black_level_dn) / peak;
        Ok(r.gain_dn)
    }

    /// The chain of one frame: the view, the effects, the scene and the noise key.
    fn frame(&self, view: &View, noise: NoiseIndex) -> Result<ChainFrame, RenderError> {
        view.check()?;
        let field = (!self.cfg.scene.is_empty()).then_some(&self.cfg.scene);
        Ok(ChainFrame::new_in_field(
            &self.model,
            &self.cfg.camera,
            &view.scene(self.cfg.dmax),
            &self.cfg.response,
            noise,
            field,
        ))
    }

    /// The polarization maps of `view` at `stage`, noise-free.
    pub fn sky_maps(&self, view: &View, stage: Stage) -> Result<SkyMaps, RenderError> {
        let mut out = SkyMaps::default();
        self.sky_maps_into(view, stage, &mut out)?;
        Ok(out)
    }

    /// [`Renderer::sky_maps`] into `out`, whose buffers are resized and reused.
    pub fn sky_maps_into(&self, view: &View, stage: Stage, out: &mut SkyMaps) -> Result<(), RenderError> {
        // The scene elements' per-frame draws are those of frame 0 (as `raw_frame` with frame 0).
        let f = self.frame(view, NoiseIndex { seed: 0, trial: 0, frame: 0 })?;
        let (w, h) = (self.cfg.width_px, self.cfg.height_px);
        out.width_px = w;
        out.height_px = h;
        for v in [&mut out.s0, &mut out.s1, &mut out.s2, &mut out.aop_deg, &mut out.dolp, &mut out.aoe_deg] {
            v.clear();
            v.resize(w * h, 0.0);
        }
        let c = (f.intr.cx_px, f.intr.cy_px);
        out.s0
            .par_chunks_mut(w)
            .zip(out.s1.par_chunks_mut(w))
            .zip(out.s2.par_chunks_mut(w))
            .zip(out.aop_deg.par_chunks_mut(w))
            .zip(out.dolp.par_chunks_mut(w))
            .zip(out.aoe_deg.par_chunks_mut(w))
            .enumerate()
            .for_each(|(v, (((((s0, s1), s2), aop), dolp), aoe))| {
                for u in 0..w {
                    let (x, y) = (u as f64, v as f64);
                    let s: Stokes = match stage {
                        Stage::Analyzers => pixel_stokes(&f, x, y),
                        Stage::Sky => {
                            let g = f.intr.geometry(x, y);
                            meridional_to_image(sky_along::<true>(&f, &g), g.basis.cos2b, g.basis.sin2b)
                        }
                    };
                    let [a, d, e] = crate::chain::sky_angles(s, x, y, c);
                    (s0[u], s1[u], s2[u]) = (s.i as f32, s.q as f32, s.u as f32);
                    (aop[u], dolp[u], aoe[u]) = (a, d, e);
                }
            });
        Ok(())
    }

    /// The raw frame of `view`, its noise drawn from `noise` (the same index gives the
    /// same bits whatever the thread count; another seed, other noise).
    pub fn raw_frame(&self, view: &View, noise: NoiseIndex) -> Result<RawFrame, RenderError> {
        let mut out = RawFrame::default();
        self.raw_frame_into(view, noise, &mut out)?;
        Ok(out)
    }

    /// [`Renderer::raw_frame`] into `out`, whose buffer is resized and reused (a DoFP
    /// frame is rendered in place; a colocated one through row buffers).
    pub fn raw_frame_into(&self, view: &View, noise: NoiseIndex, out: &mut RawFrame) -> Result<(), RenderError> {
        let f = self.frame(view, noise)?;
        let (w, h) = (self.cfg.width_px, self.cfg.height_px);
        out.width_px = w;
        out.height_px = h;
        out.channels.clear();
        match &self.cfg.layout {
            Layout::Dofp { mosaic } => {
                out.dn.resize(w * h, 0.0);
                out.dn.truncate(w * h);
                crate::simulate::render_mosaic_into(&f, w, h, mosaic, &mut out.dn);
            }
            Layout::Colocated { channels } => {
                out.channels.extend_from_slice(channels);
                out.dn.clear();
                for plane in crate::simulate::render_colocated(&f, w, h, channels) {
                    out.dn.extend_from_slice(&plane);
                }
            }
        }
        Ok(())
    }
}

/// One trial of the seed paper's Monte Carlo (§4, seed Tables 1 and 3; what a trial
/// is: the private `montecarlo` module's doc, and `docs/` PAPER.md): trial `trial` of
/// `source` draws its errors (keyed by the configuration's seed, the source and the
/// trial: re-run alone, it gives the same bits), renders the colocated frame with
/// them, reconstructs it with the nominal analyzers and reads the heading with every
/// extractor; the result holds each extractor's heading error (with the lens ρ known
/// and unknown where the source has a lens error).
///
/// ```
/// use bpins_core::render::{paper_trial, ErrorSource, PaperConfig};
/// // The paper's setup at a quarter of its resolution (the same field of view).
/// let cfg = PaperConfig { width_px: 306, height_px: 256, pixel_pitch_um: 13.8, ..PaperConfig::default() };
/// let t = paper_trial(&cfg, ErrorSource::ArrayRotation, 3)?;
/// assert_eq!(t.draw.sun_az_deg, 10.0);
/// // A rotated analyzer array turns the heading by about its angle.
/// for (extractor, _, err_deg) in &t.errors {
///     assert!(err_deg.abs() < 1.0, "{extractor:?}: {err_deg}°");
/// }
/// # Ok::<(), bpins_core::render::RenderError>(())
/// ```
pub fn paper_trial(cfg: &PaperConfig, source: ErrorSource, trial: usize) -> Result<TrialResult, RenderError> {
    let bad = |m: String| Err(RenderError::Trial(m));
    let (w, h) = (cfg.width_px, cfg.height_px);
    if w < 2 || h < 2 || w.checked_mul(h).is_none_or(|n| n > u32::MAX as usize) {
        return bad(format!("sensor of {w} × {h} px: each side at least 2, at most 2³² pixels in all"));
    }
    let (pitch, focal) = (cfg.pixel_pitch_um, cfg.focal_length_mm);
    if !(pitch > 0.0 && focal > 0.0 && pitch.is_finite() && focal.is_finite()) {
        return bad(format!(
            "pixel pitch {} µm and focal length {} mm must be finite numbers > 0",
            cfg.pixel_pitch_um, cfg.focal_length_mm
        ));
    }
    if cfg.sun_azimuths_deg.is_empty() || cfg.sun_azimuths_deg.iter().any(|a| !a.is_finite()) {
        return bad(format!("sun azimuths {:?}: at least one, each finite", cfg.sun_azimuths_deg));
    }
    if !(-90.0..=90.0).contains(&cfg.sun_el_deg) {
        return bad(format!("sun elevation {}° outside [−90, 90]°", cfg.sun_el_deg));
    }
    if cfg.trials_per_azimuth == 0 || trial >= cfg.trials_per_source() {
        return bad(format!(
            "trial {trial}: {} trials per source ({} per azimuth × {} azimuths)",
            cfg.trials_per_source(),
            cfg.trials_per_azimuth,
            cfg.sun_azimuths_deg.len()
        ));
    }
    if !(cfg.peak_dn > 0.0 && cfg.peak_dn.is_finite() && (0.0..=1.0).contains(&cfg.dmax)) {
        return bad(format!("peak {} DN must be > 0 and d_max {} in [0, 1]", cfg.peak_dn, cfg.dmax));
    }
    Ok(crate::montecarlo::run_trial(cfg, source, trial)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::compass::{Attitude, Compass, CompassConfig, RawImage, Sun};
    use crate::conventions::{wrap_deg_180, wrap_deg_90};

    fn lens() -> Intrinsics {
        Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5)
    }

    fn view() -> View {
        View { sun_azimuth_deg: 40.0, sun_elevation_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 2.0, tilt_y_deg: -1.0 }
    }

    fn exposed(response: Response) -> Renderer {
        let mut r = Renderer::new(RendererConfig::dofp(lens(), 306, 256, response)).unwrap();
        r.expose(&view(), 0.7).unwrap();
        r
    }

    fn seed(seed: u64) -> NoiseIndex {
        NoiseIndex { seed, trial: 0, frame: 0 }
    }

    #[test]
    fn the_same_seed_gives_the_same_bits_another_seed_other_noise() {
        let r = exposed(Response::samples(1.0));
        let a = r.raw_frame(&view(), seed(5)).unwrap();
        let b = r.raw_frame(&view(), seed(5)).unwrap();
        assert_eq!(
            a.dn.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            b.dn.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        // Into a buffer that held another frame: the same bits again.
        let mut c = r.raw_frame(&View { heading_deg: 200.0, ..view() }, seed(9)).unwrap();
        r.raw_frame_into(&view(), seed(5), &mut c).unwrap();
        assert_eq!(a, c);
        // The bits of the private driver the CLI and Python render with.
        let f = r.frame(&view(), seed(5)).unwrap();
        assert_eq!(a.dn, crate::simulate::render_mosaic(&f, 306, 256, &crate::sensor::DEFAULT_MOSAIC));
        let d = r.raw_frame(&view(), seed(6)).unwrap();
        let differ = a.dn.iter().zip(&d.dn).filter(|(x, y)| x != y).count();
        assert!(differ > a.dn.len() / 2, "only {differ} of {} pixels differ", a.dn.len());
        // Whole DN within the 12-bit range, as a camera delivers them.
        assert!(a.dn.iter().all(|&x| x.fract() == 0.0 && (0.0..=4095.0).contains(&x)));
        let mut raw = Vec::new();
        a.to_u16_into(&mut raw);
        assert!(raw.iter().zip(&a.dn).all(|(&u, &x)| u as f32 == x));
    }

    #[test]
    fn without_noise_the_dn_are_the_noise_free_rendering_rounded() {
        let quiet = Response { read_noise_dn: 0.0, system_gain_dn_per_e: 0.0, ..Response::samples(1.0) };
        let q = exposed(quiet);
        let smooth = exposed(Response { quantize: false, ..quiet });
        let (a, b) = (q.raw_frame(&view(), seed(1)).unwrap(), smooth.raw_frame(&view(), seed(2)).unwrap());
        let mut near_half = 0;
        for (&dn, &x) in a.dn.iter().zip(&b.dn) {
            // The f32 of the smooth DN may sit on the other side of a half.
            if ((x as f64).fract() - 0.5).abs() < 1e-3 {
                near_half += 1;
                assert!((dn - x).abs() <= 0.5 + 1e-3);
            } else {
                assert_eq!(dn as f64, (x as f64 + 0.5).floor().clamp(0.0, 4095.0), "{x}");
            }
        }
        assert!(near_half < a.dn.len() / 100, "{near_half}");
        // The smooth DN are the analyzers' maps through the channel's analyzer, plus black.
        let maps = smooth.sky_maps(&view(), Stage::Analyzers).unwrap();
        let g = smooth.config().response.gain_dn;
        for (u, v) in [(0usize, 0usize), (151, 127), (305, 255), (40, 201)] {
            let k = v * 306 + u;
            let ch = Layout::dofp_channel(&crate::sensor::DEFAULT_MOSAIC, u, v);
            let t = ch.angle_deg().to_radians() * 2.0;
            let want = 64.0 + g * 0.5 * (maps.s0[k] as f64 + maps.s1[k] as f64 * t.cos() + maps.s2[k] as f64 * t.sin());
            assert!((b.dn[k] as f64 - want).abs() < 1e-3 * want, "({u}, {v}): {} vs {want}", b.dn[k]);
        }
    }

    #[test]
    fn the_aop_at_the_zenith_of_a_level_camera_is_perpendicular_to_the_sun() {
        // Level at heading 0: North up, East left (CONVENTIONS.md). The sun at azimuth A
        // lies in the image at angle 90° + A; Rayleigh's E-vector at the zenith is
        // perpendicular to it: AoP = A (mod 180°), and DoLP = d_max sin²γ/(1 + cos²γ)
        // with γ the sun's zenith angle.
        let cam = Intrinsics::new(Projection::Equidistant, 30.0, 32.0, 32.0);
        let r = Renderer::new(RendererConfig::dofp(cam, 65, 65, Response::ideal(1.0))).unwrap();
        let k = 32 * 65 + 32;
        for (az, el) in [(0.0, 30.0), (30.0, 10.0), (90.0, 45.0), (135.0, 5.0), (250.0, 60.0)] {
            let v = View { sun_azimuth_deg: az, sun_elevation_deg: el, ..View::default() };
            for stage in [Stage::Sky, Stage::Analyzers] {
                let m = r.sky_maps(&v, stage).unwrap();
                let d = wrap_deg_90(m.aop_deg[k] as f64 - az);
                assert!(d.abs() < 1e-4, "sun at {az}°: AoP {}° at the zenith", m.aop_deg[k]);
                let g = (90.0f64 - el).to_radians();
                let want = 0.6 * g.sin().powi(2) / (1.0 + g.cos().powi(2));
                assert!((m.dolp[k] as f64 - want).abs() < 1e-5, "{} vs {want}", m.dolp[k]);
                assert_eq!(m.aoe_deg[k], m.aop_deg[k]);
            }
        }
    }

    #[test]
    fn the_lens_shows_behind_the_lens_and_not_before() {
        let mut cfg = RendererConfig::dofp(lens(), 306, 256, Response::ideal(1.0));
        cfg.effects.set("lens_diattenuation", "rho2", 0.8).unwrap();
        let with = Renderer::new(cfg).unwrap();
        let without = Renderer::new(RendererConfig::dofp(lens(), 306, 256, Response::ideal(1.0))).unwrap();
        let sky = with.sky_maps(&view(), Stage::Sky).unwrap();
        assert_eq!(sky, without.sky_maps(&view(), Stage::Sky).unwrap());
        assert_eq!(sky, without.sky_maps(&view(), Stage::Analyzers).unwrap());
        let behind = with.sky_maps(&view(), Stage::Analyzers).unwrap();
        let corner = 0;
        assert!((behind.dolp[corner] - sky.dolp[corner]).abs() > 1e-3);
        // The private maps the GPU twin is checked against, within f32 rounding.
        let f = with.frame(&view(), seed(0)).unwrap();
        let m = crate::simulate::sky_maps(&f, 306, 256);
        for k in (0..306 * 256).step_by(97) {
            assert!(wrap_deg_90((m.aop_deg[k] - behind.aop_deg[k]) as f64).abs() < 1e-4);
            assert!((m.dolp[k] - behind.dolp[k]).abs() < 1e-6);
        }
    }

    /// The CLI's and Python's simulation path (`pipeline::sim_response`,
    /// `simulate_frame`): the same gain and the same bits, so they can move onto the
    /// renderer without a change in their frames.
    #[cfg(all(feature = "io", feature = "spa"))]
    #[test]
    fn the_same_gain_and_bits_as_the_captures_simulation() {
        use crate::capture::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
        use crate::pipeline::{sim_response, simulate_frame, SimSensor};
        use crate::sensor::Geometry;
        use crate::sky::sun::SunPosition;
        let v = view();
        let capture = Capture {
            dir: ".".into(),
            sensor: SensorSpec {
                colour: None,
                layout: Layout::Dofp { mosaic: crate::sensor::DEFAULT_MOSAIC },
                geometry: Geometry { width_px: 306, height_px: 256, pixel_pitch_um: 27.6 },
                bit_depth: 12,
                black_level_dn: 64.0,
            },
            lens: LensSpec {
                projection: Projection::Pinhole,
                focal_length_mm: 8.0,
                principal_point_px: (152.5, 127.5),
            },
            frames: vec![FrameSpec {
                heading_deg: Some(v.heading_deg),
                tilt_x_deg: Some(v.tilt_x_deg),
                tilt_y_deg: Some(v.tilt_y_deg),
                ..FrameSpec::new("frames/f000.png", SunPosition::given(v.sun_azimuth_deg, v.sun_elevation_deg))
            }],
        };
        let mut effects = EffectSet::new();
        effects.set("lens_diattenuation", "rho2", 0.3).unwrap();
        let sim = SimSensor { seed: 4, ..SimSensor::samples(4) };
        let resp = sim_response(&capture, &sim, None).unwrap();
        let FrameData::Mosaic { dn, .. } = simulate_frame(&capture, 0, &effects.model(), &resp, &sim, None) else {
            panic!("a dofp capture renders a mosaic")
        };
        let mut cfg = RendererConfig::dofp(capture.intrinsics(), 306, 256, Response::samples(1.0));
        cfg.effects = effects;
        let mut r = Renderer::new(cfg).unwrap();
        assert_eq!(r.expose(&v, sim.peak_fraction).unwrap(), resp.gain_dn);
        assert_eq!(r.config().response, resp);
        assert_eq!(r.raw_frame(&v, seed(4)).unwrap().dn, dn);
    }

    #[test]
    fn the_compass_reads_the_views_heading_back_within_its_sigma() {
        let r = exposed(Response::samples(1.0));
        let mut compass = Compass::new(CompassConfig::dofp(lens(), 306, 256, 12, 64.0)).unwrap();
        let mut raw = Vec::new();
        let mut frame = RawFrame::default();
        for (k, heading_deg) in [30.0, 135.0, 290.0].into_iter().enumerate() {
            let v = View { heading_deg, ..view() };
            r.raw_frame_into(&v, seed(k as u64 + 1), &mut frame).unwrap();
            frame.to_u16_into(&mut raw);
            let sun =
                Sun::Angles { azimuth_deg: v.sun_azimuth_deg, elevation_deg: v.sun_elevation_deg, sigma_deg: 0.0 };
            let tilt = Attitude { tilt_x_deg: v.tilt_x_deg, tilt_y_deg: v.tilt_y_deg, sigma_deg: 0.0 };
            let fix = compass.heading(RawImage::packed(&raw, 306, 256), sun, tilt).unwrap();
            let (got, sigma) = (fix.heading_deg().unwrap(), fix.sigma_deg().unwrap());
            let err = wrap_deg_180(got - heading_deg);
            assert!(err.abs() < sigma, "heading {heading_deg}°: {err}° off, 1σ {sigma}°");
        }
    }

    #[test]
    fn colocated_frames_are_planes_in_the_layouts_order() {
        let mut cfg = RendererConfig::dofp(lens(), 40, 30, Response::ideal(100.0));
        cfg.layout = Layout::Colocated { channels: vec![Channel::C90, Channel::C0, Channel::C45] };
        let r = Renderer::new(cfg.clone()).unwrap();
        let fr = r.raw_frame(&view(), seed(1)).unwrap();
        assert_eq!((fr.dn.len(), fr.channels.clone()), (3 * 40 * 30, vec![Channel::C90, Channel::C0, Channel::C45]));
        let dofp =
            Renderer::new(RendererConfig { layout: Layout::Dofp { mosaic: crate::sensor::DEFAULT_MOSAIC }, ..cfg })
                .unwrap()
                .raw_frame(&view(), seed(1))
                .unwrap();
        // Where the mosaic's pixel is one of the planes' channels, the same DN.
        for v in 0..30 {
            for u in 0..40 {
                let ch = Layout::dofp_channel(&crate::sensor::DEFAULT_MOSAIC, u, v);
                if let Some(k) = fr.channels.iter().position(|&c| c == ch) {
                    assert_eq!(fr.plane(k)[v * 40 + u], dofp.dn[v * 40 + u]);
                }
            }
        }
    }

    #[test]
    fn bad_configurations_and_views_are_typed_errors() {
        let cfg = RendererConfig::dofp(lens(), 306, 256, Response::samples(1.0));
        let mut bad = cfg.clone();
        bad.width_px = 0;
        assert!(matches!(Renderer::new(bad), Err(RenderError::Config(_))));
        let mut bad = cfg.clone();
        bad.camera.f_px = f64::NAN;
        assert!(matches!(Renderer::new(bad), Err(RenderError::Config(_))));
        let mut bad = cfg.clone();
        bad.dmax = 1.5;
        assert!(matches!(Renderer::new(bad), Err(RenderError::Config(_))));
        let mut bad = cfg.clone();
        bad.layout = Layout::Colocated { channels: vec![Channel::C0, Channel::C0] };
        assert!(matches!(Renderer::new(bad), Err(RenderError::Config(_))));
        let mut r = Renderer::new(cfg).unwrap();
        assert!(matches!(r.expose(&view(), 0.0), Err(RenderError::Config(_))));
        let v = View { sun_elevation_deg: 91.0, ..view() };
        assert!(matches!(r.raw_frame(&v, seed(1)), Err(RenderError::View(_))));
        let v = View { tilt_x_deg: f64::NAN, ..view() };
        assert!(matches!(r.sky_maps(&v, Stage::Sky), Err(RenderError::View(_))));
    }

    #[test]
    fn a_paper_trial_is_the_montecarlos_trial() {
        let cfg = PaperConfig {
            width_px: 306,
            height_px: 256,
            pixel_pitch_um: 13.8,
            trials_per_azimuth: 2,
            sun_azimuths_deg: vec![10.0, 50.0],
            ..PaperConfig::default()
        };
        let t = paper_trial(&cfg, ErrorSource::Combined, 3).unwrap();
        assert_eq!(t, crate::montecarlo::run_trial(&cfg, ErrorSource::Combined, 3).unwrap());
        assert_eq!(t.draw.sun_az_deg, 50.0);
        // With a lens error: each extractor with ρ known and unknown.
        assert_eq!(t.errors.len(), 2 * crate::compass::Extractor::ALL.len());
        assert!(matches!(paper_trial(&cfg, ErrorSource::Combined, 4), Err(RenderError::Trial(_))));
        let none = PaperConfig { sun_azimuths_deg: vec![], ..cfg };
        assert!(matches!(paper_trial(&none, ErrorSource::Combined, 0), Err(RenderError::Trial(_))));
    }
}
