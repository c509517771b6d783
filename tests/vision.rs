//! The vision estimator against the paper's published numbers, properties that any correct
//! estimator has (proptest), its typed errors, and the accuracy study's conclusion.

use std::path::Path;

use nalgebra::{Matrix3, Rotation3, Vector3};
use proptest::prelude::*;
use spmcal::math::constellation::Degeneracy;
use spmcal::math::polar::Polar;
use spmcal::math::so3;
use spmcal::vision::{MarkerError, Method, Reference, SessionEstimate};

/// The four markers of the nominal model (P frame), a tetrahedron as in the paper.
fn tetrahedron() -> Vec<Vector3<f64>> {
    let r = 0.075;
    let mut m: Vec<_> = [90.0f64, 210.0, 330.0]
        .iter()
        .map(|a| Vector3::new(r * a.to_radians().cos(), r * a.to_radians().sin(), 0.06))
        .collect();
    m.push(Vector3::new(0.0, 0.0, 0.22));
    m
}

/// Eq. (13): the unfiltered putative rotation of pose 14.
fn eq13() -> Matrix3<f64> {
    Matrix3::new(-0.0675, 1.0157, 0.0007, -0.9323, -0.0151, 0.3778, 0.4010, 0.0376, 0.9949)
}

fn assert_printed(got: &Matrix3<f64>, printed: &Matrix3<f64>, what: &str) {
    // Four decimals are printed: agreement to half a unit of the last digit.
    assert!((got - printed).amax() <= 5e-5, "{what}: got {got:.5}, printed {printed:.4}");
}

#[test]
fn reproduces_the_papers_equations_14_and_15_and_table_1() {
    // Markers of pose 14 made exactly from the reference by eq. (13) (plus a translation):
    // the least squares of eq. (7) must return eq. (13) itself.
    let reference: Vec<_> = tetrahedron().iter().map(|p| p + Vector3::new(0.01, -0.02, 0.75)).collect();
    let c0 = reference.iter().sum::<Vector3<f64>>() / 4.0;
    let shift = Vector3::new(0.003, 0.001, -0.002);
    let pose14: Vec<_> = reference.iter().map(|p| eq13() * (p - c0) + c0 + shift).collect();
    let estimate = Reference::new(&reference).unwrap().estimate(&pose14, Method::Paper).unwrap();
    assert!((estimate.putative - eq13()).amax() < 1e-14, "eq. (7) does not give eq. (13)");
    let eq14 = Matrix3::new(1.0345, -0.0394, 0.0467, -0.0394, 1.0333, 0.0324, 0.0467, 0.0324, 1.1326);
    assert_printed(&(estimate.putative.transpose() * estimate.putative), &eq14, "eq. (14)");
    let eq15 = Matrix3::new(-0.0469, 0.9988, -0.0132, -0.9261, -0.0385, 0.3754, 0.3744, 0.0298, 0.9268);
    assert_printed(estimate.rotation.matrix(), &eq15, "eq. (15)");
    // Table I, pose 14: e = 0.0277 (printed to 4 decimals).
    assert!((estimate.error - 0.0277).abs() <= 5e-5, "e_14 = {}", estimate.error);
    assert!((estimate.translation - shift).amax() < 1e-15);
    assert!(estimate.redundant && estimate.markers_used == 4);
}

fn rotation(v: [f64; 3]) -> Rotation3<f64> {
    so3::exp(&Vector3::from(v))
}

/// Markers around the origin: `m` of them at spread azimuths (jittered by `seed`), at alternating
/// heights and one atop a column, so that any `m ≥ 4` is well off a plane; `m = 3` is planar.
fn markers(m: usize, seed: &[f64]) -> Vec<Vector3<f64>> {
    (0..m)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / m as f64 + 0.4 * seed[i % seed.len()].sin();
            let z = match (m, i) {
                (3, _) => 0.06,
                (_, 3) => 0.16,
                _ => 0.06 + 0.02 * (i % 2) as f64,
            };
            Vector3::new(0.08 * a.cos(), 0.08 * a.sin(), z)
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn estimates_are_proper_rotations_with_spd_stretch(
        r in prop::array::uniform3(-1.5..1.5f64),
        seed in prop::collection::vec(0.0..std::f64::consts::TAU, 1..6),
        m in 3usize..9,
        noise in prop::collection::vec(-0.002..0.002f64, 27),
    ) {
        let reference = markers(m, &seed);
        let q = rotation(r);
        let current: Vec<_> = reference.iter().enumerate()
            .map(|(i, p)| q * p + Vector3::new(noise[3 * i], noise[3 * i + 1], noise[3 * i + 2]) + Vector3::new(0.1, 0.0, 0.8))
            .collect();
        let factor = Reference::new(&reference).unwrap();
        for method in [Method::Paper, Method::Kabsch] {
            let e = factor.estimate(&current, method).unwrap();
            let qm = e.rotation.matrix();
            prop_assert!((qm.transpose() * qm - Matrix3::identity()).amax() < 1e-12);
            prop_assert!((qm.determinant() - 1.0).abs() < 1e-12);
            prop_assert!((e.stretch - e.stretch.transpose()).amax() < 1e-12);
            prop_assert!(e.stretch.symmetric_eigenvalues().min() > 0.0);
            prop_assert_eq!(e.redundant, m >= 4);
        }
    }

    #[test]
    fn noise_free_markers_give_the_true_rotation(
        r in prop::array::uniform3(-1.5..1.5f64),
        seed in prop::collection::vec(0.0..std::f64::consts::TAU, 1..6),
        m in 3usize..9,
    ) {
        let reference = markers(m, &seed);
        let q = rotation(r);
        let current: Vec<_> = reference.iter().map(|p| q * p + Vector3::new(-0.05, 0.02, 0.7)).collect();
        let factor = Reference::new(&reference).unwrap();
        for method in [Method::Paper, Method::Kabsch] {
            let e = factor.estimate(&current, method).unwrap();
            prop_assert!(so3::geodesic_angle(&e.rotation, &q) < 1e-12);
            prop_assert!(e.error < 1e-12);
        }
    }

    #[test]
    fn a_rigid_motion_of_the_camera_leaves_the_rotation_angle_unchanged(
        r in prop::array::uniform3(-1.0..1.0f64),
        camera in prop::array::uniform3(-3.0..3.0f64),
        shift in prop::array::uniform3(-1.0..1.0f64),
        noise in prop::collection::vec(-0.002..0.002f64, 12),
    ) {
        let reference = markers(4, &[0.3]);
        let q = rotation(r);
        let current: Vec<_> = reference.iter().enumerate()
            .map(|(i, p)| q * p + Vector3::new(noise[3 * i], noise[3 * i + 1], noise[3 * i + 2]))
            .collect();
        let (rc, tc) = (rotation(camera), Vector3::from(shift));
        let moved = |ps: &[Vector3<f64>]| -> Vec<Vector3<f64>> { ps.iter().map(|p| rc * p + tc).collect() };
        for method in [Method::Paper, Method::Kabsch] {
            let here = Reference::new(&reference).unwrap().estimate(&current, method).unwrap();
            let there = Reference::new(&moved(&reference)).unwrap().estimate(&moved(&current), method).unwrap();
            let (a, b) = (so3::log(&here.rotation).norm(), so3::log(&there.rotation).norm());
            prop_assert!((a - b).abs() < 1e-12, "{} vs {}", a, b);
            // More than the angle: the rotation is the same one, seen from the moved camera.
            prop_assert!(so3::geodesic_angle(&(rc * here.rotation * rc.inverse()), &there.rotation) < 1e-12);
            prop_assert!((here.error - there.error).abs() < 1e-12);
        }
    }
}

#[test]
fn degenerate_markers_get_typed_errors() {
    let line: Vec<_> = (0..4).map(|i| Vector3::new(0.01 * i as f64, 0.02 * i as f64, 0.7)).collect();
    assert!(matches!(Reference::new(&line), Err(MarkerError::Degenerate(Degeneracy::Collinear { .. }))));
    let point = vec![Vector3::new(0.1, 0.2, 0.7); 4];
    assert!(matches!(Reference::new(&point), Err(MarkerError::Degenerate(Degeneracy::Coincident { .. }))));
    // Degeneracy is judged against the noise: a triangle 0.5 mm off a line, or two markers 0.1 mm
    // apart, is degenerate to a camera with millimetre noise (it would flip by 180° on noise).
    let near_line = vec![Vector3::new(0.0, 0.0, 0.7), Vector3::new(0.05, 0.0005, 0.7), Vector3::new(0.1, 0.0, 0.7)];
    assert!(matches!(Reference::new(&near_line), Err(MarkerError::Degenerate(Degeneracy::Collinear { .. }))));
    let mut close = tetrahedron();
    close[3] = close[2] + Vector3::new(1e-4, 0.0, 0.0);
    assert!(matches!(Reference::new(&close), Err(MarkerError::Degenerate(Degeneracy::Coincident { .. }))));
    let good = Reference::new(&tetrahedron()).unwrap();
    assert!(matches!(
        good.estimate(&close, Method::Kabsch),
        Err(MarkerError::Degenerate(Degeneracy::Coincident { .. }))
    ));
    assert!(matches!(Reference::new(&point[..2]), Err(MarkerError::TooFew { seen: 2 })));
    // A mirror image is not a rotation.
    let reference = tetrahedron();
    let mirrored: Vec<_> = reference.iter().map(|p| Vector3::new(-p.x, p.y, p.z)).collect();
    let err = Reference::new(&reference).unwrap().estimate(&mirrored, Method::Paper).unwrap_err();
    assert!(matches!(err, MarkerError::Reflection { det } if det < 0.0), "{err}");
}

#[test]
fn session_errors_name_the_pose_and_poses_with_three_markers_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let (mut session, _) = spmcal::dataset::Session::load(Path::new("datasets/agile_wrist_sim_20"), None).unwrap();
    // Three poses that saw all four markers: hide two markers of the first, mirror the second,
    // hide one marker of the third.
    let full: Vec<usize> = (1..session.poses.len()).filter(|&k| session.poses[k].seen() == 4).take(3).collect();
    let ids: Vec<u64> = full.iter().map(|&k| session.poses[k].id).collect();
    session.poses[full[0]].markers[0] = None;
    session.poses[full[0]].markers[1] = None;
    for m in session.poses[full[1]].markers.iter_mut().flatten() {
        m.x = -m.x;
    }
    session.poses[full[2]].markers[3] = None;
    session.write(dir.path()).unwrap();
    let (session, warnings) =
        spmcal::dataset::Session::load(dir.path(), Some(Path::new("models/agile_wrist.urdf"))).unwrap();
    // Few markers are data (for the marker-level fit), not a load warning; the estimator skips them.
    assert!(warnings.is_empty(), "{warnings:?}");
    let result = SessionEstimate::of(&session, Method::Paper).unwrap();
    let skipped: Vec<String> = result.skipped.iter().map(|s| s.to_string()).collect();
    assert_eq!(skipped.len(), 2, "{skipped:?}");
    // Each located at its markers.csv row, the file in full: `<folder>/markers.csv:57: pose 14: …`.
    let file = format!("{}:", dir.path().join("markers.csv").display());
    let line = |id: u64| {
        let at = format!(": pose {id}: ");
        skipped.iter().find(|s| s.starts_with(&file) && s.contains(&at)).cloned().unwrap_or_default()
    };
    assert!(line(ids[0]).contains("2 markers seen in both"), "{skipped:?}");
    assert!(line(ids[1]).contains("the putative rotation has determinant"), "{skipped:?}");
    let third = result.poses.iter().find(|(p, _)| *p == ids[2]).unwrap().1;
    assert!(!third.redundant && third.markers_used == 3);
}

#[test]
fn higham_agrees_with_the_svd_on_noisy_rotations() {
    for k in 0..200 {
        let q = rotation([0.01 * k as f64, -0.7, 0.3 * (k as f64).sin()]);
        let noise = Matrix3::from_fn(|i, j| 0.02 * ((k * 9 + i * 3 + j) as f64 * 1.3).sin());
        let a = q.matrix() + noise;
        let (newton, svd) = (Polar::of(&a).unwrap(), Polar::by_svd(&a).unwrap());
        assert!((newton.q - svd.q).amax() < 1e-14 && newton.iterations <= 4, "{k}: {} iterations", newton.iterations);
    }
}

/// The study behind the README's accuracy table (`examples/vision_accuracy`), on one small case.
#[path = "../examples/vision_accuracy/study.rs"]
mod study;

#[test]
fn accuracy_study_errors_scale_with_noise_and_kabsch_is_better() {
    let mut config = spmcal::sim::SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = 120;
    let model = spmcal::model::RobotModel::load(&config.model).unwrap();
    let rows = study::accuracy_study(&config, &model, &[0.5, 1.0, 2.0]).unwrap();
    for pair in rows.windows(2) {
        // Same poses, twice the noise: twice the error (small-noise regime), within 5%.
        let ratio = pair[1].paper_rms_deg / pair[0].paper_rms_deg;
        assert!((ratio - 2.0).abs() < 0.1, "error ratio {ratio}");
    }
    for r in &rows {
        // Kabsch minimises the marker residuals; under this noise it is also closer to the truth.
        assert!(r.kabsch_rms_deg < r.paper_rms_deg, "{r:?}");
        assert_eq!(r.poses, 120);
    }
}
