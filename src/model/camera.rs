//! The camera model: how a stereo camera distorts what it sees.
//!
//! A point at `x` in the camera frame (z along the optical axis) is reported at `f(x)`. A perfect
//! camera reports it where it is (`rigid`). A focal-length or disparity-scale error makes depths
//! read long or short: `f(x) = K x`, `K = diag(1, 1, s)`, `s` the depth scale (`depth_scale`).
//! The affine model is the general linear `K` that the data can tell from the registration and
//! the markers (`affine`):
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
//!
//! The projective model (`projective`) is a homography of space, what a stereo rig with wrong
//! intrinsics or extrinsics does to the points it triangulates (a principal point off by `δ`
//! pixels shifts every disparity, so depths read `z / (1 + z δ / (f b))`):
//!
//! ```text
//! f(x) = (A x + b) / (cᵀx + 1)      reduced to      f(x) = K x / (cᵀx + 1)
//! ```
//!
//! with `K` the affine model's symmetric matrix and `c` three more terms (`perspective_x`, `_y`,
//! `_z`, per metre): eight in all. `b` is carried by `t_CB`: with `x' = x + A⁻¹b`,
//! `(A x + b) / (cᵀx + 1) = A x' / (cᵀx' + γ)`, `γ = 1 − cᵀA⁻¹b`, which is `(A/γ) x' / ((c/γ)ᵀx' + 1)`.
//! A uniform scale `λ A` is carried by the markers and `t_CB`: scaled by `λ`, they make every `x`
//! into `x̃ = λ x`, and `λ A x / (cᵀx + 1) = A x̃ / ((c/λ)ᵀx̃ + 1)`, so `c` takes the scale and `K`
//! keeps its lateral x scale at 1. The rotation is carried by `R_CB` as in the affine case (it
//! turns `c` with it). The model is refused wherever it is read when its denominator could fall
//! below [`CameraModel::MIN_DENOMINATOR`] in the camera's working volume (within
//! [`CameraModel::WORKING_RANGE_M`] of it): beyond, space folds over.

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
    /// A homography of space: the affine terms and the three of the denominator (eight terms).
    Projective,
}

impl CameraModelKind {
    /// Every model, simplest first: each has the terms of the one before it and more.
    pub const ALL: [CameraModelKind; 4] =
        [CameraModelKind::Rigid, CameraModelKind::DepthScale, CameraModelKind::Affine, CameraModelKind::Projective];

    /// Its name in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            CameraModelKind::Rigid => "rigid",
            CameraModelKind::DepthScale => "depth_scale",
            CameraModelKind::Affine => "affine",
            CameraModelKind::Projective => "projective",
        }
    }

    /// The smallest model that has every term `needed` picks.
    pub fn smallest(needed: impl Fn(CameraTerm) -> bool) -> Self {
        let all = |kind: CameraModelKind| CameraTerm::ALL.iter().all(|t| !needed(*t) || kind.terms().contains(t));
        CameraModelKind::ALL.into_iter().find(|k| all(*k)).unwrap_or(CameraModelKind::Projective)
    }

    /// The terms this model has.
    pub fn terms(self) -> &'static [CameraTerm] {
        match self {
            CameraModelKind::Rigid => &[],
            CameraModelKind::DepthScale => &[CameraTerm::DepthScale],
            CameraModelKind::Affine => &CameraTerm::ALL[..5],
            CameraModelKind::Projective => &CameraTerm::ALL,
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
    /// `c_x`: how the projective denominator grows along camera x (per metre).
    PerspectiveX,
    /// `c_y`: how it grows along camera y (per metre).
    PerspectiveY,
    /// `c_z`: how it grows along the optical axis (per metre).
    PerspectiveZ,
}

impl CameraTerm {
    /// Every term, in the order of [`CameraModel`]'s values.
    pub const ALL: [CameraTerm; 8] = [
        CameraTerm::DepthScale,
        CameraTerm::ScaleY,
        CameraTerm::ShearXy,
        CameraTerm::ShearXz,
        CameraTerm::ShearYz,
        CameraTerm::PerspectiveX,
        CameraTerm::PerspectiveY,
        CameraTerm::PerspectiveZ,
    ];

    /// Its name in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            CameraTerm::DepthScale => "depth_scale",
            CameraTerm::ScaleY => "scale_y",
            CameraTerm::ShearXy => "shear_xy",
            CameraTerm::ShearXz => "shear_xz",
            CameraTerm::ShearYz => "shear_yz",
            CameraTerm::PerspectiveX => "perspective_x",
            CameraTerm::PerspectiveY => "perspective_y",
            CameraTerm::PerspectiveZ => "perspective_z",
        }
    }

    /// Its value for a perfect camera.
    pub fn perfect(self) -> f64 {
        match self {
            CameraTerm::DepthScale | CameraTerm::ScaleY => 1.0,
            _ => 0.0,
        }
    }

    fn index(self) -> usize {
        self as usize
    }

    /// Whether it is a term of the denominator's `c` (per metre), not of `K`.
    #[cfg(feature = "full")] // only the fit bounds them
    pub(crate) fn is_perspective(self) -> bool {
        self.perspective_axis().is_some()
    }

    /// The axis of `c` a perspective term is, `None` for a term of `K`.
    fn perspective_axis(self) -> Option<usize> {
        match self {
            CameraTerm::PerspectiveX => Some(0),
            CameraTerm::PerspectiveY => Some(1),
            CameraTerm::PerspectiveZ => Some(2),
            _ => None,
        }
    }

    /// `∂K/∂term`: the term's unit matrix (zero for a perspective term).
    fn unit(self) -> Matrix3<f64> {
        let (a, b) = match self {
            CameraTerm::DepthScale => (2, 2),
            CameraTerm::ScaleY => (1, 1),
            CameraTerm::ShearXy => (0, 1),
            CameraTerm::ShearXz => (0, 2),
            CameraTerm::ShearYz => (1, 2),
            CameraTerm::PerspectiveX | CameraTerm::PerspectiveY | CameraTerm::PerspectiveZ => {
                return Matrix3::zeros();
            }
        };
        let mut m = Matrix3::zeros();
        m[(a, b)] = 1.0;
        m[(b, a)] = 1.0;
        m
    }
}

/// The number of terms.
const TERMS: usize = CameraTerm::ALL.len();

/// A camera model with its terms' values and, when fitted, their standard errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraModel {
    /// Which model.
    pub kind: CameraModelKind,
    values: [f64; TERMS],
    std_errors: [Option<f64>; TERMS],
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
            std_errors: [None; TERMS],
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

    /// The model `kind` with the terms' `values` in the order of [`CameraTerm::ALL`] (the first
    /// `N` of them; the rest a perfect camera's), no standard errors.
    pub fn of<const N: usize>(kind: CameraModelKind, values: [f64; N]) -> Self {
        let model = CameraModel::perfect(kind);
        CameraTerm::ALL.iter().zip(values).fold(model, |m, (t, v)| m.with(*t, v, None))
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

    /// Whether the camera reports every point where it is.
    pub fn is_perfect(&self) -> bool {
        CameraTerm::ALL.iter().all(|t| self.value(*t) == t.perfect())
    }

    /// `K`, the linear part.
    pub fn matrix(&self) -> Matrix3<f64> {
        CameraTerm::ALL.iter().fold(Matrix3::identity(), |k, t| k + t.unit() * (self.value(*t) - t.perfect()))
    }

    /// `c`, the denominator's growth per metre along each camera axis.
    fn perspective(&self) -> Vector3<f64> {
        Vector3::new(
            self.value(CameraTerm::PerspectiveX),
            self.value(CameraTerm::PerspectiveY),
            self.value(CameraTerm::PerspectiveZ),
        )
    }

    /// `det K`: a model whose determinant is below [`CameraModel::MIN_DETERMINANT`] squeezes space
    /// flat along some direction and is refused where it is read.
    pub fn determinant(&self) -> f64 {
        self.matrix().determinant()
    }

    /// The smallest `det K` accepted: a quarter (a camera that halves two axes).
    pub const MIN_DETERMINANT: f64 = 0.25;

    /// The camera's working volume, where a model must stay defined: every point within this
    /// distance of it (m). A stereo camera watching a wrist-sized mechanism works well inside.
    pub const WORKING_RANGE_M: f64 = 2.0;

    /// The smallest denominator `cᵀx + 1` accepted in the working volume: a half (a camera that
    /// doubles the distances there). A model below it is refused where it is read.
    pub const MIN_DENOMINATOR: f64 = 0.5;

    /// The smallest denominator `cᵀx + 1` over the working volume, `1 − |c| · WORKING_RANGE_M`
    /// (1 for a linear model).
    pub fn smallest_denominator(&self) -> f64 {
        1.0 - self.perspective().norm() * Self::WORKING_RANGE_M
    }

    /// Why the model cannot be used, in words, when it cannot: `K` nearly singular, or its
    /// denominator near zero in the working volume. Every reader of a model (parameters files,
    /// configs, the simulator's) refuses such a model with this reason.
    pub(crate) fn defect(&self) -> Option<String> {
        if self.determinant() < Self::MIN_DETERMINANT {
            return Some(format!(
                "the camera model is nearly singular (det K = {:.3}, below {}): its scales and shears flatten space",
                self.determinant(),
                Self::MIN_DETERMINANT
            ));
        }
        let smallest = self.smallest_denominator();
        (smallest < Self::MIN_DENOMINATOR).then(|| {
            format!(
                "the projective camera's denominator cᵀx + 1 falls to {smallest:.3} within {} m of the camera (|c| = \
                 {:.4} per metre; at most {} there, below which space folds over): the perspective terms must keep \
                 |c| ≤ {:.3} per metre",
                Self::WORKING_RANGE_M,
                self.perspective().norm(),
                Self::MIN_DENOMINATOR,
                (1.0 - Self::MIN_DENOMINATOR) / Self::WORKING_RANGE_M
            )
        })
    }

    /// Where the camera reports a point at `x` in its frame: `K x / (cᵀx + 1)`.
    pub fn distort(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.matrix() * x / self.denominator(x)
    }

    fn denominator(&self, x: &Vector3<f64>) -> f64 {
        self.perspective().dot(x) + 1.0
    }

    /// `∂f/∂x` at `x`, `(K − f(x) cᵀ) / (cᵀx + 1)`: how the reported position moves with the point
    /// (the fit carries every parameter but the camera model's own through it).
    pub fn jacobian(&self, x: &Vector3<f64>) -> Matrix3<f64> {
        let d = self.denominator(x);
        let f = self.matrix() * x / d;
        (self.matrix() - f * self.perspective().transpose()) / d
    }

    /// How the reported position of `x` moves with `term`: `(∂K/∂term) x / (cᵀx + 1)` for a term
    /// of `K`, `−f(x) x_k / (cᵀx + 1)` for the perspective term `c_k`.
    pub fn term_derivative(&self, term: CameraTerm, x: &Vector3<f64>) -> Vector3<f64> {
        let d = self.denominator(x);
        match term.perspective_axis() {
            Some(k) => -(self.matrix() * x) * x[k] / (d * d),
            None => term.unit() * x / d,
        }
    }

    /// Where a point the camera reports at `m` is, exactly: with `z = K⁻¹ m = x / (cᵀx + 1)`,
    /// `cᵀx + 1 = 1 / (1 − cᵀz)`, so `x = z / (1 − cᵀz)`. `None` when `K` is singular or `m` lies
    /// where no point in front of the denominator's zero is reported.
    pub fn undistort(&self, m: &Vector3<f64>) -> Option<Vector3<f64>> {
        let z = self.matrix().try_inverse()? * m;
        let scale = 1.0 - self.perspective().dot(&z);
        (scale > 0.0).then(|| z / scale)
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
    /// Growth of the projective denominator along camera x, per metre.
    pub perspective_x: f64,
    /// Growth of the projective denominator along camera y, per metre.
    pub perspective_y: f64,
    /// Growth of the projective denominator along the optical axis, per metre.
    pub perspective_z: f64,
}

#[cfg(feature = "full")]
impl Default for CameraTerms {
    fn default() -> Self {
        CameraTerms::of(&CameraModel::rigid())
    }
}

#[cfg(feature = "full")]
impl CameraTerms {
    /// The values in the order of [`CameraTerm::ALL`].
    pub(crate) fn values(&self) -> [f64; TERMS] {
        [
            self.depth_scale,
            self.scale_y,
            self.shear_xy,
            self.shear_xz,
            self.shear_yz,
            self.perspective_x,
            self.perspective_y,
            self.perspective_z,
        ]
    }

    /// The terms of `model` by name.
    pub(crate) fn of(model: &CameraModel) -> Self {
        let [depth_scale, scale_y, shear_xy, shear_xz, shear_yz, perspective_x, perspective_y, perspective_z] =
            model.values;
        CameraTerms { depth_scale, scale_y, shear_xy, shear_xz, shear_yz, perspective_x, perspective_y, perspective_z }
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

    /// A projective camera like a stereo rig's with wrong intrinsics: every term away from a
    /// perfect camera's by a few percent (per metre for `c`).
    fn projective() -> CameraModel {
        CameraModel::of(CameraModelKind::Projective, [1.02, 0.99, 0.005, 0.01, -0.008, 0.03, -0.02, 0.05])
    }

    #[test]
    fn a_depth_scale_stretches_only_the_optical_axis() {
        let x = Vector3::new(0.1, -0.2, 0.8);
        let m = CameraModel::depth_scale(1.02).distort(&x);
        assert_eq!(m, Vector3::new(0.1, -0.2, 0.8 * 1.02));
        assert!((CameraModel::depth_scale(1.02).undistort(&m).unwrap() - x).norm() < 1e-15);
    }

    #[test]
    fn each_term_moves_the_reported_point_by_its_derivative() {
        // Central differences, error O(h²): with h = 1e-5 and second derivatives O(1) m, about
        // 1e-10 m, far below 1e-8; a wrong sign or factor is off by the derivative itself (≥ 1e-3 m).
        let x = Vector3::new(0.1, -0.2, 0.8);
        let h = 1e-5;
        for base in [CameraModel::perfect(CameraModelKind::Projective), projective()] {
            for term in CameraTerm::ALL {
                let at = |d: f64| base.with(term, base.value(term) + d, None).distort(&x);
                let numeric = (at(h) - at(-h)) / (2.0 * h);
                let analytic = base.term_derivative(term, &x);
                assert!(analytic.norm() > 1e-3, "{term:?} moves the point");
                assert!((numeric - analytic).norm() < 1e-8, "{term:?}: {numeric} vs {analytic}");
            }
        }
        let k = projective().matrix();
        assert!((k - k.transpose()).norm() == 0.0, "K is symmetric");
        assert_eq!(k[(0, 0)], 1.0, "the lateral x scale is the unit");
    }

    #[test]
    fn the_jacobian_is_the_derivative_of_the_reported_point() {
        // Central differences along each axis, as above (the map's second derivatives are O(0.1)).
        let (model, h) = (projective(), 1e-5);
        for x in [Vector3::new(0.1, -0.2, 0.8), Vector3::new(-0.4, 0.3, 1.5)] {
            let numeric = Matrix3::from_columns(&[0, 1, 2].map(|k| {
                let e = Vector3::ith(k, h);
                (model.distort(&(x + e)) - model.distort(&(x - e))) / (2.0 * h)
            }));
            let analytic = model.jacobian(&x);
            assert!((numeric - analytic).norm() < 1e-9, "{numeric} vs {analytic}");
            assert!((analytic - model.matrix()).norm() > 1e-3, "the denominator's share is there");
        }
    }

    #[test]
    fn undistort_is_the_exact_inverse_of_distort() {
        let model = projective();
        for x in [Vector3::new(0.1, -0.2, 0.8), Vector3::new(-1.0, 0.7, 1.6), Vector3::new(0.0, 0.0, 0.05)] {
            let m = model.distort(&x);
            assert!((m - x).norm() > 1e-3, "the model moves the point");
            let back = model.undistort(&m).unwrap();
            assert!((back - x).norm() < 1e-14, "{back} vs {x}");
        }
        // A reported point beyond the image of the denominator's zero has no preimage.
        let steep = CameraModel::perfect(CameraModelKind::Projective).with(CameraTerm::PerspectiveZ, 0.2, None);
        assert!(steep.undistort(&Vector3::new(0.0, 0.0, 6.0)).is_none());
        assert!((steep.distort(&steep.undistort(&Vector3::new(0.0, 0.0, 4.0)).unwrap()).z - 4.0).abs() < 1e-12);
    }

    #[test]
    fn the_smallest_model_has_every_term_needed_and_no_more() {
        assert_eq!(CameraModelKind::smallest(|_| false), CameraModelKind::Rigid);
        assert_eq!(CameraModelKind::smallest(|t| t == CameraTerm::DepthScale), CameraModelKind::DepthScale);
        assert_eq!(CameraModelKind::smallest(|t| t == CameraTerm::ShearXz), CameraModelKind::Affine);
        assert_eq!(CameraModelKind::smallest(|t| t == CameraTerm::PerspectiveY), CameraModelKind::Projective);
        for pair in CameraModelKind::ALL.windows(2) {
            assert!(pair[0].terms().iter().all(|t| pair[1].terms().contains(t)), "{pair:?} are nested");
        }
    }

    #[test]
    fn a_model_whose_denominator_nears_zero_where_the_camera_sees_is_refused() {
        assert!(projective().defect().is_none());
        // |c| = 0.3 per metre: the denominator is 0.4 at 2 m.
        let steep = CameraModel::perfect(CameraModelKind::Projective).with(CameraTerm::PerspectiveZ, -0.3, None);
        assert!((steep.smallest_denominator() - 0.4).abs() < 1e-12);
        assert!(steep.defect().unwrap().contains("falls to 0.400"), "{:?}", steep.defect());
        let flat = CameraModel::perfect(CameraModelKind::Affine).with(CameraTerm::DepthScale, 0.2, None);
        assert!(flat.defect().unwrap().contains("nearly singular"));
    }
}
