//! `bpins simulate`: a capture (bpins-capture/1) made by the model, with any catalog
//! effect at any value and any scene element (field conditions: `--scene`), or one
//! EXR frame with I0…I135, AoP, DoLP and AoE. Defaults reproduce the sample
//! captures' setup (samples/README.md).

use crate::Backend;
use anyhow::{bail, Context};
use bpins_core::camera::Projection;
use bpins_core::conventions::image_centre_px;
use bpins_core::effects::EffectSet;
use bpins_core::scene::{FieldAttitude, FieldScene};
use bpins_core::sensor::{Channel, Geometry, Layout, DEFAULT_MOSAIC};
use bpins_core::tool::capture::write_exr_layers;
use bpins_core::tool::pipeline::angle_maps;
use bpins_core::tool::pipeline::{
    reconstruct_frame, sim_band_frames, sim_chain_frame, sim_response, ReconMode, SimSensor,
};
use bpins_core::tool::radiometry::{exposed_response, Exposure};
use bpins_core::tool::sun::source_from_time_place;
use bpins_core::ChainFrame;
use bpins_core::SunPosition;
use bpins_core::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Output folder for the new capture (must not hold a capture.toml yet).
    #[arg(long, required_unless_present = "exr")]
    out: Option<PathBuf>,
    /// Instead of a capture, write the first frame as one EXR with channels
    /// I0, I45, I90, I135 (DN, every channel at every pixel), AoP (°), DoLP, AoE (°).
    /// Not with the flags that only a capture writes (a series, the IMU's reference
    /// tilt, the colocated layout's channels): they would be ignored.
    #[arg(long, conflicts_with_all = ["out", "every_min", "imu_sigma_deg", "layout", "channels_deg"])]
    exr: Option<PathBuf>,
    /// Also write the capture as a ROS 2 bag (MCAP) to this new folder: images,
    /// CameraInfo, the IMU's tilt, GNSS fixes (time-and-place suns) and the true
    /// heading (docs/ros2.md).
    #[arg(long, value_name = "DIR", requires = "out", conflicts_with = "lab")]
    bag_out: Option<PathBuf>,
    /// Compute backend.
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    backend: Backend,
    /// An effect of the catalog at a value, effect.param=value (repeatable),
    /// e.g. --effect array_rotation.dtheta_deg=0.3. `bpins effects` lists them.
    #[arg(long = "effect", value_name = "EFFECT.PARAM=VALUE")]
    effects: Vec<String>,
    /// A scene element (field conditions) at its defaults, NAME, or one of its
    /// parameters, NAME.PARAM=VALUE (repeatable), e.g. --scene clouds --scene
    /// skyline.max_elevation_deg=15. `bpins effects` lists them. CPU backend only.
    #[arg(long = "scene", value_name = "NAME[.PARAM=VALUE]")]
    scene: Vec<String>,
    /// Seed of the scene's clouds, skyline, textures and of the random tilts and
    /// IMU/sun errors (default: --seed).
    #[arg(long)]
    scene_seed: Option<u64>,
    /// Each frame's true tilt about camera x and y drawn uniformly within ±this,
    /// degrees, added to --tilt-x-deg/--tilt-y-deg (seeded by --scene-seed).
    #[arg(long, default_value_t = 0.0)]
    tilt_random_deg: f64,
    /// 1σ of the IMU per tilt axis, degrees: the reference tilt written is the true
    /// tilt plus N(0, σ), and `tilt_sigma_deg` = σ is written with it.
    #[arg(long)]
    imu_sigma_deg: Option<f64>,
    /// 1σ of the sun's azimuth and elevation, degrees: frames are rendered under the
    /// written sun plus N(0, σ) per angle, and `sun_sigma_deg` = σ is written.
    #[arg(long)]
    sun_sigma_deg: Option<f64>,
    /// Sensor layout.
    #[arg(long, value_enum, default_value_t = LayoutArg::Dofp)]
    layout: LayoutArg,
    /// A colour-polarization sensor (Sony IMX250MYR order: RGGB): the colour filter
    /// over each 2×2 analyzer tile of the 4×4 superpixel, four letters R, G, B by tile
    /// row then column (RGGB: colour_tiles = [["R", "G"], ["G", "B"]]), written with
    /// CAPTURE.md's default band_centre_nm. Each band sees the sky and responds as
    /// the effects sky_spectrum and band_response say (green: the scene's radiance,
    /// --dmax and --peak-fraction). --layout dofp only.
    #[arg(long, value_name = "TILES")]
    colour_tiles: Option<String>,
    /// Colocated channels, degrees (0,45,90 or 0,45,90,135; default all four). With
    /// --layout colocated only (a DoFP mosaic's channels are its tiles').
    #[arg(long, value_delimiter = ',')]
    channels_deg: Option<Vec<f64>>,
    /// Sensor width, pixels.
    #[arg(long, default_value_t = 612)]
    width_px: u32,
    /// Sensor height, pixels.
    #[arg(long, default_value_t = 512)]
    height_px: u32,
    /// Pixel pitch, micrometres.
    #[arg(long, default_value_t = 13.8)]
    pixel_pitch_um: f64,
    /// ADC bits.
    #[arg(long, default_value_t = 12)]
    bit_depth: u32,
    /// Black level, DN.
    #[arg(long, default_value_t = 64.0)]
    black_level_dn: f64,
    /// Lens projection: pinhole, equidistant, equisolid or stereographic.
    #[arg(long, value_parser = crate::names::by_name(&Projection::ALL, Projection::name), default_value = "pinhole")]
    projection: Projection,
    /// Focal length, millimetres.
    #[arg(long, default_value_t = 8.0)]
    focal_length_mm: f64,
    /// Nominal principal point x,y in pixels (default: the image centre).
    #[arg(long, value_delimiter = ',', num_args = 2, allow_hyphen_values = true)]
    principal_point_px: Option<Vec<f64>>,
    /// Sun azimuth from North toward East, degrees.
    #[arg(long, default_value_t = 40.0, allow_negative_numbers = true)]
    sun_azimuth_deg: f64,
    /// Sun elevation, degrees.
    #[arg(long, default_value_t = 25.0, allow_negative_numbers = true)]
    sun_elevation_deg: f64,
    /// Instead of the sun's angles: UTC time (RFC 3339) for NREL SPA, with --latitude-deg/--longitude-deg.
    #[arg(long, conflicts_with_all = ["sun_azimuth_deg", "sun_elevation_deg"], requires_all = ["latitude_deg", "longitude_deg"])]
    time_utc: Option<String>,
    /// Latitude, degrees north.
    #[arg(long, requires = "time_utc", allow_negative_numbers = true)]
    latitude_deg: Option<f64>,
    /// Longitude, degrees east.
    #[arg(long, requires = "time_utc", allow_negative_numbers = true)]
    longitude_deg: Option<f64>,
    /// One frame per heading, degrees (a turntable; default 0,45,90,135,180,225,270,315).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    headings_deg: Option<Vec<f64>>,
    /// A time series for `bpins locate`: a frame every N minutes from --time-utc at
    /// --latitude-deg/--longitude-deg (the sun by NREL SPA) over --span-min; the frames
    /// are written with their `time_utc` alone (no place, no heading) and the truth
    /// (place, heading of the first frame) to truth.toml beside capture.toml. The first
    /// of --headings-deg is the camera's heading at the first frame.
    #[arg(long, requires_all = ["time_utc", "span_min"], value_name = "N")]
    every_min: Option<f64>,
    /// The series' span, minutes (frames at 0, N, 2N, … ≤ span).
    #[arg(long, requires = "every_min")]
    span_min: Option<f64>,
    /// Series: the camera turns by this much from frame to frame, degrees; its yaw is
    /// written as `yaw_deg`.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, requires = "every_min")]
    yaw_step_deg: f64,
    /// Series: 1σ of the written yaw (a gyro), degrees; `yaw_sigma_deg` is written too.
    #[arg(long, requires = "every_min")]
    yaw_sigma_deg: Option<f64>,
    /// Frame tilt about camera x, degrees (recorded as the frames' reference tilt).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    tilt_x_deg: f64,
    /// Frame tilt about camera y, degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    tilt_y_deg: f64,
    /// Peak degree of linear polarization of the sky.
    #[arg(long, default_value_t = 0.6)]
    dmax: f64,
    /// Peak signal of the first frame as a fraction of the range above black (with
    /// --scene: of its field sky without the sun's disc and aureole, which saturate).
    #[arg(long, default_value_t = 0.7)]
    peak_fraction: f64,
    /// A physical exposure instead of --peak-fraction's auto-exposure: the exposure
    /// time, seconds. The gain follows from the sky's luminance under the frame's
    /// source (the sun, or at night the moon: docs/night.md), the lens (--f-number,
    /// --lens-transmittance), the sensor (--qe, --full-well-e, --read-noise-e,
    /// --gain-db, --dark-current-e-per-s; the Sony IMX250MZR's by default) and
    /// --pixel-pitch-um.
    #[arg(long, conflicts_with_all = ["peak_fraction", "read_noise_dn", "system_gain_dn_per_e", "lab"])]
    exposure_s: Option<f64>,
    /// With --exposure-s: the lens's f-number.
    #[arg(long, default_value_t = 1.4, requires = "exposure_s")]
    f_number: f64,
    /// With --exposure-s: the lens's transmittance.
    #[arg(long, default_value_t = 0.9, requires = "exposure_s")]
    lens_transmittance: f64,
    /// With --exposure-s: quantum efficiency for light along an analyzer's pass axis
    /// (twice an EMVA 1288 QE measured with unpolarized light through the polarizers).
    #[arg(long, default_value_t = 0.6, requires = "exposure_s")]
    qe: f64,
    /// With --exposure-s: full-well capacity, e⁻ (full scale at 0 dB gain).
    #[arg(long, default_value_t = 10_500.0, requires = "exposure_s")]
    full_well_e: f64,
    /// With --exposure-s: read noise (temporal dark noise), e⁻.
    #[arg(long, default_value_t = 2.3, requires = "exposure_s")]
    read_noise_e: f64,
    /// With --exposure-s: analog gain, dB (the system gain K grows by 10^(dB/20)).
    #[arg(long, default_value_t = 0.0, requires = "exposure_s", allow_negative_numbers = true)]
    gain_db: f64,
    /// With --exposure-s: dark current, e⁻ per second per pixel (the `dark_signal`
    /// effect's dark_dn = K·current·time).
    #[arg(long, default_value_t = 0.0, requires = "exposure_s")]
    dark_current_e_per_s: f64,
    /// Read noise σ, DN.
    #[arg(long, default_value_t = 1.0)]
    read_noise_dn: f64,
    /// System gain K, DN per electron (shot-noise variance K·signal).
    #[arg(long, default_value_t = 0.1)]
    system_gain_dn_per_e: f64,
    /// Per-pixel offset non-uniformity σ, DN.
    #[arg(long, default_value_t = 0.0)]
    dsnu_dn: f64,
    /// Per-pixel gain non-uniformity σ, relative.
    #[arg(long, default_value_t = 0.0)]
    prnu: f64,
    /// Seed of the noise; the same seed gives the same DN.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Instead of a sky capture, a lab capture (kind = "lab", CAPTURE.md) of this
    /// sensor, for `bpins calibrate`: flats through a polarizer at --lab-angles-deg,
    /// unpolarized flats at --lab-exposures, --lab-darks dark frames. The sensor's
    /// per-channel flaws come from --effect (analyzer_angles, extinction_ratio,
    /// channel_response, array_rotation, vignetting), per-pixel ones from --prnu,
    /// --dsnu-dn and --pixel-*; --peak-fraction sets a polarized flat's peak. With
    /// --colour-tiles, each band's gain and ε from band_response (a white source).
    #[arg(long, conflicts_with_all = ["scene", "scene_seed", "tilt_random_deg", "imu_sigma_deg", "sun_sigma_deg", "time_utc", "every_min", "headings_deg", "sun_azimuth_deg", "sun_elevation_deg", "tilt_x_deg", "tilt_y_deg", "dmax", "backend"], requires = "out")]
    lab: bool,
    /// Lab: polarizer angles, degrees (image frame).
    #[arg(long, requires = "lab", value_delimiter = ',', default_value = "0,15,30,45,60,75,90,105,120,135,150,165")]
    lab_angles_deg: Vec<f64>,
    /// Lab: exposures of the unpolarized flats, relative (the flag alone: none).
    #[arg(long, requires = "lab", value_delimiter = ',', num_args = 0.., default_value = "0.3,0.6,1.2")]
    lab_exposures: Vec<f64>,
    /// Lab: number of dark frames.
    #[arg(long, requires = "lab", default_value_t = 1)]
    lab_darks: usize,
    /// Lab: also write the per-pixel truth (offset_dn, gain, analyzer_deg, eps) to
    /// this EXR file (outside the capture).
    #[arg(long, requires = "lab", value_name = "FILE")]
    lab_truth: Option<PathBuf>,
    /// Lab: white spread (1σ) of each pixel's analyzer angle, degrees.
    #[arg(long, requires = "lab", default_value_t = 0.0)]
    pixel_angle_sigma_deg: f64,
    /// Lab: change of the analyzer angles across the die's width and height, degrees (X,Y).
    #[arg(long, requires = "lab", value_delimiter = ',', allow_hyphen_values = true, default_value = "0,0")]
    pixel_angle_gradient_deg: Vec<f64>,
    /// Lab: white spread (1σ) of each pixel's extinction ratio ε.
    #[arg(long, requires = "lab", default_value_t = 0.0)]
    pixel_eps_sigma: f64,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum LayoutArg {
    /// 2×2 micro-polarizer mosaic (Sony IMX250MZR order).
    Dofp,
    /// Every pixel measures every channel (the seed paper's idealisation).
    Colocated,
}

impl Args {
    /// `--headings-deg`, or the turntable's eight (0°, 45°, …, 315°).
    fn headings(&self) -> Vec<f64> {
        self.headings_deg.clone().unwrap_or_else(|| (0..8).map(|k| 45.0 * k as f64).collect())
    }

    /// A combination of flags clap cannot see (it turns on a flag's value): the two
    /// flags as a clap conflict names them, for `main` to refuse as clap does.
    pub fn refused(&self) -> Option<(String, String)> {
        let pair = |a: &str, b: &str| Some((a.to_string(), b.to_string()));
        if self.channels_deg.is_some() && !matches!(self.layout, LayoutArg::Colocated) {
            return pair("--channels-deg <CHANNELS_DEG>", "--layout dofp (the default)");
        }
        if self.colour_tiles.is_some() && !matches!(self.layout, LayoutArg::Dofp) {
            return pair(
                "--colour-tiles <TILES>",
                "--layout colocated (colour filters sit over a dofp mosaic's tiles)",
            );
        }
        if self.colour_tiles.is_some() && self.exr.is_some() {
            return pair("--colour-tiles <TILES>", "--exr <EXR> (a colour dump: not yet)");
        }
        if self.exr.is_some() && self.headings_deg.as_ref().is_some_and(|h| h.len() > 1) {
            return pair("--headings-deg with more than one heading", "--exr <EXR> (one frame)");
        }
        None
    }

    /// A flag that acts only beside another, given without it: the flag and what it
    /// needs, for `main` to refuse as clap refuses a missing argument.
    pub fn lacking(&self) -> Option<(String, String)> {
        let seeded = !self.scene.is_empty()
            || self.tilt_random_deg != 0.0
            || self.imu_sigma_deg.is_some()
            || self.sun_sigma_deg.is_some();
        if self.scene_seed.is_some() && !seeded {
            return Some((
                "--scene-seed <SCENE_SEED>".into(),
                "--scene, --tilt-random-deg, --imu-sigma-deg or --sun-sigma-deg (what it seeds)".into(),
            ));
        }
        None
    }
}

pub fn run(a: Args) -> anyhow::Result<()> {
    ensure_allocatable(a.width_px, a.height_px)?;
    let mut effects = EffectSet::new();
    for spec in &a.effects {
        effects.parse_assignment(spec).with_context(|| format!("--effect {spec}"))?;
    }
    let model = effects.model();
    if a.lab {
        return run_lab(&a, &model);
    }
    let scene_seed = a.scene_seed.unwrap_or(a.seed);
    let mut field = FieldScene::new(scene_seed);
    for spec in &a.scene {
        field.parse(spec).with_context(|| format!("--scene {spec}"))?;
    }
    if !field.is_empty() && a.backend == Backend::Gpu {
        bail!("--scene: scene elements (field conditions) run on the CPU backend only; use --backend cpu");
    }
    let field = (!field.is_empty()).then_some(field);
    // The frames as asked; with random tilts or IMU/sun errors, the truth to render
    // and the reference to write differ (scene::attitude).
    let nominal = build_capture(&a)?;
    let series = series_of(&a)?;
    if series.is_some() && a.bag_out.is_some() {
        bail!(
            "--bag-out with --every-min: a located series has frames without a place (no sun to write); \
             simulate the series as a capture, or the bag without --every-min"
        );
    }
    let (nominal, series_written) = match &series {
        Some(s) => {
            let ext = nominal.frames[0].file.extension().and_then(|e| e.to_str()).unwrap_or("png").to_string();
            let (truth, written) = s.frames(&ext).context("--every-min / --span-min / --time-utc")?;
            (Capture { frames: truth, ..nominal }, Some(written))
        }
        None => (nominal, None),
    };
    let attitude = FieldAttitude {
        tilt_random_deg: a.tilt_random_deg,
        imu_sigma_deg: a.imu_sigma_deg,
        sun_sigma_deg: a.sun_sigma_deg,
        seed: scene_seed,
    };
    let (truth_frames, reference_frames) =
        attitude.draw(&nominal.frames).context("--tilt-random-deg / --imu-sigma-deg / --sun-sigma-deg")?;
    // A series writes its stamps and yaw; the attitude draws give the reference tilt.
    let reference_frames = match series_written {
        Some(w) => bpins_core::tool::locate::with_reference_tilts(w, reference_frames),
        None => reference_frames,
    };
    let capture = Capture { frames: truth_frames, ..nominal.clone() };
    let written = Capture { frames: reference_frames, ..nominal };
    let sim = SimSensor {
        peak_fraction: a.peak_fraction,
        read_noise_dn: a.read_noise_dn,
        system_gain_dn_per_e: a.system_gain_dn_per_e,
        dsnu_dn: a.dsnu_dn,
        prnu: a.prnu,
        dmax: a.dmax,
        seed: a.seed,
    };
    if !(a.dmax >= 0.0 && a.dmax <= 1.0) {
        bail!("--dmax {} must lie in [0, 1]", a.dmax);
    }
    for (name, v) in [
        ("--read-noise-dn", a.read_noise_dn),
        ("--system-gain-dn-per-e", a.system_gain_dn_per_e),
        ("--dsnu-dn", a.dsnu_dn),
        ("--prnu", a.prnu),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            bail!("{name} {v} must be a finite number ≥ 0");
        }
    }
    // A physical exposure (docs/night.md): each frame's gain from its source's sky, the
    // dark signal as the `dark_signal` effect; otherwise the first frame's auto-exposure.
    let (resp, resps, model) = match exposure_of(&a) {
        Some(e) => {
            let exposed = (0..capture.frames.len())
                .map(|i| exposed_response(&capture, i, &sim, &e))
                .collect::<Result<Vec<_>, _>>()
                .context("--exposure-s")?;
            let first = exposed[0];
            let k = first.response.system_gain_dn_per_e;
            say!(
                "exposure {} s at f/{} (K {:.3} DN/e⁻, read noise {:.2} DN): {}; {:.1} e⁻ per pixel behind an analyzer at the zenith",
                e.exposure_s,
                e.f_number,
                k,
                first.response.read_noise_dn,
                first.sky.describe(),
                first.zenith_e
            );
            let model = if first.dark_dn > 0.0 {
                effects
                    .parse_assignment(&format!("dark_signal.dark_dn={}", first.dark_dn))
                    .context("--dark-current-e-per-s: the dark signal K·current·time")?;
                effects.model()
            } else {
                model
            };
            (first.response, exposed.iter().map(|x| x.response).collect::<Vec<_>>(), model)
        }
        None => {
            let resp = sim_response(&capture, &sim, field.as_ref())?;
            (resp, vec![resp; capture.frames.len()], model)
        }
    };
    let effects_text: Vec<String> = effects
        .iter()
        .flat_map(|(d, v)| d.params.iter().zip(v).map(move |(p, x)| format!("{}.{}={} {}", d.name, p.name, x, p.unit)))
        .collect();
    let scene_text: Vec<String> = field
        .iter()
        .flat_map(|f| f.iter())
        .flat_map(|(d, v)| d.params.iter().zip(v).map(move |(p, x)| format!("{}.{}={} {}", d.name, p.name, x, p.unit)))
        .collect();
    say!(
        "bpins simulate ({} backend): gain {:.2} DN per unit radiance, effects: {}",
        a.backend.name(),
        resp.gain_dn,
        if effects_text.is_empty() { "none".to_string() } else { effects_text.join(", ") }
    );
    if !scene_text.is_empty() {
        say!("scene (seed {scene_seed}): {}", scene_text.join(", "));
    }
    if !attitude.is_none() {
        say!(
            "attitude (seed {scene_seed}): true tilt ±{} deg per axis; IMU σ {} deg; sun σ {} deg",
            a.tilt_random_deg,
            a.imu_sigma_deg.map_or("none".into(), |s| s.to_string()),
            a.sun_sigma_deg.map_or("none".into(), |s| s.to_string()),
        );
    }
    let engine = crate::backend::open(a.backend)?;
    if let Some(path) = &a.exr {
        crate::ensure_not_in_capture(path)?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        return write_dump(engine.as_ref(), &capture, &model, &resp, &sim, field.as_ref(), path);
    }
    let out = a.out.as_ref().expect("clap requires --out without --exr");
    if let Some(parent) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        crate::ensure_not_in_capture(parent)?;
    }
    if let Some(b) = &a.bag_out {
        crate::ensure_not_in_capture(b).context("--bag-out")?;
        // The bag and the new capture apart: neither inside the other.
        crate::ensure_apart(b, out).context("--bag-out and --out")?;
    }
    // Each frame is written as it is made (memory: one batch of frames), capture.toml
    // last: a run killed part-way leaves whole frames and no capture.
    let written = Capture { dir: out.clone(), ..written };
    let mut writer = written.writer(out)?;
    let pb = crate::progress::bar(capture.frames.len() as u64, "frames");
    let g = capture.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    // A few frames per call: the GPU batches them, the bar moves.
    for first in (0..capture.frames.len()).step_by(8) {
        let chain: Vec<ChainFrame> = (first..capture.frames.len().min(first + 8))
            .map(|i| sim_chain_frame(&capture, i, &model, &resps[i], &sim, field.as_ref()))
            .collect();
        match &capture.sensor.layout {
            Layout::Dofp { mosaic } if capture.sensor.colour.is_some() => {
                let tiles = capture.sensor.colour.as_ref().expect("matched");
                let bands: Vec<[ChainFrame; 3]> = (first..capture.frames.len().min(first + 8))
                    .map(|i| sim_band_frames(&capture, i, &model, &resps[i], &sim, field.as_ref()))
                    .collect();
                for dn in engine.render_colour_mosaic(&bands, w, h, mosaic, tiles)? {
                    writer.write_frame(&FrameData::Mosaic { width_px: g.width_px, height_px: g.height_px, dn })?;
                }
            }
            Layout::Dofp { mosaic } => {
                for dn in engine.render_mosaic(&chain, w, h, mosaic)? {
                    writer.write_frame(&FrameData::Mosaic { width_px: g.width_px, height_px: g.height_px, dn })?;
                }
            }
            Layout::Colocated { channels } => {
                for planes in engine.render_colocated(&chain, w, h, channels)? {
                    let channels = channels.iter().copied().zip(planes).collect();
                    writer.write_frame(&FrameData::Colocated {
                        width_px: g.width_px,
                        height_px: g.height_px,
                        channels,
                    })?;
                }
            }
        }
        pb.set_position(writer.written() as u64);
    }
    pb.finish_and_clear();
    let n = writer.written();
    writer.finish()?;
    say!("wrote {n} frames to {}", out.display());
    if let Some(s) = &series {
        let path = out.join("truth.toml");
        crate::write_output(&path, s.truth().to_toml_string().as_bytes())?;
        say!("wrote the truth to {}", path.display());
    }
    if let Some(b) = &a.bag_out {
        crate::capture_bag::capture_to_bag(&Capture::load(out)?, b)?;
    }
    Ok(())
}

/// `--exposure-s` and the camera flags beside it, if asked.
fn exposure_of(a: &Args) -> Option<Exposure> {
    Some(Exposure {
        exposure_s: a.exposure_s?,
        f_number: a.f_number,
        lens_transmittance: a.lens_transmittance,
        qe: a.qe,
        full_well_e: a.full_well_e,
        read_noise_e: a.read_noise_e,
        gain_db: a.gain_db,
        dark_current_e_per_s: a.dark_current_e_per_s,
    })
}

/// The time series of `--every-min`, if asked.
fn series_of(a: &Args) -> anyhow::Result<Option<bpins_core::tool::locate::Series>> {
    let Some(every) = a.every_min else { return Ok(None) };
    if a.sun_sigma_deg.is_some() {
        bail!("--sun-sigma-deg: a series' sun comes from SPA at its stamps; leave the sun's 1σ out");
    }
    let (Some(t), Some(lat), Some(lon)) = (&a.time_utc, a.latitude_deg, a.longitude_deg) else {
        bail!("--every-min needs --time-utc, --latitude-deg and --longitude-deg (the site and the first frame's time)");
    };
    Ok(Some(bpins_core::tool::locate::Series {
        latitude_deg: lat,
        longitude_deg: lon,
        start_utc: t.clone(),
        every_s: every * 60.0,
        span_s: a.span_min.unwrap_or(0.0) * 60.0,
        heading_deg: a.headings().first().copied().unwrap_or(0.0),
        yaw_step_deg: a.yaw_step_deg,
        yaw_sigma_deg: a.yaw_sigma_deg,
        seed: a.scene_seed.unwrap_or(a.seed),
    }))
}

/// `--lab`: a lab capture of the sensor (bpins_core::tool::lab), written whole
/// (capture.toml last), and its truth where asked.
fn run_lab(a: &Args, model: &bpins_core::effects::Model) -> anyhow::Result<()> {
    use bpins_core::tool::lab::{colour_truth_maps, lab_frames, truth_maps, LabPlan, LabSensor, PixelFlaws};
    use bpins_core::LabCapture;
    if !matches!(a.layout, LayoutArg::Dofp) {
        bail!("--lab: a lab capture calibrates a dofp mosaic; use --layout dofp");
    }
    let out = a.out.as_ref().expect("clap requires --out with --lab");
    crate::ensure_not_in_capture(out)?;
    if let Some(t) = &a.lab_truth {
        crate::ensure_not_in_capture(t)?;
    }
    for (name, v) in [
        ("--prnu", a.prnu),
        ("--dsnu-dn", a.dsnu_dn),
        ("--pixel-angle-sigma-deg", a.pixel_angle_sigma_deg),
        ("--pixel-eps-sigma", a.pixel_eps_sigma),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            bail!("{name} {v} must be a finite number ≥ 0");
        }
    }
    if a.pixel_angle_gradient_deg.len() != 2 || a.pixel_angle_gradient_deg.iter().any(|x| !x.is_finite()) {
        bail!("--pixel-angle-gradient-deg takes two finite angles X,Y in degrees");
    }
    let c = build_capture(a)?;
    let g = c.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let flaws = PixelFlaws {
        angle_sigma_deg: a.pixel_angle_sigma_deg,
        angle_gradient_deg: [a.pixel_angle_gradient_deg[0], a.pixel_angle_gradient_deg[1]],
        eps_sigma: a.pixel_eps_sigma,
        prnu: a.prnu,
        dsnu_dn: a.dsnu_dn,
        seed: a.seed,
    };
    let plan = LabPlan {
        angles_deg: a.lab_angles_deg.clone(),
        source_dolp: 1.0,
        exposures: a.lab_exposures.clone(),
        darks: a.lab_darks,
    };
    // A colour sensor: each pixel through its band's response under the lab's white
    // source, its band's ε added before the die's spread, as in the sky's chain.
    let truth = match &c.sensor.colour {
        Some(colour) => {
            colour_truth_maps(model, &c.intrinsics(), w, h, DEFAULT_MOSAIC, a.black_level_dn, &flaws, colour)
        }
        None => truth_maps(model, &c.intrinsics(), w, h, DEFAULT_MOSAIC, a.black_level_dn, &flaws),
    };
    let full = c.sensor.full_scale_dn();
    let sensor = LabSensor {
        signal_dn: a.peak_fraction * (full - a.black_level_dn),
        k_dn_per_e: a.system_gain_dn_per_e,
        read_noise_dn: a.read_noise_dn,
        full_scale_dn: full,
        seed: a.seed,
    };
    let lab = LabCapture { dir: out.clone(), sensor: c.sensor.clone(), lens: c.lens.clone(), frames: plan.frames() };
    say!(
        "bpins simulate --lab: {} polarized, {} unpolarized, {} dark frames of {w} × {h} px",
        plan.angles_deg.len(),
        plan.exposures.len(),
        plan.darks
    );
    let frames = lab_frames(&truth, &plan, &sensor);
    lab.write(out, &frames)?;
    if let Some(t) = &a.lab_truth {
        write_exr_layers(t, g.width_px, g.height_px, &truth.present())?;
        say!("wrote the per-pixel truth to {}", t.display());
    }
    say!("wrote the lab capture {}", out.display());
    Ok(())
}

fn build_capture(a: &Args) -> anyhow::Result<Capture> {
    let layout = match a.layout {
        LayoutArg::Dofp => Layout::Dofp { mosaic: DEFAULT_MOSAIC },
        LayoutArg::Colocated => {
            let mut ch = Vec::new();
            for &d in a.channels_deg.as_deref().unwrap_or(&[0.0, 45.0, 90.0, 135.0]) {
                ch.push(
                    Channel::from_angle_deg(d)
                        .with_context(|| format!("--channels-deg: {d}° is not 0, 45, 90 or 135"))?,
                );
            }
            Layout::Colocated { channels: ch }
        }
    };
    let ext = if matches!(a.layout, LayoutArg::Dofp) { "png" } else { "exr" };
    let sun = match &a.time_utc {
        Some(t) => source_from_time_place(t, a.latitude_deg.unwrap_or(f64::NAN), a.longitude_deg.unwrap_or(f64::NAN))?,
        None => SunPosition::given(a.sun_azimuth_deg, a.sun_elevation_deg),
    };
    let tilt = |t: f64| (t != 0.0).then_some(t);
    let frames = a
        .headings()
        .iter()
        .enumerate()
        .map(|(i, &h)| FrameSpec {
            file: PathBuf::from(format!("frames/f{i:03}.{ext}")),
            sun: sun.clone(),
            heading_deg: Some(h),
            tilt_x_deg: tilt(a.tilt_x_deg),
            tilt_y_deg: tilt(a.tilt_y_deg),
            tilt_sigma_deg: None,
            sun_sigma_deg: None,
            yaw_deg: None,
            yaw_sigma_deg: None,
        })
        .collect();
    let pp = match &a.principal_point_px {
        Some(v) => (v[0], v[1]),
        None => image_centre_px(a.width_px, a.height_px),
    };
    let projection = a.projection;
    Ok(Capture {
        dir: PathBuf::new(),
        sensor: SensorSpec {
            colour: a.colour_tiles.as_deref().map(colour_tiles).transpose()?,
            layout,
            geometry: Geometry { width_px: a.width_px, height_px: a.height_px, pixel_pitch_um: a.pixel_pitch_um },
            bit_depth: a.bit_depth,
            black_level_dn: a.black_level_dn,
        },
        lens: LensSpec { projection, focal_length_mm: a.focal_length_mm, principal_point_px: pp },
        frames,
    })
}

/// One EXR: every channel at every pixel (as a colocated sensor would read it), and
/// the angle maps reconstructed with the nominal model.
fn write_dump(
    engine: &dyn bpins_core::twin::Backend,
    c: &Capture,
    model: &bpins_core::effects::Model,
    resp: &bpins_core::sensor::Response,
    sim: &SimSensor,
    field: Option<&FieldScene>,
    path: &std::path::Path,
) -> anyhow::Result<()> {
    let g = &c.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    // One frame: seconds on a CPU rasterizer at full size; a log still hears of it.
    let sp = crate::progress::spinner("rendering the frame");
    let f = sim_chain_frame(c, 0, model, resp, sim, field);
    let planes = engine.render_colocated(std::slice::from_ref(&f), w, h, &Channel::ALL)?.remove(0);
    let colocated = Capture {
        sensor: SensorSpec { layout: Layout::Colocated { channels: Channel::ALL.to_vec() }, ..c.sensor.clone() },
        ..c.clone()
    };
    let data = FrameData::Colocated {
        width_px: g.width_px,
        height_px: g.height_px,
        channels: Channel::ALL.iter().copied().zip(planes.clone()).collect(),
    };
    let img = reconstruct_frame(&colocated, &data, &Default::default(), ReconMode::Demosaic)?;
    let [aop, dolp, aoe] = angle_maps(&img, &c.intrinsics());
    let mut layers: Vec<(&str, &[f32])> =
        Channel::ALL.iter().zip(&planes).map(|(ch, p)| (ch.exr_name(), p.as_slice())).collect();
    layers.extend([("AoP", aop.as_slice()), ("DoLP", dolp.as_slice()), ("AoE", aoe.as_slice())]);
    write_exr_layers(path, g.width_px, g.height_px, &layers)?;
    sp.finish_and_clear();
    say!("wrote {} ({}×{} px; I0…I135 in DN, AoP and AoE in degrees, DoLP in 1)", path.display(), w, h);
    Ok(())
}

/// Refuses a frame size whose buffers (a few f32/f64 planes per pixel) cannot be
/// allocated, with the size in the message, instead of aborting on a failed
/// allocation: the pixel count is capped at 2³⁰ (a 32 k × 32 k sensor), and the
/// largest buffer is reserved once to ask the allocator.
fn ensure_allocatable(width_px: u32, height_px: u32) -> anyhow::Result<()> {
    let pixels = width_px as u64 * height_px as u64;
    // An f32 plane per channel for colocated frames (4), and f64 rows besides.
    let bytes = pixels.saturating_mul(4 * 4);
    let gib = bytes as f64 / (1u64 << 30) as f64;
    if pixels > 1 << 30 {
        bail!("--width-px {width_px} × --height-px {height_px} = {pixels} px: more than 2^30 px (1.07 G px) per frame is not simulated");
    }
    let mut probe: Vec<u8> = Vec::new();
    if probe.try_reserve_exact(bytes as usize).is_err() {
        bail!("--width-px {width_px} × --height-px {height_px}: a frame needs {gib:.1} GiB, which cannot be allocated here");
    }
    Ok(())
}

/// `--colour-tiles`: four letters R, G, B, by tile row then column (`RGGB`: the
/// IMX250MYR's `[["R", "G"], ["G", "B"]]`), with CAPTURE.md's default wavelengths.
fn colour_tiles(text: &str) -> anyhow::Result<bpins_core::sensor::ColourTiles> {
    use bpins_core::sensor::{Band, ColourTiles};
    let bands: Vec<Band> = text
        .chars()
        .map(|c| Band::from_name(&c.to_ascii_uppercase().to_string()))
        .collect::<Option<_>>()
        .filter(|b: &Vec<Band>| b.len() == 4)
        .with_context(|| format!("--colour-tiles {text}: expected four letters R, G, B by tile row, e.g. RGGB"))?;
    let tiles = [[bands[0], bands[1]], [bands[2], bands[3]]];
    if Band::ALL.iter().any(|b| !bands.contains(b)) {
        bail!("--colour-tiles {text}: each band R, G and B must cover at least one tile (CAPTURE.md)");
    }
    Ok(ColourTiles { tiles, ..ColourTiles::imx250myr() })
}
