//! The marker-level fit recovering a simulated truth, misplaced markers included, within its
//! standard errors, at the Cramér–Rao bound. The model's analytic Jacobian, the directions the
//! marker data leave free and the one-step cross-validation are unit tests inside the crate
//! (`calib::tests`): the residual model (`calib::Model`) is the crate's own.

use std::path::Path;

use nalgebra::Vector3;
use spmcal::calib::CalibConfig;
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

fn simulated(poses: usize, seed: u64, sequential: bool) -> (Session, RobotModel) {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = poses;
    config.seed = seed;
    config.capture.sequential = sequential;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    (session, model)
}

/// Standardised errors of the fits' parameters against the truth, checked for honest σ's.
#[path = "common/z_scores.rs"]
#[allow(dead_code)] // shared by the tests, each using part of it
mod z_scores;

/// The efficiency study of the README (`examples/marker_efficiency`), here on one noise level.
#[path = "../examples/marker_efficiency/study.rs"]
#[allow(dead_code)] // shared by the studies, each using part of it
mod study;

fn config(poses: usize) -> SimConfig {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = poses;
    config
}

#[test]
fn the_marker_level_fit_reaches_the_cramer_rao_bound_and_beats_the_orientation_level_fit() {
    // 20 sessions (a new true geometry and misplaced markers each), 200 poses, 4 markers at once.
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap();
    let rows: Vec<_> = (0..20).map(|s| study::run_session(&config(200), &model, 10_000 + s, 60)).collect();
    let markers = study::pooled(rows.iter().map(|r| r.markers_deg));
    let orientations = study::pooled(rows.iter().map(|r| r.orientations_deg.unwrap()));
    let bound = study::pooled(rows.iter().map(|r| r.cramer_rao_deg));
    eprintln!("marker-level {markers:.4}°, orientation-level {orientations:.4}°, Cramér–Rao {bound:.4}°");
    // Efficient: within 10% of the bound (the RMS over 20 sessions of a ~30-parameter error has a
    // relative spread of ~4%; 1.02 measured, the excess is the encoders' noise, which the bound leaves out).
    assert!((markers / bound - 1.0).abs() < 0.10, "{markers} vs {bound}");
    // And at least 1.3× better than fitting per-pose orientation estimates (2.7× measured).
    assert!(orientations > 1.3 * markers, "{orientations} vs {markers}");
}

#[test]
fn sequential_capture_costs_the_marker_level_fit_little_and_biases_the_per_station_fit() {
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap();
    let run = |sequential: bool| -> Vec<study::SessionResult> {
        let mut c = config(200);
        c.capture.sequential = sequential;
        c.capture.motion_deg = 0.2;
        // 20 sessions: the pooled RMS of one mode has a relative spread of ~4%, the ratio ~6%.
        (0..20).map(|s| study::run_session(&c, &model, 10_000 + s, 60)).collect()
    };
    let (together, one_by_one) = (run(false), run(true));
    let m = |r: &[study::SessionResult]| study::pooled(r.iter().map(|x| x.markers_deg));
    let o = |r: &[study::SessionResult]| study::pooled(r.iter().filter_map(|x| x.orientations_deg));
    eprintln!(
        "simultaneous {:.4}° / {:.4}°, sequential {:.4}° / {:.4}°",
        m(&together),
        o(&together),
        m(&one_by_one),
        o(&one_by_one)
    );
    // As many observations either way (a capture per visible marker).
    let count = |r: &[study::SessionResult]| r.iter().map(|x| x.observations).sum::<usize>() as f64;
    assert!((count(&one_by_one) / count(&together) - 1.0).abs() < 0.05);
    // Per-capture readings: within 15% of simultaneous capture.
    assert!(m(&one_by_one) < 1.15 * m(&together), "{} vs {}", m(&one_by_one), m(&together));
    // The per-station orientation fit blames the drift on the mechanism: clearly worse.
    assert!(o(&one_by_one) > 1.5 * o(&together), "{} vs {}", o(&one_by_one), o(&together));
}

#[test]
fn standard_errors_are_honest_and_misplaced_markers_are_recovered() {
    // Over 10 sessions, every free parameter (mechanism, camera, t_CB, markers) against the truth
    // in the fit's gauge, in units of its standard error.
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap();
    let (mut z, mut marker_z) = (z_scores::ZScores::default(), z_scores::ZScores::default());
    for seed in 0..10u64 {
        let mut c = config(200);
        c.seed = 30_000 + seed;
        let (session, _) = c.simulate(&model, &mut |_| {}).unwrap();
        // The depth-scale model named: 34 parameters a session (`auto` would choose rigid for most
        // of these perfect cameras, its own honesty checked by tests/camera_model.rs).
        let settings = CalibConfig {
            folds: 0,
            camera_model: spmcal::calib::CameraModelSetting::DepthScale,
            ..CalibConfig::default()
        };
        let calibration = spmcal::calib::calibrate(&session, &model, &settings, &mut |_| {}).unwrap();
        z.add_marker_fit(&calibration, &session);
        // The markers' coordinates alone (their z's correlated with each other, not the rest's).
        let p = &calibration.parameterisation;
        let truth = session.truth.as_ref().unwrap();
        let markers: Vec<Vector3<f64>> = truth.parameters.markers.iter().map(|m| m.position).collect();
        let gauge = spmcal::calib::TruthInGauge::for_markers(
            p,
            &truth.parameters.legs,
            &truth.parameters.camera.unwrap(),
            &truth.parameters.camera_model,
            &markers,
        );
        let indices: Vec<usize> =
            (0..p.len()).filter(|&i| matches!(p.entries[i].kind, spmcal::calib::Kind::Marker { .. })).collect();
        let errors: Vec<f64> = indices.iter().map(|&i| calibration.calibrated.x[i] - gauge.x[i]).collect();
        marker_z.add_session(&errors, &calibration.covariance, &indices);
        // The markers were misplaced by N(0, 3 mm): the fit moves them most of the way.
        let moved = markers.iter().zip(&model.markers).map(|(t, m)| (t - m.position).norm()).sum::<f64>();
        assert!(moved > 4e-3, "seed {seed}: the truth barely misplaces the markers");
    }
    eprintln!("all parameters: {}\nmarkers: {}", z.summary(), marker_z.summary());
    // Honest: each statistic within the band honest σ's keep with probability 99.9% (`z_scores`:
    // 340 z's, correlated within a session). The misplaced markers (120 coordinates, 3 mm off where
    // their σ is 0.03–0.16 mm: a fit that did not move them would leave z's of ~20–100) are recovered within
    // their own standard errors, by the same bands.
    assert_eq!((z.len(), marker_z.len()), (340, 120));
    z.assert_honest("marker-level fit, 10 sessions");
    marker_z.assert_honest("marker positions, 10 sessions");
}

#[test]
fn a_session_that_barely_moves_is_refused_naming_what_it_cannot_identify() {
    let (mut session, model) = simulated(30, 8, false);
    let still = session.poses[0].clone();
    for pose in session.poses.iter_mut() {
        let id = pose.id;
        *pose = still.clone();
        pose.id = id;
    }
    let err = spmcal::calib::calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap_err().to_string();
    assert!(err.contains("barely moves") && err.contains("cannot identify") && err.contains("leg"), "{err}");
}

#[test]
fn a_marker_seen_at_one_pose_is_reported_and_held() {
    let (mut session, model) = simulated(60, 9, false);
    let first = session.poses.iter().position(|p| p.markers[3].is_some()).unwrap();
    for pose in session.poses.iter_mut().skip(first + 1) {
        pose.markers[3] = None;
    }
    let calibration = spmcal::calib::calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap();
    let warnings = &calibration.report.warnings;
    assert!(warnings.iter().any(|w| w.contains("`m4` is seen at 1 pose")), "{warnings:?}");
    let report = calibration.report.markers.unwrap();
    let m4 = &report.markers[3];
    assert!(m4.std_error_mm.is_none() && m4.change_mm == [0.0; 3], "{m4:?}");
}

#[test]
fn gross_marker_errors_are_excluded_with_their_line() {
    let (mut session, model) = simulated(100, 11, false);
    // Three markers off by 3 cm (a swapped label or a reflection): 100× the noise.
    for k in [5, 40, 77] {
        if let Some(m) = session.poses[k].markers[0].as_mut() {
            *m += Vector3::new(0.03, 0.0, 0.0);
        }
        session.poses[k].marker_lines[0] = 1000 + k;
    }
    let calibration = spmcal::calib::calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap();
    let excluded: Vec<usize> = calibration.report.flagged.iter().filter(|f| f.excluded).map(|f| f.line).collect();
    let report = calibration.report.markers.as_ref().unwrap();
    for k in [5, 40, 77] {
        if session.poses[k].markers[0].is_some() {
            assert!(excluded.contains(&(1000 + k)), "line {} not excluded: {excluded:?}", 1000 + k);
        }
    }
    assert!(calibration.report.excluded.iter().any(|e| e.contains("gross error")));
    // Without them, the fit is as good as on clean data: residuals at the noise level.
    assert!(report.after.errors.rms < 1.0, "{}", report.after.errors.rms);
}

#[test]
fn a_calibration_not_clearly_better_than_nominal_says_so_or_is_refused() {
    // The true geometry is the nominal one and the markers sit where the model says: there is
    // nothing to calibrate, so the calibrated model cannot predict unseen poses clearly better.
    let mut c = config(60);
    c.truth.axis_tilt_deg = 0.0;
    c.truth.link_angle_deg = 0.0;
    c.truth.joint_offset_deg = 0.0;
    c.truth.marker_position_m = 0.0;
    c.seed = 14;
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap();
    let (session, _) = c.simulate(&model, &mut |_| {}).unwrap();
    let calibration = spmcal::calib::calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap();
    let report = &calibration.report;
    let cv = report.cross_validation.as_ref().unwrap();
    assert!(!cv.clearly_better, "{cv:?}");
    assert!(
        report.warnings.iter().any(|w| w.contains("not predict unseen poses clearly better")),
        "{:?}",
        report.warnings
    );
    let text = calibration.report.to_string();
    assert!(text.contains("verdict: WARN") && text.contains("not clearly better"), "{text}");
    let refuse = CalibConfig { if_not_better: spmcal::calib::IfNotBetter::Refuse, ..CalibConfig::default() };
    let err = spmcal::calib::calibrate(&session, &model, &refuse, &mut |_| {}).unwrap_err().to_string();
    assert!(err.contains("not written"), "{err}");
}
