//! Is a set of marker positions able to fix an orientation? Judged against the measurement noise,
//! not in absolute units: two markers 0.1 mm apart are one marker to a camera whose noise is a
//! fraction of a millimetre, and a constellation that is a line to within the noise leaves the
//! rotation about that line to the noise (a 180° flip costs it nothing).

use nalgebra::{Matrix3, Vector3};

/// The noise (1σ, metres) the degeneracy tests assume for a marker position: a Bumblebee-class
/// stereo camera at 0.8 m measures across the line of sight to ~0.2 mm and along it to ~1 mm.
pub(crate) const MARKER_NOISE_M: f64 = 1e-3;

/// How many noise deviations two markers must be apart, or the constellation be wide off its
/// principal line, to count as distinct (a 3σ separation is the conventional detection limit).
pub(crate) const SEPARATION_SIGMAS: f64 = 3.0;

/// Why a constellation cannot fix an orientation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Degeneracy {
    /// Fewer than three points.
    #[error("{count} markers; at least 3 are needed")]
    TooFew {
        /// How many there are.
        count: usize,
    },
    /// Two points closer than the noise can separate.
    #[error(
        "markers #{first} and #{second} are {distance_mm:.3} mm apart, within {limit_mm:.1} mm ({SEPARATION_SIGMAS} × the {noise_mm} mm marker noise): they coincide"
    )]
    Coincident {
        /// 1-based position of the first marker in the list.
        first: usize,
        /// 1-based position of the second.
        second: usize,
        /// Their distance.
        distance_mm: f64,
        /// The smallest distance accepted.
        limit_mm: f64,
        /// The noise assumed.
        noise_mm: f64,
    },
    /// All points within the noise of one line.
    #[error(
        "the markers lie within {width_mm:.3} mm (RMS) of a line, below {limit_mm:.1} mm ({SEPARATION_SIGMAS} × the {noise_mm} mm marker noise): the rotation about that line is unobservable"
    )]
    Collinear {
        /// RMS distance of the points from their principal line.
        width_mm: f64,
        /// The smallest width accepted.
        limit_mm: f64,
        /// The noise assumed.
        noise_mm: f64,
    },
}

/// The principal spreads of a constellation about its centroid: RMS extents along its three
/// principal axes, largest first (metres).
pub(crate) fn spreads(points: &[Vector3<f64>]) -> Vector3<f64> {
    let n = points.len().max(1) as f64;
    let c = points.iter().sum::<Vector3<f64>>() / n;
    let scatter: Matrix3<f64> = points.iter().map(|p| (p - c) * (p - c).transpose()).sum::<Matrix3<f64>>() / n;
    let Some(eigen) = crate::math::linalg::bounded_symmetric_eigen(&scatter) else { return Vector3::repeat(f64::NAN) };
    let mut s = eigen.eigenvalues.map(|l| l.max(0.0).sqrt());
    s.as_mut_slice().sort_by(|a, b| b.total_cmp(a));
    s
}

/// Check that `points` fix an orientation under marker noise `noise_m` (1σ): at least three,
/// no two closer than [`SEPARATION_SIGMAS`] noise deviations, and not within that of a line.
///
/// # Errors
/// The first [`Degeneracy`] found.
pub(crate) fn check(points: &[Vector3<f64>], noise_m: f64) -> Result<(), Degeneracy> {
    if points.len() < 3 {
        return Err(Degeneracy::TooFew { count: points.len() });
    }
    let limit = SEPARATION_SIGMAS * noise_m;
    let (limit_mm, noise_mm) = (limit * 1e3, noise_m * 1e3);
    for i in 0..points.len() {
        for k in (i + 1)..points.len() {
            let d = (points[i] - points[k]).norm();
            if d.is_nan() || d < limit {
                return Err(Degeneracy::Coincident {
                    first: i + 1,
                    second: k + 1,
                    distance_mm: d * 1e3,
                    limit_mm,
                    noise_mm,
                });
            }
        }
    }
    let width = spreads(points)[1];
    if width.is_nan() || width < limit {
        return Err(Degeneracy::Collinear { width_mm: width * 1e3, limit_mm, noise_mm });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degeneracy_is_judged_against_the_noise() {
        let tri =
            [Vector3::new(0.075, 0.0, 0.06), Vector3::new(-0.0375, 0.065, 0.06), Vector3::new(-0.0375, -0.065, 0.06)];
        assert_eq!(check(&tri, MARKER_NOISE_M), Ok(()));
        // 0.1 mm apart: one marker to the camera.
        let mut close = tri;
        close[2] = close[1] + Vector3::new(1e-4, 0.0, 0.0);
        assert!(matches!(check(&close, MARKER_NOISE_M), Err(Degeneracy::Coincident { first: 2, second: 3, .. })));
        // A line to within 0.5 mm.
        let line = [Vector3::zeros(), Vector3::new(0.05, 0.0005, 0.0), Vector3::new(0.1, 0.0, 0.0)];
        assert!(matches!(check(&line, MARKER_NOISE_M), Err(Degeneracy::Collinear { .. })));
        // The same line is a fine triangle to a camera a hundred times better.
        assert_eq!(check(&line, 1e-5), Ok(()));
        let nan = [Vector3::zeros(), Vector3::new(f64::NAN, 0.0, 0.0), Vector3::new(0.1, 0.0, 0.0)];
        assert!(check(&nan, MARKER_NOISE_M).is_err());
    }
}
