//! How accurate is each estimator? Simulated sessions at several camera noise levels, each pose's
//! estimate compared with the true rotation from the reference pose (in the camera frame).

use spmcal::math::so3;
use spmcal::model::RobotModel;
use spmcal::sim::{SimConfig, SimError};
use spmcal::vision::{Method, SessionEstimate};

/// One noise level of the study.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccuracyRow {
    /// Multiple of the config's camera noise.
    pub noise_scale: f64,
    /// Camera noise across the line of sight (mm).
    pub lateral_sigma_mm: f64,
    /// Camera noise along the line of sight (mm).
    pub depth_sigma_mm: f64,
    /// RMS angle (degrees) between estimated and true rotations, per method.
    pub paper_rms_deg: f64,
    /// The same for Kabsch's estimator.
    pub kabsch_rms_deg: f64,
    /// Mean `e_j`.
    pub mean_e: f64,
    /// Poses estimated.
    pub poses: usize,
}

/// Simulate a session per noise scale (same seed, so the same poses and occlusions) and score
/// both methods against the truth.
pub fn accuracy_study(config: &SimConfig, model: &RobotModel, scales: &[f64]) -> Result<Vec<AccuracyRow>, SimError> {
    let mut rows = Vec::with_capacity(scales.len());
    for &scale in scales {
        let mut c = config.clone();
        c.camera.lateral_sigma_m *= scale;
        c.camera.depth_sigma_m *= scale;
        let (session, _) = c.simulate(model, &mut |_| {})?;
        let truth = session.truth.as_ref().expect("simulated sessions carry truth");
        let camera = truth.parameters.camera.expect("simulated truth has a camera");
        let r0 = truth.orientations[&session.reference_pose];
        let rms = |method: Method| -> (f64, f64, usize) {
            let estimate = SessionEstimate::of(&session, method).expect("a simulated reference pose is regular");
            let mut sum = 0.0;
            let mut e = 0.0;
            for (pose, est) in &estimate.poses {
                // Rotation from the reference pose to this one, seen from the camera.
                let truth_c = camera.rotation * truth.orientations[pose] * r0.inverse() * camera.rotation.inverse();
                sum += so3::geodesic_angle(&est.rotation, &truth_c).powi(2);
                e += est.error;
            }
            let n = estimate.poses.len();
            ((sum / n as f64).sqrt().to_degrees(), e / n as f64, n)
        };
        let (paper, mean_e, poses) = rms(Method::Paper);
        let (kabsch, _, _) = rms(Method::Kabsch);
        rows.push(AccuracyRow {
            noise_scale: scale,
            lateral_sigma_mm: c.camera.lateral_sigma_m * 1e3,
            depth_sigma_mm: c.camera.depth_sigma_m * 1e3,
            paper_rms_deg: paper,
            kabsch_rms_deg: kabsch,
            mean_e,
            poses,
        });
    }
    Ok(rows)
}
