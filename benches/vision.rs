//! Vision estimator timings: Higham's polar decomposition against nalgebra's SVD, and the
//! whole per-pose estimate with four markers (reference factorised once, as in a session).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix3, Vector3};
use spmcal::polar::{polar, polar_svd};
use spmcal::so3;
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
    c.bench_function("polar_higham", |b| b.iter(|| polar(black_box(&noisy)).unwrap()));
    c.bench_function("polar_svd", |b| b.iter(|| polar_svd(black_box(&noisy)).unwrap()));

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

criterion_group!(benches, vision);
criterion_main!(benches);
