//! Calibration settings (`configs/calibrate.yaml`). Angles in degrees (`_deg`), lengths in metres
//! or millimetres (`_m`, `_mm`), times in seconds (`_s`); unknown keys are errors.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::io::files::FileError;
use crate::model::{CameraModelKind, CameraTerm, CameraTerms};
use crate::vision::Method;

/// A group of parameters that can be frozen at its nominal (or initial) value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Group {
    /// Tilts of the actuated axes `u_i`.
    ActuatedAxes,
    /// Tilts of the platform axes `v0_i`.
    PlatformAxes,
    /// Proximal link angles `α1_i`.
    ProximalAngles,
    /// Distal link angles `α2_i`.
    DistalAngles,
    /// Encoder zero offsets `δ_i`.
    JointOffsets,
    /// Joint scales `s_i` (`φ = sθ + δ`): frozen, every scale is held at its start (1 unless the
    /// parameters started from say otherwise); `joint_scales: hold` does the same.
    JointScales,
    /// The platform's sag under its weight: frozen, held at its start (0 unless the parameters
    /// started from say otherwise); `platform_sag: hold` does the same.
    PlatformSag,
    /// Camera rotation `R_CB`.
    CameraRotation,
    /// Orientation of the reference pose's markers in the camera (a property of the session;
    /// orientation-level fit only).
    ReferenceRotation,
    /// Camera translation `t_CB` (marker-level fit).
    CameraTranslation,
    /// The markers' positions on the MP (marker-level fit).
    MarkerPositions,
    /// The camera's latency (free-motion recordings): frozen, `latency_s` is used as it is.
    Latency,
    /// The camera clock's rate (free-motion recordings): frozen, `clock_rate_ppm` is used as it is.
    ClockRate,
    /// The camera model's terms (marker-level fit): frozen, `camera_terms` are used as they are.
    CameraModel,
    /// A pixel session's camera rig (`rig_terms`): frozen, the rig is used as `cameras.yaml` gives it.
    CameraRig,
}

/// The camera model a calibration fits (`camera_model`): one by name, or `auto` (the default),
/// the simplest that the cross-validation supports (`camera_choice.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CameraModelSetting {
    /// The simplest of rigid, depth_scale, affine and projective that the data support.
    #[default]
    Auto,
    /// A perfect camera.
    Rigid,
    /// Depths read `s` times their length.
    DepthScale,
    /// Per-axis scales and shears.
    Affine,
    /// A homography of space.
    Projective,
}

impl CameraModelSetting {
    /// The model named, `None` for `auto`.
    pub fn named(self) -> Option<CameraModelKind> {
        match self {
            CameraModelSetting::Auto => None,
            CameraModelSetting::Rigid => Some(CameraModelKind::Rigid),
            CameraModelSetting::DepthScale => Some(CameraModelKind::DepthScale),
            CameraModelSetting::Affine => Some(CameraModelKind::Affine),
            CameraModelSetting::Projective => Some(CameraModelKind::Projective),
        }
    }

    /// Its name in configs.
    pub fn name(self) -> &'static str {
        self.named().map_or("auto", CameraModelKind::name)
    }
}

impl From<CameraModelKind> for CameraModelSetting {
    fn from(kind: CameraModelKind) -> Self {
        match kind {
            CameraModelKind::Rigid => CameraModelSetting::Rigid,
            CameraModelKind::DepthScale => CameraModelSetting::DepthScale,
            CameraModelKind::Affine => CameraModelSetting::Affine,
            CameraModelKind::Projective => CameraModelSetting::Projective,
        }
    }
}

/// Whether a calibration fits a term the mechanism may or may not show: the joints' scales
/// (`joint_scales`), the platform's sag (`platform_sag`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitChoice {
    /// Where the session shows it. Joint scales: each scale that the session determines (to
    /// ±0.1 %, or worse where its own error shows at 3σ) and shows to differ from its start (by 3
    /// standard errors); the others held at their start, and said. The sag: when its score at
    /// the fit without it is beyond 2σ (a 5 % test: a clean session fits it one time in twenty,
    /// at the cost of one parameter).
    #[default]
    Auto,
    /// Whatever the session.
    Fit,
    /// Held at its start.
    Hold,
}

/// What the calibration fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitLevel {
    /// Every marker observation with its capture's encoder reading, under the stereo noise model
    /// (maximum likelihood); the markers' positions and `t_CB` are fitted too.
    #[default]
    Markers,
    /// Per-pose orientation estimates of the vision estimator (needs three markers per pose).
    Orientations,
}

impl FitLevel {
    /// The unit its residuals are read in: `mm` (markers) or `deg` (orientations).
    pub fn unit(self) -> &'static str {
        match self {
            FitLevel::Markers => "mm",
            FitLevel::Orientations => "deg",
        }
    }

    /// What its observations are called: `marker observations` or `poses`.
    pub(crate) fn observations(self) -> &'static str {
        match self {
            FitLevel::Markers => "marker observations",
            FitLevel::Orientations => "poses",
        }
    }
}

/// What `calibrate` does when the calibrated model does not predict unseen data clearly better
/// than the nominal one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IfNotBetter {
    /// Write the parameters, with the warning in the report and in the file's header.
    #[default]
    Warn,
    /// Write nothing: the calibration fails with the reason.
    Refuse,
}

/// The loss applied to each observation's (whitened) residual norm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Loss {
    /// Plain least squares on the whitened residuals.
    LeastSquares,
    /// Quadratic up to `huber_threshold` robust standard deviations, linear beyond.
    Huber,
}

/// What to do with directions the data cannot identify.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Unidentifiable {
    /// Stop with an error naming the directions.
    Refuse,
    /// Hold them at their initial values with a weak prior, and say so.
    Regularise,
}

/// A workspace of orientations: the MP tilted from home up to `max_tilt_deg` in any direction and
/// turned about its own axis by up to ±`max_yaw_deg` (`R = exp(tilt) · exp(yaw ẑ)`, tilt about an
/// axis of the base's xy plane), as `plan` and `simulate` draw poses.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PredictionWorkspace {
    /// Largest tilt of the MP from home (deg).
    pub max_tilt_deg: f64,
    /// Largest yaw of the MP about its own axis, either way (deg).
    pub max_yaw_deg: f64,
}

/// The most iterations a fit may be given: a fit converges in tens; more is a typo.
pub(crate) const MAX_ITERATIONS: u32 = 10_000;
/// The most folds of the cross-validation (each costs a solve of the normal equations).
pub(crate) const MAX_FOLDS: usize = 1_000;

/// Calibration settings; every field has a default (a partial file works).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CalibConfig {
    /// What to fit: marker observations (default) or per-pose orientations.
    pub fit: FitLevel,
    /// Folds of the cross-validation that measures the error on unseen poses (both fit levels;
    /// stations, else poses, kept together), 2 or more; 0: none (the verdict says so); 1 is refused.
    pub folds: usize,
    /// What to do when the calibrated model does not predict unseen data clearly better.
    pub if_not_better: IfNotBetter,
    /// The orientation error (degrees RMS on unseen poses, the report's predicted error) the
    /// mechanism must reach: the verdict fails a calibration whose predicted error is larger, and
    /// warns when its 90 % range reaches past it. `None` (the default): no requirement.
    pub required_accuracy_deg: Option<f64>,
    /// No longer decides anything (read so that older configs still work): the verdict is about
    /// the mechanism, and the camera's noise, which this compared the marker error with, is
    /// reported beside it. Set `required_accuracy_deg` for a requirement.
    pub pass_held_out_mm: f64,
    /// No longer decides anything (as `pass_held_out_mm`).
    pub pass_held_out_deg: f64,
    /// The camera's latency behind the encoders (s), for free-motion recordings: each capture's
    /// joints are interpolated at its time less this. The marker-level fit estimates it from here
    /// (within ±`latency_bound_s`) unless `latency` is frozen.
    pub latency_s: f64,
    /// The bound on the estimated latency, either sign (s).
    pub latency_bound_s: f64,
    /// How much faster the camera's clock runs than the encoders' (ppm), for free-motion
    /// recordings: a capture stamped `t` was taken at `(t − latency) / (1 + rate·10⁻⁶)`, the
    /// latency being the one at the encoders' time 0. The marker-level fit estimates it from here
    /// (within ±`clock_rate_bound_ppm`) on a recording that spans at least
    /// `clock_rate_min_duration_s`, unless `clock_rate` is frozen; a shorter one holds it here.
    pub clock_rate_ppm: f64,
    /// The bound on the estimated clock rate difference, either sign (ppm).
    pub clock_rate_bound_ppm: f64,
    /// The shortest recording (camera time from its first frame to its last, s) on which the
    /// clock rate is estimated: over a shorter one the drift of any plausible rate is lost in the
    /// latency's own uncertainty.
    pub clock_rate_min_duration_s: f64,
    /// Free-motion recordings: a capture taken while a joint turns faster than this (deg/s) is
    /// flagged and its noise inflated in proportion (blur, interpolation error).
    pub max_joint_speed_deg_s: f64,
    /// The orientations the predicted error is for (`max_tilt_deg`, `max_yaw_deg`): where the
    /// model will be used. Absent (the default): the session's own poses. A workspace beyond the
    /// session's poses is predicted as the model extrapolates there, and the report says so.
    pub workspace: Option<PredictionWorkspace>,
    /// The camera model the marker-level fit estimates with the mechanism: `auto` (the default:
    /// the simplest of the others that the cross-validation supports), `rigid` (a perfect camera),
    /// `depth_scale` (depths read `s` times their length), `affine` (per-axis scales and shears)
    /// or `projective` (a homography of space); see `model/camera.rs`.
    pub camera_model: CameraModelSetting,
    /// The camera model's terms as known before the fit: where the marker-level fit starts them
    /// (and keeps them when `camera_model` is frozen), and the correction the orientation-level
    /// fit applies to the measured markers. Only the terms of a named `camera_model` may be set
    /// (`auto` starts from a perfect camera).
    pub camera_terms: CameraTerms,
    /// Vision estimator for the measured orientations.
    pub vision_method: Method,
    /// Loss applied to each observation's residual.
    pub loss: Loss,
    /// Huber threshold, in robust standard deviations of the residuals.
    pub huber_threshold: f64,
    /// Observations whose residual exceeds this many robust standard deviations are flagged as
    /// outliers; beyond twice this, excluded as gross errors and the fit repeated without them.
    pub outlier_threshold: f64,
    /// Parameter groups held fixed.
    #[serde(default)]
    pub freeze: Vec<Group>,
    /// The joints' scales (`φ = sθ + δ`, a transmission ratio's error): `auto` (the default) keeps
    /// the ones the session determines (to ±0.1 %, or worse where a scale's own error shows at 3σ)
    /// when they show an error (3σ's worth together) and holds the others at their start, saying
    /// so; `fit` fits all three; `hold` holds them (as `freeze: [joint_scales]`).
    pub joint_scales: FitChoice,
    /// The platform's sag under its weight (a rotation `c (n × (−z))` after the rigid mechanism's,
    /// `n` the platform's axis, `z` the base's up): `auto` (the default) fits it when the session
    /// shows it (its score beyond 2σ at the fit without it, and the fit with it agreeing); `fit`
    /// always; `hold` never (as `freeze: [platform_sag]`).
    pub platform_sag: FitChoice,
    /// A session seen through its cameras' pixels: the rig's terms refined with the mechanism
    /// (`focal_lengths`, `principal_points`, `radial_k1`, `radial_k2`, `other_distortion`,
    /// `extrinsics`); the first baseline's length is always held (the rig's metric scale).
    pub rig_terms: Vec<RigTermGroup>,
    /// Every `holdout_every`-th pose is held out of the fit for validation (orientation-level fit;
    /// 0: none).
    pub holdout_every: usize,
    /// Iteration budget of each fit.
    pub max_iterations: u32,
    /// Initial trust-region radius, as an angle (the marker-level fit's positions and latency
    /// take the same number of radians as metres or seconds).
    pub initial_radius_deg: f64,
    /// Converged when the full step changes no parameter by more than this (as an angle; positions
    /// and the latency compare their metres or seconds with the same number of radians); the fit
    /// usually stops first, when the Newton decrement proves the optimum within 1e-3 standard
    /// errors.
    pub step_tolerance_deg: f64,
    /// Physical bounds on the departures from nominal.
    pub bounds: Bounds,
    /// What to do with directions the data cannot identify.
    pub unidentifiable: Unidentifiable,
    /// A direction whose scaled singular value is below this fraction of the largest is unidentifiable.
    pub min_singular_ratio: f64,
}

/// Physical bounds on the departures from nominal: angles in degrees, marker positions in metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Bounds {
    /// Tilt of any joint axis.
    pub axis_tilt_deg: f64,
    /// Change of a link angle α1 or α2.
    pub link_angle_deg: f64,
    /// Encoder offset δ.
    pub joint_offset_deg: f64,
    /// Departure of a marker's position from the model's, per axis (m; marker-level fit).
    pub marker_position_m: f64,
    /// Departure of a camera model's term from `camera_terms` (a scale's from its start, a shear's).
    pub camera_term: f64,
    /// Departure of a joint scale from its start (0.05: 5 %, far beyond a transmission's error).
    pub joint_scale: f64,
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds {
            axis_tilt_deg: 10.0,
            link_angle_deg: 5.0,
            joint_offset_deg: 30.0,
            marker_position_m: 0.03,
            camera_term: 0.1,
            joint_scale: 0.05,
        }
    }
}

impl Default for CalibConfig {
    fn default() -> Self {
        CalibConfig {
            fit: FitLevel::Markers,
            folds: 5,
            if_not_better: IfNotBetter::Warn,
            required_accuracy_deg: None,
            pass_held_out_mm: 1.0,
            pass_held_out_deg: 0.5,
            latency_s: 0.0,
            latency_bound_s: 0.2,
            clock_rate_ppm: 0.0,
            clock_rate_bound_ppm: 500.0,
            clock_rate_min_duration_s: 60.0,
            max_joint_speed_deg_s: 90.0,
            workspace: None,
            camera_model: CameraModelSetting::Auto,
            camera_terms: CameraTerms::default(),
            vision_method: Method::Kabsch,
            loss: Loss::Huber,
            huber_threshold: 3.0,
            outlier_threshold: 4.0,
            freeze: Vec::new(),
            joint_scales: FitChoice::Auto,
            platform_sag: FitChoice::Auto,
            rig_terms: RigTermGroup::DEFAULT.to_vec(),
            holdout_every: 4,
            max_iterations: 200,
            initial_radius_deg: 3.0,
            step_tolerance_deg: 1e-7,
            bounds: Bounds::default(),
            unidentifiable: Unidentifiable::Regularise,
            min_singular_ratio: 1e-6,
        }
    }
}

impl CalibConfig {
    /// The groups held fixed: `freeze`, the joint scales with `joint_scales: hold` and the sag
    /// with `platform_sag: hold`.
    pub(crate) fn frozen_groups(&self) -> Vec<Group> {
        let mut groups = self.freeze.clone();
        for (choice, group) in [(self.joint_scales, Group::JointScales), (self.platform_sag, Group::PlatformSag)] {
            if choice == FitChoice::Hold && !groups.contains(&group) {
                groups.push(group);
            }
        }
        groups
    }

    /// `platform_sag: auto` and the sag not frozen: the calibration tests whether the session
    /// shows a sag before fitting it.
    pub(crate) fn sag_auto(&self) -> bool {
        self.platform_sag == FitChoice::Auto && !self.freeze.contains(&Group::PlatformSag)
    }

    /// The camera model the config names, or for `auto` the one `auto` chooses when there is
    /// nothing to choose from: a fit that cannot estimate one (the orientation level) or whose
    /// camera terms are frozen takes the camera as perfect (`auto` starts from a perfect camera).
    pub(crate) fn camera_model_or_rigid(&self) -> CameraModelKind {
        self.camera_model.named().unwrap_or(CameraModelKind::Rigid)
    }

    /// `camera_terms` within range, of the named model (none with `auto`), and a model that does
    /// not fold space where the camera sees.
    fn check_camera_terms(&self) -> Result<(), (String, String)> {
        for (term, value) in CameraTerm::ALL.iter().zip(self.camera_terms.values()) {
            let key = format!("camera_terms.{}", term.name());
            let most = crate::model::limits::MAX_CAMERA_TERM;
            if !(value.is_finite() && (value - term.perfect()).abs() <= most) {
                return Err((
                    key,
                    format!("`{}` must be within ±{most} of {} (got {value})", term.name(), term.perfect()),
                ));
            }
            if value == term.perfect() {
                continue;
            }
            let having: Vec<String> = CameraModelKind::ALL
                .iter()
                .filter(|k| k.terms().contains(term))
                .map(|k| format!("`camera_model: {}`", k.name()))
                .collect();
            let reason = match self.camera_model.named() {
                Some(kind) if kind.terms().contains(term) => continue,
                Some(kind) => format!(
                    "`{}` is not a term of `camera_model: {}`: set {}",
                    term.name(),
                    kind.name(),
                    having.join(" or ")
                ),
                None => format!(
                    "`camera_model: auto` chooses the model starting from a perfect camera, so it takes no known                      `{}`: to start there, name the model ({})",
                    term.name(),
                    having.join(" or ")
                ),
            };
            return Err((key, reason));
        }
        let camera = self.camera_terms.model(self.camera_model_or_rigid());
        if let Some(reason) = camera.defect() {
            return Err(("camera_terms".into(), reason));
        }
        Ok(())
    }

    /// Read and check a config file.
    ///
    /// # Errors
    /// A [`FileError`] naming the file, line and key for unreadable or malformed YAML, unknown keys or values [`CalibConfig::check`] refuses.
    pub fn read(path: &Path) -> Result<Self, FileError> {
        crate::io::yaml::read_checked(path, CalibConfig::check)
    }

    /// Values serde accepted but that make no sense, as `(key, reason)`.
    ///
    /// # Errors
    /// `(key, reason)` for the first value out of its range.
    pub fn check(&self) -> Result<(), (String, String)> {
        let positive = [
            ("huber_threshold", self.huber_threshold),
            ("outlier_threshold", self.outlier_threshold),
            ("initial_radius_deg", self.initial_radius_deg),
            ("step_tolerance_deg", self.step_tolerance_deg),
            ("bounds.axis_tilt_deg", self.bounds.axis_tilt_deg),
            ("bounds.link_angle_deg", self.bounds.link_angle_deg),
            ("bounds.joint_offset_deg", self.bounds.joint_offset_deg),
            ("bounds.marker_position_m", self.bounds.marker_position_m),
            ("bounds.camera_term", self.bounds.camera_term),
            ("bounds.joint_scale", self.bounds.joint_scale),
            ("min_singular_ratio", self.min_singular_ratio),
            ("max_joint_speed_deg_s", self.max_joint_speed_deg_s),
        ];
        for (key, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err((key.into(), format!("`{key}` must be a positive number (got {value})")));
            }
        }
        let required = self.required_accuracy_deg.map(|v| ("required_accuracy_deg", v));
        for (key, value) in [("pass_held_out_mm", self.pass_held_out_mm), ("pass_held_out_deg", self.pass_held_out_deg)]
            .into_iter()
            .chain(required)
        {
            if !(value.is_finite() && value > 0.0) {
                return Err((key.into(), format!("`{key}` must be a positive number (got {value})")));
            }
        }
        // A parameters file holds a latency within ±0.2 s (what a recording is read with): a fit
        // may not write one it cannot read back.
        let most = crate::model::limits::MAX_LATENCY_S;
        if !(self.latency_bound_s.is_finite() && self.latency_bound_s > 0.0 && self.latency_bound_s <= most) {
            let reason = format!("`latency_bound_s` must be in (0, {most}] s (got {})", self.latency_bound_s);
            return Err(("latency_bound_s".into(), reason));
        }
        if !(self.latency_s.is_finite() && self.latency_s.abs() < self.latency_bound_s) {
            let reason = format!(
                "`latency_s` must lie inside ±`latency_bound_s` = {} s (got {})",
                self.latency_bound_s, self.latency_s
            );
            return Err(("latency_s".into(), reason));
        }
        // The same for the clock rate.
        let most = crate::model::limits::MAX_CLOCK_RATE_PPM;
        let bound = self.clock_rate_bound_ppm;
        if !(bound.is_finite() && bound > 0.0 && bound <= most) {
            let reason = format!("`clock_rate_bound_ppm` must be in (0, {most}] ppm (got {bound})");
            return Err(("clock_rate_bound_ppm".into(), reason));
        }
        if !(self.clock_rate_ppm.is_finite() && self.clock_rate_ppm.abs() < bound) {
            let reason = format!(
                "`clock_rate_ppm` must lie inside ±`clock_rate_bound_ppm` = {bound} ppm (got {})",
                self.clock_rate_ppm
            );
            return Err(("clock_rate_ppm".into(), reason));
        }
        if !(self.clock_rate_min_duration_s.is_finite() && self.clock_rate_min_duration_s >= 0.0) {
            let reason = format!(
                "`clock_rate_min_duration_s` must be a non-negative time (got {})",
                self.clock_rate_min_duration_s
            );
            return Err(("clock_rate_min_duration_s".into(), reason));
        }
        if let Some(w) = &self.workspace {
            if !(w.max_tilt_deg.is_finite() && w.max_tilt_deg > 0.0 && w.max_tilt_deg < 90.0) {
                let reason = format!("`workspace.max_tilt_deg` must be in (0°, 90°) (got {})", w.max_tilt_deg);
                return Err(("workspace.max_tilt_deg".into(), reason));
            }
            if !(w.max_yaw_deg.is_finite() && w.max_yaw_deg >= 0.0 && w.max_yaw_deg <= 180.0) {
                let reason = format!("`workspace.max_yaw_deg` must be in [0°, 180°] (got {})", w.max_yaw_deg);
                return Err(("workspace.max_yaw_deg".into(), reason));
            }
        }
        if self.max_iterations == 0 || self.max_iterations > MAX_ITERATIONS {
            let reason = format!("`max_iterations` must be from 1 to {MAX_ITERATIONS} (got {})", self.max_iterations);
            return Err(("max_iterations".into(), reason));
        }
        if self.folds == 1 {
            let reason = "`folds: 1` is no cross-validation: one fold would hold out every pose and fit on none; \
                          use 2 or more (5: the default), or 0 to skip it (the verdict then says nothing shows how the \
                          model predicts new data)";
            return Err(("folds".into(), reason.into()));
        }
        if self.folds > MAX_FOLDS {
            let reason = format!(
                "`folds: {}` is absurd: k-fold cross-validation uses 2 to {MAX_FOLDS} folds (0: none)",
                self.folds
            );
            return Err(("folds".into(), reason));
        }
        if self.holdout_every == 1 {
            return Err(("holdout_every".into(), "`holdout_every: 1` would hold out every pose".into()));
        }
        // Values that are positive but absurd: the fit works in radians of a few degrees.
        if self.initial_radius_deg > 90.0 {
            return Err((
                "initial_radius_deg".into(),
                format!(
                    "`initial_radius_deg` {} is absurd: a trust region of at most 90° is meaningful",
                    self.initial_radius_deg
                ),
            ));
        }
        if self.step_tolerance_deg >= self.initial_radius_deg {
            return Err((
                "step_tolerance_deg".into(),
                "`step_tolerance_deg` must be smaller than `initial_radius_deg`".into(),
            ));
        }
        if self.min_singular_ratio >= 1.0 {
            return Err(("min_singular_ratio".into(), "`min_singular_ratio` must be below 1".into()));
        }
        if self.outlier_threshold < 1.0 || self.huber_threshold < 0.5 {
            let key = if self.outlier_threshold < 1.0 { "outlier_threshold" } else { "huber_threshold" };
            return Err((key.into(), format!("`{key}` below 1 (0.5 for huber) would flag ordinary noise")));
        }
        self.check_camera_terms()?;
        let mechanism =
            [Group::ActuatedAxes, Group::PlatformAxes, Group::ProximalAngles, Group::DistalAngles, Group::JointOffsets];
        if mechanism.iter().all(|g| self.freeze.contains(g)) {
            return Err((
                "freeze".into(),
                "`freeze` holds every mechanism parameter fixed: there is nothing to calibrate".into(),
            ));
        }
        Ok(())
    }
}

/// Which of a rig's terms a calibration refines (`rig_terms` in the config).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RigTermGroup {
    /// Every camera's `fu`, `fv`.
    FocalLengths,
    /// Every camera's `pu`, `pv`.
    PrincipalPoints,
    /// Every camera's first radial coefficient `k1`.
    RadialK1,
    /// The second radial coefficient `k2`.
    RadialK2,
    /// The rest of the distortion coefficients (`r1`, `r2` of radtan; `k3`, `k4` of equidistant).
    OtherDistortion,
    /// Every camera's pose relative to cam0 (the first baseline's length held).
    Extrinsics,
}

impl RigTermGroup {
    /// What a calibration refines by default: what a lab's rig calibration typically gets wrong
    /// and a session identifies (the higher distortion terms trade with the principal points and
    /// the focal lengths and are left at the file's values unless asked for).
    pub const DEFAULT: [RigTermGroup; 4] =
        [RigTermGroup::FocalLengths, RigTermGroup::PrincipalPoints, RigTermGroup::RadialK1, RigTermGroup::Extrinsics];

    pub(crate) fn holds(self, term: crate::model::RigTerm) -> bool {
        use crate::model::RigTerm;
        match (self, term) {
            (RigTermGroup::FocalLengths, RigTerm::Intrinsic { k, .. }) => k < 2,
            (RigTermGroup::PrincipalPoints, RigTerm::Intrinsic { k, .. }) => k >= 2,
            (RigTermGroup::RadialK1, RigTerm::Distortion { k, .. }) => k == 0,
            (RigTermGroup::RadialK2, RigTerm::Distortion { k, .. }) => k == 1,
            (RigTermGroup::OtherDistortion, RigTerm::Distortion { k, .. }) => k >= 2,
            (RigTermGroup::Extrinsics, RigTerm::Rotation { .. } | RigTerm::Translation { .. }) => true,
            _ => false,
        }
    }
}
