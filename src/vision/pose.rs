//! Orientation of the MP in one pose relative to the reference pose, from marker positions
//! (He, Angeles & Kövecses 2015, §IV), and the optimal alternative (Kabsch).
//!
//! With `P_j` the matrix of marker positions about their centroid (eqs. 1–3), the putative
//! rotation solves `P_0ᵀ Q̃ᵀ = P_jᵀ` in least squares (eqs. 5–7). It is computed from a QR
//! factorisation of `P_0ᵀ`, made once per reference and set of markers and reused for every pose
//! that sees the same markers, never by forming `(P_0 P_0ᵀ)⁻¹`. Its polar decomposition
//! `Q̃ = Q T` (eq. 8) gives the rotation `Q`; `T = Qᵀ Q̃` (eq. 9) holds the measurement error,
//! summarised as `e = ‖T − 1‖_F / 3` (eqs. 11–12, see [`orthogonality_error`]).
//!
//! Markers on a plane (three markers, or four in a plane) leave `P_0` of rank 2 and the least
//! squares undetermined; a virtual marker along the plane's normal (Newell's method, scaled to the
//! markers' RMS radius) is then added to both poses, which determines `Q̃` without redundancy.

use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};

use crate::math::constellation::{self, Degeneracy, MARKER_NOISE_M};
use crate::math::polar::Polar;
use crate::math::so3;

/// Which rotation estimate to return.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Least-squares putative rotation, then its polar decomposition (the paper).
    #[default]
    Paper,
    /// The rotation minimising the squared marker residuals (orthogonal Procrustes: the nearest
    /// rotation, by Higham's polar iteration with an SVD fallback).
    Kabsch,
}

/// Below this ratio of the third to the largest singular value the markers count as planar and
/// get the virtual normal marker (a 4th marker 5% of the triangle's size off the plane adds
/// little but noise in the normal direction).
pub(crate) const PLANAR_RATIO: f64 = 0.05;
/// Why markers cannot give an orientation (the pose is named by the caller).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MarkerError {
    #[error("{seen} markers seen in both this pose and the reference; at least 3 are needed")]
    /// Fewer than 3 markers are seen in both poses.
    TooFew {
        /// Markers seen in both.
        seen: usize,
    },
    /// No pose of the session sees three markers (e.g. one marker at a time without stations).
    #[error(
        "no pose sees 3 markers (at most {most}): the per-pose estimator has nothing to work on; `calibrate` (the marker-level fit) uses every marker"
    )]
    NoPoseWithThree {
        /// The most markers any pose sees.
        most: usize,
    },
    /// The markers cannot fix an orientation (judged against the marker noise).
    #[error(transparent)]
    Degenerate(#[from] Degeneracy),
    /// The least squares has no unique solution for this pose's markers.
    #[error("this pose's markers give no unique rotation (they collapse onto a line or a point)")]
    NoSolution,
    #[error(
        "the putative rotation has determinant {det:.4} ≤ 0: the markers are mirrored (swapped labels?), not rotated"
    )]
    /// The estimate is a reflection.
    Reflection {
        /// Its determinant.
        det: f64,
    },
    #[error("the putative rotation is singular: {0}")]
    /// The estimate has no polar factor.
    Singular(crate::math::polar::PolarError),
}

/// The estimate for one pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseEstimate {
    /// `Q_j`: rotation from the reference pose to this one, in the camera frame.
    pub rotation: Rotation3<f64>,
    /// `Q̃_j`, the least-squares putative rotation (eq. 7).
    pub putative: Matrix3<f64>,
    /// `T_j = Q_jᵀ Q̃_j` (eq. 9), symmetric positive definite.
    pub stretch: Matrix3<f64>,
    /// `e_j` (eq. 12).
    pub error: f64,
    /// `t_j = c_j − c_0` (eq. 10), metres, camera frame.
    pub translation: Vector3<f64>,
    /// Centroid `c_j` of the markers used, camera frame.
    pub centroid: Vector3<f64>,
    /// Centroid `c_0` of the same markers in the reference pose.
    pub reference_centroid: Vector3<f64>,
    /// Markers used (seen in both poses).
    pub markers_used: usize,
    /// False for planar marker sets (three markers, or more in a plane): no redundancy filters
    /// the noise.
    pub redundant: bool,
    /// Iterations of Higham's polar decomposition.
    pub polar_iterations: u32,
}

/// `e = ‖T − 1‖_F / 3`. The paper's footnote defines the normalised Frobenius norm as
/// `(1/n) tr(A Aᵀ)` and calls `1` the 4×4 identity, but `T` is 3×3 and its printed numbers follow
/// `(1/n) √tr(E Eᵀ)` with n = 3: eq. (13) gives ‖E‖_F = 0.0831 and Table I prints e₁₄ = 0.0277 =
/// 0.0831 / 3 (the footnote's formula would give 0.0023). We follow the numbers.
pub(crate) fn orthogonality_error(t: &Matrix3<f64>) -> f64 {
    (t - Matrix3::identity()).norm() / 3.0
}

/// Centroid and positions about it.
fn centred(points: &[Vector3<f64>]) -> (Vector3<f64>, Vec<Vector3<f64>>) {
    let c = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    (c, points.iter().map(|p| p - c).collect())
}

/// The reference configuration of a set of markers, factorised for the least squares.
#[derive(Debug, Clone)]
pub struct Reference {
    centroid: Vector3<f64>,
    /// Centred reference markers (with the virtual normal last when planar).
    columns: Vec<Vector3<f64>>,
    /// Rows of the thin Q factor of `P_0ᵀ`.
    q_rows: Vec<Vector3<f64>>,
    /// The R factor of `P_0ᵀ`.
    r: Matrix3<f64>,
    planar: bool,
    scale: f64,
}

impl Reference {
    /// Factorise the reference positions of the markers to be used (in a fixed order).
    ///
    /// # Errors
    /// A [`MarkerError`] when fewer than three markers are given or they are degenerate against the marker noise.
    pub fn new(points: &[Vector3<f64>]) -> Result<Self, MarkerError> {
        if points.len() < 3 {
            return Err(MarkerError::TooFew { seen: points.len() });
        }
        constellation::check(points, MARKER_NOISE_M)?;
        let (centroid, mut columns) = centred(points);
        let sigma = constellation::spreads(points);
        let scale = sigma.norm();
        let planar = sigma[2] < PLANAR_RATIO * sigma[0];
        if planar {
            columns.push(newell(&columns, &Vector3::zeros()) * scale);
        }
        let p0t = DMatrix::from_fn(columns.len(), 3, |i, k| columns[i][k]);
        let qr = p0t.qr();
        let q = qr.q();
        let r = qr.r();
        Ok(Reference {
            centroid,
            q_rows: (0..columns.len()).map(|i| Vector3::new(q[(i, 0)], q[(i, 1)], q[(i, 2)])).collect(),
            r: Matrix3::from_fn(|i, k| r[(i, k)]),
            columns,
            planar,
            scale,
        })
    }

    /// Number of real markers.
    pub fn markers(&self) -> usize {
        self.columns.len() - usize::from(self.planar)
    }

    /// The estimates of both methods from one least-squares solve: `(paper, Kabsch)`, which
    /// differ only in the rotation.
    ///
    /// # Errors
    /// As [`Reference::estimate`].
    pub fn estimate_both(&self, points: &[Vector3<f64>]) -> Result<(PoseEstimate, PoseEstimate), MarkerError> {
        let paper = self.estimate(points, Method::Paper)?;
        let kabsch = PoseEstimate { rotation: self.kabsch(points, &paper.centroid)?, ..paper };
        Ok((paper, kabsch))
    }

    /// Estimate the rotation from this reference to `points` (the same markers, same order).
    /// No heap allocation: the per-pose work is a few 3×3 products.
    ///
    /// # Errors
    /// A [`MarkerError`] when the markers are degenerate, give no unique or a mirrored rotation.
    pub fn estimate(&self, points: &[Vector3<f64>], method: Method) -> Result<PoseEstimate, MarkerError> {
        debug_assert_eq!(points.len(), self.markers());
        // Markers of this pose that coincide within the noise: their labels, and so the rotation,
        // are ambiguous (the reference's constellation was checked in full when it was factorised).
        for i in 0..points.len() {
            for k in (i + 1)..points.len() {
                let d = (points[i] - points[k]).norm();
                if d.is_nan() || d < constellation::SEPARATION_SIGMAS * MARKER_NOISE_M {
                    let limit_mm = constellation::SEPARATION_SIGMAS * MARKER_NOISE_M * 1e3;
                    let noise_mm = MARKER_NOISE_M * 1e3;
                    let (first, second, distance_mm) = (i + 1, k + 1, d * 1e3);
                    return Err(Degeneracy::Coincident { first, second, distance_mm, limit_mm, noise_mm }.into());
                }
            }
        }
        let n = points.len() as f64;
        let centroid = points.iter().sum::<Vector3<f64>>() / n;
        // Qtᵀ P_jᵀ = Σ_i q_i (p_i − c)ᵀ; with the virtual normal of this pose when planar.
        let mut m: Matrix3<f64> = points.iter().zip(&self.q_rows).map(|(p, q)| q * (p - centroid).transpose()).sum();
        if self.planar {
            let normal = newell(points, &centroid) * self.scale;
            m += self.q_rows[self.q_rows.len() - 1] * normal.transpose();
        }
        let x = self.r.solve_upper_triangular(&m).ok_or(MarkerError::NoSolution)?;
        let putative = x.transpose();
        let det = putative.determinant();
        if det <= 0.0 {
            return Err(MarkerError::Reflection { det });
        }
        let decomposition = Polar::of(&putative).map_err(MarkerError::Singular)?;
        let rotation = match method {
            Method::Paper => Rotation3::from_matrix_unchecked(decomposition.q),
            Method::Kabsch => self.kabsch(points, &centroid)?,
        };
        Ok(PoseEstimate {
            rotation,
            putative,
            stretch: decomposition.t,
            error: orthogonality_error(&decomposition.t),
            translation: centroid - self.centroid,
            centroid,
            reference_centroid: self.centroid,
            markers_used: points.len(),
            redundant: !self.planar,
            polar_iterations: decomposition.iterations,
        })
    }

    /// The rotation minimising `Σ |p_i − c − Q (p0_i − c0)|²`: the nearest rotation to
    /// `Σ (p_i − c)(p0_i − c0)ᵀ` (Kabsch, by [`so3::nearest_rotation`]: the polar factor, or the
    /// SVD whose sign correction keeps it proper when the determinant is not positive). Planar sets
    /// include the virtual normal pair, without which the sum has rank 2.
    fn kabsch(&self, points: &[Vector3<f64>], centroid: &Vector3<f64>) -> Result<Rotation3<f64>, MarkerError> {
        let mut h: Matrix3<f64> = points.iter().zip(&self.columns).map(|(p, p0)| (p - centroid) * p0.transpose()).sum();
        if self.planar {
            h += newell(points, centroid) * self.scale * self.columns[self.columns.len() - 1].transpose();
        }
        so3::nearest_rotation(&h).ok_or(MarkerError::NoSolution)
    }
}

/// Unit Newell normal of the points about `centroid`, in order.
fn newell(points: &[Vector3<f64>], centroid: &Vector3<f64>) -> Vector3<f64> {
    let mut n = Vector3::zeros();
    for i in 0..points.len() {
        n += (points[i] - centroid).cross(&(points[(i + 1) % points.len()] - centroid));
    }
    n.normalize()
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix3, Vector3};

    use super::orthogonality_error;

    #[test]
    fn e_is_the_frobenius_norm_over_three() {
        let t = Matrix3::identity() + Matrix3::from_diagonal(&Vector3::new(0.03, 0.0, -0.04));
        assert!((orthogonality_error(&t) - 0.05 / 3.0).abs() < 1e-16);
    }
}
