//! Properties of the kinematics over random geometries and orientations (proptest shrinks
//! any counterexample to a small case).

use nalgebra::Vector3;
use proptest::prelude::*;
use rand::SeedableRng;
use spmcal::math::so3;
use spmcal::model::{Branch, GeometrySpread, Spm};

/// `a` wrapped into (−π, π].
fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let w = a - two_pi * (a / two_pi).round();
    if w <= -std::f64::consts::PI { w + two_pi } else { w }
}

const DEG: f64 = std::f64::consts::PI / 180.0;

fn geometry(seed: u64) -> Spm {
    let spread = GeometrySpread { axis_tilt: 1.0 * DEG, link_angle: 0.5 * DEG, joint_offset: 5.0 * DEG };
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    Spm::new(spread.perturb(Spm::agile_wrist_nominal().geometry(), &mut rng)).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// IK closes every loop in the working branch, FDA gives the orientation back, and the
    /// velocity relation A ω = B θ̇ holds along a small motion.
    #[test]
    fn ik_fda_round_trip(seed in 0u64..1000, tilt in 0.0..30.0 * DEG, azimuth in 0.0..360.0 * DEG, yaw in -30.0 * DEG..30.0 * DEG) {
        let spm = geometry(seed);
        let r = so3::exp(&(Vector3::new(azimuth.cos(), azimuth.sin(), 0.0) * tilt)) * so3::exp(&(Vector3::z() * yaw));
        let joints = spm.ik(&r).unwrap();
        prop_assert!(joints.iter().all(|j| *j > -std::f64::consts::PI && *j <= std::f64::consts::PI));
        prop_assert!(spm.closure_residual(&joints, &r).amax() < 1e-14);
        prop_assert_eq!(spm.branches(&joints, &r), [Branch::Working; 3]);
        let back = spm.forward(&joints).unwrap();
        prop_assert!(so3::geodesic_angle(&r, &back) < 1e-10);
        // A small rotation ω changes the joints by B⁻¹ A ω to first order.
        let omega = Vector3::new(1e-7, -2e-7, 1.5e-7);
        let moved = spm.ik(&(so3::exp(&omega) * r)).unwrap();
        let jac = spm.jacobians(&joints, &r);
        let predicted = jac.b.try_inverse().unwrap() * jac.a * omega;
        let actual = Vector3::from_fn(|i, _| wrap_angle(moved[i] - joints[i]));
        prop_assert!((predicted - actual).amax() < 1e-12, "{:?} vs {:?}", predicted, actual);
    }

    /// The working-mode solution is one of the assembly modes, and all of them close the loops.
    #[test]
    fn working_mode_is_among_all_modes(seed in 0u64..1000, tilt in 0.0..30.0 * DEG, azimuth in 0.0..360.0 * DEG) {
        let spm = geometry(seed);
        let r = so3::exp(&(Vector3::new(azimuth.cos(), azimuth.sin(), 0.0) * tilt));
        let joints = spm.ik(&r).unwrap();
        let modes = spm.all_modes(&joints);
        prop_assert!(!modes.is_empty() && modes.iter().all(|m| m.residual < 1e-12));
        let working = modes.iter().find(|m| so3::geodesic_angle(&m.rotation, &r) < 1e-10);
        prop_assert!(working.is_some_and(|m| m.all_working()));
    }
}
