//! How far a parameter set and the camera disagree on a session: per pose, in degrees (the angle
//! between the orientation the set predicts from the joints and the one the per-pose estimator
//! measured) or in millimetres (the RMS distance between the markers it predicts and the ones the
//! camera measured). `compare` reports them for any parameter sets; the calibration reports them
//! before and after.
//!
//! Registrations: a parameter set without one (the nominal model) gets the best-fit registration
//! alone (least squares), so that a camera misalignment is not blamed on the mechanism. With one (a
//! calibrated file) the file's registration, markers and latency are used as they are — at the
//! orientation level only the reference rotation `A` is fitted: it belongs to the session (where
//! its reference pose was), not to the device.

use nalgebra::{DVector, Rotation3, Vector3};
use serde::Serialize;

use super::config::{CalibConfig, Group, Loss};
use super::fit::{FitError, FitOutcome, FitSettings, fit};
use super::marker_residuals::{MarkerObservation, MarkerResiduals, per_pose_rms};
use super::orientation_residuals::{Observation, OrientationResiduals, observations};
use super::parameterisation::Parameterisation;
use super::registration;
use super::residuals::{EvalError, Residuals};
use crate::dataset::Session;
use crate::math::so3;
use crate::math::stats::{Stats, rms};
use crate::model::{CameraModel, CameraRegistration, Parameters, RobotModel, Spm, SpmError};
use crate::vision::SessionEstimate;

/// Per-observation distances (mm) between measured and predicted markers: their statistics, and
/// per marker.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarkerErrors {
    /// Over every observation, mm (px for a pixel session's).
    #[serde(flatten)]
    pub errors: Stats,
    /// `(marker, observations, RMS)` per marker.
    pub per_marker: Vec<(String, usize, f64)>,
    /// `mm`, or `px` for a pixel session's reprojection errors.
    pub unit: &'static str,
}

impl MarkerErrors {
    /// The statistics of marker residuals (m) of `observations`, per marker of `names`.
    pub(crate) fn of(residuals: &[Vector3<f64>], observations: &[MarkerObservation], names: &[String]) -> Self {
        // Pixels (px) as they are, points in millimetres.
        let pixels = observations.first().is_some_and(|o| o.camera.is_some());
        let scale = if pixels { 1.0 } else { 1e3 };
        // A rigid body's orientations (rad) are not among the positions' errors.
        let positions = observations.iter().zip(residuals).filter(|(o, _)| !o.rotation);
        let mm: Vec<f64> = positions.clone().map(|(_, r)| r.norm() * scale).collect();
        let per_marker = names
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let of_k: Vec<f64> =
                    positions.clone().filter(|(o, _)| o.marker == k).map(|(_, r)| r.norm() * scale).collect();
                (name.clone(), of_k.len(), rms(of_k.iter().copied()))
            })
            .collect();
        MarkerErrors { errors: Stats::of_or_zero(&mm), per_marker, unit: if pixels { "px" } else { "mm" } }
    }
}

/// The statistics (degrees) of per-pose residual rotation vectors (angle = norm).
pub(crate) fn degrees(residuals: &[Vector3<f64>]) -> Stats {
    let deg: Vec<f64> = residuals.iter().map(|r| r.norm().to_degrees()).collect();
    Stats::of_or_zero(&deg)
}

/// Why a parameter set cannot be compared with the camera on a session.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SetError {
    #[error("{0}")]
    /// The parameters make no valid manipulator.
    Geometry(SpmError),
    #[error("only {0} poses have both a vision estimate and a forward kinematics solution")]
    /// Too few poses to register.
    TooFewPoses(usize),
    #[error("only {0} marker observations have a forward kinematics solution")]
    /// Too few marker observations to register.
    TooFewObservations(usize),
    #[error("the session's marker `{0}` is not among the model's markers")]
    /// The session names a marker the model lacks.
    UnknownMarker(String),
    #[error("every pose rotates about one axis: no registration")]
    /// The rotations do not fix the camera rotation.
    RotationsOnOneAxis,
    #[error("the markers do not span a plane: no registration")]
    /// The markers do not fix the registration.
    MarkersInALine,
    #[error("the rigid body's orientations do not fix its frame on the platform: no registration")]
    /// A rigid body's poses do not fix the registration and its frame on the MP.
    BodyFrame,
    #[error("{0}")]
    /// The registration fit failed.
    Fit(FitError),
    #[error("{0}")]
    /// The model cannot be evaluated.
    Eval(EvalError),
    #[error("{0}")]
    /// The vision estimate of the corrected session failed.
    Vision(crate::vision::VisionError),
    #[error("the camera model is singular: its markers cannot be corrected")]
    /// The set's camera model cannot be inverted.
    SingularCamera,
}

/// `session` as the camera model of `params` corrects it (`K⁻¹` on every marker), with its vision
/// estimate when `vision` (the uncorrected session's) is given; `None` for a perfect camera: use
/// `session` and `vision` as they are.
///
/// # Errors
/// [`SetError::SingularCamera`]; a vision error as [`SetError::Vision`].
pub(crate) fn corrected_for(
    session: &Session,
    vision: Option<&SessionEstimate>,
    method: crate::vision::Method,
    params: &Parameters,
) -> Result<Option<(Session, Option<SessionEstimate>)>, SetError> {
    if params.camera_model.is_perfect() {
        return Ok(None);
    }
    let corrected = session.undistorted(&params.camera_model).ok_or(SetError::SingularCamera)?;
    let estimate = match vision {
        Some(_) => Some(SessionEstimate::of(&corrected, method).map_err(SetError::Vision)?),
        None => None,
    };
    Ok(Some((corrected, estimate)))
}

/// The errors of one parameter set, per pose.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PoseErrors {
    /// How the camera registration was obtained.
    pub registration: &'static str,
    /// `(pose, error)`: degrees (orientations) or mm RMS over the pose's markers (markers).
    pub per_pose: Vec<(u64, f64)>,
    /// Poses left out with this set (forward kinematics failed, frames outside the encoder
    /// stream at the set's latency), and why.
    pub excluded: Vec<String>,
}

/// The registration groups that are free.
pub(crate) fn registration_mask(p: &Parameterisation, free: &[bool]) -> Vec<bool> {
    p.entries
        .iter()
        .zip(free)
        .map(|(e, &f)| {
            f && matches!(e.kind.group(), Group::CameraRotation | Group::ReferenceRotation | Group::CameraTranslation)
        })
        .collect()
}

/// The model with its best-fit registration from `start` (the `registration` parameters alone,
/// least squares, as `compare` fits it), evaluated with the full Jacobian at the solution (for the
/// identifiability analysis and the validation).
pub(crate) fn best_registration<M: Residuals + Clone>(
    model: &M,
    start: &DVector<f64>,
    registration: &[bool],
    config: &CalibConfig,
) -> Result<FitOutcome<M::Noise>, FitError> {
    let settings = FitSettings { loss: Loss::LeastSquares, ..FitSettings::from_config(config, registration.to_vec()) };
    let light = model.clone().with_columns(registration.to_vec());
    let mut outcome = fit(&light, start, &settings, &mut |_| {})?;
    let iteration = outcome.log.len() as u32;
    outcome.evaluation = model
        .evaluate(&outcome.x, Some(&outcome.evaluation.orientations), true)
        .map_err(|error| FitError::Evaluation { iteration, error })?;
    // The orientations' sensitivities serve the calibrated model's predicted error only.
    outcome.evaluation.orientation_jacobians = None;
    Ok(outcome)
}

/// The FDA-vs-vision angles (degrees) of `params` on `session`, registration as the module says.
///
/// # Errors
/// A [`SetError`]: an invalid geometry, fewer than three poses with both an estimate and an FDA,
/// no registration, a failed fit.
pub(crate) fn pose_errors(
    session: &Session,
    vision: &SessionEstimate,
    params: &Parameters,
) -> Result<PoseErrors, SetError> {
    let spm = params.spm().map_err(SetError::Geometry)?;
    let (kept, failed) = observations(session, vision, &spm);
    let excluded: Vec<String> = failed.iter().map(|(pose, e)| format!("pose {pose}: {e}")).collect();
    let (observations, predicted): (Vec<Observation>, Vec<Rotation3<f64>>) = kept.into_iter().unzip();
    if observations.len() < 3 {
        return Err(SetError::TooFewPoses(observations.len()));
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
            let (c, a) = registration::from_rotations(&observations, &predicted, vision.reference_pose)
                .ok_or(SetError::RotationsOnOneAxis)?;
            (c, a, "best fit to this session", &[Group::CameraRotation, Group::ReferenceRotation])
        }
    };
    let config = CalibConfig::default();
    let p = Parameterisation::new(*spm.geometry(), camera0, reference0, &config.bounds)
        .with_platform_sag(spm.platform_sag());
    let free: Vec<bool> = p.entries.iter().map(|e| groups.contains(&e.kind.group())).collect();
    let settings = FitSettings { loss: Loss::LeastSquares, ..FitSettings::from_config(&config, free.clone()) };
    let model = OrientationResiduals::new(&p, &observations).with_columns(free);
    let outcome = fit(&model, &DVector::zeros(p.len()), &settings, &mut |_| {}).map_err(SetError::Fit)?;
    let residuals = &outcome.evaluation.residuals;
    Ok(PoseErrors {
        registration,
        per_pose: observations.iter().zip(residuals).map(|(o, r)| (o.pose, r.norm().to_degrees())).collect(),
        excluded,
    })
}

/// The per-pose marker errors (mm) of `params` on `session` (a free-motion recording read at the
/// set's camera clock, latency 0 when it has none), registration as the module says, and that registration.
///
/// # Errors
/// A [`SetError`]: an invalid geometry, a session marker the model lacks, fewer than three
/// observations, no registration, a failed fit.
pub(crate) fn marker_pose_errors(
    session: &Session,
    model: &RobotModel,
    params: &Parameters,
) -> Result<(PoseErrors, CameraRegistration), SetError> {
    let spm = params.spm().map_err(SetError::Geometry)?;
    let (session, left_out) = session.at_clock(params.latency_s.unwrap_or(0.0), params.clock_rate_ppm.unwrap_or(0.0));
    let (observations, failed) = MarkerObservation::of_session(&session, &spm);
    let mut excluded: Vec<String> = left_out.iter().map(|w| w.to_string()).collect();
    excluded.extend(failed.iter().map(|(pose, e)| format!("pose {pose}: {e}")));
    if observations.len() < 3 {
        return Err(SetError::TooFewObservations(observations.len()));
    }
    // A rigid body's origin is the one "marker" (as the calibration has it).
    let names = session.observed_names();
    let mut markers = match session.body {
        Some(_) => vec![Vector3::zeros()],
        None => model_markers(&session.markers, model)?,
    };
    for (k, name) in names.iter().enumerate() {
        if let Some(fitted) = params.marker(name) {
            markers[k] = fitted;
        }
    }
    // The body's frame on the MP as the file has it (body → P): the fit's `A` is its inverse.
    let filed_frame = session
        .body
        .as_ref()
        .and_then(|b| params.markers.iter().find(|m| &m.name == b))
        .and_then(|m| m.rotation.map(|r| (r.inverse(), m.position)));
    let config = CalibConfig::default();
    let nominal = || pose_orientations(&spm, &observations, &markers).map_err(SetError::Eval);
    let (registration, body_frame, how) = match (params.camera, &session.body, filed_frame) {
        (Some(c), None, _) => (c, None, "from the parameters file"),
        (Some(c), Some(_), Some((a, _))) => (c, Some(a), "from the parameters file"),
        // A body the file knows nothing of: its frame and origin as this session shows them.
        (camera, Some(_), _) => {
            let (start, a, origin) = registration::from_body(&observations, &nominal()?).ok_or(SetError::BodyFrame)?;
            markers[0] = filed_frame.map_or(origin, |(_, position)| position);
            match camera {
                Some(c) => (c, Some(a), "from the parameters file (the body's frame fitted)"),
                None => (start, Some(a), "best fit to this session"),
            }
        }
        (None, None, _) => {
            let nominal = nominal()?;
            let start = match session.rig.as_deref() {
                Some(rig) => registration::from_pixels(&observations, &nominal, &markers, rig),
                None => registration::from_markers(&observations, &nominal, &markers),
            };
            (start.ok_or(SetError::MarkersInALine)?, None, "best fit to this session")
        }
    };
    let p = Parameterisation::for_markers(
        params.legs,
        &registration,
        &markers,
        &names,
        CameraModel::rigid(),
        &config.bounds,
    )
    .with_platform_sag(params.platform_sag_deg.to_radians());
    let p = match (body_frame, &session.body) {
        (Some(a), Some(body)) => p.with_body_frame(a, body),
        _ => p,
    };
    // A pixel session's observations are seen through its rig, as it is (no term of it refined).
    let p = match &session.rig {
        Some(rig) => p.with_rig(rig.clone(), &[]),
        None => p,
    };
    let x0 = DVector::zeros(p.len());
    let marker_residuals = MarkerResiduals::new(&p, &observations);
    // What is fitted: the registration when the file has none; a body's frame the file lacks.
    let frame_unknown = session.body.is_some() && filed_frame.is_none();
    let mask: Vec<bool> = registration_mask(&p, &vec![true; p.len()])
        .into_iter()
        .zip(&p.entries)
        .map(|(f, e)| f && (params.camera.is_none() || (frame_unknown && e.kind.group() == Group::ReferenceRotation)))
        .collect();
    let (x, evaluation) = if mask.contains(&true) {
        let fit = best_registration(&marker_residuals, &x0, &mask, &config).map_err(SetError::Fit)?;
        (fit.x, fit.evaluation)
    } else {
        (x0.clone(), marker_residuals.evaluate(&x0, None, false).map_err(SetError::Eval)?)
    };
    // Metres to millimetres; a pixel's residual is in pixels already.
    let scale = if session.rig.is_some() { 1.0 } else { 1e3 };
    let per_pose = per_pose_rms(&observations, &evaluation.residuals, scale);
    let camera = CameraRegistration { rotation: p.camera(&x), translation: p.translation(&x) };
    Ok((PoseErrors { registration: how, per_pose, excluded }, camera))
}

/// The model's position of each of the session's markers `names`.
pub(crate) fn model_markers(names: &[String], model: &RobotModel) -> Result<Vec<Vector3<f64>>, SetError> {
    names
        .iter()
        .map(|name| {
            model
                .markers
                .iter()
                .find(|m| &m.name == name)
                .map(|m| m.position)
                .ok_or_else(|| SetError::UnknownMarker(name.clone()))
        })
        .collect()
}

/// The orientation `spm` gives each observation's pose (one FDA per pose, not per marker).
pub(crate) fn pose_orientations(
    spm: &Spm,
    observations: &[MarkerObservation],
    markers: &[Vector3<f64>],
) -> Result<Vec<Rotation3<f64>>, EvalError> {
    let origin = CameraRegistration { rotation: Rotation3::identity(), translation: Vector3::zeros() };
    let names: Vec<String> = (0..markers.len()).map(|k| format!("m{k}")).collect();
    let p = Parameterisation::for_markers(
        *spm.geometry(),
        &origin,
        markers,
        &names,
        CameraModel::rigid(),
        &CalibConfig::default().bounds,
    )
    .with_platform_sag(spm.platform_sag());
    let model = MarkerResiduals::new(&p, observations);
    let at_pose = model.evaluate(&DVector::zeros(p.len()), None, false)?.orientations;
    Ok((0..observations.len()).map(|j| at_pose[model.pose_of(j)]).collect())
}

/// The largest rotation (degrees) between the first orientation and any other.
pub(crate) fn largest_rotation(rotations: &[Rotation3<f64>]) -> f64 {
    let first = rotations.first().copied().unwrap_or_else(Rotation3::identity);
    rotations.iter().map(|r| so3::geodesic_angle(r, &first).to_degrees()).fold(0.0, f64::max)
}
