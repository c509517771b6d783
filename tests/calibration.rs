//! Calibration against simulated ground truth: accuracy against the true orientations, honest
//! uncertainties, robustness, and the settings. The model's analytic Jacobians, the gauge and the
//! noise floor are unit tests inside the crate (`calib::tests`): the residual model
//! (`calib::Model`) is the crate's own.

use std::path::Path;

use nalgebra::DVector;

use spmcal::calib::{
    CalibConfig, Calibration, Convergence, FitLevel, Fitted, Group, Observation, TruthInGauge, Unidentifiable,
    calibrate,
};
use spmcal::dataset::Session;
use spmcal::math::so3;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

fn load(dir: &str) -> (Session, RobotModel) {
    let (session, _) = Session::load(Path::new(dir), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    (session, model)
}

/// This file tests the orientation-level fit (`fit: orientations`); tests/markers.rs the marker-level one.
fn orientation_config() -> CalibConfig {
    CalibConfig { fit: spmcal::calib::FitLevel::Orientations, ..CalibConfig::default() }
}

fn simulated(poses: usize, seed: u64) -> (Session, RobotModel) {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = poses;
    config.seed = seed;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    (session, model)
}

/// The truth of a simulated session in the gauge of a calibration.
fn truth(session: &Session, calibration: &Calibration) -> TruthInGauge {
    let t = session.truth.as_ref().unwrap();
    let r0 = t.orientations[&session.reference_pose];
    TruthInGauge::new(&calibration.parameterisation, &t.parameters.legs, &t.parameters.camera.unwrap().rotation, &r0)
}

/// RMS angle (degrees), over `poses`, between the motion from the reference pose that the model
/// predicts from the joints, as the camera sees it, `R_CB R_j R_0ᵀ R_CBᵀ`, and the true one. Both
/// gauge freedoms cancel in it, and no vision measurement enters: it is the model's own error.
fn error_against_truth(session: &Session, calibration: &Calibration, x: &DVector<f64>, poses: &[Observation]) -> f64 {
    let t = session.truth.as_ref().unwrap();
    let p = &calibration.parameterisation;
    let spm = spmcal::model::Spm::new(p.legs(x)).unwrap();
    let reference = session.reference();
    let r0 = spm.forward(&reference.joints).unwrap();
    let (camera, camera_true) = (p.camera(x), t.parameters.camera.unwrap().rotation);
    let r0_true = t.orientations[&reference.id];
    let sum: f64 = poses
        .iter()
        .map(|o| {
            let predicted = camera * spm.forward(&o.joints).unwrap() * r0.inverse() * camera.inverse();
            let truth = camera_true * t.orientations[&o.pose] * r0_true.inverse() * camera_true.inverse();
            so3::geodesic_angle(&predicted, &truth).powi(2)
        })
        .sum();
    (sum / poses.len() as f64).sqrt().to_degrees()
}

/// The poses an orientation-level calibration fitted, and those it held out.
fn poses(calibration: &Calibration) -> (&[Observation], &[Observation]) {
    match &calibration.fitted {
        Fitted::Orientations { fitted, held_out, .. } => (fitted, held_out),
        _ => panic!("an orientation-level calibration"),
    }
}

#[test]
fn sim_400_calibration_beats_nominal_fivefold() {
    let (session, model) = load("datasets/agile_wrist_sim_400");
    let calibration = calibrate(&session, &model, &orientation_config(), &mut |_| {}).unwrap();
    // Against the true orientations, on poses held out of the fit.
    let nominal = error_against_truth(&session, &calibration, &calibration.nominal.x, poses(&calibration).1);
    let calibrated = error_against_truth(&session, &calibration, &calibration.calibrated.x, poses(&calibration).1);
    eprintln!(
        "held-out error against truth: nominal {nominal:.4}°, calibrated {calibrated:.4}° ({:.1}×)",
        nominal / calibrated
    );
    assert!(nominal >= 5.0 * calibrated, "nominal {nominal:.4}° vs calibrated {calibrated:.4}°");
    // Every fourth pose held out (`holdout_every: 4`). The held-out error against the camera
    // within 10% of what the true parameters achieve is a unit test inside the crate (it fits the
    // true mechanism's registration alone, which the public API does not offer):
    // `calib::tests::the_orientation_level_fit_reaches_the_noise_floor_on_held_out_poses`.
    assert_eq!(calibration.report.held_out_poses, 100);
}

#[test]
fn recovered_parameters_lie_within_three_standard_errors_of_the_truth() {
    let mut z = z_scores::ZScores::default();
    for seed in 0..20 {
        let (session, model) = simulated(300, 1000 + seed);
        let calibration = calibrate(&session, &model, &orientation_config(), &mut |_| {}).unwrap();
        let truth = truth(&session, &calibration);
        // The reference rotation is a property of the session's reference markers, not of the device.
        // So are joint scales `auto` held (no error to show: no standard error).
        let indices: Vec<usize> = (0..calibration.parameterisation.len())
            .filter(|&i| !matches!(calibration.parameterisation.entries[i].kind.group(), Group::ReferenceRotation))
            .filter(|&i| calibration.covariance[(i, i)] > 0.0)
            .collect();
        let errors: Vec<f64> = indices.iter().map(|&i| calibration.calibrated.x[i] - truth.x[i]).collect();
        z.add_session(&errors, &calibration.covariance, &indices);
    }
    eprintln!("{}", z.summary());
    // Honest on both sides: each statistic within the band honest σ's keep with probability 99.9%
    // (`z_scores`: 360 z's, correlated within a session; 20 sessions, as 10 leave σ's 1.5×
    // too large on the band's edge).
    // 18 per session, more for a session whose scales `auto` fitted (0.3 % of sessions, or a scale
    // the orientation-level fit determines to 0.1 % beside one it does not).
    assert!(z.len() >= 360, "{}", z.len());
    z.assert_honest("orientation-level fit, 20 sessions");
}

/// Standardised errors of the fits' parameters against the truth, checked for honest σ's.
#[path = "common/z_scores.rs"]
#[allow(dead_code)] // shared by the tests, each using part of it
mod z_scores;

#[test]
fn twenty_poses_converge_and_say_what_they_cannot_pin_down() {
    let (session, model) = load("datasets/agile_wrist_sim_20");
    let small = calibrate(&session, &model, &orientation_config(), &mut |_| {}).unwrap();
    let (session, model) = load("datasets/agile_wrist_sim_400");
    let large = calibrate(&session, &model, &orientation_config(), &mut |_| {}).unwrap();
    let r = &small.report;
    assert_eq!((r.fit_poses, r.held_out_poses), (15, 5));
    // Converged (the Newton decrement below 1e-3 standard errors), not merely stopped.
    assert_eq!(r.convergence, Convergence::Converged, "{:?}", r.iterations.last());
    assert_eq!(large.report.convergence, Convergence::Converged, "{:?}", large.report.iterations.last());
    // Fewer poses: a worse-conditioned problem and honestly larger standard errors.
    assert!(r.identifiability.condition > large.report.identifiability.condition);
    assert_eq!(r.identifiability.weakest.len(), 3);
    // (The platform's sag, which `platform_sag: auto` holds on both clean sessions, has none.)
    for (a, b) in r.parameters.iter().zip(&large.report.parameters).filter(|(a, _)| a.name != "platform.sag") {
        assert!(a.std_error_deg.unwrap() > b.std_error_deg.unwrap(), "{}", a.name);
    }
    // 20 poses cannot separate most parameters from nominal, and the report says which.
    assert!(
        r.not_significant.len() > large.report.not_significant.len() && r.not_significant.len() >= 10,
        "{:?}",
        r.not_significant
    );
    let u_small = r.predicted_error_deg.as_ref().unwrap().rms;
    let u_large = large.report.predicted_error_deg.as_ref().unwrap().rms;
    assert!(u_small > 2.0 * u_large, "{u_small} vs {u_large}");
}

#[test]
fn outliers_are_flagged_and_down_weighted() {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = 200;
    config.camera.outlier_probability = 0.03;
    config.camera.outlier_sigma_m = 0.01;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, summary) = config.simulate(&model, &mut |_| {}).unwrap();
    assert!(summary.outliers > 0);
    let calibration = calibrate(&session, &model, &orientation_config(), &mut |_| {}).unwrap();
    let flagged = &calibration.report.flagged;
    assert!(!flagged.is_empty());
    assert!(flagged.iter().all(|o| o.weight < 1.0), "{flagged:?}");
    // The robust fit still reaches a calibrated model far better than nominal against the truth.
    let nominal = error_against_truth(&session, &calibration, &calibration.nominal.x, poses(&calibration).1);
    let calibrated = error_against_truth(&session, &calibration, &calibration.calibrated.x, poses(&calibration).1);
    // Outliers do not bias it: its error against the truth, measured as `compare` measures it (up
    // to the rotations common to every pose) at the held-out poses, is the error the fit predicts
    // for itself (within 2×: the achieved RMS is one draw of a weighted χ² of ~10 effective
    // degrees of freedom, whose 90% range is 0.63–1.35× the prediction), and far below the
    // nominal model's (the truth's spread).
    let predicted = calibration.report.predicted_error_deg.as_ref().unwrap().rms;
    let spm = calibration.parameters.spm().unwrap();
    let t = session.truth.as_ref().unwrap();
    let held_out = poses(&calibration).1;
    let fitted: Vec<_> = held_out.iter().map(|o| spm.forward(&o.joints).unwrap()).collect();
    let truth: Vec<_> = held_out.iter().map(|o| t.orientations[&o.pose]).collect();
    let achieved = study::up_to_common_rotations(&fitted, &truth);
    eprintln!(
        "nominal {nominal:.4}°, calibrated {calibrated:.4}°, predicted {predicted:.4}°, achieved up to the common rotations {achieved:.4}°"
    );
    assert!(
        achieved < 2.0 * predicted && achieved > 0.5 * predicted,
        "achieved {achieved:.4}° vs predicted {predicted:.4}°"
    );
    assert!(nominal > 3.0 * calibrated, "nominal {nominal:.4}° vs calibrated {calibrated:.4}°");
}

#[allow(dead_code)]
#[path = "../examples/predicted_accuracy/accuracy.rs"]
mod accuracy;
/// The study of `examples/predicted_accuracy` (its measure of the achieved error).
#[allow(dead_code)]
#[path = "../examples/marker_efficiency/study.rs"]
mod study;

#[test]
fn frozen_groups_do_not_move_and_refusal_names_the_directions() {
    let (session, model) = load("datasets/agile_wrist_sim_20");
    let mut config = CalibConfig { freeze: vec![Group::JointOffsets, Group::PlatformAxes], ..Default::default() };
    let calibration = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
    for p in &calibration.report.parameters {
        // The platform's sag is held too: `platform_sag: auto` finds none in this session.
        let frozen = p.name.ends_with(".delta") || p.name.contains(".v0_tilt") || p.name == "platform.sag";
        assert_eq!(p.frozen, frozen, "{}", p.name);
        if frozen {
            assert_eq!((p.change_deg, p.std_error_deg), (0.0, None), "{}", p.name);
        }
    }
    // An absurd threshold makes weak directions "unidentifiable": refuse names them...
    config.freeze.clear();
    config.min_singular_ratio = 0.2;
    config.unidentifiable = Unidentifiable::Refuse;
    let err = calibrate(&session, &model, &config, &mut |_| {}).unwrap_err().to_string();
    assert!(err.contains("cannot identify") && err.contains("leg"), "{err}");
    // ...and regularise holds them, and says so.
    config.unidentifiable = Unidentifiable::Regularise;
    let held = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
    assert!(!held.report.regularised.is_empty());
}

#[test]
fn config_errors_name_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("calibrate.yaml");
    let good = std::fs::read_to_string("configs/calibrate.yaml").unwrap();
    assert_eq!(CalibConfig::read(Path::new("configs/calibrate.yaml")).unwrap(), CalibConfig::default());
    std::fs::write(&path, good.replace("holdout_every: 4", "hold_out_every: 4")).unwrap();
    let err = CalibConfig::read(&path).unwrap_err().to_string();
    assert!(err.contains("calibrate.yaml:") && err.contains("hold_out_every"), "{err}");
    std::fs::write(&path, good.replace("huber_threshold: 3.0", "huber_threshold: -1")).unwrap();
    let err = CalibConfig::read(&path).unwrap_err().to_string();
    let line = good.lines().position(|l| l.starts_with("huber_threshold:")).unwrap() + 1;
    assert!(err.contains(&format!("calibrate.yaml:{line}")) && err.contains("huber_threshold"), "{err}");
    std::fs::write(&path, good.replace("freeze: []", "freeze: [offsets]")).unwrap();
    assert!(CalibConfig::read(&path).unwrap_err().to_string().contains("unknown variant `offsets`"));
    // A workspace: read as written; a tilt of 90° or more (no workspace of an SPM) refused at its key.
    let named = good.replace("workspace: null", "workspace: {max_tilt_deg: 25, max_yaw_deg: 40}");
    std::fs::write(&path, &named).unwrap();
    let w = CalibConfig::read(&path).unwrap().workspace.unwrap();
    assert_eq!((w.max_tilt_deg, w.max_yaw_deg), (25.0, 40.0));
    std::fs::write(&path, good.replace("workspace: null", "workspace: {max_tilt_deg: 95, max_yaw_deg: 40}")).unwrap();
    let err = CalibConfig::read(&path).unwrap_err().to_string();
    let line = good.lines().position(|l| l.starts_with("workspace:")).unwrap() + 1;
    assert!(err.contains(&format!("calibrate.yaml:{line}")) && err.contains("max_tilt_deg"), "{err}");
}

#[test]
fn an_error_in_the_reference_pose_does_not_bias_the_mechanism() {
    let (session, model) = load("datasets/agile_wrist_sim_400");
    let base = calibrate(&session, &model, &orientation_config(), &mut |_| {}).unwrap();
    // Rotate the reference pose's markers by 0.5° about their centroid: a reference measurement
    // error 2.5× the per-pose noise, entering every measured rotation Q_j alike.
    let mut shifted = session.clone();
    let k = shifted.poses.iter().position(|p| p.id == shifted.reference_pose).unwrap();
    let seen: Vec<_> = shifted.poses[k].markers.iter().flatten().copied().collect();
    let centroid = seen.iter().sum::<nalgebra::Vector3<f64>>() / seen.len() as f64;
    let e = so3::exp(&(nalgebra::Vector3::new(0.6, -0.3, 0.74).normalize() * 0.5f64.to_radians()));
    for m in shifted.poses[k].markers.iter_mut().flatten() {
        *m = centroid + e * (*m - centroid);
    }
    let moved = calibrate(&shifted, &model, &orientation_config(), &mut |_| {}).unwrap();
    let mut worst: f64 = 0.0;
    for (i, entry) in base.parameterisation.entries.iter().enumerate() {
        if entry.kind.leg().is_some() {
            let se = base.covariance[(i, i)].sqrt();
            worst = worst.max(((moved.calibrated.x[i] - base.calibrated.x[i]) / se).abs());
        }
    }
    // The free reference rotation A takes the error; only pose 0's own residual sees it, as one
    // noisy pose among 300. One pose at 2.5σ with leverage ≈ 21/300 can move a parameter by at most
    // ≈ 2.5·√0.07 ≈ 0.66 standard errors (less once Huber down-weights it; 0.31 measured on the
    // shipped data), whereas the same error carried into every Q_j would shift the parameters by
    // E/SE ≈ 1–8 standard errors (E = 0.5°, SE = 0.07–0.42°): the bound separates the two.
    eprintln!("largest mechanism change: {worst:.3} standard errors");
    assert!(worst < 0.66, "{worst}");
}

#[test]
fn too_few_usable_poses_are_an_error_not_a_panic() {
    let (mut session, model) = load("datasets/agile_wrist_sim_20");
    // The camera lost every pose after the fifth.
    for pose in session.poses.iter_mut().skip(5) {
        pose.markers.iter_mut().for_each(|m| *m = None);
    }
    let err = calibrate(&session, &model, &orientation_config(), &mut |_| {}).unwrap_err().to_string();
    assert!(err.contains("usable poses") && err.contains("21 parameters"), "{err}");
    session.poses.truncate(2);
    let sets = [("nominal".to_string(), spmcal::model::Parameters::nominal(&model.spm, None))];
    let err = spmcal::compare::compare(&session, &model, &sets, spmcal::vision::Method::Kabsch, None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("only 2 poses"), "{err}");
    // Two poses of four markers still register at the marker level; no marker at all does not.
    let markers = Some(spmcal::calib::FitLevel::Markers);
    let compared = spmcal::compare::compare(&session, &model, &sets, spmcal::vision::Method::Kabsch, markers).unwrap();
    assert_eq!((compared[0].per_pose.len(), compared[0].unit), (2, "mm"));
    session.poses.iter_mut().for_each(|p| p.markers.iter_mut().for_each(|m| *m = None));
    let err = spmcal::compare::compare(&session, &model, &sets, spmcal::vision::Method::Kabsch, markers)
        .unwrap_err()
        .to_string();
    assert!(err.contains("only 0 marker observations"), "{err}");
    assert!(spmcal::record::Scene::replay(&session, &model, None).is_err());
}

/// Small sessions (the paper's 20 poses) under many draws of truth and noise, including the noisy
/// stereo (σ 1 mm across, 3 mm along the line of sight) and sequential capture of an independent
/// simulator: the fit must always end with a result, converged or stalled at a minimum — never a
/// "did not converge" at its optimum — and the result must fit better than the nominal model.
#[test]
fn small_sessions_always_end_at_a_minimum() {
    let base = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    let model = RobotModel::load(&base.model).unwrap();
    let mut stalled = 0;
    for seed in 0..24u64 {
        let mut config = base.clone();
        config.poses = 20;
        config.seed = 1000 + seed;
        if seed % 2 == 1 {
            config.camera.lateral_sigma_m = 1e-3;
            config.camera.depth_sigma_m = 3e-3;
        }
        // Sequential capture (a pose per marker) only the marker-level fit can use.
        config.capture.sequential = seed % 3 == 0;
        let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
        let fit = if config.capture.sequential { FitLevel::Markers } else { FitLevel::Orientations };
        let settings = CalibConfig { fit, folds: 0, ..CalibConfig::default() };
        let calibration =
            calibrate(&session, &model, &settings, &mut |_| {}).unwrap_or_else(|e| panic!("seed {}: {e}", config.seed));
        let report = &calibration.report;
        match &report.markers {
            Some(m) => assert!(m.after.errors.rms <= m.before.errors.rms, "seed {}", config.seed),
            None => assert!(report.after.fit.rms <= report.before.fit.rms, "seed {}", config.seed),
        }
        stalled += usize::from(report.convergence == Convergence::StalledAtMinimum);
    }
    // Most fits meet the convergence test outright; stalls are the exception the rule is there
    // for. Over 2,400 sessions of this scheme (seeds 1000–3399) none stalled: the stall rate is
    // below 0.29% with 99.9% confidence, and 24 fits at that rate stall more than twice with
    // probability < 0.1% (binomial). (One of the 2,400, seed 2057, ended instead at
    // `max_iterations` with its cost still falling by 6e-10 per iteration: outside these 24.)
    assert!(stalled <= 2, "{stalled} of 24 fits stalled");
}
