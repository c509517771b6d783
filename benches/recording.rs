//! Writing the Rerun recording of a 400-pose calibration (the calibration itself is done once,
//! outside the measurement). Target: under 1 second.

use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use spmcal::calib::{CalibConfig, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;

fn recording(c: &mut Criterion) {
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_sim_400"), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let calibration = calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("calibration.rrd");
    let mut group = c.benchmark_group("record");
    group.sample_size(20);
    group.bench_function("calibration_400_poses", |b| {
        b.iter(|| {
            let scene = spmcal::record::Scene::calibration(&session, &model, &calibration).unwrap();
            scene.write(&path).unwrap()
        })
    });
    group.finish();
    let bytes = std::fs::metadata(&path).unwrap().len();
    println!("recording size: {bytes} bytes ({:.0} KiB)", bytes as f64 / 1024.0);
}

criterion_group!(benches, recording);
criterion_main!(benches);
