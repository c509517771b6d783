//! Joint scales (README table, issue 35): a joint's reading and its angle differ by a scale of
//! 0.1–1 % (a capstan's effective radius, a belt's pitch), `φ = sθ + δ`. Per row, over simulated
//! sessions (a new true geometry per seed; each leg's true scale drawn uniformly within ±0.5 %),
//! the calibrated mechanism's RMS error against the simulator's truth on 100 unseen poses (up to
//! the rotations common to every pose, as the report's predicted error is defined) for
//! - the same sessions without a scale error, the default (`joint_scales: auto`),
//! - the same, the scales held (`joint_scales: hold`: what spmcal did before it fitted them),
//! - the same, the scales always fitted (`joint_scales: fit`): what not knowing the scales costs,
//! - with the scale error, the default,
//! - with the scale error, the scales held;
//!
//! how many fitted scales lie within 3σ of the truth, and the report's predicted error against the
//! achieved. Each session with and without the error is the same draw (geometry, camera, poses).
//!
//! The price of estimating the scales is bounded below by the Cramér–Rao bound: no estimator that
//! does not know them does better than the bound with them free. The study shows it two ways on the
//! sessions without an error: the achieved error with the scales fitted over held, and the report's
//! predicted error (the bound, propagated to the poses) with them fitted over held.
//! Run: `cargo run --release --example joint_scales [sessions] [recordings]` (default 20 and 20).

#[macro_use]
#[path = "../common/results.rs"]
mod results;
use std::path::Path;

use rand::{Rng, SeedableRng};
use spmcal::calib::{CalibConfig, FitChoice};
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;

/// Largest true scale error, either sign (0.5 %).
const MOST_SCALE_ERROR: f64 = 0.005;

/// One calibration: achieved and predicted error (deg), the fitted scales' errors in σ, and how
/// many scales `auto` held.
struct Outcome {
    achieved: f64,
    predicted: f64,
    z: Vec<f64>,
    held: usize,
}

fn main() {
    let mut results = results::Results::new("joint_scales");
    let sessions: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let recordings: u64 = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(20);
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).expect("shipped model");
    let mut fixed = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    fixed.poses = 200;
    let mut moving =
        SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).expect("shipped config");
    if let Some(r) = moving.recording.as_mut() {
        r.duration_s = 600.0;
    }
    out!(
        results,
        "| session | sessions | no scale error, default (°) | no scale error, held (°) | default / held | no scale error, fitted (°) | fitted / held | bound: predicted, fitted / held | scale error, default (°) | / no error | / no error, fitted | scale error, held (°) | scales within 3σ | predicted / achieved | scales held by auto |"
    );
    out!(results, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (label, config, n, seed0) in
        [("200 static poses", &fixed, sessions, 35_000), ("10-minute recording", &moving, recordings, 36_000)]
    {
        // [no error default, no error held, error default, error held, no error fitted]
        let mut rows: [Vec<Outcome>; 5] = Default::default();
        for s in 0..n {
            let mut c = config.clone();
            c.seed = seed0 + s;
            let (clean, _) = c.simulate(&model, &mut |_| {}).expect("the simulation succeeds");
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(c.seed ^ 0x5ca1e);
            c.encoders.scales = std::array::from_fn(|_| 1.0 + rng.random_range(-MOST_SCALE_ERROR..MOST_SCALE_ERROR));
            let (scaled, _) = c.simulate(&model, &mut |_| {}).expect("the simulation succeeds");
            let runs = [
                (&clean, FitChoice::Auto),
                (&clean, FitChoice::Hold),
                (&scaled, FitChoice::Auto),
                (&scaled, FitChoice::Hold),
                (&clean, FitChoice::Fit),
            ];
            let outcomes: Vec<Result<Outcome, String>> =
                runs.iter().map(|(session, setting)| run(session, &model, *setting, c.seed)).collect();
            // A session counts in every column or in none, so that the ratios compare like with like.
            if let Some(e) = outcomes.iter().find_map(|o| o.as_ref().err()) {
                eprintln!("  {label} seed {}: {e}", c.seed);
                continue;
            }
            for (row, o) in rows.iter_mut().zip(outcomes) {
                row.push(o.expect("checked"));
            }
            let last: Vec<String> =
                rows.iter().map(|r| format!("{:.4}", r.last().map_or(f64::NAN, |o| o.achieved))).collect();
            eprintln!("  {label} seed {}: scales {:?}: {}°", c.seed, c.encoders.scales, last.join(" / "));
            let pred: Vec<String> =
                rows.iter().map(|r| format!("{:.4}", r.last().map_or(f64::NAN, |o| o.predicted))).collect();
            eprintln!("    predicted {}", pred.join(" / "));
        }
        let [clean_default, clean_held, scaled_default, scaled_held, clean_fitted] = rows.each_ref().map(|r| pooled(r));
        let bound = study_rms(rows[4].iter().map(|o| o.predicted)) / study_rms(rows[1].iter().map(|o| o.predicted));
        let z: Vec<f64> = rows[2].iter().flat_map(|o| o.z.iter().copied()).collect();
        let within = match z.is_empty() {
            true => "–".to_string(),
            false => {
                let inside = z.iter().filter(|z| z.abs() <= 3.0).count();
                format!("{:.1} % of {}", 100.0 * inside as f64 / z.len() as f64, z.len())
            }
        };
        let predicted = study_rms(rows[2].iter().map(|o| o.predicted));
        let held: usize = rows[0].iter().chain(&rows[2]).map(|o| o.held).sum();
        let fitted_runs = rows[0].len() + rows[2].len();
        out!(
            results,
            "| {label} | {} | {clean_default:.4} | {clean_held:.4} | {:.3}× | {clean_fitted:.4} | {:.2}× | {bound:.2}× | {scaled_default:.4} | {:.2}× | {:.2}× | {scaled_held:.4} | {within} | {:.2} | {held} of {} |",
            rows[0].len(),
            clean_default / clean_held,
            clean_fitted / clean_held,
            scaled_default / clean_held,
            scaled_default / clean_fitted,
            predicted / scaled_default,
            3 * fitted_runs,
        );
    }
    out!(results);
    out!(
        results,
        "\"/ no error\": the default's error with the scale error over the same sessions' without it (scales held, \
         what spmcal did before it fitted them). \"default / held\": what fitting the scales by default costs on \
         sessions without a scale error. \"fitted / held\" and \"bound\": what estimating the scales costs where \
         they are right, achieved and as the Cramér–Rao bound predicts it (the report's predicted error with them \
         fitted over held): no estimator that does not know the scales does better. \"/ no error, fitted\": the \
         default with the scale error over the same sessions without it, the scales fitted."
    );
    results.save();
}

/// Calibrate `session` (defaults but `joint_scales`, no cross-validation) and score it against the truth.
fn run(
    session: &spmcal::dataset::Session,
    model: &RobotModel,
    scales: FitChoice,
    seed: u64,
) -> Result<Outcome, String> {
    let truth = session.truth.as_ref().expect("simulated");
    let tests = study::test_orientations(&truth.parameters.spm().expect("valid"), 100, seed ^ 0x5eed);
    // The predicted error over the workspace the achieved one is measured on.
    let workspace = Some(study::TEST_WORKSPACE);
    let config = CalibConfig { folds: 0, joint_scales: scales, workspace, ..CalibConfig::default() };
    let fitted = spmcal::calib::calibrate(session, model, &config, &mut |_| {}).map_err(|e| e.to_string())?;
    let achieved = study::calibration_error_up_to_common_rotations(session, &fitted, &tests);
    let predicted = fitted.report.predicted_error_deg.as_ref().map_or(f64::NAN, |p| p.rms);
    let true_scales = truth.parameters.legs.map(|g| g.scale);
    let z = fitted
        .report
        .joint_scales
        .iter()
        .filter_map(|s| s.std_error_ppm.map(|se| (s.scale - true_scales[s.leg - 1]) * 1e6 / se))
        .collect();
    let held = fitted.report.joint_scales.iter().filter(|s| s.held.is_some() && scales == FitChoice::Auto).count();
    Ok(Outcome { achieved, predicted, z, held })
}

fn pooled(rows: &[Outcome]) -> f64 {
    study_rms(rows.iter().map(|o| o.achieved))
}

fn study_rms(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.collect();
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}
