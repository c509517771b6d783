//! Capture planning: 40 poses from 2,000 candidates (candidates drawn and checked, information,
//! continuous design, rounding and exchanges, tour, comparison with random designs), as the
//! library call and as `spmcal plan` end to end (process start to `plan.csv` written).

use std::hint::black_box;
use std::process::Command;

use criterion::{Criterion, criterion_group, criterion_main};
use spmcal::model::RobotModel;
use spmcal::plan::{Plan, PlanSettings};
use spmcal::sim::SimConfig;

fn planning(c: &mut Criterion) {
    let config = SimConfig::default();
    let model = RobotModel::load(std::path::Path::new("models/agile_wrist.urdf")).unwrap();
    let settings = PlanSettings { poses: 40, candidates: 2000, ..PlanSettings::default() };
    let mut group = c.benchmark_group("plan");
    group.sample_size(10);
    group.bench_function("40_of_2000", |b| {
        b.iter(|| Plan::design(black_box(&model), None, &config, &settings, None).unwrap())
    });
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan.csv");
    group.bench_function("command_40_of_2000", |b| {
        b.iter(|| {
            let run = Command::new(env!("CARGO_BIN_EXE_spmcal"))
                .args(["plan", "--poses", "40", "--out", out.to_str().unwrap()])
                .output()
                .unwrap();
            assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        })
    });
    group.finish();
}

criterion_group!(benches, planning);
criterion_main!(benches);
