//! The camera model (README table): sessions from a stereo camera whose depths read a percent or
//! two long or short, from an affine camera (a scale of y and shears) and from a projective one (a
//! homography of space, what a stereo rig with wrong intrinsics does to the points it
//! triangulates), calibrated with each camera model and with `auto`, the default, which picks the
//! simplest model the cross-validation supports. Per row, over simulated sessions (a new true
//! geometry per seed, misplaced markers, 200 poses, `configs/simulate_agile_wrist.yaml`): the RMS
//! orientation error of the calibrated mechanism against the truth over fresh workspace
//! orientations, the Cramér–Rao prediction of the true camera model's fit, the fitted depth scale,
//! its reported σ beside the scatter of its error, how often the truth lies within 2σ and 3σ, and
//! which model `auto` chose. Then ten minutes of free motion from a perfect camera and from one
//! whose depths read 1% long.
//! Run: `cargo run --release --example camera_model [sessions] [recordings]` (default 50 static
//! sessions per row, the same seeds in every row so that rows differ only by the camera, and 5
//! recordings per free-motion row).

#[macro_use]
#[path = "../common/results.rs"]
mod results;
use std::path::Path;

use spmcal::calib::{CalibConfig, CameraModelSetting};
use spmcal::model::{CameraModelKind, CameraTerm, RobotModel};
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;
use study::{SessionResult, pooled, run_session_with};

/// The projective camera of the study: depths 0.5% long, and the denominator growing 4% per metre
/// along the optical axis and 1.5% along camera x (a disparity offset of about half a pixel per
/// pixel of focal length over the baseline, and a tilt of the stereo pair).
const PROJECTIVE: [(CameraTerm, f64); 3] =
    [(CameraTerm::DepthScale, 1.005), (CameraTerm::PerspectiveZ, 0.04), (CameraTerm::PerspectiveX, 0.015)];

fn main() {
    let mut results = results::Results::new("camera_model");
    let sessions: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(50);
    let recordings: u64 = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(5);
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).expect("shipped model");
    let mut base = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    base.poses = 200;
    let study = Study { model: &model, sessions };
    depth_scales(&mut results, &study, &base);
    // An affine camera: y reads 1% short, x and the optical axis are sheared by 1%, depths 1% long.
    let mut affine = base.clone();
    (affine.camera.depth_scale, affine.camera.scale_y, affine.camera.shear_xz, affine.camera.shear_xy) =
        (1.01, 0.99, 0.01, 0.005);
    camera(&mut results, &study, &affine, "affine camera", CameraModelKind::Affine);
    let mut projective = base.clone();
    set_projective(&mut projective);
    camera(&mut results, &study, &projective, "projective camera", CameraModelKind::Projective);
    free_motion(&mut results, &model, recordings);
    results.save();
}

/// The study's projective camera set on `config`.
fn set_projective(config: &mut SimConfig) {
    for (term, value) in PROJECTIVE {
        match term {
            CameraTerm::DepthScale => config.camera.depth_scale = value,
            CameraTerm::PerspectiveX => config.camera.perspective_x = value,
            CameraTerm::PerspectiveZ => config.camera.perspective_z = value,
            _ => unreachable!("the study's camera sets these terms only"),
        }
    }
}

/// The sessions of a row and the model that calibrates them.
struct Study<'a> {
    model: &'a RobotModel,
    sessions: u64,
}

impl Study<'_> {
    /// Every session of `c` calibrated with `camera_model` (the same seeds for every row).
    fn run(&self, c: &SimConfig, camera_model: CameraModelSetting) -> Vec<SessionResult> {
        let settings = CalibConfig { camera_model, ..CalibConfig::default() };
        (0..self.sessions).map(|s| run_session_with(c, self.model, 10_000 + s, 60, &settings)).collect()
    }
}

/// How often `auto` chose each model: `depth_scale 48, affine 2`.
fn chosen(rows: &[SessionResult]) -> String {
    let counts = CameraModelKind::ALL.map(|k| (k, rows.iter().filter(|r| r.fitted_camera.kind == k).count()));
    let named: Vec<String> = counts.iter().filter(|(_, n)| *n > 0).map(|(k, n)| format!("{} {n}", k.name())).collect();
    named.join(", ")
}

/// The depth-scale table: rigid, depth-scale and `auto` fits of cameras whose depths read 2% short
/// to 2% long.
fn depth_scales(results: &mut results::Results, study: &Study, base: &SimConfig) {
    out!(
        results,
        "| depth scale | sessions | rigid camera (°) | depth-scale model (°) | auto (°) | auto chose | Cramér–Rao (°) | \
         model / CRB | fitted scale − true (mean ± sd) | reported σ (mean) | truth within 2σ / 3σ |"
    );
    out!(results, "|---|---|---|---|---|---|---|---|---|---|---|");
    for scale in [0.98, 0.99, 1.0, 1.01, 1.02] {
        let mut c = base.clone();
        c.camera.depth_scale = scale;
        let rigid = study.run(&c, CameraModelSetting::Rigid);
        let model_fit = study.run(&c, CameraModelSetting::DepthScale);
        let auto = study.run(&c, CameraModelSetting::Auto);
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
            "| {scale:.2} | {} | {:.4} | {m:.4} | {:.4} | {} | {crb:.4} | {:.3} | {mean:+.5} ± {sd:.5} | {sigma:.5} | {} / {} of {} |",
            model_fit.len(),
            pooled(rigid.iter().map(|r| r.markers_deg)),
            pooled(auto.iter().map(|r| r.markers_deg)),
            chosen(&auto),
            m / crb,
            within(2.0),
            within(3.0),
            errors.len()
        );
    }
}

/// Every camera model and `auto` fitted to sessions of the camera `c` (`label`), whose true model
/// is `truth`: the error against the truth, and against the Cramér–Rao bound of the true model and
/// of the larger ones.
fn camera(results: &mut results::Results, study: &Study, c: &SimConfig, label: &str, truth: CameraModelKind) {
    out!(results);
    out!(results, "| camera model fitted ({label}) | sessions | error vs truth (°) | Cramér–Rao (°) | model / CRB |");
    out!(results, "|---|---|---|---|---|");
    let fitted = CameraModelKind::ALL.into_iter().map(|k| (k.name().to_string(), k.into()));
    for (name, setting) in fitted.chain([("auto".to_string(), CameraModelSetting::Auto)]) {
        let rows = study.run(c, setting);
        let m = pooled(rows.iter().map(|r| r.markers_deg));
        // A model that has the true one's terms has a bound (the auto row: of the models it chose).
        let covers = rows.iter().all(|r| truth.terms().iter().all(|t| r.fitted_camera.kind.terms().contains(t)));
        let (crb, ratio) = match covers {
            true => {
                let crb = pooled(rows.iter().map(|r| r.cramer_rao_deg));
                (format!("{crb:.4}"), format!("{:.3}", m / crb))
            }
            false => ("–".to_string(), "–".to_string()),
        };
        let name = match setting {
            CameraModelSetting::Auto => format!("auto (chose {})", chosen(&rows)),
            _ => name,
        };
        out!(results, "| {name} | {} | {m:.4} | {crb} | {ratio} |", rows.len());
    }
}

/// Ten minutes of free motion (`configs/simulate_agile_wrist_free_motion.yaml`, 600 s) from a
/// perfect camera and from one whose depths read 1% long, calibrated with the depth-scale model,
/// with `auto` (and, for the long camera, with a rigid one): RMS error against the truth.
fn free_motion(results: &mut results::Results, model: &RobotModel, sessions: u64) {
    let recording =
        SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).expect("shipped config");
    out!(results);
    out!(results, "| 10 min free motion | sessions | error vs truth (°) | fitted scale − true (RMS) |");
    out!(results, "|---|---|---|---|");
    for (label, scale, setting) in [
        ("perfect camera, depth-scale model", 1.0, CameraModelSetting::DepthScale),
        ("perfect camera, auto", 1.0, CameraModelSetting::Auto),
        ("depth 1% long, depth-scale model", 1.01, CameraModelSetting::DepthScale),
        ("depth 1% long, auto", 1.01, CameraModelSetting::Auto),
        ("depth 1% long, rigid camera", 1.01, CameraModelSetting::Rigid),
    ] {
        let (mut errors, mut scales, mut kinds) = (Vec::new(), Vec::new(), Vec::new());
        for s in 0..sessions {
            let mut c = recording.clone();
            c.seed = 60_000 + s;
            c.camera.depth_scale = scale;
            c.recording.as_mut().expect("a recording config").duration_s = 600.0;
            let (session, _) = c.simulate(model, &mut |_| {}).expect("the simulation succeeds");
            let truth = session.truth.as_ref().expect("simulated");
            let tests = study::test_orientations(&truth.parameters.spm().expect("valid"), 60, c.seed ^ 0x5eed);
            let config = CalibConfig { folds: 0, camera_model: setting, ..CalibConfig::default() };
            match spmcal::calib::calibrate(&session, model, &config, &mut |_| {}) {
                Ok(fitted) => {
                    errors.push(study::calibration_error(&session, &fitted, &tests));
                    let camera = fitted.parameters.camera_model;
                    kinds.push(camera.kind);
                    if camera.kind != CameraModelKind::Rigid {
                        scales.push(camera.value(CameraTerm::DepthScale) - scale);
                    }
                }
                Err(e) => eprintln!("  seed {}: {e}", c.seed),
            }
        }
        let scale_error = match scales.is_empty() {
            true => "–".to_string(),
            false => format!("{:.5}", pooled(scales.into_iter())),
        };
        let label = match setting {
            CameraModelSetting::Auto => {
                let counts = CameraModelKind::ALL.map(|k| (k, kinds.iter().filter(|c| **c == k).count()));
                let named: Vec<String> =
                    counts.iter().filter(|(_, n)| *n > 0).map(|(k, n)| format!("{} {n}", k.name())).collect();
                format!("{label} (chose {})", named.join(", "))
            }
            _ => label.to_string(),
        };
        out!(results, "| {label} | {} | {:.4} | {scale_error} |", errors.len(), pooled(errors.into_iter()));
    }
}
