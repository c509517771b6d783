//! Vision estimator timings: Higham's polar decomposition against nalgebra's SVD, the whole
//! per-pose estimate with four markers (reference factorised once, as in a session), and
//! `spmcal estimate` end to end on 100,000 poses (files in, orientations file out).
//!
//! `SPMCAL_BIN=/path/to/an/older/spmcal cargo bench --bench vision -- estimate_command` times
//! another build of the command the same way (the README's before/after figures).

use std::hint::black_box;
use std::path::Path;
use std::process::Command;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix3, Vector3};
use spmcal::math::polar::Polar;
use spmcal::math::so3;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;
use spmcal::vision::{Method, Reference};

fn markers() -> Vec<Vector3<f64>> {
    let mut m: Vec<_> = [90.0f64, 210.0, 330.0]
        .iter()
        .map(|a| Vector3::new(0.075 * a.to_radians().cos(), 0.075 * a.to_radians().sin(), 0.06))
        .collect();
    m.push(Vector3::new(0.0, 0.0, 0.22));
    m.iter().map(|p| p + Vector3::new(0.0, 0.0, 0.74)).collect()
}

fn vision(c: &mut Criterion) {
    // A putative rotation with e ≈ 0.004, the simulated camera's typical value.
    let q = so3::exp(&Vector3::new(0.3, -0.2, 0.25));
    let noisy = q.matrix() + Matrix3::from_fn(|i, j| 0.004 * ((i * 3 + j) as f64).sin());
    c.bench_function("polar_higham", |b| b.iter(|| Polar::of(black_box(&noisy)).unwrap()));
    c.bench_function("polar_svd", |b| b.iter(|| Polar::by_svd(black_box(&noisy)).unwrap()));

    let reference = markers();
    let c0 = reference.iter().sum::<Vector3<f64>>() / 4.0;
    let current: Vec<_> = reference
        .iter()
        .enumerate()
        .map(|(i, p)| q * (p - c0) + c0 + Vector3::new(2e-4, -3e-4, 8e-4) * (i as f64 - 1.5))
        .collect();
    let factor = Reference::new(&reference).unwrap();
    c.bench_function("estimate_pose_paper_4_markers", |b| {
        b.iter(|| factor.estimate(black_box(&current), Method::Paper).unwrap())
    });
    c.bench_function("estimate_pose_kabsch_4_markers", |b| {
        b.iter(|| factor.estimate(black_box(&current), Method::Kabsch).unwrap())
    });
    c.bench_function("factorise_reference_4_markers", |b| b.iter(|| Reference::new(black_box(&reference)).unwrap()));
}

/// `spmcal estimate --dataset D --out O` on a simulated session of 100,000 poses (four markers
/// each, 7 + 26 MB of CSV), written once.
fn estimate_command(c: &mut Criterion) {
    let mut sim = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    sim.poses = 100_000;
    let model = RobotModel::load(&sim.model).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    sim.simulate(&model, &mut |_| {}).unwrap().0.write(&session).unwrap();
    let out = dir.path().join("orientations.csv");
    let binary = std::env::var("SPMCAL_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_spmcal").to_string());
    let mut group = c.benchmark_group("estimate_command");
    group.sample_size(10).measurement_time(std::time::Duration::from_secs(20));
    group.bench_function("100000", |b| {
        b.iter(|| {
            let run = Command::new(&binary)
                .args(["estimate", "--dataset", session.to_str().unwrap(), "--out", out.to_str().unwrap()])
                .output()
                .unwrap();
            assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        })
    });
    group.finish();
}

criterion_group!(benches, vision, estimate_command);
criterion_main!(benches);
