//! Free-motion recordings against static poses (README table): for several true geometries, the
//! RMS orientation error of the calibrated mechanism against the truth over fresh workspace
//! orientations, from free-motion recordings of several lengths (latency estimated, and held at
//! zero), beside 200 static poses captured four markers at once.
//! Run: `cargo run --release --example free_motion [sessions]` (default 5 per row).
//! A fit that fails is counted, not hidden.

use std::path::Path;

use spmcal::calib::{CalibConfig, Group, calibrate};
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;

fn main() {
    let sessions: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(5);
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).expect("shipped model");
    let recording =
        SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).expect("shipped config");
    let mut static_poses = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    static_poses.poses = 200;
    let config = CalibConfig { folds: 0, ..CalibConfig::default() };
    let ignore = CalibConfig { freeze: vec![Group::Latency], ..config.clone() };
    println!(
        "| data | observations (mean) | latency error (ms, RMS) | error vs truth, latency estimated (°) | latency held at 0 (°) |"
    );
    println!("|---|---|---|---|---|");
    let statics: Vec<_> = (0..sessions).map(|s| study::run_session(&static_poses, &model, 50_000 + s, 60)).collect();
    println!(
        "| 200 static poses, 4 markers at once | {:.0} | – | {:.4} | – |",
        statics.iter().map(|r| r.observations).sum::<usize>() as f64 / statics.len() as f64,
        study::pooled(statics.iter().map(|r| r.markers_deg))
    );
    for seconds in [30.0, 60.0, 120.0, 300.0] {
        let (mut estimated, mut ignored, mut latency, mut observations) = (Vec::new(), Vec::new(), Vec::new(), 0usize);
        let mut failed = Vec::new();
        for s in 0..sessions {
            let mut c = recording.clone();
            c.seed = 50_000 + s;
            c.recording.as_mut().unwrap().duration_s = seconds;
            let (session, _) = c.simulate(&model, &mut |_| {}).expect("the simulation succeeds");
            let truth = session.truth.as_ref().unwrap();
            let tests = study::test_orientations(&truth.parameters.spm().unwrap(), 60, c.seed ^ 0x5eed);
            let (fitted, held) = match (
                calibrate(&session, &model, &config, &mut |_| {}),
                calibrate(&session, &model, &ignore, &mut |_| {}),
            ) {
                (Ok(f), Ok(h)) => (f, h),
                (Err(e), _) | (_, Err(e)) => {
                    failed.push(format!("seed {}: {e}", c.seed));
                    continue;
                }
            };
            estimated.push(study::calibration_error(&session, &fitted, &tests));
            ignored.push(study::calibration_error(&session, &held, &tests));
            let l = fitted.report.markers.as_ref().unwrap().latency.unwrap();
            latency.push((l.value_s - truth.parameters.latency_s.unwrap()) * 1e3);
            observations += fitted.report.markers.as_ref().map_or(0, |m| m.observations);
        }
        let done = estimated.len().max(1) as f64;
        println!(
            "| {seconds:.0} s free motion, one marker per 15 Hz frame ({} of {sessions} fits) | {:.0} | {:.3} | {:.4} | {:.4} |",
            estimated.len(),
            observations as f64 / done,
            study::pooled(latency.into_iter()),
            study::pooled(estimated.into_iter()),
            study::pooled(ignored.into_iter())
        );
        for f in failed {
            eprintln!("  failed: {f}");
        }
    }
}
