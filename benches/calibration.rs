//! Whole calibrations, marker-level (the default: baseline, identifiability, robust fit,
//! gross-error exclusion, covariance, 5-fold cross-validation, per-pose comparison) on 20, 400,
//! 4,000 and 27,000 poses (100,000 observations) — the cost should grow linearly — and
//! orientation-level on 400; then the command end to end as a user runs it (files in, parameters
//! file out), on static sessions, on free-motion recordings of ten minutes and an hour, and on a
//! ten-minute recording seen through a stereo rig's pixels beside the same recording as points.

use std::hint::black_box;
use std::path::Path;
use std::process::Command;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use spmcal::calib::{CalibConfig, FitLevel, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

fn calibration(c: &mut Criterion) {
    let mut sim = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    let model = RobotModel::load(&sim.model).unwrap();
    let mut sessions = Vec::new();
    for dir in ["datasets/agile_wrist_sim_20", "datasets/agile_wrist_sim_400"] {
        sessions.push(Session::load(Path::new(dir), None).unwrap().0);
    }
    sim.poses = 4000;
    sessions.push(sim.simulate(&model, &mut |_| {}).unwrap().0);
    let mut group = c.benchmark_group("calibrate_markers");
    group.sample_size(10);
    for session in &sessions {
        group.bench_with_input(BenchmarkId::from_parameter(session.poses.len()), session, |b, s| {
            b.iter(|| calibrate(black_box(s), &model, &CalibConfig::default(), &mut |_| {}).unwrap())
        });
    }
    group.finish();
    // 100,000 observations (27,000 poses × ~3.8 markers seen): target ≤ 3 s.
    sim.poses = 27_000;
    let big = sim.simulate(&model, &mut |_| {}).unwrap().0;
    let mut group = c.benchmark_group("calibrate_markers_100k");
    group.sample_size(10).measurement_time(std::time::Duration::from_secs(40));
    group.bench_function("27000", |b| {
        b.iter(|| calibrate(black_box(&big), &model, &CalibConfig::default(), &mut |_| {}).unwrap())
    });
    group.finish();
    let orientations = CalibConfig { fit: FitLevel::Orientations, ..CalibConfig::default() };
    let mut group = c.benchmark_group("calibrate_orientations");
    group.sample_size(10);
    group.bench_function("400", |b| {
        b.iter(|| calibrate(black_box(&sessions[1]), &model, &orientations, &mut |_| {}).unwrap())
    });
    group.finish();
}

/// `spmcal calibrate --dataset D --out P`, process start to parameters file written.
fn command(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("params.yaml");
    let mut group = c.benchmark_group("calibrate_command");
    group.sample_size(10);
    for dataset in ["datasets/agile_wrist_sim_400", "datasets/agile_wrist_sequential_200"] {
        group.bench_function(dataset.trim_start_matches("datasets/"), |b| {
            b.iter(|| {
                let run = Command::new(env!("CARGO_BIN_EXE_spmcal"))
                    .args(["calibrate", "--dataset", dataset, "--out", out.to_str().unwrap()])
                    .output()
                    .unwrap();
                assert!(run.status.success());
            })
        });
    }
    group.finish();
    // Free-motion recordings of ten minutes (600,001 encoder samples, ~8,700 captures) and an hour
    // (3.6 million encoder samples, ~52,000 captures), each written once: the cost is linear in
    // the data.
    let mut group = c.benchmark_group("calibrate_command_free_motion");
    group.sample_size(10).measurement_time(std::time::Duration::from_secs(60));
    for seconds in [600.0, 3600.0] {
        let mut sim = SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).unwrap();
        sim.recording.as_mut().unwrap().duration_s = seconds;
        let model = RobotModel::load(&sim.model).unwrap();
        let recording = dir.path().join(format!("recording_{seconds}"));
        sim.simulate(&model, &mut |_| {}).unwrap().0.write(&recording).unwrap();
        group.bench_function(format!("{seconds}s"), |b| {
            b.iter(|| {
                let run = Command::new(env!("CARGO_BIN_EXE_spmcal"))
                    .args(["calibrate", "--dataset", recording.to_str().unwrap(), "--out", out.to_str().unwrap()])
                    .output()
                    .unwrap();
                assert!(run.status.success());
            })
        });
        std::fs::remove_dir_all(&recording).unwrap();
    }
    group.finish();
    // A ten-minute recording seen through a stereo rig (issue 34): its pixels and the rig's file
    // (the rig refined with the mechanism), beside the same recording as the points that file
    // triangulates (`auto` chooses the camera model): the pixels within 2× the points' time.
    let mut group = c.benchmark_group("calibrate_command_pixels");
    group.sample_size(10).measurement_time(std::time::Duration::from_secs(60));
    let sim = SimConfig::read(Path::new("configs/simulate_agile_wrist_stereo_free_motion.yaml")).unwrap();
    let model = RobotModel::load(&sim.model).unwrap();
    let (seen, _) = sim.simulate(&model, &mut |_| {}).unwrap();
    let (pixels, points) = (dir.path().join("pixels_600s"), dir.path().join("points_600s"));
    seen.write(&pixels).unwrap();
    seen.as_points().write(&points).unwrap();
    for (name, recording) in [("pixels_600s", &pixels), ("points_600s", &points)] {
        group.bench_function(name, |b| {
            b.iter(|| {
                let run = Command::new(env!("CARGO_BIN_EXE_spmcal"))
                    .args(["calibrate", "--dataset", recording.to_str().unwrap(), "--out", out.to_str().unwrap()])
                    .output()
                    .unwrap();
                assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
            })
        });
    }
    group.finish();
}

/// Reading an hour-long recording (3.6 million joint states, ~52,000 marker points) as a CSV
/// session and as the equivalent ROS 2 bag (issue 23: the bag within 2x the CSV's time).
fn reading(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut sim = SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).unwrap();
    sim.recording.as_mut().unwrap().duration_s = 3600.0;
    let model = RobotModel::load(&sim.model).unwrap();
    let (session, _) = sim.simulate(&model, &mut |_| {}).unwrap();
    let (csv, bag) = (dir.path().join("hour"), dir.path().join("hour.mcap"));
    session.write(&csv).unwrap();
    session.write_bag(&bag).unwrap();
    let mut group = c.benchmark_group("read_hour_long_recording");
    group.sample_size(10).measurement_time(std::time::Duration::from_secs(40));
    for (name, path) in [("csv", &csv), ("bag", &bag)] {
        group.bench_function(name, |b| {
            b.iter(|| Session::load(path, Some(&sim.model)).unwrap());
        });
    }
    group.finish();
}

criterion_group!(benches, calibration, command, reading);
criterion_main!(benches);
