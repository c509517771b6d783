//! Calibration: the parameter vector and its gauge, residuals with analytic Jacobians, the
//! clarabel trust-region fit, identifiability, uncertainty and validation.

mod calibrate;
mod config;
mod identify;
mod marker_calibration;
mod marker_pose_errors;
mod markers;
mod params;
mod pose_errors;
mod registration;
mod residual;
mod solver;

pub use calibrate::{
    CalibError, Calibration, CalibrationReport, Correlation, ErrorSummary, Errors, MIN_MOTION_DEG, Outlier,
    ParameterReport, calibrate,
};
pub use config::{Bounds, CalibConfig, FitLevel, Group, IfNotBetter, Loss, Unidentifiable};
pub use identify::{Direction, Identifiability, analyse};
pub use marker_calibration::{
    CrossValidation, FlaggedObservation, Latency, MarkerErrors, MarkerFitReport, MarkerReport,
};
pub use marker_pose_errors::{MarkerPoseErrors, marker_pose_errors};
pub use markers::{MarkerModel, MarkerObservation, StereoNoise, marker_observations, per_pose_rms_mm};
pub use params::{Entry, Kind, Parameterisation, TruthInGauge};
pub use pose_errors::{PoseErrors, pose_errors};
pub(crate) use registration::initial_registration;
pub use residual::{EvalError, Evaluation, Observation, Predicted, Unpredicted, evaluate, observations};
pub use solver::{
    Convergence, FitError, FitOutcome, FitSettings, IterationLog, Model, Orientations, RELATIVE_COST_TOLERANCE,
    Weighting, fit, fit_model, rms,
};
