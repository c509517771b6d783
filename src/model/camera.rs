//! The camera model: how a stereo camera distorts what it sees.
//!
//! A point at `x` in the camera frame (z along the optical axis) is reported at `K x`. A perfect
//! camera has `K = I`. A focal-length or disparity-scale error makes depths read long or short:
//! `K = diag(1, 1, s)`, `s` the depth scale. The affine model is the general linear `K` that the
//! data can tell from the registration and the markers:
//!
//! ```text
//!     ⎡ 1     k_xy  k_xz ⎤
//! K = ⎢ k_xy  s_y   k_yz ⎥
//!     ⎣ k_xz  k_yz  s    ⎦
//! ```
//!
//! Any linear distortion is a symmetric matrix times a rotation (polar decomposition) times a
//! uniform scale: the rotation is carried by `R_CB` and the uniform scale by the markers'
//! positions and `t_CB`, so neither is a term; the lateral x scale is the unit the others are
//! measured in.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Which camera model a fit uses (`camera_model` in configs and parameters files).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CameraModelKind {
    /// A perfect camera: `K = I`.
    #[default]
    Rigid,
    /// Depths read `s` times their length: `K = diag(1, 1, s)`.
    DepthScale,
    /// Per-axis scales and shears of the camera frame (five terms).
    Affine,
}

impl CameraModelKind {
    /// Its name in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            CameraModelKind::Rigid => "rigid",
            CameraModelKind::DepthScale => "depth_scale",
            CameraModelKind::Affine => "affine",
        }
    }

    /// The smallest model that has every term `needed` picks: affine when a term beyond the depth
    /// scale is picked, the depth-scale model when only that is, else rigid.
    pub fn smallest(needed: impl Fn(CameraTerm) -> bool) -> Self {
        if CameraTerm::ALL[1..].iter().any(|t| needed(*t)) {
            CameraModelKind::Affine
        } else if needed(CameraTerm::DepthScale) {
            CameraModelKind::DepthScale
        } else {
            CameraModelKind::Rigid
        }
    }

    /// The terms this model has.
    pub fn terms(self) -> &'static [CameraTerm] {
        match self {
            CameraModelKind::Rigid => &[],
            CameraModelKind::DepthScale => &[CameraTerm::DepthScale],
            CameraModelKind::Affine => &CameraTerm::ALL,
        }
    }
}

/// One term of the camera model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CameraTerm {
    /// `s`: the depth (optical-axis) scale.
    DepthScale,
    /// `s_y`: the scale of camera y relative to camera x.
    ScaleY,
    /// `k_xy`: the shear between camera x and y.
    ShearXy,
    /// `k_xz`: the shear between camera x and the optical axis.
    ShearXz,
    /// `k_yz`: the shear between camera y and the optical axis.
    ShearYz,
}

impl CameraTerm {
    /// Every term, in the order of [`CameraModel`]'s values.
    pub const ALL: [CameraTerm; 5] =
        [CameraTerm::DepthScale, CameraTerm::ScaleY, CameraTerm::ShearXy, CameraTerm::ShearXz, CameraTerm::ShearYz];

    /// Its name in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            CameraTerm::DepthScale => "depth_scale",
            CameraTerm::ScaleY => "scale_y",
            CameraTerm::ShearXy => "shear_xy",
            CameraTerm::ShearXz => "shear_xz",
            CameraTerm::ShearYz => "shear_yz",
        }
    }

    /// Its value for a perfect camera.
    pub fn perfect(self) -> f64 {
        match self {
            CameraTerm::DepthScale | CameraTerm::ScaleY => 1.0,
            CameraTerm::ShearXy | CameraTerm::ShearXz | CameraTerm::ShearYz => 0.0,
        }
    }

    fn index(self) -> usize {
        self as usize
    }

    /// `∂K/∂term`: the term's unit matrix.
    fn unit(self) -> Matrix3<f64> {
        let (a, b) = match self {
            CameraTerm::DepthScale => (2, 2),
            CameraTerm::ScaleY => (1, 1),
            CameraTerm::ShearXy => (0, 1),
            CameraTerm::ShearXz => (0, 2),
            CameraTerm::ShearYz => (1, 2),
        };
        let mut m = Matrix3::zeros();
        m[(a, b)] = 1.0;
        m[(b, a)] = 1.0;
        m
    }

    /// How the reported position of `x` moves with the term: `(∂K/∂term) x`.
    pub fn derivative(self, x: &Vector3<f64>) -> Vector3<f64> {
        self.unit() * x
    }
}

/// A camera model with its terms' values and, when fitted, their standard errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraModel {
    /// Which model.
    pub kind: CameraModelKind,
    values: [f64; 5],
    std_errors: [Option<f64>; 5],
}

impl Default for CameraModel {
    fn default() -> Self {
        CameraModel::rigid()
    }
}

impl CameraModel {
    /// A perfect camera.
    pub fn rigid() -> Self {
        CameraModel {
            kind: CameraModelKind::Rigid,
            values: CameraTerm::ALL.map(CameraTerm::perfect),
            std_errors: [None; 5],
        }
    }

    /// A camera of model `kind` with a perfect camera's values.
    pub fn perfect(kind: CameraModelKind) -> Self {
        CameraModel { kind, ..CameraModel::rigid() }
    }

    /// The same values as the model `kind` (terms outside it keep their values: a perfect
    /// camera's, wherever models are read or fitted).
    #[must_use]
    pub fn with_kind(self, kind: CameraModelKind) -> Self {
        CameraModel { kind, ..self }
    }

    /// The model `kind` with the terms' `values` in the order of [`CameraTerm::ALL`], no standard
    /// errors.
    pub fn of(kind: CameraModelKind, values: [f64; 5]) -> Self {
        CameraModel { kind, values, std_errors: [None; 5] }
    }

    /// A camera whose depths read `s` times their length.
    pub fn depth_scale(s: f64) -> Self {
        CameraModel::perfect(CameraModelKind::DepthScale).with(CameraTerm::DepthScale, s, None)
    }

    /// The same model with `term` at `value` (standard error `std_error`).
    #[must_use]
    pub fn with(mut self, term: CameraTerm, value: f64, std_error: Option<f64>) -> Self {
        self.values[term.index()] = value;
        self.std_errors[term.index()] = std_error;
        self
    }

    /// The value of `term`.
    pub fn value(&self, term: CameraTerm) -> f64 {
        self.values[term.index()]
    }

    /// The standard error of `term`, when fitted.
    pub fn std_error(&self, term: CameraTerm) -> Option<f64> {
        self.std_errors[term.index()]
    }

    /// Whether the camera reports every point where it is (`K = I`).
    pub fn is_perfect(&self) -> bool {
        CameraTerm::ALL.iter().all(|t| self.value(*t) == t.perfect())
    }

    /// `K`.
    pub fn matrix(&self) -> Matrix3<f64> {
        CameraTerm::ALL.iter().fold(Matrix3::identity(), |k, t| k + t.unit() * (self.value(*t) - t.perfect()))
    }

    /// `det K`: a model whose determinant is below [`CameraModel::MIN_DETERMINANT`] squeezes space
    /// flat along some direction and is refused where it is read.
    pub fn determinant(&self) -> f64 {
        self.matrix().determinant()
    }

    /// The smallest `det K` accepted: a quarter (a camera that halves two axes).
    pub const MIN_DETERMINANT: f64 = 0.25;

    /// Where the camera reports a point at `x` in its frame: `K x`.
    pub fn distort(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.matrix() * x
    }

    /// `∂(K x)/∂x` at `x`: how the reported position moves with the point (the fit carries every
    /// parameter but the camera model's own through it).
    pub fn jacobian(&self, _x: &Vector3<f64>) -> Matrix3<f64> {
        self.matrix()
    }

    /// How the reported position of `x` moves with `term`.
    pub fn term_derivative(&self, term: CameraTerm, x: &Vector3<f64>) -> Vector3<f64> {
        term.derivative(x)
    }

    /// Where a point the camera reports at `m` is: `K⁻¹ m` (`None` when `K` is singular).
    pub fn undistort(&self, m: &Vector3<f64>) -> Option<Vector3<f64>> {
        self.matrix().try_inverse().map(|k| k * m)
    }
}

#[cfg(feature = "full")] // configs hold it; the lean core reads none
/// The camera model's terms by name, as configs give them: the start (or known correction) of a
/// calibration's camera model, the simulated camera's distortion (a perfect camera's by default).
/// The one definition of the terms' names; [`CameraModel`] holds them with a kind and standard
/// errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraTerms {
    /// Depths read this many times their length.
    pub depth_scale: f64,
    /// Camera y reads this many times its length relative to camera x.
    pub scale_y: f64,
    /// Shear between camera x and y.
    pub shear_xy: f64,
    /// Shear between camera x and the optical axis.
    pub shear_xz: f64,
    /// Shear between camera y and the optical axis.
    pub shear_yz: f64,
}

#[cfg(feature = "full")]
impl Default for CameraTerms {
    fn default() -> Self {
        CameraTerms { depth_scale: 1.0, scale_y: 1.0, shear_xy: 0.0, shear_xz: 0.0, shear_yz: 0.0 }
    }
}

#[cfg(feature = "full")]
impl CameraTerms {
    /// The values in the order of [`CameraTerm::ALL`].
    pub(crate) fn values(&self) -> [f64; 5] {
        [self.depth_scale, self.scale_y, self.shear_xy, self.shear_xz, self.shear_yz]
    }

    /// The camera model `kind` with these terms.
    pub fn model(&self, kind: CameraModelKind) -> CameraModel {
        CameraModel::of(kind, self.values())
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    #[test]
    fn a_depth_scale_stretches_only_the_optical_axis() {
        let x = Vector3::new(0.1, -0.2, 0.8);
        let m = CameraModel::depth_scale(1.02).distort(&x);
        assert_eq!(m, Vector3::new(0.1, -0.2, 0.8 * 1.02));
        assert!((CameraModel::depth_scale(1.02).undistort(&m).unwrap() - x).norm() < 1e-15);
    }

    #[test]
    fn each_term_moves_the_reported_point_by_its_derivative() {
        let x = Vector3::new(0.1, -0.2, 0.8);
        let base = CameraModel::perfect(CameraModelKind::Affine).with(CameraTerm::ScaleY, 0.99, None).with(
            CameraTerm::ShearXz,
            0.01,
            None,
        );
        for term in CameraTerm::ALL {
            let h = 1e-6;
            let moved = base.with(term, base.value(term) + h, None);
            let numeric = (moved.distort(&x) - base.distort(&x)) / h;
            assert!((numeric - term.derivative(&x)).norm() < 1e-9, "{term:?}: {numeric} vs {}", term.derivative(&x));
        }
        let k = base.matrix();
        assert!((k - k.transpose()).norm() == 0.0, "K is symmetric");
        assert_eq!(k[(0, 0)], 1.0, "the lateral x scale is the unit");
    }
}
