//! A fit level: what the pipeline asks of the data of one level (per-pose orientations, marker
//! observations) beyond its residuals, and what the level hands back for the one report. The
//! pipeline (`pipeline.rs`) runs over this trait; the implementations (`levels/`) sit beside it and
//! import only this file and the shared types (`calibration.rs`), never the pipeline.

use nalgebra::DMatrix;

use super::calibration::{CalibError, Fitted};
use super::fit::FitOutcome;
use super::parameterisation::Parameterisation;
use super::report::{ErrorStats, FlaggedObservation, MarkerFitReport};
use super::residuals::Residuals;
use super::uncertainty::{ParameterReport, PredictedError};
use crate::dataset::Session;
use crate::model::{Parameters, RobotModel};
use crate::vision::Method;

/// Below this largest rotation (degrees) the session holds no motion to calibrate from: a few
/// camera noise levels (~0.05° per pose at the Agile Wrist's scale).
pub(crate) const MIN_MOTION_DEG: f64 = 0.5;

/// Where an observation came from, as the report names it: `(pose, marker, line)`.
pub(crate) type Origin = (u64, Option<String>, usize);

/// The data of one fit level: what the pipeline asks of it beyond its residuals.
pub(crate) trait Level {
    /// The level's residual problem.
    type Problem<'a>: Residuals + Clone
    where
        Self: 'a;

    /// The parameter vector.
    fn parameterisation(&self) -> &Parameterisation;

    /// The residuals of every observation to fit.
    fn problem(&self) -> Self::Problem<'_>;

    /// Which parameters move.
    fn free(&self) -> Vec<bool>;

    /// The largest rotation of the MP over the session (degrees).
    fn motion_deg(&self) -> f64;

    /// Observation `j` of `problem` as the report names it: `(pose, marker, line)`.
    fn origin(&self, problem: &Self::Problem<'_>, j: usize) -> Origin;

    /// What the level adds to the report, and the parameters file, from the fit's results.
    ///
    /// # Errors
    /// A [`CalibError`] when a held-out pose cannot be predicted.
    fn finish(&self, fit: LevelResults<'_, Self::Problem<'_>>) -> Result<LevelReport, CalibError>;
}

/// What the pipeline hands a level to finish with.
pub(crate) struct LevelResults<'a, M: Residuals> {
    pub(crate) session: &'a Session,
    pub(crate) robot: &'a RobotModel,
    /// The residuals of the observations finally fitted (without the gross errors).
    pub(crate) problem: M,
    pub(crate) nominal: FitOutcome<M::Noise>,
    pub(crate) calibrated: FitOutcome<M::Noise>,
    pub(crate) free: Vec<bool>,
    pub(crate) covariance: &'a DMatrix<f64>,
    /// The covariance the predicted error uses: `covariance`, widened by what the misfit can do
    /// when the model check failed.
    pub(crate) predicted_covariance: &'a DMatrix<f64>,
    /// Each residual's expected squared prediction error `tr(J_j Cov J_jᵀ)` (unit²), when the
    /// calibrated evaluation has its Jacobian.
    pub(crate) predicted_ms: Option<Vec<f64>>,
    /// The observations the robust fit flagged (the gross errors among them excluded).
    pub(crate) flagged: &'a [FlaggedObservation],
}

/// What a level hands back: its parameters file, what it fitted, and its parts of the report
/// (the pipeline assembles the report once, from these and its own).
pub(crate) struct LevelReport {
    pub(crate) parameters: Parameters,
    pub(crate) fitted: Fitted,
    /// The per-pose estimator behind `before` and `after`, when it is not the config's.
    pub(crate) vision_method: Option<Method>,
    pub(crate) before: ErrorStats,
    pub(crate) after: ErrorStats,
    pub(crate) held_out_poses: usize,
    pub(crate) parameters_report: Vec<ParameterReport>,
    pub(crate) predicted_error_deg: Option<PredictedError>,
    pub(crate) predicted_error_mm: Option<PredictedError>,
    /// The predicted orientation error (RMS, degrees) from `covariance` alone, when the predicted
    /// covariance was widened.
    pub(crate) predicted_error_unwidened_deg: Option<f64>,
    pub(crate) residual_sigma_deg: Vec<(usize, usize, [f64; 3])>,
    pub(crate) camera_translation_m: Option<[f64; 3]>,
    pub(crate) camera_translation_std_error_m: Option<[f64; 3]>,
    pub(crate) markers: Option<MarkerFitReport>,
    /// Observations the level left out (before the fit, and its gross errors), in its words.
    pub(crate) excluded: Vec<String>,
    /// Warnings found while preparing (shown before the pipeline's).
    pub(crate) notes: Vec<String>,
    /// Warnings found in the results (shown after the pipeline's).
    pub(crate) findings: Vec<String>,
}

/// Something to fit, and enough residuals (3 per observation) for the free parameters: checked
/// before anything indexes them.
pub(crate) fn check_enough(free: &[bool], observations: usize, what: &'static str) -> Result<(), CalibError> {
    let n_free = free.iter().filter(|f| **f).count();
    if n_free == 0 {
        let reason = "every parameter is frozen: there is nothing to fit".to_string();
        return Err(CalibError::Config { key: "freeze".into(), reason });
    }
    if 3 * observations < n_free + 3 {
        return Err(CalibError::TooFewPoses {
            usable: observations,
            needed: n_free.div_ceil(3) + 1,
            parameters: n_free,
            what,
        });
    }
    Ok(())
}
