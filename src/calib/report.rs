//! The one report of a calibration, whatever its fit level, with its one verdict. Text, JSON, the
//! HTML report and the recording all show this.

use serde::Serialize;

use super::agreement::MarkerErrors;
use super::camera_choice::CameraModelChoice;
use super::config::{CalibConfig, FitLevel, Loss};
use super::fit::{Convergence, IterationLog};
use super::identify::Identifiability;
use super::marker_residuals::StereoNoise;
use super::model_check::ModelCheck;
use super::uncertainty::{Correlation, ParameterReport, PredictedError};
use super::validation::CrossValidation;
use crate::math::stats::Stats;
use crate::model::CameraModelKind;
use crate::vision::Method;

/// FDA-vs-vision errors of one parameter set, on the fitted and on the held-out poses.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct ErrorStats {
    /// On the fitted poses, degrees.
    pub fit: Stats,
    /// On the held-out poses, when some were held out, degrees.
    pub held_out: Option<Stats>,
}

/// An observation (a pose's orientation, or a marker at a capture) that the robust fit flagged.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlaggedObservation {
    /// Pose (capture) id.
    pub pose: u64,
    /// Marker name (marker-level fit).
    pub marker: Option<String>,
    /// Line of `markers.csv` or `captures.csv` (0 when not read from a file or per pose).
    pub line: usize,
    /// Its residual, in the report's unit (`mm` or `deg`).
    pub residual: f64,
    /// Its residual in robust standard deviations.
    pub sigmas: f64,
    /// Its Huber weight in the fit, in (0, 1].
    pub weight: f64,
    /// Left out of the final fit (a gross error).
    pub excluded: bool,
}

/// The verdict's word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum VerdictLevel {
    /// The calibration can be used as it is.
    Pass,
    /// It can be used, with what the reasons say in mind.
    Warn,
    /// It should not be used: what the reasons say must be fixed first.
    Fail,
}

impl VerdictLevel {
    /// `PASS`, `WARN` or `FAIL`.
    fn label(self) -> &'static str {
        match self {
            VerdictLevel::Pass => "PASS",
            VerdictLevel::Warn => "WARN",
            VerdictLevel::Fail => "FAIL",
        }
    }
}

/// One reason of a verdict that is not a pass: what was found, and what to do.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct VerdictReason {
    /// `WARN` or `FAIL`: what this reason alone makes of the verdict.
    pub level: &'static str,
    /// What was found, in words.
    pub finding: String,
    /// What to do about it.
    pub action: String,
}

/// Whether the calibrated mechanism can be trusted, decided once for every view of the report:
/// from (a) whether it predicts unseen poses clearly better than the nominal one, (b) the model
/// check (are the residuals what the noise model says), and (c) its predicted orientation error
/// against `required_accuracy_deg` when the config sets one. The camera's noise is reported beside
/// it, never a reason by itself.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Verdict {
    /// `PASS`, `WARN` or `FAIL`.
    pub level: &'static str,
    /// `level` is `PASS`.
    pub pass: bool,
    /// What the unseen poses say, in one sentence.
    pub summary: String,
    /// Why it is not a pass, each reason with what to do (empty for a pass).
    pub reasons: Vec<VerdictReason>,
}

impl Verdict {
    /// `PASS`, `WARN` or `FAIL`.
    pub fn label(&self) -> &'static str {
        self.level
    }

    /// A verdict from its summary and reasons: the most severe reason decides.
    fn from_reasons(summary: String, reasons: Vec<VerdictReason>) -> Self {
        let severity = |label: &str| match label {
            "FAIL" => VerdictLevel::Fail,
            "WARN" => VerdictLevel::Warn,
            _ => VerdictLevel::Pass,
        };
        let level = reasons.iter().map(|r| severity(r.level)).max().unwrap_or(VerdictLevel::Pass);
        Verdict { level: level.label(), pass: level == VerdictLevel::Pass, summary, reasons }
    }

    /// The verdict on cross-validation `cv`, else on the held-out poses' errors `before`, `after`;
    /// with the model check `check` and the predicted orientation error `predicted`.
    pub(crate) fn of(
        cv: Option<&CrossValidation>,
        before: &ErrorStats,
        after: &ErrorStats,
        check: Option<&ModelCheck>,
        predicted: Option<&PredictedError>,
        config: &CalibConfig,
    ) -> Self {
        let mut reasons = Vec::new();
        let summary = if let Some(cv) = cv {
            let what = match (cv.level, cv.unit) {
                (FitLevel::Markers, "px") => "pixels",
                (FitLevel::Markers, _) => "markers",
                (FitLevel::Orientations, _) => "orientations",
            };
            let unit = if cv.unit == "deg" { "°".to_string() } else { format!(" {}", cv.unit) };
            if !cv.clearly_better {
                let worse = cv.reduction < -2.0 * cv.reduction_std_error
                    || cv.orientation_reduction_deg2.is_some_and(|[m, s]| m < -2.0 * s);
                reasons.push(VerdictReason {
                    level: if worse { "FAIL" } else { "WARN" },
                    finding: if worse {
                        "the calibrated model predicts unseen poses worse than the nominal one".into()
                    } else {
                        "the calibrated model does not predict unseen poses clearly better than the nominal one".into()
                    },
                    action: "capture more poses, spread over the workspace (`spmcal plan` says where), and \
                             check the camera model"
                        .into(),
                });
            }
            let verdict = if cv.clearly_better { "clearly better" } else { "not clearly better" };
            match cv.orientation_rms_deg {
                // A rigid body: its positions and its orientations, each in its own unit.
                Some([nominal_deg, calibrated_deg]) => format!(
                    "on unseen poses ({}-fold cross-validation, {} observations) the calibrated model predicts the \
                     body's positions to {:.3}{unit} and its orientations to {calibrated_deg:.4}° RMS against the \
                     nominal model's {:.3}{unit} and {nominal_deg:.4}° ({verdict}; the tracker's noise included)",
                    cv.folds, cv.observations, cv.calibrated_rms, cv.nominal_rms,
                ),
                None => format!(
                    "on unseen poses ({}-fold cross-validation, {} observations) the calibrated model predicts the \
                     {what} to {:.3}{unit} RMS against the nominal model's {:.3}{unit} ({verdict}; the camera's noise \
                     included)",
                    cv.folds, cv.observations, cv.calibrated_rms, cv.nominal_rms,
                ),
            }
        } else {
            match (before.held_out, after.held_out) {
                (Some(b), Some(a)) => {
                    if a.rms >= b.rms {
                        reasons.push(VerdictReason {
                            level: "FAIL",
                            finding: "the calibrated model is not better than the nominal one on the held-out poses"
                                .into(),
                            action: "capture more poses, spread over the workspace".into(),
                        });
                    }
                    format!(
                        "on held-out poses the calibrated model's FDA agrees with vision to {:.4}° RMS against the \
                         nominal model's {:.4}°",
                        a.rms, b.rms
                    )
                }
                _ => {
                    reasons.push(VerdictReason {
                        level: "WARN",
                        finding: "nothing shows how the model predicts new data".into(),
                        action: "set `folds` to 2 or more".into(),
                    });
                    format!(
                        "no unseen poses were predicted (cross-validation needs `folds` of at least 2, got {})",
                        config.folds
                    )
                }
            }
        };
        if let Some(check) = check.filter(|c| !c.passed) {
            let finding =
                check.finding.clone().unwrap_or_else(|| "the residuals are not what the noise model says".into());
            let action = check.action.clone().unwrap_or_default();
            let widened = match check.widening {
                Some(f) if f > 1.0 => format!("; the predicted error is widened {f:.1}× for what the misfit can do"),
                _ => String::new(),
            };
            reasons.push(VerdictReason {
                level: "WARN",
                finding: format!(
                    "the model check fails (p = {:.2e} against a false-alarm rate of {}): {finding}{widened}",
                    check.p_value, check.false_alarm_rate
                ),
                action,
            });
        }
        if let Some(required) = config.required_accuracy_deg {
            match predicted {
                Some(p) if p.rms > required => reasons.push(VerdictReason {
                    level: "FAIL",
                    finding: format!(
                        "the predicted orientation error, {:.4}° RMS, is more than the {required}° required",
                        p.rms
                    ),
                    action: "add poses where the predicted-error map is worst (`spmcal plan`), or fix what the \
                             model check names"
                        .into(),
                }),
                Some(p) if p.interval_90[1] > required => reasons.push(VerdictReason {
                    level: "WARN",
                    finding: format!(
                        "the predicted orientation error, {:.4}° RMS, may be more than the {required}° required \
                         (90 % range up to {:.4}°)",
                        p.rms, p.interval_90[1]
                    ),
                    action: "add poses where the predicted-error map is worst (`spmcal plan`)".into(),
                }),
                Some(_) => {}
                None => reasons.push(VerdictReason {
                    level: "WARN",
                    finding: format!("there is no predicted orientation error to hold to the {required}° required"),
                    action: "use a session whose poses determine the mechanism (see the identifiability)".into(),
                }),
            }
        }
        Verdict::from_reasons(summary, reasons)
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.label(), self.summary)?;
        for r in &self.reasons {
            write!(f, "\n  {}: {}", r.level, r.finding)?;
            if !r.action.is_empty() {
                write!(f, " — {}", r.action)?;
            }
        }
        Ok(())
    }
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
    /// A rigid body's frame: its fitted orientation on the MP, body frame → P, `qw,qx,qy,qz`
    /// (`None` for a marker).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rotation_wxyz: Option<[f64; 4]>,
    /// Its standard errors (deg, per axis of a small turn of the body frame, in its axes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rotation_std_error_deg: Option<[f64; 3]>,
}

/// The camera's latency behind the encoders, for a free-motion recording: at the encoders' time
/// 0 (with the clock rate, it is `value_s + ρ·10⁻⁶·t` at time `t`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Latency {
    /// The latency (s) at the encoders' time 0: estimated, or as given when frozen.
    pub value_s: f64,
    /// Its standard error (s); `None` when frozen or at its bound.
    pub std_error_s: Option<f64>,
    /// It ended at its bound, `±latency_bound_s`: the data want it further.
    pub at_bound: bool,
}

/// How much faster the camera's clock runs than the encoders', for a free-motion recording.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ClockRate {
    /// The rate difference (ppm): estimated, or as held.
    pub value: f64,
    /// Its standard error (ppm); `None` when held or at its bound.
    pub std_error: Option<f64>,
    /// It ended at its bound, `±clock_rate_bound_ppm`: the data want it further.
    pub at_bound: bool,
    /// Held, not fitted: `frozen` (the config), `short_recording` (shorter than
    /// `clock_rate_min_duration_s`) or `orientations` (the orientation-level fit holds it).
    pub held: Option<&'static str>,
    /// The camera time the recording spans, first frame to last (s).
    pub span_s: f64,
}

/// One stage of a calibration: what it did, the fit iterations it took and its wall-clock time.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageReport {
    /// `registration` (the nominal model's), `identifiability`, `calibration`, `refit without
    /// gross errors`, `uncertainty`, `cross-validation`, `report`.
    pub name: &'static str,
    /// Fit iterations (0 for stages that fit nothing).
    pub iterations: usize,
    /// Wall-clock time, seconds.
    pub seconds: f64,
}

/// The camera model the marker-level fit used (`camera_model`), term by term.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraModelReport {
    /// The model fitted.
    pub model: CameraModelKind,
    /// The depth scale (1: depths read true), as fitted or held.
    pub depth_scale: f64,
    /// Its standard error; `None` when held.
    pub depth_scale_std_error: Option<f64>,
    /// Every term of the model, and for a rigid model the depth scale it holds at 1.
    pub terms: Vec<CameraTermReport>,
    /// What the camera model says about the camera, in words, when something is significant: a
    /// fitted term away from a perfect camera's, or a held one the residuals want moved.
    pub finding: Option<String>,
    /// With `camera_model: auto`, which model it chose and why.
    pub choice: Option<CameraModelChoice>,
}

/// One term of the camera model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraTermReport {
    /// Its name (`depth_scale`, `scale_y`, `shear_xy`, `shear_xz`, `shear_yz`, `perspective_x`,
    /// `perspective_y`, `perspective_z`).
    pub name: String,
    /// The value fitted (or held).
    pub value: f64,
    /// Its standard error; `None` when held.
    pub std_error: Option<f64>,
    /// Held, not fitted: `frozen` (the config), `rigid` (a rigid model's depth scale),
    /// `unidentifiable` (the data cannot determine it) or `at_bound`.
    pub held: Option<&'static str>,
    /// For a held term: the value a fit that freed it would reach, and that value's standard
    /// error (a score test of holding it).
    pub released: Option<(f64, f64)>,
}

/// A capture of a free-motion recording taken while a joint turned faster than
/// `max_joint_speed_deg_s`: down-weighted in proportion.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FastCapture {
    /// Pose (frame) id.
    pub pose: u64,
    /// Marker name.
    pub marker: String,
    /// Line of `captures.csv`.
    pub line: usize,
    /// The fastest joint's speed, deg/s.
    pub speed_deg_s: f64,
}

/// What the marker-level calibration adds to the report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarkerFitReport {
    /// The camera latency of a free-motion recording.
    pub latency: Option<Latency>,
    /// The camera clock's rate of a free-motion recording.
    pub clock_rate_ppm: Option<ClockRate>,
    /// The latency each part of a free-motion recording implies, in time bins: `[t, latency,
    /// standard error]` (s), `t` the bin's time on the encoders' clock — the fitted latency there
    /// plus the one-parameter step the bin's residuals ask for (everything else held), so that a
    /// clock running at another rate shows as a slope, whether or not the fit estimated it.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub apparent_latency: Vec<[f64; 3]>,
    /// The camera model.
    pub camera_model: CameraModelReport,
    /// Marker observations fitted.
    pub observations: usize,
    /// Distinct poses (encoder readings) among them.
    pub poses: usize,
    /// Nominal mechanism and markers with their best-fit registration.
    pub before: MarkerErrors,
    /// The calibrated model.
    pub after: MarkerErrors,
    /// The stereo noise the residuals imply.
    pub stereo_noise: Option<StereoNoise>,
    /// Every marker's fitted position.
    pub markers: Vec<MarkerReport>,
    /// Captures taken while a joint turned too fast, down-weighted.
    pub fast_captures: Vec<FastCapture>,
    /// A pixel session's camera rig: every term before and after, and what was held.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rig: Option<RigReport>,
}

/// A pixel session's camera rig refined with the mechanism.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RigReport {
    /// The first baseline's length (m), held at the file's value: the rig's metric scale, which
    /// the mechanism's rotation-only motion cannot tell (0 for one camera, whose scale the
    /// markers' nominal spacing sets).
    pub baseline_held_m: f64,
    /// Every term of the rig, fitted or held.
    pub terms: Vec<RigTermReport>,
    /// Each camera's pixel noise (σ per coordinate, px) with its standard error.
    pub pixel_noise_px: Vec<(String, f64, f64)>,
    /// The refined rig, as `--cameras-out` writes it.
    #[serde(skip)]
    pub refined: crate::model::Rig,
}

/// One term of a rig: the file's value, the change the fit made and its standard error, in the
/// unit a person reads it in (`px` for intrinsics, none for a distortion coefficient, `deg` for a
/// rotation or the baseline's direction, `mm` for a further camera's translation).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RigTermReport {
    /// `cam1.fu`, `cam0.k1`, `cam1.rotation_x`, …
    pub name: String,
    /// The unit.
    pub unit: &'static str,
    /// The value in `cameras.yaml` (intrinsics and coefficients; a pose's terms are changes only).
    pub file_value: Option<f64>,
    /// The fit's change.
    pub change: f64,
    /// Its standard error (`None` when held).
    pub std_error: Option<f64>,
    /// Held at the file's value (not in `rig_terms`, frozen, or unidentifiable).
    pub held: bool,
}

/// Everything a user needs to judge a calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationReport {
    /// Session name.
    pub session: String,
    /// What was fitted.
    pub fit: FitLevel,
    /// Vision estimator used for the measured orientations (and the per-pose errors).
    pub vision_method: Method,
    /// Loss of the fit.
    pub loss: Loss,
    /// Poses in the session.
    pub poses: usize,
    /// Poses fitted.
    pub fit_poses: usize,
    /// Poses held out of the fit (orientation-level `holdout_every`).
    pub held_out_poses: usize,
    /// Poses and observations left out, and why.
    pub excluded: Vec<String>,
    /// Whether the calibration can be trusted, and why.
    pub verdict: Verdict,
    /// Plain-language warnings: markers seen at too few poses, a calibration not clearly better.
    pub warnings: Vec<String>,
    /// What the session could not do that is no sign of trouble: joint scales it cannot tell from
    /// the offsets, held at their start (a warning instead when the model check finds the residuals
    /// following the joints' angles).
    pub notes: Vec<String>,
    /// The error on unseen data, when cross-validated (`folds` ≥ 2).
    pub cross_validation: Option<CrossValidation>,
    /// Whether the residuals are what the noise model says, and if not, the likely cause.
    pub model_check: Option<ModelCheck>,
    /// The predicted orientation error before the misfit widened it (when the model check failed).
    pub predicted_error_unwidened_deg: Option<f64>,
    /// Nominal mechanism with its best-fit camera registration, FDA against vision per pose
    /// (poses the per-pose estimator can work on).
    pub before: ErrorStats,
    /// Calibrated mechanism with its registration.
    pub after: ErrorStats,
    /// The calibration fit, iteration by iteration (the refit without the gross errors, when
    /// there is one, after it), each naming its stage.
    pub iterations: Vec<IterationLog>,
    /// Every stage of the calibration with its fit iterations and wall-clock time.
    pub stages: Vec<StageReport>,
    /// How the fit ended: converged, or stalled at a minimum.
    pub convergence: Convergence,
    /// Every angle parameter with its change and standard error (degrees).
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
    /// The expected RMS orientation error (degrees) of the calibrated FDA on an unseen pose of the
    /// session's workspace, as `compare` measures it (up to the common rotations no measurement
    /// sees), from the parameter covariance; the same definition at both fit levels.
    pub predicted_error_deg: Option<PredictedError>,
    /// The same for the markers' positions, mm (marker-level fit) — px for a session seen through its
    /// cameras' pixels (the reprojection of the markers; `unit` says which).
    pub predicted_error_mm: Option<PredictedError>,
    /// Residual standard deviation per camera axis, degrees, by the number of markers seen:
    /// `(markers, poses, [σx, σy, σz])` (orientation-level fit).
    pub residual_sigma_deg: Vec<(usize, usize, [f64; 3])>,
    /// Observations the robust fit flagged, excluded ones first.
    pub flagged: Vec<FlaggedObservation>,
    /// Unit of the flagged observations' residuals: `mm` or `deg`.
    pub unit: &'static str,
    /// Parameters that ended at their bound: held there, without a standard error (the data
    /// want them further: widen the bound in the config if the device can be that far off).
    pub at_bound: Vec<String>,
    /// `t_CB`; `None` when the poses leave it undetermined (orientation-level: from the centre of
    /// rotation).
    pub camera_translation_m: Option<[f64; 3]>,
    /// Its standard errors.
    pub camera_translation_std_error_m: Option<[f64; 3]>,
    /// The marker-level fit's own figures (`fit: markers`).
    pub markers: Option<MarkerFitReport>,
    /// Each leg's joint scale (`φ = sθ + δ`): its change in ppm with its standard error, or why
    /// it was held.
    pub joint_scales: Vec<super::joint_scales::JointScaleReport>,
    /// Why the platform's sag (`platform.sag` among the parameters) was held at its start by
    /// `platform_sag: auto`; `None` when it was fitted, or held by the config.
    pub platform_sag_held: Option<String>,
}

impl CalibrationReport {
    /// The file the marker observations came from, for messages ([`observations_file`]).
    pub(crate) fn observations_file(&self) -> &'static str {
        // A rigid body's frame is reported with its orientation: its observations are poses.csv's.
        if self.markers.as_ref().is_some_and(|m| m.markers.iter().any(|k| k.rotation_wxyz.is_some())) {
            return "poses.csv";
        }
        observations_file(self.markers.as_ref().is_some_and(|m| m.latency.is_some()), self.unit == "px")
    }
}

/// Where an observation is in its file, for a message: `markers.csv line 12`; `None` for one read
/// from a bag, whose messages have no line (line 0).
pub(crate) fn file_line(file: &str, line: usize) -> Option<String> {
    (line > 0).then(|| format!("{file} line {line}"))
}

/// The file marker observations come from, for messages: a pixel session's `pixels.csv`, a
/// free-motion recording's (it has a latency) `captures.csv`, else `markers.csv`.
pub(crate) fn observations_file(recording: bool, pixels: bool) -> &'static str {
    match (pixels, recording) {
        (true, _) => "pixels.csv",
        (false, true) => "captures.csv",
        (false, false) => "markers.csv",
    }
}

/// The `fit:` header of the parameters file.
///
/// # Panics
/// Never: the header serialises.
pub(crate) fn fit_header(report: &CalibrationReport) -> serde_yaml::Value {
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
        reprojection_rms_before_px: Option<f64>,
        #[serde(skip_serializing_if = "Option::is_none")]
        reprojection_rms_after_px: Option<f64>,
        #[serde(skip_serializing_if = "Option::is_none")]
        cross_validated_rms_mm: Option<[f64; 2]>,
        #[serde(skip_serializing_if = "Option::is_none")]
        cross_validated_rms_px: Option<[f64; 2]>,
        #[serde(skip_serializing_if = "Option::is_none")]
        cross_validated_rms_deg: Option<[f64; 2]>,
        #[serde(skip_serializing_if = "Option::is_none")]
        camera_model_choice: Option<String>,
        verdict: &'a str,
        #[serde(skip_serializing_if = "Vec::is_empty")]
        at_bound: Vec<&'a str>,
        #[serde(skip_serializing_if = "Vec::is_empty")]
        warnings: Vec<&'a str>,
        #[serde(skip_serializing_if = "Vec::is_empty")]
        notes: Vec<&'a str>,
    }
    // A pixel session's marker errors are reprojection errors (px).
    let pixels = report.unit == "px";
    let markers = report.markers.as_ref().filter(|_| !pixels);
    let reprojection = report.markers.as_ref().filter(|_| pixels);
    let cv = |level: FitLevel, unit: &str| {
        report
            .cross_validation
            .as_ref()
            .filter(|cv| cv.level == level && cv.unit == unit)
            .map(|cv| [cv.nominal_rms, cv.calibrated_rms])
    };
    let header = Header {
        session: &report.session,
        vision_method: report.vision_method,
        loss: report.loss,
        fit_poses: report.fit_poses,
        held_out_poses: report.held_out_poses,
        iterations: report.iterations.len(),
        rms_before_deg: report.before.fit.rms,
        rms_after_deg: report.after.fit.rms,
        held_out_rms_before_deg: report.before.held_out.map(|e| e.rms),
        held_out_rms_after_deg: report.after.held_out.map(|e| e.rms),
        identifiable_directions: report.identifiability.rank,
        free_parameters: report.identifiability.parameters,
        condition_number: report.identifiability.condition,
        std_errors_deg: report
            .parameters
            .iter()
            .filter_map(|p| p.std_error_deg.map(|s| (p.name.as_str(), s)))
            .collect(),
        camera_translation_std_error_m: report.camera_translation_std_error_m,
        markers_rms_before_mm: markers.map(|m| m.before.errors.rms),
        markers_rms_after_mm: markers.map(|m| m.after.errors.rms),
        reprojection_rms_before_px: reprojection.map(|m| m.before.errors.rms),
        reprojection_rms_after_px: reprojection.map(|m| m.after.errors.rms),
        cross_validated_rms_mm: cv(FitLevel::Markers, "mm"),
        cross_validated_rms_px: cv(FitLevel::Markers, "px"),
        cross_validated_rms_deg: cv(FitLevel::Orientations, "deg"),
        camera_model_choice: markers
            .and_then(|m| m.camera_model.choice.as_ref().map(|c| format!("{} ({})", c.chosen.name(), c.summary))),
        verdict: report.verdict.label(),
        at_bound: report.at_bound.iter().map(String::as_str).collect(),
        warnings: report.warnings.iter().map(String::as_str).collect(),
        notes: report.notes.iter().map(String::as_str).collect(),
    };
    serde_yaml::to_value(header).expect("the header serialises")
}
