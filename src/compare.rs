//! FDA against vision: per pose, the angle between the orientation the model predicts from the
//! joints and the one the camera measured, for one or more parameter sets.
//!
//! A parameter set without a camera registration (the nominal model) gets the best-fit
//! registration alone, so that a camera misalignment is not blamed on the mechanism. With a
//! registration (a calibrated file) only the reference rotation `A` is fitted: it belongs to the
//! session (where its reference pose was), not to the device.

use nalgebra::{DVector, Rotation3};
use serde::Serialize;

use crate::calib::{
    CalibConfig, ErrorSummary, FitError, FitSettings, Group, Loss, Observation, Parameterisation, fit,
    initial_registration, observations,
};
use crate::dataset::Session;
use crate::model::{LegGeometry, Parameters, Spm};
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
    let fail = |reason: String| CompareError::Set { label: label.to_string(), reason };
    let spm = Spm::new(params.legs).map_err(|e| fail(e.to_string()))?;
    let (kept, failed) = observations(session, vision, &spm);
    let excluded: Vec<String> = failed.iter().map(|(pose, e)| format!("pose {pose}: {e}")).collect();
    let (observations, predicted): (Vec<Observation>, Vec<Rotation3<f64>>) = kept.into_iter().unzip();
    if observations.len() < 3 {
        return Err(fail(format!(
            "only {} poses have both a vision estimate and a forward kinematics solution",
            observations.len()
        )));
    }
    let reference = observations.iter().position(|o| o.pose == vision.reference_pose).unwrap_or(0);
    let (camera0, reference0, registration, groups): (_, _, _, &[Group]) = match params.camera {
        Some(c) => (
            c.rotation,
            c.rotation * predicted[reference],
            "from the parameters file (reference rotation fitted)",
            &[Group::ReferenceRotation],
        ),
        None => {
            let (c, a) = initial_registration(&observations, &predicted, vision.reference_pose)
                .ok_or_else(|| fail("every pose rotates about one axis: no registration".into()))?;
            (c, a, "best fit to this session", &[Group::CameraRotation, Group::ReferenceRotation])
        }
    };
    let legs: [LegGeometry; 3] = *spm.geometry();
    let defaults = CalibConfig::default();
    let p = Parameterisation::new(legs, camera0, reference0, &defaults.bounds);
    let free = p.entries.iter().map(|e| groups.contains(&e.kind.group())).collect();
    let settings = FitSettings { loss: Loss::LeastSquares, ..FitSettings::from_config(&defaults, free) };
    let outcome = fit(&p, &DVector::zeros(p.len()), &observations, &settings, &mut |_| {})
        .map_err(|e: FitError| fail(e.to_string()))?;
    let summary = ErrorSummary::of(&outcome.evaluation.residuals);
    Ok(SetComparison {
        label: label.to_string(),
        registration,
        per_pose: observations
            .iter()
            .zip(&outcome.evaluation.residuals)
            .map(|(o, r)| (o.pose, r.norm().to_degrees()))
            .collect(),
        rms_deg: summary.rms_deg,
        median_deg: summary.median_deg,
        max_deg: summary.max_deg,
        excluded,
    })
}
