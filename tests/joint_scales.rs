//! Joint scales (`φ = sθ + δ`, a transmission ratio's error): a simulated session with scale
//! errors gets them back within their standard errors and the mechanism as accurate as without
//! them; one without gets no worse for fitting them by default; one whose joints barely move
//! holds them and says so. The study over many sessions is `examples/joint_scales`.

use std::path::Path;

use spmcal::calib::{CalibConfig, Calibration, FitChoice, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[path = "../examples/marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;

/// The scale errors: +0.4 / −0.3 / +0.2 %.
const SCALES: [f64; 3] = [1.004, 0.997, 1.002];

fn simulated(poses: usize, seed: u64, scales: [f64; 3]) -> (Session, RobotModel) {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = poses;
    config.seed = seed;
    config.encoders.scales = scales;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    (session, model)
}

fn calibrated(session: &Session, model: &RobotModel, scales: FitChoice) -> Calibration {
    let config = CalibConfig { folds: 0, joint_scales: scales, ..CalibConfig::default() };
    calibrate(session, model, &config, &mut |_| {}).unwrap()
}

/// The calibrated mechanism's error against the truth on 100 unseen poses (degrees), up to the
/// rotations common to every pose (as the report's predicted error is defined).
fn held_out_error(session: &Session, calibration: &Calibration) -> f64 {
    let truth = session.truth.as_ref().unwrap().parameters.spm().unwrap();
    let tests = study::test_orientations(&truth, 100, 0x5eed);
    study::calibration_error_up_to_common_rotations(session, calibration, &tests)
}

#[test]
fn scale_errors_are_recovered_and_cost_the_mechanism_nothing_while_held_they_cost_it_much() {
    let (scaled, model) = simulated(200, 3501, SCALES);
    let (clean, _) = simulated(200, 3501, [1.0; 3]);
    // The truth file carries them (read back as the simulator wrote them).
    let truth = &scaled.truth.as_ref().unwrap().parameters;
    assert_eq!(truth.legs.map(|g| g.scale), SCALES);
    let fitted = calibrated(&scaled, &model, FitChoice::Auto);
    assert_eq!(fitted.report.joint_scales.len(), 3);
    for s in &fitted.report.joint_scales {
        // 200 poses determine a scale to ~550 ppm: errors of 0.4 and 0.3 % are 7σ and 5σ, and
        // `auto` then fits all three.
        assert!(s.held.is_none(), "{s:?}");
        let se = s.std_error_ppm.unwrap();
        let error_ppm = (s.scale - SCALES[s.leg - 1]) * 1e6;
        // Honest standard errors put |z| > 4 once in 16,000: a failure here is a biased or
        // overconfident scale, not bad luck. 200 poses determine a scale to ~550 ppm (the study's
        // figure), within the 1,000 ppm `auto` asks for.
        assert!(error_ppm.abs() < 4.0 * se && se < 1000.0, "leg {}: error {error_ppm:.0} ppm, σ {se:.0} ppm", s.leg);
    }
    // The calibrated parameters file carries the ones fitted.
    assert_eq!(fitted.parameters.to_yaml().matches("  scale: ").count(), 3);
    let with_scales = held_out_error(&scaled, &fitted);
    let without_error = held_out_error(&clean, &calibrated(&clean, &model, FitChoice::Hold));
    let held = held_out_error(&scaled, &calibrated(&scaled, &model, FitChoice::Hold));
    // Three more parameters determined to ~550 ppm add variance (the report's predicted error rises
    // 20–25 %; the study pools 20 sessions); one session has room for its spread. Held, the same
    // scale errors cost several times that (the study: 3.5× on 200 poses).
    assert!(with_scales < 1.5 * without_error, "{with_scales:.4}° with the error, {without_error:.4}° without");
    assert!(held > 2.0 * with_scales, "held {held:.4}° against {with_scales:.4}° fitted");
    // The text report, its HTML page's table and `--json` (the report serialised) each carry them.
    let text = fitted.report.to_string();
    assert!(text.contains("leg1.scale") && text.contains("ppm"), "{text}");
    let html = fitted.html(&text);
    assert!(html.contains("Joint scales (φ = s·θ + δ)") && html.contains("std error (ppm)"), "no joint-scale table");
    let found = |leg: usize| fitted.report.joint_scales.iter().any(|s| s.leg == leg && s.std_error_ppm.is_some());
    assert!((1..=3).all(found));
}

#[test]
fn a_session_without_scale_errors_is_not_hurt_by_fitting_them_by_default() {
    let (clean, model) = simulated(200, 3502, [1.0; 3]);
    let default = calibrated(&clean, &model, FitChoice::Auto);
    let held = calibrated(&clean, &model, FitChoice::Hold);
    assert!(held.report.joint_scales.iter().all(|s| s.held.as_deref().is_some_and(|h| h.starts_with("frozen"))));
    // Without a scale error `auto` holds the scales unless their fit differs from 1 by 3σ's worth
    // (0.3 % of sessions): held, the session is calibrated as with `hold`.
    for s in &default.report.joint_scales {
        let why = s.held.as_deref().expect("held");
        assert!(why.starts_with("not distinguishable") && why.contains("ppm"), "{why}");
        assert_eq!(s.scale, 1.0);
    }
    assert!(default.report.warnings.iter().all(|w| !w.contains("scale")), "{:?}", default.report.warnings);
    let (a, b) = (held_out_error(&clean, &default), held_out_error(&clean, &held));
    assert!(a < 1.03 * b, "default {a:.4}° against scales held {b:.4}°");
    // Nothing written for scales of 1 when held.
    assert!(!held.parameters.to_yaml().contains("  scale: "));
}

/// With a noisier camera (1 mm across, 3 mm along the line of sight) 200 poses determine a scale
/// to ~0.25 % only, worse than the ±0.1 % `auto` tries by itself. A joint 2 % long (8σ) shows in
/// its score at the fit without the scales, and `auto` fits it: the scale within 4σ of the truth,
/// the mechanism well below the held fit's error (the verdict study: held, a 2 % scale costs
/// 3.3×). The other two, without an error, show none (their score under 3σ but once in 370) and
/// stay held, as on the same session without the error.
#[test]
fn a_scale_determined_worse_than_auto_asks_is_fitted_where_its_error_shows() {
    let noisy = |scales: [f64; 3]| {
        let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
        (config.poses, config.seed, config.encoders.scales) = (200, 3504, scales);
        (config.camera.lateral_sigma_m, config.camera.depth_sigma_m) = (0.001, 0.003);
        let model = RobotModel::load(&config.model).unwrap();
        let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
        (session, model)
    };
    let (scaled, model) = noisy([1.02, 1.0, 1.0]);
    let fitted = calibrated(&scaled, &model, FitChoice::Auto);
    let leg1 = &fitted.report.joint_scales[0];
    let se = leg1.std_error_ppm.expect("leg 1's scale fitted");
    assert!(se > 1000.0, "σ {se:.0} ppm: the session must determine it worse than `auto`'s 0.1 %");
    let error_ppm = (leg1.scale - 1.02) * 1e6;
    assert!(error_ppm.abs() < 4.0 * se, "error {error_ppm:.0} ppm, σ {se:.0} ppm");
    let held = calibrated(&scaled, &model, FitChoice::Hold);
    let (a, b) = (held_out_error(&scaled, &fitted), held_out_error(&scaled, &held));
    assert!(2.0 * a < b, "auto {a:.4}° against held {b:.4}°");
    let (clean, _) = noisy([1.0; 3]);
    let clean_fit = calibrated(&clean, &model, FitChoice::Auto);
    assert!(clean_fit.report.joint_scales.iter().all(|s| s.held.is_some()), "{:?}", clean_fit.report.joint_scales);
}

#[test]
fn scales_a_session_cannot_tell_from_the_offsets_are_held_and_said() {
    // Poses within 4° of home: every joint's reading spans a few degrees only.
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = 60;
    config.seed = 3503;
    config.workspace.max_tilt_deg = 4.0;
    config.workspace.max_yaw_deg = 4.0;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let fitted = calibrated(&session, &model, FitChoice::Auto);
    let held: Vec<_> = fitted.report.joint_scales.iter().filter(|s| s.held.is_some()).collect();
    assert!(!held.is_empty(), "{:?}", fitted.report.joint_scales);
    for s in &held {
        assert_eq!(s.scale, 1.0);
        assert!(s.std_error_ppm.is_none());
    }
    for s in &held {
        assert!(s.held.as_deref().is_some_and(|h| h.starts_with("not determined") && h.contains("spans")), "{s:?}");
    }
    // One note for every scale held (a warning only when the model check finds a scale off).
    let notes: Vec<_> = fitted.report.notes.iter().filter(|w| w.contains("joint scale")).collect();
    assert_eq!(notes.len(), 1, "one note for every scale held: {notes:?}");
    assert!(notes[0].contains("span") && notes[0].contains("joint_scales: fit"), "{}", notes[0]);
    assert!(!fitted.report.warnings.iter().any(|w| w.contains("joint scale")), "{:?}", fitted.report.warnings);
}

#[test]
fn the_setting_is_read_from_the_config_and_a_wrong_one_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("calibrate.yaml");
    std::fs::write(&path, "folds: 0\njoint_scales: hold\n").unwrap();
    assert_eq!(CalibConfig::read(&path).unwrap().joint_scales, FitChoice::Hold);
    std::fs::write(&path, "folds: 0\njoint_scales: maybe\n").unwrap();
    let err = CalibConfig::read(&path).unwrap_err();
    assert_eq!(err.line, Some(2), "{err}");
    assert!(err.to_string().contains("maybe"), "{err}");
    std::fs::write(&path, "freeze: [joint_scales]\n").unwrap();
    assert!(CalibConfig::read(&path).unwrap().freeze.contains(&spmcal::calib::Group::JointScales));
}

/// With the scales fitted, the model check's joint-angle columns are the scales' own: nothing is
/// left of them to test. In a recording the model reads the joints along the encoder stream at the
/// fitted camera clock (40 ms before the capture's stamp here); a check that took the joints at the
/// stamp instead tested that 40 ms of motion, and on a ten-minute recording blamed a joint scale
/// (p = 1e-6) and widened the predicted error 295× (0.005° → 1.4°) on clean data.
#[test]
fn fitted_scales_leave_the_model_check_no_joint_columns_in_a_recording() {
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_free_motion_120s"), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let config = CalibConfig { folds: 5, joint_scales: FitChoice::Fit, ..CalibConfig::default() };
    let calibration = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
    assert!(calibration.report.joint_scales.iter().all(|s| s.held.is_none()), "all three scales fitted");
    let check = calibration.report.model_check.as_ref().expect("a recording of markers is checked");
    let structures: Vec<&str> = check.tests.iter().map(|t| t.structure).collect();
    assert!(!structures.contains(&"joint angles"), "tests: {structures:?}");
    assert!(check.passed, "{check:?}");
    assert!(check.widening.is_none(), "{check:?}");
}
