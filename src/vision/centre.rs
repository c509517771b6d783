//! The fixed point of the motion: every marker centroid obeys `c_j = o + Q_j (c_0 − o)` about
//! the centre of rotation `o`. Its least-squares residual measures how far the MP's motion is
//! from a pure rotation about one point: axis non-concurrency plus camera error.

use nalgebra::{Matrix3, Vector3};

use super::pose::PoseEstimate;

/// The estimated centre of rotation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CentreOfRotation {
    /// `o`, camera frame, metres.
    pub position_m: [f64; 3],
    /// RMS over poses of `|c_j − o − Q_j (c_0 − o)|`, metres.
    pub rms_residual_m: f64,
    /// Largest such residual, metres.
    pub max_residual_m: f64,
    /// Standard errors of `o` from the least squares (residual variance × `(AᵀA)⁻¹`), metres.
    pub std_error_m: [f64; 3],
    /// Smallest singular value of the stacked `I − Q_j`, over its largest: near 0 when every
    /// rotation shares one axis and `o` slides along it.
    pub conditioning: f64,
}

/// Least squares over the poses, `(I − Q_j) o = c_j − Q_j c_0`, by its 3 × 3 normal equations
/// (a session has hundreds of thousands of poses; the stacked system's SVD would copy them all
/// and cost 30 times more, and with the conditioning required below the normal equations lose
/// at most six of sixteen digits).
/// `None` when the rotations leave `o` undetermined (all about one axis, or too few poses).
pub(crate) fn centre_of_rotation<'a>(
    estimates: impl Iterator<Item = &'a PoseEstimate> + Clone,
) -> Option<CentreOfRotation> {
    let (mut normal, mut rhs, mut n) = (Matrix3::zeros(), Vector3::zeros(), 0_usize);
    for e in estimates.clone() {
        let a = Matrix3::identity() - e.rotation.matrix();
        normal += a.transpose() * a;
        rhs += a.transpose() * (e.centroid - e.rotation * e.reference_centroid);
        n += 1;
    }
    let eigen = crate::math::linalg::bounded_symmetric_eigen(&normal)?;
    let (smallest, largest) = (eigen.eigenvalues.min().max(0.0), eigen.eigenvalues.max());
    // The singular values of the stacked system are the square roots of the eigenvalues.
    let conditioning = (smallest / largest.max(f64::MIN_POSITIVE)).sqrt();
    if n < 2 || conditioning < 1e-3 {
        return None;
    }
    let inverse = eigen.eigenvectors
        * Matrix3::from_diagonal(&eigen.eigenvalues.map(|l| 1.0 / l))
        * eigen.eigenvectors.transpose();
    let o = inverse * rhs;
    let residual = |e: &PoseEstimate| (e.centroid - o - e.rotation * (e.reference_centroid - o)).norm();
    let (mut squares, mut max_residual_m) = (0.0, 0.0_f64);
    for r in estimates.map(residual) {
        squares += r * r;
        max_residual_m = max_residual_m.max(r);
    }
    let variance = squares / (3 * n - 3).max(1) as f64;
    Some(CentreOfRotation {
        std_error_m: [0, 1, 2].map(|i| (variance * inverse[(i, i)]).sqrt()),
        position_m: o.into(),
        rms_residual_m: (squares / n as f64).sqrt(),
        max_residual_m,
        conditioning,
    })
}
