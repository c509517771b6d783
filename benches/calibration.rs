//! Whole calibrations (vision, starting point, nominal baseline, identifiability, fit, covariance,
//! hold-out) of 20, 400 and 4,000 poses: the cost should grow linearly with the poses.

use std::hint::black_box;
use std::path::Path;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use spmcal::calib::{CalibConfig, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::{SimConfig, simulate};

fn calibration(c: &mut Criterion) {
    let mut sim = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    let model = RobotModel::load(&sim.model).unwrap();
    let mut sessions = Vec::new();
    for dir in ["datasets/agile_wrist_sim_20", "datasets/agile_wrist_sim_400"] {
        sessions.push(Session::load(Path::new(dir), None).unwrap().0);
    }
    sim.poses = 4000;
    sessions.push(simulate(&sim, &model, &mut |_| {}).unwrap().0);
    let config = CalibConfig::default();
    let mut group = c.benchmark_group("calibrate");
    group.sample_size(10);
    for session in &sessions {
        group.bench_with_input(BenchmarkId::from_parameter(session.poses.len()), session, |b, s| {
            b.iter(|| calibrate(black_box(s), &model, &config, &mut |_| {}).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, calibration);
criterion_main!(benches);
