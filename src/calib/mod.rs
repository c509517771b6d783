//! Calibration: one pipeline for both fit levels.
//!
//! observations → a `Residuals` (orientation-level or marker-level, each with its own noise model)
//! → the fit (noise re-estimation, robust weighting, exclusion of gross errors) → validation
//! (k-fold cross-validation) → uncertainty (covariance, correlations, identifiability,
//! significance) → one [`CalibrationReport`] with one [`Verdict`].
//!
//! Files, from the bottom up: `config` and `parameterisation` (the settings and the parameter
//! vector with its gauge), `sensitivity` (how the MP's orientation moves with the mechanism's
//! parameters), `residuals` (the trait of what a fit fits), `orientation_residuals` and
//! `marker_residuals` (its two implementations), `registration` (starting registrations), `fit`
//! (the trust-region fit), `identify`, `uncertainty`, `validation`, `agreement` (how far a
//! parameter set and the camera disagree), `camera_choice` (which camera model `auto` fits),
//! `joint_scales` (which joint scales a session identifies), `platform_sag` (whether a session
//! shows the platform's sag), `model_check` (are the residuals what
//! the noise model says, and if not, why), `report` (the one report and its verdict),
//! `calibration` (what a calibration produces, and its errors), `level` (the trait of a fit level
//! and what a level hands back), `levels/` (its two implementations) and `pipeline` (the one flow,
//! over the trait). Nothing imports `pipeline` but this facade.

mod agreement;
mod calibration;
mod camera_choice;
mod config;
mod fit;
mod identify;
pub(crate) mod joint_scales;
mod level;
mod levels;
pub(crate) mod platform_sag;
// Without `internals`, what only the studies and tests use is neither reachable nor used here.
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
mod marker_residuals;
mod model_check;
mod orientation_residuals;
// Without `internals`, what only the studies and tests use is neither reachable nor used here.
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
mod parameterisation;
mod pipeline;
pub(crate) mod registration;
mod report;
mod residuals;
mod rig_terms;
mod sensitivity;
#[cfg(test)]
mod tests;
mod uncertainty;
mod validation;
mod workspace;

pub use agreement::{MarkerErrors, SetError};
pub(crate) use agreement::{PoseErrors, corrected_for, marker_pose_errors, pose_errors};
pub use calibration::{CalibError, Calibration, Fitted, Solution};
pub use camera_choice::{CameraCandidate, CameraModelChoice};
pub use config::{
    Bounds, CalibConfig, CameraModelSetting, FitChoice, FitLevel, Group, IfNotBetter, Loss, PredictionWorkspace,
    RigTermGroup, Unidentifiable,
};
pub use fit::{Convergence, IterationLog, Solver};
pub use identify::{Direction, Identifiability};
pub(crate) use joint_scales::AUTO_MOST_STD_ERROR as JOINT_SCALE_AUTO_MOST_STD_ERROR;
pub use joint_scales::JointScaleReport;
#[cfg(feature = "internals")]
pub use marker_residuals::MarkerResiduals;
#[cfg(not(feature = "internals"))]
pub(crate) use marker_residuals::MarkerResiduals;
pub(crate) use marker_residuals::per_pose_rms;
pub use marker_residuals::{MarkerObservation, StereoNoise};
pub use model_check::{ModelCheck, StructureTest};
pub use orientation_residuals::Observation;
pub(crate) use orientation_residuals::observations;
#[cfg(feature = "internals")]
pub use parameterisation::{Entry, Kind, Parameterisation, TruthInGauge};
#[cfg(not(feature = "internals"))]
pub(crate) use parameterisation::{Kind, Parameterisation};
pub use pipeline::calibrate;
pub(crate) use report::file_line;
pub use report::{
    CalibrationReport, CameraModelReport, CameraTermReport, ClockRate, ErrorStats, FastCapture, FlaggedObservation,
    Latency, MarkerFitReport, MarkerReport, RigReport, RigTermReport, StageReport, Verdict, VerdictReason,
};
pub use residuals::EvalError;
pub(crate) use residuals::Residuals;
pub use uncertainty::{Correlation, ParameterReport, PredictedError, RegionError};
pub(crate) use uncertainty::{common_rotations, predicted_orientation_error};
pub use validation::CrossValidation;
