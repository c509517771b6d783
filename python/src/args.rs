//! Model and parameters arguments: wherever a model is expected, a `Model` or the path of a URDF;
//! wherever a parameters file is, a `Model` or the path of one. A `Model` given as a model stands
//! for its mechanism's description, the URDF it was loaded with (for a parameters file's model,
//! the URDF the file belongs to), as `--model` does on the command line; its parameters count
//! where parameters are expected.

use std::path::PathBuf;
use std::sync::Arc;

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use spmcal::model::{Parameters, RobotModel};

use crate::Model;
use crate::errors::{FileError, ModelError, raise};

/// A model argument `name`: the `Model` itself, or the path of a URDF.
pub(crate) enum ModelArg<'py> {
    /// A `Model` object.
    Model(PyRef<'py, Model>),
    /// A path (str or os.PathLike).
    Path(PathBuf),
}

/// Read a model argument `name` (a `TypeError` naming it for anything else).
pub(crate) fn model_arg<'py>(arg: &Bound<'py, PyAny>, name: &str) -> PyResult<ModelArg<'py>> {
    if let Ok(model) = arg.cast::<Model>() {
        return Ok(ModelArg::Model(model.borrow()));
    }
    arg.extract::<PathBuf>().map(ModelArg::Path).map_err(|_| {
        let given = arg.get_type().name().map_or_else(|_| "object".to_string(), |n| n.to_string());
        PyTypeError::new_err(format!(
            "{name}: expected a spmcal.Model or the path of a model's URDF (str or os.PathLike), got {given}"
        ))
    })
}

impl ModelArg<'_> {
    /// The URDF: the path, or the one the `Model` was loaded with.
    pub(crate) fn urdf(&self, name: &str) -> PyResult<PathBuf> {
        match self {
            ModelArg::Path(p) => Ok(p.clone()),
            ModelArg::Model(m) => Ok(m.robot(name)?.urdf_path.clone()),
        }
    }

    /// The mechanism: the `Model`'s (no reload), or the URDF at the path loaded.
    pub(crate) fn robot(&self, name: &str) -> PyResult<Arc<RobotModel>> {
        match self {
            ModelArg::Path(p) => Ok(Arc::new(RobotModel::load(p).map_err(raise!(ModelError))?)),
            ModelArg::Model(m) => m.robot(name),
        }
    }
}

/// An optional model argument's mechanism, `None` when not given.
pub(crate) fn robot_opt(arg: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<Arc<RobotModel>>> {
    arg.map(|a| model_arg(a, name)?.robot(name)).transpose()
}

/// An optional model argument's URDF, `None` when not given.
pub(crate) fn urdf_opt(arg: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<PathBuf>> {
    arg.map(|a| model_arg(a, name)?.urdf(name)).transpose()
}

/// A parameters argument: its label (the file's path, or the `Model`'s source), the parameters,
/// and the `Model`'s mechanism when it has one.
pub(crate) struct ParamsArg {
    /// How reports name it: the file, or the `Model`'s source.
    pub label: String,
    /// The parameters.
    pub params: Parameters,
    /// The mechanism of a `Model` given as parameters (a path brings none).
    pub robot: Option<Arc<RobotModel>>,
}

/// Read a parameters argument `name`: a `Model`'s parameters, or the parameters file at a path.
pub(crate) fn params_arg(arg: &Bound<'_, PyAny>, name: &str) -> PyResult<ParamsArg> {
    match model_arg(arg, name).map_err(|_| not_params(arg, name))? {
        ModelArg::Model(m) => {
            Ok(ParamsArg { label: m.source.clone(), params: m.params.clone(), robot: m.robot.clone() })
        }
        ModelArg::Path(p) => Ok(ParamsArg {
            label: p.display().to_string(),
            params: Parameters::read(&p).map_err(raise!(FileError))?,
            robot: None,
        }),
    }
}

/// The `TypeError` of a parameters argument that is neither a `Model` nor a path.
fn not_params(arg: &Bound<'_, PyAny>, name: &str) -> PyErr {
    let given = arg.get_type().name().map_or_else(|_| "object".to_string(), |n| n.to_string());
    PyTypeError::new_err(format!(
        "{name}: expected a spmcal.Model or the path of a parameters file (str or os.PathLike), got {given}"
    ))
}
