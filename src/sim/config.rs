//! Simulation settings (`configs/simulate_*.yaml`). Angles in degrees (`_deg`), lengths in
//! metres (`_m`), times in seconds (`_s`), rates in hertz (`_hz`); unknown keys are errors.

use std::path::{Path, PathBuf};

use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use super::rig::RigSettings;
use crate::io::files::FileError;
use crate::model::{CameraModel, CameraTerm};

/// The most poses a simulated session may have: a session is held in memory (about 200 bytes a
/// pose), and 1,000,000 is far beyond any capture a person would make.
pub(crate) const MAX_POSES: usize = 1_000_000;
/// How the orientations are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Trajectory {
    /// Independent samples, uniform over the tilt disc and the yaw range.
    #[default]
    Random,
    /// A continuous spiral: three turns of growing tilt with a yaw oscillation.
    Spiral,
}

impl Trajectory {
    /// The name used in config files.
    pub fn name(self) -> &'static str {
        match self {
            Trajectory::Random => "random",
            Trajectory::Spiral => "spiral",
        }
    }
}

/// Where a config was read from, and its keys' lines (nothing for a config made in code). Two
/// configs are equal whatever their source.
#[derive(Debug, Clone, Default)]
pub(crate) struct Source(pub(crate) Option<(PathBuf, crate::io::yaml::KeyLines)>);

impl PartialEq for Source {
    fn eq(&self, _: &Source) -> bool {
        true
    }
}

impl Source {
    /// `error`, located at `key`'s line of the file the config came from (unchanged without one).
    pub(crate) fn locate(&self, key: &str, error: String) -> Result<crate::io::FileError, String> {
        match &self.0 {
            Some((path, keys)) => Ok(keys.error(path, key, error)),
            None => Err(error),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// Settings of a simulated session; every field has a default (a partial file works).
pub struct SimConfig {
    /// The file the config was read from, with its keys' lines, so that a problem found only when
    /// simulating (no pose meets a setting) names the file and the key's line; not part of its value.
    #[serde(skip)]
    pub(crate) source: Source,
    /// Session name.
    pub name: String,
    /// The model: a shipped model's name (`agile_wrist`, the default) or a URDF's path relative to
    /// the config file.
    pub model: PathBuf,
    /// Poses to simulate.
    pub poses: usize,
    /// Random seed (same seed, same session).
    pub seed: u64,
    #[serde(default)]
    /// Free-text description for `session.yaml`.
    pub description: Option<String>,
    /// Spread of the true geometry.
    pub truth: TruthSpread,
    /// Which orientations are visited.
    pub workspace: Workspace,
    /// The stereo camera.
    pub camera: Camera,
    /// The joint encoders.
    pub encoders: Encoders,
    /// How markers are captured.
    pub capture: CaptureSettings,
    /// A free-motion recording (encoder and camera streams) instead of static poses.
    pub recording: Option<Recording>,
    /// The orientations to capture, in order, instead of drawing them (`simulate --plan`; not
    /// read from the file). Each must be reachable by the model and inside `workspace`, else the
    /// simulation is refused, naming the pose.
    #[serde(skip)]
    pub plan: Option<Vec<Rotation3<f64>>>,
    /// Where `plan` came from, one row per orientation: the plan file and each row's line, step
    /// and the joint readings it expects. With it, the simulation also refuses a row whose joints
    /// contradict its orientation under the model, and its errors name the file and line
    /// (`PlannedPose::read_into` sets both fields). Not read from the file.
    #[serde(skip)]
    pub(crate) plan_source: Option<PlanSource>,
}

/// The file a plan was read from and, per pose (in the order of [`SimConfig::plan`]), its row.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct PlanSource {
    /// The plan file.
    pub(crate) path: PathBuf,
    /// One row per planned orientation.
    pub(crate) rows: Vec<PlanRow>,
}

/// One row of a plan file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PlanRow {
    /// Its step number.
    pub(crate) step: u64,
    /// Its line in the file.
    pub(crate) line: usize,
    /// The joint readings the plan expects at its orientation (rad).
    pub(crate) joints: Vector3<f64>,
}

/// Standard deviations of the true geometry around the nominal model, and its compliance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TruthSpread {
    /// Tilt of each joint axis (deg).
    pub axis_tilt_deg: f64,
    /// Link angles α1, α2 (deg).
    pub link_angle_deg: f64,
    /// Encoder offsets δ (deg).
    pub joint_offset_deg: f64,
    /// Camera position (m).
    pub camera_position_m: f64,
    /// Camera rotation (deg).
    pub camera_rotation_deg: f64,
    /// Misplacement of each marker on the MP, per axis (m): markers are glued by hand.
    pub marker_position_m: f64,
    /// Not a spread: the platform's sag under its weight, degrees per unit of the gravity torque's
    /// arm (the sine of the platform's tilt from level; its centre of mass on its axis). The MP
    /// turns that much further down than the joints put it, about the horizontal axis across its
    /// tilt: at 30° of tilt, half of it. 0 (a rigid mechanism) by default.
    pub sag_deg: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// The orientations a session visits.
pub struct Workspace {
    /// How they are drawn.
    pub trajectory: Trajectory,
    /// Largest tilt of the MP from home (deg).
    pub max_tilt_deg: f64,
    /// Largest yaw of the MP (deg).
    pub max_yaw_deg: f64,
    /// Poses whose conditioning index is below this are rejected (near a parallel singularity).
    pub min_conditioning: f64,
    /// Poses with a leg branch margin below this are rejected (near a serial singularity).
    pub min_branch_margin: f64,
}

/// A Bumblebee-like stereo camera above the MP, looking down: a camera of points with stereo
/// noise, or with a `rig` section a rig of cameras seen through their pixels (the section's keys
/// in `configs/simulate_agile_wrist_stereo.yaml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Camera {
    /// Height of the camera centre above O.
    pub height_m: f64,
    /// Distance between the two lenses (a marker must be visible from both).
    pub baseline_m: f64,
    /// Noise across the line of sight at `reference_distance_m`; grows with the distance.
    pub lateral_sigma_m: f64,
    /// Noise along the line of sight at `reference_distance_m`; grows with the distance squared.
    pub depth_sigma_m: f64,
    /// Distance at which `lateral_sigma_m` and `depth_sigma_m` hold (m).
    pub reference_distance_m: f64,
    /// Probability that a marker measurement is an outlier.
    pub outlier_probability: f64,
    /// Standard deviation of an outlier measurement (m).
    pub outlier_sigma_m: f64,
    /// Radius of the spherical markers (the start of the line of sight for occlusion).
    pub marker_radius_m: f64,
    /// Depths read this many times their length (1: a perfect camera); see `model/camera.rs`.
    pub depth_scale: f64,
    /// Camera y reads this many times its length relative to camera x (an affine camera).
    pub scale_y: f64,
    /// Symmetric shear between camera x and y (an affine camera).
    pub shear_xy: f64,
    /// Symmetric shear between camera x and the optical axis (an affine camera).
    pub shear_xz: f64,
    /// Symmetric shear between camera y and the optical axis (an affine camera).
    pub shear_yz: f64,
    /// A rig of cameras seen through their pixels instead of a camera of points (`camera.rig`);
    /// none by default.
    #[cfg(feature = "internals")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig: Option<RigSettings>,
    /// A rig of cameras seen through their pixels instead of a camera of points (`camera.rig`,
    /// see `configs/simulate_agile_wrist_stereo.yaml`); none by default.
    #[cfg(not(feature = "internals"))]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) rig: Option<RigSettings>,
    /// A motion-capture rigid body instead of markers (`camera.rigid_body`): the session holds
    /// the body's poses (`poses.csv`) in the camera's frame; none by default.
    #[cfg(feature = "internals")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rigid_body: Option<RigidBodySettings>,
    /// A motion-capture rigid body instead of markers (`camera.rigid_body`); none by default.
    #[cfg(not(feature = "internals"))]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) rigid_body: Option<RigidBodySettings>,
    /// Growth of the denominator `cᵀx + 1` along camera x, per metre (a projective camera).
    pub perspective_x: f64,
    /// Growth of the denominator along camera y, per metre (a projective camera).
    pub perspective_y: f64,
    /// Growth of the denominator along the optical axis, per metre (a projective camera).
    pub perspective_z: f64,
}

/// A rigid body a motion-capture system tracks on the MP (`camera.rigid_body`): per capture it
/// reports the pose of the body's frame in the tracker's frame (the camera's), either with
/// Gaussian noise of its own or, with `fitted_to_markers`, as a tracker makes it — the body's
/// markers (the model's, at their true places) fitted to their measured positions (Kabsch, three
/// seen at least), so that its noise is the markers' noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RigidBodySettings {
    /// The body's name (`session.yaml`'s `body`).
    pub name: String,
    /// The body frame's origin in P (m).
    pub origin_m: [f64; 3],
    /// The body frame's orientation on the MP (body → P), a rotation vector (deg).
    pub rotation_deg: [f64; 3],
    /// Position noise, per axis (m).
    pub position_sigma_m: f64,
    /// Orientation noise, per axis of a small rotation (deg).
    pub orientation_sigma_deg: f64,
    /// The body fitted to the measured markers instead (the σ's above do not apply).
    pub fitted_to_markers: bool,
}

impl Default for RigidBodySettings {
    /// An OptiTrack-like body: 0.3 mm and 0.1° of noise, its frame off the MP's.
    fn default() -> Self {
        RigidBodySettings {
            name: "platform".into(),
            origin_m: [0.004, -0.008, 0.02],
            rotation_deg: [5.0, -8.0, 30.0],
            position_sigma_m: 0.0003,
            orientation_sigma_deg: 0.1,
            fitted_to_markers: false,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// Joint encoders.
pub struct Encoders {
    /// Encoder resolution (quantisation).
    pub counts_per_revolution: u32,
    /// Reading noise (deg).
    pub noise_deg: f64,
    /// Each leg's true joint scale (`φ = sθ + δ`: the joint turns `s` radians per radian of its
    /// reading, a transmission ratio's error); `[1, 1, 1]` by default. Written in `truth.yaml`.
    pub scales: [f64; 3],
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// How markers are captured.
pub struct CaptureSettings {
    /// One marker at a time, as in the paper: each capture is its own pose, with the encoder
    /// reading of its instant, and the captures of one station share its `station` number.
    pub sequential: bool,
    /// Drift of the hand-held MP between sequential captures (a random walk; deg per axis).
    pub motion_deg: f64,
    /// Time between captures (the `time_s` column).
    pub interval_s: f64,
}

/// A free-motion recording instead of static poses: a hand moving the joystick smoothly over
/// the workspace while the encoders stream and the camera tracks markers on its own clock.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Recording {
    /// Length of the recording (s).
    pub duration_s: f64,
    /// Encoder sampling rate (Hz).
    pub encoder_rate_hz: f64,
    /// Camera frame rate (Hz).
    pub camera_rate_hz: f64,
    /// The camera's latency behind the encoders (s): a frame taken at `t` (on the encoders'
    /// clock) is stamped `t·(1 + clock_rate_ppm·10⁻⁶) + latency`.
    pub latency_s: f64,
    /// How much faster the camera's clock runs than the encoders' (ppm; 0: one clock).
    pub clock_rate_ppm: f64,
    /// Standard deviation of the camera's time stamps (s).
    pub jitter_s: f64,
    /// Every marker in every frame (else one marker per frame, round robin).
    pub all_markers: bool,
    /// Ten times the time between the hand's random waypoints (s).
    pub period_s: f64,
}

impl Default for Recording {
    fn default() -> Self {
        Recording {
            duration_s: 120.0,
            encoder_rate_hz: 1000.0,
            camera_rate_hz: 15.0,
            latency_s: 0.04,
            clock_rate_ppm: 0.0,
            jitter_s: 0.001,
            all_markers: false,
            period_s: 20.0,
        }
    }
}

impl Default for SimConfig {
    /// The settings of `configs/simulate_agile_wrist.yaml`.
    fn default() -> Self {
        SimConfig {
            source: Source::default(),
            name: "simulated".into(),
            model: PathBuf::new(),
            poses: 400,
            seed: 400,
            description: None,
            truth: TruthSpread::default(),
            workspace: Workspace::default(),
            camera: Camera::default(),
            encoders: Encoders::default(),
            capture: CaptureSettings::default(),
            recording: None,
            plan: None,
            plan_source: None,
        }
    }
}

impl Default for TruthSpread {
    fn default() -> Self {
        TruthSpread {
            axis_tilt_deg: 0.5,
            link_angle_deg: 0.3,
            joint_offset_deg: 1.0,
            camera_position_m: 0.01,
            camera_rotation_deg: 1.0,
            marker_position_m: 0.003,
            sag_deg: 0.0,
        }
    }
}

impl Default for Workspace {
    fn default() -> Self {
        Workspace {
            trajectory: Trajectory::Random,
            max_tilt_deg: 30.0,
            max_yaw_deg: 30.0,
            min_conditioning: 0.2,
            min_branch_margin: 0.1,
        }
    }
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            height_m: 0.8,
            baseline_m: 0.12,
            lateral_sigma_m: 0.0002,
            depth_sigma_m: 0.0008,
            reference_distance_m: 0.8,
            outlier_probability: 0.0,
            outlier_sigma_m: 0.005,
            marker_radius_m: 0.006,
            depth_scale: 1.0,
            scale_y: 1.0,
            shear_xy: 0.0,
            shear_xz: 0.0,
            shear_yz: 0.0,
            rig: None,
            rigid_body: None,
            perspective_x: 0.0,
            perspective_y: 0.0,
            perspective_z: 0.0,
        }
    }
}

impl Default for Encoders {
    fn default() -> Self {
        Encoders { counts_per_revolution: 16384, noise_deg: 0.005, scales: [1.0; 3] }
    }
}

impl Default for CaptureSettings {
    fn default() -> Self {
        CaptureSettings { sequential: false, motion_deg: 0.05, interval_s: 0.5 }
    }
}

/// The model used when a config names none.
pub(crate) const DEFAULT_MODEL: &str = crate::model::shipped::DEFAULT_MODEL;

impl SimConfig {
    /// Read and check a config; `model` is resolved against the config's folder.
    ///
    /// # Errors
    /// A [`FileError`] naming the line and key of the first problem.
    pub fn read(path: &Path) -> Result<Self, FileError> {
        let (mut config, keys): (SimConfig, _) = crate::io::yaml::read(path)?;
        config.check().map_err(|(key, reason)| keys.error(path, &key, reason))?;
        config.model = if config.model.as_os_str().is_empty() {
            PathBuf::from(DEFAULT_MODEL)
        } else {
            let model = crate::io::files::resolve_reference(path.parent().unwrap_or(Path::new("")), &config.model);
            if let Some(reason) = crate::model::shipped::missing(&model) {
                return Err(keys.error(path, "model", reason));
            }
            model
        };
        config.source = Source(Some((path.to_path_buf(), keys)));
        Ok(config)
    }

    /// Values serde accepted but that make no physical sense, as `(key, reason)`.
    ///
    /// # Errors
    /// `(key, reason)` for the first value out of its range.
    pub fn check(&self) -> Result<(), (String, String)> {
        // The conditioning index (the Jacobian's smallest over largest singular value) is at most
        // 1: a threshold of 1 or more rejects every pose, which the simulator would find out only
        // after all its attempts.
        if self.workspace.min_conditioning >= 1.0 {
            let reason = format!(
                "`workspace.min_conditioning` must be below 1 (got {}): the conditioning index is at most 1 (1 only at an exactly isotropic pose), so no pose would pass",
                self.workspace.min_conditioning
            );
            return Err(("workspace.min_conditioning".into(), reason));
        }
        // Each spread, noise and size from 0 to far beyond any real device's (a turn's spread to a
        // half turn, a noise to a metre or a right angle): a value past it would only make the
        // simulator write infinities.
        let bounded = [
            ("truth.axis_tilt_deg", self.truth.axis_tilt_deg, 90.0),
            ("truth.link_angle_deg", self.truth.link_angle_deg, 90.0),
            ("truth.joint_offset_deg", self.truth.joint_offset_deg, 180.0),
            ("truth.camera_position_m", self.truth.camera_position_m, 10.0),
            ("truth.camera_rotation_deg", self.truth.camera_rotation_deg, 180.0),
            ("truth.marker_position_m", self.truth.marker_position_m, 1.0),
            ("workspace.max_tilt_deg", self.workspace.max_tilt_deg, 180.0),
            ("workspace.max_yaw_deg", self.workspace.max_yaw_deg, 180.0),
            ("workspace.min_conditioning", self.workspace.min_conditioning, 1.0),
            ("workspace.min_branch_margin", self.workspace.min_branch_margin, 1.0),
            ("camera.baseline_m", self.camera.baseline_m, 10.0),
            ("camera.lateral_sigma_m", self.camera.lateral_sigma_m, 1.0),
            ("camera.depth_sigma_m", self.camera.depth_sigma_m, 1.0),
            ("camera.outlier_sigma_m", self.camera.outlier_sigma_m, 10.0),
            ("camera.marker_radius_m", self.camera.marker_radius_m, 1.0),
            ("encoders.noise_deg", self.encoders.noise_deg, 90.0),
            ("capture.motion_deg", self.capture.motion_deg, 180.0),
            ("capture.interval_s", self.capture.interval_s, 3600.0),
        ];
        for (key, value, most) in bounded {
            if !(value.is_finite() && (0.0..=most).contains(&value)) {
                let got = crate::io::files::number(value);
                return Err((key.into(), format!("`{key}` must be from 0 to {most} (got {got})")));
            }
        }
        for (key, value) in [
            ("camera.height_m", self.camera.height_m),
            ("camera.reference_distance_m", self.camera.reference_distance_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err((key.into(), format!("`{key}` must be positive (got {value})")));
            }
        }
        // A degree's sag at 90° of tilt is already a weak mechanism; ten would break the small
        // rotation the simulator applies.
        if !(self.truth.sag_deg.is_finite() && self.truth.sag_deg.abs() <= 10.0) {
            let reason = format!("`truth.sag_deg` must be within ±10° (got {})", self.truth.sag_deg);
            return Err(("truth.sag_deg".into(), reason));
        }
        if self.poses == 0 || self.poses > MAX_POSES {
            let reason = format!("`poses` (or `--poses`) must be from 1 to {MAX_POSES} (got {})", self.poses);
            return Err(("poses".into(), reason));
        }
        if let Some(r) = &self.recording {
            for (key, value) in [
                ("recording.duration_s", r.duration_s),
                ("recording.encoder_rate_hz", r.encoder_rate_hz),
                ("recording.camera_rate_hz", r.camera_rate_hz),
                ("recording.period_s", r.period_s),
            ] {
                if !(value.is_finite() && value > 0.0) {
                    return Err((key.into(), format!("`{key}` must be positive (got {value})")));
                }
            }
            if !(r.latency_s.is_finite() && r.latency_s.abs() <= 0.2) {
                return Err((
                    "recording.latency_s".into(),
                    format!("`latency_s` must be within ±0.2 s (got {})", r.latency_s),
                ));
            }
            let most = crate::model::limits::MAX_CLOCK_RATE_PPM;
            if !(r.clock_rate_ppm.is_finite() && r.clock_rate_ppm.abs() <= most) {
                return Err((
                    "recording.clock_rate_ppm".into(),
                    format!("`clock_rate_ppm` must be within ±{most} ppm (got {})", r.clock_rate_ppm),
                ));
            }
            if !(r.jitter_s.is_finite() && r.jitter_s >= 0.0 && r.jitter_s < 0.25 / r.camera_rate_hz) {
                let reason = format!("`jitter_s` must be non-negative and below a quarter frame (got {})", r.jitter_s);
                return Err(("recording.jitter_s".into(), reason));
            }
            if r.encoder_rate_hz < 20.0 || r.duration_s * r.encoder_rate_hz > 2.0e7 {
                let reason = "the encoders must stream at 20 Hz or more (their gaps are bounded), and at most 2e7 samples in all";
                return Err(("recording.encoder_rate_hz".into(), reason.into()));
            }
        }
        if !(0.0..=1.0).contains(&self.camera.outlier_probability) {
            return Err(("camera.outlier_probability".into(), "`outlier_probability` must lie in [0, 1]".into()));
        }
        if let Some(k) = self.encoders.scales.iter().position(|s| !(s.is_finite() && (0.5..=1.5).contains(s))) {
            let reason = format!(
                "`scales` must be ratios from 0.5 to 1.5 (1.004: the joint turns 0.4 % further than its reading; got {})",
                self.encoders.scales[k]
            );
            return Err((format!("encoders.scales[{k}]"), reason));
        }
        if self.encoders.counts_per_revolution == 0 {
            return Err(("encoders.counts_per_revolution".into(), "`counts_per_revolution` must be at least 1".into()));
        }
        if self.workspace.max_tilt_deg >= 90.0 {
            return Err(("workspace.max_tilt_deg".into(), "`max_tilt_deg` must be below 90°".into()));
        }
        if self.workspace.max_yaw_deg > 180.0 {
            return Err(("workspace.max_yaw_deg".into(), "`max_yaw_deg` must be at most 180°".into()));
        }
        if self.camera.outlier_probability.is_nan() {
            return Err(("camera.outlier_probability".into(), "`outlier_probability` is not a number".into()));
        }
        let model = self.camera.model();
        for term in CameraTerm::ALL {
            let v = model.value(term);
            if !(v.is_finite() && (v - term.perfect()).abs() <= 0.5) {
                let key = format!("camera.{}", term.name());
                return Err((key, format!("`{}` must be within ±0.5 of {} (got {v})", term.name(), term.perfect())));
            }
        }
        if let Some(reason) = model.defect() {
            let key = if model.determinant() < CameraModel::MIN_DETERMINANT { "depth_scale" } else { "perspective_z" };
            return Err((format!("camera.{key}"), reason));
        }
        self.check_rig()?;
        self.check_rigid_body()?;
        if self.camera.height_m <= self.camera.marker_radius_m {
            return Err(("camera.height_m".into(), "the camera must be above the markers".into()));
        }
        if self.name.trim().is_empty() {
            return Err(("name".into(), "`name` must not be empty".into()));
        }
        Ok(())
    }

    /// A rigid body's settings: finite, non-negative noise, a name, no rig beside it.
    fn check_rigid_body(&self) -> Result<(), (String, String)> {
        let Some(b) = &self.camera.rigid_body else { return Ok(()) };
        for (key, value, most) in [
            ("camera.rigid_body.position_sigma_m", b.position_sigma_m, 1.0),
            ("camera.rigid_body.orientation_sigma_deg", b.orientation_sigma_deg, 90.0),
        ] {
            if !(value.is_finite() && (0.0..=most).contains(&value)) {
                let got = crate::io::files::number(value);
                return Err((key.into(), format!("`{key}` must be from 0 to {most} (got {got})")));
            }
        }
        let frame = b.origin_m.iter().chain(&b.rotation_deg);
        if frame.clone().any(|v| !v.is_finite()) || b.origin_m.iter().any(|v| v.abs() > 1.0) {
            let reason = "the body frame's `origin_m` (within 1 m of O) and `rotation_deg` must be finite numbers";
            return Err(("camera.rigid_body".into(), reason.into()));
        }
        if b.name.trim().is_empty() {
            return Err(("camera.rigid_body.name".into(), "the body's `name` must not be empty".into()));
        }
        if self.camera.rig.is_some() {
            let reason = "a rigid body's poses come from a tracker, not from a rig's pixels: give one or the other";
            return Err(("camera.rigid_body".into(), reason.into()));
        }
        if b.fitted_to_markers && self.capture.sequential {
            let reason =
                "a body fitted to its markers needs three of them in one capture: not with `capture.sequential`";
            return Err(("camera.rigid_body.fitted_to_markers".into(), reason.into()));
        }
        Ok(())
    }

    /// The rig's settings, and that a rig comes without the terms of a camera of points: its
    /// pixels are the cameras' own (their errors are the rig's, `miscalibration`).
    fn check_rig(&self) -> Result<(), (String, String)> {
        let Some(rig) = &self.camera.rig else { return Ok(()) };
        if !self.camera.model().is_perfect() {
            let reason = "a rig is seen through its cameras' pixels: the terms of a camera of points (`depth_scale`, `scale_y`, the shears) must keep their perfect values with `camera.rig` (the rig's errors are its `miscalibration`)";
            return Err(("camera.rig".into(), reason.into()));
        }
        rig.check()
    }
}
