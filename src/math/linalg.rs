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
