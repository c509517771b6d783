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
        let terms = terms_at(self, x);
        for &(_, term, value) in &terms {
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

/// The rig terms of `p` at `x`: `(entry index, term, value)`.
fn terms_at(p: &Parameterisation, x: &DVector<f64>) -> Vec<(usize, RigTerm, f64)> {
    p.entries
        .iter()
        .enumerate()
        .filter_map(|(i, e)| match e.kind {
            Kind::Rig { term } => Some((i, term, x[i])),
            _ => None,
        })
        .collect()
}

/// Camera 1's baseline-direction coordinates `β` in `terms`.
fn baseline_beta(terms: &[(usize, RigTerm, f64)]) -> Vector2<f64> {
    Vector2::from_fn(|k, _| value(terms, RigTerm::Translation { camera: 1, k }))
}

/// Camera `c`'s pose relative to cam0 with `terms` applied, and what the derivatives need: the
/// rotation vector `ω` and camera 1's baseline direction.
fn extrinsics(rig0: &Rig, terms: &[(usize, RigTerm, f64)], c: usize) -> (Isometry3<f64>, Vector3<f64>, Direction) {
    let t0 = rig0.from_cam0(c);
    let omega = Vector3::from_fn(|k, _| value(terms, RigTerm::Rotation { camera: c, k }));
    let rotation = so3::exp(&omega) * t0.rotation.to_rotation_matrix();
    let direction = Direction::of(&t0.translation.vector);
    let translation = if c == 1 {
        direction.at(&baseline_beta(terms))
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

fn value(terms: &[(usize, RigTerm, f64)], term: RigTerm) -> f64 {
    terms.iter().find(|(_, t, _)| *t == term).map_or(0.0, |(_, _, v)| *v)
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

/// How a pixel moves with each rig term of a parameterisation at one `x`: what depends on the
/// camera alone (its rotation, `J_l(ω)`, camera 1's direction derivatives, its entries) is worked
/// out once per evaluation of the Jacobian, not once per observation.
pub(crate) struct PixelDerivatives {
    cameras: Vec<CameraDerivatives>,
}

/// One camera's share of [`PixelDerivatives`].
struct CameraDerivatives {
    /// `R_c` (cam0 → camera c) at `x`.
    rotation: UnitQuaternion<f64>,
    /// `J_l(ω)` of its rotation's parameters.
    left_jacobian: Matrix3<f64>,
    /// `∂t/∂β_k` (camera 1 only; zero otherwise).
    direction: [Vector3<f64>; 2],
    /// The intrinsics' unit (its file focal length).
    focal: f64,
    /// `(entry index, term)` of its terms.
    entries: Vec<(usize, RigTerm)>,
}

impl PixelDerivatives {
    /// The derivatives of `p`'s rig terms at `x` (`None` for a session of points).
    pub(crate) fn new(p: &Parameterisation, x: &DVector<f64>) -> Option<Self> {
        let rig0 = p.rig0.as_deref()?;
        let terms = terms_at(p, x);
        let beta = baseline_beta(&terms);
        let cameras = (0..rig0.cameras.len())
            .map(|c| {
                let (pose, omega, direction) = extrinsics(rig0, &terms, c);
                CameraDerivatives {
                    rotation: pose.rotation,
                    left_jacobian: so3::left_jacobian(&omega),
                    direction: [0, 1].map(|k| if c == 1 { direction.derivative(&beta, k) } else { Vector3::zeros() }),
                    focal: focal(rig0, c),
                    entries: terms.iter().filter(|(_, t, _)| t.camera() == c).map(|(i, t, _)| (*i, *t)).collect(),
                }
            })
            .collect();
        Some(PixelDerivatives { cameras })
    }

    /// How the pixel where camera `c` sees `y` (cam0's frame; `projection` its projection) moves
    /// with each of that camera's terms: `(entry index, ∂pixel/∂term)`.
    pub(crate) fn of<'a>(
        &'a self,
        c: usize,
        y: &Vector3<f64>,
        projection: &'a RigProjection,
    ) -> impl Iterator<Item = (usize, Vector2<f64>)> + 'a {
        let camera = &self.cameras[c];
        let d_rotation = -(camera.rotation * y).cross_matrix() * camera.left_jacobian;
        let lens = &projection.lens;
        camera.entries.iter().map(move |&(i, term)| {
            let d = match term {
                RigTerm::Intrinsic { k, .. } => lens.d_intrinsics[k] * camera.focal,
                RigTerm::Distortion { k, .. } => lens.d_distortion[k],
                RigTerm::Rotation { k, .. } => lens.d_point * d_rotation.column(k),
                RigTerm::Translation { camera: 1, k } => lens.d_point * camera.direction[k],
                RigTerm::Translation { k, .. } => lens.d_point.column(k).into(),
            };
            (i, d)
        })
    }
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
