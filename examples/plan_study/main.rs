//! Capture planning against random poses (README table): for N ∈ {12, 20, 40, 80}, a plan of N
//! poses (made once on the nominal model) and N, 2N and 4N random reachable poses, each
//! calibrated on several true geometries; the RMS orientation error against the truth, beside
//! the plan's own prediction. Run: `cargo run --release --example plan_study [geometries]`
//! (default 5). A failed fit is counted, not hidden.

use std::path::Path;

use spmcal::model::RobotModel;
use spmcal::plan::{PlanSettings, plan};
use spmcal::sim::SimConfig;

mod study;
use study::{calibrated_error, pooled};

fn main() {
    let geometries: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(5);
    let config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    let model = RobotModel::load(&config.model).expect("shipped model");
    println!(
        "| N | plan: predicted (°) | plan: achieved (°) | N random (°) | 2N random (°) | 4N random (°) | random poses the plan is worth (predicted) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for n in [12, 20, 40, 80] {
        let settings = PlanSettings { poses: n, ..PlanSettings::default() };
        let planned = plan(&model, None, &config, &settings, None).expect("a plan");
        let rotations: Vec<_> = planned.poses.iter().map(|p| p.rotation).collect();
        let row = |poses: Option<usize>| {
            let errors: Vec<Option<f64>> = (0..geometries)
                .map(|g| {
                    let mut c = config.clone();
                    c.poses = poses.unwrap_or(n);
                    calibrated_error(&c, &model, 30_000 + g, poses.is_none().then_some(&rotations[..]))
                })
                .collect();
            let ok: Vec<f64> = errors.iter().flatten().copied().collect();
            let failed = errors.len() - ok.len();
            let note = if failed > 0 { format!(" ({failed} fits failed)") } else { String::new() };
            format!("{:.4}{note}", pooled(ok.into_iter()))
        };
        let needed = planned.summary.random_poses_needed.map_or("> all".to_string(), |r| r.to_string());
        println!(
            "| {n} | {:.4} | {} | {} | {} | {} | {needed} |",
            planned.summary.plan.rms_deg,
            row(None),
            row(Some(n)),
            row(Some(2 * n)),
            row(Some(4 * n))
        );
    }
}
