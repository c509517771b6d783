//! FDA against vision: per pose, the angle between the orientation the model predicts from the
//! joints and the one the camera measured, for one or more parameter sets.
//!
//! A parameter set without a camera registration (the nominal model) gets the best-fit
//! registration alone, so that a camera misalignment is not blamed on the mechanism. With a
//! registration (a calibrated file) only the reference rotation `A` is fitted: it belongs to the
//! session (where its reference pose was), not to the device.

use serde::Serialize;

use crate::calib::pose_errors;
use crate::dataset::Session;
use crate::model::Parameters;
use crate::vision::{Method, VisionError, estimate_session};

/// The comparison of one parameter set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SetComparison {
    /// Name of the parameter set (`nominal`, `calibrated`, a file name).
    pub label: String,
    /// How the camera registration was obtained.
    pub registration: &'static str,
    /// `(pose, angle in degrees)`.
    pub per_pose: Vec<(u64, f64)>,
    /// RMS angle, degrees.
    pub rms_deg: f64,
    /// Median angle, degrees.
    pub median_deg: f64,
    /// Largest angle, degrees.
    pub max_deg: f64,
    /// Poses whose forward kinematics failed with this set, and why.
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
        reason: String,
    },
}

/// Compare each `(label, parameters)` set with the camera on `session`.
///
/// # Errors
/// A [`CompareError`] when the vision estimate fails or a parameter set cannot be registered or predicts no pose.
pub fn compare(
    session: &Session,
    sets: &[(String, Parameters)],
    method: Method,
) -> Result<Vec<SetComparison>, CompareError> {
    let vision = estimate_session(session, method)?;
    sets.iter().map(|(label, params)| compare_one(session, &vision, label, params)).collect()
}

fn compare_one(
    session: &Session,
    vision: &crate::vision::SessionEstimate,
    label: &str,
    params: &Parameters,
) -> Result<SetComparison, CompareError> {
    let e = pose_errors(session, vision, params)
        .map_err(|reason| CompareError::Set { label: label.to_string(), reason })?;
    Ok(SetComparison {
        label: label.to_string(),
        registration: e.registration,
        rms_deg: e.summary.rms_deg,
        median_deg: e.summary.median_deg,
        max_deg: e.summary.max_deg,
        per_pose: e.per_pose,
        excluded: e.excluded,
    })
}
