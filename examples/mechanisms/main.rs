//! The marker-level calibration on each shipped mechanism (README table): the Agile Wrist and
//! Orbita3d, a coaxial SPM whose home sits on the other branch. Over simulated sessions (a new true
//! geometry per seed, misplaced markers, 200 poses, each model's simulation config): the RMS
//! orientation error of the calibrated mechanism against the truth over fresh workspace
//! orientations beside its Cramér–Rao prediction, and how many fitted parameters lie within three
//! standard errors of the truth (honest σ's: ≥ 95%, ideally 99.7%).
//! Run: `cargo run --release --example mechanisms [sessions]` (default 20 per model).

#[macro_use]
#[path = "../common/results.rs"]
mod results;
use std::path::Path;

use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)] // shared with the other studies, each using part of it
mod study;
use study::{pooled, run_session};

fn main() {
    let mut results = results::Results::new("mechanisms");
    let sessions: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    out!(
        results,
        "| model | sessions | nominal (°) | marker-level (°) | Cramér–Rao (°) | marker / CRB | parameters within 3σ |"
    );
    out!(results, "|---|---|---|---|---|---|---|");
    for config in ["configs/simulate_agile_wrist.yaml", "configs/simulate_orbita3d.yaml"] {
        let mut c = SimConfig::read(Path::new(config)).expect("shipped config");
        c.poses = 200;
        let model = RobotModel::load(&c.model).expect("shipped model");
        let rows: Vec<_> = (0..sessions).map(|s| run_session(&c, &model, 10_000 + s, 60)).collect();
        let (m, crb) = (pooled(rows.iter().map(|r| r.markers_deg)), pooled(rows.iter().map(|r| r.cramer_rao_deg)));
        let (inside, total) = rows.iter().fold((0, 0), |(a, b), r| (a + r.within_3_sigma.0, b + r.within_3_sigma.1));
        out!(
            results,
            "| {} | {} | {:.4} | {m:.4} | {crb:.4} | {:.3} | {inside} of {total} ({:.1}%) |",
            model.name,
            rows.len(),
            pooled(rows.iter().map(|r| r.nominal_deg)),
            m / crb,
            100.0 * inside as f64 / total as f64
        );
    }
    results.save();
}
