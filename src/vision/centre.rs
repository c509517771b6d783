//! The fixed point of the motion: every marker centroid obeys `c_j = o + Q_j (c_0 − o)` about
//! the centre of rotation `o`. Its least-squares residual measures how far the MP's motion is
//! from a pure rotation about one point: axis non-concurrency plus camera error.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

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

/// Least squares over the poses, `(I − Q_j) o = c_j − Q_j c_0`, by the SVD of the stacked system
/// (which also gives its conditioning).
/// `None` when the rotations leave `o` undetermined (all about one axis, or too few poses).
pub fn centre_of_rotation(estimates: &[PoseEstimate]) -> Option<CentreOfRotation> {
    let n = estimates.len();
    let mut a = DMatrix::zeros(3 * n, 3);
    let mut b = DVector::zeros(3 * n);
    for (k, e) in estimates.iter().enumerate() {
        let q = e.rotation.matrix();
        a.view_mut((3 * k, 0), (3, 3)).copy_from(&(Matrix3::identity() - q));
        b.rows_mut(3 * k, 3).copy_from(&(e.centroid - q * e.reference_centroid));
    }
    let svd = crate::so3::bounded_svd(&a, true, true)?;
    let conditioning = svd.singular_values.min() / svd.singular_values.max().max(f64::MIN_POSITIVE);
    if n < 2 || conditioning < 1e-3 {
        return None;
    }
    let o = svd.solve(&b, 0.0).ok()?;
    // (AᵀA)⁻¹ = V Σ⁻² Vᵀ.
    let v_t = svd.v_t.as_ref()?;
    let inv_normal = Matrix3::<f64>::from_fn(|i, k| {
        (0..3).map(|m| v_t[(m, i)] * v_t[(m, k)] / svd.singular_values[m].powi(2)).sum::<f64>()
    });
    let o = Vector3::new(o[0], o[1], o[2]);
    let residuals: Vec<f64> =
        estimates.iter().map(|e| (e.centroid - o - e.rotation * (e.reference_centroid - o)).norm()).collect();
    let variance = residuals.iter().map(|r| r * r).sum::<f64>() / (3 * n - 3).max(1) as f64;
    Some(CentreOfRotation {
        std_error_m: [0, 1, 2].map(|i| (variance * inv_normal[(i, i)]).sqrt()),
        position_m: o.into(),
        rms_residual_m: (residuals.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt(),
        max_residual_m: residuals.iter().fold(0.0, |m, r| m.max(*r)),
        conditioning,
    })
}
