//! Scratch: a pixel session made in memory from a simulated one (development only).
use std::path::Path;
use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector2, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use spmcal::calib::CalibConfig;
use spmcal::dataset::SeenPixel;
use spmcal::model::{DistortionModel, Lens, Rig, RigCamera, RobotModel};
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;

fn rig(baseline: f64, f: [f64; 4], pp: [f64; 4], rot_deg: f64, k1: f64) -> Rig {
    let lens = |c: usize| Lens {
        intrinsics: [f[2 * c], f[2 * c + 1], 640.0 + pp[2 * c], 400.0 + pp[2 * c + 1]],
        distortion_model: DistortionModel::Radtan,
        distortion: [k1, 0.0, 0.0, 0.0],
        resolution: [1280, 800],
    };
    let r = UnitQuaternion::from_scaled_axis(
        Vector3::new(0.0, -4f64.to_radians(), 0.0) + Vector3::new(rot_deg.to_radians(), 0.0, 0.0),
    );
    let t = -(r * Vector3::new(baseline, 0.0, 0.0));
    Rig {
        cameras: vec![
            RigCamera { name: "cam0".into(), lens: lens(0), from_previous: Isometry3::identity() },
            RigCamera {
                name: "cam1".into(),
                lens: lens(1),
                from_previous: Isometry3::from_parts(Translation3::from(t), r),
            },
        ],
    }
}

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(3);
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap();
    let mut c = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    c.poses = 200;
    c.camera.lateral_sigma_m = 0.0;
    c.camera.depth_sigma_m = 0.0;
    let truth_rig = rig(0.12, [900.0, 900.0, 905.0, 905.0], [0.0; 4], 0.0, 0.01);
    let wrong = rig(0.12 * 1.005, [903.0, 897.0, 908.5, 901.5], [2.0, -1.5, -2.0, 1.8], 0.05, 0.0);
    for seed in 0..seeds {
        c.seed = 10_000 + seed;
        let (clean, _) = c.simulate(&model, &mut |_| {}).unwrap();
        let truth = clean.truth.as_ref().unwrap();
        let tests = study::test_orientations(&truth.parameters.spm().unwrap(), 60, c.seed ^ 0x5eed);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, 0.3).unwrap();
        let mut session = clean.clone();
        for pose in &mut session.poses {
            pose.pixels.clear();
            for (k, m) in pose.markers.iter().enumerate() {
                let Some(y) = m else { continue };
                for cam in 0..2 {
                    let q = truth_rig.project(cam, y).unwrap().lens.pixel;
                    let q = q + Vector2::new(noise.sample(&mut rng), noise.sample(&mut rng));
                    pose.pixels.push(SeenPixel { marker: k, camera: cam, pixel: q, line: 0 });
                }
            }
        }
        for (label, r) in [("perfect rig", &truth_rig), ("wrong rig", &wrong)] {
            let s = spmcal::dataset::Session { rig: Some(Arc::new(r.clone())), ..session.clone() };
            let config = CalibConfig { folds: 0, ..CalibConfig::default() };
            let t = std::time::Instant::now();
            match spmcal::calib::calibrate(&s, &model, &config, &mut |_| {}) {
                Ok(fitted) => {
                    let e = study::calibration_error_up_to_common_rotations(&s, &fitted, &tests);
                    let e2 = study::calibration_error(&s, &fitted, &tests);
                    let rep = &fitted.report;
                    println!(
                        "seed {seed} {label}: error {e:.4}° (gauge {e2:.4}°) predicted {:?} in {:?} iterations {} warnings {:?}",
                        rep.predicted_error_deg.as_ref().map(|p| p.rms),
                        t.elapsed(),
                        rep.iterations.len(),
                        rep.warnings
                    );
                }
                Err(e) => println!("seed {seed} {label}: {e}"),
            }
            if std::env::var("SHOW").is_ok() {
                let config = CalibConfig { folds: 0, ..CalibConfig::default() };
                if let Ok(fitted) = spmcal::calib::calibrate(&s, &model, &config, &mut |_| {}) {
                    println!("{}", fitted.report);
                }
            }
        }
        // The points the wrong rig triangulates, rigid/default camera model.
        let mut points = session.clone();
        for pose in &mut points.poses {
            for k in 0..pose.markers.len() {
                let px: Vec<(usize, Vector2<f64>)> =
                    pose.pixels.iter().filter(|p| p.marker == k).map(|p| (p.camera, p.pixel)).collect();
                pose.markers[k] = if px.len() >= 2 { wrong.triangulate(&px) } else { None };
            }
            pose.pixels.clear();
        }
        let config = CalibConfig { folds: 0, ..CalibConfig::default() };
        let t = std::time::Instant::now();
        if let Ok(fitted) = spmcal::calib::calibrate(&points, &model, &config, &mut |_| {}) {
            println!(
                "seed {seed} triangulated (default camera model): {:.4}° in {:?} iterations {}",
                study::calibration_error_up_to_common_rotations(&points, &fitted, &tests),
                t.elapsed(),
                fitted.report.iterations.len()
            );
        }
    }
}
