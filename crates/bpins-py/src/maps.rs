//! `bpins.stokes_maps`: AoP, DoLP, intensity (and AoE) of a raw DoFP mosaic through
//! `bpins_core::maps`, the kernel behind `bpins maps` and the C ABI. The mosaic is read
//! in place (uint8, uint16 or float32, any row stride); the maps are written straight
//! into numpy arrays, new ones or those the caller passes in `out` (no allocation per
//! frame in a loop); the GIL is released while the kernel runs. A colour-polarization
//! mosaic (`colour_tiles`) gives one such dict per band.

use crate::array::{Borrowed, Mosaic};
use crate::compass::mosaic_of;
use crate::{finite, py_err};
use bpins_core::compass::{RawDn, RawImage};
use bpins_core::sensor::{Band, Channel, ColourTiles};
use bpins_core::{colour_maps_into, colour_maps_size, ColourScratch};
use bpins_core::{stokes_maps_into, Interpolation, MapsConfig, MapsOut, Reconstructor};
use numpy::{PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The maps' names, in the order of `MapsOut`.
const NAMES: [&str; 4] = ["aop_deg", "dolp", "intensity_dn", "aoe_deg"];

/// An output array: `out[name]` if given (float32, C-contiguous, the maps' shape),
/// else a new one.
fn output<'py>(
    py: Python<'py>,
    out: Option<&Bound<'py, PyDict>>,
    name: &str,
    h: usize,
    w: usize,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let Some(d) = out else {
        // SAFETY: every element is written by the kernel before Python sees the array.
        return Ok(unsafe { PyArray2::<f32>::new(py, [h, w], false) });
    };
    let obj = d.get_item(name)?.ok_or_else(|| {
        PyValueError::new_err(format!("out: no \"{name}\" array; expected float32 arrays of shape ({h}, {w})"))
    })?;
    let a = obj.cast::<PyArray2<f32>>().map_err(|_| {
        PyTypeError::new_err(format!("out[\"{name}\"]: expected a 2-D float32 numpy array of shape ({h}, {w})"))
    })?;
    if a.shape() != [h, w] || !a.is_c_contiguous() {
        return Err(PyValueError::new_err(format!(
            "out[\"{name}\"]: shape {:?}{}; expected a C-contiguous ({h}, {w})",
            a.shape(),
            if a.is_c_contiguous() { "" } else { ", not C-contiguous" }
        )));
    }
    Ok(a.clone())
}

/// AoP, DoLP and intensity (and AoE) of a raw DoFP mosaic.
///
/// stokes_maps(mosaic, *, black_level_dn=0.0, mosaic_layout=((90, 45), (135, 0)),
///             interpolation="bilinear", full_scale_dn=None, aoe=False,
///             aoe_centre_px=None, colour_tiles=None, out=None) -> dict
///
/// Returns "aop_deg" (image frame, counter-clockwise as displayed, (−90°, 90°]),
/// "dolp", "intensity_dn" (DN above the black level) and, with `aoe`, "aoe_deg" (about
/// `aoe_centre_px`, default the image centre): float32 arrays of the mosaic's shape,
/// half of it for "superpixel". "bilinear" interpolates each channel on its own
/// lattice (NaN where a sample it weighs is zero, non-finite or at `full_scale_dn`);
/// "opencv" reproduces polanalyser's `demosaicing` (OpenCV's Bayer bilinear) exactly
/// for uint8 and uint16 mosaics, "opencv_ea" its edge-aware `COLOR_PolarMono_EA` (the
/// same maps: the analyzers it keeps are the bilinear ones). `out`: a dict of preallocated float32 arrays, filled
/// in place and returned (a loop over frames then allocates nothing).
///
/// With `colour_tiles` (a colour-polarization mosaic, e.g. the IMX250MYR's
/// (("R", "G"), ("G", "B"))): a dict by band ("R", "G", "B") of such dicts, each band
/// from its own pixels (docs/colour.md); "opencv" is polanalyser's
/// `demosaicing(raw, COLOR_PolarRGB)` exactly, "opencv_ea" its `COLOR_PolarRGB_EA`,
/// "superpixel" a quarter of the size;
/// `out` then holds one dict per band.
#[pyfunction]
#[pyo3(signature = (mosaic, *, black_level_dn=0.0, mosaic_layout=[[90.0, 45.0], [135.0, 0.0]], interpolation="bilinear", full_scale_dn=None, aoe=false, aoe_centre_px=None, colour_tiles=None, out=None))]
#[allow(clippy::too_many_arguments)]
pub fn stokes_maps<'py>(
    py: Python<'py>,
    mosaic: &Bound<'py, PyAny>,
    black_level_dn: f64,
    mosaic_layout: [[f64; 2]; 2],
    interpolation: &str,
    full_scale_dn: Option<f64>,
    aoe: bool,
    aoe_centre_px: Option<[f64; 2]>,
    colour_tiles: Option<[[String; 2]; 2]>,
    out: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let interp = Interpolation::from_name(interpolation).ok_or_else(|| {
        let names: Vec<_> = Interpolation::ALL.iter().map(|i| i.name()).collect();
        PyValueError::new_err(format!("interpolation = {interpolation:?}; expected one of {}", names.join(", ")))
    })?;
    let borrowed = Borrowed::new("mosaic", mosaic)?;
    let (h, w) = crate::array::shape2("mosaic", mosaic)?;
    let centre = match aoe_centre_px {
        Some([x, y]) => [finite("aoe_centre_px[0]", x)?, finite("aoe_centre_px[1]", y)?],
        None => [(w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0],
    };
    let cfg = MapsConfig {
        interpolation: interp,
        mosaic: mosaic_of(mosaic_layout)?,
        full_scale_dn: match full_scale_dn {
            Some(f) if f > 0.0 => f,
            Some(f) => return Err(PyValueError::new_err(format!("full_scale_dn = {f}: expected a number > 0"))),
            None => f64::INFINITY,
        },
        aoe_centre_px: centre,
    };
    let rec = Reconstructor::new(&Default::default(), finite("black_level_dn", black_level_dn)?, &Channel::ALL)
        .map_err(py_err)?;
    let names = if aoe { &NAMES[..] } else { &NAMES[..3] };
    let tiles = colour_tiles.map(tiles_of).transpose()?;
    // The bands' output dicts (one, unnamed, for a mono mosaic).
    let (bands, (mw, mh)): (Vec<Option<Band>>, _) = match &tiles {
        Some(t) => (t.bands().into_iter().map(Some).collect(), colour_maps_size(interp, w, h)),
        None => (vec![None], interp.maps_size(w, h)),
    };
    let mut arrays: Vec<Vec<Bound<'py, PyArray2<f32>>>> = Vec::new();
    for b in &bands {
        let d = match (b, out) {
            (Some(b), Some(o)) => Some(
                o.get_item(b.name())?
                    .ok_or_else(|| PyValueError::new_err(format!("out: no \"{}\" dict of arrays", b.name())))?
                    .cast_into::<PyDict>()
                    .map_err(|_| PyTypeError::new_err(format!("out[\"{}\"]: expected a dict of arrays", b.name())))?,
            ),
            (None, o) => o.cloned(),
            (Some(_), None) => None,
        };
        arrays.push(names.iter().map(|n| output(py, d.as_ref(), n, mh, mw)).collect::<PyResult<_>>()?);
    }
    let mut guards = Vec::new();
    for band in &arrays {
        for (a, n) in band.iter().zip(names) {
            guards.push(a.try_readwrite().map_err(|e| PyValueError::new_err(format!("out[\"{n}\"]: {e}")))?);
        }
    }
    let mut slices: Vec<&mut [f32]> = guards.iter_mut().map(|g| g.as_slice_mut().expect("C-contiguous")).collect();
    let mut maps: Vec<(Band, MapsOut)> = Vec::new();
    let mut it = slices.iter_mut();
    for b in &bands {
        let (a, d, i) = (it.next().unwrap(), it.next().unwrap(), it.next().unwrap());
        let e = if aoe { it.next().map(|e| &mut **e) } else { None };
        maps.push((b.unwrap_or(Band::G), MapsOut { aop_deg: a, dolp: d, intensity_dn: i, aoe_deg: e }));
    }
    let m = borrowed.mosaic();
    let result = py.detach(|| {
        fn run<T: RawDn>(
            raw: &RawImage<T>,
            rec: &Reconstructor,
            cfg: &MapsConfig,
            tiles: &Option<ColourTiles>,
            mut maps: Vec<(Band, MapsOut)>,
        ) -> Result<(), bpins_core::MapsError> {
            match tiles {
                Some(t) => colour_maps_into(raw, rec, cfg, t, &mut ColourScratch::default(), &mut maps),
                None => stokes_maps_into(raw, rec, cfg, maps.pop().expect("one").1),
            }
        }
        match &m {
            Mosaic::U8(d, s) => {
                run(&RawImage { data: d, width_px: w, height_px: h, stride: *s }, &rec, &cfg, &tiles, maps)
            }
            Mosaic::U16(d, s) => {
                run(&RawImage { data: d, width_px: w, height_px: h, stride: *s }, &rec, &cfg, &tiles, maps)
            }
            Mosaic::F32(d, s) => {
                run(&RawImage { data: d, width_px: w, height_px: h, stride: *s }, &rec, &cfg, &tiles, maps)
            }
        }
    });
    result.map_err(|e| PyValueError::new_err(format!("mosaic: {e}")))?;
    drop(guards);
    let fill = |dict: &Bound<'py, PyDict>, band: Vec<Bound<'py, PyArray2<f32>>>| -> PyResult<()> {
        for (a, n) in band.into_iter().zip(names) {
            dict.set_item(n, a)?;
        }
        Ok(())
    };
    let dict = match out {
        Some(d) => d.clone(),
        None => PyDict::new(py),
    };
    for (b, band) in bands.into_iter().zip(arrays) {
        match b {
            None => fill(&dict, band)?,
            Some(b) => {
                let sub = match dict.get_item(b.name())? {
                    Some(s) => s.cast_into::<PyDict>()?,
                    None => {
                        let s = PyDict::new(py);
                        dict.set_item(b.name(), &s)?;
                        s
                    }
                };
                fill(&sub, band)?;
            }
        }
    }
    Ok(dict)
}

/// `colour_tiles` as the bands' names, by tile row and column.
fn tiles_of(t: [[String; 2]; 2]) -> PyResult<ColourTiles> {
    let mut c = ColourTiles::imx250myr();
    for (r, row) in t.iter().enumerate() {
        for (k, name) in row.iter().enumerate() {
            c.tiles[r][k] = Band::from_name(name).ok_or_else(|| {
                PyValueError::new_err(format!("colour_tiles: band {name:?} is unknown; use \"R\", \"G\" or \"B\""))
            })?;
        }
    }
    Ok(c)
}
