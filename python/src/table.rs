//! The calibrated parameters as a table in the report's units: what the text report shows in its
//! parameter table (degrees), its camera lines (translation in mm, latency in ms, the camera
//! model's dimensionless terms) and its marker table (mm), one row per parameter, so that a
//! DataFrame of it reads as the report does. Every figure is the report's own; only the values of
//! the link angles and offsets come from the calibrated parameters file (the report shows their
//! changes).

use pyo3::prelude::*;
use pyo3::types::PyDict;
use spmcal::calib::{Calibration, CalibrationReport, Kind, MarkerFitReport};
use spmcal::model::{CameraTerm, RigTerm};

/// One parameter as the report shows it.
pub(crate) struct Row {
    name: String,
    value: f64,
    change: f64,
    std_error: Option<f64>,
    unit: &'static str,
    status: String,
}

/// The unit of a parameter vector entry (the covariance's). Every kind by name, so that a new
/// kind is a compile error here rather than a silent `rad`.
pub(crate) fn internal_unit(kind: Kind) -> &'static str {
    match kind {
        Kind::ActuatedTilt { .. }
        | Kind::Alpha1 { .. }
        | Kind::Alpha2 { .. }
        | Kind::Offset { .. }
        | Kind::PlatformTilt { .. }
        | Kind::Camera { .. }
        | Kind::Reference { .. }
        | Kind::PlatformSag => "rad",
        Kind::Translation { .. } | Kind::Marker { .. } => "m",
        Kind::Latency => "s",
        Kind::ClockRate => "s",
        Kind::CameraTerm { .. } | Kind::Scale { .. } => "",
        Kind::Rig { term } => match term {
            RigTerm::Intrinsic { .. } => "px",
            RigTerm::Distortion { .. } => "",
            RigTerm::Rotation { .. } => "rad",
            RigTerm::Translation { .. } => "m",
        },
    }
}

/// Every row, in the text report's order.
pub(crate) fn rows(c: &Calibration) -> Vec<Row> {
    let r = &c.report;
    let mut out = angles(c);
    out.extend(joint_scales(c));
    out.extend(translation(c));
    if let Some(m) = &r.markers {
        out.extend(latency(m));
        out.extend(clock_rate(m));
        out.extend(camera_terms(m));
        out.extend(markers(m));
    }
    out
}

/// `fitted`, `frozen` or `at bound`, from a standard error and the bound flag.
fn status(std_error: Option<f64>, at_bound: bool) -> String {
    match (std_error, at_bound) {
        (_, true) => "at bound",
        (Some(_), false) => "fitted",
        (None, false) => "frozen",
    }
    .to_string()
}

/// The report's angle table (degrees): a link angle's or an offset's value is the calibrated
/// one; an axis tilt or a rotation component is itself a departure, its value its change.
fn angles(c: &Calibration) -> Vec<Row> {
    let legs = &c.parameters.legs;
    let kind_of = |name: &str| c.parameterisation.entries.iter().find(|e| e.name == name).map(|e| e.kind);
    c.report
        .parameters
        .iter()
        .map(|p| {
            let value = match kind_of(&p.name) {
                Some(Kind::Alpha1 { leg }) => legs[leg].alpha1.to_degrees(),
                Some(Kind::Alpha2 { leg }) => legs[leg].alpha2.to_degrees(),
                Some(Kind::Offset { leg }) => legs[leg].delta.to_degrees(),
                Some(Kind::PlatformSag) => c.parameters.platform_sag_deg,
                _ => p.change_deg,
            };
            let held = kind_of(&p.name) == Some(Kind::PlatformSag) && c.report.platform_sag_held.is_some();
            Row {
                name: p.name.clone(),
                value,
                change: p.change_deg,
                std_error: p.std_error_deg,
                // The sag's degrees are per unit of the gravity torque's arm.
                unit: if kind_of(&p.name) == Some(Kind::PlatformSag) { "deg per unit of arm" } else { "deg" },
                status: if held { "held".to_string() } else { status(p.std_error_deg, p.at_bound) },
            }
        })
        .collect()
}

/// The joints' scales (ppm: the value is the scale itself, its change and standard error in ppm).
fn joint_scales(c: &Calibration) -> Vec<Row> {
    c.report
        .joint_scales
        .iter()
        .map(|s| Row {
            name: format!("leg{}.scale", s.leg),
            value: s.scale,
            change: s.change_ppm,
            std_error: s.std_error_ppm,
            unit: "ppm",
            status: match &s.held {
                None => "fitted".to_string(),
                Some(why) if why.starts_with("frozen") => "frozen".to_string(),
                Some(why) if why.starts_with("at its bound") => "at bound".to_string(),
                Some(_) => "held".to_string(),
            },
        })
        .collect()
}

/// The camera translation `t_CB` (mm; the report prints it in m with its standard error in mm),
/// its change from the starting registration.
fn translation(c: &Calibration) -> Vec<Row> {
    let r: &CalibrationReport = &c.report;
    let Some(t) = r.camera_translation_m else { return Vec::new() };
    let start = c.parameterisation.translation0;
    ["x", "y", "z"]
        .iter()
        .enumerate()
        .map(|(k, axis)| {
            let std_error = r.camera_translation_std_error_m.map(|s| s[k] * 1e3);
            Row {
                name: format!("camera.t_{axis}"),
                value: t[k] * 1e3,
                change: (t[k] - start[k]) * 1e3,
                std_error,
                unit: "mm",
                status: status(std_error, false),
            }
        })
        .collect()
}

/// The camera's latency (ms; none is its nominal value, so its change is itself).
fn latency(m: &MarkerFitReport) -> Option<Row> {
    let l = m.latency.as_ref()?;
    let std_error = l.std_error_s.map(|s| s * 1e3);
    Some(Row {
        name: "camera.latency".into(),
        value: l.value_s * 1e3,
        change: l.value_s * 1e3,
        std_error,
        unit: "ms",
        status: status(std_error, l.at_bound),
    })
}

/// The camera clock's rate difference (ppm; none is its nominal value, so its change is itself).
fn clock_rate(m: &MarkerFitReport) -> Option<Row> {
    let c = m.clock_rate_ppm.as_ref()?;
    Some(Row {
        name: "camera.clock_rate".into(),
        value: c.value,
        change: c.value,
        std_error: c.std_error,
        unit: "ppm",
        status: status(c.std_error, c.at_bound),
    })
}

/// The camera model's terms (dimensionless), their change from a perfect camera's.
fn camera_terms(m: &MarkerFitReport) -> Vec<Row> {
    m.camera_model
        .terms
        .iter()
        .map(|t| {
            let perfect = CameraTerm::ALL.iter().find(|c| c.name() == t.name).map_or(0.0, |c| c.perfect());
            Row {
                name: format!("camera.{}", t.name),
                value: t.value,
                change: t.value - perfect,
                std_error: t.std_error,
                unit: "",
                status: t.held.map_or_else(|| "fitted".to_string(), |why| why.replace('_', " ")),
            }
        })
        .collect()
}

/// The markers' positions in P (mm; the report prints them in m, their changes from the model's
/// and standard errors in mm).
fn markers(m: &MarkerFitReport) -> Vec<Row> {
    let mut out = Vec::with_capacity(3 * m.markers.len());
    for k in &m.markers {
        for (i, axis) in ["x", "y", "z"].iter().enumerate() {
            let std_error = k.std_error_mm.map(|s| s[i]);
            out.push(Row {
                name: format!("{}.{axis}", k.name),
                value: k.fitted_m[i] * 1e3,
                change: k.change_mm[i],
                std_error,
                unit: "mm",
                status: status(std_error, false),
            });
        }
    }
    out
}

/// The rows as columns: a dict of equal-length lists, what `pandas.DataFrame` takes (a missing
/// standard error is NaN, so the column stays numeric).
pub(crate) fn columns<'py>(py: Python<'py>, rows: &[Row]) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item("name", rows.iter().map(|r| r.name.as_str()).collect::<Vec<_>>())?;
    out.set_item("value", rows.iter().map(|r| r.value).collect::<Vec<_>>())?;
    out.set_item("change", rows.iter().map(|r| r.change).collect::<Vec<_>>())?;
    out.set_item("std_error", rows.iter().map(|r| r.std_error.unwrap_or(f64::NAN)).collect::<Vec<_>>())?;
    out.set_item("unit", rows.iter().map(|r| r.unit).collect::<Vec<_>>())?;
    out.set_item("status", rows.iter().map(|r| r.status.as_str()).collect::<Vec<_>>())?;
    Ok(out)
}
