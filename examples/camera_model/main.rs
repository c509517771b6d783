//! The camera model (README table): sessions from a stereo camera whose depths read a percent or
//! two long or short, and from an affine camera (a scale of y and shears), calibrated with a
//! rigid camera and with the camera model. Per row, over simulated sessions (a new true geometry
//! per seed, misplaced markers, 200 poses, `configs/simulate_agile_wrist.yaml`): the RMS
//! orientation error of the calibrated mechanism against the truth over fresh workspace
//! orientations, the Cramér–Rao prediction of the camera-model fit, the fitted depth scale, its
//! reported σ beside the scatter of its error, and how often the truth lies within 2σ and 3σ.
//! Run: `cargo run --release --example camera_model [sessions]` (default 50 per row; the same seeds in every row, so that rows differ only by the camera).

use std::path::Path;

use spmcal::calib::CalibConfig;
use spmcal::model::{CameraModelKind, CameraTerm, RobotModel};
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;
use study::{SessionResult, pooled, run_session_with};

fn main() {
    let sessions: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(50);
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).expect("shipped model");
    let mut base = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    base.poses = 200;
    let fit = |kind| CalibConfig { camera_model: kind, ..CalibConfig::default() };
    let run = |c: &SimConfig, kind| -> Vec<SessionResult> {
        (0..sessions).map(|s| run_session_with(c, &model, 10_000 + s, 60, &fit(kind))).collect()
    };
    println!(
        "| depth scale | sessions | rigid camera (°) | depth-scale model (°) | Cramér–Rao (°) | model / CRB | \
         fitted scale − true (mean ± sd) | reported σ (mean) | truth within 2σ / 3σ |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
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
        println!(
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
    println!();
    println!("| camera model fitted (affine camera) | sessions | error vs truth (°) | Cramér–Rao (°) | model / CRB |");
    println!("|---|---|---|---|---|");
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
        println!("| {} | {} | {m:.4} | {crb} | {ratio} |", kind.name(), rows.len());
    }
}
