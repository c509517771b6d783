//! Model against camera at the marker level, per pose: the distance between the markers a
//! parameter set predicts from the joints and the ones the camera measured. `compare` reports it
//! where the per-pose estimator has nothing to work on (one marker per frame, as free-motion
//! recordings have) or when asked to.
//!
//! A parameter set without a camera registration (the nominal model) gets the best-fit
//! registration (rotation and translation, least squares). With one (a calibrated file) the file's
//! registration, markers and latency are used as they are: that is the prediction the file makes
//! for any session taken with the same set-up.

use nalgebra::DVector;

use super::config::CalibConfig;
use super::marker_calibration::{baseline, initial_registration, model_markers, pose_orientations, registration_mask};
use super::markers::{MarkerModel, marker_observations, per_pose_rms_mm};
use super::params::Parameterisation;
use super::solver::Model as _;
use crate::dataset::Session;
use crate::model::{CameraRegistration, Parameters, RobotModel, Spm};

/// Per-pose marker errors of one parameter set.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerPoseErrors {
    /// How the camera registration was obtained.
    pub registration: &'static str,
    /// The registration used.
    pub camera: CameraRegistration,
    /// `(pose, RMS over the pose's markers in millimetres)`.
    pub per_pose: Vec<(u64, f64)>,
    /// Poses whose forward kinematics failed with this set, and frames outside the encoder
    /// stream at the set's latency, and why.
    pub excluded: Vec<String>,
}

/// The per-pose marker errors of `params` on `session` (a free-motion recording read at the
/// set's latency, 0 when it has none), registration as the module says.
///
/// # Errors
/// Why the set cannot be compared (in words): an invalid geometry, a session marker the model
/// lacks, fewer than three observations, no registration, a failed fit.
pub fn marker_pose_errors(
    session: &Session,
    model: &RobotModel,
    params: &Parameters,
) -> Result<MarkerPoseErrors, String> {
    let spm = Spm::new(params.legs).map_err(|e| e.to_string())?;
    let (session, left_out) = session.at_latency(params.latency_s.unwrap_or(0.0));
    let (observations, failed) = marker_observations(&session, &spm);
    let mut excluded: Vec<String> = left_out.iter().map(|w| w.to_string()).collect();
    excluded.extend(failed.iter().map(|(pose, e)| format!("pose {pose}: {e}")));
    if observations.len() < 3 {
        return Err(format!("only {} marker observations have a forward kinematics solution", observations.len()));
    }
    let mut markers = model_markers(&session, model).map_err(|e| e.to_string())?;
    for (k, name) in session.markers.iter().enumerate() {
        if let Some(fitted) = params.marker(name) {
            markers[k] = fitted;
        }
    }
    let config = CalibConfig::default();
    let (registration, how) = match params.camera {
        Some(c) => (c, "from the parameters file"),
        None => {
            let nominal = pose_orientations(&params.legs, &observations, &markers, &session.markers)
                .map_err(|e| e.to_string())?;
            let start = initial_registration(&observations, &nominal, &markers)
                .ok_or("the markers do not span a plane: no registration")?;
            (start, "best fit to this session")
        }
    };
    let p = Parameterisation::for_markers(params.legs, &registration, &markers, &session.markers, &config.bounds);
    let x0 = DVector::zeros(p.len());
    let (x, evaluation) = if params.camera.is_some() {
        let evaluation = MarkerModel::new(&p, &observations).evaluate(&x0, None, false).map_err(|e| e.to_string())?;
        (x0, evaluation)
    } else {
        let mask = registration_mask(&p, &vec![true; p.len()]);
        let fit = baseline(&p, &observations, None, &x0, &mask, &config).map_err(|e| e.to_string())?;
        (fit.x, fit.evaluation)
    };
    let per_pose = per_pose_rms_mm(&observations, &evaluation.residuals);
    let camera = CameraRegistration { rotation: p.camera(&x), translation: p.translation(&x) };
    Ok(MarkerPoseErrors { registration: how, camera, per_pose, excluded })
}
