//! Captures through the chain: simulate a whole capture from a model, and read the
//! heading of every frame of a capture. The glue between `capture` (files) and the
//! per-pixel physics; the CLI and the tests call these.

use crate::calibration::Calibration;
use crate::camera::Intrinsics;
use crate::capture::{Capture, FrameData, FrameSpec};
use crate::chain::{ChainFrame, NoiseIndex, Scene};
use crate::compass::{Attitude, Compass, CompassError};
use crate::effects::Model;
use crate::error::{Error, Result};
use crate::heading::field::{Cells, FieldContext, FieldHeading, FieldOptions};
use crate::heading::{Extractor, HeadingContext, HeadingEstimate, HeadingSums};
use crate::pixel_analyzers::PixelMaps;
use crate::recon::{self, PolImage, Reconstructor};
use crate::scene::FieldScene;
use crate::sensor::{Layout, Response};
use crate::simulate::{peak_intensity, peak_signal, render_colocated, render_mosaic};

#[path = "pipeline_colour.rs"]
mod colour;
pub use colour::{colour_frame_headings_of, ColourPlainHeadings};

/// How a DoFP mosaic becomes Stokes samples (colocated captures ignore it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReconMode {
    /// 2 × 2 tiles → one sample at the tile centre, each channel moved there from its
    /// own pixel by its gradient across the tiles beside it (`recon::superpixels_centred`:
    /// the tile's four rays no longer read the sky's gradient as polarization).
    Superpixel,
    /// Bilinear per channel onto every pixel (each sample at its own ray); neighbours
    /// share raw DN, so the plain 1σ carries their design effect (× 8/3).
    Demosaic,
}

impl ReconMode {
    pub const ALL: [ReconMode; 2] = [ReconMode::Demosaic, ReconMode::Superpixel];

    pub fn name(self) -> &'static str {
        match self {
            ReconMode::Superpixel => "superpixel",
            ReconMode::Demosaic => "demosaic",
        }
    }
}

/// The intrinsics a capture declares with the `known` geometry folded in as the
/// chain folds it ([`Model::camera`]).
pub(crate) fn assumed_intrinsics(c: &Capture, known: &Model) -> Intrinsics {
    known.camera(&c.intrinsics())
}

/// What the heading extractors know about frame `f`: the capture's camera (plus
/// `known` calibrations), the sun, and the frame's reference tilt plus a known mount tilt.
pub(crate) fn heading_context(c: &Capture, f: &FrameSpec, known: &Model) -> HeadingContext {
    let g = &c.sensor.geometry;
    let mut ctx = HeadingContext::new(
        assumed_intrinsics(c, known),
        g.width_px as usize,
        g.height_px as usize,
        f.sun.azimuth_deg,
        f.sun.elevation_deg,
    );
    ctx.tilt_x_deg = f.tilt_x_deg.unwrap_or(0.0);
    ctx.tilt_y_deg = f.tilt_y_deg.unwrap_or(0.0);
    ctx.mount_tilt_deg = known.geometry.mount_tilt_deg;
    ctx.lens_rho2 = crate::effects::lens_diattenuation::rho2(known);
    ctx
}

/// Reconstructs one frame's Stokes samples, undoing the `known` analyzer and channel errors.
pub fn reconstruct_frame(c: &Capture, data: &FrameData, known: &Model, mode: ReconMode) -> Result<PolImage> {
    let rec = Reconstructor::new(known, c.sensor.black_level_dn, &c.sensor.channels())?;
    let full = c.sensor.full_scale_dn();
    Ok(match (data, &c.sensor.layout) {
        (FrameData::Mosaic { width_px, height_px, dn }, Layout::Dofp { mosaic }) => {
            let (w, h) = (*width_px as usize, *height_px as usize);
            match mode {
                ReconMode::Superpixel => recon::superpixels_centred(dn, w, h, mosaic, &rec, full),
                ReconMode::Demosaic => recon::demosaic(dn, w, h, mosaic, &rec, full),
            }
        }
        (FrameData::Colocated { width_px, height_px, channels }, Layout::Colocated { .. }) => {
            let planes: Vec<_> = channels.iter().map(|(ch, p)| (*ch, p.as_slice())).collect();
            recon::colocated(&planes, *width_px as usize, *height_px as usize, &rec, full)
        }
        _ => return Err(Error::FrameMismatch("frame data does not match the capture's sensor layout".into())),
    })
}

/// Frame `data` of capture `c` as nominal pixels would read it, through a lab
/// calibration's per-pixel maps ([`PixelMaps::nominal_mosaic`]): then `heading`,
/// `fit` and `diagnose` read it with nominal analyzers. On a colour-polarization
/// sensor every 2 × 2 tile lies under one filter (CONVENTIONS.md `colour_tiles`), so
/// each tile is solved through its own band's pixels only; its maps are each pixel's
/// total (the band's ε and gain included), so the nominal mosaic is read with a
/// neutral `band_response` (`Calibration::pixels_conflict`). Maps of another sensor
/// size or mosaic are refused, with both named.
pub fn apply_pixel_maps(c: &Capture, data: FrameData, maps: &PixelMaps) -> Result<FrameData> {
    let g = &c.sensor.geometry;
    let refuse = |m: String| Error::Capture { path: c.toml_path(), message: m };
    match (data, &c.sensor.layout) {
        (FrameData::Mosaic { width_px, height_px, dn }, Layout::Dofp { mosaic }) => {
            maps.check_sensor(g.width_px as usize, g.height_px as usize, mosaic).map_err(refuse)?;
            let dn = maps.nominal_mosaic(&dn, c.sensor.black_level_dn, c.sensor.full_scale_dn());
            Ok(FrameData::Mosaic { width_px, height_px, dn })
        }
        _ => Err(refuse("per-pixel maps are for a dofp mosaic; this capture is colocated".into())),
    }
}

/// Heading of frame `index` with each extractor in `extractors` (the plain estimator:
/// every sample, statistical 1σ).
pub fn frame_headings(
    c: &Capture,
    index: usize,
    known: &Model,
    mode: ReconMode,
    extractors: &[Extractor],
) -> Result<Vec<(Extractor, Result<HeadingEstimate>)>> {
    frame_headings_of(c, index, &c.read_frame(index)?, known, mode, extractors)
}

/// [`frame_headings`] of frame `index` whose pixels `data` are already in memory. A DoFP
/// mosaic read with [`ReconMode::Demosaic`] has each 1σ multiplied by √F of the
/// demosaic's samples (`demosaic_design_effect`); superpixels and colocated pixels
/// are independent samples, their 1σ as the extractor gives it.
pub fn frame_headings_of(
    c: &Capture,
    index: usize,
    data: &FrameData,
    known: &Model,
    mode: ReconMode,
    extractors: &[Extractor],
) -> Result<Vec<(Extractor, Result<HeadingEstimate>)>> {
    let img = reconstruct_frame(c, data, known, mode)?;
    let ctx = heading_context(c, &c.frames[index], known);
    let sums = HeadingSums::from_image(&img, &ctx);
    let widen = match (&c.sensor.layout, mode) {
        (Layout::Dofp { .. }, ReconMode::Demosaic) => demosaic_design_effect().sqrt(),
        _ => 1.0,
    };
    let widened = |mut est: HeadingEstimate| {
        est.sigma_deg *= widen;
        est
    };
    Ok(extractors.iter().map(|&e| (e, sums.solve(e, &ctx).map(widened))).collect())
}

/// Kish's design effect (Survey Sampling, 1965) of samples interpolated from independent
/// raw samples of one variance, from one raw sample's footprint `w` (its weight in each
/// interpolated sample it enters; every raw sample's the same, as in a frame's interior):
///
/// ```text
/// mean of N samples y_p = Σ_s w_ps x_s:   Var = σ²/N² · Σ_s (Σ_p w_ps)²
/// the same taken as independent:            Var = σ²/N² · Σ_p Σ_s w_ps²   (each y_p's own variance)
/// F = (Σ_p w_p)² / Σ_p w_p²                 their ratio, ≥ 1 (= 1: each raw sample in one sample only)
/// ```
///
/// The plain extractors' 1σ takes their samples as independent; multiplied by √F it is
/// the noise's through the interpolation's correlation. F is exact for a frame-wide
/// mean and holds where the extractor's influence varies slowly over the footprint (its
/// least squares over the whole frame). It covers the noise only: the sky model's
/// misfit, clouds, the sun's and the tilt's 1σ and a floor are in no plain 1σ.
pub(crate) fn kish_design_effect(footprint: &[f64]) -> f64 {
    let (sum, sq) = footprint.iter().fold((0.0, 0.0), |(a, b), w| (a + w, b + w * w));
    sum * sum / sq
}

/// One raw sample's footprint in [`recon::demosaic`]'s samples (bilinear per channel on
/// the channel's 2 × 2 sub-lattice, CONVENTIONS.md): its own pixel 1, the four pixels
/// beside it ½, the four diagonal ¼ (total 4: each of the four pixels of a tile reads
/// the channel with weights (1), (½, ½), (½, ½) or (¼ × 4), Σw² 9/16 on average).
const DEMOSAIC_FOOTPRINT: [f64; 9] = [1.0, 0.5, 0.5, 0.5, 0.5, 0.25, 0.25, 0.25, 0.25];

/// The design effect of a monochrome DoFP mosaic's demosaiced samples
/// ([`kish_design_effect`] of [`DEMOSAIC_FOOTPRINT`]): F = 4² / (9/4) = 64/9, √F = 8/3.
/// The same for every channel, so for I, Q, U and the AoP. Interior pixels; the
/// clamped one-pixel rim's footprint differs (its 2(W + H) pixels: 0.7 % of 612 × 512).
/// What it covers: the noise's correlation through the interpolation, no more (the
/// plain route stays statistical only). `tests` checks the footprint against
/// [`recon::demosaic`] itself.
pub(crate) fn demosaic_design_effect() -> f64 {
    kish_design_effect(&DEMOSAIC_FOOTPRINT)
}

/// What the field estimator knows about frame `f`: the capture's camera (plus `known`
/// calibrations), the sun and the reference tilt with their 1σ, the mount tilt — as
/// the compass builds it ([`crate::compass`]).
pub(crate) fn field_context(c: &Capture, f: &FrameSpec, known: &Model) -> FieldContext {
    let attitude = Attitude {
        tilt_x_deg: f.tilt_x_deg.unwrap_or(0.0),
        tilt_y_deg: f.tilt_y_deg.unwrap_or(0.0),
        sigma_deg: f.tilt_sigma_deg.unwrap_or(0.0),
    };
    let sun = (f.sun.azimuth_deg, f.sun.elevation_deg, f.sun_sigma_deg.unwrap_or(0.0));
    crate::compass::field_context(assumed_intrinsics(c, known), known, sun, &attitude)
}

/// The compass for capture `c` with the `known` effects (no per-pixel maps: a
/// calibration's are applied to the frame first, [`apply_pixel_maps`]), refusals
/// named by the capture's file.
fn capture_compass(c: &Capture, known: &Model, opts: &FieldOptions) -> Result<Compass> {
    Compass::for_capture_known(c, Calibration::default(), known.clone(), *opts, Extractor::SunVector)
        .map_err(|e| compass_error(c, e))
}

/// A compass's refusal of a capture's frame as the core's error, naming the capture.
fn compass_error(c: &Capture, e: CompassError) -> Error {
    match e {
        CompassError::Core(e) => e,
        e => Error::Capture { path: c.toml_path(), message: e.to_string() },
    }
}

/// The cells of one frame's pixels, the `known` analyzer and channel errors undone:
/// the compass's ([`Compass::for_capture`]).
pub(crate) fn frame_cells(c: &Capture, data: &FrameData, known: &Model, cell_px: Option<usize>) -> Result<Cells> {
    let opts = FieldOptions { cell_px, ..FieldOptions::default() };
    capture_compass(c, known, &opts)?.capture_cells(data).map_err(|e| compass_error(c, e))
}

/// Field headings (robust, honest 1σ: [`crate::heading::field`]) of frame `index`.
pub fn field_headings(
    c: &Capture,
    index: usize,
    known: &Model,
    opts: &FieldOptions,
    extractors: &[Extractor],
) -> Result<Vec<FieldHeading>> {
    field_headings_of(c, index, &c.read_frame(index)?, known, opts, extractors)
}

/// [`field_headings`] of frame `index` whose pixels `data` are already in memory:
/// through the compass, as `bpins heading` and a robot read a frame
/// ([`Compass::capture_frame`]).
pub fn field_headings_of(
    c: &Capture,
    index: usize,
    data: &FrameData,
    known: &Model,
    opts: &FieldOptions,
    extractors: &[Extractor],
) -> Result<Vec<FieldHeading>> {
    capture_compass(c, known, opts)?.capture_frame(data, &c.frames[index], extractors).map_err(|e| compass_error(c, e))
}

/// Sensor settings of a simulation beyond what `capture.toml` records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimSensor {
    /// Peak photo-signal of the brightest channel over the first frame, as a
    /// fraction of full scale above the black level.
    pub peak_fraction: f64,
    pub read_noise_dn: f64,
    pub system_gain_dn_per_e: f64,
    pub dsnu_dn: f64,
    pub prnu: f64,
    /// Peak degree of polarization of the sky.
    pub dmax: f64,
    pub seed: u64,
}

impl SimSensor {
    /// The sample captures' sensor (samples/README.md): peak 70 % of full
    /// scale, read noise 1 DN, shot noise at K = 0.1 DN/e⁻, no fixed-pattern noise,
    /// sky d_max 0.6; noise seeded by `seed`.
    pub fn samples(seed: u64) -> Self {
        SimSensor {
            peak_fraction: 0.7,
            read_noise_dn: 1.0,
            system_gain_dn_per_e: 0.1,
            dsnu_dn: 0.0,
            prnu: 0.0,
            dmax: 0.6,
            seed,
        }
    }
}

/// The scene of frame `f` (heading and tilt default to 0 where not given).
pub(crate) fn scene_of(f: &FrameSpec, dmax: f64) -> Scene {
    Scene {
        sun_az_deg: f.sun.azimuth_deg,
        sun_el_deg: f.sun.elevation_deg,
        heading_deg: f.heading_deg.unwrap_or(0.0),
        tilt_x_deg: f.tilt_x_deg.unwrap_or(0.0),
        tilt_y_deg: f.tilt_y_deg.unwrap_or(0.0),
        dmax,
    }
}

/// The response of a simulated capture: gain set so the first frame's nominal peak
/// sits at `peak_fraction` of the range above black. With a `field` scene the peak is
/// that of the first frame's field sky without the sun's disc and aureole (which
/// then saturate where in view, as under an exposure set on the sky).
pub fn sim_response(c: &Capture, s: &SimSensor, field: Option<&FieldScene>) -> Result<Response> {
    let first = c.frames.first().ok_or_else(|| Error::TooFewSamples("a capture needs at least one frame".into()))?;
    let g = &c.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let scene = scene_of(first, s.dmax);
    let peak = match field.filter(|f| !f.is_empty()) {
        None => peak_intensity(&Model::default(), &c.intrinsics(), &scene, w, h, 8),
        Some(field) => {
            let sky = crate::sensor_exposure::field_under(
                &field.without(crate::scene::sun_disc::ELEMENT.name),
                &first.sun,
                s.dmax,
            );
            let idx = NoiseIndex { seed: 0, trial: 0, frame: 0 };
            let f = ChainFrame::new_in_field(
                &Model::default(),
                &c.intrinsics(),
                &scene,
                &Response::ideal(1.0),
                idx,
                Some(&sky),
            );
            peak_signal(&f, w, h, 8)
        }
    };
    let full = c.sensor.full_scale_dn();
    if !(s.peak_fraction > 0.0 && s.peak_fraction <= 1.0) {
        return Err(Error::OutOfRange {
            what: "peak fraction".into(),
            value: s.peak_fraction.to_string(),
            range: "(0, 1]".into(),
        });
    }
    if !(peak > 0.0 && peak.is_finite()) {
        return Err(Error::TooFewSamples(format!(
            "the first frame's peak signal {peak} is not positive: nothing to expose"
        )));
    }
    Ok(Response {
        gain_dn: s.peak_fraction * (full - c.sensor.black_level_dn) / peak,
        black_level_dn: c.sensor.black_level_dn,
        read_noise_dn: s.read_noise_dn,
        system_gain_dn_per_e: s.system_gain_dn_per_e,
        dsnu_dn: s.dsnu_dn,
        prnu: s.prnu,
        bit_depth: c.sensor.bit_depth,
        quantize: true,
    })
}

/// The chain of frame `index` of capture `c` under `model` (the truth) and the scene
/// elements of `field` (none when `None`), as [`simulate_frame`] renders it. Without
/// a field any backend can render it; with one, the CPU only.
pub fn sim_chain_frame(
    c: &Capture,
    index: usize,
    model: &Model,
    resp: &Response,
    s: &SimSensor,
    field: Option<&FieldScene>,
) -> ChainFrame {
    let scene = scene_of(&c.frames[index], s.dmax);
    let noise = NoiseIndex { seed: s.seed, trial: 0, frame: index as u32 };
    let field = field.map(|f| crate::sensor_exposure::field_under(f, &c.frames[index].sun, s.dmax));
    ChainFrame::new_in_field(model, &c.intrinsics(), &scene, resp, noise, field.as_ref())
}

/// The three band frames of frame `index` of a colour-polarization capture `c`
/// ([`sim_chain_frame`], then [`ChainFrame::bands`]: `model`'s band block, the green
/// band the scene's radiance and d_max), by [`Band::index`](crate::sensor::Band::index).
pub fn sim_band_frames(
    c: &Capture,
    index: usize,
    model: &Model,
    resp: &Response,
    s: &SimSensor,
    field: Option<&FieldScene>,
) -> [ChainFrame; 3] {
    let scene = scene_of(&c.frames[index], s.dmax);
    sim_chain_frame(c, index, model, resp, s, field).bands(model, &scene)
}

/// Simulates frame `index` of capture `c` under `model` (the truth) and `field`.
pub fn simulate_frame(
    c: &Capture,
    index: usize,
    model: &Model,
    resp: &Response,
    s: &SimSensor,
    field: Option<&FieldScene>,
) -> FrameData {
    let g = &c.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let f = sim_chain_frame(c, index, model, resp, s, field);
    match &c.sensor.layout {
        Layout::Dofp { mosaic } if c.sensor.colour.is_some() => {
            let tiles = c.sensor.colour.as_ref().expect("matched");
            let frames = sim_band_frames(c, index, model, resp, s, field);
            let dn = crate::simulate::render_colour_mosaic(&frames, w, h, mosaic, tiles);
            FrameData::Mosaic { width_px: g.width_px, height_px: g.height_px, dn }
        }
        Layout::Dofp { mosaic } => {
            FrameData::Mosaic { width_px: g.width_px, height_px: g.height_px, dn: render_mosaic(&f, w, h, mosaic) }
        }
        Layout::Colocated { channels } => {
            let planes = render_colocated(&f, w, h, channels);
            FrameData::Colocated {
                width_px: g.width_px,
                height_px: g.height_px,
                channels: channels.iter().copied().zip(planes).collect(),
            }
        }
    }
}

/// Every frame of capture `c` simulated in memory under `model` (the truth) and the
/// scene elements of `field`: the response from [`sim_response`], then
/// [`simulate_frame`] for each frame. The frames' tilts and suns are taken as true;
/// for an IMU's and a clock's errors draw them first (`scene::FieldAttitude`).
pub fn simulate_capture(
    c: &Capture,
    model: &Model,
    s: &SimSensor,
    field: Option<&FieldScene>,
) -> Result<(Response, Vec<FrameData>)> {
    let resp = sim_response(c, s, field)?;
    let frames = (0..c.frames.len()).map(|i| simulate_frame(c, i, model, &resp, s, field)).collect();
    Ok((resp, frames))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::capture::{LensSpec, SensorSpec};
    use crate::sensor::{Channel, Geometry, DEFAULT_MOSAIC};
    use crate::sky::sun::SunPosition;

    /// [`DEMOSAIC_FOOTPRINT`] is [`recon::demosaic`]'s own: on a flat mosaic, one raw
    /// sample raised by 64 DN raises the intensity (½ Σ_k x_k, nominal analyzers) of each
    /// pixel p by ½·64·w_p; the w_p sum to 4 and give F = 64/9, for a sample of each
    /// channel in the interior.
    #[test]
    fn the_design_effect_is_the_bilinear_demosaics_stencil() {
        let (w, h) = (16, 16);
        let rec = Reconstructor::new(&Model::default(), 0.0, &Channel::ALL).unwrap();
        let intensity = |dn: &[f32]| recon::demosaic(dn, w, h, &DEFAULT_MOSAIC, &rec, 4095.0).iqu;
        let flat = vec![1000.0f32; w * h];
        let base = intensity(&flat);
        for (u0, v0) in [(8, 8), (9, 8), (8, 9), (9, 9)] {
            let mut raised = flat.clone();
            raised[v0 * w + u0] += 64.0;
            let wt: Vec<f64> =
                intensity(&raised).iter().zip(&base).map(|(z, a)| (z[0] - a[0]) / 32.0).filter(|x| *x != 0.0).collect();
            let (sum, f) = (wt.iter().sum::<f64>(), kish_design_effect(&wt));
            assert!(
                wt.len() == 9 && (sum - 4.0).abs() < 1e-9 && (f - 64.0 / 9.0).abs() < 1e-9,
                "({u0}, {v0}): {} pixels, Σw {sum}, F {f}",
                wt.len()
            );
        }
        assert!((demosaic_design_effect() - 64.0 / 9.0).abs() < 1e-12);
    }

    /// With the 1σ × √F the demosaic route's 1σ is its noise's: one frame under 24
    /// seeds, the spread of its sun-vector headings about their mean over the 1σ has an
    /// RMS near 1 (2.7 were the samples taken as independent); superpixels (independent
    /// samples, 1σ unchanged) the same.
    #[test]
    fn the_demosaic_1sigma_is_the_noise_of_its_headings_over_seeds() {
        let c = Capture {
            dir: "/nowhere".into(),
            sensor: SensorSpec {
                colour: None,
                layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
                geometry: Geometry { width_px: 160, height_px: 128, pixel_pitch_um: 27.6 },
                bit_depth: 12,
                black_level_dn: 64.0,
            },
            lens: LensSpec { projection: Projection::Pinhole, focal_length_mm: 8.0, principal_point_px: (79.5, 63.5) },
            frames: vec![FrameSpec {
                heading_deg: Some(7.0),
                ..FrameSpec::new("f.png", SunPosition::given(130.0, 35.0))
            }],
        };
        for mode in ReconMode::ALL {
            let est: Vec<HeadingEstimate> = (1..=24)
                .map(|seed| {
                    let (_, frames) = simulate_capture(&c, &Model::default(), &SimSensor::samples(seed), None).unwrap();
                    let hs = frame_headings_of(&c, 0, &frames[0], &Model::default(), mode, &[Extractor::SunVector]);
                    hs.unwrap().remove(0).1.unwrap()
                })
                .collect();
            let err = |e: &HeadingEstimate| crate::conventions::wrap_deg_180(e.heading_deg - 7.0);
            let mean = est.iter().map(err).sum::<f64>() / est.len() as f64;
            let z2 = est.iter().map(|e| ((err(e) - mean) / e.sigma_deg).powi(2)).sum::<f64>();
            let rms = (z2 / (est.len() - 1) as f64).sqrt();
            eprintln!("{}: RMS (e − ē)/σ {rms:.2}, mean error {mean:+.4}°", mode.name());
            assert!((0.7..1.4).contains(&rms), "{}: RMS (e − ē)/σ {rms:.2}", mode.name());
        }
    }
}
