//! Rotation helpers on SO(3): geodesic angle, exponential and logarithm maps,
//! quaternion output in the file convention (scalar first, `qw ≥ 0`).
//!
//! nalgebra's `angle()` goes through `acos` of the trace, which loses half the
//! digits near the identity (an error of ~1e-8 rad at zero). Calibration residuals
//! and the 1e-10 rad round-trip tests live exactly there, so the functions here
//! use `atan2` forms that keep full relative precision at every angle.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// Skew-symmetric matrix `[a]×` with `[a]× b = a × b`.
#[cfg(feature = "full")]
pub(crate) fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    a.cross_matrix()
}

/// Exponential map: the rotation by `|omega|` about `omega / |omega|`.
pub fn exp(omega: &Vector3<f64>) -> Rotation3<f64> {
    Rotation3::new(*omega)
}

/// Logarithm map: the rotation vector of `r`, accurate to full relative
/// precision for small angles (via the quaternion and `atan2`).
pub fn log(r: &Rotation3<f64>) -> Vector3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(r);
    // q and -q are the same rotation; take the one with w >= 0 so that angle <= pi.
    let (w, v) = if q.w >= 0.0 { (q.w, q.imag()) } else { (-q.w, -q.imag()) };
    let s = v.norm();
    if s < 1e-300 {
        return Vector3::zeros();
    }
    let angle = 2.0 * s.atan2(w);
    v * (angle / s)
}

/// Left Jacobian of SO(3): `exp(φ + dφ) = exp(J_l(φ) dφ) exp(φ)` to first order.
#[cfg(feature = "full")]
pub(crate) fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let k = skew(phi);
    // Series below 1e-4 rad: the closed forms lose precision to cancellation there.
    let (a, b) = if theta < 1e-4 {
        (0.5 - theta * theta / 24.0, 1.0 / 6.0 - theta * theta / 120.0)
    } else {
        ((1.0 - theta.cos()) / (theta * theta), (theta - theta.sin()) / (theta * theta * theta))
    };
    Matrix3::identity() + k * a + k * k * b
}

/// Inverse of the left Jacobian: `log(exp(ε) exp(φ)) = φ + J_l⁻¹(φ) ε` to first order.
#[cfg(feature = "full")]
pub(crate) fn left_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let k = skew(phi);
    let c = if theta < 1e-4 {
        1.0 / 12.0 + theta * theta / 720.0
    } else {
        1.0 / (theta * theta) - (1.0 + theta.cos()) / (2.0 * theta * theta.sin())
    };
    Matrix3::identity() - k * 0.5 + k * k * c
}

/// Geodesic angle between two rotations (radians, in `[0, π]`), accurate for tiny angles.
pub fn geodesic_angle(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    let d = a.matrix().transpose() * b.matrix();
    let sin2 = Vector3::new(d[(2, 1)] - d[(1, 2)], d[(0, 2)] - d[(2, 0)], d[(1, 0)] - d[(0, 1)]).norm();
    let cos2 = d.trace() - 1.0;
    sin2.atan2(cos2)
}

/// Unit quaternion `[qw, qx, qy, qz]` of `r`, scalar first, with `qw ≥ 0`.
pub fn to_wxyz(r: &Rotation3<f64>) -> [f64; 4] {
    let q = UnitQuaternion::from_rotation_matrix(r);
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    [s * q.w, s * q.i, s * q.j, s * q.k]
}

/// Rotation from a quaternion `[qw, qx, qy, qz]`; `None` unless its norm is 1 within `1e-6`
/// (a file that claims a unit quaternion but is far from one is malformed, not to be normalised silently).
pub fn from_wxyz(q: [f64; 4]) -> Option<Rotation3<f64>> {
    let quat = nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]);
    let n = quat.norm();
    if !n.is_finite() || (n - 1.0).abs() > 1e-6 {
        return None;
    }
    Some(UnitQuaternion::from_quaternion(quat).to_rotation_matrix())
}

/// How far from 1 the norm of a quaternion a person typed or a tool printed may be: four or five
/// digits put it within 10⁻⁴ of unit norm; 10⁻³ is a wrong number, not rounding.
#[cfg(feature = "full")] // the files that print quaternions are read by the full build
pub(crate) const PRINTED_QUATERNION_TOLERANCE: f64 = 1e-3;

/// Rotation from a quaternion `[qw, qx, qy, qz]` as printed or typed with a few digits: normalised
/// when its norm is 1 within [`PRINTED_QUATERNION_TOLERANCE`], else `Err(norm)`.
#[cfg(feature = "full")]
pub(crate) fn from_printed_wxyz(q: [f64; 4]) -> Result<Rotation3<f64>, f64> {
    let quat = nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]);
    let n = quat.norm();
    if !n.is_finite() || (n - 1.0).abs() > PRINTED_QUATERNION_TOLERANCE {
        return Err(n);
    }
    Ok(UnitQuaternion::from_quaternion(quat).to_rotation_matrix())
}

/// The right-handed orthonormal frame `[e1, e2, e3]` of two non-parallel vectors: `e1 ∥ a`,
/// `e2 ∝ b − (e1·b) e1`, `e3 = e1 × e2`.
pub(crate) fn pair_frame(a: &Vector3<f64>, b: &Vector3<f64>) -> Matrix3<f64> {
    let e1 = a.normalize();
    let e2 = (b - e1 * e1.dot(b)).normalize();
    Matrix3::from_columns(&[e1, e2, e1.cross(&e2)])
}

#[cfg(feature = "full")] // the simulator and the gauge use it; the lean core does not
/// The rotation that carries the frame of the pair `(a1, b1)` onto that of `(a2, b2)`: `a1 ↦ a2`
/// exactly, and `b1` into the half-plane of `b2` (exactly onto it when the angles agree).
pub(crate) fn carry(a1: &Vector3<f64>, b1: &Vector3<f64>, a2: &Vector3<f64>, b2: &Vector3<f64>) -> Rotation3<f64> {
    Rotation3::from_matrix_unchecked(pair_frame(a2, b2) * pair_frame(a1, b1).transpose())
}

/// The proper rotation nearest to `m` in the Frobenius norm (the polar factor by Higham's
/// iteration when `det m` is clearly positive, else the SVD with its sign correction), or `None`
/// when `m` is rank-deficient (no unique nearest rotation). Public to the crate's own studies and
/// tests only (`internals`): the API keeps the conversions a user needs.
#[cfg(feature = "internals")]
pub fn nearest_rotation(m: &Matrix3<f64>) -> Option<Rotation3<f64>> {
    nearest(m)
}

/// See the `internals` twin above.
#[cfg(not(feature = "internals"))]
#[cfg_attr(not(feature = "full"), allow(dead_code))]
pub(crate) fn nearest_rotation(m: &Matrix3<f64>) -> Option<Rotation3<f64>> {
    nearest(m)
}

fn nearest(m: &Matrix3<f64>) -> Option<Rotation3<f64>> {
    // With det m > 8ε‖m‖³ (so σ_min > 8ε σ_max: σ1σ2σ3 ≤ σ_max²σ_min) the answer is the orthogonal
    // polar factor, which Higham's iteration finds about six times faster than the SVD (93 ns
    // against 548 ns, docs/benchmarks.md).
    let scale = m.norm();
    if m.determinant() > 8.0 * f64::EPSILON * scale * scale * scale
        && let Ok(p) = super::polar::Polar::of(m)
    {
        return Some(Rotation3::from_matrix_unchecked(p.q));
    }
    let svd = super::linalg::bounded_svd(m, true, true)?;
    let (u, vt) = (svd.u?, svd.v_t?);
    if svd.singular_values.min() <= f64::EPSILON * svd.singular_values.max() * 8.0 {
        return None;
    }
    let mut d = Matrix3::identity();
    d[(2, 2)] = (u * vt).determinant().signum();
    Some(Rotation3::from_matrix_unchecked(u * d * vt))
}

/// `R = exp(tilt a) exp(yaw z)` with `a = (cos azimuth, sin azimuth, 0)` (rad): how the
/// workspace's orientations are drawn, surveyed, planned and reported.
#[cfg(feature = "full")]
pub(crate) fn from_tilt_and_yaw(azimuth: f64, tilt: f64, yaw: f64) -> Rotation3<f64> {
    exp(&(Vector3::new(azimuth.cos(), azimuth.sin(), 0.0) * tilt)) * exp(&(Vector3::z() * yaw))
}

/// Tilt of the MP's z axis from the base's and yaw about it (rad), the inverse of
/// [`from_tilt_and_yaw`] (up to the azimuth).
#[cfg(feature = "full")]
pub(crate) fn tilt_and_yaw(r: &Rotation3<f64>) -> (f64, f64) {
    let z = r * Vector3::z();
    let tilt = z.z.clamp(-1.0, 1.0).acos();
    let tilting = Rotation3::rotation_between(&Vector3::z(), &z).unwrap_or_else(Rotation3::identity);
    (tilt, log(&(tilting.inverse() * r)).z)
}

/// The bands (deg) by which plans and predicted errors map the workspace: 0–10, 10–20, 20–30 and
/// beyond, of tilt and of |yaw|.
#[cfg(feature = "full")]
pub(crate) const WORKSPACE_BANDS_DEG: [f64; 5] = [0.0, 10.0, 20.0, 30.0, f64::INFINITY];

/// The bands of [`WORKSPACE_BANDS_DEG`] that `r`'s tilt and |yaw| fall in.
#[cfg(feature = "full")]
pub(crate) fn workspace_band(r: &Rotation3<f64>) -> (usize, usize) {
    let (tilt, yaw) = tilt_and_yaw(r);
    let band = |x: f64| WORKSPACE_BANDS_DEG.windows(2).position(|w| x.to_degrees().abs() < w[1]).unwrap_or(3);
    (band(tilt), band(yaw))
}

/// An angle wrapped to `(−π, π]`. IK's angles are within a turn of that range: one step of `2π`
/// there (and a fix-up for rounding at the ends); beyond, the exact remainder (`round` is a
/// library call on the baseline x86-64, and subtracting a rounded number of turns loses the
/// angle past 1e17). Not a number stays so.
#[inline]
pub(crate) fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let w = if a.abs() <= 3.0 * PI {
        if a > PI {
            a - TAU
        } else if a <= -PI {
            a + TAU
        } else {
            a
        }
    } else {
        let r = a.rem_euclid(TAU);
        if r > PI { r - TAU } else { r }
    };
    // Rounding at the range's ends: −π itself (from −3π + 2π) and anything just beyond π.
    if w <= -PI {
        w + TAU
    } else if w > PI {
        w - TAU
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_inverts_exp_across_angles() {
        for &angle in &[0.0, 1e-12, 1e-6, 0.3, 2.0, 3.1] {
            let omega = Vector3::new(0.3, -0.5, 0.8).normalize() * angle;
            let back = log(&exp(&omega));
            assert!((back - omega).norm() <= 1e-15 + 1e-14 * angle, "angle {angle}: {back:?}");
        }
    }

    #[test]
    fn geodesic_angle_keeps_precision_near_identity() {
        let r = exp(&Vector3::new(1e-11, 0.0, 0.0));
        let got = geodesic_angle(&Rotation3::identity(), &r);
        assert!((got - 1e-11).abs() < 1e-24, "{got}");
        let big = exp(&Vector3::new(0.0, 2.5, 0.0));
        assert!((geodesic_angle(&r, &big) - r.inverse().rotation_to(&big).angle()).abs() < 1e-12);
    }

    #[test]
    fn quaternion_round_trip_and_sign_convention() {
        let r = exp(&Vector3::new(0.2, 3.0, -0.1));
        let q = to_wxyz(&r);
        assert!(q[0] >= 0.0);
        assert!(geodesic_angle(&r, &from_wxyz(q).unwrap()) < 1e-14);
        assert!(from_wxyz([1.0, 0.1, 0.0, 0.0]).is_none());
    }

    #[test]
    #[cfg(feature = "full")]
    fn left_jacobians_match_finite_differences_and_invert() {
        for phi in [Vector3::new(0.3, -0.2, 0.5), Vector3::new(1e-6, 2e-6, -1e-6), Vector3::new(2.0, 0.5, -1.0)] {
            let jl = left_jacobian(&phi);
            assert!((jl * left_jacobian_inverse(&phi) - Matrix3::identity()).amax() < 1e-12);
            let h = 1e-6;
            for k in 0..3 {
                let mut d = Vector3::zeros();
                d[k] = h;
                let numeric = log(&(exp(&(phi + d)) * exp(&(phi - d)).inverse())) / (2.0 * h);
                assert!((numeric - jl.column(k)).amax() < 1e-8, "{phi:?} column {k}");
            }
        }
    }

    #[test]
    #[cfg(feature = "full")]
    fn carry_maps_one_pair_onto_another() {
        let r = exp(&Vector3::new(0.3, -1.1, 0.4));
        let (a, b) = (Vector3::new(0.2, 0.9, -0.3), Vector3::new(-0.5, 0.1, 0.8));
        let c = carry(&a, &b, &(r * a), &(r * b));
        assert!(geodesic_angle(&c, &r) < 1e-14);
    }

    #[test]
    fn nearest_rotation_by_polar_iteration_agrees_with_the_svd() {
        // Well and badly conditioned matrices of either determinant sign.
        for (k, stretch) in [[1.0, 1.0, 1.0], [3.0, 0.2, 1e-6], [1.0, -0.5, 2.0], [1e3, 1e-9, 1.0]].iter().enumerate() {
            let r = exp(&Vector3::new(0.4 + k as f64, -0.2, 0.9));
            let s = exp(&Vector3::new(-0.3, 0.7 * k as f64, 0.1));
            let m = r.matrix() * Matrix3::from_diagonal(&Vector3::from(*stretch)) * s.matrix();
            let svd = crate::math::linalg::bounded_svd(&m, true, true).unwrap();
            let (u, vt) = (svd.u.unwrap(), svd.v_t.unwrap());
            let mut d = Matrix3::identity();
            d[(2, 2)] = (u * vt).determinant().signum();
            let by_svd = Rotation3::from_matrix_unchecked(u * d * vt);
            let near = nearest_rotation(&m).unwrap();
            assert!(geodesic_angle(&by_svd, &near) < 1e-9, "{stretch:?}: {}", geodesic_angle(&by_svd, &near));
        }
    }

    #[test]
    fn nearest_rotation_of_a_scaled_rotation_is_the_rotation() {
        let r = exp(&Vector3::new(0.4, -0.2, 0.9));
        let near = nearest_rotation(&(r.matrix() * 2.5)).unwrap();
        assert!(geodesic_angle(&r, &near) < 1e-14);
        assert!(nearest_rotation(&Matrix3::zeros()).is_none());
    }

    #[test]
    fn angles_wrap_into_the_half_open_turn() {
        use std::f64::consts::{PI, TAU};

        let within = |a: f64| {
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "wrap_angle({a:e}) = {w:e}");
            // The same angle: a whole number of turns away (exactly, for the exact remainder).
            let turns = (a - w) / TAU;
            assert!((turns - turns.round()).abs() <= 1e-9 * turns.abs().max(1.0), "wrap_angle({a:e}) = {w:e}");
            w
        };
        assert_eq!(within(PI), PI);
        assert_eq!(within(-PI), PI);
        assert_eq!(within(3.0 * PI), PI);
        assert_eq!(within(-3.0 * PI), PI);
        assert_eq!(within(0.5), 0.5);
        for a in [1e17, -1e17, 1.7e308, -1e300, 123.456, -7.0 * PI + 1e-9, 2.5 * TAU] {
            within(a);
        }
        // Past 1e17 the old `a − 2π round(a/2π)` left the range (1.7e308 gave −2e292).
        assert!(wrap_angle(1.7e308).abs() <= PI);
        assert!(wrap_angle(f64::NAN).is_nan() && wrap_angle(f64::INFINITY).is_nan());
    }
}
