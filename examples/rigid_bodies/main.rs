//! Rigid bodies beside markers (README table, issue 37): a motion-capture system reports a rigid
//! body's pose per capture (its frame's origin and orientation) where a stereo camera reports each
//! marker. Per row, over simulated sessions (a new true geometry per seed), the calibrated
//! mechanism's RMS orientation error against the simulator's truth on 100 unseen poses (up to the
//! rotations common to every pose, as the report's predicted error is defined) for the same
//! simulated poses seen
//! - as markers (the shipped camera: 0.2 mm across the line of sight, 0.8 mm along it at 0.8 m),
//! - as a rigid body fitted to those same measured markers, as a tracker makes its body (Kabsch on
//!   the body's four markers at their true places: the tracker knows its constellation), so that
//!   its noise is the markers' noise,
//! - as a rigid body with a tracker's own noise, 0.3 mm and 0.1° per axis (OptiTrack-like);
//!
//! each with the defaults (`fit: markers`; the body's frame on the MP and the registration fitted;
//! a marker session's camera model chosen by `auto`), no cross-validation. Also the noise the fit
//! estimates for the fitted body, and the predicted error against the achieved for the bodies.
//! Static rows: 200 poses; recording rows: free motion, every marker in every frame (a body needs
//! three at once), 15 Hz, 40 ms latency, two minutes (as the shipped recording; shorter ones
//! cover the workspace too thinly for the unseen poses, which span all of it).
//! Run: `cargo run --release --example rigid_bodies [sessions] [recordings] [seconds]` (default
//! 50, 30 and 120).

#[macro_use]
#[path = "../common/results.rs"]
mod results;
use std::path::Path;

use spmcal::calib::CalibConfig;
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::{RigidBodySettings, SimConfig};

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;

/// One calibration: achieved and predicted error (deg), and the body noise it estimated (mm, deg).
struct Outcome {
    achieved: f64,
    predicted: f64,
    noise: Option<(f64, f64)>,
}

fn main() {
    let mut results = results::Results::new("rigid_bodies");
    let arg = |k: usize, default: u64| std::env::args().nth(k).and_then(|a| a.parse().ok()).unwrap_or(default);
    let (sessions, recordings, seconds) = (arg(1, 50), arg(2, 30), arg(3, 120));
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).expect("shipped model");
    let mut fixed = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    fixed.poses = 200;
    let mut moving =
        SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).expect("shipped config");
    if let Some(r) = moving.recording.as_mut() {
        (r.duration_s, r.all_markers) = (seconds as f64, true);
    }
    let fitted = RigidBodySettings { fitted_to_markers: true, ..RigidBodySettings::default() };
    let tracker = RigidBodySettings::default();
    out!(
        results,
        "| session | sessions | markers (°) | body fitted to the markers (°) | / markers | its noise estimated (mm, °) | body, tracker noise (°) | / markers | predicted / achieved (bodies) |"
    );
    out!(results, "|---|---|---|---|---|---|---|---|---|");
    let recording = format!("{seconds} s recording");
    for (label, config, n, seed0) in
        [("200 static poses", &fixed, sessions, 37_000), (recording.as_str(), &moving, recordings, 37_500)]
    {
        // [markers, fitted body, tracker body]
        let mut rows: [Vec<Outcome>; 3] = Default::default();
        for s in 0..n {
            let mut c = config.clone();
            c.seed = seed0 + s;
            let kinds = [None, Some(fitted.clone()), Some(tracker.clone())];
            let outcomes: Vec<Result<Outcome, String>> = kinds
                .into_iter()
                .map(|body| {
                    let mut c = c.clone();
                    c.camera.rigid_body = body;
                    let (session, _) = c.simulate(&model, &mut |_| {}).map_err(|e| e.to_string())?;
                    run(&session, &model, c.seed)
                })
                .collect();
            // A session counts in every column or in none, so that the ratios compare like with like.
            if let Some(e) = outcomes.iter().find_map(|o| o.as_ref().err()) {
                eprintln!("  {label} seed {}: {e}", c.seed);
                continue;
            }
            for (row, o) in rows.iter_mut().zip(outcomes) {
                row.push(o.expect("checked"));
            }
            let last = |k: usize| rows[k].last().map_or((f64::NAN, f64::NAN), |o| (o.achieved, o.predicted));
            eprintln!(
                "  {label} seed {}: achieved (predicted) {:.4} ({:.4}) / {:.4} ({:.4}) / {:.4} ({:.4})°",
                c.seed,
                last(0).0,
                last(0).1,
                last(1).0,
                last(1).1,
                last(2).0,
                last(2).1,
            );
        }
        let [markers, body, tracked] = rows.each_ref().map(|r| rms(r.iter().map(|o| o.achieved)));
        let noise: Vec<(f64, f64)> = rows[1].iter().filter_map(|o| o.noise).collect();
        let (position, orientation) = (
            noise.iter().map(|n| n.0).sum::<f64>() / noise.len().max(1) as f64,
            noise.iter().map(|n| n.1).sum::<f64>() / noise.len().max(1) as f64,
        );
        let bodies = rows[1].iter().chain(&rows[2]);
        let predicted = rms(bodies.clone().map(|o| o.predicted)) / rms(bodies.map(|o| o.achieved));
        out!(
            results,
            "| {label} | {} | {markers:.4} | {body:.4} | {:.2}× | {position:.3}, {orientation:.3} | {tracked:.4} | {:.2}× | {predicted:.2} |",
            rows[0].len(),
            body / markers,
            tracked / markers,
        );
    }
    out!(results);
    out!(
        results,
        "\"/ markers\": the body's error over the markers' on the same poses. The fitted body's noise is the \
         markers' seen through a Kabsch fit (its position's σ per axis, its orientation's per axis of a small turn), \
         as the fit estimates it."
    );
    results.save();
}

/// Calibrate `session` (defaults, no cross-validation) and score it against the truth.
fn run(session: &Session, model: &RobotModel, seed: u64) -> Result<Outcome, String> {
    let truth = session.truth.as_ref().expect("simulated");
    let tests = study::test_orientations(&truth.parameters.spm().expect("valid"), 100, seed ^ 0x5eed);
    let config = CalibConfig { folds: 0, ..CalibConfig::default() };
    let fitted = spmcal::calib::calibrate(session, model, &config, &mut |_| {}).map_err(|e| e.to_string())?;
    let achieved = study::calibration_error_up_to_common_rotations(session, &fitted, &tests);
    let predicted = fitted.report.predicted_error_deg.as_ref().map_or(f64::NAN, |p| p.rms);
    let noise = fitted
        .report
        .markers
        .as_ref()
        .and_then(|m| m.stereo_noise.as_ref())
        .and_then(|n| Some((n.body_position_m? * 1e3, n.body_orientation_rad?.to_degrees())));
    Ok(Outcome { achieved, predicted, noise })
}

fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.collect();
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}
