//! Per-operation benchmarks of the kinematics: IK, tracking FDA (the 1 kHz haptic path),
//! continuation FDA and all assembly modes, on the nominal Agile Wrist.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Rotation3, Vector3};
use spmcal::math::so3;
use spmcal::model::Spm;

fn pose() -> Rotation3<f64> {
    // 20° tilt and 15° yaw: a typical joystick deflection.
    so3::exp(&Vector3::new(0.3, -0.25, 0.0).normalize().scale(20f64.to_radians()))
        * so3::exp(&(Vector3::z() * 15f64.to_radians()))
}

fn kinematics(c: &mut Criterion) {
    let spm = Spm::agile_wrist_nominal();
    let r = pose();
    let joints = spm.ik(&r).unwrap();
    // The previous haptic sample: 1 ms earlier at 1 rad/s, i.e. 1 mrad away.
    let previous = so3::exp(&Vector3::new(0.0006, -0.0005, 0.0006)) * r;
    c.bench_function("ik", |b| b.iter(|| spm.ik(black_box(&r)).unwrap()));
    c.bench_function("fda_track", |b| b.iter(|| spm.track(black_box(&joints), black_box(&previous)).unwrap()));
    c.bench_function("fda_forward_from_home", |b| b.iter(|| spm.forward(black_box(&joints)).unwrap()));
    c.bench_function("fda_all_modes", |b| b.iter(|| spm.all_modes(black_box(&joints))));
    // The batch the Python module's `model.forward` wraps (python/benchmarks/forward_batch.py
    // times the same call from Python): 100,000 readings of random orientations, each rotation
    // vector component uniform in ±0.3 rad.
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(1);
    let batch: Vec<Vector3<f64>> = (0..100_000)
        .map(|_| {
            let v = Vector3::from_fn(|_, _| rand::Rng::random_range(&mut rng, -0.3..0.3));
            spm.ik(&so3::exp(&v)).unwrap()
        })
        .collect();
    let mut group = c.benchmark_group("forward_batch");
    group.sample_size(10);
    group.bench_function("100k", |b| {
        b.iter(|| batch.iter().map(|j| spm.forward(black_box(j)).unwrap()).collect::<Vec<_>>())
    });
    group.finish();
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
