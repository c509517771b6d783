//! Is the predicted accuracy the accuracy the user gets (README table)? Over simulated sessions of
//! each kind (a new true geometry and misplaced markers per seed): the report's predicted RMS error
//! of the calibrated model against the error it achieves against the truth on fresh workspace
//! poses, measured as `compare` measures it; then the standard errors' coverage per parameter group.
//! Run: `cargo run --release --example predicted_accuracy [sessions] [kind]` (default 60 per kind: 20 sessions
//! estimate a pooled ratio to about ±0.06, 60 to about ±0.035;
//! `kind` keeps the kinds whose label contains it, e.g. `free`).

#[macro_use]
#[path = "../common/results.rs"]
mod results;
use std::path::Path;

use spmcal::calib::Group;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

mod accuracy;
#[allow(dead_code)]
#[path = "../marker_efficiency/study.rs"]
mod study;

fn main() {
    let mut results = results::Results::new("predicted_accuracy");
    let sessions: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(60);
    let only = std::env::args().nth(2).unwrap_or_default();
    let kinds: [(&str, &str, Option<usize>); 4] = [
        ("static, 200 poses", "configs/simulate_agile_wrist.yaml", Some(200)),
        ("static, 20 poses", "configs/simulate_agile_wrist.yaml", Some(20)),
        ("sequential, 200 stations", "configs/simulate_agile_wrist_sequential.yaml", None),
        ("free motion, 2 min", "configs/simulate_agile_wrist_free_motion.yaml", None),
    ];
    out!(
        results,
        "| session | sessions | predicted (°) | achieved (°) | pooled ratio ± s.e. | per-session ratio mean [min, max] | effective dof | achieved inside the 90% interval | fresh workspace poses (°) | predicted (mm) | achieved (mm) | pooled ratio ± s.e. | per-session ratio mean [min, max] | inside the 90% interval |"
    );
    out!(results, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut z: Vec<(Group, f64)> = Vec::new();
    for (label, file, poses) in kinds.into_iter().filter(|(label, ..)| label.contains(only.as_str())) {
        let mut config = SimConfig::read(Path::new(file)).expect("shipped config");
        if let Some(n) = poses {
            config.poses = n;
        }
        let model = RobotModel::load(&config.model).expect("shipped model");
        let rows: Vec<accuracy::Accuracy> =
            (0..sessions).map(|s| accuracy::run(&config, &model, 20_000 + s, 200)).collect();
        let rms = |v: Vec<f64>| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let ratios = |f: &dyn Fn(&accuracy::Accuracy) -> f64| {
            let r: Vec<f64> = rows.iter().map(f).collect();
            let mean = r.iter().sum::<f64>() / r.len() as f64;
            let (lo, hi) = r.iter().fold((f64::INFINITY, 0f64), |(a, b), x| (a.min(*x), b.max(*x)));
            format!("{mean:.2} [{lo:.2}, {hi:.2}]")
        };
        out!(
            results,
            "| {label} | {} | {:.4} | {:.4} | {:.2} ± {:.2} | {} | {:.1} | {} of {} | {:.4} | {:.4} | {:.4} | {:.2} ± {:.2} | {} | {} of {} |",
            rows.len(),
            rms(rows.iter().map(|r| r.predicted_deg).collect()),
            rms(rows.iter().map(|r| r.achieved_deg).collect()),
            accuracy::pooled_ratio(&rows, |r| r.predicted_deg, |r| r.achieved_deg),
            accuracy::pooled_ratio_std_error(&rows, |r| r.predicted_deg, |r| r.achieved_deg),
            ratios(&|r| r.predicted_deg / r.achieved_deg),
            rows.iter().map(|r| r.dof_deg).sum::<f64>() / rows.len() as f64,
            rows.iter().filter(|r| r.inside_deg()).count(),
            rows.len(),
            rms(rows.iter().map(|r| r.fresh_deg).collect()),
            rms(rows.iter().map(|r| r.predicted_mm).collect()),
            rms(rows.iter().map(|r| r.achieved_mm).collect()),
            accuracy::pooled_ratio(&rows, |r| r.predicted_mm, |r| r.achieved_mm),
            accuracy::pooled_ratio_std_error(&rows, |r| r.predicted_mm, |r| r.achieved_mm),
            ratios(&|r| r.predicted_mm / r.achieved_mm),
            rows.iter().filter(|r| r.inside_mm()).count(),
            rows.len(),
        );
        z.extend(rows.iter().flat_map(|r| r.z.iter().copied()));
    }
    out!(results);
    out!(results, "| parameter group | parameters | within 1σ (68.3%) | within 2σ (95.4%) | within 3σ (99.7%) |");
    out!(results, "|---|---|---|---|---|");
    let mut groups: Vec<Group> = Vec::new();
    for (g, _) in &z {
        if !groups.contains(g) {
            groups.push(*g);
        }
    }
    for g in groups {
        let of: Vec<f64> = z.iter().filter(|(h, _)| *h == g).map(|(_, v)| *v).collect();
        let within = |k: f64| 100.0 * of.iter().filter(|v| **v <= k).count() as f64 / of.len() as f64;
        out!(results, "| {g:?} | {} | {:.1}% | {:.1}% | {:.1}% |", of.len(), within(1.0), within(2.0), within(3.0));
    }
    results.save();
}
