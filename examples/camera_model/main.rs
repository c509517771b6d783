//! The camera model (README table): sessions from a stereo camera whose depths read a percent or
//! two long or short, and from an affine camera (a scale of y and shears), calibrated with a
//! rigid camera and with the camera model. Per row, over simulated sessions (a new true geometry
//! per seed, misplaced markers, 200 poses, `configs/simulate_agile_wrist.yaml`): the RMS
//! orientation error of the calibrated mechanism against the truth over fresh workspace
//! orientations, the Cramér–Rao prediction of the camera-model fit, the fitted depth scale, its
//! reported σ beside the scatter of its error, and how often the truth lies within 2σ and 3σ.
//! Then ten minutes of free motion from a perfect camera and from one whose depths read 1% long.
//! Run: `cargo run --release --example camera_model [sessions] [recordings]` (default 50 static
//! sessions per row, the same seeds in every row so that rows differ only by the camera, and 5
//! recordings per free-motion row).

#[macro_use]
#[path = "../common/results.rs"]
mod results;
use std::path::Path;

use spmcal::calib::CalibConfig;
use spmcal::model::{CameraModelKind, CameraTerm, RobotModel};
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;
use study::{SessionResult, pooled, run_session_with};

fn main() {
    let mut results = results::Results::new("camera_model");
    let sessions: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(50);
    let recordings: u64 = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(5);
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).expect("shipped model");
    let mut base = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    base.poses = 200;
    let fit = |kind| CalibConfig { camera_model: kind, ..CalibConfig::default() };
    let run = |c: &SimConfig, kind| -> Vec<SessionResult> {
        (0..sessions).map(|s| run_session_with(c, &model, 10_000 + s, 60, &fit(kind))).collect()
    };
    out!(
        results,
        "| depth scale | sessions | rigid camera (°) | depth-scale model (°) | Cramér–Rao (°) | model / CRB | \
         fitted scale − true (mean ± sd) | reported σ (mean) | truth within 2σ / 3σ |"
    );
    out!(results, "|---|---|---|---|---|---|---|---|---|");
    for scale in [0.98, 0.99, 1.0, 1.01, 1.02] {
        let mut c = base.clone();
        c.camera.depth_scale = scale;
        let (rigid, model_fit) = (run(&c, CameraModelKind::Rigid), run(&c, CameraModelKind::DepthScale));
        let m = pooled(model_fit.iter().map(|r| r.markers_deg));
        let crb = pooled(model_fit.iter().map(|r| r.cramer_rao_deg));
        let errors: Vec<(f64, f64)> = model_fit
            .iter()
            .map(|r| {
                let s = r.fitted_camera.std_error(CameraTerm::DepthScale).unwrap_or(f64::NAN);
                (r.fitted_camera.value(CameraTerm::DepthScale) - scale, s)
            })
            .collect();
        let n = errors.len() as f64;
        let mean = errors.iter().map(|e| e.0).sum::<f64>() / n;
        let sd = (errors.iter().map(|e| (e.0 - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
        let sigma = errors.iter().map(|e| e.1).sum::<f64>() / n;
        let within = |k: f64| errors.iter().filter(|(e, s)| e.abs() <= k * s).count();
        out!(
            results,
            "| {scale:.2} | {} | {:.4} | {m:.4} | {crb:.4} | {:.3} | {mean:+.5} ± {sd:.5} | {sigma:.5} | {} / {} of {} |",
            model_fit.len(),
            pooled(rigid.iter().map(|r| r.markers_deg)),
            m / crb,
            within(2.0),
            within(3.0),
            errors.len()
        );
    }
    // An affine camera: y reads 1% short, x and the optical axis are sheared by 1%, depths 1% long.
    let mut c = base.clone();
    (c.camera.depth_scale, c.camera.scale_y, c.camera.shear_xz, c.camera.shear_xy) = (1.01, 0.99, 0.01, 0.005);
    out!(results);
    out!(
        results,
        "| camera model fitted (affine camera) | sessions | error vs truth (°) | Cramér–Rao (°) | model / CRB |"
    );
    out!(results, "|---|---|---|---|---|");
    for kind in [CameraModelKind::Rigid, CameraModelKind::DepthScale, CameraModelKind::Affine] {
        let rows = run(&c, kind);
        let m = pooled(rows.iter().map(|r| r.markers_deg));
        let crb = match kind {
            CameraModelKind::Affine => format!("{:.4}", pooled(rows.iter().map(|r| r.cramer_rao_deg))),
            _ => "–".to_string(),
        };
        let ratio = match kind {
            CameraModelKind::Affine => format!("{:.3}", m / pooled(rows.iter().map(|r| r.cramer_rao_deg))),
            _ => "–".to_string(),
        };
        out!(results, "| {} | {} | {m:.4} | {crb} | {ratio} |", kind.name(), rows.len());
    }
    free_motion(&mut results, &model, recordings);
    results.save();
}

/// Ten minutes of free motion (`configs/simulate_agile_wrist_free_motion.yaml`, 600 s) from a
/// perfect camera and from one whose depths read 1% long, calibrated with the depth-scale model
/// (and, for the long camera, with a rigid one): RMS error against the truth.
fn free_motion(results: &mut results::Results, model: &RobotModel, sessions: u64) {
    let recording =
        SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).expect("shipped config");
    out!(results);
    out!(results, "| 10 min free motion | sessions | error vs truth (°) | fitted scale − true (RMS) |");
    out!(results, "|---|---|---|---|");
    for (label, scale, kind) in [
        ("perfect camera, depth-scale model", 1.0, CameraModelKind::DepthScale),
        ("depth 1% long, depth-scale model", 1.01, CameraModelKind::DepthScale),
        ("depth 1% long, rigid camera", 1.01, CameraModelKind::Rigid),
    ] {
        let (mut errors, mut scales) = (Vec::new(), Vec::new());
        for s in 0..sessions {
            let mut c = recording.clone();
            c.seed = 60_000 + s;
            c.camera.depth_scale = scale;
            c.recording.as_mut().expect("a recording config").duration_s = 600.0;
            let (session, _) = c.simulate(model, &mut |_| {}).expect("the simulation succeeds");
            let truth = session.truth.as_ref().expect("simulated");
            let tests = study::test_orientations(&truth.parameters.spm().expect("valid"), 60, c.seed ^ 0x5eed);
            let config = CalibConfig { folds: 0, camera_model: kind, ..CalibConfig::default() };
            match spmcal::calib::calibrate(&session, model, &config, &mut |_| {}) {
                Ok(fitted) => {
                    errors.push(study::calibration_error(&session, &fitted, &tests));
                    scales.push(fitted.parameters.camera_model.value(CameraTerm::DepthScale) - scale);
                }
                Err(e) => eprintln!("  seed {}: {e}", c.seed),
            }
        }
        let scale_error = match kind {
            CameraModelKind::Rigid => "–".to_string(),
            _ => format!("{:.5}", pooled(scales.into_iter())),
        };
        out!(results, "| {label} | {} | {:.4} | {scale_error} |", errors.len(), pooled(errors.into_iter()));
    }
}
