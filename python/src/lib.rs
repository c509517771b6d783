//! `spmcal._spmcal`: the native half of the `spmcal` Python package (pyo3 + rust-numpy, stable
//! ABI). Arrays in and out (`(n, 3)` joints in rad, `(n, 4)` quaternions `qw, qx, qy, qz`,
//! `(n, 3, 3)` matrices; any array-like in, `arrays`); a `Model` wherever a model or parameters
//! are expected (`args`); every error a Python exception under `SpmcalError` whose one-line
//! message is the command line's (`errors`); the parameters in the report's units (`table`).
//! `spmcal/__init__.py` re-exports it with its types (`_spmcal.pyi`, `_types.py`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use spmcal::calib::CalibConfig;
use spmcal::model::{CameraModelKind, Parameters, RobotModel, Spm};
use spmcal::vision::Method;

mod args;
mod arrays;
mod errors;
mod table;

use args::{model_arg, params_arg, robot_opt, urdf_opt};
use arrays::{Arg, JOINTS, QUATERNIONS, rotations, rows3};
use errors::{
    CalibrationError, CompareError, ConfigError, FileError, KinematicsError, ModelError, PlanError, SimulationError,
    SpmcalError, message, raise, row_error,
};

/// `qw, qx, qy, qz` with `qw ≥ 0`.
fn quaternion(r: &Rotation3<f64>) -> [f64; 4] {
    let q = UnitQuaternion::from_rotation_matrix(r);
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    [s * q.w, s * q.i, s * q.j, s * q.k]
}

/// Quaternions as `(n, 4)`, or `(4,)` for a single row.
fn quaternion_array<'py>(py: Python<'py>, rs: &[Rotation3<f64>], single: bool) -> Bound<'py, PyAny> {
    let mut a = Array2::<f64>::zeros((rs.len(), 4));
    for (k, r) in rs.iter().enumerate() {
        for (i, v) in quaternion(r).iter().enumerate() {
            a[[k, i]] = *v;
        }
    }
    if single { a.row(0).to_owned().into_pyarray(py).into_any() } else { a.into_pyarray(py).into_any() }
}

/// 3 × 3 matrices as `(n, 3, 3)`, or `(3, 3)` for a single one.
fn matrix_array<'py>(py: Python<'py>, ms: &[nalgebra::Matrix3<f64>], single: bool) -> Bound<'py, PyAny> {
    let mut a = Array3::<f64>::zeros((ms.len(), 3, 3));
    for (k, m) in ms.iter().enumerate() {
        for i in 0..3 {
            for j in 0..3 {
                a[[k, i, j]] = m[(i, j)];
            }
        }
    }
    if single {
        a.index_axis(numpy::ndarray::Axis(0), 0).to_owned().into_pyarray(py).into_any()
    } else {
        a.into_pyarray(py).into_any()
    }
}

/// A mechanism's kinematic model: the nominal one of a URDF, or a (calibrated) parameters file.
#[pyclass(module = "spmcal._spmcal", frozen)]
struct Model {
    spm: Spm,
    robot: Option<Arc<RobotModel>>,
    params: Parameters,
    source: String,
}

#[pymethods]
impl Model {
    /// The nominal model `urdf`: a shipped model's name (`"agile_wrist"`, `"orbita3d"`: compiled
    /// in, found anywhere) or a URDF's path (its companion `.yaml` beside it).
    #[staticmethod]
    fn load(urdf: PathBuf) -> PyResult<Model> {
        let robot = RobotModel::load(&urdf).map_err(raise!(ModelError))?;
        let params = Parameters {
            model_sha256: Some(robot.sha256.clone()),
            ..Parameters::nominal(&robot.spm, Some(urdf.display().to_string()))
        };
        Ok(Model { spm: robot.spm.clone(), robot: Some(Arc::new(robot)), params, source: urdf.display().to_string() })
    }

    /// The model of the parameters file at `params` (e.g. a calibration's), with the model it was
    /// made with: `urdf` (a shipped model's name, a URDF's path or a `Model`) when given, else the
    /// file's `model:` (relative to the file; the shipped model of the file's `model_sha256` when
    /// that path is not found; an error naming the file's line when neither is found). A file that
    /// names no model gives a geometry alone (it computes; it is no model where one is expected).
    #[staticmethod]
    #[pyo3(signature = (params, urdf=None))]
    fn from_params(py: Python<'_>, params: PathBuf, urdf: Option<&Bound<'_, PyAny>>) -> PyResult<Model> {
        let p = Parameters::read(&params).map_err(raise!(FileError))?;
        let spm = p.spm().map_err(|e| ModelError::new_err(format!("{}: {}", params.display(), message(&e))))?;
        let robot = match urdf {
            Some(u) => {
                let robot = model_arg(u, "urdf")?.robot("urdf")?;
                for w in p.check_model(&params, &robot).map_err(raise!(ModelError))? {
                    warn(py, &w)?;
                }
                Some(robot)
            }
            // A file that names no model is a geometry alone: it computes, and is no model where
            // one is needed.
            None if p.model.is_none() => None,
            None => {
                let (robot, warnings) = p.load_model(&params, None).map_err(raise!(ModelError))?;
                for w in warnings {
                    warn(py, &w)?;
                }
                Some(Arc::new(robot))
            }
        };
        Ok(Model { spm, robot, params: p, source: params.display().to_string() })
    }

    /// The MP orientation for joint readings `joints` (`(n, 3)` or `(3,)`, rad) by the working-mode
    /// FDA: `(n, 4)` quaternions `qw, qx, qy, qz`, or `(n, 3, 3)` matrices with `matrices=True`.
    /// Raises `KinematicsError` naming the first row without a solution, or with a reading beyond a
    /// full turn (degrees, not radians).
    #[pyo3(signature = (joints, matrices=false))]
    fn forward<'py>(&self, py: Python<'py>, joints: &Bound<'py, PyAny>, matrices: bool) -> PyResult<Bound<'py, PyAny>> {
        let (rows, single) = rows3(joints, JOINTS)?;
        let spm = &self.spm;
        let solved: Result<Vec<Rotation3<f64>>, (usize, String)> = py.detach(|| {
            rows.iter()
                .enumerate()
                .map(|(k, j)| match degrees(j) {
                    Some(reason) => Err((k, reason)),
                    None => spm.forward(j).map_err(|e| (k, message(&e))),
                })
                .collect()
        });
        let rs = solved.map_err(|(k, e)| KinematicsError::new_err(format!("joints row {k}: {e}")))?;
        Ok(if matrices {
            let ms: Vec<_> = rs.iter().map(|r| *r.matrix()).collect();
            matrix_array(py, &ms, single)
        } else {
            quaternion_array(py, &rs, single)
        })
    }

    /// Joint readings (rad) of the working mode for MP orientations `q` (`(n, 4)` or `(4,)`
    /// quaternions `qw, qx, qy, qz`).
    fn ik<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (rs, single) = rotations(q, QUATERNIONS)?;
        let spm = &self.spm;
        let solved: Result<Vec<Vector3<f64>>, (usize, String)> =
            py.detach(|| rs.iter().enumerate().map(|(k, r)| spm.ik(r).map_err(|e| (k, message(&e)))).collect());
        let js = solved.map_err(|(k, e)| KinematicsError::new_err(format!("q row {k}: {e}")))?;
        Ok(rows_array(py, &js, single))
    }

    /// The FDA tracked along a stream: each row of `joints` solved from the previous solution,
    /// the first from `previous` (a quaternion): `(n, 4)` quaternions. The haptic loop's call.
    fn track<'py>(
        &self,
        py: Python<'py>,
        joints: &Bound<'py, PyAny>,
        previous: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (rows, single) = rows3(joints, JOINTS)?;
        let arg = Arg { name: "previous", expected: "one quaternion qw, qx, qy, qz (of unit norm), shape (4,)" };
        let (start, one) = rotations(previous, arg)?;
        if !one {
            return Err(arrays::wrong_shape(py, arg, &[start.len(), 4]));
        }
        let mut last = start[0];
        let mut out = Vec::with_capacity(rows.len());
        for (k, j) in rows.iter().enumerate() {
            last = self.spm.track(j, &last).map_err(|e| row_error(k, &e))?;
            out.push(last);
        }
        Ok(quaternion_array(py, &out, single))
    }

    /// Every assembly mode (at most 8) for one set of joint readings `(3,)`: `(k, 4)` quaternions,
    /// nearest home first.
    fn all_modes<'py>(&self, py: Python<'py>, joints: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let arg =
            Arg { name: "joints", expected: "one set of joint readings in rad, shape (3,) (all_modes solves one)" };
        let (rows, single) = rows3(joints, arg)?;
        if !single {
            return Err(arrays::wrong_shape(py, arg, &[rows.len(), 3]));
        }
        let modes: Vec<Rotation3<f64>> = self.spm.all_modes(&rows[0]).iter().map(|m| m.rotation).collect();
        Ok(quaternion_array(py, &modes, false))
    }

    /// The forward Jacobian `J = A⁻¹B` (joint rates → MP angular velocity) at each row of
    /// `joints`: `(n, 3, 3)`; NaN at a parallel singularity.
    fn jacobians<'py>(&self, py: Python<'py>, joints: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (rows, single) = rows3(joints, JOINTS)?;
        let nan = nalgebra::Matrix3::from_element(f64::NAN);
        let out: Vec<_> = self.jacobians_at(&rows)?.iter().map(|j| j.forward().unwrap_or(nan)).collect();
        Ok(matrix_array(py, &out, single))
    }

    /// The conditioning index (1 isotropic, 0 at a parallel singularity) at each row of `joints`:
    /// `(n,)`, or a float for a single row `(3,)`.
    fn conditioning<'py>(&self, py: Python<'py>, joints: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (rows, single) = rows3(joints, JOINTS)?;
        let out: Array1<f64> = self.jacobians_at(&rows)?.iter().map(spmcal::model::Jacobians::conditioning).collect();
        Ok(if single { out[0].into_pyobject(py)?.into_any() } else { out.into_pyarray(py).into_any() })
    }

    /// The names of the markers on the MP (the URDF companion's, else the parameters file's).
    #[getter]
    fn marker_names(&self) -> Vec<String> {
        match &self.robot {
            Some(r) => r.markers.iter().map(|m| m.name.clone()).collect(),
            None => self.params.markers.iter().map(|m| m.name.clone()).collect(),
        }
    }

    /// The parameters file's content (geometry, registration, markers) as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        yaml_to_python(py, &self.params.to_yaml())
    }

    /// Write the model as a parameters file (atomically).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.params.write(&path).map_err(raise!(FileError))
    }

    fn __repr__(&self) -> String {
        let legs: Vec<String> = self
            .spm
            .geometry()
            .iter()
            .enumerate()
            .map(|(i, l)| {
                format!(
                    "leg{}: alpha1 {:.4}°, alpha2 {:.4}°, u [{:+.4}, {:+.4}, {:+.4}]",
                    i + 1,
                    l.alpha1.to_degrees(),
                    l.alpha2.to_degrees(),
                    l.u.x,
                    l.u.y,
                    l.u.z
                )
            })
            .collect();
        format!("Model({}; {})", self.source, legs.join("; "))
    }
}

impl Model {
    /// The closure Jacobians at each row of joint readings, at the working-mode FDA's pose.
    fn jacobians_at(&self, rows: &[Vector3<f64>]) -> PyResult<Vec<spmcal::model::Jacobians>> {
        rows.iter()
            .enumerate()
            .map(|(k, j)| {
                // The closure's Jacobians are the rigid mechanism's, at its own orientation.
                let r = self.spm.forward(j).map_err(|e| row_error(k, &e))?;
                Ok(self.spm.jacobians(j, &self.spm.rigid(&r)))
            })
            .collect()
    }

    /// The mechanism this model describes, for an argument `name` that expects a model: its URDF's
    /// (a parameters file's model without a URDF found cannot be one).
    fn robot(&self, name: &str) -> PyResult<Arc<RobotModel>> {
        self.robot.clone().ok_or_else(|| {
            ModelError::new_err(format!(
                "{name}: the Model of {} names no model (no `model:`): load it with Model.from_params(params, urdf=...)",
                self.source
            ))
        })
    }
}

/// Rows of three as `(n, 3)`, or `(3,)` for a single row.
fn rows_array<'py>(py: Python<'py>, rows: &[Vector3<f64>], single: bool) -> Bound<'py, PyAny> {
    let mut a = Array2::<f64>::zeros((rows.len(), 3));
    for (k, r) in rows.iter().enumerate() {
        for i in 0..3 {
            a[[k, i]] = r[i];
        }
    }
    if single { a.row(0).to_owned().into_pyarray(py).into_any() } else { a.into_pyarray(py).into_any() }
}

/// YAML text as Python objects (through JSON).
fn yaml_to_python<'py>(py: Python<'py>, yaml: &str) -> PyResult<Bound<'py, PyAny>> {
    let value: serde_json::Value = serde_yaml::from_str(yaml).map_err(|e| SpmcalError::new_err(e.to_string()))?;
    json_to_python(py, &value.to_string())
}

/// A serialisable value (a report, a summary) as Python objects, as `--json` gives it.
fn to_python<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    json_to_python(py, &serde_json::to_string(value).map_err(|e| SpmcalError::new_err(e.to_string()))?)
}

/// JSON text as Python objects.
fn json_to_python<'py>(py: Python<'py>, json: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (json,))
}

/// A session: static poses, sequential captures, a free-motion recording or a ROS 2 bag.
#[pyclass(module = "spmcal._spmcal", frozen)]
struct Session {
    inner: Arc<spmcal::dataset::Session>,
}

#[pymethods]
impl Session {
    /// Load the session at `path` (a session folder, an `.mcap` bag or a bag folder); `model`
    /// (a URDF's path or a `Model`) overrides the URDF it names.
    #[staticmethod]
    #[pyo3(signature = (path, model=None))]
    fn load(py: Python<'_>, path: PathBuf, model: Option<&Bound<'_, PyAny>>) -> PyResult<Session> {
        let model = urdf_opt(model, "model")?;
        let loaded = py.detach(|| spmcal::dataset::Session::load(&path, model.as_deref()));
        let (session, warnings) = loaded.map_err(raise!(FileError))?;
        // What the command line prints as `warning:` lines, as Python warnings (not its notes:
        // a recording's few frames at its ends left out are expected, and would warn on every
        // clean recording).
        let warn = py.import("warnings")?;
        for w in warnings.iter().filter(|w| !w.note) {
            warn.call_method1("warn", (w.to_string(),))?;
        }
        Ok(Session { inner: Arc::new(session) })
    }

    /// A static session from arrays already in memory (any array-likes): `joints` `(n, 3)` rad,
    /// `markers` `(n, m, 3)` m in the camera frame (NaN where a marker was not seen),
    /// `marker_names` (m, the model's), `model` the URDF (a path or a `Model`), `poses` `n`
    /// integer ids, `times` `n` seconds. Checked as a session folder is.
    #[staticmethod]
    #[pyo3(signature = (joints, markers, marker_names, model, name="arrays".to_string(), poses=None, times=None))]
    #[allow(clippy::too_many_arguments)]
    fn from_arrays(
        joints: &Bound<'_, PyAny>,
        markers: &Bound<'_, PyAny>,
        marker_names: Vec<String>,
        model: &Bound<'_, PyAny>,
        name: String,
        poses: Option<&Bound<'_, PyAny>>,
        times: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Session> {
        let model = model_arg(model, "model")?.urdf("model")?;
        let (rows, _) = rows3(joints, Arg { name: "joints", expected: "an (n, 3) array of joint readings in rad" })?;
        let n = rows.len();
        let seen = marker_rows(markers, &marker_names, n)?;
        let expected = format!("({n},): an integer pose id per row of joints");
        let ids = match poses {
            Some(p) => arrays::ids(p, Arg { name: "poses", expected: &expected }, n)?,
            None => (0..n as u64).collect(),
        };
        let expected = format!("({n},): a time in s per row of joints");
        let times = times.map(|t| arrays::values(t, Arg { name: "times", expected: &expected }, n)).transpose()?;
        let mut pose_list = Vec::with_capacity(n);
        for (k, (j, seen)) in rows.iter().zip(seen).enumerate() {
            pose_list.push(spmcal::dataset::SessionPose {
                id: ids[k],
                joints: *j,
                time_s: times.as_ref().map(|t| t[k]),
                markers: seen,
                line: k + 1,
                marker_lines: vec![0; marker_names.len()],
                station: None,
                pixels: Vec::new(),
                body: None,
            });
        }
        let session =
            spmcal::dataset::Session::from_poses(&name, &model, marker_names, pose_list).map_err(raise!(FileError))?;
        Ok(Session { inner: Arc::new(session) })
    }

    /// The session's name.
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    /// `"static"` or `"free_motion"`.
    #[getter]
    fn kind(&self) -> &'static str {
        if self.inner.streams.is_some() { "free_motion" } else { "static" }
    }

    /// The URDF the session is read with.
    #[getter]
    fn model(&self) -> String {
        self.inner.model.display().to_string()
    }

    /// Marker names, in the order of `markers`' second axis.
    #[getter]
    fn marker_names(&self) -> Vec<String> {
        self.inner.markers.clone()
    }

    /// Pose ids `(n,)` (a free-motion recording: one per camera frame).
    #[getter]
    fn poses<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u64>> {
        self.inner.poses.iter().map(|p| p.id).collect::<Vec<_>>().into_pyarray(py)
    }

    /// Joint readings `(n, 3)`, rad.
    #[getter]
    fn joints<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let rows: Vec<Vector3<f64>> = self.inner.poses.iter().map(|p| p.joints).collect();
        rows_array(py, &rows, false)
    }

    /// Marker positions `(n, m, 3)`, m, NaN where not seen.
    #[getter]
    fn markers<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let m = self.inner.markers.len();
        let mut a = Array3::<f64>::from_elem((self.inner.poses.len(), m, 3), f64::NAN);
        for (k, p) in self.inner.poses.iter().enumerate() {
            for (i, x) in p.markers.iter().enumerate() {
                if let Some(x) = x {
                    for c in 0..3 {
                        a[[k, i, c]] = x[c];
                    }
                }
            }
        }
        a.into_pyarray(py)
    }

    /// The cameras of a session seen through its pixels (`cameras.yaml`'s names, in the order of
    /// `pixels["camera"]`); empty for a session of points.
    #[getter]
    fn cameras(&self) -> Vec<String> {
        self.inner.rig.iter().flat_map(|r| r.cameras.iter().map(|c| c.name.clone())).collect()
    }

    /// Each pixel a camera saw (`pixels.csv`), one row per marker per camera: a dict of arrays —
    /// `pose` `(k,)` uint64 (a free-motion recording: `time_s` `(k,)`, the capture's time in s on
    /// the camera's clock), `marker` `(k,)` int64 (into `marker_names`), `camera` `(k,)` int64
    /// (into `cameras`), `uv` `(k, 2)` px (the top-left pixel's centre at (0, 0)). Empty arrays
    /// for a session of points.
    #[getter]
    fn pixels<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let out = PyDict::new(py);
        let rows: Vec<(f64, u64, &spmcal::dataset::SeenPixel)> = match &self.inner.streams {
            Some(streams) => streams.pixels().map(|(t, p)| (t, 0, p)).collect(),
            None => {
                self.inner.poses.iter().flat_map(|pose| pose.pixels.iter().map(|p| (f64::NAN, pose.id, p))).collect()
            }
        };
        if self.inner.streams.is_some() {
            out.set_item("time_s", rows.iter().map(|r| r.0).collect::<Vec<_>>().into_pyarray(py))?;
        } else {
            out.set_item("pose", rows.iter().map(|r| r.1).collect::<Vec<_>>().into_pyarray(py))?;
        }
        out.set_item("marker", rows.iter().map(|r| r.2.marker as i64).collect::<Vec<_>>().into_pyarray(py))?;
        out.set_item("camera", rows.iter().map(|r| r.2.camera as i64).collect::<Vec<_>>().into_pyarray(py))?;
        let uv = Array2::from_shape_fn((rows.len(), 2), |(i, k)| rows[i].2.pixel[k]);
        out.set_item("uv", uv.into_pyarray(py))?;
        Ok(out)
    }

    /// Capture times `(n,)`, s (NaN where none was recorded).
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.poses.iter().map(|p| p.time_s.unwrap_or(f64::NAN)).collect::<Vec<_>>().into_pyarray(py)
    }

    /// Write the session as a folder (CSV), or as a ROS 2 bag when `path` ends in `.mcap`.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        if path.extension().is_some_and(|x| x == "mcap") {
            self.inner.write_bag(&path).map_err(raise!(FileError))
        } else {
            self.inner.write(&path).map_err(raise!(FileError))
        }
    }

    fn __len__(&self) -> usize {
        self.inner.poses.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Session({}, {} {} poses, markers {:?})",
            self.inner.name,
            self.inner.poses.len(),
            self.kind(),
            self.inner.markers
        )
    }
}

/// The markers of each pose from an `(n, m, 3)` array-like: a position, or `None` where all three
/// coordinates are NaN (not seen); anything else not finite is an `ArrayError`.
fn marker_rows(markers: &Bound<'_, PyAny>, names: &[String], n: usize) -> PyResult<Vec<Vec<Option<Vector3<f64>>>>> {
    let py = markers.py();
    let expected =
        format!("shape ({n}, {}, 3), marker positions in m (poses, marker_names, xyz; NaN where unseen)", names.len());
    let arg = Arg { name: "markers", expected: &expected };
    let a = arrays::floats(markers, arg)?;
    let m = a.as_array();
    if m.shape() != [n, names.len(), 3] {
        return Err(arrays::wrong_shape(py, arg, m.shape()));
    }
    let mut rows = Vec::with_capacity(n);
    for k in 0..n {
        let mut seen = Vec::with_capacity(names.len());
        for (i, name) in names.iter().enumerate() {
            let p = Vector3::new(m[[k, i, 0]], m[[k, i, 1]], m[[k, i, 2]]);
            if p.iter().all(|v| v.is_nan()) {
                seen.push(None);
            } else if p.iter().all(|v| v.is_finite()) {
                seen.push(Some(p));
            } else {
                let text = format!(
                    "markers: row {k}, marker `{name}`: {:?} is neither a position nor unseen (all NaN)",
                    p.as_slice()
                );
                return Err(errors::array_error(py, text));
            }
        }
        rows.push(seen);
    }
    Ok(rows)
}

/// The settings of a calibration: `config` (a YAML file, or a dict) with `overrides` on top.
fn calib_config(
    py: Python<'_>,
    config: Option<&Bound<'_, PyAny>>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<CalibConfig> {
    let to_value = |obj: &Bound<'_, PyAny>| -> PyResult<serde_yaml::Value> {
        // numpy scalars and arrays (np.int64(5), np.float32(1.5)) as the Python values they hold.
        let kwargs = PyDict::new(py);
        kwargs.set_item("default", py.import("operator")?.call_method1("methodcaller", ("tolist",))?)?;
        let json: String = py
            .import("json")?
            .call_method("dumps", (obj,), Some(&kwargs))
            .map_err(|e| {
                let reason = e.value(py).to_string();
                ConfigError::new_err(format!("settings are numbers, strings, lists or dicts of them: {reason}"))
            })?
            .extract()?;
        serde_json::from_str(&json).map_err(|e| ConfigError::new_err(e.to_string()))
    };
    let mut value = match config {
        None => serde_yaml::Value::Mapping(Default::default()),
        Some(c) if c.is_instance_of::<PyDict>() => to_value(c)?,
        Some(c) => {
            let path: PathBuf = c.extract()?;
            let text =
                std::fs::read_to_string(&path).map_err(|e| FileError::new_err(format!("{}: {e}", path.display())))?;
            serde_yaml::from_str(&text).map_err(|e| FileError::new_err(format!("{}: {e}", path.display())))?
        }
    };
    if let (Some(o), serde_yaml::Value::Mapping(map)) = (overrides, &mut value)
        && let serde_yaml::Value::Mapping(extra) = to_value(o.as_any())?
    {
        map.extend(extra);
    }
    let config: CalibConfig = serde_yaml::from_value(value).map_err(|e| ConfigError::new_err(e.to_string()))?;
    config.check().map_err(|(key, reason)| ConfigError::new_err(format!("`{key}`: {reason}")))?;
    Ok(config)
}

/// How long to wait for a background job between checks for Ctrl-C.
const POLL: std::time::Duration = std::time::Duration::from_millis(50);

/// Run `job` on its own thread with the GIL released, checking for signals (Ctrl-C raises
/// `KeyboardInterrupt` at once; the abandoned job finishes on its own).
fn interruptible<T: Send + 'static>(py: Python<'_>, job: impl FnOnce() -> T + Send + 'static) -> PyResult<T> {
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = send.send(job());
    });
    let mut receive = Some(receive);
    loop {
        // The receiver goes with the released thread and comes back (it is not `Sync`).
        let (back, received) = py.detach(move || {
            let r = receive.take().expect("returned each round");
            let received = r.recv_timeout(POLL);
            (r, received)
        });
        receive = Some(back);
        match received {
            Ok(value) => return Ok(value),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => py.check_signals()?,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(SpmcalError::new_err("the calculation ended without a result (it panicked)"));
            }
        }
    }
}

/// The robot model of a session (or `model`).
/// The robot model of a session, or `model` (a URDF's path or a `Model`) when given.
fn robot_of(session: &spmcal::dataset::Session, model: Option<&Bound<'_, PyAny>>) -> PyResult<Arc<RobotModel>> {
    match robot_opt(model, "model")? {
        Some(robot) => Ok(robot),
        None => Ok(Arc::new(RobotModel::load(&session.model).map_err(raise!(ModelError))?)),
    }
}

/// Calibrate `session` (with the model it names, or `model`: a URDF's path or a `Model`, whose
/// URDF's nominal model the fit starts from, as `--model`): `config` a YAML file or a dict of
/// `calibrate`'s settings, `overrides` settings on top (e.g. `fit="orientations"`). The fit runs
/// with the GIL released; Ctrl-C interrupts it.
#[pyfunction]
#[pyo3(signature = (session, model=None, config=None, **overrides))]
fn calibrate(
    py: Python<'_>,
    session: &Session,
    model: Option<&Bound<'_, PyAny>>,
    config: Option<&Bound<'_, PyAny>>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<Calibration> {
    let config = calib_config(py, config, overrides)?;
    let robot = robot_of(&session.inner, model)?;
    let (s, r) = (session.inner.clone(), robot.clone());
    let result = interruptible(py, move || spmcal::calib::calibrate(&s, &r, &config, &mut |_| {}))?;
    let calibration = result
        .map_err(|e| CalibrationError::new_err(format!("calibrating {}: {}", session.inner.name, message(&e))))?;
    Ok(Calibration { inner: calibration, session: session.inner.clone(), robot })
}

/// A calibration: the calibrated parameters, the report, the covariance.
#[pyclass(module = "spmcal._spmcal", frozen)]
struct Calibration {
    inner: spmcal::calib::Calibration,
    session: Arc<spmcal::dataset::Session>,
    robot: Arc<RobotModel>,
}

#[pymethods]
impl Calibration {
    /// The report, as `spmcal calibrate --json` gives it (`results`).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.report)
    }

    /// The calibrated parameters file's content as a dict.
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        yaml_to_python(py, &self.inner.parameters.to_yaml())
    }

    /// The calibrated model.
    #[getter]
    fn model(&self) -> PyResult<Model> {
        let p = &self.inner.parameters;
        let spm = p.spm().map_err(raise!(ModelError))?;
        Ok(Model {
            spm,
            robot: Some(self.robot.clone()),
            params: p.clone(),
            source: format!("calibration of {}", self.session.name),
        })
    }

    /// The verdict's word as the report prints it: `PASS` (the calibrated mechanism predicts
    /// unseen poses clearly better than the nominal one, the model check finds its residuals what
    /// the noise model says, and its predicted error meets `required_accuracy_deg` when set),
    /// `WARN` or `FAIL` (read `verdict_reasons`).
    #[getter]
    fn verdict(&self) -> &'static str {
        self.inner.report.verdict.label()
    }

    /// The verdict's sentence (what the cross-validation says of the calibrated model against
    /// the nominal one), as the report prints it after the word.
    #[getter]
    fn verdict_reason(&self) -> String {
        self.inner.report.verdict.summary.clone()
    }

    /// Why the verdict is not a pass: a list of `{"level", "finding", "action"}` (empty for a pass).
    #[getter]
    fn verdict_reasons<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.report.verdict.reasons)
    }

    /// The model check (the report's `model_check`): `passed`, `statistic`, `p_value`, every test,
    /// and for a failed check its `cause`, `finding` and `action`; `None` when there was nothing
    /// to test.
    #[getter]
    fn model_check<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.report.model_check)
    }

    /// The verdict is `PASS`.
    #[getter]
    fn passed(&self) -> bool {
        self.inner.report.verdict.pass
    }

    /// The identifiability analysis of the fitted parameters (the report's `identifiability`).
    #[getter]
    fn identifiability<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.report.identifiability)
    }

    /// The fitted parameter vector's names (as in the covariance).
    #[getter]
    fn parameter_names(&self) -> Vec<String> {
        self.inner.parameterisation.entries.iter().map(|e| e.name.clone()).collect()
    }

    /// The parameter vector's covariance `(p, p)` (internal units: rad, m, s; zero rows for held
    /// parameters).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let c = &self.inner.covariance;
        Array2::from_shape_fn((c.nrows(), c.ncols()), |(i, j)| c[(i, j)]).into_pyarray(py)
    }

    /// Standard errors of the fitted parameters by name, in the covariance's order and units
    /// (`parameter_units`: rad, m, s, or dimensionless): `sqrt(diag(covariance))` without the held
    /// parameters. In the report's units (degrees, mm, ms): `parameters_table()`.
    #[getter]
    fn std_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = &self.inner.covariance;
        let out = PyDict::new(py);
        for (i, e) in self.inner.parameterisation.entries.iter().enumerate() {
            if c[(i, i)] > 0.0 {
                out.set_item(&e.name, c[(i, i)].sqrt())?;
            }
        }
        Ok(out)
    }

    /// The unit of each entry of the parameter vector, as `parameter_names` orders them: `rad`
    /// (axis tilts, link angles, offsets, rotations), `m` (camera translation, marker positions),
    /// `s` (latency), `s` (also the camera clock's rate, as the drift it makes over the recording:
    /// ppm × 1e-6 × the recording's span), `""` (camera
    /// model terms, dimensionless). The units of `covariance` and
    /// `std_errors`.
    #[getter]
    fn parameter_units(&self) -> Vec<&'static str> {
        self.inner.parameterisation.entries.iter().map(|e| table::internal_unit(e.kind)).collect()
    }

    /// The calibrated parameters as the text report shows them, one row each, as columns (a dict of
    /// equal-length lists; `pandas.DataFrame(calibration.parameters_table())`): `name`, `value`,
    /// `change` (from the nominal model, the starting registration, the model's marker position,
    /// a perfect camera), `std_error` (NaN when not fitted), `unit` (`deg`, `mm`, `ms`, or `""`)
    /// and `status` (`fitted`, `frozen`, `at bound`, or why a camera term is held). Angles first,
    /// in the report's order, then the camera translation, latency and model, then the markers.
    fn parameters_table<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        table::columns(py, &table::rows(&self.inner))
    }

    /// The predicted RMS orientation error on unseen poses of the session's workspace (degrees):
    /// the report's `predicted_error_deg.rms`.
    #[getter]
    fn predicted_error_deg(&self) -> Option<f64> {
        self.inner.report.predicted_error_deg.as_ref().map(|e| e.rms)
    }

    /// Each pose's error against the camera before (nominal) and after (calibrated), as `compare`
    /// measures them: `{"poses", "nominal", "calibrated", "unit"}` (arrays over the poses both
    /// sets predict).
    fn errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let nominal = Parameters::nominal(&self.robot.spm, None);
        let sets = vec![("nominal".to_string(), nominal), ("calibrated".to_string(), self.inner.parameters.clone())];
        let compared = spmcal::compare::compare(&self.session, &self.robot, &sets, Method::Kabsch, None)
            .map_err(raise!(CompareError))?;
        let after: std::collections::HashMap<u64, f64> = compared[1].per_pose.iter().copied().collect();
        let (mut ids, mut before_v, mut after_v) = (Vec::new(), Vec::new(), Vec::new());
        for (id, e) in &compared[0].per_pose {
            if let Some(a) = after.get(id) {
                ids.push(*id);
                before_v.push(*e);
                after_v.push(*a);
            }
        }
        let out = PyDict::new(py);
        out.set_item("poses", ids.into_pyarray(py))?;
        out.set_item("nominal", before_v.into_pyarray(py))?;
        out.set_item("calibrated", after_v.into_pyarray(py))?;
        out.set_item("unit", compared[0].unit)?;
        Ok(out)
    }

    /// The camera rig refined with the mechanism (a session seen through its pixels), as the
    /// report gives it (`to_dict()["markers"]["rig"]`): `baseline_held_m`, `terms` (each with
    /// `name`, `unit`, `file_value`, `change`, `std_error`, `held`) and `pixel_noise_px`; `None`
    /// for a session of points.
    #[getter]
    fn rig<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.rig_report().map(|r| to_python(py, r)).transpose()
    }

    /// Write the refined rig as a Kalibr camchain (atomically), as `spmcal calibrate
    /// --cameras-out` does; a session of points has no rig to write (`CalibrationError`).
    fn write_cameras(&self, path: PathBuf) -> PyResult<()> {
        let Some(rig) = self.rig_report() else {
            return Err(CalibrationError::new_err(format!(
                "{}: a session of points, not pixels (pixels.csv + cameras.yaml): it has no camera rig to write",
                self.session.name
            )));
        };
        let mut file = spmcal::io::StagedFile::create(&path).map_err(raise!(FileError))?;
        file.write(rig.refined.to_camchain().as_bytes()).map_err(raise!(FileError))?;
        file.commit().map_err(raise!(FileError))
    }

    /// Write the calibrated parameters file (atomically), as `spmcal calibrate --out` does.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.inner.parameters.write(&path).map_err(raise!(FileError))
    }

    /// The text report, as `spmcal calibrate` prints it (without its `wrote` line).
    fn __str__(&self) -> String {
        self.inner.report.to_string()
    }

    fn __repr__(&self) -> String {
        let predicted = self.predicted_error_deg().map_or("none".to_string(), |e| format!("{e:.4} deg"));
        format!("Calibration({}: {}, predicted error {predicted})", self.session.name, self.verdict())
    }
}

impl Calibration {
    /// The report's refined rig, for a session seen through its pixels.
    fn rig_report(&self) -> Option<&spmcal::calib::RigReport> {
        self.inner.report.markers.as_ref().and_then(|m| m.rig.as_ref())
    }
}

/// Compare parameter sets against the camera on `session`: `params` parameters files or `Model`s
/// (one or a list; the nominal model is always first), `model` the mechanism (a URDF's path or a
/// `Model`; default the session's). One dict per set, as `spmcal compare --json` gives them.
#[pyfunction]
#[pyo3(signature = (session, params=None, model=None))]
fn compare<'py>(
    py: Python<'py>,
    session: &Session,
    params: Option<&Bound<'py, PyAny>>,
    model: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let robot = robot_of(&session.inner, model)?;
    let mut sets = vec![("nominal".to_string(), Parameters::nominal(&robot.spm, None))];
    for (k, set) in params.map(params_list).transpose()?.unwrap_or_default().iter().enumerate() {
        let p = params_arg(set, &format!("params[{k}]"))?;
        sets.push((p.label, p.params));
    }
    let compared = py
        .detach(|| spmcal::compare::compare(&session.inner, &robot, &sets, Method::Kabsch, None))
        .map_err(raise!(CompareError))?;
    to_python(py, &compared)
}

/// `params` as a list: one parameters argument (a path or a `Model`), or an iterable of them.
fn params_list<'py>(params: &Bound<'py, PyAny>) -> PyResult<Vec<Bound<'py, PyAny>>> {
    if model_arg(params, "params").is_ok() {
        return Ok(vec![params.clone()]);
    }
    let Ok(items) = params.try_iter() else {
        let given = params.get_type().name().map_or_else(|_| "object".to_string(), |n| n.to_string());
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "params: expected a spmcal.Model, the path of a parameters file, or a list of them, got {given}"
        )));
    };
    items.collect()
}

/// Simulate a session with ground truth from the settings file `config` (`seed`, `poses`
/// override it); written to `out` when given.
#[pyfunction]
#[pyo3(signature = (config, out=None, seed=None, poses=None))]
fn simulate(
    py: Python<'_>,
    config: PathBuf,
    out: Option<PathBuf>,
    seed: Option<u64>,
    poses: Option<usize>,
) -> PyResult<Session> {
    let mut c = spmcal::sim::SimConfig::read(&config).map_err(raise!(FileError))?;
    c.seed = seed.unwrap_or(c.seed);
    c.poses = poses.unwrap_or(c.poses);
    c.check().map_err(|(key, reason)| ConfigError::new_err(format!("{}: `{key}`: {reason}", config.display())))?;
    let robot = RobotModel::load(&c.model).map_err(raise!(ModelError))?;
    let (session, _) = interruptible(py, move || c.simulate(&robot, &mut |_| {}))?.map_err(raise!(SimulationError))?;
    if let Some(dir) = out {
        session.write(&dir).map_err(raise!(FileError))?;
    }
    Ok(Session { inner: Arc::new(session) })
}

/// What `export` wrote: the calibrated URDF, its companion beside it, and what the user should
/// be told.
#[pyclass(module = "spmcal._spmcal", frozen, get_all)]
struct Exported {
    /// The calibrated URDF written (`pathlib.Path`).
    urdf: PathBuf,
    /// Its companion (`NAME.yaml` beside `NAME.urdf`): markers, camera model, provenance.
    companion: PathBuf,
    /// What the caller should tell the user (e.g. the parameters' `model:` names another URDF
    /// whose legs and markers agree); each is also a comment in both files.
    warnings: Vec<String>,
}

#[pymethods]
impl Exported {
    fn __repr__(&self) -> String {
        format!("Exported(urdf={:?}, companion={:?}, {} warnings)", self.urdf, self.companion, self.warnings.len())
    }
}

/// Write the calibrated URDF of `params` (a parameters file or a `Model`) at `urdf`, its companion
/// beside it, copied from `model` (a URDF's path or a `Model`; default: the `Model`'s URDF, else
/// the parameters file's `model:`). Returns what it wrote (`Exported`).
#[pyfunction]
#[pyo3(signature = (params, urdf, model=None))]
fn export(params: &Bound<'_, PyAny>, urdf: PathBuf, model: Option<&Bound<'_, PyAny>>) -> PyResult<Exported> {
    let given = params_arg(params, "params")?;
    let robot = match (robot_opt(model, "model")?, given.robot.clone()) {
        (Some(r), _) | (None, Some(r)) => r,
        (None, None) => {
            let (robot, _) = given.params.load_model(Path::new(&given.label), None).map_err(raise!(ModelError))?;
            Arc::new(robot)
        }
    };
    let companion = RobotModel::companion_path(&urdf);
    let inputs = [robot.urdf_path.clone(), RobotModel::companion_path(&robot.urdf_path), PathBuf::from(&given.label)];
    if let Some(out) = [&urdf, &companion].into_iter().find(|out| inputs.iter().any(|i| same_file(i, out))) {
        return Err(FileError::new_err(format!(
            "{}: is an input of this call: refusing to overwrite it",
            out.display()
        )));
    }
    let provenance = [format!("Calibrated model exported by spmcal (Python) from {}", given.label)];
    let exported = spmcal::model::export(&robot, &given.params, &provenance).map_err(raise!(ModelError))?;
    exported.write(&urdf).map_err(raise!(FileError))?;
    Ok(Exported { urdf, companion, warnings: exported.warnings })
}

/// Why joint readings are refused as degrees: one is beyond a full turn (as `joints.csv` refuses
/// it; the FDA would otherwise only say "near a singularity").
fn degrees(joints: &Vector3<f64>) -> Option<String> {
    joints.iter().find(|j| j.abs() > std::f64::consts::TAU).map(|j| {
        format!("{j} rad is more than a full turn: the readings look like degrees; spmcal reads joints in radians")
    })
}

/// A Python `UserWarning` (what the command line prints as `warning: …`).
fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    py.import("warnings")?.call_method1("warn", (message,))?;
    Ok(())
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// The model `plan` plans for when given none: the shipped Agile Wrist (compiled in).
const DEFAULT_MODEL: &str = "agile_wrist";

/// Plan `poses` poses for `model` (a URDF's path or a `Model`; default the `params` `Model`'s
/// URDF, else the shipped Agile Wrist), or the parameters `params` (a file or a `Model`), with the simulation settings `config` (workspace, camera, noise),
/// as `spmcal plan` does (`candidates`, `margin_deg`, `camera_model`, `augment` a session the plan
/// adds to): `(summary dict, (poses, 4) quaternions, (poses, 3) joints)` in capture order.
#[pyfunction]
#[pyo3(signature = (
    poses,
    model=None,
    params=None,
    config=None,
    candidates=2000,
    margin_deg=2.0,
    camera_model="depth_scale",
    augment=None,
))]
#[allow(clippy::too_many_arguments)]
fn plan<'py>(
    py: Python<'py>,
    poses: usize,
    model: Option<&Bound<'py, PyAny>>,
    params: Option<&Bound<'py, PyAny>>,
    config: Option<PathBuf>,
    candidates: usize,
    margin_deg: f64,
    camera_model: &str,
    augment: Option<&Session>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let params = params.map(|p| params_arg(p, "params")).transpose()?;
    let robot = match (robot_opt(model, "model")?, params.as_ref().and_then(|p| p.robot.clone())) {
        (Some(r), _) | (None, Some(r)) => r,
        (None, None) => Arc::new(RobotModel::load(Path::new(DEFAULT_MODEL)).map_err(raise!(ModelError))?),
    };
    let params = params.map(|p| p.params);
    let sim = match &config {
        Some(path) => spmcal::sim::SimConfig::read(path).map_err(raise!(FileError))?,
        None => spmcal::sim::SimConfig::default(),
    };
    let camera_model = CameraModelKind::ALL.into_iter().find(|k| k.name() == camera_model).ok_or_else(|| {
        ConfigError::new_err(format!("camera_model: `{camera_model}` is not rigid, depth_scale, affine or projective"))
    })?;
    let settings = spmcal::plan::PlanSettings { poses, candidates, margin_deg, camera_model, ..Default::default() };
    let augment = augment.map(|s| s.inner.clone());
    let planned = interruptible(py, move || {
        spmcal::plan::Plan::design(&robot, params.as_ref(), &sim, &settings, augment.as_deref())
    })?
    .map_err(raise!(PlanError))?;
    let summary = to_python(py, &planned.summary)?;
    let rs: Vec<Rotation3<f64>> = planned.poses.iter().map(|p| p.rotation).collect();
    let js: Vec<Vector3<f64>> = planned.poses.iter().map(|p| p.joints).collect();
    Ok((summary, quaternion_array(py, &rs, false), rows_array(py, &js, false)))
}

/// The marker-level observation model of the fit at the parameter vector `x` (`None`: the start,
/// all zeros), for an independent check (`python/tests/test_reference_model.py`; private: the leading underscore).
///
/// The parameterisation is the fit's (`Parameterisation::for_markers` around `model`'s geometry,
/// the registration `camera_rotation` (`qw, qx, qy, qz`) and `camera_translation`, the markers'
/// positions `marker_positions` `(k, 3)`, `camera_model` with its terms started at
/// `camera_terms`, the first five (or all eight) values in `CameraTerm::ALL`'s order, a perfect
/// camera's by default),
/// with the default bounds. Observation `j` is marker `markers[j]` seen at readings `joints[j]`.
///
/// Returns a dict: `names` (the parameters, in `x`'s order); `predictions` `(m, 3)`, the camera
/// point `K (R_CB R(θ) p_k + t_CB)` made from the parameterisation's public parts at `x` and the
/// library's working-mode FDA (`orientations`, `(m, 3, 3)`); `jacobian` `(m, 3, n)`, the analytic
/// Jacobian of the predictions that the fit uses; `information` `(m, n, n)` and `whitening`
/// `(m, 3, 3)`, what that Jacobian is read from; `actuated_dirs` and `platform_dirs`, the gauge's
/// tilt directions per leg (`(k, 3)` each).
///
/// The fit's Jacobian is not public; `MarkerResiduals::information_per_pose` is, and it is the fit's
/// `Σ (W_j J_j)ᵀ (W_j J_j)` at `x` (`J_j = ∂r_j/∂x` of the residual `r = x_C − x̂`, `W_j` the
/// whitening). With one observation per pose, `M_j = W_j J_j` follows from the translation
/// columns `T`, where `∂r/∂t_CB = −K`: `G[T, :] = M_Tᵀ M`, so `M = M_T⁻ᵀ G[T, :]`. A library whose
/// translation columns were not `−K` would give every other column wrong, so the check still
/// sees it; `information` lets a test compare `G` itself too.
#[pyfunction]
#[pyo3(signature = (model, x, joints, markers, marker_positions, camera_rotation, camera_translation, camera_model="depth_scale", camera_terms=None))]
#[allow(clippy::too_many_arguments)]
fn _marker_model<'py>(
    py: Python<'py>,
    model: &Model,
    x: Option<Vec<f64>>,
    joints: &Bound<'py, PyAny>,
    markers: Vec<usize>,
    marker_positions: &Bound<'py, PyAny>,
    camera_rotation: Vec<f64>,
    camera_translation: Vec<f64>,
    camera_model: &str,
    camera_terms: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    use nalgebra::{DMatrix, DVector, Matrix3};
    use spmcal::calib::{Bounds, Kind, MarkerObservation, MarkerResiduals, Parameterisation, StereoNoise};
    use spmcal::model::{CameraModel, CameraRegistration};

    let (rows, _) = rows3(joints, JOINTS)?;
    let positions_arg = Arg { name: "marker_positions", expected: "a (k, 3) array of positions in P, m" };
    let (positions, _) = rows3(marker_positions, positions_arg)?;
    let kind = CameraModelKind::ALL.into_iter().find(|k| k.name() == camera_model).ok_or_else(|| {
        ConfigError::new_err(format!("camera_model: `{camera_model}` is not rigid, depth_scale, affine or projective"))
    })?;
    // Five values (the affine terms) or eight (with the projective model's three).
    let mut terms = spmcal::model::CameraTerm::ALL.map(|t| t.perfect());
    match camera_terms {
        None => {}
        Some(v) if v.len() == 5 || v.len() == terms.len() => terms[..v.len()].copy_from_slice(&v),
        Some(_) => return Err(FileError::new_err("camera_terms: expected 5 values (8 with the projective terms)")),
    }
    if markers.len() != rows.len() || markers.iter().any(|&k| k >= positions.len()) {
        return Err(FileError::new_err(
            "markers: one index per row of joints, each below the number of marker_positions",
        ));
    }
    let (q, t) = (camera_rotation, camera_translation);
    if q.len() != 4 || t.len() != 3 {
        return Err(FileError::new_err("camera_rotation: 4 values (qw, qx, qy, qz); camera_translation: 3"));
    }
    let registration = CameraRegistration {
        rotation: UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3])).to_rotation_matrix(),
        translation: Vector3::new(t[0], t[1], t[2]),
    };
    let bounds = Bounds::default();
    let names: Vec<String> = (1..=positions.len()).map(|k| format!("m{k}")).collect();
    let p = Parameterisation::for_markers(
        *model.spm.geometry(),
        &registration,
        &positions,
        &names,
        CameraModel::of(kind, terms),
        &bounds,
    );
    let n = p.len();
    let x = match x {
        None => p.start(),
        Some(x) if x.len() == n => DVector::from_vec(x),
        Some(x) => return Err(FileError::new_err(format!("x: expected {n} parameters, got {}", x.len()))),
    };

    // The predictions, from the parameterisation's public parts and the library's FDA.
    let spm = p.spm(&x).map_err(raise!(ModelError))?;
    let (camera, translation, k_matrix) = (p.camera(&x), p.translation(&x), p.camera_model(&x));
    let mut orientations = Vec::with_capacity(rows.len());
    let mut predictions = Vec::with_capacity(rows.len());
    for (j, (theta, &k)) in rows.iter().zip(&markers).enumerate() {
        let r = spm.forward(theta).map_err(|e| row_error(j, &e))?;
        predictions.push(k_matrix.distort(&(camera * (r * p.marker(&x, k)) + translation)));
        orientations.push(*r.matrix());
    }

    // The fit's Jacobian, read from its information (one observation per pose).
    let observations: Vec<MarkerObservation> = rows
        .iter()
        .zip(&markers)
        .zip(&predictions)
        .enumerate()
        .map(|(j, ((theta, &marker), measured))| MarkerObservation {
            pose: j as u64,
            marker,
            joints: *theta,
            measured: *measured,
            camera: None,
            line: 0,
            station: None,
            time_s: None,
            rotation: false,
        })
        .collect();
    let noise = StereoNoise::points(1.0, 1.0, 1.0);
    let fitted = MarkerResiduals::new(&p, &observations);
    let information = fitted.information_per_pose(&x, &noise).map_err(raise!(CalibrationError))?;
    let columns: Vec<usize> = (0..3)
        .map(|k| p.entries.iter().position(|e| e.kind == Kind::Translation { k }).expect("the marker level has t_CB"))
        .collect();
    let k_now = k_matrix.matrix();
    let mut jacobian = Array3::<f64>::zeros((rows.len(), 3, n));
    let mut info_out = Array3::<f64>::zeros((rows.len(), n, n));
    let mut whitening_out = Array3::<f64>::zeros((rows.len(), 3, 3));
    for (j, (_, g)) in information.iter().enumerate() {
        let w = fitted.whitening_of(j, &noise);
        let m_t: Matrix3<f64> = -(w * k_now);
        let g_t = DMatrix::from_fn(3, n, |a, c| g[(columns[a], c)]);
        let inverse = m_t.transpose().try_inverse().ok_or_else(|| CalibrationError::new_err("a singular K"))?;
        let w_inverse = w.try_inverse().ok_or_else(|| CalibrationError::new_err("a singular whitening"))?;
        // x̂ = x_C − r, so the predictions' Jacobian is −∂r/∂x.
        let d = -(w_inverse * inverse) * g_t;
        for a in 0..3 {
            for c in 0..n {
                jacobian[[j, a, c]] = d[(a, c)];
            }
            for b in 0..3 {
                whitening_out[[j, a, b]] = w[(a, b)];
            }
        }
        for a in 0..n {
            for c in 0..n {
                info_out[[j, a, c]] = g[(a, c)];
            }
        }
    }

    let out = PyDict::new(py);
    out.set_item("names", p.entries.iter().map(|e| e.name.clone()).collect::<Vec<_>>())?;
    out.set_item("predictions", rows_array(py, &predictions, false))?;
    out.set_item("orientations", matrix_array(py, &orientations, false))?;
    out.set_item("jacobian", jacobian.into_pyarray(py))?;
    out.set_item("information", info_out.into_pyarray(py))?;
    out.set_item("whitening", whitening_out.into_pyarray(py))?;
    let dirs = |d: &[Vec<Vector3<f64>>; 3]| -> Vec<Bound<'py, PyAny>> {
        d.iter()
            .map(|v| {
                if v.is_empty() {
                    Array2::<f64>::zeros((0, 3)).into_pyarray(py).into_any()
                } else {
                    rows_array(py, v, false)
                }
            })
            .collect()
    };
    out.set_item("actuated_dirs", dirs(&p.actuated_dirs))?;
    out.set_item("platform_dirs", dirs(&p.platform_dirs))?;
    Ok(out)
}

/// The module.
#[pymodule]
fn _spmcal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Model>()?;
    m.add_class::<Session>()?;
    m.add_class::<Calibration>()?;
    m.add_class::<Exported>()?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(export, m)?)?;
    m.add_function(wrap_pyfunction!(plan, m)?)?;
    m.add_function(wrap_pyfunction!(_marker_model, m)?)?;
    errors::add_to(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
