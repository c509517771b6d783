//! Random geometries around a nominal one: the manufacturing and assembly errors that a
//! calibration must recover (used by the simulator and by the tests).

use nalgebra::Vector3;
use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::geometry::LegGeometry;

/// Standard deviations of the per-leg errors, radians.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GeometrySpread {
    /// Tilt of the axes `u` and `v0` (each tangent component), rad.
    pub axis_tilt: f64,
    /// Error of the link angles `α1`, `α2`, rad.
    pub link_angle: f64,
    /// Encoder zero offset `δ`, rad.
    pub joint_offset: f64,
}

/// Tilt the unit vector `a` by a random tangent vector with components of deviation `sigma`.
///
/// # Panics
/// If `sigma` is infinite (a NaN or negative `sigma` counts as 0: no tilt).
fn tilt<R: Rng + ?Sized>(a: &Vector3<f64>, sigma: f64, rng: &mut R) -> Vector3<f64> {
    let normal = Normal::new(0.0, sigma.max(0.0)).expect("finite, non-negative deviation");
    let e1 = a.cross(&if a.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() }).normalize();
    let e2 = a.cross(&e1);
    let omega = e1 * normal.sample(rng) + e2 * normal.sample(rng);
    crate::math::so3::exp(&omega) * a
}

impl GeometrySpread {
    /// A geometry drawn around `nominal`: axes tilted, link angles and offsets shifted. `z` is
    /// re-orthogonalised against the moved `u`, as the conventions require.
    ///
    /// # Panics
    /// If a spread is infinite (a NaN or negative one counts as 0).
    pub fn perturb<R: Rng + ?Sized>(&self, nominal: &[LegGeometry; 3], rng: &mut R) -> [LegGeometry; 3] {
        let angle = Normal::new(0.0, self.link_angle.max(0.0)).expect("finite deviation");
        let offset = Normal::new(0.0, self.joint_offset.max(0.0)).expect("finite deviation");
        nominal.map(|g| {
            let u = tilt(&g.u, self.axis_tilt, rng);
            LegGeometry {
                u,
                z: (g.z - u * u.dot(&g.z)).normalize(),
                alpha1: g.alpha1 + angle.sample(rng),
                alpha2: g.alpha2 + angle.sample(rng),
                v0: tilt(&g.v0, self.axis_tilt, rng),
                delta: g.delta + offset.sample(rng),
                scale: g.scale,
                home_branch: g.home_branch,
            }
        })
    }
}
