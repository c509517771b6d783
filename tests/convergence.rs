//! A calibration converges in about ten iterations, whatever the session: the fit's weights (noise
//! model, Huber weights) settle while its parameters converge, and it stops where the Newton
//! decrement proves the optimum near. The README's table is `examples/convergence` (ten 20-pose
//! sessions, sequential capture, recordings of ten minutes and an hour); here the shipped
//! datasets and three 20-pose sessions.

use std::path::Path;

use spmcal::calib::{CalibConfig, Calibration, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

/// The budget: at most 15 iterations in all (every stage), measured 7–13.
const MOST_ITERATIONS: usize = 15;

fn calibrated(session: &Session) -> Calibration {
    let model = RobotModel::load(&session.model).unwrap();
    calibrate(session, &model, &CalibConfig::default(), &mut |_| {}).unwrap()
}

fn check(name: &str, c: &Calibration) {
    let log = &c.report.iterations;
    assert!(log.len() <= MOST_ITERATIONS, "{name}: {} iterations", log.len());
    // Every stage is reported, the calibration's iterations among them.
    let stage = |n: &str| c.report.stages.iter().find(|s| s.name == n).map(|s| s.iterations);
    assert_eq!(stage("calibration"), Some(log.iter().filter(|l| l.stage == "calibration").count()), "{name}");
    assert!(stage("registration").is_some_and(|n| n <= MOST_ITERATIONS), "{name}: {:?}", c.report.stages);
    // The stop is proven: the last step is a thousandth of a standard error from the optimum of
    // the settled weights (a free-motion recording's cost is rough below 0.3 of one).
    let last = log.last().unwrap().decrement;
    let rough = c.report.markers.as_ref().is_some_and(|m| m.latency.is_some());
    assert!(last < if rough { 0.3 } else { 1e-3 }, "{name}: last decrement {last}");
}

#[test]
fn every_shipped_dataset_calibrates_in_at_most_fifteen_iterations() {
    for name in [
        "agile_wrist_sim_400",
        "agile_wrist_sim_20",
        "agile_wrist_sequential_200",
        "agile_wrist_free_motion_120s",
        "orbita3d_sim_400",
    ] {
        let (session, _) = Session::load(&Path::new("datasets").join(name), None).unwrap();
        check(name, &calibrated(&session));
    }
}

#[test]
fn twenty_pose_sessions_all_calibrate_in_at_most_fifteen_iterations() {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = 20;
    let model = RobotModel::load(&config.model).unwrap();
    for seed in [20, 23, 27] {
        config.seed = seed;
        let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
        check(&format!("seed {seed}"), &calibrated(&session));
    }
}
