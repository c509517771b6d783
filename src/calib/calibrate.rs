//! The whole calibration of a session: vision, starting point, nominal baseline, identifiability,
//! the fit, uncertainty, outliers and held-out validation.

use nalgebra::{DMatrix, DVector, Rotation3, Vector3};
use serde::Serialize;

use super::config::{CalibConfig, FitLevel, Group, Loss, Unidentifiable};
use super::identify::Identifiability;
use super::marker_calibration::{MarkerFitReport, calibrate_markers};
use super::markers::MarkerObservation;
use super::params::Parameterisation;
use super::registration::initial_registration;
use super::residual::{EvalError, Observation, evaluate, observations};
use super::solver::{Convergence, FitError, FitOutcome, FitSettings, IterationLog, Weighting, fit, rms};
use crate::dataset::Session;
use crate::model::{CameraRegistration, ParameterSource, Parameters, RobotModel};
use crate::vision::{Method, SessionEstimate, Stats, VisionError, estimate_session};

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
    #[error("only {usable} usable poses; at least {needed} are needed for {parameters} parameters")]
    /// Too few usable poses for the number of free parameters.
    TooFewPoses {
        /// Poses left after vision and FDA exclusions.
        usable: usize,
        /// Poses needed (free parameters plus redundancy).
        needed: usize,
        /// Free parameters.
        parameters: usize,
    },
    #[error("the camera registration cannot be started: every pose rotates about one axis")]
    /// No starting camera registration: the poses do not span two rotation axes.
    Registration,
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
        /// The parameter directions the data leave undetermined (marker-level fit).
        unidentifiable: Vec<String>,
    },
    #[error("the data cannot identify {} direction(s) of parameter space: {}; freeze parameters or set `unidentifiable: regularise`", .0.len(), .0.join("; "))]
    /// The data leave some parameter directions undetermined (with `unidentifiable: refuse`).
    Unidentifiable(Vec<String>),
    #[error("{stage}: {error}")]
    /// A fit stage failed.
    Fit {
        /// `nominal` (registration only) or `calibration`.
        stage: &'static str,
        /// Why the fit failed.
        error: FitError,
    },
    #[error("{0}; not written (`if_not_better: refuse`)")]
    /// The calibrated model does not predict unseen poses clearly better than the nominal one.
    NotBetter(String),
    #[error("held-out poses: {0}")]
    /// The calibrated model cannot predict a held-out pose.
    HeldOut(EvalError),
}

/// RMS, median and maximum of per-pose angles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorSummary {
    /// Poses summarised.
    pub poses: usize,
    /// RMS angle, degrees.
    pub rms_deg: f64,
    /// Median angle, degrees.
    pub median_deg: f64,
    /// Largest angle, degrees.
    pub max_deg: f64,
}

impl ErrorSummary {
    /// Summary of per-pose residual rotation vectors (angle = norm).
    pub fn of(residuals: &[Vector3<f64>]) -> ErrorSummary {
        let deg: Vec<f64> = residuals.iter().map(|r| r.norm().to_degrees()).collect();
        let stats = Stats::of(&deg).unwrap_or(Stats { mean: 0.0, median: 0.0, max: 0.0 });
        ErrorSummary {
            poses: deg.len(),
            rms_deg: rms(residuals).to_degrees(),
            median_deg: stats.median,
            max_deg: stats.max,
        }
    }
}

/// FDA-vs-vision errors of one parameter set, on the fitted and on the held-out poses.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Errors {
    /// On the fitted poses.
    pub fit: ErrorSummary,
    /// On the held-out poses, when some were held out.
    pub held_out: Option<ErrorSummary>,
}

/// One parameter of the report (angles in degrees; `change` is the departure from nominal).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterReport {
    /// Parameter name, e.g. `alpha1_2`.
    pub name: String,
    /// Departure from nominal, degrees.
    pub change_deg: f64,
    /// Standard error, degrees (`None` when frozen or regularised).
    pub std_error_deg: Option<f64>,
    /// Held at its initial value.
    pub frozen: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
/// A strong correlation between two fitted parameters.
pub struct Correlation {
    /// First parameter.
    pub a: String,
    /// Second parameter.
    pub b: String,
    /// Correlation coefficient.
    pub rho: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
/// A pose the robust fit down-weighted.
pub struct Outlier {
    /// Pose id.
    pub pose: u64,
    /// Its residual angle, degrees.
    pub residual_deg: f64,
    /// Its Huber weight in (0, 1].
    pub weight: f64,
}

/// Everything a user needs to judge a calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationReport {
    /// Session name.
    pub session: String,
    /// What was fitted.
    pub fit: FitLevel,
    /// Vision estimator used for the measured orientations.
    pub vision_method: Method,
    /// Loss of the fit.
    pub loss: Loss,
    /// Poses in the session.
    pub poses: usize,
    /// Poses fitted.
    pub fit_poses: usize,
    /// Poses held out for validation.
    pub held_out_poses: usize,
    /// Poses left out, and why (vision or forward kinematics of the nominal model).
    pub excluded: Vec<String>,
    /// Nominal mechanism with its best-fit camera registration.
    pub before: Errors,
    /// Calibrated mechanism with its registration.
    pub after: Errors,
    /// The calibration fit, iteration by iteration.
    pub iterations: Vec<IterationLog>,
    /// How the fit ended: converged, or stalled at a minimum.
    pub convergence: Convergence,
    /// Every parameter with its change and standard error.
    pub parameters: Vec<ParameterReport>,
    /// Singular values and weakest directions of the scaled Jacobian.
    pub identifiability: Identifiability,
    /// Unidentifiable directions held by a weak prior.
    pub regularised: Vec<String>,
    /// Parameters whose change from nominal is smaller than twice its standard error: the data
    /// cannot tell them from nominal.
    pub not_significant: Vec<String>,
    /// Parameter pairs with |ρ| above 0.9.
    pub high_correlations: Vec<Correlation>,
    /// Predicted orientation uncertainty (1σ, RMS over axes) from the parameter covariance.
    pub orientation_uncertainty_deg: Option<Stats>,
    /// Residual standard deviation per camera axis, degrees, by the number of markers seen:
    /// `(markers, poses, [σx, σy, σz])`.
    pub residual_sigma_deg: Vec<(usize, usize, [f64; 3])>,
    /// Poses down-weighted by the robust loss.
    pub outliers: Vec<Outlier>,
    /// `t_CB` from the centre of rotation; `None` when the poses leave it undetermined.
    pub camera_translation_m: Option<[f64; 3]>,
    /// Its standard errors.
    pub camera_translation_std_error_m: Option<[f64; 3]>,
    /// The marker-level fit's own figures (`fit: markers`).
    pub markers: Option<MarkerFitReport>,
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
    /// Fitted poses, then held-out poses.
    pub observations: Vec<Observation>,
    /// Held-out poses.
    pub held_out: Vec<Observation>,
    /// The marker observations fitted (`fit: markers`; empty otherwise).
    pub marker_observations: Vec<MarkerObservation>,
    /// The nominal mechanism with its best registration.
    pub nominal: FitOutcome,
    /// The calibration fit.
    pub calibrated: FitOutcome,
    /// Parameter covariance over the full vector (zero rows for frozen parameters).
    pub covariance: DMatrix<f64>,
    /// The vision estimate the fit used (orientation-level fit).
    pub vision: Option<SessionEstimate>,
}

/// Below this largest rotation from the reference (degrees) the session holds no motion to
/// calibrate from: a few camera noise levels (~0.05° per pose at the Agile Wrist's scale).
pub const MIN_MOTION_DEG: f64 = 0.5;

/// Calibrate `session` on `model`; `on_iteration` sees every iteration of the main fit.
///
/// # Errors
/// A [`CalibError`] for an invalid config, too few usable poses, no motion, no starting registration, unidentifiable directions (with `unidentifiable: refuse`), a failed fit or an unpredictable held-out pose.
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
        Some((s, warnings)) => (s, warnings.as_slice()),
        None => (session, &[][..]),
    };
    if config.fit == FitLevel::Markers {
        let mut calibration = calibrate_markers(session, model, config, on_iteration)?;
        calibration.report.excluded.extend(left_out.iter().map(|w| w.to_string()));
        return Ok(calibration);
    }
    let vision = estimate_session(session, config.vision_method)?;
    let nominal_spm = &model.spm;
    // Observations whose nominal FDA exists.
    let (all, failed) = observations(session, &vision, nominal_spm);
    let mut excluded: Vec<String> = vision.skipped.iter().map(|s| s.to_string()).collect();
    excluded.extend(failed.iter().map(|(pose, e)| format!("pose {pose}: nominal forward kinematics: {e}")));
    let (fit_set, held_set): (Vec<_>, Vec<_>) = all.iter().enumerate().partition(|(k, (o, _))| {
        config.holdout_every == 0 || o.pose == vision.reference_pose || (k + 1) % config.holdout_every != 0
    });
    let observations: Vec<Observation> = fit_set.iter().map(|(_, (o, _))| *o).collect();
    let held_out: Vec<Observation> = held_set.iter().map(|(_, (o, _))| *o).collect();
    // Enough poses for the free parameters (3 residuals each), checked before anything indexes them.
    // (The entries do not depend on the rotations: the free mask is known before the registration.)
    let layout =
        Parameterisation::new(*nominal_spm.geometry(), Rotation3::identity(), Rotation3::identity(), &config.bounds);
    let free: Vec<bool> = layout.entries.iter().map(|e| !config.freeze.contains(&e.kind.group())).collect();
    check_enough(&free, observations.len())?;
    let predicted: Vec<Rotation3<f64>> = fit_set.iter().map(|(_, (_, r))| *r).collect();
    let measured: Vec<Rotation3<f64>> = observations.iter().map(|o| o.measured).collect();
    // Nothing moving is its own problem, not "one axis": say which.
    let max_deg = measured.iter().map(|q| q.angle().to_degrees()).fold(0.0, f64::max);
    if max_deg < MIN_MOTION_DEG {
        return Err(CalibError::NoMotion { max_deg, unidentifiable: Vec::new() });
    }
    let (camera0, reference0) =
        initial_registration(&observations, &predicted, vision.reference_pose).ok_or(CalibError::Registration)?;
    let p = Parameterisation::new(*nominal_spm.geometry(), camera0, reference0, &config.bounds);
    let settings = |free: Vec<bool>, prior| FitSettings { prior, ..FitSettings::from_config(config, free) };
    // The baseline: nominal mechanism, best-fit registration alone.
    let registration_only: Vec<bool> =
        p.entries.iter().map(|e| matches!(e.kind.group(), Group::CameraRotation | Group::ReferenceRotation)).collect();
    let x0 = DVector::zeros(p.len());
    let nominal = fit(&p, &x0, &observations, &settings(registration_only, None), &mut |_| {})
        .map_err(|error| CalibError::Fit { stage: "nominal registration", error })?;
    // Identifiability at the start of the full fit.
    let identifiability = identifiability_at(&p, &nominal, &free, config);
    let regularised: Vec<String> = identifiability.unidentifiable.iter().map(|d| d.describe()).collect();
    if !regularised.is_empty() && config.unidentifiable == Unidentifiable::Refuse {
        return Err(CalibError::Unidentifiable(regularised));
    }
    let prior = identifiability.prior(p.len()).map(|lambda| (lambda, nominal.x.clone()));
    let calibrated = fit(&p, &nominal.x, &observations, &settings(free.clone(), prior.clone()), on_iteration)
        .map_err(|error| CalibError::Fit { stage: "calibration", error })?;
    let covariance = covariance(&calibrated, &free, prior.as_ref().map(|(l, _)| l));
    let held = |x: &DVector<f64>| -> Result<Option<ErrorSummary>, CalibError> {
        if held_out.is_empty() {
            return Ok(None);
        }
        let eval = evaluate(&p, x, &held_out, None, false).map_err(CalibError::HeldOut)?;
        Ok(Some(ErrorSummary::of(&eval.residuals)))
    };
    let before = Errors { fit: ErrorSummary::of(&nominal.evaluation.residuals), held_out: held(&nominal.x)? };
    let after = Errors { fit: ErrorSummary::of(&calibrated.evaluation.residuals), held_out: held(&calibrated.x)? };
    // Orientations fix R_CB; t_CB comes from the centre of rotation. When the poses leave the
    // centre undetermined (all about one axis) no registration is written rather than a made-up t_CB.
    let centre = vision.centre;
    let mut parameters = Parameters {
        markers: Vec::new(),
        latency_s: None,
        source: ParameterSource::Calibrated,
        model: Some(crate::files::tidy_path(&model.urdf_path).display().to_string()),
        legs: p.legs(&calibrated.x),
        camera: centre.map(|c| CameraRegistration {
            rotation: p.camera(&calibrated.x),
            translation: Vector3::from(c.position_m),
        }),
        fit: None,
    };
    let reports = parameter_reports(&p, &calibrated.x, &covariance, &free);
    let report = CalibrationReport {
        session: session.name.clone(),
        fit: FitLevel::Orientations,
        vision_method: config.vision_method,
        loss: config.loss,
        poses: session.poses.len(),
        fit_poses: observations.len(),
        held_out_poses: held_out.len(),
        excluded,
        before,
        after,
        iterations: calibrated.log.clone(),
        convergence: calibrated.status,
        not_significant: not_significant(&reports),
        parameters: reports,
        identifiability,
        regularised,
        high_correlations: correlations(&p, &covariance, 0.9),
        orientation_uncertainty_deg: orientation_uncertainty(&calibrated, &covariance),
        residual_sigma_deg: residual_sigmas(&calibrated.weighting),
        outliers: outliers(&observations, &calibrated, config.outlier_threshold),
        camera_translation_m: centre.map(|c| c.position_m),
        camera_translation_std_error_m: centre.map(|c| c.std_error_m),
        markers: None,
    };
    parameters.fit = Some(fit_header(&report));
    Ok(Calibration {
        parameters,
        report,
        parameterisation: p,
        observations,
        held_out,
        marker_observations: Vec::new(),
        nominal,
        calibrated,
        covariance,
        vision: Some(vision),
    })
}

/// Something to fit, and enough residuals (3 per observation) for the free parameters: checked
/// before anything indexes them.
pub(super) fn check_enough(free: &[bool], observations: usize) -> Result<(), CalibError> {
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
        });
    }
    Ok(())
}

/// The parameters whose change from nominal is under twice its standard error.
pub(super) fn not_significant(reports: &[ParameterReport]) -> Vec<String> {
    reports
        .iter()
        .filter(|r| r.std_error_deg.is_some_and(|se| r.change_deg.abs() < 2.0 * se))
        .map(|r| r.name.clone())
        .collect()
}

/// `JᵀWJ` of an outcome over every parameter (whitened, weighted), without copying the Jacobian.
fn weighted_gram(outcome: &FitOutcome) -> DMatrix<f64> {
    let all: Vec<usize> = (0..outcome.evaluation.jacobian.as_ref().map_or(0, |j| j.ncols())).collect();
    super::solver::weighted_normal(&outcome.evaluation, &outcome.weighting, &all).0
}

pub(super) fn identifiability_at(
    p: &Parameterisation,
    start: &FitOutcome,
    free: &[bool],
    config: &CalibConfig,
) -> Identifiability {
    let free_idx: Vec<usize> = (0..p.len()).filter(|&i| free[i]).collect();
    let names: Vec<String> = p.entries.iter().map(|e| e.name.clone()).collect();
    super::identify::analyse_gram(&weighted_gram(start), &free_idx, &names, config.min_singular_ratio)
}

/// `σ̂² (J̃ᵀ W J̃ + Λ)⁻¹` over the free parameters, embedded in the full vector; `σ̂²` is the weighted
/// whitened residual variance per degree of freedom (≈ 1 when the whitening fits the noise).
pub(super) fn covariance(outcome: &FitOutcome, free: &[bool], prior: Option<&DMatrix<f64>>) -> DMatrix<f64> {
    let n = free.len();
    let idx: Vec<usize> = (0..n).filter(|&i| free[i]).collect();
    let full_h = weighted_gram(outcome);
    let mut h = DMatrix::zeros(idx.len(), idx.len());
    for (a, &i) in idx.iter().enumerate() {
        for (b, &k) in idx.iter().enumerate() {
            h[(a, b)] = full_h[(i, k)] + prior.map_or(0.0, |l| l[(i, k)]);
        }
    }
    let w = &outcome.weighting;
    let m = outcome.evaluation.residuals.len();
    let chi2: f64 = outcome
        .evaluation
        .residuals
        .iter()
        .enumerate()
        .map(|(j, r)| w.weights[j] * w.whiten(j, r).norm_squared())
        .sum();
    let dof = (3 * m).saturating_sub(idx.len()).max(1) as f64;
    let inv = if h.iter().all(|x| x.is_finite()) {
        h.clone().pseudo_inverse(1e-14 * h.amax()).unwrap_or_else(|_| DMatrix::zeros(idx.len(), idx.len()))
    } else {
        DMatrix::from_element(idx.len(), idx.len(), f64::NAN)
    };
    let mut full = DMatrix::zeros(n, n);
    for (a, &i) in idx.iter().enumerate() {
        for (b, &k) in idx.iter().enumerate() {
            full[(i, k)] = inv[(a, b)] * chi2 / dof;
        }
    }
    full
}

pub(super) fn parameter_reports(
    p: &Parameterisation,
    x: &DVector<f64>,
    cov: &DMatrix<f64>,
    free: &[bool],
) -> Vec<ParameterReport> {
    p.entries
        .iter()
        .enumerate()
        .map(|(i, e)| ParameterReport {
            name: e.name.clone(),
            change_deg: x[i].to_degrees(),
            std_error_deg: free[i].then(|| cov[(i, i)].max(0.0).sqrt().to_degrees()),
            frozen: !free[i],
        })
        .collect()
}

pub(super) fn correlations(p: &Parameterisation, cov: &DMatrix<f64>, threshold: f64) -> Vec<Correlation> {
    let mut out = Vec::new();
    for i in 0..p.len() {
        for k in (i + 1)..p.len() {
            let d = (cov[(i, i)] * cov[(k, k)]).sqrt();
            if d > 0.0 && (cov[(i, k)] / d).abs() >= threshold {
                out.push(Correlation {
                    a: p.entries[i].name.clone(),
                    b: p.entries[k].name.clone(),
                    rho: cov[(i, k)] / d,
                });
            }
        }
    }
    out.sort_by(|a, b| b.rho.abs().total_cmp(&a.rho.abs()));
    out
}

/// Uncertainty (1σ, RMS over the three axes) of each pose's predicted orientation as the camera sees
/// it, `R_CB R_j Aᵀ`: the propagation `J_j Cov J_jᵀ` of the parameter covariance through the residual
/// Jacobian. The camera frame is where the prediction is checked, and it carries the strong
/// correlations between axis tilts and the camera rotation that a base-frame figure would ignore.
fn orientation_uncertainty(outcome: &FitOutcome, cov: &DMatrix<f64>) -> Option<Stats> {
    let jac = outcome.evaluation.jacobian.as_ref()?;
    let values: Vec<f64> = (0..outcome.evaluation.residuals.len())
        .map(|j| {
            let block = jac.rows(3 * j, 3);
            ((block * cov * block.transpose()).trace() / 3.0).max(0.0).sqrt().to_degrees()
        })
        .collect();
    Stats::of(&values)
}

fn residual_sigmas(w: &Weighting) -> Vec<(usize, usize, [f64; 3])> {
    w.classes.iter().map(|(m, n, c)| (*m, *n, [0, 1, 2].map(|i| c[(i, i)].max(0.0).sqrt().to_degrees()))).collect()
}

fn outliers(observations: &[Observation], outcome: &FitOutcome, threshold: f64) -> Vec<Outlier> {
    let w = &outcome.weighting;
    observations
        .iter()
        .zip(&outcome.evaluation.residuals)
        .zip(&w.weights)
        .enumerate()
        .filter(|(j, ((_, r), _))| w.whiten(*j, r).norm() > threshold * w.sigma)
        .map(|(_, x)| x)
        .map(|((o, r), weight)| Outlier { pose: o.pose, residual_deg: r.norm().to_degrees(), weight: *weight })
        .collect()
}

/// The `fit:` header of the parameters file.
pub(super) fn fit_header(report: &CalibrationReport) -> serde_yaml::Value {
    #[derive(Serialize)]
    struct Header<'a> {
        session: &'a str,
        vision_method: Method,
        loss: Loss,
        fit_poses: usize,
        held_out_poses: usize,
        iterations: usize,
        rms_before_deg: f64,
        rms_after_deg: f64,
        held_out_rms_before_deg: Option<f64>,
        held_out_rms_after_deg: Option<f64>,
        identifiable_directions: usize,
        free_parameters: usize,
        condition_number: f64,
        std_errors_deg: Vec<(&'a str, f64)>,
        camera_translation_std_error_m: Option<[f64; 3]>,
        #[serde(skip_serializing_if = "Option::is_none")]
        markers_rms_before_mm: Option<f64>,
        #[serde(skip_serializing_if = "Option::is_none")]
        markers_rms_after_mm: Option<f64>,
        #[serde(skip_serializing_if = "Option::is_none")]
        cross_validated_rms_mm: Option<[f64; 2]>,
        #[serde(skip_serializing_if = "Vec::is_empty")]
        warnings: Vec<&'a str>,
    }
    let markers = report.markers.as_ref();
    let header = Header {
        session: &report.session,
        vision_method: report.vision_method,
        loss: report.loss,
        fit_poses: report.fit_poses,
        held_out_poses: report.held_out_poses,
        iterations: report.iterations.len(),
        rms_before_deg: report.before.fit.rms_deg,
        rms_after_deg: report.after.fit.rms_deg,
        held_out_rms_before_deg: report.before.held_out.map(|e| e.rms_deg),
        held_out_rms_after_deg: report.after.held_out.map(|e| e.rms_deg),
        identifiable_directions: report.identifiability.rank,
        free_parameters: report.identifiability.parameters,
        condition_number: report.identifiability.condition,
        std_errors_deg: report
            .parameters
            .iter()
            .filter_map(|p| p.std_error_deg.map(|s| (p.name.as_str(), s)))
            .collect(),
        camera_translation_std_error_m: report.camera_translation_std_error_m,
        markers_rms_before_mm: markers.map(|m| m.before.rms_mm),
        markers_rms_after_mm: markers.map(|m| m.after.rms_mm),
        cross_validated_rms_mm: markers
            .and_then(|m| m.cross_validation.as_ref())
            .map(|cv| [cv.nominal_rms_mm, cv.calibrated_rms_mm]),
        warnings: markers.map(|m| m.warnings.iter().map(String::as_str).collect()).unwrap_or_default(),
    };
    serde_yaml::to_value(header).expect("the header serialises")
}
