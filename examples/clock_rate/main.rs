//! A camera clock that runs at its own rate (README table, issue 35): ten-minute free-motion
//! recordings (`configs/simulate_agile_wrist_free_motion.yaml`, 600 s) whose camera clock runs
//! 50 ppm fast — the latency drifts from 40 ms to 70 ms over the recording — against the same
//! recordings (same seed: same truth, motion and noise) with one clock. Per row, over simulated
//! recordings (a new true geometry per seed): the calibrated mechanism's RMS error against the
//! simulator's truth on 100 unseen poses (up to the rotations common to every pose, as the
//! report's predicted error is defined), its ratio to the one-clock recordings' under the default
//! fit, the report's predicted error (for the test poses' workspace) against the achieved, the
//! error at the recording's own poses, the latency at time 0 and the clock
//! rate against the truth in their standard errors, and what the old model (the rate held at 0)
//! makes of the same recordings.
//! Run: `cargo run --release --example clock_rate [recordings] [seconds]` (default 20 and 600).

#[macro_use]
#[path = "../common/results.rs"]
mod results;
use std::path::Path;

use spmcal::calib::{CalibConfig, Group, PredictionWorkspace};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;

/// The drifting clock: 50 ppm fast (30 ms over ten minutes).
const FAST_PPM: f64 = 50.0;

/// One calibration of one recording.
struct Outcome {
    /// The mechanism's error against the truth (°).
    achieved: f64,
    /// The report's predicted error (°).
    predicted: f64,
    /// The error against the truth at the recording's own poses (°).
    own: f64,
    /// The latency at time 0 (ms), its standard error, its error against the truth in σ.
    latency_ms: (f64, Option<f64>, Option<f64>),
    /// The clock rate (ppm), its standard error, its error against the truth in σ.
    rate_ppm: (f64, Option<f64>, Option<f64>),
}

/// How a row calibrates its recordings.
#[derive(Clone, Copy, PartialEq)]
enum Row {
    OneClockDefault,
    OneClockHeld,
    FastDefault,
    FastHeld,
}

impl Row {
    fn label(self) -> &'static str {
        match self {
            Row::OneClockDefault => "one clock, rate estimated (default)",
            Row::OneClockHeld => "one clock, rate held at 0 (old model)",
            Row::FastDefault => "camera clock 50 ppm fast, rate estimated (default)",
            Row::FastHeld => "camera clock 50 ppm fast, rate held at 0 (old model)",
        }
    }

    fn fast(self) -> bool {
        matches!(self, Row::FastDefault | Row::FastHeld)
    }

    fn config(self) -> CalibConfig {
        // The predicted error for the workspace the test poses are drawn from (tilt ≤ 30°, yaw
        // ±30°): the recording's hand stays within 80 % of it, and the model extrapolates beyond.
        let workspace = Some(PredictionWorkspace { max_tilt_deg: 30.0, max_yaw_deg: 30.0 });
        let config = CalibConfig { folds: 0, workspace, ..CalibConfig::default() };
        match self {
            Row::OneClockHeld | Row::FastHeld => CalibConfig { freeze: vec![Group::ClockRate], ..config },
            _ => config,
        }
    }
}

fn main() {
    let mut results = results::Results::new("clock_rate");
    let recordings: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let seconds: f64 = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(600.0);
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).expect("shipped model");
    let config = SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).expect("shipped config");
    let rows = [Row::OneClockDefault, Row::OneClockHeld, Row::FastDefault, Row::FastHeld];
    let mut outcomes: Vec<Vec<Outcome>> = rows.iter().map(|_| Vec::new()).collect();
    for s in 0..recordings {
        for fast in [false, true] {
            let mut c = config.clone();
            c.seed = 35_500 + s;
            let r = c.recording.as_mut().expect("a recording");
            r.duration_s = seconds;
            r.clock_rate_ppm = if fast { FAST_PPM } else { 0.0 };
            let (session, _) = c.simulate(&model, &mut |_| {}).expect("the simulation succeeds");
            for (k, row) in rows.iter().enumerate().filter(|(_, row)| row.fast() == fast) {
                let started = std::time::Instant::now();
                match run(&session, &model, c.seed, row.config()) {
                    Ok(o) => {
                        eprintln!(
                            "  seed {} {}: {:.4}° (predicted {:.4}°), latency {:.3} ms, rate {:+.2} ppm, {:.0} s",
                            c.seed,
                            row.label(),
                            o.achieved,
                            o.predicted,
                            o.latency_ms.0,
                            o.rate_ppm.0,
                            started.elapsed().as_secs_f64()
                        );
                        outcomes[k].push(o);
                    }
                    Err(e) => eprintln!("  seed {} {}: FAILED: {e}", c.seed, row.label()),
                }
            }
        }
    }
    let reference = pooled(outcomes[0].iter().map(|o| o.achieved));
    out!(results, "{} recordings of {seconds:.0} s each (the same seeds in every row).", outcomes[0].len());
    out!(results);
    out!(
        results,
        "| recording, fit | fits | error vs truth, unseen poses (°) | / one clock, default | predicted / achieved (unseen) | error at the recording's own poses (°) | latency at time 0 (ms, mean) | rate (ppm, mean ± σ) | latency, rate within 3σ |"
    );
    out!(results, "|---|---|---|---|---|---|---|---|---|");
    for (k, row) in rows.iter().enumerate() {
        let o = &outcomes[k];
        let achieved = pooled(o.iter().map(|o| o.achieved));
        let predicted = pooled(o.iter().map(|o| o.predicted));
        let own = pooled(o.iter().map(|o| o.own));
        let mean = |v: Vec<f64>| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let latency = mean(o.iter().map(|o| o.latency_ms.0).collect());
        let rate = mean(o.iter().map(|o| o.rate_ppm.0).collect());
        let sigma = mean(o.iter().filter_map(|o| o.rate_ppm.1).collect());
        let within = |z: Vec<f64>| match z.len() {
            0 => "–".to_string(),
            n => format!("{:.0} %", 100.0 * z.iter().filter(|z| z.abs() <= 3.0).count() as f64 / n as f64),
        };
        let latency_z = within(o.iter().filter_map(|o| o.latency_ms.2).collect());
        let rate_z = within(o.iter().filter_map(|o| o.rate_ppm.2).collect());
        let rate_text = if sigma > 0.0 { format!("{rate:+.2} ± {sigma:.2}") } else { format!("{rate:+.2} (held)") };
        out!(
            results,
            "| {} | {} | {achieved:.4} | {:.2}× | {:.2} | {own:.4} | {latency:.2} | {rate_text} | {latency_z}, {rate_z} |",
            row.label(),
            o.len(),
            achieved / reference,
            predicted / achieved,
        );
    }
    results.save();
}

/// Calibrate `session` under `config` and score it against the truth.
fn run(session: &Session, model: &RobotModel, seed: u64, config: CalibConfig) -> Result<Outcome, String> {
    let truth = session.truth.as_ref().expect("simulated");
    let tests = study::test_orientations(&truth.parameters.spm().expect("valid"), 100, seed ^ 0x5eed);
    let fitted = spmcal::calib::calibrate(session, model, &config, &mut |_| {}).map_err(|e| e.to_string())?;
    let achieved = study::calibration_error_up_to_common_rotations(session, &fitted, &tests);
    let predicted = fitted.report.predicted_error_deg.as_ref().map_or(f64::NAN, |p| p.rms);
    let own = own_poses_error(session, &fitted);
    let markers = fitted.report.markers.as_ref().expect("a marker-level fit");
    let latency = markers.latency.expect("a recording's latency");
    let rate = markers.clock_rate_ppm.expect("a recording's clock");
    let (true_latency, true_rate) =
        (truth.parameters.latency_s.unwrap_or(0.0), truth.parameters.clock_rate_ppm.unwrap_or(0.0));
    Ok(Outcome {
        achieved,
        predicted,
        own,
        latency_ms: (
            latency.value_s * 1e3,
            latency.std_error_s.map(|s| s * 1e3),
            latency.std_error_s.map(|s| (latency.value_s - true_latency) / s),
        ),
        rate_ppm: (rate.value, rate.std_error, rate.std_error.map(|s| (rate.value - true_rate) / s)),
    })
}

/// The calibrated mechanism's error (°) against the truth at the recording's own poses (every
/// fifth frame's encoder reading), up to the common rotations (the unseen poses also reach the
/// outer 20 % of the workspace's tilt the hand never does).
fn own_poses_error(session: &Session, fitted: &spmcal::calib::Calibration) -> f64 {
    let truth = session.truth.as_ref().expect("simulated").parameters.spm().expect("valid");
    let Ok(spm) = fitted.parameters.spm() else { return f64::INFINITY };
    let (mut fit, mut true_r) = (Vec::new(), Vec::new());
    for pose in session.poses.iter().step_by(5) {
        if let (Ok(f), Ok(t)) = (spm.forward(&pose.joints), truth.forward(&pose.joints)) {
            fit.push(f);
            true_r.push(t);
        }
    }
    study::up_to_common_rotations(&fit, &true_r)
}

/// RMS over recordings of per-recording figures.
fn pooled(values: impl Iterator<Item = f64>) -> f64 {
    study::pooled(values)
}
