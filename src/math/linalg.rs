//! General linear algebra with bounded work: SVD and symmetric eigen-decompositions that refuse
//! non-finite input instead of looping, and the Gram matrix `JᵀJ` of a tall Jacobian.

/// Iterations allowed to nalgebra's SVD and eigen solvers: they converge in tens; unbounded, they
/// loop for ever on NaN or infinite input (found by fuzzing: a session with a 1e300 coordinate).
pub(crate) const MAX_DECOMPOSITION_ITERATIONS: usize = 1000;

/// The SVD of `m` with bounded work: `None` for non-finite input or no convergence.
pub(crate) fn bounded_svd<R, C, S>(
    m: &nalgebra::Matrix<f64, R, C, S>,
    compute_u: bool,
    compute_v: bool,
) -> Option<nalgebra::SVD<f64, R, C>>
where
    S: nalgebra::Storage<f64, R, C>,
    R: nalgebra::DimMin<C>,
    C: nalgebra::Dim,
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<R, C>
        + nalgebra::allocator::Allocator<C>
        + nalgebra::allocator::Allocator<R>
        + nalgebra::allocator::Allocator<nalgebra::DimMinimum<R, C>>
        + nalgebra::allocator::Allocator<nalgebra::DimMinimum<R, C>, C>
        + nalgebra::allocator::Allocator<R, nalgebra::DimMinimum<R, C>>
        + nalgebra::allocator::Allocator<nalgebra::DimDiff<nalgebra::DimMinimum<R, C>, nalgebra::U1>>,
    nalgebra::DimMinimum<R, C>: nalgebra::DimSub<nalgebra::U1>,
{
    if !m.iter().all(|x| x.is_finite()) {
        return None;
    }
    m.clone_owned().try_svd(compute_u, compute_v, f64::EPSILON, MAX_DECOMPOSITION_ITERATIONS)
}

/// The eigen-decomposition of the symmetric `m` with bounded work: `None` for non-finite input
/// or no convergence.
#[cfg(feature = "full")]
pub(crate) fn bounded_symmetric_eigen<D>(m: &nalgebra::OMatrix<f64, D, D>) -> Option<nalgebra::SymmetricEigen<f64, D>>
where
    D: nalgebra::DimSub<nalgebra::U1>,
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D, D>
        + nalgebra::allocator::Allocator<D>
        + nalgebra::allocator::Allocator<nalgebra::DimDiff<D, nalgebra::U1>>,
{
    if !m.iter().all(|x| x.is_finite()) {
        return None;
    }
    nalgebra::SymmetricEigen::try_new(m.clone(), f64::EPSILON, MAX_DECOMPOSITION_ITERATIONS)
}

/// The pseudo-inverse of the symmetric positive semi-definite `m` (a normal matrix, a covariance,
/// a Schur complement), worked out with unit diagonal (`D m D`, `D = diag(m)^{-1/2}`, so that
/// columns in metres, radians and seconds weigh alike) by its eigen-decomposition, the eigenvalues
/// at most `relative` times the largest taken as zero. A zero or negative diagonal entry gives a
/// zero row and column. `None` for non-finite input or an eigen-decomposition that does not converge.
///
/// Not nalgebra's `pseudo_inverse`: its SVD of a dynamic-size matrix loses accuracy when singular
/// values cluster (on the 6 × 6 Gram matrix of 150 poses' common rotations it reconstructed the
/// matrix to 5e-4 and its inverse to 1.3 %; one random 6 × 6 with clustered values in twenty,
/// errors up to 3e-3), while the inverse by the symmetric eigen-decomposition holds to 1e-12 (tests
/// below).
#[cfg(feature = "full")]
pub(crate) fn symmetric_pseudo_inverse(m: &nalgebra::DMatrix<f64>, relative: f64) -> Option<nalgebra::DMatrix<f64>> {
    let n = m.nrows();
    let d: Vec<f64> = (0..n).map(|i| if m[(i, i)] > 0.0 { m[(i, i)].sqrt().recip() } else { 0.0 }).collect();
    let scaled = nalgebra::DMatrix::from_fn(n, n, |i, k| 0.5 * (m[(i, k)] + m[(k, i)]) * d[i] * d[k]);
    let eigen = bounded_symmetric_eigen(&scaled)?;
    let largest = eigen.eigenvalues.iter().copied().fold(0.0, f64::max);
    let kept = eigen.eigenvalues.map(|l| if l > relative * largest && l > 0.0 { l.recip() } else { 0.0 });
    let v = &eigen.eigenvectors;
    let inverse = v * nalgebra::DMatrix::from_diagonal(&kept) * v.transpose();
    Some(nalgebra::DMatrix::from_fn(n, n, |i, k| inverse[(i, k)] * d[i] * d[k]))
}

/// `JᵀJ` by one cache-blocked GEMM reading `J` through transposed strides: nalgebra's `tr_mul`
/// takes a dot product per entry (5× slower at 100,000 observations) and `transpose() *` first
/// copies the whole matrix.
#[cfg(feature = "full")]
pub(crate) fn gram(j: &nalgebra::DMatrix<f64>) -> nalgebra::DMatrix<f64> {
    let mut out = nalgebra::DMatrix::zeros(j.ncols(), j.ncols());
    gram_into(j, j.nrows(), &mut out);
    out
}

/// `out += J[..rows]ᵀ J[..rows]`, the Gram matrix of the first `rows` rows of `j`.
///
/// # Panics
/// If `rows` exceeds `j`'s rows or `out` is not `n × n`.
#[cfg(feature = "full")]
pub(crate) fn gram_into(j: &nalgebra::DMatrix<f64>, rows: usize, out: &mut nalgebra::DMatrix<f64>) {
    let n = j.ncols();
    assert!(
        rows <= j.nrows() && out.shape() == (n, n),
        "gram of {rows} rows of {:?} into {:?}",
        j.shape(),
        out.shape()
    );
    if rows == 0 || n == 0 {
        return;
    }
    let (a, stride) = (j.as_slice().as_ptr(), j.nrows() as isize);
    // SAFETY: `a` points to `nrows × n` column-major values (element (i, k) at i + k·nrows); the
    // first `rows` rows are read as Jᵀ (n × rows: row stride `nrows`, column stride 1) and as J
    // (rows × n: strides 1, `nrows`); `out` is a distinct n × n column-major matrix (strides 1,
    // n), accumulated into (beta = 1). All indices stay in bounds (asserted above).
    unsafe {
        matrixmultiply::dgemm(
            n,
            rows,
            n,
            1.0,
            a,
            stride,
            1,
            a,
            1,
            stride,
            1.0,
            out.as_mut_slice().as_mut_ptr(),
            1,
            n as isize,
        );
    }
}

#[cfg(all(test, feature = "full"))]
mod tests {
    use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

    use super::symmetric_pseudo_inverse;

    /// Numbers in [−1, 1) from a fixed sequence (a linear congruential generator).
    fn numbers(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    /// `Q diag(values) Qᵀ`, `Q` orthonormal from the sequence `next`.
    fn symmetric(values: &[f64], next: &mut impl FnMut() -> f64) -> DMatrix<f64> {
        let n = values.len();
        let q = DMatrix::from_fn(n, n, |_, _| next()).qr().q();
        let m = &q * DMatrix::from_diagonal(&DVector::from_column_slice(values)) * q.transpose();
        (&m + m.transpose()) * 0.5
    }

    #[test]
    fn clustered_values_are_inverted_to_rounding() {
        // Three values near 290 and three near 10, as the Gram matrix of many poses' common
        // rotations has: nalgebra 0.35's SVD-based `pseudo_inverse` was off by up to 3e-3 on some
        // of these (dimforge/nalgebra#1172).
        let mut next = numbers(3);
        let mut worst = 0.0f64;
        for _ in 0..300 {
            let values: Vec<f64> = (0..6).map(|i| if i < 3 { 290.0 } else { 10.0 } * (1.0 + 1e-2 * next())).collect();
            let m = symmetric(&values, &mut next);
            let exact = m.clone().cholesky().unwrap().inverse();
            let p = symmetric_pseudo_inverse(&m, 1e-14).unwrap();
            worst = worst.max((&p - &exact).amax() / exact.amax());
        }
        assert!(worst < 1e-12, "{worst:e}");
    }

    #[test]
    fn columns_in_different_units_and_singular_directions() {
        let mut next = numbers(5);
        // Rank 4 of 5, then scaled to units 1e-6 … 1e6 apart, with a column of zeros added.
        let m = symmetric(&[4.0, 2.0, 1.0, 0.5, 0.0], &mut next);
        let units = [1e-6, 1.0, 1e3, 1e6, 1e-3, 1.0];
        let mut a = DMatrix::zeros(6, 6);
        for i in 0..5 {
            for k in 0..5 {
                a[(i, k)] = m[(i, k)] * units[i] * units[k];
            }
        }
        let p = symmetric_pseudo_inverse(&a, 1e-12).unwrap();
        // The Moore–Penrose conditions that hold for a scaled inverse: A P A = A, P A P = P.
        let apa = &a * &p * &a;
        for i in 0..6 {
            for k in 0..6 {
                let size = (a[(i, i)] * a[(k, k)]).sqrt().max(f64::MIN_POSITIVE);
                assert!((apa[(i, k)] - a[(i, k)]).abs() <= 1e-9 * size, "A P A at {i},{k}");
            }
        }
        let pap = &p * &a * &p;
        assert!((&pap - &p).amax() <= 1e-9 * p.amax(), "P A P");
        assert!(p.row(5).iter().all(|&x| x == 0.0), "the zero column's row");
        // A full-rank matrix in the same units is inverted exactly.
        let full = symmetric(&[4.0, 2.0, 1.0, 0.5, 0.25, 3.0], &mut next);
        let b = DMatrix::from_fn(6, 6, |i, k| full[(i, k)] * units[i] * units[k]);
        let pb = symmetric_pseudo_inverse(&b, 1e-12).unwrap();
        // `(P B)_ik` carries units `units[k] / units[i]`: compared in them.
        let error = &pb * &b - DMatrix::<f64>::identity(6, 6);
        for i in 0..6 {
            for k in 0..6 {
                assert!(error[(i, k)].abs() < 1e-9 * units[k] / units[i], "P B − I at {i},{k}: {:e}", error[(i, k)]);
            }
        }
    }

    /// `Q₁ diag(σ) Q₂ᵀ` with orthonormal `Q`s from the sequence `next`.
    fn with_singular_values(sigma: [f64; 3], next: &mut impl FnMut() -> f64) -> Matrix3<f64> {
        let q = |next: &mut dyn FnMut() -> f64| Matrix3::from_fn(|_, _| next()).qr().q();
        q(next) * Matrix3::from_diagonal(&Vector3::from(sigma)) * q(next).transpose()
    }

    #[test]
    fn near_rotations_are_decomposed_to_rounding() {
        // Singular values clustered around 1 (a marker constellation's polar decomposition), and
        // spread, and with one or two zero: U Σ Vᵀ = M, U and V orthonormal. nalgebra's SVD of a
        // fixed-size 3 × 3 (the only size `bounded_svd` is given) holds to rounding; of the same
        // matrices as dynamic-size ones (nalgebra 0.35) it was off by up to 5e-4, which is why
        // `symmetric_pseudo_inverse` avoids it.
        let mut next = numbers(7);
        let mut worst = 0.0f64;
        for k in 0..2000 {
            let spread = [1e-3, 1e-6, 0.1, 1.0][k % 4];
            let mut sigma = [0.0; 3].map(|_| 1.0 + spread * next());
            if k % 50 == 0 {
                sigma[2] = 0.0;
            }
            if k % 100 == 0 {
                sigma[1] = 0.0;
            }
            let m = with_singular_values(sigma, &mut next);
            let svd = super::bounded_svd(&m, true, true).unwrap();
            let (u, vt, s) = (svd.u.unwrap(), svd.v_t.unwrap(), svd.singular_values);
            let error = (u * Matrix3::from_diagonal(&s) * vt - m).amax() / m.amax();
            worst = worst.max(error);
            assert!((u.transpose() * u - Matrix3::identity()).amax() < 1e-14, "U at {k}");
            assert!((vt * vt.transpose() - Matrix3::identity()).amax() < 1e-14, "V at {k}");
        }
        assert!(worst < 1e-14, "{worst:e}");
    }

    #[test]
    fn non_finite_input_has_no_inverse() {
        let mut m = DMatrix::<f64>::identity(3, 3);
        m[(0, 1)] = f64::NAN;
        assert!(symmetric_pseudo_inverse(&m, 1e-12).is_none());
    }
}
