//! Simulation settings (`configs/simulate_*.yaml`). Angles in degrees (`_deg`), lengths in
//! metres (`_m`); unknown keys are errors.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::files::{FileError, read_checked_yaml};

/// How the orientations are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Trajectory {
    /// Independent samples, uniform over the tilt disc and the yaw range.
    Random,
    /// A continuous spiral: three turns of growing tilt with a yaw oscillation.
    Spiral,
}

impl Trajectory {
    pub fn name(self) -> &'static str {
        match self {
            Trajectory::Random => "random",
            Trajectory::Spiral => "spiral",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimConfig {
    pub name: String,
    /// The URDF model, relative to the config file.
    pub model: PathBuf,
    pub poses: usize,
    pub seed: u64,
    #[serde(default)]
    pub description: Option<String>,
    pub truth: TruthSpread,
    pub workspace: Workspace,
    pub camera: Camera,
    pub encoders: Encoders,
    pub capture: Capture,
}

/// Standard deviations of the true geometry around the nominal model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthSpread {
    pub axis_tilt_deg: f64,
    pub link_angle_deg: f64,
    pub joint_offset_deg: f64,
    pub camera_position_m: f64,
    pub camera_rotation_deg: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Workspace {
    pub trajectory: Trajectory,
    pub max_tilt_deg: f64,
    pub max_yaw_deg: f64,
    /// Poses whose conditioning index is below this are rejected (near a parallel singularity).
    pub min_conditioning: f64,
    /// Poses with a leg branch margin below this are rejected (near a serial singularity).
    pub min_branch_margin: f64,
}

/// A Bumblebee-like stereo camera above the MP, looking down.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// Height of the camera centre above O.
    pub height_m: f64,
    /// Distance between the two lenses (a marker must be visible from both).
    pub baseline_m: f64,
    /// Noise across the line of sight.
    pub lateral_sigma_m: f64,
    /// Noise along the line of sight at `reference_distance_m`; grows with the distance squared.
    pub depth_sigma_m: f64,
    pub reference_distance_m: f64,
    pub outlier_probability: f64,
    pub outlier_sigma_m: f64,
    /// Radius of the spherical markers (the start of the line of sight for occlusion).
    pub marker_radius_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Encoders {
    pub counts_per_revolution: u32,
    pub noise_deg: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Capture {
    /// One marker at a time, as in the paper, with a small motion of the MP between captures.
    pub sequential: bool,
    /// Standard deviation of that motion (per axis).
    pub motion_deg: f64,
    /// Time between poses (the `time_s` column).
    pub interval_s: f64,
}

impl SimConfig {
    /// Read and check a config; `model` is resolved against the config's folder.
    pub fn read(path: &Path) -> Result<Self, FileError> {
        let mut config = read_checked_yaml(path, SimConfig::check)?;
        config.model = path.parent().unwrap_or(Path::new(".")).join(&config.model);
        Ok(config)
    }

    /// Values serde accepted but that make no physical sense, as `(key, reason)`.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let non_negative = [
            ("axis_tilt_deg", self.truth.axis_tilt_deg),
            ("link_angle_deg", self.truth.link_angle_deg),
            ("joint_offset_deg", self.truth.joint_offset_deg),
            ("camera_position_m", self.truth.camera_position_m),
            ("camera_rotation_deg", self.truth.camera_rotation_deg),
            ("max_tilt_deg", self.workspace.max_tilt_deg),
            ("max_yaw_deg", self.workspace.max_yaw_deg),
            ("min_conditioning", self.workspace.min_conditioning),
            ("min_branch_margin", self.workspace.min_branch_margin),
            ("baseline_m", self.camera.baseline_m),
            ("lateral_sigma_m", self.camera.lateral_sigma_m),
            ("depth_sigma_m", self.camera.depth_sigma_m),
            ("outlier_sigma_m", self.camera.outlier_sigma_m),
            ("marker_radius_m", self.camera.marker_radius_m),
            ("noise_deg", self.encoders.noise_deg),
            ("motion_deg", self.capture.motion_deg),
            ("interval_s", self.capture.interval_s),
        ];
        for (key, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err((key, format!("`{key}` must be a finite, non-negative number (got {value})")));
            }
        }
        for (key, value) in
            [("height_m", self.camera.height_m), ("reference_distance_m", self.camera.reference_distance_m)]
        {
            if !(value.is_finite() && value > 0.0) {
                return Err((key, format!("`{key}` must be positive (got {value})")));
            }
        }
        if self.poses == 0 {
            return Err(("poses", "`poses` must be at least 1".into()));
        }
        if !(0.0..=1.0).contains(&self.camera.outlier_probability) {
            return Err(("outlier_probability", "`outlier_probability` must lie in [0, 1]".into()));
        }
        if self.encoders.counts_per_revolution == 0 {
            return Err(("counts_per_revolution", "`counts_per_revolution` must be at least 1".into()));
        }
        if self.workspace.max_tilt_deg >= 90.0 {
            return Err(("max_tilt_deg", "`max_tilt_deg` must be below 90°".into()));
        }
        Ok(())
    }
}
