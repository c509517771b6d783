//! Tests of the pipeline's internals that the public API does not reach: the noise floor of the
//! orientation-level fit, both models' analytic Jacobians against finite differences, the
//! directions the gauge fixes, and the one-step cross-validation against refitting.

use std::path::Path;

use nalgebra::{DMatrix, DVector, Rotation3, Vector3};

use super::calibration::{Calibration, Fitted};
use super::config::{CalibConfig, FitLevel, Group, Loss};
use super::fit::{FitSettings, fit};
use super::identify::Identifiability;
use super::marker_residuals::{MarkerObservation, MarkerResiduals};
use super::orientation_residuals::{Observation, OrientationResiduals};
use super::parameterisation::{Kind, Parameterisation};
use super::pipeline::calibrate;
use super::residuals::{EvalError, Evaluation, Residuals};
use crate::dataset::Session;
use crate::math::so3;
use crate::model::{CameraModel, CameraRegistration, LegGeometry, RobotModel};
use crate::sim::SimConfig;

/// On held-out poses, the calibrated model's FDA agrees with vision within 10% of what the true
/// parameters achieve with their own best-fit registration (fitted on the same poses, the same
/// loss): the calibration reaches the noise floor.
#[test]
fn the_orientation_level_fit_reaches_the_noise_floor_on_held_out_poses() {
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_sim_400"), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let config = CalibConfig { fit: FitLevel::Orientations, ..CalibConfig::default() };
    let calibration = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
    let Fitted::Orientations { fitted, held_out, .. } = &calibration.fitted else { panic!("orientation level") };
    let truth = session.truth.as_ref().unwrap();
    let (p0, x0) = (&calibration.parameterisation, &calibration.calibrated.x);
    let p = Parameterisation::new(truth.parameters.legs, p0.camera(x0), p0.reference(x0), &config.bounds);
    let free: Vec<bool> =
        p.entries.iter().map(|e| matches!(e.kind.group(), Group::CameraRotation | Group::ReferenceRotation)).collect();
    let settings =
        FitSettings { loss: Loss::Huber, step_tolerance: 1e-10, ..FitSettings::from_config(&config, free.clone()) };
    let model_true = OrientationResiduals::new(&p, fitted).with_columns(free);
    let registered = fit(&model_true, &DVector::zeros(p.len()), &settings, &mut |_| {}).unwrap();
    let held = OrientationResiduals::new(&p, held_out).evaluate(&registered.x, None, false).unwrap();
    let floor = super::residuals::rms(&held.residuals).to_degrees();
    let achieved = calibration.report.after.held_out.unwrap().rms;
    eprintln!("held-out FDA vs vision: calibrated {achieved:.4}°, true parameters {floor:.4}°");
    assert!(achieved <= 1.10 * floor, "calibrated {achieved:.4}° vs floor {floor:.4}°");
    assert_eq!(calibration.report.held_out_poses, 100);
}

// The orientation-level model (`fit: orientations`).

fn load(dir: &str) -> (Session, RobotModel) {
    let (session, _) = Session::load(Path::new(dir), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    (session, model)
}

fn orientation_config() -> CalibConfig {
    CalibConfig { fit: FitLevel::Orientations, ..CalibConfig::default() }
}

/// The poses an orientation-level calibration fitted.
fn fitted_poses(calibration: &Calibration) -> &[Observation] {
    match &calibration.fitted {
        Fitted::Orientations { fitted, .. } => fitted,
        _ => panic!("an orientation-level calibration"),
    }
}

/// The orientation-level residuals of `observations` at `x`.
fn evaluate(
    p: &Parameterisation,
    x: &DVector<f64>,
    observations: &[Observation],
    warm: Option<&[Rotation3<f64>]>,
    jacobian: bool,
) -> Result<Evaluation, EvalError> {
    OrientationResiduals::new(p, observations).evaluate(x, warm, jacobian)
}

#[test]
fn analytic_jacobian_matches_finite_differences() {
    let (session, model) = load("datasets/agile_wrist_sim_20");
    let calibration = calibrate(&session, &model, &orientation_config(), &mut |_| {}).unwrap();
    let p = &calibration.parameterisation;
    // Away from the optimum, with every parameter non-zero, so that no term hides.
    let x = calibration.calibrated.x.map(|v| v * 1.5 + 0.003);
    let obs = fitted_poses(&calibration);
    let at = evaluate(p, &x, obs, None, true).unwrap();
    let jac = at.jacobian.unwrap();
    let h = 1e-6;
    for i in 0..p.len() {
        let (mut plus, mut minus) = (x.clone(), x.clone());
        plus[i] += h;
        minus[i] -= h;
        let rp = evaluate(p, &plus, obs, Some(&at.orientations), false).unwrap().residuals;
        let rm = evaluate(p, &minus, obs, Some(&at.orientations), false).unwrap().residuals;
        for j in 0..obs.len() {
            let numeric = (rp[j] - rm[j]) / (2.0 * h);
            let analytic = jac.fixed_view::<3, 1>(3 * j, i);
            // Central differences: O(h²) ≈ 1e-12 truncation, ~1e-10 rounding (1e-16 / h).
            assert!(
                (numeric - analytic).amax() < 1e-8,
                "{} pose {}: {numeric:?} vs {analytic:?}",
                p.entries[i].name,
                obs[j].pose
            );
        }
    }
}

#[test]
fn the_gauge_leaves_no_null_direction_and_its_six_directions_are_null() {
    let (session, model) = load("datasets/agile_wrist_sim_400");
    // The joint scales and the platform's sag fitted whatever the data say, so that their
    // identifiability is tested too.
    let config = CalibConfig {
        joint_scales: super::FitChoice::Fit,
        platform_sag: super::FitChoice::Fit,
        ..orientation_config()
    };
    let calibration = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
    let id = &calibration.report.identifiability;
    assert_eq!((id.rank, id.parameters), (25, 25), "{id:?}");
    assert!(calibration.report.regularised.is_empty());
    // Add the six gauge directions as extra columns: tilts of u_1 (2), of u_2 out of its plane (1),
    // of v0_1 (2), of v0_2 out of its plane (1). They must be null: numerically differentiate the
    // residuals along each and check the augmented Jacobian has exactly six zero singular values.
    let p = &calibration.parameterisation;
    let x = &without_sag(p, &calibration.calibrated.x);
    let obs = fitted_poses(&calibration);
    let base = evaluate(p, x, obs, None, true).unwrap();
    let augmented = augmented_with_gauge(base.jacobian.as_ref().unwrap(), &p.legs(x), |legs| {
        let q = Parameterisation::new(legs, p.camera(x), p.reference(x), &orientation_config().bounds);
        evaluate(&q, &DVector::zeros(q.len()), obs, Some(&base.orientations), false).unwrap().residuals
    });
    let names: Vec<String> = (0..augmented.ncols()).map(|i| format!("c{i}")).collect();
    let all: Vec<usize> = (0..augmented.ncols()).collect();
    let analysis = Identifiability::analyse(&augmented, &all, &names, 1e-5);
    assert_eq!(analysis.rank, 25, "the 6 gauge directions must add nothing: {:?}", analysis.weakest);
    assert_eq!(analysis.unidentifiable.len(), 6);
}

// The marker-level model (the default fit).

fn simulated(poses: usize, seed: u64, sequential: bool) -> (Session, RobotModel) {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = poses;
    config.seed = seed;
    config.capture.sequential = sequential;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    (session, model)
}

/// The true registration and the model's markers: a parameterisation near the truth.
fn parameterisation(session: &Session, model: &RobotModel) -> Parameterisation {
    parameterisation_with(session, model, CameraModel::rigid())
}

/// The same with the camera model `camera` (its terms parameters, started at its values).
fn parameterisation_with(session: &Session, model: &RobotModel, camera: CameraModel) -> Parameterisation {
    let truth = session.truth.as_ref().unwrap();
    let markers: Vec<Vector3<f64>> = model.markers.iter().map(|m| m.position).collect();
    Parameterisation::for_markers(
        *model.spm.geometry(),
        &truth.parameters.camera.unwrap(),
        &markers,
        &session.markers,
        camera,
        &CalibConfig::default().bounds,
    )
}

#[test]
fn the_analytic_jacobian_matches_central_differences() {
    for sequential in [false, true] {
        let (session, model) = simulated(15, 3, sequential);
        check_jacobian(&session, &model, &parameterisation(&session, &model), &format!("sequential {sequential}"));
    }
}

#[test]
fn the_analytic_jacobian_of_a_projective_camera_matches_central_differences() {
    // Every term of `K` and of `c` away from a perfect camera's, so that each column mixes them.
    use crate::model::{CameraModelKind, CameraTerm};
    let (session, model) = simulated(15, 3, false);
    let start = [1.01, 0.99, 0.004, 0.01, -0.006, 0.02, -0.015, 0.04];
    let camera = CameraTerm::ALL
        .iter()
        .zip(start)
        .fold(CameraModel::perfect(CameraModelKind::Projective), |m, (t, v)| m.with(*t, v, None));
    let p = parameterisation_with(&session, &model, camera);
    assert_eq!(
        p.entries.iter().filter(|e| matches!(e.kind, crate::calib::parameterisation::Kind::CameraTerm { .. })).count(),
        8
    );
    check_jacobian(&session, &model, &p, "projective camera");
}

/// The marker-level Jacobian of `p` at a point away from zero against central differences.
fn check_jacobian(session: &Session, model: &RobotModel, p: &Parameterisation, label: &str) {
    check_jacobian_within(session, model, p, label, 1e-8);
}

/// [`check_jacobian`] within `tolerance` (absolute, per component).
fn check_jacobian_within(session: &Session, model: &RobotModel, p: &Parameterisation, label: &str, tolerance: f64) {
    let (observations, failed) = MarkerObservation::of_session(session, &model.spm);
    assert!(failed.is_empty());
    let m = MarkerResiduals::new(p, &observations);
    // Away from zero, so that every term (left Jacobians, moved axes) is exercised.
    let x = DVector::from_fn(p.len(), |i, _| 2e-3 * ((i * 7 + 3) as f64).sin());
    let at = m.evaluate(&x, None, true).unwrap();
    let jac = at.jacobian.as_ref().unwrap();
    let h = 1e-6;
    for i in 0..p.len() {
        let mut plus = x.clone();
        plus[i] += h;
        let mut minus = x.clone();
        minus[i] -= h;
        let rp = m.evaluate(&plus, Some(&at.orientations), false).unwrap().residuals;
        let rm = m.evaluate(&minus, Some(&at.orientations), false).unwrap().residuals;
        for j in 0..observations.len() {
            let numeric = (rp[j] - rm[j]) / (2.0 * h);
            let analytic: Vector3<f64> = jac.fixed_view::<3, 1>(3 * j, i).into();
            // Central differences are exact to O(h²) ≈ 1e-12 relative, plus rounding
            // (1e-16 / 1e-6 on residuals of ~1 m): 1e-8 absolute is far above both.
            assert!(
                (numeric - analytic).amax() < tolerance,
                "{label}, {}: numeric {numeric:?}, analytic {analytic:?}",
                p.entries[i].name
            );
        }
    }
}

/// Singular values of `J`, smallest first.
fn spectrum(jac: &DMatrix<f64>) -> Vec<f64> {
    let mut s: Vec<f64> = jac.clone().svd(false, false).singular_values.iter().copied().collect();
    s.sort_by(f64::total_cmp);
    s
}

#[test]
fn marker_data_identify_every_parameter_of_the_gauge_fixed_parameterisation() {
    let (session, model) = simulated(60, 5, false);
    let p = parameterisation(&session, &model);
    let (observations, _) = MarkerObservation::of_session(&session, &model.spm);
    let m = MarkerResiduals::new(&p, &observations);
    let jac = m.evaluate(&DVector::zeros(p.len()), None, true).unwrap().jacobian.unwrap();
    // Scale columns (angles vs metres) before judging the spectrum.
    let scaled = DMatrix::from_fn(jac.nrows(), jac.ncols(), |r, c| jac[(r, c)] / jac.column(c).norm());
    let s = spectrum(&scaled);
    assert!(s[0] > 1e-4 * s[s.len() - 1], "a free direction: smallest {:e}, largest {:e}", s[0], s[s.len() - 1]);
}

#[test]
fn cross_validation_by_one_newton_step_matches_refitting_each_fold() {
    let (session, model) = simulated(120, 12, false);
    let config = CalibConfig::default();
    let calibration = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
    let cv = calibration.report.cross_validation.clone().unwrap();
    assert_eq!(cv.unpredicted, 0);
    let Fitted::Markers(observations) = &calibration.fitted else { panic!("a marker-level calibration") };
    // Folds: poses dealt out in order of appearance (no stations here).
    let mut poses: Vec<u64> = observations.iter().map(|o| o.pose).collect();
    poses.dedup();
    let fold_of = |pose: u64| poses.iter().position(|p| *p == pose).unwrap() % config.folds;
    let (mut nominal_sq, mut calibrated_sq) = (0.0, 0.0);
    for f in 0..config.folds {
        // The whole calibration again, on the session without the fold's poses; the fold's
        // observations predicted by its nominal and calibrated models.
        let mut train = session.clone();
        train.poses.retain(|p| !poses.contains(&p.id) || fold_of(p.id) != f);
        train.reference_pose = train.poses[0].id;
        let refit = calibrate(&train, &model, &config, &mut |_| {}).unwrap();
        let test: Vec<_> = observations.iter().filter(|o| fold_of(o.pose) == f).copied().collect();
        let test_model = MarkerResiduals::new(&refit.parameterisation, &test);
        for (x, sum) in [(&refit.nominal.x, &mut nominal_sq), (&refit.calibrated.x, &mut calibrated_sq)] {
            let eval = test_model.evaluate(x, None, false).unwrap();
            *sum += eval.residuals.iter().map(|r| r.norm_squared() * 1e6).sum::<f64>();
        }
    }
    let n = observations.len() as f64;
    let (nominal, calibrated) = ((nominal_sq / n).sqrt(), (calibrated_sq / n).sqrt());
    eprintln!("refit {nominal:.5} / {calibrated:.5} mm, one step {:.5} / {:.5} mm", cv.nominal_rms, cv.calibrated_rms);
    // The one-step estimate is second-order exact; the refits re-estimate the noise model per
    // fold, which the one step keeps. Deterministic (a fixed session): 1.6e-4 (calibrated) and
    // 5e-5 (nominal) of the held-out error measured; required within 5e-4, a 3× margin.
    assert!((cv.calibrated_rms / calibrated - 1.0).abs() < 5e-4, "{} vs {calibrated}", cv.calibrated_rms);
    assert!((cv.nominal_rms / nominal - 1.0).abs() < 5e-4, "{} vs {nominal}", cv.nominal_rms);
}

#[test]
fn marker_data_leave_free_only_the_two_rotation_gauges() {
    // Add the six directions the parameterisation fixes — tilts of u_1 (2), of u_2 out of its
    // plane (1), of v0_1 (2), of v0_2 out of its plane (1) — as extra Jacobian columns. They lie
    // in the span of the others (a rotation of B carried by R_CB, of P carried by the markers and
    // the v0's): the augmented rank stays that of the gauge-fixed set, and exactly six directions
    // are null. Everything else — t_CB and every marker included — is identified.
    let (session, model) = simulated(200, 13, false);
    assert_only_the_gauges_are_free(&session, &model);
}

#[test]
fn a_coaxial_spm_leaves_free_only_its_own_gauges() {
    // Orbita3d: one line carries the three actuated axes, so a turn of B about it moves every
    // zero direction — with the offsets — and the plane of u_1, u_2 is undefined. Leg 1's offset
    // fixes that turn instead; the six directions are again exactly the null ones.
    let mut config = SimConfig::read(Path::new("configs/simulate_orbita3d.yaml")).unwrap();
    (config.poses, config.seed) = (200, 13);
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let p = Parameterisation::for_markers(
        *model.spm.geometry(),
        &CameraRegistration { rotation: Rotation3::identity(), translation: Vector3::zeros() },
        &[],
        &[],
        CameraModel::rigid(),
        &CalibConfig::default().bounds,
    );
    let names: Vec<&str> = p.entries.iter().map(|e| e.name.as_str()).collect();
    assert!(!names.contains(&"leg1.delta") && names.contains(&"leg2.u_tilt2"), "{names:?}");
    assert_only_the_gauges_are_free(&session, &model);
}

/// The marker-level calibration of `session` with the depth-scale model identifies all 38
/// parameters (37 of the mechanism with its joint scales and its platform's sag, registration and
/// markers, and the camera's depth scale), and
/// the six directions its parameterisation fixes add nothing: exactly six null directions.
fn assert_only_the_gauges_are_free(session: &Session, model: &RobotModel) {
    let config = CalibConfig {
        camera_model: super::CameraModelSetting::DepthScale,
        joint_scales: super::FitChoice::Fit,
        platform_sag: super::FitChoice::Fit,
        ..CalibConfig::default()
    };
    let calibration = calibrate(session, model, &config, &mut |_| {}).unwrap();
    let id = &calibration.report.identifiability;
    assert_eq!((id.rank, id.parameters), (38, 38), "{id:?}");
    assert!(calibration.parameterisation.entries.iter().any(|e| e.name == "camera.depth_scale"));
    let p = &calibration.parameterisation;
    let x = &without_sag(p, &calibration.calibrated.x);
    let Fitted::Markers(obs) = &calibration.fitted else { panic!("a marker-level calibration") };
    let base = MarkerResiduals::new(p, obs).evaluate(x, None, true).unwrap();
    let camera = CameraRegistration { rotation: p.camera(x), translation: p.translation(x) };
    let markers: Vec<Vector3<f64>> = (0..p.markers0.len()).map(|k| p.marker(x, k)).collect();
    let augmented = augmented_with_gauge(base.jacobian.as_ref().unwrap(), &p.legs(x), |legs| {
        let bounds = CalibConfig::default().bounds;
        let q = Parameterisation::for_markers(legs, &camera, &markers, &session.markers, p.camera_model(x), &bounds);
        MarkerResiduals::new(&q, obs)
            .evaluate(&DVector::zeros(q.len()), Some(&base.orientations), false)
            .unwrap()
            .residuals
    });
    let names: Vec<String> = (0..augmented.ncols()).map(|i| format!("c{i}")).collect();
    let all: Vec<usize> = (0..augmented.ncols()).collect();
    let analysis = Identifiability::analyse(&augmented, &all, &names, 1e-5);
    assert_eq!(analysis.rank, 38, "the six gauge directions must add nothing: {:?}", analysis.weakest);
    assert_eq!(analysis.unidentifiable.len(), 6);
}

/// A free-motion recording of the shipped settings, `seconds` long, a waypoint every `period_s / 10`.
fn free_motion(seconds: f64, period_s: f64) -> (Session, RobotModel) {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).unwrap();
    let r = config.recording.as_mut().unwrap();
    (r.duration_s, r.period_s) = (seconds, period_s);
    let model = RobotModel::load(&config.model).unwrap();
    (config.simulate(&model, &mut |_| {}).unwrap().0, model)
}

#[test]
fn the_latency_column_of_the_jacobian_matches_central_differences() {
    // A smooth hand motion (10 s of the shipped recording's settings).
    let (session, model) = free_motion(10.0, 20.0);
    let (recording, _) = session.at_latency(0.04);
    let truth = session.truth.as_ref().unwrap();
    let markers: Vec<_> = model.markers.iter().map(|m| m.position).collect();
    let p = Parameterisation::for_markers(
        *model.spm.geometry(),
        &truth.parameters.camera.unwrap(),
        &markers,
        &recording.markers,
        CameraModel::rigid(),
        &CalibConfig::default().bounds,
    )
    .with_latency(0.04, 0.2);
    // Frames at least 20 ms inside the stream at either end, so that ±10 ms of latency keeps them in.
    let (observations, _) = MarkerObservation::of_session(&recording, &model.spm);
    let (first, last) = (observations[0].time_s.unwrap(), observations[observations.len() - 1].time_s.unwrap());
    let observations: Vec<_> =
        observations.into_iter().filter(|o| o.time_s.is_some_and(|t| t > first + 0.02 && t < last - 0.02)).collect();
    let m = MarkerResiduals::new(&p, &observations).with_streams(recording.streams.as_ref().unwrap());
    let x = p.start() + DVector::from_fn(p.len(), |i, _| 1e-3 * ((i * 5 + 1) as f64).sin());
    let at = m.evaluate(&x, None, true).unwrap();
    let i = p.len() - 1;
    assert_eq!(p.entries[i].name, "camera.latency");
    // The analytic column uses the joint velocity over ±10 ms (`VELOCITY_WINDOW_S`), not the
    // quantised slope of one 1 ms interval: central differences over the same ±10 ms agree with
    // it up to the curvature of the motion over that window (well under 1%).
    let h = 0.01; // the velocity window, ±10 ms
    let (mut plus, mut minus) = (x.clone(), x.clone());
    plus[i] += h;
    minus[i] -= h;
    let rp = m.evaluate(&plus, Some(&at.orientations), false).unwrap().residuals;
    let rm = m.evaluate(&minus, Some(&at.orientations), false).unwrap().residuals;
    let jac = at.jacobian.unwrap();
    let mut agree = 0;
    for j in 0..observations.len() {
        let numeric = (rp[j] - rm[j]) / (2.0 * h);
        let analytic: Vector3<f64> = jac.fixed_view::<3, 1>(3 * j, i).into();
        agree += usize::from((numeric - analytic).norm() <= 0.01 * analytic.norm() + 1e-6);
    }
    assert_eq!(agree, observations.len(), "{agree} of {} frames agree", observations.len());
}

#[test]
fn the_clock_rate_and_latency_columns_match_central_differences_on_a_drifting_clock() {
    // 10 s of the shipped recording's settings, its camera clock 300 ppm fast (3 ms over 10 s).
    let (session, model) = free_motion(10.0, 20.0);
    let (recording, _) = session.at_clock(0.04, 300.0);
    let truth = session.truth.as_ref().unwrap();
    let markers: Vec<_> = model.markers.iter().map(|m| m.position).collect();
    let p = Parameterisation::for_markers(
        *model.spm.geometry(),
        &truth.parameters.camera.unwrap(),
        &markers,
        &recording.markers,
        CameraModel::rigid(),
        &CalibConfig::default().bounds,
    )
    .with_latency(0.04, 0.2)
    .with_clock_rate(300.0, 500.0, 10.0);
    let (tau, rate) = (p.len() - 2, p.len() - 1);
    assert_eq!((p.entries[tau].name.as_str(), p.entries[rate].name.as_str()), ("camera.latency", "camera.clock_rate"));
    let x = p.start() + DVector::from_fn(p.len(), |i, _| 1e-4 * ((i * 5 + 1) as f64).sin());
    let clock = p.clock(&x);
    let streams = recording.streams.as_ref().unwrap();
    let (observations, _) = MarkerObservation::of_session(&recording, &model.spm);
    // The analytic columns use the joint velocity over ±10 ms (`VELOCITY_WINDOW_S`), and the
    // slope of one 1 ms interval is quantisation, not motion: each frame is differenced between
    // the steps that read it exactly 10 ms either side, as the latency's test does. For the
    // latency, ∓0.01·(1 + r); for the rate r = ρ·10⁻⁶, which reads `e = c / (1 + r)` (`c = t − τ`),
    // `1 + r + h± = c / (e ∓ 0.01)`: a secant over `h₊ + h₋`, whose slope in `e` differs from
    // `∂e/∂r = −e / (1 + r)` by a relative `O(h / (1 + r))` ≤ 0.3 % from 4 s on. Frames from 4 s
    // on, and 50 ms inside the stream's end.
    let end = streams.encoders[streams.encoders.len() - 1].time_s - 0.05;
    let mut checked = 0;
    for frame in observations.chunk_by(|a, b| a.pose == b.pose).step_by(7) {
        let e = clock.encoder_time(frame[0].time_s.unwrap());
        if !(4.0..end).contains(&e) {
            continue;
        }
        let m = MarkerResiduals::new(&p, frame).with_streams(streams);
        let at = m.evaluate(&x, None, true).unwrap();
        let jac = at.jacobian.unwrap();
        let stretch = 1.0 + clock.rate_ppm * 1e-6;
        let c = e * stretch;
        // The rate's entry is the drift over the span T = 10 s, r·T.
        let span = p.clock_rate_span_s;
        let drift = |r: f64| r * span;
        for (i, up, down) in [
            (tau, 0.01 * stretch, 0.01 * stretch),
            (rate, drift(c / (e - 0.01) - stretch), drift(stretch - c / (e + 0.01))),
        ] {
            let (mut plus, mut minus) = (x.clone(), x.clone());
            plus[i] += up;
            minus[i] -= down;
            let rp = m.evaluate(&plus, Some(&at.orientations), false).unwrap().residuals;
            let rm = m.evaluate(&minus, Some(&at.orientations), false).unwrap().residuals;
            for j in 0..frame.len() {
                let numeric = (rp[j] - rm[j]) / (up + down);
                let analytic: Vector3<f64> = jac.fixed_view::<3, 1>(3 * j, i).into();
                // Up to the curvature of the motion over ±10 ms (as for the latency alone): 1%.
                assert!(
                    (numeric - analytic).norm() <= 0.01 * analytic.norm() + 1e-6,
                    "{} at {e:.2} s: {numeric} vs {analytic}",
                    p.entries[i].name
                );
            }
        }
        checked += 1;
    }
    assert!(checked >= 10, "{checked} frames checked");
}

/// The six directions the parameterisation fixes (the gauge), as extra Jacobian columns: `jac`
/// with six columns added: the central-difference derivatives of the residuals along tilts
/// of `u_1` (2), of `u_2` out of its plane with `u_1` (1; for a coaxial SPM, a turn of leg 1's
/// zero direction about `u_1`, which its fixed offset holds), of `v0_1` (2) and of `v0_2` out of
/// its plane (1). `residuals_of` evaluates the model with the legs so moved.
/// `x` with the platform's sag at 0. The gauge's six directions are null for a rigid platform
/// only: a sag turns it about the arm `(R z) × (−z)`, which ties B's up and P's axis to gravity,
/// so that with a sag `c` a turn of either frame moves the model by `c` times the turn.
fn without_sag(p: &Parameterisation, x: &DVector<f64>) -> DVector<f64> {
    let mut x = x.clone();
    let i = p.entries.iter().position(|e| e.kind == crate::calib::parameterisation::Kind::PlatformSag).unwrap();
    x[i] = -p.sag0;
    x
}

fn augmented_with_gauge(
    jac: &DMatrix<f64>,
    legs: &[LegGeometry; 3],
    residuals_of: impl Fn([LegGeometry; 3]) -> Vec<Vector3<f64>>,
) -> DMatrix<f64> {
    let g = legs;
    let tangent = |a: &Vector3<f64>| {
        let hint = if a.z.abs() < 0.9 { Vector3::z() } else { Vector3::x() };
        let e1 = a.cross(&hint).normalize();
        [e1, a.cross(&e1)]
    };
    let n12 = g[0].u.cross(&g[1].u);
    let m12 = g[0].v0.cross(&g[1].v0).normalize();
    let base_turn = match n12.norm() < 1e-6 {
        true => (true, 0, g[0].u),
        false => (true, 1, g[1].u.cross(&n12.normalize()).normalize()),
    };
    let moves = [
        (true, 0, tangent(&g[0].u)[0]),
        (true, 0, tangent(&g[0].u)[1]),
        base_turn,
        (false, 0, tangent(&g[0].v0)[0]),
        (false, 0, tangent(&g[0].v0)[1]),
        (false, 1, g[1].v0.cross(&m12).normalize()),
    ];
    let mut augmented = DMatrix::zeros(jac.nrows(), jac.ncols() + moves.len());
    augmented.view_mut((0, 0), (jac.nrows(), jac.ncols())).copy_from(jac);
    let moved = |actuated: bool, leg: usize, angle: Vector3<f64>| {
        let rot = so3::exp(&angle);
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

#[test]
fn a_camera_term_in_a_direction_the_data_cannot_determine_is_held() {
    // A Jacobian whose depth-scale column is exactly the camera's t_z column scaled (markers
    // that never change depth: the scale moves them as t_z would), every other column generic.
    let spm = RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap().spm;
    let camera = CameraRegistration { rotation: Rotation3::identity(), translation: Vector3::new(0.0, 0.0, 0.8) };
    let bounds = CalibConfig::default().bounds;
    let p = Parameterisation::for_markers(
        *spm.geometry(),
        &camera,
        &[Vector3::zeros()],
        &["m".into()],
        crate::model::CameraModel::perfect(crate::model::CameraModelKind::DepthScale),
        &bounds,
    );
    let index = |name: &str| p.entries.iter().position(|e| e.name == name).unwrap();
    let (depth, t_z) = (index("camera.depth_scale"), index("camera.t_z"));
    let generic = |rows: usize| {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        DMatrix::from_fn(rows, p.len(), |_, _| rng.random_range(-1.0..1.0))
    };
    let mut jacobian = generic(120);
    let column = jacobian.column(t_z) * -0.8;
    jacobian.set_column(depth, &column);
    let names: Vec<String> = p.entries.iter().map(|e| e.name.clone()).collect();
    let all: Vec<usize> = (0..p.len()).collect();
    let analysis = Identifiability::analyse(&jacobian, &all, &names, 1e-6);
    assert_eq!(analysis.unidentifiable.len(), 1, "{:?}", analysis.weakest);
    assert_eq!(super::pipeline::unidentified_camera_terms(&p, &analysis), vec![depth]);
    // A null direction among the markers alone holds no camera term.
    let mut jacobian = generic(120);
    let (x, y) = (index("m.x"), index("m.y"));
    let column = jacobian.column(x) * 2.0;
    jacobian.set_column(y, &column);
    let analysis = Identifiability::analyse(&jacobian, &all, &names, 1e-6);
    assert_eq!(analysis.unidentifiable.len(), 1);
    assert!(super::pipeline::unidentified_camera_terms(&p, &analysis).is_empty());
}

#[test]
fn a_fit_restarted_at_its_solution_stays_there() {
    // Refitted from its own solution (the unwhitened phase, the noise estimate and the Huber
    // weights all redone from there) the calibration returns to within 0.1 of its standard
    // errors. Not closer: the unwhitened phase's robust scale is its start's (from the nominal
    // model nearly least squares, from the solution Huber), so the noise model is estimated at a
    // slightly different point — 0.07 σ measured on sim_400's camera translation. (A scale that
    // follows the residuals there brings a restart within 0.01 σ, but moves every calibration by
    // up to 0.09 σ from the two-stage fit's answers, which the goldens keep.)
    for name in ["agile_wrist_sim_20", "agile_wrist_sim_400"] {
        let (session, _) = Session::load(&Path::new("datasets").join(name), None).unwrap();
        let model = RobotModel::load(&session.model).unwrap();
        let config = CalibConfig { folds: 0, ..CalibConfig::default() };
        let first = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
        let Fitted::Markers(obs) = &first.fitted else { panic!("a marker-level calibration") };
        let p = &first.parameterisation;
        let sigma: Vec<f64> = (0..p.len()).map(|i| first.covariance[(i, i)].sqrt()).collect();
        let free: Vec<bool> = sigma.iter().map(|s| *s > 0.0).collect();
        let settings = FitSettings::from_config(&config, free);
        let again = fit(&MarkerResiduals::new(p, obs), &first.calibrated.x, &settings, &mut |_| {}).unwrap();
        for i in (0..p.len()).filter(|&i| sigma[i] > 0.0) {
            let moved = (again.x[i] - first.calibrated.x[i]).abs() / sigma[i];
            assert!(moved < 0.1, "{name}, {}: {moved} σ", p.entries[i].name);
        }
        assert!(again.log.len() <= 15, "{name}: {} iterations from the solution", again.log.len());
    }
}

/// The pixel-level Jacobian with every rig term free (intrinsics, all distortion coefficients,
/// the second camera's rotation and baseline direction), on a rig of a radial-tangential and an
/// equidistant camera, against central differences: the rig's columns through the whole fit's
/// residuals, not only the lens's own derivatives.
#[test]
fn the_analytic_jacobian_of_a_pixel_session_matches_central_differences() {
    use crate::calib::config::RigTermGroup;
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist_stereo.yaml")).unwrap();
    (config.poses, config.seed) = (15, 3);
    let rig = config.camera.rig.as_mut().unwrap();
    rig.cameras[0].distortion_coeffs = [0.01, -0.004, 0.0005, -0.0003];
    rig.cameras[1].distortion_model = "equidistant".into();
    rig.cameras[1].distortion_coeffs = [0.01, -0.003, 0.001, -0.0005];
    rig.miscalibration.distortion_left_out = false;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let every = [
        RigTermGroup::FocalLengths,
        RigTermGroup::PrincipalPoints,
        RigTermGroup::RadialK1,
        RigTermGroup::RadialK2,
        RigTermGroup::OtherDistortion,
        RigTermGroup::Extrinsics,
    ];
    let p = parameterisation(&session, &model).with_rig(session.rig.clone().unwrap(), &every);
    let rig_columns = p.entries.iter().filter(|e| matches!(e.kind, Kind::Rig { .. })).count();
    // 4 intrinsics and 4 distortion coefficients per camera; cam1's rotation (3) and direction (2).
    assert_eq!(rig_columns, 2 * 8 + 5);
    let (observations, failed) = MarkerObservation::of_session(&session, &model.spm);
    assert!(failed.is_empty() && observations.iter().all(|o| o.camera.is_some()));
    let m = MarkerResiduals::new(&p, &observations);
    let x = DVector::from_fn(p.len(), |i, _| 2e-3 * ((i * 7 + 3) as f64).sin());
    let at = m.evaluate(&x, None, true).unwrap();
    let jac = at.jacobian.as_ref().unwrap();
    let h = 1e-6;
    for i in 0..p.len() {
        let (mut plus, mut minus) = (x.clone(), x.clone());
        plus[i] += h;
        minus[i] -= h;
        let rp = m.evaluate(&plus, Some(&at.orientations), false).unwrap().residuals;
        let rm = m.evaluate(&minus, Some(&at.orientations), false).unwrap().residuals;
        for j in 0..observations.len() {
            let numeric = (rp[j] - rm[j]) / (2.0 * h);
            let analytic: Vector3<f64> = jac.fixed_view::<3, 1>(3 * j, i).into();
            // Residuals of ~1,000 px: rounding 2e-13 px over 2h = 2e-6 is 1e-7 px; the O(h²)
            // truncation is far below. 1e-5 px (relative 1e-8 of a column of ~1e3) is above both.
            assert!(
                (numeric - analytic).amax() < 1e-5 * analytic.amax().max(1.0),
                "{}: numeric {numeric:?}, analytic {analytic:?}",
                p.entries[i].name
            );
            assert_eq!(analytic.z, 0.0, "a pixel residual has two rows");
        }
    }
}

// A rigid body (motion capture): its origin a point of the MP, its orientation a rotation.

/// A simulated session of a rigid body with `poses` static poses (or a recording of `seconds`),
/// and a parameterisation near its truth: the body frame's start off by a few millimetres and
/// degrees, so that every term of its Jacobian is exercised.
fn body_session(recording: Option<f64>) -> (Session, RobotModel, Parameterisation) {
    let path = if recording.is_some() {
        "configs/simulate_agile_wrist_free_motion.yaml"
    } else {
        "configs/simulate_agile_wrist.yaml"
    };
    let mut config = SimConfig::read(Path::new(path)).unwrap();
    (config.poses, config.seed) = (15, 5);
    if let (Some(r), Some(seconds)) = (config.recording.as_mut(), recording) {
        r.duration_s = seconds;
    }
    let body = crate::sim::RigidBodySettings::default();
    config.camera.rigid_body = Some(body.clone());
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let truth = session.truth.as_ref().unwrap();
    let frame = so3::exp(&Vector3::from(body.rotation_deg).map(f64::to_radians));
    let p = Parameterisation::for_markers(
        *model.spm.geometry(),
        &truth.parameters.camera.unwrap(),
        &[Vector3::from(body.origin_m) + Vector3::new(0.002, -0.001, 0.003)],
        std::slice::from_ref(&body.name),
        CameraModel::rigid(),
        &CalibConfig::default().bounds,
    )
    .with_body_frame(so3::exp(&Vector3::new(0.02, -0.01, 0.03)) * frame.inverse(), &body.name);
    (session, model, p)
}

#[test]
fn the_analytic_jacobian_of_a_rigid_body_matches_central_differences() {
    let (session, model, p) = body_session(None);
    assert!(session.body.is_some() && session.markers.is_empty());
    let (observations, _) = MarkerObservation::of_session(&session, &model.spm);
    // A position and an orientation per pose.
    assert_eq!(observations.len(), 2 * session.poses.len());
    assert_eq!(observations.iter().filter(|o| o.rotation).count(), session.poses.len());
    // The FDA resolves an orientation to ~1e-14 rad: over h = 1e-6 that is 1e-8 per difference,
    // and the rotation rows move ~0.2 rad per unit of a joint scale (metres move far less):
    // 5e-8, against differences of 1e-2 to 1e-1 where a term were missing or wrong.
    check_jacobian_within(&session, &model, &p, "rigid body", 5e-8);
}

#[test]
fn a_rigid_body_recording_s_clock_columns_match_central_differences() {
    let (session, model, p) = body_session(Some(10.0));
    let (recording, _) = session.at_clock(0.04, 300.0);
    let p = p.with_latency(0.04, 0.2).with_clock_rate(300.0, 500.0, 10.0);
    // Frames at least 20 ms inside the stream at either end, so that ±10 ms keeps them in.
    let (observations, _) = MarkerObservation::of_session(&recording, &model.spm);
    let (first, last) = (observations[0].time_s.unwrap(), observations[observations.len() - 1].time_s.unwrap());
    let observations: Vec<_> =
        observations.into_iter().filter(|o| o.time_s.is_some_and(|t| t > first + 0.02 && t < last - 0.02)).collect();
    assert!(observations.iter().any(|o| o.rotation));
    let m = MarkerResiduals::new(&p, &observations).with_streams(recording.streams.as_ref().unwrap());
    let x = p.start() + DVector::from_fn(p.len(), |i, _| 1e-3 * ((i * 5 + 1) as f64).sin());
    let at = m.evaluate(&x, None, true).unwrap();
    let jac = at.jacobian.unwrap();
    for (i, entry) in p.entries.iter().enumerate() {
        // The clock's columns use the joint velocity over ±10 ms (`VELOCITY_WINDOW_S`): central
        // differences over the same window agree up to the motion's curvature (under 1 %); every
        // other column to 1e-8, as `check_jacobian`'s.
        // The rate's column is the latency's times `e / T` through the same product (checked on
        // a drifting clock by the markers' test above, whose secants a body's frames share).
        if entry.kind == Kind::ClockRate {
            continue;
        }
        let clock = entry.kind == Kind::Latency;
        let h = if clock { 0.01 } else { 1e-6 };
        let (mut plus, mut minus) = (x.clone(), x.clone());
        plus[i] += h;
        minus[i] -= h;
        let rp = m.evaluate(&plus, Some(&at.orientations), false).unwrap().residuals;
        let rm = m.evaluate(&minus, Some(&at.orientations), false).unwrap().residuals;
        for j in 0..observations.len() {
            let numeric = (rp[j] - rm[j]) / (2.0 * h);
            let analytic: Vector3<f64> = jac.fixed_view::<3, 1>(3 * j, i).into();
            // As the static body's (5e-8: the FDA's resolution over h), the latency's as above.
            let tolerance = if clock { 0.01 * analytic.norm() + 1e-6 } else { 5e-8 };
            assert!(
                (numeric - analytic).norm() <= tolerance,
                "{} (rotation {}): numeric {numeric:?}, analytic {analytic:?}",
                entry.name,
                observations[j].rotation
            );
        }
    }
}
