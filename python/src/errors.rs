//! The module's exceptions and how a Rust error becomes one: every error is a `SpmcalError` whose
//! message is the command line's, one line naming the file, argument or row and the reason.

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

create_exception!(spmcal, SpmcalError, PyException, "Base class of every spmcal error.");
create_exception!(
    spmcal,
    FileError,
    SpmcalError,
    "A file (or array) that cannot be used: the message names the file, line and reason."
);
create_exception!(spmcal, ModelError, SpmcalError, "A model (URDF, companion, parameters) that cannot be used.");
create_exception!(
    spmcal,
    KinematicsError,
    SpmcalError,
    "IK or FDA without a solution (outside the workspace, at a singularity)."
);
create_exception!(spmcal, ConfigError, SpmcalError, "A setting out of its range or unknown.");
create_exception!(spmcal, CalibrationError, SpmcalError, "A calibration that cannot be made from the session.");
create_exception!(spmcal, CompareError, SpmcalError, "A comparison that cannot be made.");
create_exception!(spmcal, PlanError, SpmcalError, "A plan that cannot be made.");
create_exception!(spmcal, SimulationError, SpmcalError, "A simulation that cannot be run.");

/// The error and its causes, as the command line prints them (a cause only where the message
/// does not already say it).
pub(crate) fn message(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        let cause_text = cause.to_string();
        if !text.contains(&cause_text) {
            text = format!("{text}: {cause_text}");
        }
        source = cause.source();
    }
    text
}

/// `|e| Kind::new_err(message(&e))`: a Rust error as the exception `Kind`.
macro_rules! raise {
    ($kind:ident) => {
        |e| $kind::new_err($crate::errors::message(&e))
    };
}
pub(crate) use raise;

/// A kinematics error at row `k` of the joint readings.
pub(crate) fn row_error(k: usize, e: &(dyn std::error::Error + 'static)) -> PyErr {
    KinematicsError::new_err(format!("joints row {k}: {}", message(e)))
}

/// `ArrayError(FileError, ValueError)`: an array argument numpy cannot read as numbers, or whose
/// values cannot be used. A `ValueError` because numpy users catch that (numpy raises it for the
/// same mistakes); a `FileError` because that is what arrays raised before it existed.
static ARRAY_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
/// `ShapeError(ArrayError)`: an array argument of the wrong shape.
static SHAPE_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

const ARRAY_DOC: &str = "An array argument that numpy cannot read as numbers, or whose values cannot be used \
     (a NaN joint reading, a quaternion that is not a unit one). A ValueError, and a FileError.";
const SHAPE_DOC: &str = "An array argument of the wrong shape: the message names the argument, the shape \
     expected and the shape given. A ValueError (through ArrayError).";

/// A class `name(*bases)` made as Python's `type()` makes one (pyo3 declares single bases only).
fn new_class<'py>(py: Python<'py>, name: &str, bases: Bound<'py, PyTuple>, doc: &str) -> PyResult<Py<PyType>> {
    let namespace = PyDict::new(py);
    namespace.set_item("__doc__", doc)?;
    namespace.set_item("__module__", "spmcal")?;
    Ok(py.get_type::<PyType>().call1((name, bases, namespace))?.cast_into::<PyType>()?.unbind())
}

/// The `ArrayError` class, made once.
pub(crate) fn array_error_type(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    let class = ARRAY_ERROR.get_or_try_init(py, || {
        let bases = PyTuple::new(py, [py.get_type::<FileError>(), py.get_type::<PyValueError>()])?;
        new_class(py, "ArrayError", bases, ARRAY_DOC)
    })?;
    Ok(class.bind(py))
}

/// The `ShapeError` class, made once.
pub(crate) fn shape_error_type(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    let class = SHAPE_ERROR.get_or_try_init(py, || {
        let bases = PyTuple::new(py, [array_error_type(py)?.clone()])?;
        new_class(py, "ShapeError", bases, SHAPE_DOC)
    })?;
    Ok(class.bind(py))
}

/// An `ArrayError` with `text` (or the error making the class, which would be a bug).
pub(crate) fn array_error(py: Python<'_>, text: String) -> PyErr {
    array_error_type(py).map_or_else(|e| e, |class| PyErr::from_type(class.clone(), text))
}

/// A `ShapeError` with `text`.
pub(crate) fn shape_error(py: Python<'_>, text: String) -> PyErr {
    shape_error_type(py).map_or_else(|e| e, |class| PyErr::from_type(class.clone(), text))
}

/// Add every exception class to the module.
pub(crate) fn add_to(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    for (name, class) in [
        ("SpmcalError", py.get_type::<SpmcalError>()),
        ("FileError", py.get_type::<FileError>()),
        ("ModelError", py.get_type::<ModelError>()),
        ("KinematicsError", py.get_type::<KinematicsError>()),
        ("ConfigError", py.get_type::<ConfigError>()),
        ("CalibrationError", py.get_type::<CalibrationError>()),
        ("CompareError", py.get_type::<CompareError>()),
        ("PlanError", py.get_type::<PlanError>()),
        ("SimulationError", py.get_type::<SimulationError>()),
        ("ArrayError", array_error_type(py)?.clone()),
        ("ShapeError", shape_error_type(py)?.clone()),
    ] {
        m.add(name, class)?;
    }
    Ok(())
}
