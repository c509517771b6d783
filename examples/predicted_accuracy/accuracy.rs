//! Is the predicted accuracy the accuracy the user gets? One simulated session, calibrated at the
//! marker level: the report's `predicted_error_deg` / `predicted_error_mm` against the error the
//! calibrated model achieves against the (independent, noise-free) simulated truth on fresh poses
//! of the same workspace, measured as `compare` measures it — the orientation up to a rotation of
//! the base and one of the platform common to every pose (fitted by least squares), the markers in
//! the camera frame as they are — and each fitted parameter's error in standard errors.

use nalgebra::Vector3;
use spmcal::calib::{CalibConfig, Calibration, Group, Kind, MarkerObservation, TruthInGauge, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

/// One session's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Accuracy {
    /// The report's predicted RMS orientation error, degrees.
    pub predicted_deg: f64,
    /// Its 90% interval, degrees.
    pub interval_deg: [f64; 2],
    /// Its effective degrees of freedom.
    pub dof_deg: f64,
    /// Achieved against the truth at the session's own poses (its workspace), degrees.
    pub achieved_deg: f64,
    /// Achieved over fresh poses of the whole workspace (as the simulator accepts them), degrees.
    pub fresh_deg: f64,
    /// The report's predicted RMS marker error, mm.
    pub predicted_mm: f64,
    /// Its 90% interval, mm.
    pub interval_mm: [f64; 2],
    /// Achieved at the session's own poses, mm.
    pub achieved_mm: f64,
    /// Achieved over fresh uniform poses, mm.
    pub fresh_mm: f64,
    /// `(group, |error| / standard error)` of every parameter with a standard error.
    pub z: Vec<(Group, f64)>,
}

/// Simulate `config` with `seed`, calibrate at the marker level, score the prediction on `tests`
/// fresh workspace poses.
pub fn run(config: &SimConfig, model: &RobotModel, seed: u64, tests: usize) -> Accuracy {
    let mut c = config.clone();
    c.seed = seed;
    let (session, _) = c.simulate(model, &mut |_| {}).expect("the simulation succeeds");
    let calibration = calibrate(&session, model, &CalibConfig { folds: 0, ..CalibConfig::default() }, &mut |_| {})
        .expect("the marker-level fit succeeds");
    let truth = session.truth.as_ref().expect("a simulated session");
    let spm_true = truth.parameters.spm().expect("a valid truth");
    // The session's own workspace: the joints of its poses (the truth is noise-free there, and
    // the model's error at a pose does not depend on whether the fit saw it).
    let (observations, _) = MarkerObservation::of_session(&session, &spm_true);
    let mut own: Vec<Vector3<f64>> = Vec::new();
    let mut last = None;
    for o in &observations {
        if last != Some(o.pose) {
            own.push(o.joints);
            last = Some(o.pose);
        }
    }
    let fresh: Vec<Vector3<f64>> = config
        .workspace_orientations(model, &spm_true, tests, seed ^ 0xacc)
        .iter()
        .map(|r| spm_true.ik(r).expect("reachable"))
        .collect();
    let (achieved_deg, achieved_mm) = achieved(&calibration, &session, &own);
    let (fresh_deg, fresh_mm) = achieved(&calibration, &session, &fresh);
    let report = &calibration.report;
    Accuracy {
        predicted_deg: report.predicted_error_deg.as_ref().map_or(f64::NAN, |e| e.rms),
        interval_deg: report.predicted_error_deg.as_ref().map_or([f64::NAN; 2], |e| e.interval_90),
        dof_deg: report.predicted_error_deg.as_ref().map_or(f64::NAN, |e| e.effective_dof),
        achieved_deg,
        fresh_deg,
        predicted_mm: report.predicted_error_mm.as_ref().map_or(f64::NAN, |e| e.rms),
        interval_mm: report.predicted_error_mm.as_ref().map_or([f64::NAN; 2], |e| e.interval_90),
        achieved_mm,
        fresh_mm,
        z: standardised_errors(&calibration, &session),
    }
}

/// The calibrated model's RMS errors against the truth at `joints`: degrees (up to the common
/// rotations) and mm (every true marker against the fitted one where each camera model reports it).
fn achieved(calibration: &Calibration, session: &Session, joints: &[Vector3<f64>]) -> (f64, f64) {
    let truth = session.truth.as_ref().expect("a simulated session");
    let spm_true = truth.parameters.spm().expect("a valid truth");
    let spm_fit = calibration.parameters.spm().expect("a valid fit");
    let true_camera = truth.parameters.camera.expect("a simulated camera");
    let fit_camera = calibration.parameters.camera.expect("a marker-level fit has a registration");
    let (mut fitted, mut true_r, mut sq_mm, mut n_mm) = (Vec::new(), Vec::new(), 0.0, 0usize);
    for theta in joints {
        let (Ok(r), Ok(f)) = (spm_true.forward(theta), spm_fit.forward(theta)) else { continue };
        for (t, m) in truth.parameters.markers.iter().zip(&calibration.parameters.markers) {
            // Where each camera reports the marker: through its camera model.
            let x_true = truth
                .parameters
                .camera_model
                .distort(&(true_camera.rotation * (r * t.position) + true_camera.translation));
            let x_fit = calibration
                .parameters
                .camera_model
                .distort(&(fit_camera.rotation * (f * m.position) + fit_camera.translation));
            sq_mm += (x_true - x_fit).norm_squared() * 1e6;
            n_mm += 1;
        }
        fitted.push(f);
        true_r.push(r);
    }
    (crate::study::up_to_common_rotations(&fitted, &true_r), (sq_mm / n_mm.max(1) as f64).sqrt())
}

/// `(group, |fitted − true| / σ)` of every parameter with a standard error, the truth in the
/// fit's gauge.
fn standardised_errors(calibration: &Calibration, session: &Session) -> Vec<(Group, f64)> {
    let truth = session.truth.as_ref().expect("a simulated session");
    let camera = truth.parameters.camera.expect("a simulated camera");
    let markers: Vec<Vector3<f64>> = truth.parameters.markers.iter().map(|m| m.position).collect();
    let p = &calibration.parameterisation;
    let gauge = TruthInGauge::for_markers(p, &truth.parameters.legs, &camera, &truth.parameters.camera_model, &markers);
    let x = &calibration.calibrated.x;
    p.entries
        .iter()
        .enumerate()
        .filter_map(|(i, e)| {
            let sigma = calibration.covariance[(i, i)].sqrt();
            if !(sigma.is_finite() && sigma > 0.0) {
                return None;
            }
            let error = match e.kind {
                Kind::Latency => p.latency(x) - truth.parameters.latency_s.unwrap_or(0.0),
                Kind::ClockRate => {
                    (p.clock_rate_ppm(x) - truth.parameters.clock_rate_ppm.unwrap_or(0.0)) * 1e-6 * p.clock_rate_span_s
                }
                _ => x[i] - gauge.x[i],
            };
            Some((e.kind.group(), (error / sigma).abs()))
        })
        .collect()
}

impl Accuracy {
    /// The achieved orientation error lies in the predicted 90% interval.
    pub fn inside_deg(&self) -> bool {
        (self.interval_deg[0]..=self.interval_deg[1]).contains(&self.achieved_deg)
    }

    /// The achieved marker error lies in the predicted 90% interval.
    pub fn inside_mm(&self) -> bool {
        (self.interval_mm[0]..=self.interval_mm[1]).contains(&self.achieved_mm)
    }
}

/// RMS over sessions of per-session RMS figures, and the ratio of two such.
pub fn pooled_ratio(rows: &[Accuracy], a: impl Fn(&Accuracy) -> f64, b: impl Fn(&Accuracy) -> f64) -> f64 {
    let rms =
        |f: &dyn Fn(&Accuracy) -> f64| (rows.iter().map(|r| f(r).powi(2)).sum::<f64>() / rows.len() as f64).sqrt();
    rms(&a) / rms(&b)
}

/// The standard error of [`pooled_ratio`] over sessions (delta method): each session's achieved
/// square is one draw around its prediction, `u = achieved² / predicted²`, and the pooled ratio
/// moves as `−½ δ(mean u) / mean u`.
pub fn pooled_ratio_std_error(rows: &[Accuracy], a: impl Fn(&Accuracy) -> f64, b: impl Fn(&Accuracy) -> f64) -> f64 {
    let u: Vec<f64> = rows.iter().map(|r| (b(r) / a(r)).powi(2)).collect();
    let n = u.len() as f64;
    let mean = u.iter().sum::<f64>() / n;
    let sd = (u.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    0.5 * pooled_ratio(rows, a, b) * sd / (mean * n.sqrt())
}
