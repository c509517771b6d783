//! What one recording shows ([`Scene`]), and why writing it may fail.

use std::collections::BTreeMap;
use std::path::PathBuf;

use nalgebra::Rotation3;

use crate::calib::IterationLog;
use crate::dataset::Session;
use crate::model::{CameraModel, CameraRegistration, RobotModel, Spm};

/// MP orientations of one source, by pose.
#[derive(Debug, Clone)]
pub(crate) struct PoseFrames {
    /// Entity name under `world/mp/`.
    pub(crate) name: String,
    /// Orientation (P → B) per pose.
    pub(crate) rotations: BTreeMap<u64, Rotation3<f64>>,
}

/// A scalar per pose, plotted under `errors/`.
#[derive(Debug, Clone)]
pub(crate) struct Series {
    /// Entity path under `errors/`.
    pub(crate) name: String,
    /// Value per pose.
    pub(crate) values: BTreeMap<u64, f64>,
}

/// Pixels of one source (`measured`, `predicted`, `nominal`, …) in a pixel session's image
/// planes: per pose, `(camera, marker, pixel)` in Kalibr's pixel coordinates (the top-left
/// pixel's centre at (0, 0)).
#[derive(Debug, Clone)]
pub(crate) struct PixelLayer {
    /// Entity name under `world/camera/<camera>/`.
    pub(crate) name: String,
    /// The pixels, by pose.
    pub(crate) pixels: BTreeMap<u64, Vec<(usize, usize, nalgebra::Vector2<f64>)>>,
}

/// A pixel session's cameras: the rig that places and draws their image planes (each a Pinhole
/// under `world/camera/<camera>`) and the pixels shown in them.
#[derive(Debug, Clone)]
pub(crate) struct ImagePlanes {
    /// The rig drawn (the refined one after a calibration).
    pub(crate) rig: crate::model::Rig,
    /// What is drawn in every camera's image, measured first.
    pub(crate) layers: Vec<PixelLayer>,
}

/// Everything one recording shows.
pub struct Scene<'a> {
    /// The session recorded.
    pub session: &'a Session,
    /// Its model (markers, shapes).
    pub model: &'a RobotModel,
    /// The geometry that draws the legs and predicts the markers.
    pub mechanism: Spm,
    /// Camera registration, to put the measured markers in the base frame.
    pub registration: Option<CameraRegistration>,
    /// The camera model that corrects the measured markers before (`K⁻¹`): a perfect camera
    /// unless the scene's parameters fitted (or simulated) one.
    pub camera_model: CameraModel,
    /// MP orientations to draw (e.g. vision, nominal, calibrated).
    pub(crate) frames: Vec<PoseFrames>,
    /// Per-pose scalars to plot.
    pub(crate) series: Vec<Series>,
    /// The fit's iterations, on the `iteration` timeline.
    pub iterations: Vec<IterationLog>,
    /// `(entity under parameters/, markdown)`.
    pub documents: Vec<(String, String)>,
    /// The markers' fitted positions in P (marker-level calibration): the predicted markers use
    /// them, and the model's positions are drawn beside them.
    pub fitted_markers: Option<Vec<nalgebra::Vector3<f64>>>,
    /// A pixel session's image planes (none for a session of points).
    pub(crate) image_planes: Option<ImagePlanes>,
}

/// What was written.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RecordingSummary {
    /// The `.rrd` file.
    pub path: PathBuf,
    /// Poses recorded.
    pub poses: usize,
    /// File size.
    pub bytes: u64,
}

/// Why a recording could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordError {
    #[error("{path}: cannot create the recording: {reason}")]
    /// The file cannot be created.
    Create {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    #[error("{path}: cannot log {entity}: {reason}")]
    /// An entity cannot be logged.
    Log {
        /// The file.
        path: PathBuf,
        /// Entity path.
        entity: String,
        /// Why.
        reason: String,
    },
}

/// Entity of the fit's iteration table (a markdown document).
pub(crate) const FIT_TABLE: &str = "fit/iterations";

/// The Rerun application id of every recording.
pub(crate) const APPLICATION: &str = "spmcal";

impl Scene<'_> {
    /// The entity paths of the per-pose scalars plotted under `errors/` (e.g.
    /// `markers_mm/replayed`).
    pub fn series_names(&self) -> impl Iterator<Item = &str> {
        self.series.iter().map(|s| s.name.as_str())
    }
}
