//! Model against camera, per pose, for one or more parameter sets: at the orientation level (the
//! angle between the orientation the model predicts from the joints and the one the per-pose
//! estimator measured, degrees) or at the marker level (the distance between predicted and
//! measured markers, millimetres) — the only one possible when no pose sees three markers, as in
//! a free-motion recording with one marker per camera frame.
//!
//! Registrations: a parameter set without one (the nominal model) gets its best fit to the
//! session; a calibrated file's own is used as it is (see `calib::agreement`).

use serde::Serialize;

use crate::calib::{FitLevel, SetError, corrected_for, marker_pose_errors, pose_errors};
use crate::dataset::Session;
use crate::math::stats::Stats;
use crate::model::{Parameters, RobotModel};
use crate::vision::{MarkerError, Method, SessionEstimate, VisionError};

/// The unit of the per-pose errors at `level`.
fn unit(level: FitLevel) -> &'static str {
    match level {
        FitLevel::Orientations => "deg",
        FitLevel::Markers => "mm",
    }
}

/// The comparison of one parameter set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SetComparison {
    /// Name of the parameter set (`nominal`, `calibrated`, a file name).
    pub label: String,
    /// What was compared: orientations (per pose, from the per-pose estimator) or markers.
    pub level: FitLevel,
    /// Unit of the errors: `deg` (orientations), `mm` (markers, RMS over a pose's markers) or `px`
    /// (a pixel session's markers: the reprojection error, RMS over a pose's pixels).
    pub unit: &'static str,
    /// How the camera registration was obtained.
    pub registration: &'static str,
    /// `(pose, error)`.
    pub per_pose: Vec<(u64, f64)>,
    /// Their statistics.
    #[serde(flatten)]
    pub errors: Stats,
    /// Poses left out with this set, and why.
    pub excluded: Vec<String>,
}

/// Why a comparison could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CompareError {
    #[error("vision: {0}")]
    /// The vision estimate failed.
    Vision(#[from] VisionError),
    #[error("{label}: {reason}")]
    /// One parameter set cannot be compared.
    Set {
        /// Its label.
        label: String,
        /// Why.
        reason: SetError,
    },
}

/// Compare each `(label, parameters)` set with the camera on `session`, at `level`; `None`:
/// orientations where the per-pose estimator can work, markers where no pose sees three. Each set
/// sees the markers corrected by its own camera model (`camera_model`). A session seen through
/// its cameras' pixels is also compared at its marker level, in pixels through its rig (after the
/// orientations, for each set).
///
/// # Errors
/// A [`CompareError`] when the vision estimate fails or a parameter set cannot be registered or predicts no pose.
pub fn compare(
    session: &Session,
    model: &RobotModel,
    sets: &[(String, Parameters)],
    method: Method,
    level: Option<FitLevel>,
) -> Result<Vec<SetComparison>, CompareError> {
    let vision = match level {
        Some(FitLevel::Markers) => None,
        Some(FitLevel::Orientations) => Some(SessionEstimate::of(session, method)?),
        None => match SessionEstimate::of(session, method) {
            Ok(v) => Some(v),
            Err(VisionError { reason: MarkerError::NoPoseWithThree { .. }, .. }) => None,
            Err(e) => return Err(e.into()),
        },
    };
    // A session seen through its cameras' pixels is compared in pixels too (its marker level):
    // the reprojection error through its rig, beside the orientations of the points it triangulates.
    let pixels = session.rig.is_some();
    let mut out = Vec::new();
    for (label, params) in sets {
        let set_error = |reason| CompareError::Set { label: label.clone(), reason };
        // Each set sees the markers as its own camera model corrects them.
        let corrected = corrected_for(session, vision.as_ref(), method, params).map_err(set_error)?;
        let (seen, vision) = match &corrected {
            Some((s, v)) => (s, v.as_ref()),
            None => (session, vision.as_ref()),
        };
        if let Some(v) = vision {
            out.push(SetComparison::new(
                label,
                FitLevel::Orientations,
                pose_errors(seen, v, params).map_err(set_error)?,
                false,
            ));
        }
        if vision.is_none() || pixels {
            let errors = marker_pose_errors(seen, model, params).map_err(set_error)?.0;
            out.push(SetComparison::new(label, FitLevel::Markers, errors, pixels));
        }
    }
    Ok(out)
}

impl SetComparison {
    fn new(label: &str, level: FitLevel, errors: crate::calib::PoseErrors, pixels: bool) -> Self {
        let crate::calib::PoseErrors { registration, per_pose, excluded, .. } = errors;
        let values: Vec<f64> = per_pose.iter().map(|(_, e)| *e).collect();
        SetComparison {
            label: label.to_string(),
            level,
            unit: if pixels { "px" } else { unit(level) },
            registration,
            per_pose,
            errors: Stats::of_or_zero(&values),
            excluded,
        }
    }
}

impl std::fmt::Display for SetComparison {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let unit = match self.unit {
            "deg" => "°",
            "px" => " px",
            _ => " mm",
        };
        writeln!(
            f,
            "{:<11} RMS {:.4}{unit}, median {:.4}{unit}, max {:.4}{unit} over {} poses (registration: {})",
            self.label,
            self.errors.rms,
            self.errors.median,
            self.errors.max,
            self.per_pose.len(),
            self.registration
        )
    }
}
