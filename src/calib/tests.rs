//! Tests of the pipeline's internals that the public API does not reach.

use std::path::Path;

use nalgebra::DVector;

use super::config::{CalibConfig, FitLevel, Group, Loss};
use super::fit::{FitSettings, fit};
use super::model::Model;
use super::orientation_model::OrientationModel;
use super::params::Parameterisation;
use super::pipeline::{Fitted, calibrate};
use crate::dataset::Session;
use crate::model::RobotModel;

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
    let model_true = OrientationModel::new(&p, fitted).with_columns(free);
    let registered = fit(&model_true, &DVector::zeros(p.len()), &settings, &mut |_| {}).unwrap();
    let held = OrientationModel::new(&p, held_out).evaluate(&registered.x, None, false).unwrap();
    let floor = super::model::rms(&held.residuals).to_degrees();
    let achieved = calibration.report.after.held_out.unwrap().rms;
    eprintln!("held-out FDA vs vision: calibrated {achieved:.4}°, true parameters {floor:.4}°");
    assert!(achieved <= 1.10 * floor, "calibrated {achieved:.4}° vs floor {floor:.4}°");
    assert_eq!(calibration.report.held_out_poses, 100);
}
