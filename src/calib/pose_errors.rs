//! FDA against vision, per pose: the angle between the orientation a parameter set predicts from
//! the joints and the one the per-pose estimator measured. `compare` reports it for any parameter
//! sets; the marker-level calibration reports it before and after (in degrees, beside its
//! marker errors in millimetres).
//!
//! A parameter set without a camera registration (the nominal model) gets the best-fit
//! registration alone, so that a camera misalignment is not blamed on the mechanism. With a
//! registration (a calibrated file) only the reference rotation `A` is fitted: it belongs to the
//! session (where its reference pose was), not to the device.

use nalgebra::{DVector, Rotation3};

use super::calibrate::ErrorSummary;
use super::config::{CalibConfig, Group, Loss};
use super::params::Parameterisation;
use super::registration::initial_registration;
use super::residual::{Observation, observations};
use super::solver::{FitError, FitSettings, Orientations, fit_model};
use crate::dataset::Session;
use crate::model::{LegGeometry, Parameters, Spm};
use crate::vision::SessionEstimate;

/// FDA-vs-vision angles of one parameter set.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseErrors {
    /// How the camera registration was obtained.
    pub registration: &'static str,
    /// `(pose, angle in degrees)`.
    pub per_pose: Vec<(u64, f64)>,
    /// Their RMS, median and maximum.
    pub summary: ErrorSummary,
    /// Poses whose forward kinematics failed with this set, and why.
    pub excluded: Vec<String>,
}

/// The FDA-vs-vision angles of `params` on `session`, registration fitted as the module says.
///
/// # Errors
/// Why the set cannot be compared (in words): an invalid geometry, fewer than three poses with
/// both an estimate and an FDA, no registration, a failed fit.
pub fn pose_errors(session: &Session, vision: &SessionEstimate, params: &Parameters) -> Result<PoseErrors, String> {
    let fail = |reason: String| reason;
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
    let model = Orientations { p: &p, observations: &observations, registration_only: true };
    let outcome = fit_model(&model, &DVector::zeros(p.len()), &settings, &mut |_| {})
        .map_err(|e: FitError| fail(e.to_string()))?;
    Ok(PoseErrors {
        registration,
        per_pose: observations
            .iter()
            .zip(&outcome.evaluation.residuals)
            .map(|(o, r)| (o.pose, r.norm().to_degrees()))
            .collect(),
        summary: ErrorSummary::of(&outcome.evaluation.residuals),
        excluded,
    })
}
