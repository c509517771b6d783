//! Array arguments as numpy users expect: anything `np.asarray(x, dtype=float64)` reads — lists,
//! tuples, float32, integers, non-contiguous views — is accepted; what it cannot read raises an
//! `ArrayError`, a wrong shape a `ShapeError` (both `ValueError`s), each one line naming the
//! argument, what it must be and what it was.

use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};
use numpy::{PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{array_error, shape_error};

/// An array argument: its name and what it must be, as its messages say them.
#[derive(Clone, Copy)]
pub(crate) struct Arg<'a> {
    /// The argument's name, e.g. `joints`.
    pub name: &'a str,
    /// What it must be, e.g. `an (n, 3) array of joint readings in rad or one reading (3,)`.
    pub expected: &'a str,
}

/// Joint readings, many or one.
pub(crate) const JOINTS: Arg<'static> =
    Arg { name: "joints", expected: "an (n, 3) array of joint readings in rad or one reading (3,)" };
/// Unit quaternions, many or one.
pub(crate) const QUATERNIONS: Arg<'static> =
    Arg { name: "q", expected: "an (n, 4) array of unit quaternions qw, qx, qy, qz or one quaternion (4,)" };

/// A shape as numpy prints it: `(4,)`, `(2, 3)`, `()`.
pub(crate) fn shape_text(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!("({})", shape.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")),
    }
}

/// The `ShapeError` of `arg` given an array of `shape`.
pub(crate) fn wrong_shape(py: Python<'_>, arg: Arg<'_>, shape: &[usize]) -> PyErr {
    shape_error(py, format!("{}: expected {}, got shape {}", arg.name, arg.expected, shape_text(shape)))
}

/// `x` as `np.asarray(x, dtype=float64)` reads it (no copy when it already is one). What numpy
/// refuses is an `ArrayError` (a ragged sequence a `ShapeError`), one line.
pub(crate) fn floats<'py>(x: &Bound<'py, PyAny>, arg: Arg<'_>) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    let py = x.py();
    let numpy = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", numpy.getattr("float64")?)?;
    let converted = match numpy.call_method("asarray", (x,), Some(&kwargs)) {
        Ok(a) => a,
        Err(e) => return Err(unreadable(x, arg, &e)),
    };
    let array = converted.cast_into::<PyArrayDyn<f64>>().map_err(|e| array_error(py, e.to_string()))?;
    Ok(array.readonly())
}

/// Why numpy could not read `x` as float64, in one line.
fn unreadable(x: &Bound<'_, PyAny>, arg: Arg<'_>, e: &PyErr) -> PyErr {
    let py = x.py();
    let reason = e.value(py).to_string();
    let reason = reason.lines().next().unwrap_or("").trim();
    // numpy's words for a list of rows of different lengths (1.24+).
    if reason.contains("inhomogeneous") || reason.contains("sequence") {
        let text =
            format!("{}: expected {}, got a ragged sequence (rows of different lengths)", arg.name, arg.expected);
        return shape_error(py, text);
    }
    let given = match x.getattr("dtype") {
        Ok(dtype) => format!("{} of dtype {dtype}", type_name(x)),
        Err(_) => type_name(x),
    };
    let text = format!("{}: expected {}; numpy cannot read the {given} as float64: {reason}", arg.name, arg.expected);
    array_error(py, text)
}

/// `type(x).__name__`.
fn type_name(x: &Bound<'_, PyAny>) -> String {
    x.get_type().name().map_or_else(|_| "object".to_string(), |n| n.to_string())
}

/// Rows of three from an `(n, 3)` array, or a `(3,)` one (`single`), every value finite.
pub(crate) fn rows3(x: &Bound<'_, PyAny>, arg: Arg<'_>) -> PyResult<(Vec<Vector3<f64>>, bool)> {
    let a = floats(x, arg)?;
    let v = a.as_array();
    let (rows, single): (Vec<Vector3<f64>>, bool) = match v.shape() {
        [3] => (vec![Vector3::new(v[[0]], v[[1]], v[[2]])], true),
        [_, 3] => (v.outer_iter().map(|r| Vector3::new(r[0], r[1], r[2])).collect(), false),
        shape => return Err(wrong_shape(x.py(), arg, shape)),
    };
    if let Some(k) = rows.iter().position(|r| !r.iter().all(|c| c.is_finite())) {
        let r = rows[k];
        let text =
            format!("{}: row {k} is [{}, {}, {}], not finite: expected {}", arg.name, r.x, r.y, r.z, arg.expected);
        return Err(array_error(x.py(), text));
    }
    Ok((rows, single))
}

/// Rotations from an `(n, 4)` array of unit quaternions `qw, qx, qy, qz`, or a `(4,)` one.
pub(crate) fn rotations(x: &Bound<'_, PyAny>, arg: Arg<'_>) -> PyResult<(Vec<Rotation3<f64>>, bool)> {
    let py = x.py();
    let a = floats(x, arg)?;
    let v = a.as_array();
    let one = |q: [f64; 4], row: usize| -> PyResult<Rotation3<f64>> {
        let q = Quaternion::new(q[0], q[1], q[2], q[3]);
        let norm = q.norm();
        if !norm.is_finite() || (norm - 1.0).abs() >= 1e-6 {
            return Err(array_error(py, format!("{}: row {row}: not a unit quaternion (norm {norm})", arg.name)));
        }
        Ok(UnitQuaternion::from_quaternion(q).to_rotation_matrix())
    };
    match v.shape() {
        [4] => Ok((vec![one([v[[0]], v[[1]], v[[2]], v[[3]]], 0)?], true)),
        [_, 4] => {
            let out: PyResult<Vec<_>> =
                v.outer_iter().enumerate().map(|(k, r)| one([r[0], r[1], r[2], r[3]], k)).collect();
            Ok((out?, false))
        }
        shape => Err(wrong_shape(py, arg, shape)),
    }
}

/// `n` finite values from a `(n,)` array-like (e.g. capture times).
pub(crate) fn values(x: &Bound<'_, PyAny>, arg: Arg<'_>, n: usize) -> PyResult<Vec<f64>> {
    let a = floats(x, arg)?;
    let v = a.as_array();
    if v.shape() != [n] {
        return Err(wrong_shape(x.py(), arg, v.shape()));
    }
    if let Some(k) = v.iter().position(|t| !t.is_finite()) {
        return Err(array_error(x.py(), format!("{}: row {k}: {} is not finite", arg.name, v[[k]])));
    }
    Ok(v.iter().copied().collect())
}

/// `n` non-negative integers from a `(n,)` array-like of integers (e.g. pose ids): numpy's integer
/// dtypes, Python ints, lists of them.
pub(crate) fn ids(x: &Bound<'_, PyAny>, arg: Arg<'_>, n: usize) -> PyResult<Vec<u64>> {
    let py = x.py();
    let array = py.import("numpy")?.call_method1("asarray", (x,)).map_err(|e| unreadable(x, arg, &e))?;
    let kind: String = array.getattr("dtype")?.getattr("kind")?.extract()?;
    let shape: Vec<usize> = array.getattr("shape")?.extract()?;
    if shape != [n] {
        return Err(wrong_shape(py, arg, &shape));
    }
    if kind != "i" && kind != "u" {
        let dtype = array.getattr("dtype")?.to_string();
        return Err(array_error(py, format!("{}: expected {}, got dtype {dtype}", arg.name, arg.expected)));
    }
    let values: Vec<i128> = array.call_method0("tolist")?.extract()?;
    match values.iter().position(|&v| v < 0 || v > i128::from(u64::MAX)) {
        Some(k) => Err(array_error(py, format!("{}: row {k}: {} is not a pose id (0 or more)", arg.name, values[k]))),
        None => Ok(values.into_iter().map(|v| v as u64).collect()),
    }
}
