//! `bpins.simulate`: a frame of the model with its truth.

use crate::compass::{mosaic_of, projection};
use crate::{finite, py_err, whole};
use bpins_core::effects::EffectSet;
use bpins_core::render::{Renderer, RendererConfig, Stage, View};
use bpins_core::sensor::{Geometry, Layout, Response};
use bpins_core::{Capture, FrameSpec, LensSpec, NoiseIndex, SensorSpec, SunPosition};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::BTreeMap;

/// A row-major `h × w` buffer as a 2-D numpy array (moved, not copied).
fn array2<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>, h: usize, w: usize) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, v).reshape([h, w])?.into_any())
}

/// `{"effect": {"param": value}}` as an effect set, errors naming the entry.
pub(crate) fn effect_set(effects: Option<BTreeMap<String, BTreeMap<String, f64>>>) -> PyResult<EffectSet> {
    let mut set = EffectSet::new();
    for (effect, params) in effects.unwrap_or_default() {
        if params.is_empty() {
            set.enable(&effect).map_err(|e| PyValueError::new_err(format!("effects[{effect:?}]: {e}")))?;
        }
        for (param, v) in params {
            set.set(&effect, &param, v)
                .map_err(|e| PyValueError::new_err(format!("effects[{effect:?}][{param:?}]: {e}")))?;
        }
    }
    Ok(set)
}

/// One simulated DoFP frame and its truth.
///
/// simulate(width_px=612, height_px=512, *, heading_deg=0.0, sun_azimuth_deg=40.0,
///          sun_elevation_deg=25.0, tilt_x_deg=0.0, tilt_y_deg=0.0, effects=None,
///          seed=1, focal_length_mm=8.0, pixel_pitch_um=13.8, projection="pinhole",
///          bit_depth=12, black_level_dn=64.0, mosaic=((90, 45), (135, 0)),
///          peak_fraction=0.7, read_noise_dn=1.0, system_gain_dn_per_e=0.1, dmax=0.6) -> dict
///
/// Returns a dict: "mosaic" (uint16, height × width, DN, with shot and read noise),
/// "aop_deg", "dolp", "aoe_deg" and "intensity_dn" (float32, height × width: the
/// noise-free truth at each pixel, the light reaching its analyzer after the lens;
/// AoP in the image frame, counter-clockwise as displayed, (−90°, 90°]; AoE about
/// the true principal point; intensity in DN, the gain times Stokes S0), and
/// "focal_length_px" and "principal_point_px" (the nominal camera). `effects` is
/// {"effect": {"param": value}} with the names of `bpins.effects()`.
#[pyfunction]
#[pyo3(signature = (width_px=612, height_px=512, *, heading_deg=0.0, sun_azimuth_deg=40.0, sun_elevation_deg=25.0,
    tilt_x_deg=0.0, tilt_y_deg=0.0, effects=None, seed=1, focal_length_mm=8.0, pixel_pitch_um=13.8,
    projection="pinhole", bit_depth=12, black_level_dn=64.0, mosaic=[[90.0, 45.0], [135.0, 0.0]],
    peak_fraction=0.7, read_noise_dn=1.0, system_gain_dn_per_e=0.1, dmax=0.6))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    width_px: i64,
    height_px: i64,
    heading_deg: f64,
    sun_azimuth_deg: f64,
    sun_elevation_deg: f64,
    tilt_x_deg: f64,
    tilt_y_deg: f64,
    effects: Option<BTreeMap<String, BTreeMap<String, f64>>>,
    seed: i64,
    focal_length_mm: f64,
    pixel_pitch_um: f64,
    projection: &str,
    bit_depth: i64,
    black_level_dn: f64,
    mosaic: [[f64; 2]; 2],
    peak_fraction: f64,
    read_noise_dn: f64,
    system_gain_dn_per_e: f64,
    dmax: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let (width_px, height_px): (u32, u32) = (whole("width_px", width_px)?, whole("height_px", height_px)?);
    let (seed, bit_depth): (u64, u32) = (whole("seed", seed)?, whole("bit_depth", bit_depth)?);
    let capture = Capture {
        dir: ".".into(),
        sensor: SensorSpec {
            colour: None,
            layout: Layout::Dofp { mosaic: mosaic_of(mosaic)? },
            geometry: Geometry { width_px, height_px, pixel_pitch_um: finite("pixel_pitch_um", pixel_pitch_um)? },
            bit_depth,
            black_level_dn: finite("black_level_dn", black_level_dn)?,
        },
        lens: LensSpec {
            projection: self::projection(projection)?,
            focal_length_mm: finite("focal_length_mm", focal_length_mm)?,
            principal_point_px: ((width_px as f64 - 1.0) / 2.0, (height_px as f64 - 1.0) / 2.0),
        },
        frames: vec![FrameSpec {
            file: "frames/f000.png".into(),
            sun: SunPosition::given(
                finite("sun_azimuth_deg", sun_azimuth_deg)?,
                finite("sun_elevation_deg", sun_elevation_deg)?,
            ),
            heading_deg: Some(finite("heading_deg", heading_deg)?),
            tilt_x_deg: Some(finite("tilt_x_deg", tilt_x_deg)?),
            tilt_y_deg: Some(finite("tilt_y_deg", tilt_y_deg)?),
            tilt_sigma_deg: None,
            sun_sigma_deg: None,
            yaw_deg: None,
            yaw_sigma_deg: None,
        }],
    };
    // The capture's own rules (ranges, sizes) before anything is rendered.
    capture.validate().map_err(py_err)?;
    let frame = &capture.frames[0];
    // The front door's renderer (bpins_core::render): the capture's camera, the
    // sensor's response with its gain set from the peak, the effects as the truth.
    let response = Response {
        black_level_dn: capture.sensor.black_level_dn,
        read_noise_dn: finite("read_noise_dn", read_noise_dn)?,
        system_gain_dn_per_e: finite("system_gain_dn_per_e", system_gain_dn_per_e)?,
        bit_depth,
        quantize: true,
        ..Response::ideal(1.0)
    };
    let mut cfg = RendererConfig::dofp(capture.intrinsics(), width_px as usize, height_px as usize, response);
    cfg.layout = capture.sensor.layout.clone();
    cfg.effects = effect_set(effects)?;
    cfg.dmax = finite("dmax", dmax)?;
    let view = View {
        sun_azimuth_deg: frame.sun.azimuth_deg,
        sun_elevation_deg: frame.sun.elevation_deg,
        heading_deg,
        tilt_x_deg,
        tilt_y_deg,
    };
    let peak_fraction = finite("peak_fraction", peak_fraction)?;
    let (w, h) = (width_px as usize, height_px as usize);
    let (dn, truth) = py
        .detach(|| -> Result<_, bpins_core::render::RenderError> {
            let mut renderer = Renderer::new(cfg)?;
            let gain_dn = renderer.expose(&view, peak_fraction)?;
            let raw = renderer.raw_frame(&view, NoiseIndex { seed, trial: 0, frame: 0 })?;
            let mut dn = Vec::new();
            raw.to_u16_into(&mut dn);
            // The truth: the same chain without noise, what reaches the analyzers.
            let m = renderer.sky_maps(&view, Stage::Analyzers)?;
            let intensity: Vec<f32> = m.s0.iter().map(|&s| (s as f64 * gain_dn) as f32).collect();
            Ok((dn, [m.aop_deg, m.dolp, m.aoe_deg, intensity]))
        })
        .map_err(render_err)?;
    let [aop, dolp, aoe, intensity] = truth;
    let out = PyDict::new(py);
    out.set_item("mosaic", array2(py, dn, h, w)?)?;
    out.set_item("aop_deg", array2(py, aop, h, w)?)?;
    out.set_item("dolp", array2(py, dolp, h, w)?)?;
    out.set_item("aoe_deg", array2(py, aoe, h, w)?)?;
    out.set_item("intensity_dn", array2(py, intensity, h, w)?)?;
    out.set_item("focal_length_px", capture.focal_length_px())?;
    out.set_item("principal_point_px", capture.lens.principal_point_px)?;
    Ok(out)
}

/// A renderer's error as Python's: the chain's own as `py_err` maps it, the rest
/// (a configuration or a view out of range) as `ValueError`.
fn render_err(e: bpins_core::render::RenderError) -> PyErr {
    match e {
        bpins_core::render::RenderError::Core(e) => py_err(e),
        e => PyValueError::new_err(e.to_string()),
    }
}
