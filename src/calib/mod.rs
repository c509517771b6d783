//! Calibration: one pipeline for both fit levels.
//!
//! observations → a `Model` (orientation-level or marker-level, each with its own noise model)
//! → the fit (noise re-estimation, robust weighting, exclusion of gross errors) → validation
//! (k-fold cross-validation) → uncertainty (covariance, correlations, identifiability,
//! significance) → one [`CalibrationReport`] with one [`Verdict`].
//!
//! Files, from the bottom up: `config` and `params` (the settings and the parameter vector with its
//! gauge), `sensitivity` (how the MP's orientation moves with the mechanism's parameters),
//! `model` (the trait), `orientation_model` and `marker_model` (its two implementations),
//! `registration` (starting registrations), `fit` (the trust-region fit), `identify`,
//! `uncertainty`, `validation`, `agreement` (how far a parameter set and the camera disagree),
//! `report` and `report_text` (the report and its text view), `levels` (what each level prepares
//! and adds to the report) and `pipeline` (the one flow).

mod agreement;
mod config;
mod fit;
mod identify;
mod levels;
mod marker_model;
mod model;
mod orientation_model;
mod params;
mod pipeline;
pub(crate) mod registration;
mod report;
mod report_text;
mod sensitivity;
#[cfg(test)]
mod tests;
mod uncertainty;
mod validation;

pub use agreement::{MarkerErrors, SetError};
pub(crate) use agreement::{PoseErrors, corrected_for, marker_pose_errors, pose_errors};
pub use config::{Bounds, CalibConfig, FitLevel, Group, IfNotBetter, Loss, Unidentifiable};
pub use fit::{Convergence, IterationLog, Solver};
pub use identify::{Direction, Identifiability};
pub(crate) use marker_model::per_pose_rms_mm;
pub use marker_model::{MarkerModel, MarkerObservation, StereoNoise};
pub use model::EvalError;
pub(crate) use model::Model;
pub use orientation_model::Observation;
pub(crate) use orientation_model::{OrientationModel, observations};
pub use params::{Entry, Kind, Parameterisation, TruthInGauge};
pub use pipeline::{CalibError, Calibration, Fitted, Solution, calibrate};
pub use report::{
    CalibrationReport, CameraModelReport, CameraTermReport, Errors, FastCapture, FlaggedObservation, Latency,
    MarkerFitReport, MarkerReport, StageReport, Verdict,
};
pub use uncertainty::{Correlation, ParameterReport, PredictedError, RegionError};
pub(crate) use uncertainty::{common_rotations, predicted_orientation_error};
pub use validation::CrossValidation;
