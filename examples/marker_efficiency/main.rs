//! The marker-level fit's statistical efficiency (README tables): over simulated sessions (a new
//! true geometry per seed, misplaced markers, 200 poses), the RMS orientation error of the
//! calibrated mechanism against the truth over fresh workspace orientations — marker-level fit,
//! orientation-level fit, nominal model — beside the Cramér–Rao prediction; then sequential
//! capture (one marker at a time, the joystick drifting) against simultaneous capture.
//! Run: `cargo run --release --example marker_efficiency [sessions]` (default 20 per row).

use std::path::Path;

use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[allow(dead_code)] // shared with the other studies, each using part of it
mod study;
use study::{SessionResult, pooled, run_session};

fn main() {
    let sessions: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    config.poses = 200;
    let model = RobotModel::load(&config.model).expect("shipped model");
    let rows = |config: &SimConfig| -> Vec<SessionResult> {
        (0..sessions).map(|s| run_session(config, &model, 10_000 + s, 60)).collect()
    };
    println!(
        "| stereo σ lateral / depth at 0.8 m (mm) | sessions | nominal (°) | orientation-level (°) | marker-level (°) | Cramér–Rao (°) | marker / CRB | orientation / marker |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for scale in [0.5, 1.0, 2.0] {
        let mut c = config.clone();
        c.camera.lateral_sigma_m *= scale;
        c.camera.depth_sigma_m *= scale;
        let r = rows(&c);
        let (m, o, n, crb) = (
            pooled(r.iter().map(|x| x.markers_deg)),
            pooled(r.iter().filter_map(|x| x.orientations_deg)),
            pooled(r.iter().map(|x| x.nominal_deg)),
            pooled(r.iter().map(|x| x.cramer_rao_deg)),
        );
        println!(
            "| {:.2} / {:.2} | {} | {n:.4} | {o:.4} | {m:.4} | {crb:.4} | {:.3} | {:.2} |",
            c.camera.lateral_sigma_m * 1e3,
            c.camera.depth_sigma_m * 1e3,
            r.len(),
            m / crb,
            o / m
        );
    }
    println!();
    println!(
        "| capture | drift between captures (°) | observations (mean) | marker-level (°) | orientation-level, per station (°) | Cramér–Rao (°) |"
    );
    println!("|---|---|---|---|---|---|");
    let simultaneous = rows(&config);
    let obs = |r: &[SessionResult]| r.iter().map(|x| x.observations).sum::<usize>() as f64 / r.len() as f64;
    println!(
        "| simultaneous | – | {:.0} | {:.4} | {:.4} | {:.4} |",
        obs(&simultaneous),
        pooled(simultaneous.iter().map(|x| x.markers_deg)),
        pooled(simultaneous.iter().filter_map(|x| x.orientations_deg)),
        pooled(simultaneous.iter().map(|x| x.cramer_rao_deg))
    );
    for drift in [0.05, 0.2, 0.5] {
        let mut c = config.clone();
        c.capture.sequential = true;
        c.capture.motion_deg = drift;
        let r = rows(&c);
        println!(
            "| sequential | {drift} | {:.0} | {:.4} | {:.4} | {:.4} |",
            obs(&r),
            pooled(r.iter().map(|x| x.markers_deg)),
            pooled(r.iter().filter_map(|x| x.orientations_deg)),
            pooled(r.iter().map(|x| x.cramer_rao_deg))
        );
    }
}
