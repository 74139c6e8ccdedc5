//! Capture folders (docs/spec/CAPTURE.md) to and from numpy arrays, and the effect
//! catalog as data. The description of a capture is a dict with the keys and tables
//! of capture.toml (`format`, `sensor`, `lens`, `frames`), so what `read_capture`
//! returns `write_capture` takes, and every rule of the format (ranges, sizes, bit
//! depth) is checked by the same reader, with errors naming the key and the frame.

use crate::array::Borrowed;
use crate::{py_err, whole};
use bpins_core::effects::REGISTRY;
use bpins_core::{Capture, FrameData};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::path::PathBuf;

fn toml_to_py<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => PyString::new(py, s).into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(x) => PyFloat::new(py, *x).into_any(),
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Datetime(d) => PyString::new(py, &d.to_string()).into_any(),
        toml::Value::Array(a) => {
            let items = a.iter().map(|x| toml_to_py(py, x)).collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, toml_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// A Python value as TOML; `at` names where it is, for the error.
fn py_to_toml(v: &Bound<'_, PyAny>, at: &str) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(toml::Value::Integer(v.extract()?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract().map_err(|_| PyTypeError::new_err(format!("{at}: keys must be strings")))?;
            let here = if at.is_empty() { k.clone() } else { format!("{at}.{k}") };
            t.insert(k, py_to_toml(&x, &here)?);
        }
        return Ok(toml::Value::Table(t));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items = v
            .try_iter()?
            .enumerate()
            .map(|(i, x)| py_to_toml(&x?, &format!("{at}[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(toml::Value::Array(items));
    }
    if let Ok(x) = v.extract::<f64>() {
        // numpy scalars and other numbers.
        return Ok(toml::Value::Float(x));
    }
    Err(PyTypeError::new_err(format!(
        "{at}: {} is not a TOML value (str, int, float, bool, list or dict)",
        v.get_type().name().map(|n| n.to_string()).unwrap_or_default()
    )))
}

/// Reads a capture folder.
///
/// read_capture(path, frames=None) -> (meta, mosaics)
///
/// `meta` is capture.toml as a dict (every default written out, the sun of
/// time-and-place frames resolved; frames stamped with `time_utc` alone, for
/// `locate`, are read too); `mosaics` the frames' DN as float32 arrays:
/// (height, width) for dofp, (channels, height, width) for colocated in the order of
/// `meta["sensor"]["channels"]`. `frames` picks frame indices (default: all).
#[pyfunction]
#[pyo3(signature = (path, frames=None))]
pub fn read_capture<'py>(
    py: Python<'py>,
    path: PathBuf,
    frames: Option<Vec<i64>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyList>)> {
    let c = Capture::load_unplaced(&path).map_err(py_err)?;
    let frames = match frames {
        None => None,
        Some(f) => Some(f.into_iter().map(|i| whole::<usize>("frames[…]", i)).collect::<PyResult<Vec<_>>>()?),
    };
    let text = c.to_toml_string();
    let table: toml::Table = text.parse().map_err(|e| PyValueError::new_err(format!("{e}")))?;
    let meta = toml_to_py(py, &toml::Value::Table(table))?;
    let picks = frames.unwrap_or_else(|| (0..c.frames.len()).collect());
    let out = PyList::empty(py);
    for i in picks {
        let data = py.detach(|| c.read_frame(i)).map_err(py_err)?;
        let arr = match data {
            FrameData::Mosaic { width_px, height_px, dn } => {
                PyArray1::from_vec(py, dn).reshape([height_px as usize, width_px as usize])?.into_any()
            }
            FrameData::Colocated { width_px, height_px, channels } => {
                let n = channels.len();
                let flat: Vec<f32> = channels.into_iter().flat_map(|(_, p)| p).collect();
                PyArray1::from_vec(py, flat).reshape([n, height_px as usize, width_px as usize])?.into_any()
            }
        };
        out.append(arr)?;
    }
    Ok((meta, out))
}

/// Writes a new capture folder (never into an existing capture).
///
/// write_capture(path, meta, mosaics)
///
/// `meta` as `read_capture` returns it (the keys of capture.toml); `mosaics` one 2-D
/// array (uint8, uint16 or float32 DN) per entry of `meta["frames"]`, each the
/// sensor's shape; dofp only. Files are written whole or not at all.
#[pyfunction]
pub fn write_capture(
    py: Python<'_>,
    path: PathBuf,
    meta: &Bound<'_, PyAny>,
    mosaics: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let text = toml::to_string(&py_to_toml(meta, "meta")?).map_err(|e| PyValueError::new_err(format!("meta: {e}")))?;
    let c = Capture::parse(&path, &text).map_err(|e| PyValueError::new_err(format!("meta: {e}")))?;
    let g = &c.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let items: Vec<Bound<'_, PyAny>> = mosaics
        .try_iter()
        .map_err(|_| PyTypeError::new_err("mosaics: expected a list of 2-D arrays"))?
        .collect::<PyResult<_>>()?;
    if items.len() != c.frames.len() {
        return Err(PyValueError::new_err(format!(
            "mosaics: {} arrays for {} entries of meta[\"frames\"]",
            items.len(),
            c.frames.len()
        )));
    }
    let mut frames = Vec::with_capacity(items.len());
    for (i, a) in items.iter().enumerate() {
        let name = format!("mosaics[{i}]");
        let (ah, aw) = crate::array::shape2(&name, a)?;
        if (ah, aw) != (h, w) {
            return Err(PyValueError::new_err(format!(
                "{name}: shape ({ah}, {aw}); expected the sensor's (height_px, width_px) = ({h}, {w})"
            )));
        }
        let dn = Borrowed::new(&name, a)?.mosaic().to_f32(w, h);
        frames.push(FrameData::Mosaic { width_px: g.width_px, height_px: g.height_px, dn });
    }
    py.detach(|| c.write(&path, &frames)).map_err(py_err)
}

/// The effect catalog as data: one dict per effect (name, summary, source, stage,
/// params), each parameter with name, unit, neutral, typical, min, max and doc.
#[pyfunction]
pub fn effects<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    let out = PyList::empty(py);
    for e in REGISTRY {
        let d = PyDict::new(py);
        d.set_item("name", e.name)?;
        d.set_item("summary", e.summary)?;
        d.set_item("source", e.source)?;
        d.set_item("stage", format!("{:?}", e.stage).to_lowercase())?;
        let params = PyList::empty(py);
        for p in e.params {
            let pd = PyDict::new(py);
            pd.set_item("name", p.name)?;
            pd.set_item("unit", p.unit)?;
            pd.set_item("neutral", p.neutral)?;
            pd.set_item("typical", p.typical)?;
            pd.set_item("min", p.min)?;
            pd.set_item("max", p.max)?;
            pd.set_item("doc", p.doc)?;
            params.append(pd)?;
        }
        d.set_item("params", params)?;
        out.append(d)?;
    }
    Ok(out)
}
