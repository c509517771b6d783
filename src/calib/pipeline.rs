//! The calibration of a session, one pipeline for every fit level:
//!
//! observations → a [`Model`] (the [`Level`] prepares it) → the nominal baseline (registration
//! alone) → identifiability → the robust fit → gross errors excluded and refitted → uncertainty →
//! cross-validation → one verdict → the level's parameters file and report.
//!
//! What differs between the orientation-level and the marker-level fit is only what differs in
//! their data and model: how observations are made and registered, and what their report adds.

use nalgebra::{DMatrix, DVector, Vector3};

use super::agreement::{best_registration, registration_mask};
use super::config::{CalibConfig, FitLevel, Group, IfNotBetter, Unidentifiable};
use super::fit::{FitError, FitOutcome, FitSettings, IterationLog, fit};
use super::identify::Direction;
use super::marker_model::MarkerObservation;
use super::model::{EvalError, Model};
use super::orientation_model::Observation;
use super::params::Parameterisation;
use super::report::{CalibrationReport, FlaggedObservation, Verdict};
use super::uncertainty::{covariance, identifiability_at};
use super::validation::{CrossValidation, cross_validate};
use super::{levels, report};
use crate::dataset::Session;
use crate::model::{Parameters, RobotModel};
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
    pub parameterisation: Parameterisation,
    /// What was fitted.
    pub fitted: Fitted,
    /// The nominal mechanism with its best registration.
    pub nominal: Solution,
    /// The calibration fit.
    pub calibrated: Solution,
    /// Parameter covariance over the full vector (zero rows for frozen parameters).
    pub covariance: DMatrix<f64>,
}

/// Below this largest rotation (degrees) the session holds no motion to calibrate from: a few
/// camera noise levels (~0.05° per pose at the Agile Wrist's scale).
pub(crate) const MIN_MOTION_DEG: f64 = 0.5;

/// Where an observation came from, as the report names it: `(pose, marker, line)`.
pub(crate) type Origin = (u64, Option<String>, usize);

/// The data of one fit level: what the pipeline asks of it beyond its model.
pub(crate) trait Level {
    /// The level's residual model.
    type Model<'a>: Model + Clone
    where
        Self: 'a;

    /// The parameter vector.
    fn parameterisation(&self) -> &Parameterisation;

    /// The model of every observation to fit.
    fn model(&self) -> Self::Model<'_>;

    /// Which parameters move.
    fn free(&self) -> Vec<bool>;

    /// The largest rotation of the MP over the session (degrees).
    fn motion_deg(&self) -> f64;

    /// Observation `j` of `model` as the report names it: `(pose, marker, line)`.
    fn origin(&self, model: &Self::Model<'_>, j: usize) -> Origin;

    /// The parameters file and the report, from the fit's results.
    ///
    /// # Errors
    /// A [`CalibError`] when a held-out pose cannot be predicted.
    fn finish(&self, fit: Results<'_, Self::Model<'_>>) -> Result<Calibration, CalibError>;
}

/// What the pipeline hands a level to finish with.
pub(crate) struct Results<'a, M: Model> {
    pub(crate) session: &'a Session,
    pub(crate) robot: &'a RobotModel,
    /// The model of the observations finally fitted (without the gross errors).
    pub(crate) model: M,
    pub(crate) nominal: FitOutcome<M::Noise>,
    pub(crate) calibrated: FitOutcome<M::Noise>,
    pub(crate) free: Vec<bool>,
    pub(crate) covariance: DMatrix<f64>,
    /// Each residual's expected squared prediction error `tr(J_j Cov J_jᵀ)` (unit²), when the
    /// calibrated evaluation has its Jacobian.
    pub(crate) predicted_ms: Option<Vec<f64>>,
    /// The report, with every field that does not depend on the level filled in.
    pub(crate) report: CalibrationReport,
}

/// Calibrate `session` on `model`; `on_iteration` sees every iteration of the main fit.
///
/// # Errors
/// A [`CalibError`] for an invalid config, too few usable poses, no motion, no starting
/// registration, unidentifiable directions (with `unidentifiable: refuse`), a failed fit, a
/// calibration not better than nominal (with `if_not_better: refuse`) or an unpredictable
/// held-out pose.
pub fn calibrate(
    session: &Session,
    model: &RobotModel,
    config: &CalibConfig,
    on_iteration: &mut dyn FnMut(&IterationLog),
) -> Result<Calibration, CalibError> {
    config.check().map_err(|(key, reason)| CalibError::Config { key, reason })?;
    // A free-motion recording's poses at the configured camera latency; when the marker-level fit
    // estimates it, only frames inside the encoder stream for every latency within its bounds.
    let tau = config.latency_s;
    let range = match config.fit == FitLevel::Markers && !config.freeze.contains(&Group::Latency) {
        true => (-config.latency_bound_s, config.latency_bound_s),
        false => (tau, tau),
    };
    let resampled = session.streams.is_some().then(|| session.at_latency_within(tau, range));
    let (session, left_out) = match &resampled {
        Some((s, warnings)) => (s, warnings.iter().map(|w| w.to_string()).collect()),
        None => (session, Vec::new()),
    };
    let latency_free = resampled.is_some() && range.0 < range.1;
    // The orientation level cannot estimate the camera model: it corrects the markers by the one
    // the config gives (the marker level fits it, starting there).
    let corrected;
    let session = match config.fit {
        FitLevel::Orientations => {
            corrected = session.undistorted(&config.camera_terms.model(config.camera_model)).ok_or_else(|| {
                CalibError::Config { key: "camera_terms".into(), reason: "the camera model is singular".into() }
            })?;
            &corrected
        }
        FitLevel::Markers => session,
    };
    let calibration = match config.fit {
        FitLevel::Markers => {
            run(levels::MarkerLevel::prepare(session, model, config)?, session, model, config, left_out, on_iteration)
        }
        FitLevel::Orientations => run(
            levels::OrientationLevel::prepare(session, model, config)?,
            session,
            model,
            config,
            left_out,
            on_iteration,
        ),
    };
    // A fit of a free-motion recording that breaks down is most often a latency outside its
    // bound: the joints are read at the wrong instants. Say so in the user's terms first.
    match calibration {
        Err(CalibError::Fit { stage, error }) if latency_free => {
            Err(CalibError::FreeMotionFit { stage, error, latency_bound_s: config.latency_bound_s })
        }
        other => other,
    }
}

/// The pipeline, once for every level.
fn run<L: Level>(
    level: L,
    session: &Session,
    robot: &RobotModel,
    config: &CalibConfig,
    left_out: Vec<String>,
    on_iteration: &mut dyn FnMut(&IterationLog),
) -> Result<Calibration, CalibError> {
    let mut clock = Clock::start();
    let p = level.parameterisation();
    let mut free = level.free();
    let model = level.model();
    check_enough(&free, model.len(), if model.unit() == "mm" { "marker observations" } else { "poses" })?;
    let registration = registration_mask(p, &free);
    let stage = |stage| move |error| CalibError::Fit { stage, error };
    let x0 = p.start();
    let nominal = best_registration(&model, &x0, &registration, config).map_err(stage("nominal registration"))?;
    clock.lap("registration", nominal.log.len());
    // Identifiability at the start of the full fit; a session that barely moves is refused with
    // what it cannot tell apart.
    let mut identifiability = identifiability_at(p, &nominal, &free, config);
    // A camera term the data cannot determine is held at its start and said so, not fitted into
    // the noise (nor regularised with the mechanism).
    let held_camera = unidentified_camera_terms(p, &identifiability);
    if !held_camera.is_empty() {
        held_camera.iter().for_each(|&i| free[i] = false);
        identifiability = identifiability_at(p, &nominal, &free, config);
    }
    let camera_warnings = held_camera.iter().map(|&i| {
        format!(
            "the data cannot determine `{}` (the poses do not move the markers in the ways that tell it from the \
             mechanism and the registration): held at its start",
            p.entries[i].name
        )
    });
    let regularised: Vec<String> = identifiability.unidentifiable.iter().map(Direction::describe).collect();
    let max_deg = level.motion_deg();
    if max_deg < MIN_MOTION_DEG {
        let weak = if regularised.is_empty() { &identifiability.weakest } else { &identifiability.unidentifiable };
        return Err(CalibError::NoMotion { max_deg, unidentifiable: weak.iter().map(Direction::describe).collect() });
    }
    if !regularised.is_empty() && config.unidentifiable == Unidentifiable::Refuse {
        return Err(CalibError::Unidentifiable(regularised));
    }
    let prior = identifiability.prior(p.len()).map(|lambda| (lambda, nominal.x.clone()));
    clock.lap("identifiability", 0);
    let settings =
        FitSettings { prior: prior.clone(), stage: "calibration", ..FitSettings::from_config(config, free.clone()) };
    let robust = fit(&model, &nominal.x, &settings, on_iteration).map_err(stage("calibration"))?;
    clock.lap("calibration", robust.log.len());
    // Gross errors (centimetres, tens of degrees) are removed, not only down-weighted: they would
    // still pull. The baseline is refitted on the same observations as the calibration.
    let origin = |m: &L::Model<'_>, j: usize| level.origin(m, j);
    let mut flagged = flag(&model, &robust, config.outlier_threshold, &origin);
    let gross: Vec<usize> = flagged.iter().filter(|(_, f)| f.excluded).map(|(j, _)| *j).collect();
    let (model, calibrated, nominal) = if gross.is_empty() {
        (model, robust, nominal)
    } else {
        let mut keep = vec![true; model.len()];
        gross.iter().for_each(|&j| keep[j] = false);
        let rows: Vec<usize> = (0..model.len()).filter(|&j| keep[j]).collect();
        let model = model.subset(&rows);
        let again = FitSettings { stage: "refit without gross errors", ..settings.clone() };
        let mut refit =
            fit(&model, &robust.x, &again, on_iteration).map_err(stage("calibration without the gross errors"))?;
        let refit_iterations = refit.log.len();
        // The report's iterations are every iteration of both fits, each naming its stage.
        refit.log = robust.log.iter().chain(&refit.log).copied().collect();
        flagged.retain(|(_, f)| f.excluded);
        flagged.extend(flag(&model, &refit, config.outlier_threshold, &origin));
        let nominal =
            best_registration(&model, &nominal.x, &registration, config).map_err(stage("nominal registration"))?;
        clock.lap("refit without gross errors", refit_iterations);
        (model, refit, nominal)
    };
    // A parameter that ends at its bound is held there: the data want it further, and a standard
    // error computed as if it were free would claim a precision the bound, not the data, gives.
    let at_bound = at_bounds(p, &calibrated.x, &free);
    let determined: Vec<bool> = free.iter().zip(&at_bound).map(|(f, b)| *f && !b).collect();
    let covariance = covariance(&calibrated, &determined, prior.as_ref().map(|(l, _)| l));
    clock.lap("uncertainty", 0);
    let groups = super::validation::groups(&model);
    if config.folds > groups {
        let reason = format!(
            "`folds: {}` is more than the {groups} poses (stations) there are to hold out: at most {groups}",
            config.folds
        );
        return Err(CalibError::Config { key: "folds".into(), reason });
    }
    let mut cross_validation =
        cross_validate(&model, [&nominal, &calibrated], [&determined, &registration], prior.as_ref(), config.folds);
    clock.lap("cross-validation", 0);
    let mut warnings: Vec<String> = camera_warnings.collect();
    // Each residual's expected squared prediction error: the self-check's and the level's report's.
    let predicted_ms = super::uncertainty::residual_mean_squares(&calibrated, &covariance);
    if let (Some(cv), Some(predicted)) = (cross_validation.as_mut(), predicted_ms.as_ref()) {
        let noise = super::uncertainty::noise_mean_squares(&calibrated, determined.iter().filter(|f| **f).count());
        cv.check(&noise, predicted, model.unit_scale());
        if let (false, Some(expected)) = (cv.consistent, cv.expected_rms) {
            let unit = model.unit();
            warnings.push(format!(
                "the cross-validated error ({:.4} {unit} RMS) disagrees with the {expected:.4} {unit} the fit predicts \
                 for itself (camera noise plus the predicted error) beyond their uncertainty: the noise model or the \
                 model is wrong (a camera error the camera model does not cover, poses too alike to tell the \
                 mechanism from the camera, …)",
                cv.calibrated_rms
            ));
        }
    }
    if let Some(cv) = cross_validation.as_ref().filter(|cv| !cv.clearly_better) {
        let warning = not_better_warning(cv, &identifiability.unidentifiable, model.poses());
        if config.if_not_better == IfNotBetter::Refuse {
            return Err(CalibError::NotBetter(warning));
        }
        warnings.push(warning);
    }
    if let Some(cv) = cross_validation.as_ref().filter(|cv| cv.unpredicted > 0) {
        warnings.push(format!(
            "{} held-out observations could not be predicted by the model fitted without them (its forward \
             kinematics failed): the cross-validated error leaves them out",
            cv.unpredicted
        ));
    }
    let report = CalibrationReport {
        session: session.name.clone(),
        fit: config.fit,
        vision_method: config.vision_method,
        loss: config.loss,
        poses: session.poses.len(),
        fit_poses: model.poses(),
        held_out_poses: 0,
        excluded: left_out,
        verdict: Verdict { pass: false, summary: String::new() },
        warnings,
        cross_validation,
        before: report::Errors::default(),
        after: report::Errors::default(),
        iterations: calibrated.log.clone(),
        convergence: calibrated.status,
        parameters: Vec::new(),
        not_significant: Vec::new(),
        high_correlations: super::uncertainty::correlations(p, &covariance, 0.9),
        identifiability,
        regularised,
        predicted_error_deg: None,
        predicted_error_mm: None,
        residual_sigma_deg: Vec::new(),
        flagged: flagged.into_iter().map(|(_, f)| f).collect(),
        unit: model.unit(),
        at_bound: p.entries.iter().zip(&at_bound).filter(|(_, b)| **b).map(|(e, _)| e.name.clone()).collect(),
        camera_translation_m: None,
        camera_translation_std_error_m: None,
        markers: None,
        stages: Vec::new(),
    };
    let results =
        Results { session, robot, model, nominal, calibrated, free: determined, covariance, predicted_ms, report };
    let mut calibration = level.finish(results)?;
    clock.lap("report", 0);
    let report = &mut calibration.report;
    report.stages = clock.stages;
    report.verdict = Verdict::of(report.cross_validation.as_ref(), &report.before, &report.after, config);
    report.not_significant = super::uncertainty::not_significant(&report.parameters);
    calibration.parameters.fit = Some(report::fit_header(report));
    Ok(calibration)
}

/// The stages' wall-clock times, lap by lap.
struct Clock {
    last: std::time::Instant,
    stages: Vec<super::report::StageReport>,
}

impl Clock {
    fn start() -> Self {
        Clock { last: std::time::Instant::now(), stages: Vec::new() }
    }

    /// The stage `name` ends now, after `iterations` fit iterations.
    fn lap(&mut self, name: &'static str, iterations: usize) {
        let now = std::time::Instant::now();
        let seconds = (now - self.last).as_secs_f64();
        self.stages.push(super::report::StageReport { name, iterations, seconds });
        self.last = now;
    }
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

/// A camera-model parameter weighs this much (scaled) in an unidentifiable direction: it is part
/// of what the data cannot determine.
const CAMERA_IN_NULL_DIRECTION: f64 = 0.3;

/// The camera-model parameters that take part in an unidentifiable direction (by their share of
/// the column-scaled direction, so that units do not decide).
pub(super) fn unidentified_camera_terms(
    p: &Parameterisation,
    identifiability: &super::identify::Identifiability,
) -> Vec<usize> {
    let camera: Vec<usize> =
        (0..p.len()).filter(|&i| matches!(p.entries[i].kind, super::params::Kind::CameraTerm { .. })).collect();
    let mut held: Vec<usize> = identifiability
        .null_vectors
        .iter()
        .flat_map(|v| {
            let scaled = v.component_mul(&identifiability.column_norms);
            let norm = scaled.norm().max(f64::MIN_POSITIVE);
            camera.iter().copied().filter(move |&i| (scaled[i] / norm).abs() > CAMERA_IN_NULL_DIRECTION)
        })
        .collect();
    held.sort_unstable();
    held.dedup();
    held
}

/// The free parameters that end at their bound.
fn at_bounds(p: &Parameterisation, x: &DVector<f64>, free: &[bool]) -> Vec<bool> {
    (0..p.len()).map(|i| free[i] && p.at_bound(x, i)).collect()
}

/// Observations beyond `threshold` robust standard deviations, most extreme first; beyond twice
/// that, gross errors to exclude.
fn flag<M: Model>(
    model: &M,
    outcome: &FitOutcome<M::Noise>,
    threshold: f64,
    origin: &dyn Fn(&M, usize) -> Origin,
) -> Vec<(usize, FlaggedObservation)> {
    let w = &outcome.weighting;
    let mut out: Vec<(usize, FlaggedObservation)> = outcome
        .evaluation
        .residuals
        .iter()
        .enumerate()
        .filter_map(|(j, r)| {
            let sigmas = w.whiten(j, r).norm() / w.sigma;
            (sigmas > threshold).then(|| {
                let (pose, marker, line) = origin(model, j);
                let f = FlaggedObservation {
                    pose,
                    marker,
                    line,
                    residual: r.norm() * model.unit_scale(),
                    sigmas,
                    weight: w.weights[j],
                    excluded: sigmas > 2.0 * threshold,
                };
                (j, f)
            })
        })
        .collect();
    out.sort_by(|a, b| b.1.sigmas.total_cmp(&a.1.sigmas));
    out
}

/// Why the calibrated model may not be better, in words.
fn not_better_warning(cv: &CrossValidation, weak: &[Direction], poses: usize) -> String {
    let mut cause = if poses < 40 {
        format!("only {poses} poses: capture more, spread over the workspace")
    } else {
        "the poses may be too similar: spread them over the workspace".to_string()
    };
    if let Some(d) = weak.first() {
        cause += &format!("; weakest direction {}", d.describe());
    }
    format!(
        "the calibrated model does not predict unseen poses clearly better than the nominal one \
         ({:.3} {unit} against {:.3} {unit} RMS, {}-fold cross-validation): {cause}",
        cv.calibrated_rms,
        cv.nominal_rms,
        cv.folds,
        unit = cv.unit
    )
}
