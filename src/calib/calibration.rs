//! What a calibration produces, and why it may fail: the types the pipeline returns and every
//! level helps to fill, kept apart from the pipeline (which uses the levels) so that the levels
//! never import the pipeline back.

use nalgebra::{DMatrix, DVector, Vector3};

use super::fit::{FitError, FitOutcome, IterationLog};
use super::marker_residuals::MarkerObservation;
use super::orientation_residuals::Observation;
use super::parameterisation::Parameterisation;
use super::report::CalibrationReport;
use super::residuals::EvalError;
use crate::model::Parameters;
use crate::vision::{SessionEstimate, VisionError};

/// Why a calibration could not be done.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibError {
    #[error("config `{key}`: {reason}")]
    /// A calibration setting is invalid (checked before any work).
    Config {
        /// The config key, e.g. `bounds.axis_tilt_deg`.
        key: String,
        /// What is wrong with its value.
        reason: String,
    },
    #[error("vision: {0}")]
    /// The vision estimate of the session failed.
    Vision(#[from] VisionError),
    #[error("the session's marker `{0}` is not among the model's markers")]
    /// The session names a marker the model does not have.
    UnknownMarker(String),
    #[error("only {usable} usable {what}; at least {needed} are needed for {parameters} parameters")]
    /// Too few usable observations (poses at the orientation level, marker observations at the
    /// marker level) for the number of free parameters.
    TooFewPoses {
        /// Observations left after vision and FDA exclusions.
        usable: usize,
        /// Observations needed: three residuals each, for the free parameters plus three.
        needed: usize,
        /// Free parameters.
        parameters: usize,
        /// What is counted: `poses` (orientation level) or `marker observations`.
        what: &'static str,
    },
    #[error("the camera registration cannot be started: every pose rotates about one axis")]
    /// No starting camera registration: the poses do not span two rotation axes (orientation
    /// level), or the marker observations are fewer than three or lie in a line (marker level).
    Registration,
    #[error(
        "the camera registration cannot be started: {observations} marker observation(s) with a forward kinematics solution, all of them in a line or fewer than three"
    )]
    /// No starting camera registration from the markers.
    MarkerRegistration {
        /// Marker observations with a nominal FDA.
        observations: usize,
    },
    #[error(
        "the MP barely moves: the largest rotation {}is {max_deg:.3}°, too little to calibrate from{}",
        if unidentifiable.is_empty() { "the camera sees from the reference pose " } else { "between the session's poses " },
        if unidentifiable.is_empty() { String::new() } else {
            format!("; the data cannot identify {} direction(s), the weakest: {}", unidentifiable.len(), unidentifiable.iter().take(3).cloned().collect::<Vec<_>>().join("; "))
        }
    )]
    /// The MP barely moves over the session.
    NoMotion {
        /// Largest rotation, degrees.
        max_deg: f64,
        /// The parameter directions the data leave undetermined.
        unidentifiable: Vec<String>,
    },
    #[error("the data cannot identify {} direction(s) of parameter space: {}; freeze parameters or set `unidentifiable: regularise`", .0.len(), .0.join("; "))]
    /// The data leave some parameter directions undetermined (with `unidentifiable: refuse`).
    Unidentifiable(Vec<String>),
    #[error("{stage}: {error}")]
    /// A fit stage failed.
    Fit {
        /// `nominal registration`, `calibration` or `calibration without the gross errors`.
        stage: &'static str,
        /// Why the fit failed.
        error: FitError,
    },
    #[error(
        "{stage} of a free-motion recording failed; is the camera's latency beyond `latency_bound_s` = {latency_bound_s} s (the joints would be read at the wrong instants)? Widen it, or set `latency_s` near the true latency: {error}"
    )]
    /// A fit of a free-motion recording failed (the latency is the likely cause).
    FreeMotionFit {
        /// The fit stage.
        stage: &'static str,
        /// Why it failed.
        error: FitError,
        /// The configured bound on the latency (s).
        latency_bound_s: f64,
    },
    #[error("{0}; not written (`if_not_better: refuse`)")]
    /// The calibrated model does not predict unseen poses clearly better than the nominal one.
    NotBetter(String),
    #[error("the nominal model: {0}")]
    /// The nominal model cannot predict the session's poses.
    Nominal(EvalError),
    #[error("held-out poses: {0}")]
    /// The nominal or the calibrated model cannot predict a held-out pose (orientation level).
    HeldOut(EvalError),
}

/// A fit's solution, as the recording and the HTML report see it.
#[derive(Debug, Clone)]
pub struct Solution {
    /// The parameter vector.
    pub x: DVector<f64>,
    /// The residuals there, one per observation (radians or metres).
    pub residuals: Vec<Vector3<f64>>,
    /// The MP orientation of each distinct pose there.
    pub orientations: Vec<nalgebra::Rotation3<f64>>,
    /// Every iteration of the fit.
    pub log: Vec<IterationLog>,
}

impl Solution {
    pub(crate) fn of<N>(outcome: &FitOutcome<N>) -> Self {
        let evaluation = &outcome.evaluation;
        Solution {
            x: outcome.x.clone(),
            residuals: evaluation.residuals.clone(),
            orientations: evaluation.orientations.clone(),
            log: outcome.log.clone(),
        }
    }
}

/// What a calibration fitted, by level.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Fitted {
    /// Per-pose orientations: the fitted and the held-out poses, and the vision estimate.
    Orientations {
        /// Fitted poses.
        fitted: Vec<Observation>,
        /// Poses held out of the fit (`holdout_every`).
        held_out: Vec<Observation>,
        /// The held-out poses' residuals (radians), nominal then calibrated, as the report
        /// measured them.
        held_out_residuals: Box<[Vec<Vector3<f64>>; 2]>,
        /// The vision estimate the orientations came from.
        vision: Box<SessionEstimate>,
    },
    /// Marker observations, read at the fitted latency.
    Markers(Vec<MarkerObservation>),
}

/// A calibration: the parameters file and the report, plus what a recording needs.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// The parameters file to write.
    pub parameters: Parameters,
    /// The report.
    pub report: CalibrationReport,
    /// How the parameter vector maps to a geometry.
    #[cfg(feature = "internals")]
    pub parameterisation: Parameterisation,
    #[cfg(not(feature = "internals"))]
    pub(crate) parameterisation: Parameterisation,
    /// What was fitted.
    pub fitted: Fitted,
    /// The nominal mechanism with its best registration.
    pub nominal: Solution,
    /// The calibration fit.
    pub calibrated: Solution,
    /// Parameter covariance over the full vector (zero rows for frozen parameters).
    pub covariance: DMatrix<f64>,
}
