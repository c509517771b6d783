//! The six directions the calibration's parameterisation fixes (the gauge), as extra Jacobian
//! columns: shared by the orientation-level and the marker-level identifiability tests.

use nalgebra::{DMatrix, Vector3};
use spmcal::model::LegGeometry;

/// `jac` with six columns added: the central-difference derivatives of the residuals along tilts
/// of `u_1` (2), of `u_2` out of its plane with `u_1` (1), of `v0_1` (2) and of `v0_2` out of its
/// plane (1). `residuals_of` evaluates the model with the legs so moved.
pub fn augmented_with_gauge(
    jac: &DMatrix<f64>,
    legs: &[LegGeometry; 3],
    residuals_of: impl Fn([LegGeometry; 3]) -> Vec<Vector3<f64>>,
) -> DMatrix<f64> {
    let g = legs;
    let tangent = |a: &Vector3<f64>| {
        let e1 = a.cross(&Vector3::z()).normalize();
        [e1, a.cross(&e1)]
    };
    let n12 = g[0].u.cross(&g[1].u).normalize();
    let m12 = g[0].v0.cross(&g[1].v0).normalize();
    let moves = [
        (true, 0, tangent(&g[0].u)[0]),
        (true, 0, tangent(&g[0].u)[1]),
        (true, 1, g[1].u.cross(&n12).normalize()),
        (false, 0, tangent(&g[0].v0)[0]),
        (false, 0, tangent(&g[0].v0)[1]),
        (false, 1, g[1].v0.cross(&m12).normalize()),
    ];
    let mut augmented = DMatrix::zeros(jac.nrows(), jac.ncols() + moves.len());
    augmented.view_mut((0, 0), (jac.nrows(), jac.ncols())).copy_from(jac);
    let moved = |actuated: bool, leg: usize, angle: Vector3<f64>| {
        let rot = spmcal::math::so3::exp(&angle);
        let mut legs = *g;
        if actuated {
            legs[leg].u = rot * legs[leg].u;
            legs[leg].z = rot * legs[leg].z;
        } else {
            legs[leg].v0 = rot * legs[leg].v0;
        }
        residuals_of(legs)
    };
    let h = 1e-6;
    for (k, (actuated, leg, dir)) in moves.iter().enumerate() {
        let (plus, minus) = (moved(*actuated, *leg, dir * h), moved(*actuated, *leg, dir * -h));
        for j in 0..plus.len() {
            augmented.fixed_view_mut::<3, 1>(3 * j, jac.ncols() + k).copy_from(&((plus[j] - minus[j]) / (2.0 * h)));
        }
    }
    augmented
}
