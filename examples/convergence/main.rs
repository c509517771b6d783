//! How many iterations a calibration takes (README table): the shipped datasets, ten simulated
//! 20-pose sessions (like the paper's experiment), a sequential 200-station session, and
//! free-motion recordings of ten minutes and an hour; every fit at the default settings, its
//! iterations in all (the calibration and, when gross errors were excluded, the refit), the
//! nominal registration's, and the wall-clock time of the library call.
//! Run: `cargo run --release --example convergence` (about a minute).

use std::path::Path;
use std::time::Instant;

use spmcal::calib::{CalibConfig, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

fn main() {
    println!("| data | calibrated | iterations (calibration) | registration | time (s) |");
    println!("|---|---|---|---|---|");
    for name in [
        "agile_wrist_sim_400",
        "agile_wrist_sim_20",
        "agile_wrist_sequential_200",
        "agile_wrist_free_motion_120s",
        "orbita3d_sim_400",
    ] {
        let (session, _) = Session::load(&Path::new("datasets").join(name), None).expect("shipped dataset");
        row(name, &[session]);
    }
    let config = |path: &str| SimConfig::read(Path::new(path)).expect("shipped config");
    let sessions = |c: &SimConfig, seeds: std::ops::Range<u64>| -> Vec<Session> {
        let model = RobotModel::load(&c.model).expect("shipped model");
        seeds
            .map(|seed| {
                let mut c = c.clone();
                c.seed = seed;
                c.simulate(&model, &mut |_| {}).expect("the simulation succeeds").0
            })
            .collect()
    };
    let mut twenty = config("configs/simulate_agile_wrist.yaml");
    twenty.poses = 20;
    row("ten simulated 20-pose sessions (seeds 20–29)", &sessions(&twenty, 20..30));
    row("a sequential session, 200 stations", &sessions(&config("configs/simulate_agile_wrist_sequential.yaml"), 1..2));
    for (label, seconds) in
        [("a ten-minute free-motion recording", 600.0), ("an hour-long free-motion recording", 3600.0)]
    {
        let mut c = config("configs/simulate_agile_wrist_free_motion.yaml");
        c.recording.as_mut().expect("a recording").duration_s = seconds;
        row(label, &sessions(&c, 1..2));
    }
}

/// One row: each session calibrated; the worst figures over them.
fn row(label: &str, sessions: &[Session]) {
    let (mut calibrated, mut iterations, mut registration, mut seconds) = (0, Vec::new(), 0, 0f64);
    for session in sessions {
        let model = RobotModel::load(&session.model).expect("the session's model");
        let start = Instant::now();
        match calibrate(session, &model, &CalibConfig::default(), &mut |_| {}) {
            Ok(c) => {
                calibrated += 1;
                iterations.push(c.report.iterations.len());
                let stage = |name: &str| c.report.stages.iter().find(|s| s.name == name).map_or(0, |s| s.iterations);
                registration = registration.max(stage("registration"));
            }
            Err(e) => eprintln!("  {label}: {e}"),
        }
        seconds = seconds.max(start.elapsed().as_secs_f64());
    }
    let shown = match iterations.len() {
        1 => iterations[0].to_string(),
        _ => format!("{}–{}", iterations.iter().min().unwrap_or(&0), iterations.iter().max().unwrap_or(&0)),
    };
    println!("| {label} | {calibrated} of {} | {shown} | ≤ {registration} | {seconds:.3} |", sessions.len());
}
