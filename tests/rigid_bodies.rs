//! Rigid bodies from motion capture (issue 37): a session of a body's poses (`poses.csv`) calibrates
//! to the simulator's truth within what its predicted standard errors allow, its noise estimates
//! match the simulated noise, its files round-trip, bad rows of `poses.csv` are errors at
//! their file and line, and `compare`, `estimate` and `replay` read it.

use std::path::Path;

use nalgebra::{Rotation3, Vector3};
use spmcal::calib::{CalibConfig, Calibration, FitLevel, TruthInGauge, calibrate};
use spmcal::compare::compare;
use spmcal::dataset::Session;
use spmcal::math::so3;
use spmcal::model::{Parameters, RobotModel};
use spmcal::record::Scene;
use spmcal::sim::{RigidBodySettings, SimConfig};
use spmcal::vision::{Method, SessionEstimate};

#[path = "../examples/marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;

/// A simulated session of the default rigid body (0.3 mm and 0.1° of noise): `poses` static
/// poses, or a free-motion recording of `seconds`.
fn simulate(poses: usize, seconds: Option<f64>, seed: u64) -> (Session, RobotModel, RigidBodySettings) {
    let path = match seconds {
        Some(_) => "configs/simulate_agile_wrist_free_motion.yaml",
        None => "configs/simulate_agile_wrist.yaml",
    };
    let mut config = SimConfig::read(Path::new(path)).unwrap();
    (config.poses, config.seed) = (poses, seed);
    if let (Some(r), Some(s)) = (config.recording.as_mut(), seconds) {
        r.duration_s = s;
    }
    let body = RigidBodySettings::default();
    config.camera.rigid_body = Some(body.clone());
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    (session, model, body)
}

fn calibrated(session: &Session, model: &RobotModel) -> Calibration {
    let config = CalibConfig { folds: 0, ..CalibConfig::default() };
    calibrate(session, model, &config, &mut |_| {}).unwrap()
}

/// Within `k` standard errors, each estimate against the simulated value: `(what, estimate,
/// standard error, truth)`.
fn within(k: f64, checks: &[(&str, f64, f64, f64)]) {
    for (what, estimate, se, truth) in checks {
        assert!(
            (estimate - truth).abs() <= k * se,
            "{what}: {estimate} against {truth}, {:.1} standard errors ({se}) away",
            (estimate - truth).abs() / se
        );
    }
}

#[test]
fn a_static_body_session_calibrates_to_the_truth_and_estimates_its_noise() {
    let (session, model, body) = simulate(200, None, 71);
    assert_eq!(session.body.as_deref(), Some("platform"));
    assert!(session.poses.iter().all(|p| p.body.is_some() && p.markers.is_empty()));
    let c = calibrated(&session, &model);
    let m = c.report.markers.as_ref().unwrap();
    let noise = m.stereo_noise.as_ref().unwrap();
    // The noise estimates within 3σ of the simulated σ's (3σ: a 0.3 % chance each of a false alarm).
    within(
        3.0,
        &[
            (
                "position noise (m)",
                noise.body_position_m.unwrap(),
                noise.body_position_std_error_m.unwrap(),
                body.position_sigma_m,
            ),
            (
                "orientation noise (rad)",
                noise.body_orientation_rad.unwrap(),
                noise.body_orientation_std_error_rad.unwrap(),
                body.orientation_sigma_deg.to_radians(),
            ),
        ],
    );
    // The body frame in the fit's gauge (its P is the true P turned by `H`): origin `H b`,
    // orientation `H B`; each within 4 of its standard errors per axis (4σ over six components:
    // a 0.04 % chance of a false alarm, where the fit's own σ's, not a hand-set tolerance, decide).
    let truth = session.truth.as_ref().unwrap();
    let camera = truth.parameters.camera.unwrap();
    let gauge =
        TruthInGauge::new(&c.parameterisation, &truth.parameters.legs, &camera.rotation, &Rotation3::identity());
    let fitted = &m.markers[0];
    assert_eq!(fitted.name, "platform");
    let origin = gauge.platform * Vector3::from(body.origin_m);
    let se = fitted.std_error_mm.unwrap();
    for k in 0..3 {
        within(4.0, &[("body origin (mm)", fitted.fitted_m[k] * 1e3, se[k], origin[k] * 1e3)]);
    }
    let frame = gauge.platform * so3::exp(&Vector3::from(body.rotation_deg).map(f64::to_radians));
    let fitted_frame = so3::from_wxyz(fitted.rotation_wxyz.unwrap()).unwrap();
    // The error as a turn of the body frame in its own axes, component by component.
    let error = so3::log(&(frame.inverse() * fitted_frame)).map(f64::to_degrees);
    let se = fitted.rotation_std_error_deg.unwrap();
    for k in 0..3 {
        within(4.0, &[("body frame's orientation (deg)", error[k], se[k], 0.0)]);
    }
    // The mechanism: the calibrated model's orientation error on unseen poses (up to the rotations
    // common to every pose, as the predicted error is defined) within 3 × the report's predicted
    // RMS (an RMS over 100 poses of a Gaussian error scatters by ~10 %, not by 3×).
    let tests = study::test_orientations(&truth.parameters.spm().unwrap(), 100, 0x5eed);
    let achieved = study::calibration_error_up_to_common_rotations(&session, &c, &tests);
    let predicted = c.report.predicted_error_deg.as_ref().unwrap().rms;
    assert!(achieved <= 3.0 * predicted, "achieved {achieved:.4}° against {predicted:.4}° predicted");
    // The report says both noises in a person's units and the frame.
    let text = c.report.to_string();
    assert!(text.contains("rigid body noise: position"), "{text}");
    assert!(text.contains("frame's orientation (body → P)"), "{text}");
}

#[test]
fn a_body_recording_calibrates_with_its_latency() {
    let (session, model, body) = simulate(0, Some(60.0), 72);
    let streams = session.streams.as_ref().unwrap();
    assert!(streams.body_poses().count() > 800 && streams.capture_count() == 0);
    let c = calibrated(&session, &model);
    let m = c.report.markers.as_ref().unwrap();
    let latency = m.latency.as_ref().unwrap();
    // The simulated latency (40 ms) within 4 of its standard errors.
    within(4.0, &[("latency (s)", latency.value_s, latency.std_error_s.unwrap(), 0.04)]);
    let noise = m.stereo_noise.as_ref().unwrap();
    within(
        3.0,
        &[(
            "orientation noise (rad)",
            noise.body_orientation_rad.unwrap(),
            noise.body_orientation_std_error_rad.unwrap(),
            body.orientation_sigma_deg.to_radians(),
        )],
    );
}

#[test]
fn body_sessions_round_trip_through_their_folders() {
    for (poses, seconds) in [(30, None), (0, Some(5.0))] {
        let (session, model, _) = simulate(poses, seconds, 73);
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("body");
        session.write(&out).unwrap();
        assert!(out.join("poses.csv").exists() && !out.join("markers.csv").exists());
        let yaml = std::fs::read_to_string(out.join("session.yaml")).unwrap();
        assert!(yaml.contains("body: platform") && !yaml.contains("markers"), "{yaml}");
        let (back, _) = Session::load(&out, Some(&model.urdf_path)).unwrap();
        assert_eq!(back.body, session.body);
        // A recording is its streams (its poses are made at the latency asked for).
        let bodies = |s: &Session| -> Vec<(Option<f64>, spmcal::dataset::BodyPose)> {
            match &s.streams {
                Some(streams) => streams.body_poses().map(|(t, b)| (Some(t), *b)).collect(),
                None => s.poses.iter().map(|p| (None, p.body.unwrap())).collect(),
            }
        };
        let (written, read) = (bodies(&session), bodies(&back));
        assert_eq!(written.len(), read.len());
        assert!(written.len() >= 30);
        for ((ta, a), (tb, b)) in read.iter().zip(&written) {
            assert_eq!(ta, tb);
            // Written with every digit (Ryū) and read back: the same numbers, the quaternion's
            // normalisation and its conversion to a matrix aside (a few ulps).
            assert_eq!(a.position, b.position);
            assert!(so3::geodesic_angle(&a.rotation, &b.rotation) < 1e-12);
            assert!(a.line >= 2, "the line of poses.csv");
        }
    }
}

/// A static body session in a temporary folder with `poses.csv` replaced by `rows`.
fn load_with(rows: &str) -> String {
    let (session, model, _) = simulate(4, None, 74);
    let dir = tempfile::tempdir().unwrap();
    session.write(dir.path()).unwrap();
    std::fs::write(dir.path().join("poses.csv"), rows).unwrap();
    match Session::load(dir.path(), Some(&model.urdf_path)) {
        Ok(_) => panic!("{rows} loaded"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_rows_of_poses_csv_are_errors_at_their_line() {
    const HEADER: &str = "pose,x_m,y_m,z_m,qw,qx,qy,qz\n";
    const GOOD: &str = "0,0.01,0.02,0.75,1,0,0,0\n";
    let cases = [
        (
            format!("{HEADER}{GOOD}1,0.01,0.02,0.75,1,0.2,0,0\n"),
            "poses.csv:3: column `qw`: quaternion [1.0, 0.2, 0.0, 0.0] has norm 1.0198",
        ),
        (format!("{HEADER}{GOOD}1,NaN,0.02,0.75,1,0,0,0\n"), "poses.csv:3: column `x_m`: `NaN` is not finite"),
        (
            format!("{HEADER}{GOOD}1,10.5,20.1,750.2,1,0,0,0\n"),
            "poses.csv:3: column `x_m`: 10.5 m is farther than the 10 m a tracker measures this mechanism's rigid body within: it looks like millimetres",
        ),
        (
            "pose,x_m,y_m,z_m,qw,qx,qy\n0,0.01,0.02,0.75,1,0,0\n".to_string(),
            "poses.csv:1: the header has no column `qz`",
        ),
        (format!("{HEADER}{GOOD}{GOOD}"), "poses.csv:3: column `pose`: pose 0 appears twice"),
        (
            format!("{HEADER}{GOOD}9,0.01,0.02,0.75,1,0,0,0\n"),
            "poses.csv:3: column `pose`: the body's pose at pose 9, which joints.csv does not have",
        ),
    ];
    for (rows, expected) in cases {
        let message = load_with(&rows);
        assert!(message.contains(expected), "expected `{expected}` in `{message}`");
    }
}

#[test]
fn a_folder_of_a_body_and_markers_is_refused() {
    let (session, model, _) = simulate(4, None, 75);
    let dir = tempfile::tempdir().unwrap();
    session.write(dir.path()).unwrap();
    std::fs::write(dir.path().join("markers.csv"), "pose,marker,x_m,y_m,z_m\n").unwrap();
    let message = Session::load(dir.path(), Some(&model.urdf_path)).unwrap_err().to_string();
    assert!(
        message.contains("holds a rigid body's poses (poses.csv) and marker observations (markers.csv)"),
        "{message}"
    );
}

/// `compare`, `estimate` and `replay` read a body session as `calibrate` does: a pose's
/// measurement is its body's turn from the reference pose's (the per-pose level) and its origin,
/// the one "marker" (the marker level). With the true parameters the errors are the tracker's
/// noise; with the nominal ones, the mechanism's error too.
#[test]
fn compare_estimate_and_replay_read_a_body_session() {
    let (session, model, body) = simulate(40, None, 77);
    let truth = session.truth.as_ref().unwrap().parameters.clone();
    let sets = vec![("nominal".to_string(), Parameters::nominal(&model.spm, None)), ("truth".to_string(), truth)];
    let estimate = SessionEstimate::of(&session, Method::Paper).unwrap();
    assert_eq!((estimate.poses.len(), estimate.skipped.len()), (40, 0));
    // A turn from the reference pose carries both poses' noise, σ√2 per axis: its angle's RMS is
    // √6·σ (0.245° at 0.1°), a little less once the reference rotation is fitted to the 40 poses;
    // a position's error is √3·σ (0.52 mm at 0.3 mm) against the file's registration. Between
    // 0.6 and 1.3 times that: 40 poses' RMS is within ±15 % of its expectation at 3σ.
    let levels = [
        (FitLevel::Orientations, 6f64.sqrt() * body.orientation_sigma_deg),
        (FitLevel::Markers, 3f64.sqrt() * body.position_sigma_m * 1e3),
    ];
    for (level, noise) in levels {
        let c = compare(&session, &model, &sets, Method::Paper, Some(level)).unwrap();
        let (nominal, truth) = (&c[0], &c[1]);
        assert_eq!((nominal.per_pose.len(), truth.per_pose.len()), (40, 40), "{level:?}");
        assert!(
            (0.6 * noise..1.3 * noise).contains(&truth.errors.rms),
            "{level:?}: {} against {noise}",
            truth.errors.rms
        );
        assert!(nominal.errors.rms > truth.errors.rms, "{level:?}: {} {}", nominal.errors.rms, truth.errors.rms);
    }
    for params in [None, Some(&sets[1].1)] {
        let scene = Scene::replay(&session, &model, params).unwrap();
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(scene.write(&dir.path().join("body.rrd")).unwrap().poses, 40);
    }
}

/// A body's held-out error is told in its own units: its positions' (mm) at the tracker's noise,
/// its orientations' (deg) apart — a turn in radians is no position in millimetres, and mixed in
/// they made the positions' RMS several times the noise — and the verdict says both.
#[test]
fn a_body_sessions_held_out_error_keeps_positions_and_orientations_apart() {
    let (session, model, body) = simulate(60, None, 79);
    let config = CalibConfig { folds: 5, ..CalibConfig::default() };
    let c = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
    let cv = c.report.cross_validation.as_ref().unwrap();
    // A position's error at its noise (√3·σ, 0.52 mm), a little more held out; not the 2.5 mm the
    // orientations' milliradians made of it.
    let noise_mm = 3f64.sqrt() * body.position_sigma_m * 1e3;
    assert!((0.8 * noise_mm..1.5 * noise_mm).contains(&cv.calibrated_rms), "{} mm", cv.calibrated_rms);
    let [nominal_deg, calibrated_deg] = cv.orientation_rms_deg.unwrap();
    // An orientation's error is at least its noise (√3·σ, 0.17°), and calibration takes the
    // mechanism's share of it away.
    assert!(calibrated_deg > 3f64.sqrt() * body.orientation_sigma_deg * 0.8 && calibrated_deg < nominal_deg);
    assert!(cv.clearly_better && cv.observations == 120, "{cv:?}");
    let summary = c.report.verdict.to_string();
    assert!(summary.contains("body's positions to") && summary.contains("° RMS"), "{summary}");
}
