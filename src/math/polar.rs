//! Polar decomposition `A = Q T` of a 3×3 matrix (`Q` orthogonal, `T` symmetric positive
//! semi-definite) by Higham's scaled Newton iteration, with an SVD fallback.
//!
//! The iteration `X_{k+1} = ½ (γ_k X_k + γ_k⁻¹ X_k⁻ᵀ)`, `X_0 = A`, converges quadratically to `Q`
//! for non-singular `A` (Higham 1986; Higham & Schreiber 1990). The Frobenius-norm scaling
//! `γ_k = (‖X_k⁻¹‖_F / ‖X_k‖_F)^{1/2}` speeds up the early steps; once the step is small the
//! scaling is switched off (`γ = 1`), as Higham recommends, so that it cannot disturb the final
//! quadratic phase.
//!
//! Stopping rule: near convergence `‖X_{k+1} − Q‖ ≲ ½ ‖X_k⁻¹‖ ‖X_k − Q‖²` and `‖X_{k+1} − X_k‖`
//! estimates `‖X_k − Q‖`. With `‖X_k⁻¹‖ ≈ 1` for an almost orthogonal `X_k`, a step below
//! `√(2·4ε) ≈ 4.2e-8` leaves `X_{k+1}` within about `4ε` of `Q`: further iterations would only
//! stir rounding errors. The tests check `QᵀQ = I` to 1e-14 against this rule.

use nalgebra::Matrix3;

/// Steps below this end the iteration (see the module documentation).
pub(crate) const STEP_TOLERANCE: f64 = 4.2e-8;
/// Steps below this switch the scaling off.
const UNSCALED_BELOW: f64 = 1e-2;
/// More iterations than this means the input is too close to singular for Newton: use the SVD.
pub(crate) const MAX_ITERATIONS: u32 = 30;

/// `A = Q T`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polar {
    /// Orthogonal factor (det = sign of det A).
    pub q: Matrix3<f64>,
    /// Symmetric positive semi-definite factor `T = Qᵀ A`.
    pub t: Matrix3<f64>,
    /// Newton iterations used (0 when the SVD was used).
    pub iterations: u32,
    /// Whether the SVD fallback produced the result.
    pub by_svd: bool,
}

/// Why a matrix has no (unique) polar decomposition.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PolarError {
    #[error("matrix has non-finite entries")]
    /// The matrix has non-finite entries.
    NotFinite,
    #[error("matrix is singular (smallest singular value {smallest:.3e}): no unique orthogonal factor")]
    /// The matrix is singular.
    Singular {
        /// Its smallest singular value.
        smallest: f64,
    },
}

impl Polar {
    /// Polar decomposition by Higham's scaled Newton iteration, falling back to the SVD when the
    /// input is singular to working precision or Newton does not settle.
    ///
    /// # Errors
    /// A [`PolarError`] when `a` is not finite or is singular.
    pub fn of(a: &Matrix3<f64>) -> Result<Polar, PolarError> {
        if !a.iter().all(|x| x.is_finite()) {
            return Err(PolarError::NotFinite);
        }
        let mut x = *a;
        let mut scaled = true;
        for iteration in 1..=MAX_ITERATIONS {
            let Some(inverse) = x.try_inverse() else { break };
            let gamma = if scaled { (inverse.norm() / x.norm()).sqrt() } else { 1.0 };
            let next = (x * gamma + inverse.transpose() / gamma) * 0.5;
            let step = (next - x).norm();
            x = next;
            if step <= STEP_TOLERANCE {
                return Ok(Polar {
                    q: x,
                    t: symmetric_part(&(x.transpose() * a)),
                    iterations: iteration,
                    by_svd: false,
                });
            }
            scaled = step > UNSCALED_BELOW;
        }
        Polar::by_svd(a)
    }

    /// Polar decomposition from the SVD `A = U Σ Vᵀ`: `Q = U Vᵀ`, `T = V Σ Vᵀ`.
    ///
    /// # Errors
    /// A [`PolarError`] when `a` is not finite or is singular.
    ///
    /// # Panics
    /// Never: the SVD is asked for both factors.
    pub fn by_svd(a: &Matrix3<f64>) -> Result<Polar, PolarError> {
        if !a.iter().all(|x| x.is_finite()) {
            return Err(PolarError::NotFinite);
        }
        let svd = super::linalg::bounded_svd(a, true, true).ok_or(PolarError::NotFinite)?;
        let smallest = svd.singular_values.min();
        if smallest <= 8.0 * f64::EPSILON * svd.singular_values.max() {
            return Err(PolarError::Singular { smallest });
        }
        let (u, vt) = (svd.u.expect("asked for U"), svd.v_t.expect("asked for Vᵀ"));
        let q = u * vt;
        Ok(Polar { q, t: symmetric_part(&(q.transpose() * a)), iterations: 0, by_svd: true })
    }
}

/// `(M + Mᵀ)/2`: `QᵀA` is symmetric in exact arithmetic; this removes the rounding residue.
fn symmetric_part(m: &Matrix3<f64>) -> Matrix3<f64> {
    (m + m.transpose()) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newton_agrees_with_the_svd_and_stops_early() {
        let a = Matrix3::new(-0.0675, 1.0157, 0.0007, -0.9323, -0.0151, 0.3778, 0.4010, 0.0376, 0.9949);
        let (newton, svd) = (Polar::of(&a).unwrap(), Polar::by_svd(&a).unwrap());
        assert!((newton.q - svd.q).amax() < 1e-14 && (newton.t - svd.t).amax() < 1e-14);
        assert!((newton.q.transpose() * newton.q - Matrix3::identity()).amax() < 1e-15);
        assert!(!newton.by_svd && newton.iterations <= 5, "{} iterations", newton.iterations);
    }

    #[test]
    fn singular_input_is_refused() {
        let a = Matrix3::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 1.0, 1.0);
        assert!(matches!(Polar::of(&a), Err(PolarError::Singular { .. })));
        assert!(matches!(Polar::of(&(a * f64::NAN)), Err(PolarError::NotFinite)));
    }

    #[test]
    fn a_reflection_keeps_its_negative_determinant() {
        let a = Matrix3::from_diagonal(&nalgebra::Vector3::new(1.1, 0.9, -1.0));
        let p = Polar::of(&a).unwrap();
        assert!((p.q.determinant() + 1.0).abs() < 1e-14);
    }
}
