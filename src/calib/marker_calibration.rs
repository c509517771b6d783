//! The marker-level calibration (`fit: markers`, the default): maximum likelihood over every
//! marker observation, with the stereo noise model estimated from the residuals, gross errors
//! excluded after the robust fit, and the error on unseen poses measured by k-fold
//! cross-validation while the parameters written come from every pose.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};
use serde::Serialize;

use super::calibrate::{
    CalibError, Calibration, CalibrationReport, ErrorSummary, Errors, MIN_MOTION_DEG, check_enough, correlations,
    covariance, fit_header, identifiability_at, not_significant, parameter_reports,
};
use super::config::{CalibConfig, FitLevel, Group, IfNotBetter, Loss, Unidentifiable};
use super::markers::{MarkerModel, MarkerObservation, StereoNoise, marker_observations};
use super::params::{Kind, Parameterisation};
use super::pose_errors::pose_errors;
use super::solver::{FitOutcome, FitSettings, IterationLog, Model as _, fit_model, weighted_normal_of};
use crate::dataset::{Session, Streams};
use crate::model::{CameraRegistration, MarkerPosition, ParameterSource, Parameters, RobotModel};
use crate::so3;
use crate::vision::{Method, Stats, estimate_session};

/// RMS, median and largest distance (mm) between measured and predicted markers.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarkerErrors {
    /// Observations summarised.
    pub observations: usize,
    /// RMS distance, mm.
    pub rms_mm: f64,
    /// Median distance, mm.
    pub median_mm: f64,
    /// Largest distance, mm.
    pub max_mm: f64,
    /// `(marker, observations, RMS mm)` per marker.
    pub per_marker: Vec<(String, usize, f64)>,
}

impl MarkerErrors {
    fn of(residuals: &[Vector3<f64>], observations: &[MarkerObservation], names: &[String]) -> Self {
        let mm: Vec<f64> = residuals.iter().map(|r| r.norm() * 1e3).collect();
        let stats = Stats::of(&mm).unwrap_or(Stats { mean: 0.0, median: 0.0, max: 0.0 });
        let rms = |values: &mut dyn Iterator<Item = f64>| {
            let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
            (sum / n.max(1) as f64).sqrt()
        };
        let per_marker = names
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let of_k: Vec<f64> =
                    observations.iter().zip(&mm).filter(|(o, _)| o.marker == k).map(|(_, d)| *d).collect();
                (name.clone(), of_k.len(), rms(&mut of_k.iter().copied()))
            })
            .collect();
        MarkerErrors {
            observations: mm.len(),
            rms_mm: rms(&mut mm.iter().copied()),
            median_mm: stats.median,
            max_mm: stats.max,
            per_marker,
        }
    }
}

/// The error on unseen poses: k-fold cross-validation, stations kept together.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrossValidation {
    /// Folds.
    pub folds: usize,
    /// Held-out observations predicted.
    pub observations: usize,
    /// RMS held-out marker error of the nominal model with its best-fit registration, mm.
    pub nominal_rms_mm: f64,
    /// The same for the calibrated model, mm.
    pub calibrated_rms_mm: f64,
    /// Mean reduction of the squared held-out error per observation (mm²), and its standard error:
    /// the calibration is clearly better when the reduction exceeds twice its standard error.
    pub reduction_mm2: f64,
    /// Standard error of `reduction_mm2`.
    pub reduction_std_error_mm2: f64,
    /// The calibrated model predicts unseen poses clearly better than the nominal one.
    pub clearly_better: bool,
}

/// A marker's fitted position against the model's.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarkerReport {
    /// Marker name.
    pub name: String,
    /// Observations of it used in the fit.
    pub observations: usize,
    /// The model's position in P, m.
    pub model_m: [f64; 3],
    /// The fitted position in P, m.
    pub fitted_m: [f64; 3],
    /// Fitted minus model, mm.
    pub change_mm: [f64; 3],
    /// Standard errors, mm (`None` when held at the model's value).
    pub std_error_mm: Option<[f64; 3]>,
}

/// An observation flagged by the robust fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlaggedObservation {
    /// Pose (capture) id.
    pub pose: u64,
    /// Marker name.
    pub marker: String,
    /// Line of `markers.csv` (0 when not read from a file).
    pub line: usize,
    /// Its residual, mm.
    pub residual_mm: f64,
    /// Its residual in robust standard deviations.
    pub sigmas: f64,
    /// Left out of the final fit (a gross error).
    pub excluded: bool,
}

/// The camera's latency behind the encoders, for a free-motion recording.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Latency {
    /// The latency (s): estimated, or as given when frozen.
    pub value_s: f64,
    /// Its standard error (s); `None` when frozen.
    pub std_error_s: Option<f64>,
}

/// What the marker-level calibration adds to the report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarkerFitReport {
    /// The camera latency of a free-motion recording.
    pub latency: Option<Latency>,
    /// Marker observations fitted.
    pub observations: usize,
    /// Distinct poses (encoder readings) among them.
    pub poses: usize,
    /// Nominal mechanism and markers with their best-fit registration.
    pub before: MarkerErrors,
    /// The calibrated model.
    pub after: MarkerErrors,
    /// The error on unseen poses, when cross-validated.
    pub cross_validation: Option<CrossValidation>,
    /// The stereo noise the residuals imply.
    pub stereo_noise: Option<StereoNoise>,
    /// Every marker's fitted position.
    pub markers: Vec<MarkerReport>,
    /// Observations the robust fit flagged (excluded ones first).
    pub flagged: Vec<FlaggedObservation>,
    /// Plain-language warnings: markers seen at too few poses, a calibration not clearly better.
    pub warnings: Vec<String>,
    /// Captures of a free-motion recording taken while a joint turned faster than
    /// `max_joint_speed_deg_s`: `(pose, marker, captures.csv line, deg/s)`, down-weighted.
    pub fast_captures: Vec<(u64, String, usize, f64)>,
}

/// The marker-level calibration of `session`.
pub(super) fn calibrate_markers(
    session: &Session,
    model: &RobotModel,
    config: &CalibConfig,
    on_iteration: &mut dyn FnMut(&IterationLog),
) -> Result<Calibration, CalibError> {
    let spm = &model.spm;
    let (mut observations, failed) = marker_observations(session, spm);
    let mut excluded: Vec<String> =
        failed.iter().map(|(pose, e)| format!("pose {pose}: nominal forward kinematics: {e}")).collect();
    let markers0 = model_markers(session, model)?;
    let mut warnings = Vec::new();
    // A marker seen at fewer than two poses cannot tell its position from the registration.
    let poses_seeing: Vec<usize> = (0..session.markers.len())
        .map(|k| {
            let mut poses: Vec<u64> = observations.iter().filter(|o| o.marker == k).map(|o| o.pose).collect();
            poses.dedup();
            poses.len()
        })
        .collect();
    let held_markers: Vec<usize> = (0..session.markers.len()).filter(|&k| poses_seeing[k] < 2).collect();
    for &k in &held_markers {
        warnings.push(format!(
            "marker `{}` is seen at {} pose(s): its position is held at the model's value",
            session.markers[k], poses_seeing[k]
        ));
    }
    let nominal_r =
        pose_orientations(spm.geometry(), &observations, &markers0, &session.markers).map_err(CalibError::HeldOut)?;
    let max_deg = largest_rotation(&nominal_r);
    let registration = initial_registration(&observations, &nominal_r, &markers0).ok_or(CalibError::Registration)?;
    let p = Parameterisation::for_markers(*spm.geometry(), &registration, &markers0, &session.markers, &config.bounds);
    // A free-motion recording: the camera's latency is a parameter (frozen: `latency_s` as given).
    let streams = session.streams.as_ref();
    let p = match streams {
        Some(_) => p.with_latency(config.latency_s, config.latency_bound_s),
        None => p,
    };
    let free: Vec<bool> = p
        .entries
        .iter()
        .map(|e| {
            !config.freeze.contains(&e.kind.group())
                && !matches!(e.kind, Kind::Marker { marker, .. } if held_markers.contains(&marker))
        })
        .collect();
    check_enough(&free, observations.len())?;
    let settings = |free: Vec<bool>, prior| FitSettings { prior, ..FitSettings::from_config(config, free) };
    let registration_only = registration_mask(&p, &free);
    let x0 = DVector::zeros(p.len());
    let model_m = marker_model(&p, &observations, streams, config.max_joint_speed_deg_s);
    let nominal = baseline(&p, &observations, streams, &x0, &registration_only, config)?;
    let identifiability = identifiability_at(&p, &nominal, &free, config);
    let regularised: Vec<String> = identifiability.unidentifiable.iter().map(|d| d.describe()).collect();
    // A session that barely moves is refused, with what it cannot tell apart.
    if max_deg < MIN_MOTION_DEG {
        let mut unidentifiable = regularised.clone();
        if unidentifiable.is_empty() {
            unidentifiable = identifiability.weakest.iter().map(|d| d.describe()).collect();
        }
        return Err(CalibError::NoMotion { max_deg, unidentifiable });
    }
    if !regularised.is_empty() && config.unidentifiable == Unidentifiable::Refuse {
        return Err(CalibError::Unidentifiable(regularised));
    }
    let prior = identifiability.prior(p.len()).map(|lambda| (lambda, nominal.x.clone()));
    let robust = fit_model(&model_m, &nominal.x, &settings(free.clone(), prior.clone()), on_iteration)
        .map_err(|error| CalibError::Fit { stage: "calibration", error })?;
    // Gross errors (centimetres) are removed, not only down-weighted: they would still pull.
    let mut flagged = flag(&model_m, &robust, &session.markers, config.outlier_threshold);
    let gross: Vec<usize> = flagged.iter().filter(|(_, f)| f.excluded).map(|(j, _)| *j).collect();
    let calibrated = if gross.is_empty() {
        robust
    } else {
        observations = observations.iter().enumerate().filter(|(j, _)| !gross.contains(j)).map(|(_, o)| *o).collect();
        let refit = marker_model(&p, &observations, streams, config.max_joint_speed_deg_s);
        let outcome = fit_model(&refit, &robust.x, &settings(free.clone(), prior.clone()), &mut |_| {})
            .map_err(|error| CalibError::Fit { stage: "calibration without the gross errors", error })?;
        flagged.retain(|(_, f)| f.excluded);
        flagged.extend(flag(&refit, &outcome, &session.markers, config.outlier_threshold));
        outcome
    };
    excluded.extend(
        flagged
            .iter()
            .filter(|(_, f)| f.excluded)
            .map(|(_, f)| format!("pose {} marker {} (markers.csv line {}): gross error", f.pose, f.marker, f.line)),
    );
    let model_m = marker_model(&p, &observations, streams, config.max_joint_speed_deg_s);
    // The baseline on the same observations as the calibration (without the gross errors).
    let nominal = if gross.is_empty() {
        nominal
    } else {
        baseline(&p, &observations, streams, &nominal.x, &registration_only, config)?
    };
    let before = MarkerErrors::of(&nominal.evaluation.residuals, &observations, &session.markers);
    let after = MarkerErrors::of(&calibrated.evaluation.residuals, &observations, &session.markers);
    let covariance = covariance(&calibrated, &free, prior.as_ref().map(|(l, _)| l));
    let cross_validation =
        cross_validate(&model_m, [&nominal, &calibrated], [&free, &registration_only], prior.as_ref(), config.folds)?;
    if let Some(cv) = cross_validation.as_ref().filter(|cv| !cv.clearly_better) {
        let warning = not_better_warning(cv, &identifiability.unidentifiable, &model_m);
        if config.if_not_better == IfNotBetter::Refuse {
            return Err(CalibError::NotBetter(warning));
        }
        warnings.push(warning);
    }
    let x = &calibrated.x;
    let camera = CameraRegistration { rotation: p.camera(x), translation: p.translation(x) };
    let translation_se = index_of(&p, |k| matches!(k, Kind::Translation { .. }))
        .filter(|i| i.iter().all(|&i| free[i]))
        .map(|i| i.map(|i| covariance[(i, i)].max(0.0).sqrt()));
    let marker_reports = marker_reports(&p, x, &covariance, &free, &observations, &session.markers);
    let parameters_markers = marker_reports
        .iter()
        .map(|m| MarkerPosition {
            name: m.name.clone(),
            position: Vector3::from(m.fitted_m),
            std_error: m.std_error_mm.map(|s| Vector3::from(s) * 1e-3),
        })
        .collect();
    let reports: Vec<_> = parameter_reports(&p, x, &covariance, &free)
        .into_iter()
        .zip(&p.entries)
        .filter(|(_, e)| !matches!(e.kind, Kind::Translation { .. } | Kind::Marker { .. } | Kind::Latency))
        .map(|(r, _)| r)
        .collect();
    // Per pose, in degrees, where the per-pose estimator has something to work on: the nominal
    // model with its best-fit registration, the calibrated one with its own.
    let parameters = Parameters {
        source: ParameterSource::Calibrated,
        model: Some(crate::files::tidy_path(&model.urdf_path).display().to_string()),
        legs: p.legs(x),
        camera: Some(camera),
        markers: parameters_markers,
        latency_s: p.entries.iter().any(|e| e.kind == Kind::Latency).then(|| p.latency(x)),
        fit: None,
    };
    let vision = estimate_session(session, Method::Kabsch).ok();
    let per_pose = |params: &Parameters| {
        let fit = vision.as_ref().and_then(|v| pose_errors(session, v, params).ok()).map(|e| e.summary);
        Errors { fit: fit.unwrap_or_else(|| ErrorSummary::of(&[])), held_out: None }
    };
    let (before_deg, after_deg) = (per_pose(&Parameters::nominal(spm, None)), per_pose(&parameters));
    let report = CalibrationReport {
        session: session.name.clone(),
        fit: FitLevel::Markers,
        vision_method: Method::Kabsch,
        loss: config.loss,
        poses: session.poses.len(),
        fit_poses: model_m.poses(),
        held_out_poses: 0,
        excluded,
        before: before_deg,
        after: after_deg,
        iterations: calibrated.log.clone(),
        convergence: calibrated.status,
        not_significant: not_significant(&reports),
        parameters: reports,
        identifiability,
        regularised,
        high_correlations: correlations(&p, &covariance, 0.9),
        orientation_uncertainty_deg: orientation_uncertainty(&calibrated, &covariance),
        residual_sigma_deg: Vec::new(),
        outliers: Vec::new(),
        camera_translation_m: Some(camera.translation.into()),
        camera_translation_std_error_m: translation_se,
        markers: Some(MarkerFitReport {
            latency: p.entries.iter().position(|e| e.kind == Kind::Latency).map(|i| Latency {
                value_s: p.latency(x),
                std_error_s: free[i].then(|| covariance[(i, i)].max(0.0).sqrt()),
            }),
            observations: observations.len(),
            poses: model_m.poses(),
            before,
            after,
            cross_validation,
            stereo_noise: calibrated.weighting.stereo,
            markers: marker_reports,
            flagged: flagged.into_iter().map(|(_, f)| f).collect(),
            fast_captures: streams.map_or_else(Vec::new, |st| {
                observations
                    .iter()
                    .zip(joint_speeds(&observations, st, &p))
                    .filter(|(_, v)| *v > config.max_joint_speed_deg_s)
                    .map(|(o, v)| (o.pose, session.markers[o.marker].clone(), o.line, v))
                    .collect()
            }),
            warnings,
        }),
    };
    let mut parameters = parameters;
    parameters.fit = Some(fit_header(&report));
    let marker_observations = at_fitted_latency(observations, streams, &p, &calibrated.x);
    Ok(Calibration {
        parameters,
        report,
        parameterisation: p,
        observations: Vec::new(),
        held_out: Vec::new(),
        marker_observations,
        nominal,
        calibrated,
        covariance,
        vision: None,
    })
}

/// The nominal model with its best-fit registration (least squares, as `compare` fits it), with
/// the full Jacobian at its solution for the identifiability analysis and the cross-validation.
pub(super) fn baseline(
    p: &Parameterisation,
    observations: &[MarkerObservation],
    streams: Option<&Streams>,
    start: &DVector<f64>,
    registration_only: &[bool],
    config: &CalibConfig,
) -> Result<FitOutcome, CalibError> {
    let fail = |error| CalibError::Fit { stage: "nominal registration", error };
    let settings =
        FitSettings { loss: Loss::LeastSquares, ..FitSettings::from_config(config, registration_only.to_vec()) };
    let model = marker_model(p, observations, streams, config.max_joint_speed_deg_s);
    let light =
        marker_model(p, observations, streams, config.max_joint_speed_deg_s).with_columns(registration_only.to_vec());
    let mut outcome = fit_model(&light, start, &settings, &mut |_| {}).map_err(fail)?;
    outcome.evaluation = model
        .evaluate(&outcome.x, Some(&outcome.evaluation.orientations), true)
        .map_err(|e| fail(super::solver::FitError::Start(e)))?;
    Ok(outcome)
}

/// The observations with their joints read at the fitted latency, so that whoever evaluates them
/// without the streams (the recordings) sees the fit's own poses.
fn at_fitted_latency(
    mut observations: Vec<MarkerObservation>,
    streams: Option<&Streams>,
    p: &Parameterisation,
    x: &DVector<f64>,
) -> Vec<MarkerObservation> {
    if let Some(s) = streams.filter(|_| p.entries.iter().any(|e| e.kind == Kind::Latency)) {
        let tau = p.latency(x);
        for o in observations.iter_mut() {
            if let Some(joints) = o.time_s.and_then(|t| s.joints_at(t - tau)) {
                o.joints = joints;
            }
        }
    }
    observations
}

/// The marker-level model of `observations`, reading a recording's `streams` when there are.
fn marker_model<'a>(
    p: &'a Parameterisation,
    observations: &'a [MarkerObservation],
    streams: Option<&'a Streams>,
    max_speed: f64,
) -> MarkerModel<'a> {
    match streams {
        Some(s) => {
            let inflation = fast_inflation(observations, s, p, max_speed);
            MarkerModel::new(p, observations).with_streams(s).with_inflation(inflation)
        }
        None => MarkerModel::new(p, observations),
    }
}

/// The fastest joint's speed (deg/s) at each observation's capture, at the starting latency.
fn joint_speeds(observations: &[MarkerObservation], streams: &Streams, p: &Parameterisation) -> Vec<f64> {
    observations
        .iter()
        .map(|o| o.time_s.and_then(|t| streams.velocity_at(t - p.latency0)).map_or(0.0, |v| v.amax().to_degrees()))
        .collect()
}

/// Noise inflation of each observation: `max(1, speed / max_speed)` — a capture taken while a
/// joint turns faster than `max_speed` (deg/s) is blurred or badly interpolated.
fn fast_inflation(
    observations: &[MarkerObservation],
    streams: &Streams,
    p: &Parameterisation,
    max_speed: f64,
) -> Vec<f64> {
    joint_speeds(observations, streams, p).into_iter().map(|v| (v / max_speed).max(1.0)).collect()
}

/// The model's position of each of the session's markers.
pub(super) fn model_markers(session: &Session, model: &RobotModel) -> Result<Vec<Vector3<f64>>, CalibError> {
    session
        .markers
        .iter()
        .map(|name| {
            model.markers.iter().find(|m| &m.name == name).map(|m| m.position).ok_or_else(|| CalibError::Config {
                key: "markers".into(),
                reason: format!("the session's marker `{name}` is not among the model's markers"),
            })
        })
        .collect()
}

/// The largest rotation (degrees) of the MP between the first pose and any other, by the nominal FDA.
fn largest_rotation(rotations: &[Rotation3<f64>]) -> f64 {
    let first = rotations.first().copied().unwrap_or_else(Rotation3::identity);
    rotations.iter().map(|r| so3::geodesic_angle(r, &first).to_degrees()).fold(0.0, f64::max)
}

/// The rigid motion that best carries the nominal model's markers (in B) onto the measured ones
/// (in C): Kabsch over every observation. Needs no pose with three markers.
pub(super) fn initial_registration(
    observations: &[MarkerObservation],
    nominal: &[Rotation3<f64>],
    markers: &[Vector3<f64>],
) -> Option<CameraRegistration> {
    let pairs: Vec<(Vector3<f64>, Vector3<f64>)> =
        observations.iter().zip(nominal).map(|(o, r)| (r * markers[o.marker], o.measured)).collect();
    if pairs.len() < 3 {
        return None;
    }
    let n = pairs.len() as f64;
    let cb = pairs.iter().map(|(b, _)| b).sum::<Vector3<f64>>() / n;
    let cc = pairs.iter().map(|(_, c)| c).sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = pairs.iter().map(|(b, c)| (c - cc) * (b - cb).transpose()).sum();
    let rotation = so3::nearest_rotation(&h)?;
    Some(CameraRegistration { rotation, translation: cc - rotation * cb })
}

/// The orientation `legs` give each observation's pose (one FDA per pose, not per marker).
pub(super) fn pose_orientations(
    legs: &[crate::model::LegGeometry; 3],
    observations: &[MarkerObservation],
    markers: &[Vector3<f64>],
    names: &[String],
) -> Result<Vec<Rotation3<f64>>, super::residual::EvalError> {
    let origin = CameraRegistration { rotation: Rotation3::identity(), translation: Vector3::zeros() };
    let p = Parameterisation::for_markers(*legs, &origin, markers, names, &CalibConfig::default().bounds);
    let model = MarkerModel::new(&p, observations);
    let at_pose = model.evaluate(&DVector::zeros(p.len()), None, false)?.orientations;
    Ok((0..observations.len()).map(|j| at_pose[model.pose_of(j)]).collect())
}

/// The registration parameters (camera rotation and translation) that are free.
pub(super) fn registration_mask(p: &Parameterisation, free: &[bool]) -> Vec<bool> {
    p.entries
        .iter()
        .zip(free)
        .map(|(e, &f)| f && matches!(e.kind.group(), Group::CameraRotation | Group::CameraTranslation))
        .collect()
}

/// Observations beyond `threshold` robust standard deviations; beyond twice that, gross errors.
fn flag(
    model: &MarkerModel,
    outcome: &FitOutcome,
    names: &[String],
    threshold: f64,
) -> Vec<(usize, FlaggedObservation)> {
    let w = &outcome.weighting;
    let mut out: Vec<(usize, FlaggedObservation)> = outcome
        .evaluation
        .residuals
        .iter()
        .enumerate()
        .filter_map(|(j, r)| {
            let sigmas = w.whiten(j, r).norm() / w.sigma;
            let o = &model.observations[j];
            (sigmas > threshold).then(|| {
                let f = FlaggedObservation {
                    pose: o.pose,
                    marker: names[o.marker].clone(),
                    line: o.line,
                    residual_mm: r.norm() * 1e3,
                    sigmas,
                    excluded: sigmas > 2.0 * threshold,
                };
                (j, f)
            })
        })
        .collect();
    out.sort_by(|a, b| b.1.sigmas.total_cmp(&a.1.sigmas));
    out
}

/// The fold of each observation: groups (stations, else poses) dealt out in order of appearance.
pub(crate) fn fold_assignment(observations: &[MarkerObservation], k: usize) -> Vec<usize> {
    let mut groups: std::collections::HashMap<(bool, u64), usize> = std::collections::HashMap::new();
    observations
        .iter()
        .map(|o| {
            let key = o.station.map_or((false, o.pose), |s| (true, s));
            let next = groups.len();
            *groups.entry(key).or_insert(next) % k
        })
        .collect()
}

/// k-fold cross-validation: each fold's observations predicted by the model fitted without them,
/// the nominal model (registration fitted without them) alongside.
///
/// The fit without a fold is one Gauss–Newton step from the full fit, `x_f = x − H_f⁻¹ g_f`, with
/// `H_f`, `g_f` the normal equations of the other folds at `x` (weights and noise model of the full
/// fit): the full solution is a minimum of the sum over all folds, so leaving one out moves it by
/// a small step that one Newton step on a nearly linear least-squares problem takes to second
/// order (tests/markers.rs checks it against refitting). Each fold costs a 33 × 33 solve and an
/// evaluation, not a fit.
fn cross_validate(
    model: &MarkerModel,
    [nominal, calibrated]: [&FitOutcome; 2],
    [free, registration_only]: [&[bool]; 2],
    prior: Option<&(DMatrix<f64>, DVector<f64>)>,
    folds: usize,
) -> Result<Option<CrossValidation>, CalibError> {
    if folds < 2 {
        return Ok(None);
    }
    let fold_of = fold_assignment(model.observations, folds);
    let (mut nominal_sq, mut calibrated_sq) = (Vec::new(), Vec::new());
    let by_fold = [
        FoldNormals::new(nominal, registration_only, &fold_of, folds),
        FoldNormals::new(calibrated, free, &fold_of, folds),
    ];
    for fold in 0..folds {
        let test: Vec<MarkerObservation> =
            (0..fold_of.len()).filter(|&j| fold_of[j] == fold).map(|j| model.observations[j]).collect();
        if test.is_empty() || test.len() == fold_of.len() {
            continue;
        }
        let test_model = marker_model(model.p, &test, model.streams(), f64::INFINITY);
        // Each test pose's FDA starts from the full fit's orientation of it.
        let full_pose: Vec<usize> =
            (0..fold_of.len()).filter(|&j| fold_of[j] == fold).map(|j| model.pose_of(j)).collect();
        let warm_for = |outcome: &FitOutcome| -> Vec<nalgebra::Rotation3<f64>> {
            let mut warm = Vec::with_capacity(test_model.poses());
            for (a, &full) in full_pose.iter().enumerate() {
                if warm.len() == test_model.pose_of(a) {
                    warm.push(outcome.evaluation.orientations[full]);
                }
            }
            warm
        };
        for (outcome, normals, prior, out) in
            [(nominal, &by_fold[0], None, &mut nominal_sq), (calibrated, &by_fold[1], prior, &mut calibrated_sq)]
        {
            let x = normals.leave_out(&outcome.x, fold, prior);
            let eval = test_model.evaluate(&x, Some(&warm_for(outcome)), false).map_err(CalibError::HeldOut)?;
            out.extend(eval.residuals.iter().map(|r| r.norm_squared() * 1e6));
        }
    }
    let n = nominal_sq.len();
    if n == 0 {
        return Ok(None);
    }
    let d: Vec<f64> = nominal_sq.iter().zip(&calibrated_sq).map(|(a, b)| a - b).collect();
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64;
    let se = (var / n as f64).sqrt();
    let rms = |v: &[f64]| (v.iter().sum::<f64>() / v.len() as f64).sqrt();
    Ok(Some(CrossValidation {
        folds,
        observations: n,
        nominal_rms_mm: rms(&nominal_sq),
        calibrated_rms_mm: rms(&calibrated_sq),
        reduction_mm2: mean,
        reduction_std_error_mm2: se,
        clearly_better: mean > 2.0 * se,
    }))
}

/// The normal equations of a fit split by fold: `H = Σ_k H_k`, `g = Σ_k g_k` over the free
/// parameters, each fold's from its own rows of the whitened, weighted Jacobian.
struct FoldNormals {
    free: Vec<usize>,
    h: Vec<DMatrix<f64>>,
    g: Vec<DVector<f64>>,
}

impl FoldNormals {
    fn new(outcome: &FitOutcome, free: &[bool], fold_of: &[usize], folds: usize) -> Self {
        let free: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
        let (h, g) = (0..folds)
            .map(|fold| {
                let rows: Vec<usize> = (0..fold_of.len()).filter(|&j| fold_of[j] == fold).collect();
                weighted_normal_of(&outcome.evaluation, &outcome.weighting, &free, &rows)
            })
            .unzip();
        FoldNormals { free, h, g }
    }

    /// The parameters fitted without fold `fold`: one Gauss–Newton step from `x`.
    fn leave_out(&self, x: &DVector<f64>, fold: usize, prior: Option<&(DMatrix<f64>, DVector<f64>)>) -> DVector<f64> {
        let mut h: DMatrix<f64> = self.h.iter().enumerate().filter(|(k, _)| *k != fold).map(|(_, h)| h).sum();
        let mut g: DVector<f64> = self.g.iter().enumerate().filter(|(k, _)| *k != fold).map(|(_, g)| g).sum();
        if let Some((lambda, x0)) = prior {
            let d = x - x0;
            for (a, &i) in self.free.iter().enumerate() {
                g[a] += (lambda.row(i) * &d)[0];
                for (b, &k) in self.free.iter().enumerate() {
                    h[(a, b)] += lambda[(i, k)];
                }
            }
        }
        let mut moved = x.clone();
        if let Some(step) = h.cholesky().map(|c| c.solve(&g)) {
            for (a, &i) in self.free.iter().enumerate() {
                moved[i] -= step[a];
            }
        }
        moved
    }
}

/// Why the calibrated model may not be better, in words.
fn not_better_warning(cv: &CrossValidation, weak: &[super::identify::Direction], model: &MarkerModel) -> String {
    let mut cause = if model.poses() < 40 {
        format!("only {} poses: capture more, spread over the workspace", model.poses())
    } else {
        "the poses may be too similar: spread them over the workspace".to_string()
    };
    if let Some(d) = weak.first() {
        cause += &format!("; weakest direction {}", d.describe());
    }
    format!(
        "the calibrated model does not predict unseen poses clearly better than the nominal one \
         ({:.3} mm against {:.3} mm RMS, {}-fold cross-validation): {cause}",
        cv.calibrated_rms_mm, cv.nominal_rms_mm, cv.folds
    )
}

fn index_of(p: &Parameterisation, matches: impl Fn(Kind) -> bool) -> Option<[usize; 3]> {
    let idx: Vec<usize> = p.entries.iter().enumerate().filter(|(_, e)| matches(e.kind)).map(|(i, _)| i).collect();
    (idx.len() == 3).then(|| [idx[0], idx[1], idx[2]])
}

fn marker_reports(
    p: &Parameterisation,
    x: &DVector<f64>,
    cov: &DMatrix<f64>,
    free: &[bool],
    observations: &[MarkerObservation],
    names: &[String],
) -> Vec<MarkerReport> {
    names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let idx = index_of(p, |kind| matches!(kind, Kind::Marker { marker, .. } if marker == k));
            let fitted = p.marker(x, k);
            let std_error_mm =
                idx.filter(|i| i.iter().all(|&i| free[i])).map(|i| i.map(|i| cov[(i, i)].max(0.0).sqrt() * 1e3));
            MarkerReport {
                name: name.clone(),
                observations: observations.iter().filter(|o| o.marker == k).count(),
                model_m: p.markers0[k].into(),
                fitted_m: fitted.into(),
                change_mm: ((fitted - p.markers0[k]) * 1e3).into(),
                std_error_mm,
            }
        })
        .collect()
}

/// Uncertainty (1σ, RMS over the three axes, degrees) of each pose's predicted orientation in B:
/// the parameter covariance propagated through `∂ω/∂x`.
fn orientation_uncertainty(outcome: &FitOutcome, cov: &DMatrix<f64>) -> Option<Stats> {
    let sens = outcome.evaluation.orientation_jacobians.as_ref()?;
    let values: Vec<f64> =
        sens.iter().map(|s| ((s * cov * s.transpose()).trace() / 3.0).max(0.0).sqrt().to_degrees()).collect();
    Stats::of(&values)
}
