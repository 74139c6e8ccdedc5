//! A numpy mosaic borrowed as a bpins raw image: uint8, uint16 or float32, 2-D, with
//! any row stride (a crop, a view of a larger buffer) and no copy; a copy is made
//! only where the columns are not adjacent in memory (`a[:, ::2]`), which no raw
//! image layout can express.

use numpy::{PyArray2, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::borrow::Cow;

/// The three DN types a camera delivers.
pub(crate) enum Mosaic<'a> {
    U8(Cow<'a, [u8]>, usize),
    U16(Cow<'a, [u16]>, usize),
    F32(Cow<'a, [f32]>, usize),
}

/// `(height, width)` of a 2-D array named `name`, or the exception saying what it is.
pub(crate) fn shape2(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<(usize, usize)> {
    let a = obj.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name}: expected a 2-D numpy array (uint8, uint16 or float32), got {}",
            obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "an object".into())
        ))
    })?;
    if a.ndim() != 2 {
        return Err(PyValueError::new_err(format!(
            "{name}: a {}-D array of shape {:?}; expected a 2-D mosaic (height, width)",
            a.ndim(),
            a.shape()
        )));
    }
    Ok((a.shape()[0], a.shape()[1]))
}

fn borrow<'a, T: numpy::Element + Copy>(a: &'a numpy::PyReadonlyArray2<'_, T>) -> (Cow<'a, [T]>, usize) {
    let v = a.as_array();
    let (h, w) = v.dim();
    let (s0, s1) = (v.strides()[0], v.strides()[1]);
    if h > 0 && w > 0 && (s1 == 1 || w == 1) && s0 >= w as isize {
        let len = (h - 1) * s0 as usize + w;
        // SAFETY: rows start `s0` elements apart with adjacent columns, so the `len`
        // elements from the first one lie inside the array's buffer, which `a`
        // keeps borrowed (read-only) for as long as the slice lives.
        let data = unsafe { std::slice::from_raw_parts(v.as_ptr(), len) };
        (Cow::Borrowed(data), s0 as usize)
    } else {
        (Cow::Owned(v.iter().copied().collect()), w)
    }
}

/// Holds the numpy borrow while a [`Mosaic`] reads it.
pub(crate) enum Borrowed<'py> {
    U8(numpy::PyReadonlyArray2<'py, u8>),
    U16(numpy::PyReadonlyArray2<'py, u16>),
    F32(numpy::PyReadonlyArray2<'py, f32>),
}

impl<'py> Borrowed<'py> {
    /// Borrows `obj` (argument `name`) read-only.
    pub(crate) fn new(name: &str, obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        shape2(name, obj)?;
        if let Ok(a) = obj.cast::<PyArray2<u16>>() {
            return Ok(Borrowed::U16(a.try_readonly()?));
        }
        if let Ok(a) = obj.cast::<PyArray2<u8>>() {
            return Ok(Borrowed::U8(a.try_readonly()?));
        }
        if let Ok(a) = obj.cast::<PyArray2<f32>>() {
            return Ok(Borrowed::F32(a.try_readonly()?));
        }
        let dtype = obj.getattr("dtype").map(|d| d.to_string()).unwrap_or_else(|_| "?".into());
        Err(PyTypeError::new_err(format!("{name}: dtype {dtype}; expected uint8, uint16 or float32 (DN)")))
    }

    /// The pixels, with the row stride in elements.
    pub(crate) fn mosaic(&self) -> Mosaic<'_> {
        match self {
            Borrowed::U8(a) => {
                let (d, s) = borrow(a);
                Mosaic::U8(d, s)
            }
            Borrowed::U16(a) => {
                let (d, s) = borrow(a);
                Mosaic::U16(d, s)
            }
            Borrowed::F32(a) => {
                let (d, s) = borrow(a);
                Mosaic::F32(d, s)
            }
        }
    }
}

/// Whether the mosaic was read in place (no copy).
impl Mosaic<'_> {
    pub(crate) fn borrowed(&self) -> bool {
        matches!(
            self,
            Mosaic::U8(Cow::Borrowed(_), _) | Mosaic::U16(Cow::Borrowed(_), _) | Mosaic::F32(Cow::Borrowed(_), _)
        )
    }

    /// Every pixel as f32 DN, row-major and packed (for the simulation and capture paths).
    pub(crate) fn to_f32(&self, w: usize, h: usize) -> Vec<f32> {
        fn rows<T: Copy>(d: &[T], s: usize, w: usize, h: usize, f: impl Fn(T) -> f32) -> Vec<f32> {
            let mut out = Vec::with_capacity(w * h);
            for v in 0..h {
                out.extend(d[v * s..v * s + w].iter().map(|&x| f(x)));
            }
            out
        }
        match self {
            Mosaic::U8(d, s) => rows(d, *s, w, h, f32::from),
            Mosaic::U16(d, s) => rows(d, *s, w, h, f32::from),
            Mosaic::F32(d, s) => rows(d, *s, w, h, |x| x),
        }
    }
}
