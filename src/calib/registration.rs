//! A starting point for the camera registration.
//!
//! From rotations (orientation-level fit): the measured rotations are the model's seen from the camera: `Q_j ≈ X B_j Xᵀ` with
//! `B_j = R_j R_refᵀ` and `X = R_CB`. Conjugation maps rotation axes, so `log Q_j ≈ X log B_j`, and
//! `X` is the rotation that best aligns the two sets of rotation vectors (Kabsch); then
//! `A = X R_ref`.
//!
//! From markers (marker-level fit): the rigid motion that best carries the nominal model's markers
//! (in B) onto the measured ones (in C), Kabsch over every observation; it needs no pose with three
//! markers.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::marker_residuals::MarkerObservation;
use super::orientation_residuals::Observation;
use crate::math::so3;
use crate::model::CameraRegistration;

/// `(R_CB, A)` from the observations and the orientations the model predicts for them, `None`
/// when the rotation vectors do not span two directions (every pose rotates about one axis).
/// The reference is the observation of `reference_pose` (the first one if it was left out).
pub(crate) fn from_rotations(
    observations: &[Observation],
    predicted: &[Rotation3<f64>],
    reference_pose: u64,
) -> Option<(Rotation3<f64>, Rotation3<f64>)> {
    let reference = observations.iter().position(|o| o.pose == reference_pose).unwrap_or(0);
    let r_ref = *predicted.get(reference)?;
    let h: Matrix3<f64> = predicted
        .iter()
        .zip(observations)
        .map(|(r, o)| so3::log(&o.measured) * so3::log(&(r * r_ref.inverse())).transpose())
        .sum();
    let svd = crate::math::linalg::bounded_svd(&h, false, false)?;
    let mut s = svd.singular_values.as_slice().to_vec();
    s.sort_by(|a, b| b.total_cmp(a));
    if s[1] < 1e-6 * s[0].max(f64::MIN_POSITIVE) {
        return None;
    }
    let x = so3::nearest_rotation(&h).or_else(|| {
        // Rank 2 (rotations in one plane of axes): the SVD route still has a unique proper answer.
        let svd = crate::math::linalg::bounded_svd(&h, true, true)?;
        let (u, vt) = (svd.u?, svd.v_t?);
        let mut d = Matrix3::identity();
        d[(2, 2)] = (u * vt).determinant().signum();
        Some(Rotation3::from_matrix_unchecked(u * d * vt))
    })?;
    Some((x, x * r_ref))
}

/// `(R_CB, t_CB)` carrying the model's markers, at the orientations `nominal` of each observation,
/// onto the measured ones; `None` for fewer than three observations or markers in a line.
pub(crate) fn from_markers(
    observations: &[MarkerObservation],
    nominal: &[Rotation3<f64>],
    markers: &[Vector3<f64>],
) -> Option<CameraRegistration> {
    let pairs: Vec<(Vector3<f64>, Vector3<f64>)> =
        observations.iter().zip(nominal).map(|(o, r)| (r * markers[o.marker], o.measured)).collect();
    if pairs.len() < 3 {
        return None;
    }
    let n = pairs.len() as f64;
    let cb = pairs.iter().map(|(b, _)| b).sum::<Vector3<f64>>() / n;
    let cc = pairs.iter().map(|(_, c)| c).sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = pairs.iter().map(|(b, c)| (c - cc) * (b - cb).transpose()).sum();
    let rotation = so3::nearest_rotation(&h)?;
    Some(CameraRegistration { rotation, translation: cc - rotation * cb })
}

/// `(R_CB, t_CB)` from pixels: every pixel's ray (through its camera of `rig`, in cam0's frame:
/// origin `o`, direction `d`) must pass through the model's marker `R_CB X + t_CB`, `X` the
/// nominal marker in B: `[d]× (R X + t) = s [d]× o`, linear in the twelve entries of `(R, t)` and
/// the scale `s` (1 for a metric rig; cam0's rays alone fix the registration only up to scale,
/// which the markers' nominal spacing then sets). The null vector of that system (SVD) scaled so
/// that `R` is nearest a rotation, its sign so that the markers lie in front of the camera;
/// `None` when the rays do not determine it (too few, or every marker on one ray).
pub(crate) fn from_pixels(
    observations: &[MarkerObservation],
    nominal: &[Rotation3<f64>],
    markers: &[Vector3<f64>],
    rig: &crate::model::Rig,
) -> Option<CameraRegistration> {
    let mut rows: Vec<[f64; 13]> = Vec::with_capacity(3 * observations.len());
    for (o, r) in observations.iter().zip(nominal) {
        let c = o.camera?;
        let xy = rig.cameras.get(c)?.lens.unproject(&nalgebra::Vector2::new(o.measured.x, o.measured.y))?;
        let to_cam0 = rig.from_cam0(c).inverse();
        let d = (to_cam0.rotation * Vector3::new(xy.x, xy.y, 1.0)).normalize();
        let (x, origin) = (r * markers[o.marker], to_cam0.translation.vector);
        let (skew, rhs) = (d.cross_matrix(), d.cross(&origin));
        for i in 0..3 {
            let mut row = [0.0; 13];
            for k in 0..3 {
                for l in 0..3 {
                    row[3 * k + l] = skew[(i, k)] * x[l];
                }
                row[9 + k] = skew[(i, k)];
            }
            row[12] = -rhs[i];
            rows.push(row);
        }
    }
    if rows.len() < 3 * 7 {
        return None;
    }
    // Rays all through cam0's centre carry no scale: the scale column is then left out (it
    // would be a null direction of its own).
    let columns = if rows.iter().any(|r| r[12] != 0.0) { 13 } else { 12 };
    let a = nalgebra::DMatrix::from_fn(rows.len(), columns, |i, k| rows[i][k]);
    let eigen = crate::math::linalg::bounded_symmetric_eigen(&(a.transpose() * &a))?;
    let k = eigen.eigenvalues.imin();
    let v = eigen.eigenvectors.column(k);
    let m = Matrix3::from_fn(|i, l| v[3 * i + l]);
    let det = m.determinant();
    if det.abs() < f64::MIN_POSITIVE {
        return None;
    }
    // `m = λ R`: λ³ = det m, its sign the null vector's.
    let lambda = det.cbrt();
    let rotation = so3::nearest_rotation(&(m / lambda))?;
    let translation = Vector3::new(v[9], v[10], v[11]) / lambda;
    let registration = CameraRegistration { rotation, translation };
    let in_front = observations
        .iter()
        .zip(nominal)
        .filter(|(o, r)| (rotation * (*r * markers[o.marker]) + translation).z > 0.0)
        .count();
    (2 * in_front > observations.len()).then_some(registration)
}

/// Where a rigid body's fit starts: `(R_CB, t_CB)`, `A` (P → body frame) and the body's origin in
/// P, from its observations (each pose's position then orientation, as
/// [`MarkerObservation::of_session`] makes them) and the nominal model's orientation of each.
/// The measured orientation is `Q_j = R_CB R_j Aᵀ`: the relative rotations `Q_j Q_0ᵀ =
/// R_CB (R_j R_0ᵀ) R_CBᵀ` give `R_CB` as [`from_rotations`] does, then `A` is the chordal mean of
/// `Q_jᵀ R_CB R_j`; the origin `o_j = R_CB R_j b + t_CB` is linear in `(b, t_CB)`, solved by least
/// squares. `None` when the rotations turn about one axis only, or the positions leave `(b, t)`
/// undetermined.
pub(crate) fn from_body(
    observations: &[MarkerObservation],
    nominal: &[Rotation3<f64>],
) -> Option<(CameraRegistration, Rotation3<f64>, Vector3<f64>)> {
    let rotations: Vec<(Rotation3<f64>, Rotation3<f64>)> = observations
        .iter()
        .zip(nominal)
        .filter(|(o, _)| o.rotation)
        .map(|(o, r)| (so3::exp(&o.measured), *r))
        .collect();
    let (q0, _) = *rotations.first()?;
    let relative: Vec<Observation> = rotations
        .iter()
        .enumerate()
        .map(|(k, (q, _))| Observation {
            pose: k as u64,
            joints: Vector3::zeros(),
            measured: q * q0.inverse(),
            markers: 0,
        })
        .collect();
    let predicted: Vec<Rotation3<f64>> = rotations.iter().map(|(_, r)| *r).collect();
    let (camera, _) = from_rotations(&relative, &predicted, 0)?;
    let sum: Matrix3<f64> = rotations.iter().map(|(q, r)| (q.inverse() * camera * r).into_inner()).sum();
    let body = so3::nearest_rotation(&sum)?;
    // Normal equations of o = [R_CB R_j, I] (b, t).
    let (mut normal, mut rhs) = (nalgebra::Matrix6::<f64>::zeros(), nalgebra::Vector6::<f64>::zeros());
    for (o, r) in observations.iter().zip(nominal).filter(|(o, _)| !o.rotation) {
        let mut a = nalgebra::Matrix3x6::<f64>::zeros();
        a.fixed_view_mut::<3, 3>(0, 0).copy_from((camera * r).matrix());
        a.fixed_view_mut::<3, 3>(0, 3).copy_from(&Matrix3::identity());
        normal += a.transpose() * a;
        rhs += a.transpose() * o.measured;
    }
    let solution = normal.cholesky()?.solve(&rhs);
    let origin = Vector3::new(solution[0], solution[1], solution[2]);
    let translation = Vector3::new(solution[3], solution[4], solution[5]);
    Some((CameraRegistration { rotation: camera, translation }, body, origin))
}
