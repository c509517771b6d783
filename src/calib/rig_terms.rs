//! The camera rig's terms in the fit: which ones a session refines, the rig at a parameter
//! vector, and how a pixel moves with each term.
//!
//! A term is measured from the file's value (`cameras.yaml`), like every other parameter; an
//! intrinsic in units of the camera's focal length (`Δfu / fu⁰`: a principal point's shift is
//! then the angle it turns the view by), so that the fit's trust region, which compares every
//! parameter with an angle, takes a pixel's change as the small thing it is. The
//! extrinsics are each camera's pose relative to cam0, `z = R_c y + t_c`: `R_c = exp(ω) R_c⁰`,
//! and for camera 1 `t_c = L n`, `n` the unit direction `normalize(n⁰ + β₀ e₀ + β₁ e₁)` with the
//! baseline's length `L` held at the file's value (the rig's metric scale, which an SPM's
//! rotation-only motion cannot tell); a further camera's translation moves freely,
//! `t_c = t_c⁰ + Δt` (its scale is set by camera 1's baseline).

use nalgebra::{DVector, Isometry3, Matrix3, Translation3, UnitQuaternion, Vector2, Vector3};

use super::config::RigTermGroup;
use super::parameterisation::{Entry, Kind, Parameterisation};
use crate::math::so3;
use crate::model::{Rig, RigProjection, RigTerm};

/// Every term of `rig` in the fit's order: per camera its intrinsics and distortion, then (after
/// the first) its rotation and translation.
pub(crate) fn all_terms(rig: &Rig) -> Vec<RigTerm> {
    let mut terms = Vec::new();
    for camera in 0..rig.cameras.len() {
        terms.extend((0..4).map(|k| RigTerm::Intrinsic { camera, k }));
        terms.extend((0..4).map(|k| RigTerm::Distortion { camera, k }));
        if camera > 0 {
            terms.extend((0..3).map(|k| RigTerm::Rotation { camera, k }));
            let translations = if camera == 1 { 2 } else { 3 };
            terms.extend((0..translations).map(|k| RigTerm::Translation { camera, k }));
        }
    }
    terms
}

/// The bound of a term's change (in the fit's units): intrinsics within 10 % of the focal length, coefficients within
/// ±0.5, rotations within 5°, translations within 5 cm — far beyond a rig calibration's error,
/// short of a different rig.
fn bound(rig: &Rig, term: RigTerm) -> f64 {
    match term {
        RigTerm::Intrinsic { .. } => 0.1,
        RigTerm::Distortion { .. } => 0.5,
        RigTerm::Rotation { .. } => 5f64.to_radians(),
        RigTerm::Translation { camera: 1, .. } => 0.05 / rig.baseline_m().max(1e-6),
        RigTerm::Translation { .. } => 0.05,
    }
}

impl Parameterisation {
    /// The same parameterisation observing through `rig` (the file's values at `x = 0`), with the
    /// terms of `groups` as parameters.
    #[must_use]
    pub(crate) fn with_rig(mut self, rig: std::sync::Arc<Rig>, groups: &[RigTermGroup]) -> Self {
        for term in all_terms(&rig) {
            if groups.iter().any(|g| g.holds(term)) {
                let bound = Some(bound(&rig, term));
                self.entries.push(Entry { kind: Kind::Rig { term }, name: term.name(&rig), bound });
            }
        }
        self.rig0 = Some(rig);
        self
    }

    /// The rig at `x` (`None` for a session of points).
    pub(crate) fn rig(&self, x: &DVector<f64>) -> Option<Rig> {
        let rig0 = self.rig0.as_deref()?;
        let mut rig = rig0.clone();
        let terms: Vec<(RigTerm, f64)> = self
            .entries
            .iter()
            .enumerate()
            .filter_map(|(i, e)| match e.kind {
                Kind::Rig { term } => Some((term, x[i])),
                _ => None,
            })
            .collect();
        for &(term, value) in &terms {
            match term {
                RigTerm::Intrinsic { camera, k } => {
                    rig.cameras[camera].lens.intrinsics[k] += value * focal(rig0, camera)
                }
                RigTerm::Distortion { camera, k } => rig.cameras[camera].lens.distortion[k] += value,
                RigTerm::Rotation { .. } | RigTerm::Translation { .. } => {}
            }
        }
        let poses: Vec<Isometry3<f64>> = (0..rig0.cameras.len()).map(|c| extrinsics(rig0, &terms, c).0).collect();
        for c in 1..rig.cameras.len() {
            rig.cameras[c].from_previous = poses[c] * poses[c - 1].inverse();
        }
        Some(rig)
    }
}

/// Camera `c`'s pose relative to cam0 with `terms` applied, and what the derivatives need: the
/// rotation vector `ω`, camera 1's unnormalised direction `m = n⁰ + β₀ e₀ + β₁ e₁` and its
/// tangent basis.
fn extrinsics(rig0: &Rig, terms: &[(RigTerm, f64)], c: usize) -> (Isometry3<f64>, Vector3<f64>, Direction) {
    let t0 = rig0.from_cam0(c);
    let omega = Vector3::from_fn(|k, _| value(terms, RigTerm::Rotation { camera: c, k }));
    let rotation = so3::exp(&omega) * t0.rotation.to_rotation_matrix();
    let direction = Direction::of(&t0.translation.vector);
    let translation = if c == 1 {
        let beta = Vector2::new(
            value(terms, RigTerm::Translation { camera: 1, k: 0 }),
            value(terms, RigTerm::Translation { camera: 1, k: 1 }),
        );
        direction.at(&beta)
    } else {
        t0.translation.vector + Vector3::from_fn(|k, _| value(terms, RigTerm::Translation { camera: c, k }))
    };
    let pose = Isometry3::from_parts(Translation3::from(translation), UnitQuaternion::from_rotation_matrix(&rotation));
    (pose, omega, direction)
}

/// The unit of camera `camera`'s intrinsic terms in the fit: its focal length `fu⁰` (px).
pub(crate) fn focal(rig0: &Rig, camera: usize) -> f64 {
    rig0.cameras[camera].lens.intrinsics[0].abs()
}

fn value(terms: &[(RigTerm, f64)], term: RigTerm) -> f64 {
    terms.iter().find(|(t, _)| *t == term).map_or(0.0, |(_, v)| *v)
}

/// Camera 1's translation as a direction on a sphere of the file's baseline length.
#[derive(Debug, Clone, Copy)]
struct Direction {
    length: f64,
    n0: Vector3<f64>,
    basis: [Vector3<f64>; 2],
}

impl Direction {
    fn of(t0: &Vector3<f64>) -> Self {
        let length = t0.norm();
        let n0 = t0.try_normalize(1e-12).unwrap_or_else(Vector3::x);
        let hint = if n0.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
        let e0 = (hint - n0 * n0.dot(&hint)).normalize();
        Direction { length, n0, basis: [e0, n0.cross(&e0)] }
    }

    fn unnormalised(&self, beta: &Vector2<f64>) -> Vector3<f64> {
        self.n0 + self.basis[0] * beta.x + self.basis[1] * beta.y
    }

    fn at(&self, beta: &Vector2<f64>) -> Vector3<f64> {
        self.unnormalised(beta).normalize() * self.length
    }

    /// `∂t/∂β_k`.
    fn derivative(&self, beta: &Vector2<f64>, k: usize) -> Vector3<f64> {
        let m = self.unnormalised(beta);
        let n = m.normalize();
        (Matrix3::identity() - n * n.transpose()) * self.basis[k] * (self.length / m.norm())
    }
}

/// How a pixel of camera `c` at the point `y` (cam0's frame) moves with each rig term of `p` at
/// `x`: `(entry index, ∂pixel/∂term)` for the terms of that camera.
pub(crate) fn pixel_derivatives(
    p: &Parameterisation,
    x: &DVector<f64>,
    c: usize,
    y: &Vector3<f64>,
    projection: &RigProjection,
) -> Vec<(usize, Vector2<f64>)> {
    let Some(rig0) = p.rig0.as_deref() else { return Vec::new() };
    let terms: Vec<(RigTerm, f64)> = p
        .entries
        .iter()
        .enumerate()
        .filter_map(|(i, e)| match e.kind {
            Kind::Rig { term } => Some((term, x[i])),
            _ => None,
        })
        .collect();
    let (pose, omega, direction) = extrinsics(rig0, &terms, c);
    let beta = Vector2::new(
        value(&terms, RigTerm::Translation { camera: 1, k: 0 }),
        value(&terms, RigTerm::Translation { camera: 1, k: 1 }),
    );
    let turned = pose.rotation * y;
    let d_rotation = -turned.cross_matrix() * so3::left_jacobian(&omega);
    let lens = &projection.lens;
    p.entries
        .iter()
        .enumerate()
        .filter_map(|(i, e)| match e.kind {
            Kind::Rig { term } if term.camera() == c => Some((i, term)),
            _ => None,
        })
        .map(|(i, term)| {
            let d = match term {
                RigTerm::Intrinsic { camera, k } => lens.d_intrinsics[k] * focal(rig0, camera),
                RigTerm::Distortion { k, .. } => lens.d_distortion[k],
                RigTerm::Rotation { k, .. } => lens.d_point * d_rotation.column(k),
                RigTerm::Translation { camera: 1, k } => lens.d_point * direction.derivative(&beta, k),
                RigTerm::Translation { k, .. } => lens.d_point.column(k).into(),
            };
            (i, d)
        })
        .collect()
}

/// A term's unit for a person and the factor from the fit's unit to it: intrinsics in px (the
/// fit's are focal lengths), coefficients as they are, rotations and camera 1's baseline direction
/// in degrees, a further camera's translation in mm.
pub(crate) fn display(rig0: &Rig, term: RigTerm) -> (&'static str, f64) {
    match term {
        RigTerm::Intrinsic { camera, .. } => ("px", focal(rig0, camera)),
        RigTerm::Distortion { .. } => ("", 1.0),
        RigTerm::Rotation { .. } | RigTerm::Translation { camera: 1, .. } => ("deg", 180.0 / std::f64::consts::PI),
        RigTerm::Translation { .. } => ("mm", 1e3),
    }
}
