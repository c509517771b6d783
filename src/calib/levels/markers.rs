//! The marker-level fit (`fit: markers`, the default): maximum likelihood over every marker
//! observation with the encoder reading of its own capture, under the stereo noise model; the
//! markers' positions, `t_CB` and (for a free-motion recording) the camera's latency and clock
//! rate are parameters like the mechanism's.

use nalgebra::{DMatrix, DVector, Vector3};

use crate::calib::agreement::{
    MarkerErrors, SetError, corrected_for, largest_rotation, model_markers, pose_errors, pose_orientations,
};
use crate::calib::calibration::{CalibError, Fitted};
use crate::calib::config::{CalibConfig, Group, PredictionWorkspace};
use crate::calib::level::{Level, LevelReport, LevelResults, Origin};
use crate::calib::marker_residuals::{MarkerObservation, MarkerResiduals};
use crate::calib::parameterisation::{Kind, Parameterisation};
use crate::calib::registration;
use crate::calib::report::{
    CameraModelReport, CameraTermReport, ClockRate, ErrorStats, FastCapture, Latency, MarkerFitReport, MarkerReport,
    observations_file,
};
use crate::calib::residuals::Residuals;
use crate::calib::rig_terms;
use crate::calib::uncertainty::{
    parameter_reports, platform_sag_std_error_deg, predicted_marker_error, released, std_error,
};
use crate::calib::workspace::PredictionPoses;
use crate::dataset::{Session, Streams};
use crate::math::stats::Stats;
use crate::model::{
    CameraModel, CameraModelKind, CameraRegistration, CameraTerm, MarkerPosition, ParameterSource, Parameters,
    RobotModel,
};
use crate::vision::{Method, SessionEstimate};

/// A session's marker observations, ready to fit.
pub(crate) struct MarkerLevel<'s> {
    p: Parameterisation,
    observations: Vec<MarkerObservation>,
    streams: Option<&'s Streams>,
    names: Vec<String>,
    /// Markers seen at fewer than two poses: held at the model's position.
    held_markers: Vec<usize>,
    max_joint_speed_deg_s: f64,
    /// The camera model fitted (`camera_model`); a rigid one carries the depth scale held at its
    /// start, for the report to test.
    camera_model: CameraModelKind,
    freeze: Vec<Group>,
    max_deg: f64,
    /// The config's `workspace`: what the predicted error is for.
    workspace: Option<PredictionWorkspace>,
    excluded: Vec<String>,
    warnings: Vec<String>,
    /// Why the camera clock's rate is held (a recording's), if it is.
    clock_held: Option<&'static str>,
    /// The camera time the recording spans (s; 0 without streams).
    span_s: f64,
}

/// Why the camera clock's rate of `session`'s recording is held at `clock_rate_ppm` rather than
/// estimated under `config`: `frozen`, `orientations` (that fit holds it), `short_recording`
/// (the recording spans less than `clock_rate_min_duration_s`); `None`: the marker-level fit
/// estimates it (and for a session without streams, which has no clock).
pub(crate) fn clock_rate_held(session: &Session, config: &CalibConfig) -> Option<&'static str> {
    let streams = session.streams.as_deref()?;
    match () {
        _ if config.freeze.contains(&Group::ClockRate) => Some("frozen"),
        _ if config.fit != crate::calib::config::FitLevel::Markers => Some("orientations"),
        _ if streams.camera_span_s() < config.clock_rate_min_duration_s => Some("short_recording"),
        _ => None,
    }
}

impl<'s> MarkerLevel<'s> {
    /// The observations of `session` on `robot`'s nominal model, registered.
    pub(crate) fn prepare(session: &'s Session, robot: &RobotModel, config: &CalibConfig) -> Result<Self, CalibError> {
        let spm = &robot.spm;
        let (observations, failed) = MarkerObservation::of_session(session, spm);
        let excluded = failed.iter().map(|(pose, e)| format!("pose {pose}: nominal forward kinematics: {e}")).collect();
        // A rigid body's origin is the one "marker", its start fitted below.
        let names = session.observed_names();
        let markers0 = match session.body {
            Some(_) => vec![Vector3::zeros()],
            None => model_markers(&session.markers, robot).map_err(|e| match e {
                SetError::UnknownMarker(name) => CalibError::UnknownMarker(name),
                other => CalibError::Config { key: "markers".into(), reason: other.to_string() },
            })?,
        };
        // A marker seen at fewer than two poses cannot tell its position from the registration.
        let poses_seeing: Vec<usize> = (0..names.len())
            .map(|k| {
                let mut poses: Vec<u64> = observations.iter().filter(|o| o.marker == k).map(|o| o.pose).collect();
                poses.dedup();
                poses.len()
            })
            .collect();
        let held_markers: Vec<usize> = (0..names.len()).filter(|&k| poses_seeing[k] < 2).collect();
        let warnings = held_markers
            .iter()
            .map(|&k| {
                format!(
                    "marker `{}` is seen at {} pose(s): its position is held at the model's value",
                    names[k], poses_seeing[k]
                )
            })
            .collect();
        let nominal_r = pose_orientations(spm, &observations, &markers0).map_err(CalibError::Nominal)?;
        let (registration, body_frame, markers0) = match (session.rig.as_deref(), &session.body) {
            (Some(rig), _) => (registration::from_pixels(&observations, &nominal_r, &markers0, rig), None, markers0),
            (None, Some(_)) => match registration::from_body(&observations, &nominal_r) {
                Some((registration, a, origin)) => (Some(registration), Some(a), vec![origin]),
                None => (None, None, markers0),
            },
            (None, None) => (registration::from_markers(&observations, &nominal_r, &markers0), None, markers0),
        };
        let registration = registration.ok_or(CalibError::MarkerRegistration { observations: observations.len() })?;
        // Pixels are seen through the rig, which is refined instead of a camera model; `auto` is
        // resolved before the level is prepared (the pipeline runs its choice as named).
        // A tracker's rigid body has no line of sight: nothing of a stereo camera's model applies.
        let camera_model = match session.rig.is_some() || session.body.is_some() {
            true => CameraModelKind::Rigid,
            false => config.camera_model_or_rigid(),
        };
        let carried = match camera_model {
            CameraModelKind::Rigid if session.rig.is_none() && session.body.is_none() => CameraModelKind::DepthScale,
            kind => kind,
        };
        let start = config.camera_terms.model(carried);
        let mut p =
            Parameterisation::for_markers(*spm.geometry(), &registration, &markers0, &names, start, &config.bounds)
                .with_platform_sag(spm.platform_sag());
        if let (Some(a), Some(body)) = (body_frame, &session.body) {
            p = p.with_body_frame(a, body);
        }
        bound_perspective(&mut p, &start, config.bounds.camera_term);
        let p = match &session.rig {
            Some(rig) => p.with_rig(rig.clone(), &config.rig_terms),
            None => p,
        };
        // A free-motion recording: the camera's latency is a parameter (frozen: `latency_s` as
        // given), and its clock's rate unless held (at `clock_rate_ppm`, without an entry).
        let streams = session.streams.as_deref();
        let clock_held = clock_rate_held(session, config);
        let mut p = match streams {
            // The fit starts at `latency_s` and keeps the latency within ±`latency_bound_s`: the
            // frames were chosen for that range, and a parameters file holds no more. The same
            // for the clock rate.
            Some(_) if clock_held.is_none() => {
                p.with_latency(config.latency_s, config.latency_bound_s).with_clock_rate(
                    config.clock_rate_ppm,
                    config.clock_rate_bound_ppm,
                    streams.map_or(1.0, Streams::camera_span_s),
                )
            }
            Some(_) => p.with_latency(config.latency_s, config.latency_bound_s),
            None => p,
        };
        p.clock_rate_start_ppm = config.clock_rate_ppm;
        let span_s = streams.map_or(0.0, Streams::camera_span_s);
        let mut warnings: Vec<String> = warnings;
        if clock_held == Some("short_recording") {
            warnings.push(format!(
                "the camera clock's rate is held at {} ppm: the recording spans {span_s:.1} s, shorter than `clock_rate_min_duration_s` = {} s (the latency is then the recording's average)",
                config.clock_rate_ppm, config.clock_rate_min_duration_s
            ));
        }
        Ok(MarkerLevel {
            p,
            observations,
            streams,
            names,
            held_markers,
            max_joint_speed_deg_s: config.max_joint_speed_deg_s,
            camera_model,
            freeze: config.frozen_groups(),
            max_deg: largest_rotation(&nominal_r),
            workspace: config.workspace,
            excluded,
            warnings,
            clock_held,
            span_s,
        })
    }
}

impl Level for MarkerLevel<'_> {
    type Problem<'a>
        = MarkerResiduals<'a>
    where
        Self: 'a;

    fn parameterisation(&self) -> &Parameterisation {
        &self.p
    }

    fn problem(&self) -> MarkerResiduals<'_> {
        let model = MarkerResiduals::new(&self.p, &self.observations);
        match self.streams {
            Some(s) => {
                let inflation = fast_inflation(&self.observations, s, &self.p, self.max_joint_speed_deg_s);
                model.with_streams(s).with_inflation(inflation)
            }
            None => model,
        }
    }

    fn free(&self) -> Vec<bool> {
        self.p
            .entries
            .iter()
            .map(|e| {
                !self.freeze.contains(&e.kind.group())
                    && !matches!(e.kind, Kind::Marker { marker, .. } if self.held_markers.contains(&marker))
                    && !matches!(e.kind, Kind::CameraTerm { term } if !self.camera_model.terms().contains(&term))
            })
            .collect()
    }

    fn motion_deg(&self) -> f64 {
        self.max_deg
    }

    fn origin(&self, model: &MarkerResiduals<'_>, j: usize) -> Origin {
        let o = &model.observations()[j];
        (o.pose, Some(self.names[o.marker].clone()), o.line)
    }

    fn finish(&self, r: LevelResults<'_, MarkerResiduals<'_>>) -> Result<LevelReport, CalibError> {
        let (p, x, cov, free) = (&self.p, &r.calibrated.x, r.covariance, &r.free);
        let observations = r.problem.observations();
        let camera = CameraRegistration { rotation: p.camera(x), translation: p.translation(x) };
        let marker_reports = marker_reports(p, x, cov, free, observations, &self.names);
        let (camera_report, camera_warnings) = self.camera_report(&r);
        // The fitted model under the kind asked for (a rigid fit's carried depth scale is held at 1),
        // each fitted term with its standard error.
        let camera_model =
            p.entries.iter().enumerate().fold(p.camera_model(x).with_kind(self.camera_model), |m, (i, e)| {
                match e.kind {
                    Kind::CameraTerm { term } => m.with(term, m.value(term), std_error(cov, free, i)),
                    _ => m,
                }
            });
        let parameters = Parameters {
            source: ParameterSource::Calibrated,
            model: Some(r.robot.reference().display().to_string()),
            model_sha256: Some(r.robot.sha256.clone()),
            legs: p.legs(x),
            camera: Some(camera),
            camera_model,
            markers: marker_reports
                .iter()
                .map(|m| MarkerPosition {
                    name: m.name.clone(),
                    position: Vector3::from(m.fitted_m),
                    std_error: m.std_error_mm.map(|s| Vector3::from(s) * 1e-3),
                    rotation: m.rotation_wxyz.and_then(crate::math::so3::from_wxyz),
                    rotation_std_error: m.rotation_std_error_deg.map(|s| Vector3::from(s).map(f64::to_radians)),
                })
                .collect(),
            latency_s: p.entries.iter().any(|e| e.kind == Kind::Latency).then(|| p.latency(x)),
            clock_rate_ppm: p.entries.iter().any(|e| e.kind == Kind::Latency).then(|| p.clock_rate_ppm(x)),
            platform_sag_deg: p.platform_sag(x).to_degrees(),
            platform_sag_std_error_deg: platform_sag_std_error_deg(p, cov, free),
            fit: None,
        };
        // Per pose, in degrees, where the per-pose estimator has something to work on: the nominal
        // model with its best-fit registration, the calibrated one with its own — and a pixel
        // session's points triangulated through the file's rig and the refined one.
        let refined = p.rig(x).map(|rig| r.session.seen_through(&rig));
        let per_pose = |session: &Session, params: &Parameters| {
            let vision = SessionEstimate::of(session, Method::Kabsch).ok();
            // Nothing for the per-pose estimator (one marker per capture): no corrected copy.
            if vision.is_none() {
                return ErrorStats { fit: Stats::of_or_zero(&[]), held_out: None };
            }
            let corrected = corrected_for(session, vision.as_ref(), Method::Kabsch, params).ok().flatten();
            let (session, vision) = match &corrected {
                Some((s, v)) => (s, v.as_ref()),
                None => (session, vision.as_ref()),
            };
            let fit = vision.and_then(|v| pose_errors(session, v, params).ok());
            let degrees: Vec<f64> = fit.map(|e| e.per_pose.iter().map(|(_, d)| *d).collect()).unwrap_or_default();
            ErrorStats { fit: Stats::of_or_zero(&degrees), held_out: None }
        };
        let before = per_pose(r.session, &Parameters::nominal(&r.robot.spm, None));
        let after = per_pose(refined.as_ref().unwrap_or(r.session), &parameters);
        let parameters_report = parameter_reports(p, x, cov, free)
            .into_iter()
            .zip(&p.entries)
            .filter(|(_, e)| {
                (e.kind.moves_platform() || matches!(e.kind, Kind::Camera { .. }))
                    && !matches!(e.kind, Kind::Scale { .. })
            })
            .map(|(r, _)| r)
            .collect();
        let mut pose_ids = vec![0; r.problem.poses()];
        for (j, o) in observations.iter().enumerate() {
            pose_ids[r.problem.pose_of(j)] = o.pose;
        }
        let fda: Vec<bool> = p.entries.iter().map(|e| !matches!(e.kind, Kind::Latency | Kind::ClockRate)).collect();
        let eval = &r.calibrated.evaluation;
        let (poses, beyond_the_session) = PredictionPoses::of(
            self.workspace.as_ref(),
            p,
            x,
            eval.orientation_jacobians.as_deref(),
            &eval.orientations,
            &pose_ids,
        );
        let (predicted_error_deg, predicted_error_unwidened_deg) =
            PredictionPoses::plain_and_widened(poses.as_ref(), r.predicted_covariance, cov, &fda);
        let observation_poses: Vec<u64> = observations.iter().map(|o| o.pose).collect();
        let predicted_error_mm = r.predicted_ms.as_ref().and_then(|ms| {
            predicted_marker_error(
                &r.calibrated,
                r.problem.unit_scale(),
                ms,
                r.predicted_covariance,
                &observation_poses,
                |j| eval.orientations[r.problem.pose_of(j)],
            )
        });
        let camera_translation_std_error_m = index_of(p, |k| matches!(k, Kind::Translation { .. })).and_then(|i| {
            Some([std_error(cov, free, i[0])?, std_error(cov, free, i[1])?, std_error(cov, free, i[2])?])
        });
        let markers = MarkerFitReport {
            latency: p.entries.iter().position(|e| e.kind == Kind::Latency).map(|i| Latency {
                value_s: p.latency(x),
                std_error_s: std_error(cov, free, i),
                at_bound: p.at_bound(x, i),
            }),
            clock_rate_ppm: p.entries.iter().any(|e| e.kind == Kind::Latency).then(|| {
                let i = p.entries.iter().position(|e| e.kind == Kind::ClockRate);
                ClockRate {
                    value: p.clock_rate_ppm(x),
                    std_error: i.and_then(|i| std_error(cov, free, i)).map(|s| s / p.clock_rate_span_s * 1e6),
                    at_bound: i.is_some_and(|i| p.at_bound(x, i)),
                    held: self.clock_held,
                    span_s: self.span_s,
                }
            }),
            apparent_latency: p
                .entries
                .iter()
                .position(|e| e.kind == Kind::Latency)
                .map_or_else(Vec::new, |i| apparent_latency(&r, i)),
            camera_model: camera_report,
            observations: observations.len(),
            poses: r.problem.poses(),
            before: MarkerErrors::of(&r.nominal.evaluation.residuals, observations, &self.names),
            after: MarkerErrors::of(&r.calibrated.evaluation.residuals, observations, &self.names),
            rig: rig_report(p, x, |i| std_error(cov, free, i), r.calibrated.weighting.noise.as_ref()),
            stereo_noise: r.calibrated.weighting.noise.clone(),
            markers: marker_reports,
            fast_captures: self.streams.map_or_else(Vec::new, |s| {
                observations
                    .iter()
                    .zip(joint_speeds(observations, s, p))
                    .filter(|(_, v)| *v > self.max_joint_speed_deg_s)
                    .map(|(o, v)| FastCapture {
                        pose: o.pose,
                        marker: self.names[o.marker].clone(),
                        line: o.line,
                        speed_deg_s: v,
                    })
                    .collect()
            }),
        };
        let drift = self.drift_finding(&markers);
        let source = match observations.iter().any(|o| o.rotation) {
            true => "poses.csv",
            false => observations_file(p.entries.iter().any(|e| e.kind == Kind::Latency), p.rig0.is_some()),
        };
        let gross = r.flagged.iter().filter(|f| f.excluded).map(|f| {
            let marker = f.marker.as_deref().unwrap_or("");
            match crate::calib::report::file_line(source, f.line) {
                Some(at) => format!("pose {} marker {marker} ({at}): gross error", f.pose),
                None => format!("pose {} marker {marker}: gross error", f.pose),
            }
        });
        Ok(LevelReport {
            parameters,
            fitted: Fitted::Markers(at_fitted_latency(observations.to_vec(), self.streams, p, x)),
            vision_method: Some(Method::Kabsch),
            before,
            after,
            held_out_poses: 0,
            parameters_report,
            predicted_error_deg,
            predicted_error_unwidened_deg,
            predicted_error_mm,
            residual_sigma_deg: Vec::new(),
            camera_translation_m: Some(camera.translation.into()),
            camera_translation_std_error_m,
            markers: Some(markers),
            excluded: self.excluded.iter().cloned().chain(gross).collect(),
            notes: self.warnings.clone(),
            findings: camera_warnings.into_iter().chain(beyond_the_session).chain(drift).collect(),
        })
    }
}

impl MarkerLevel<'_> {
    /// With the clock's rate held, a warning when the apparent latency drifts beyond
    /// [`CAMERA_SIGNIFICANCE`] standard errors of its slope (its bins' weighted straight line):
    /// the camera's clock runs at its own rate, and the latency fitted is true of no moment.
    fn drift_finding(&self, m: &MarkerFitReport) -> Option<String> {
        let (held, rate) = (self.clock_held?, m.clock_rate_ppm?);
        let (slope, se) = drift(&m.apparent_latency)?;
        // The bins lie around the held clock's line: their slope is the rate they imply.
        let (ppm, se_ppm) = (slope * 1e6, se * 1e6);
        let how = match held {
            "short_recording" => "lower `clock_rate_min_duration_s` to fit it",
            "frozen" => "unfreeze `clock_rate` to fit it",
            _ => "fit the recording at the marker level (`fit: markers`) to estimate it",
        };
        ((ppm - rate.value).abs() > CAMERA_SIGNIFICANCE * se_ppm).then(|| {
            format!(
                "the apparent latency drifts: the camera's clock runs {ppm:+.1} ± {se_ppm:.1} ppm against the encoders' ({:.1} standard errors from the {:+.1} ppm held), so the latency fitted holds for no moment of the recording; {how}",
                (ppm - rate.value).abs() / se_ppm,
                rate.value
            )
        })
    }

    /// The camera model term by term: fitted or held (and why), a held term tested against the
    /// residuals, and what is significant said in words; a held term the residuals want moved is
    /// also a warning (the mechanism took the blame).
    fn camera_report(&self, r: &LevelResults<'_, MarkerResiduals<'_>>) -> (CameraModelReport, Vec<String>) {
        let (p, x, cov, free) = (&self.p, &r.calibrated.x, r.covariance, &r.free);
        let fitted = p.camera_model(x);
        let (mut findings, mut warnings) = (Vec::new(), Vec::new());
        let terms: Vec<CameraTermReport> = p
            .entries
            .iter()
            .enumerate()
            .filter_map(|(i, e)| match e.kind {
                Kind::CameraTerm { term } => Some((i, term)),
                _ => None,
            })
            .map(|(i, term)| {
                let held = match () {
                    _ if free[i] => None,
                    _ if !self.camera_model.terms().contains(&term) => Some("rigid"),
                    _ if self.freeze.contains(&Group::CameraModel) => Some("frozen"),
                    _ if p.at_bound(x, i) => Some("at_bound"),
                    _ => Some("unidentifiable"),
                };
                let value = fitted.value(term);
                let std_error = std_error(cov, free, i);
                let released = held.and_then(|_| released(&r.calibrated, free, i)).map(|(d, s)| (value + d, s));
                if let Some(finding) =
                    camera_finding(term, value, std_error, released, self.freeze.contains(&Group::CameraModel))
                {
                    if held.is_some() {
                        warnings.push(finding.clone());
                    }
                    findings.push(finding);
                }
                CameraTermReport { name: term.name().to_string(), value, std_error, held, released }
            })
            .collect();
        let depth = terms.iter().find(|t| t.name == CameraTerm::DepthScale.name());
        let report = CameraModelReport {
            model: self.camera_model,
            depth_scale: depth.map_or(1.0, |t| t.value),
            depth_scale_std_error: depth.and_then(|t| t.std_error),
            terms,
            finding: (!findings.is_empty()).then(|| findings.join("; ")),
            choice: None,
        };
        (report, warnings)
    }
}

/// A camera term is significant beyond this many standard errors from a perfect camera's value.
const CAMERA_SIGNIFICANCE: f64 = 3.0;

/// What a camera term says in words, when it is significant: fitted away from a perfect camera,
/// or held while the residuals want it moved.
fn camera_finding(
    term: CameraTerm,
    value: f64,
    std_error: Option<f64>,
    released: Option<(f64, f64)>,
    frozen: bool,
) -> Option<String> {
    let describe = |v: f64, s: f64| match term {
        CameraTerm::DepthScale => format!(
            "the camera's depths read {:.2}% {} ({v:.4} ± {s:.4})",
            (v - 1.0).abs() * 100.0,
            if v > 1.0 { "long" } else { "short" }
        ),
        _ => format!("the camera's {} is {v:.4} ± {s:.4} (a perfect camera's is {})", term.name(), term.perfect()),
    };
    match (std_error, released) {
        (Some(s), _) if (value - term.perfect()).abs() > CAMERA_SIGNIFICANCE * s => Some(format!(
            "{}: the camera, not the mechanism, explains that much of the error, and the fit corrected it",
            describe(value, s)
        )),
        (None, Some((v, s))) if (v - term.perfect()).abs() > CAMERA_SIGNIFICANCE * s => Some(format!(
            "the residuals follow the camera, not the mechanism: they say {}, {:.1} standard errors from a perfect camera, but `{}` is held — {}fit it (`camera_model: {}`)",
            describe(v, s),
            (v - term.perfect()).abs() / s,
            term.name(),
            if frozen { "take `camera_model` out of `freeze` and " } else { "" },
            CameraModelKind::smallest(|t| t == term).name()
        )),
        _ => None,
    }
}

/// The bound of the projective model's perspective terms (per metre): `bounds.camera_term`, but
/// no further than keeps `|c|` within what a parameters file accepts (the denominator above
/// [`CameraModel::MIN_DENOMINATOR`] over the camera's working volume) with all three at their
/// bounds, so that a fit never writes a model it cannot read back.
fn bound_perspective(p: &mut Parameterisation, start: &CameraModel, camera_term: f64) {
    let c0 = [CameraTerm::PerspectiveX, CameraTerm::PerspectiveY, CameraTerm::PerspectiveZ].map(|t| start.value(t));
    let c0 = Vector3::from(c0).norm();
    let most = (1.0 - CameraModel::MIN_DENOMINATOR) / CameraModel::WORKING_RANGE_M;
    // 0.99: the corner of the box stays strictly inside.
    let bound = camera_term.min(0.99 * (most - c0).max(0.0) / 3f64.sqrt());
    for e in p.entries.iter_mut() {
        if let Kind::CameraTerm { term } = e.kind
            && term.is_perspective()
        {
            e.bound = Some(bound);
        }
    }
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
        let clock = p.clock(x);
        for o in observations.iter_mut() {
            if let Some(joints) = o.time_s.and_then(|t| s.joints_at(clock.encoder_time(t))) {
                o.joints = joints;
            }
        }
    }
    observations
}

/// The fastest joint's speed (deg/s) at each observation's capture, at the starting clock.
fn joint_speeds(observations: &[MarkerObservation], streams: &Streams, p: &Parameterisation) -> Vec<f64> {
    let clock = crate::dataset::Clock { latency_s: p.latency_start, rate_ppm: p.clock_rate_start_ppm };
    observations
        .iter()
        .map(|o| {
            o.time_s.and_then(|t| streams.velocity_at(clock.encoder_time(t))).map_or(0.0, |v| v.amax().to_degrees())
        })
        .collect()
}

/// The slope of the apparent latency against time (s per s) and its standard error: the straight
/// line through the bins `[t, latency, σ]` weighted by `1/σ²`; `None` for fewer than three.
fn drift(bins: &[[f64; 3]]) -> Option<(f64, f64)> {
    if bins.len() < 3 {
        return None;
    }
    let w: Vec<f64> = bins.iter().map(|b| 1.0 / (b[2] * b[2])).collect();
    let sw: f64 = w.iter().sum();
    let mean = |k: usize| bins.iter().zip(&w).map(|(b, w)| w * b[k]).sum::<f64>() / sw;
    let (t0, l0) = (mean(0), mean(1));
    let stt: f64 = bins.iter().zip(&w).map(|(b, w)| w * (b[0] - t0).powi(2)).sum();
    let stl: f64 = bins.iter().zip(&w).map(|(b, w)| w * (b[0] - t0) * (b[1] - l0)).sum();
    (stt > 0.0).then(|| (stl / stt, 1.0 / stt.sqrt()))
}

/// Time bins of the apparent latency: at most this many, of at least [`POSES_PER_BIN`] poses.
const LATENCY_BINS: usize = 20;

/// Fewest poses (camera frames) a bin of the apparent latency holds.
const POSES_PER_BIN: usize = 30;

/// The latency each part of the recording implies (`Latency::apparent`): per time bin of the
/// encoders' clock, the fitted latency at the bin's time plus the one-parameter Gauss–Newton step
/// the bin's whitened, weighted residuals ask for with everything else held,
/// `δ = −Σ w gᵀ(W r) / Σ w |g|²` (`g = W ∂r/∂τ`), its standard error `1 / √Σ |g|²`; the bin's time
/// is the information-weighted mean of its frames'. `latency` is the latency's entry.
fn apparent_latency(r: &LevelResults<'_, MarkerResiduals<'_>>, latency: usize) -> Vec<[f64; 3]> {
    let (p, x) = (&r.problem.p, &r.calibrated.x);
    let clock = p.clock(x);
    let fresh;
    let jacobian = match &r.calibrated.evaluation.jacobian {
        Some(j) => j,
        None => match r.problem.evaluate(x, None, true) {
            Ok(e) => {
                fresh = e.jacobian;
                match &fresh {
                    Some(j) => j,
                    None => return Vec::new(),
                }
            }
            Err(_) => return Vec::new(),
        },
    };
    let observations = r.problem.observations();
    let w = &r.calibrated.weighting;
    let times: Vec<Option<f64>> = observations.iter().map(|o| o.time_s.map(|t| clock.encoder_time(t))).collect();
    let (first, last) =
        times.iter().flatten().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| (a.min(t), b.max(t)));
    let bins = (r.problem.poses() / POSES_PER_BIN).clamp(1, LATENCY_BINS);
    // No timed frame, or all at one time: no bins.
    if last.partial_cmp(&first) != Some(std::cmp::Ordering::Greater) {
        return Vec::new();
    }
    let width = (last - first) / bins as f64;
    // Per bin: Σ w |g|², Σ w gᵀ(W r), Σ |g|², Σ |g|² t.
    let mut sums = vec![[0.0; 4]; bins];
    for (j, t) in times.iter().enumerate() {
        let Some(t) = *t else { continue };
        let b = (((t - first) / width) as usize).min(bins - 1);
        let whiten = w.whitening[j];
        let g: Vector3<f64> = whiten * jacobian.fixed_view::<3, 1>(3 * j, latency);
        let wr = whiten * r.calibrated.evaluation.residuals[j];
        let h = w.weights.get(j).copied().unwrap_or(1.0);
        let s = &mut sums[b];
        s[0] += h * g.norm_squared();
        s[1] += h * g.dot(&wr);
        s[2] += g.norm_squared();
        s[3] += g.norm_squared() * t;
    }
    sums.iter()
        .filter(|s| s[0] > 0.0 && s[2] > 0.0)
        .map(|s| {
            let t = s[3] / s[2];
            [t, clock.latency_at(t) - s[1] / s[0], 1.0 / s[2].sqrt()]
        })
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
            let std_error_mm = idx.and_then(|i| {
                Some([std_error(cov, free, i[0])?, std_error(cov, free, i[1])?, std_error(cov, free, i[2])?])
                    .map(|s| s.map(|v| v * 1e3))
            });
            // A rigid body's frame (its origin is marker 0): `A` is P → body frame, reported as the
            // body frame's orientation on the MP, `Aᵀ`; a turn `a` of `A` is one of `−a` of the
            // body frame in its axes, with the same standard errors.
            let body = observations.iter().any(|o| o.rotation) && k == 0;
            let frame = index_of(p, |kind| matches!(kind, Kind::Reference { .. })).filter(|_| body);
            MarkerReport {
                name: name.clone(),
                observations: observations.iter().filter(|o| o.marker == k && !o.rotation).count(),
                model_m: p.markers0[k].into(),
                fitted_m: fitted.into(),
                change_mm: ((fitted - p.markers0[k]) * 1e3).into(),
                std_error_mm,
                rotation_wxyz: frame.map(|_| crate::math::so3::to_wxyz(&p.reference(x).inverse())),
                rotation_std_error_deg: frame.and_then(|i| {
                    Some([std_error(cov, free, i[0])?, std_error(cov, free, i[1])?, std_error(cov, free, i[2])?])
                        .map(|s| s.map(f64::to_degrees))
                }),
            }
        })
        .collect()
}

/// The report of the rig of `p` at `x`: every term (fitted or held), the baseline held, each
/// camera's pixel noise.
fn rig_report(
    p: &Parameterisation,
    x: &DVector<f64>,
    std_error: impl Fn(usize) -> Option<f64>,
    noise: Option<&crate::calib::StereoNoise>,
) -> Option<crate::calib::report::RigReport> {
    let rig0 = p.rig0.as_deref()?;
    let refined = p.rig(x)?;
    let terms = rig_terms::all_terms(rig0)
        .into_iter()
        .map(|term| {
            let (unit, scale) = rig_terms::display(rig0, term);
            let entry = p.entries.iter().position(|e| e.kind == Kind::Rig { term });
            let file_value = match term {
                crate::model::RigTerm::Intrinsic { camera, k } => Some(rig0.cameras[camera].lens.intrinsics[k]),
                crate::model::RigTerm::Distortion { camera, k } => Some(rig0.cameras[camera].lens.distortion[k]),
                _ => None,
            };
            let std_error = entry.and_then(&std_error).map(|s| s * scale);
            crate::calib::report::RigTermReport {
                name: term.name(rig0),
                unit,
                file_value,
                change: entry.map_or(0.0, |i| x[i] * scale),
                held: std_error.is_none(),
                std_error,
            }
        })
        .collect();
    let pixel_noise_px = rig0
        .cameras
        .iter()
        .enumerate()
        .map(|(c, cam)| {
            let sigma = noise.and_then(|n| n.pixel_px.get(c).copied()).unwrap_or(f64::NAN);
            let error = noise.and_then(|n| n.pixel_std_error_px.get(c).copied()).unwrap_or(f64::NAN);
            (cam.name.clone(), sigma, error)
        })
        .collect();
    Some(crate::calib::report::RigReport { baseline_held_m: rig0.baseline_m(), terms, pixel_noise_px, refined })
}
