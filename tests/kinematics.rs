//! Kinematics against independent facts: the nominal home pose, IK → FDA round trips on
//! nominal and perturbed geometries, all-modes completeness against multi-start Newton,
//! and the velocity Jacobians against finite differences.

use nalgebra::{Rotation3, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use spmcal::math::so3;
use spmcal::model::{Branch, GeometrySpread, IkError, LegGeometry, Spm};

const DEG: f64 = std::f64::consts::PI / 180.0;

/// An orientation in the ±30° tilt / ±30° yaw workspace: a tilt about a horizontal axis
/// after a yaw about the vertical.
fn workspace_orientation(rng: &mut impl Rng, max_tilt: f64, max_yaw: f64) -> Rotation3<f64> {
    let azimuth = rng.random_range(0.0..std::f64::consts::TAU);
    let tilt = rng.random_range(0.0..max_tilt);
    let yaw = rng.random_range(-max_yaw..max_yaw);
    so3::exp(&(Vector3::new(azimuth.cos(), azimuth.sin(), 0.0) * tilt)) * so3::exp(&(Vector3::z() * yaw))
}

fn perturbed(rng: &mut StdRng) -> Spm {
    let spread = GeometrySpread { axis_tilt: 1.0 * DEG, link_angle: 0.5 * DEG, joint_offset: 3.0 * DEG };
    Spm::new(spread.perturb(Spm::agile_wrist_nominal().geometry(), rng)).expect("small perturbations stay valid")
}

#[test]
fn nominal_home_is_zero_joints_both_ways() {
    let spm = Spm::agile_wrist_nominal();
    let joints = spm.ik(&Rotation3::identity()).unwrap();
    assert!(joints.amax() < 1e-15, "IK(I) = {joints:?}");
    let r = spm.forward(&Vector3::zeros()).unwrap();
    assert!(so3::geodesic_angle(&r, &Rotation3::identity()) < 1e-15);
    // Mutually orthogonal actuated axes and platform axes, as the design says.
    let g = spm.geometry();
    for (i, j) in [(0, 1), (1, 2), (0, 2)] {
        assert!(g[i].u.dot(&g[j].u).abs() < 1e-15 && g[i].v0.dot(&g[j].v0).abs() < 1e-15);
    }
}

/// Round trip IK → FDA: `forward(ik(R)) = R` to 1e-10 rad on `n` workspace orientations.
fn assert_round_trip(spm: &Spm, rng: &mut StdRng, n: usize) {
    for k in 0..n {
        let r = workspace_orientation(rng, 30.0 * DEG, 30.0 * DEG);
        let joints = spm.ik(&r).unwrap_or_else(|e| panic!("pose {k}: {e}"));
        let back = spm.forward(&joints).unwrap_or_else(|e| panic!("pose {k} ({joints:?}): {e}"));
        let err = so3::geodesic_angle(&r, &back);
        assert!(err < 1e-10, "pose {k}: round trip error {err:e} rad");
        // The haptic path from a nearby previous orientation lands on the same pose.
        let previous = so3::exp(&Vector3::new(0.01, -0.02, 0.015)) * r;
        let tracked = spm.track(&joints, &previous).unwrap();
        assert!(so3::geodesic_angle(&r, &tracked) < 1e-10);
    }
}

#[test]
fn round_trip_nominal_10000_orientations() {
    let mut rng = StdRng::seed_from_u64(1);
    assert_round_trip(&Spm::agile_wrist_nominal(), &mut rng, 10_000);
}

#[test]
fn round_trip_perturbed_geometries_10000_orientations_each() {
    let mut rng = StdRng::seed_from_u64(2);
    for _ in 0..5 {
        let spm = perturbed(&mut rng);
        assert_round_trip(&spm, &mut rng, 10_000);
    }
}

#[test]
fn a_sagging_platform_round_trips_and_turns_down_by_its_sag_times_the_sine_of_its_tilt() {
    let mut rng = StdRng::seed_from_u64(5);
    for sag_deg in [0.5, -2.0, 10.0] {
        let rigid = perturbed(&mut rng);
        let spm = rigid.clone().with_platform_sag(sag_deg * DEG).unwrap();
        assert_round_trip(&spm, &mut rng, 2_000);
        for _ in 0..200 {
            let r = workspace_orientation(&mut rng, 30.0 * DEG, 30.0 * DEG);
            let joints = rigid.ik(&r).unwrap();
            // The same joints: the rigid mechanism's orientation, turned down about the horizontal
            // axis across the tilt by the sag times the sine of the tilt (the gravity torque's arm).
            let sagged = spm.forward(&joints).unwrap();
            let tilt = |r: &Rotation3<f64>| (r * Vector3::z()).z.clamp(-1.0, 1.0).acos();
            let expected = sag_deg * DEG * tilt(&r).sin();
            assert!((so3::geodesic_angle(&r, &sagged) - expected.abs()).abs() < 1e-12);
            assert!((tilt(&sagged) - tilt(&r) - expected).abs() < 1e-12);
            // `rigid` undoes `sagged`; IK of the platform as it is reads the same joints.
            assert!(so3::geodesic_angle(&spm.rigid(&sagged), &r) < 1e-12);
            assert!((spm.ik(&sagged).unwrap() - joints).amax() < 1e-11);
        }
    }
    // Beyond ±10° per unit of arm, or not a number: refused.
    for bad in [10.5 * DEG, f64::NAN, f64::INFINITY] {
        assert!(Spm::agile_wrist_nominal().with_platform_sag(bad).is_err());
    }
}

#[test]
fn both_ik_branches_close_the_loop_and_differ_in_sign() {
    let mut rng = StdRng::seed_from_u64(3);
    let spm = perturbed(&mut rng);
    for _ in 0..200 {
        let r = workspace_orientation(&mut rng, 30.0 * DEG, 30.0 * DEG);
        for branch in [Branch::Working, Branch::Other] {
            let joints = Vector3::from_fn(|i, _| spm.ik_leg(i, &r, branch).unwrap());
            assert!(spm.closure_residual(&joints, &r).amax() < 1e-14);
            assert_eq!(spm.branches(&joints, &r), [branch; 3]);
        }
    }
}

/// A general (non-Agile-Wrist) SPM: link angles `alpha1`, `alpha2`, cone angles 40° and 60°.
/// `v0` is placed so that the loop closes at home with `w = z`.
fn general_geometry(alpha1: f64, alpha2: f64) -> Spm {
    Spm::new([0, 1, 2].map(|i| {
        let mut g = LegGeometry::nominal(i, 40.0 * DEG, 60.0 * DEG, alpha1, alpha2);
        let w0 = g.u * alpha1.cos() + g.z * alpha1.sin();
        let n = (g.v0 - w0 * w0.dot(&g.v0)).normalize();
        g.v0 = w0 * alpha2.cos() + n * alpha2.sin();
        g
    }))
    .unwrap()
}

#[test]
fn ik_rejects_orientations_outside_the_workspace() {
    // The nominal wrist (α1 = α2 = 90°) reaches every v not parallel to u; a general one does not.
    // Leg 1 reaches v only when angle(u, v) lies in [|α1 − α2|, α1 + α2] = [15°, 135°]:
    // turning v0_1 onto −u_1 (180°) is out of reach.
    let spm = general_geometry(60.0 * DEG, 75.0 * DEG);
    let g = spm.geometry()[0];
    let r = Rotation3::rotation_between(&g.v0, &(-g.u)).unwrap();
    assert!(matches!(spm.ik(&r), Err(IkError::OutsideWorkspace { .. })), "{:?}", spm.ik(&r));
}

#[test]
fn round_trip_general_geometry() {
    let mut rng = StdRng::seed_from_u64(6);
    let spm = general_geometry(60.0 * DEG, 75.0 * DEG);
    let mut done = 0;
    while done < 2000 {
        let r = workspace_orientation(&mut rng, 20.0 * DEG, 30.0 * DEG);
        let joints = spm.ik(&r).unwrap();
        let back = spm.forward(&joints).unwrap();
        assert!(so3::geodesic_angle(&r, &back) < 1e-10);
        done += 1;
    }
}

/// Dense multi-start Newton with backtracking on |f|²: every solution it can find.
fn multistart(spm: &Spm, joints: &Vector3<f64>, rng: &mut StdRng, starts: usize) -> Vec<Rotation3<f64>> {
    let mut found: Vec<Rotation3<f64>> = Vec::new();
    for _ in 0..starts {
        let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ));
        let mut r = q.to_rotation_matrix();
        for _ in 0..200 {
            let f = spm.closure_residual(joints, &r);
            if f.amax() < 1e-13 {
                break;
            }
            let jac = spm.jacobians(joints, &r);
            // Residual change for R ← exp(ω) R is ω·(v×w) = −(A ω)_i.
            let Some(step) = jac.a.lu().solve(&f) else {
                break;
            };
            let mut t = 1.0;
            while t > 1e-6 {
                let trial = so3::exp(&(step * t)) * r;
                if spm.closure_residual(joints, &trial).norm() < f.norm() {
                    r = trial;
                    break;
                }
                t *= 0.5;
            }
            if t <= 1e-6 {
                break;
            }
        }
        if spm.closure_residual(joints, &r).amax() < 1e-12 && !found.iter().any(|s| so3::geodesic_angle(s, &r) < 1e-7) {
            found.push(r);
        }
    }
    found
}

#[test]
fn all_modes_is_complete_and_has_no_spurious_solutions() {
    let mut rng = StdRng::seed_from_u64(4);
    let mut total = 0;
    for case in 0..25 {
        let spm = match case {
            0 => Spm::agile_wrist_nominal(),
            1..=5 => general_geometry((50.0 + 6.0 * case as f64) * DEG, (80.0 - 4.0 * case as f64) * DEG),
            _ => perturbed(&mut rng),
        };
        let r = workspace_orientation(&mut rng, 20.0 * DEG, 30.0 * DEG);
        let joints = spm.ik(&r).unwrap();
        let modes = spm.all_modes(&joints);
        assert!(modes.len() <= 8 && !modes.is_empty());
        for m in &modes {
            assert!(spm.closure_residual(&joints, &m.rotation).amax() < 1e-12, "case {case}: spurious solution");
        }
        assert!(
            modes.iter().any(|m| so3::geodesic_angle(&m.rotation, &r) < 1e-10),
            "case {case}: generating pose missing"
        );
        for s in multistart(&spm, &joints, &mut rng, 400) {
            assert!(
                modes.iter().any(|m| so3::geodesic_angle(&m.rotation, &s) < 1e-8),
                "case {case}: multi-start found a solution all_modes missed ({} modes)",
                modes.len()
            );
        }
        total += modes.len();
    }
    assert!(total > 25 * 2, "only {total} solutions over 25 cases: the search is not exploring");
}

#[test]
fn jacobians_match_finite_differences() {
    let mut rng = StdRng::seed_from_u64(5);
    let spm = perturbed(&mut rng);
    for _ in 0..50 {
        let r = workspace_orientation(&mut rng, 30.0 * DEG, 30.0 * DEG);
        let joints = spm.ik(&r).unwrap();
        let j = spm.jacobians(&joints, &r).forward().unwrap();
        let h = 1e-6;
        for k in 0..3 {
            let mut dj = Vector3::zeros();
            dj[k] = h;
            let plus = spm.track(&(joints + dj), &r).unwrap();
            let minus = spm.track(&(joints - dj), &r).unwrap();
            let omega = so3::log(&(plus * minus.inverse())) / (2.0 * h);
            // Central differences: error O(h²) ≈ 1e-12 times third derivatives of order one.
            assert!((omega - j.column(k)).amax() < 1e-8, "column {k}: {omega:?} vs {:?}", j.column(k));
        }
    }
}

#[test]
fn forward_refuses_poses_near_a_parallel_singularity() {
    let spm = Spm::agile_wrist_nominal();
    // Walk one joint until the FDA refuses: it must say why (singularity or branch), never panic.
    let mut refused = None;
    for k in 1..=180 {
        let joints = Vector3::new(k as f64 * DEG, -(k as f64) * DEG, 0.0);
        if let Err(e) = spm.forward(&joints) {
            refused = Some(e);
            break;
        }
    }
    let e = refused.expect("a large joint excursion reaches a singularity");
    assert!(
        matches!(e, spmcal::model::FdaError::NearSingular { .. } | spmcal::model::FdaError::LeftWorkingMode { .. }),
        "{e}"
    );
}

#[test]
fn ik_refuses_a_serial_singularity_instead_of_inventing_a_joint_angle() {
    // Nominal wrist: turn leg 1's platform axis onto its actuated axis. Every joint angle closes
    // that leg's loop alike, so there is no answer to give.
    let spm = general_geometry(90.0 * DEG, 90.0 * DEG);
    let g = spm.geometry()[0];
    let r = Rotation3::rotation_between(&g.v0, &g.u).unwrap();
    assert!(matches!(spm.ik(&r), Err(IkError::SerialSingularity { leg: 0, .. })), "{:?}", spm.ik(&r));
    // Slightly away from it the answer is determined again.
    let off = Rotation3::from_axis_angle(&Vector3::x_axis(), 1e-3) * r;
    assert!(spm.ik(&off).is_ok() || matches!(spm.ik(&off), Err(IkError::OutsideWorkspace { .. })));
}
