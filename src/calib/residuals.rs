//! What a fit fits: a [`Residuals`] of residuals (one 3-vector per observation: a pose's rotation, a
//! marker's position) over a [`Parameterisation`], with the noise model that whitens them. The
//! orientation-level and marker-level fits are two implementations; the fit, the validation and
//! the uncertainty are written once against this trait.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};

use super::config::FitLevel;
use super::parameterisation::Parameterisation;
use crate::model::{FdaError, SpmError};

/// Residuals (and optionally their Jacobian) at a parameter vector.
#[derive(Debug, Clone, Default)]
pub(crate) struct Evaluation {
    /// Per-observation residuals, in the model's unit (radians or metres), camera frame.
    pub(crate) residuals: Vec<Vector3<f64>>,
    /// Predicted MP orientation `R` (P → B) of each distinct pose.
    pub(crate) orientations: Vec<Rotation3<f64>>,
    /// `3n × N`: rows `3j..3j+3` belong to observation j.
    pub(crate) jacobian: Option<DMatrix<f64>>,
    /// Sensitivity of each pose's predicted orientation to the parameters, `∂ω/∂x` (3 × N, in B).
    pub(crate) orientation_jacobians: Option<Vec<DMatrix<f64>>>,
}

/// Why a model could not be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    #[error("the parameters do not make a valid manipulator: {0}")]
    /// The parameters make no valid manipulator.
    Geometry(SpmError),
    #[error(
        "pose {pose}: at a camera latency of {latency_s} s (at time 0) and a clock rate of {clock_rate_ppm} ppm its frame falls outside the encoder stream"
    )]
    /// A frame falls outside the encoder stream at the camera clock tried.
    OutsideStream {
        /// Pose (frame) id.
        pose: u64,
        /// The latency tried (s, at the encoders' time 0).
        latency_s: f64,
        /// The clock's rate difference tried (ppm).
        clock_rate_ppm: f64,
    },
    #[error("pose {pose}: the marker falls behind camera {camera} of the rig")]
    /// A marker the model puts behind a camera that saw it.
    BehindCamera {
        /// Pose id.
        pose: u64,
        /// Camera index.
        camera: usize,
    },
    #[error("pose {pose}: forward kinematics failed: {error}")]
    /// The forward kinematics of a pose failed.
    Fda {
        /// Pose id.
        pose: u64,
        /// Why.
        error: FdaError,
    },
}

/// What an observation was, for the model check's structure tests: where in the camera's view,
/// at which joint angles, when, and which marker.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Observed {
    /// A point's measured position in the camera frame (m).
    pub(crate) point: Option<Vector3<f64>>,
    /// A pixel: the camera that saw it and its `(u, v)` (px).
    pub(crate) pixel: Option<(usize, [f64; 2])>,
    /// The joint readings (rad).
    pub(crate) joints: Vector3<f64>,
    /// The capture's time (s), in a recording.
    pub(crate) time_s: Option<f64>,
    /// The marker (marker level).
    pub(crate) marker: Option<usize>,
}

/// Residuals of a parameterisation and the noise model that whitens them.
pub(crate) trait Residuals {
    /// What the residuals imply about the measurement noise (feasible GLS): per-class covariances
    /// for orientations, the stereo σ's for markers.
    type Noise: Clone + std::fmt::Debug;

    /// The parameters.
    fn parameterisation(&self) -> &Parameterisation;

    /// Observations (residuals) of the model.
    fn len(&self) -> usize;

    /// The rows observation `j`'s residual really has: 3 for a point or a rotation, 2 for a pixel
    /// (its third component is always 0). The degrees of freedom and robust scales count these.
    fn rows(&self, _j: usize) -> usize {
        3
    }

    /// Residuals (and optionally their Jacobian) at `x`; each pose's FDA starts from `warm` (the
    /// orientations of the previous evaluation) when given.
    ///
    /// # Errors
    /// An [`EvalError`] when the parameters make no valid manipulator or a pose's FDA fails.
    fn evaluate(
        &self,
        x: &DVector<f64>,
        warm: Option<&[Rotation3<f64>]>,
        with_jacobian: bool,
    ) -> Result<Evaluation, EvalError>;

    /// The noise the (weighted) residuals imply.
    fn estimate_noise(&self, residuals: &[Vector3<f64>], weights: &[f64]) -> Self::Noise;

    /// `Σ_j^{-1/2}` of every observation under `noise`.
    fn whitening(&self, noise: &Self::Noise) -> Vec<Matrix3<f64>>;

    /// The same model computing only the Jacobian columns marked in `columns` (e.g. the free
    /// parameters of a fit of the registration alone); the others are left zero.
    #[must_use]
    fn with_columns(self, columns: Vec<bool>) -> Self
    where
        Self: Sized;

    /// The model of the observations `rows` only (in that order).
    #[must_use]
    fn subset(&self, rows: &[usize]) -> Self
    where
        Self: Sized;

    /// The group an observation belongs to for validation (a station or a pose): observations of
    /// one group are held out together.
    fn group(&self, j: usize) -> (bool, u64);

    /// Whether observation `j` is a rigid body's orientation (a rotation residual in radians), not
    /// a position: reported on its own, never in a position's unit.
    fn is_orientation(&self, _j: usize) -> bool {
        false
    }

    /// What each observation was (for the model check), its joints where the model at `x` reads
    /// them: in a recording, along the encoder stream at the fitted camera clock, not at the
    /// capture's own time stamp.
    fn observed(&self, x: &DVector<f64>) -> Vec<Observed>;

    /// Index into the evaluation's `orientations` of observation `j`'s pose.
    fn pose_of(&self, j: usize) -> usize;

    /// Distinct poses (FDA solutions) of the model.
    fn poses(&self) -> usize;

    /// Take back an evaluation the fit no longer needs, to reuse its storage (a Jacobian of
    /// 100,000 observations is 80 MB: allocating it afresh at every step is a tenth of the fit).
    fn recycle(&self, _old: Evaluation) {}

    /// The factor from the residuals' unit to the unit a person reads them in (radians to
    /// degrees, metres to millimetres).
    fn unit_scale(&self) -> f64;

    /// The fit level these residuals belong to (and so their unit, `deg` or `mm`).
    fn level(&self) -> FitLevel;

    /// The name of the unit a person reads them in: `deg` or `mm`.
    fn unit(&self) -> &'static str {
        self.level().unit()
    }

    /// The RMS of the residuals in the unit a person reads them in.
    fn report_rms(&self, residuals: &[Vector3<f64>]) -> f64 {
        rms(residuals) * self.unit_scale()
    }
}

/// RMS of the norms of `residuals` (in their own unit).
pub(crate) fn rms(residuals: &[Vector3<f64>]) -> f64 {
    crate::math::stats::rms(residuals.iter().map(|r| r.norm()))
}
