//! How close does each fit come to the best any unbiased estimator can do? On a simulated session
//! the fitted mechanism's orientation error is measured against the truth over fresh orientations
//! of the workspace (not the session's), and compared with the Cramér–Rao prediction: the
//! orientation variance that the Fisher information at the true parameters, under the true noise
//! model, implies.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use spmcal::calib::{
    CalibConfig, Calibration, FitLevel, MarkerObservation, MarkerResiduals, Parameterisation, PredictionWorkspace,
    TruthInGauge, calibrate,
};
use spmcal::dataset::Session;
use spmcal::math::so3;
use spmcal::model::{CameraModel, CameraModelKind, LegGeometry, RobotModel, Spm};
use spmcal::sim::SimConfig;

/// One session's figures: RMS orientation errors (degrees) against the truth over the test
/// orientations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SessionResult {
    /// The marker-level fit.
    pub markers_deg: f64,
    /// The orientation-level fit (per station for sequential capture); `None` when it failed.
    pub orientations_deg: Option<f64>,
    /// The nominal model.
    pub nominal_deg: f64,
    /// The Cramér–Rao prediction of the marker-level fit's RMS error.
    pub cramer_rao_deg: f64,
    /// Marker observations fitted.
    pub observations: usize,
    /// The camera model the marker-level fit ended with.
    pub fitted_camera: CameraModel,
    /// Of the marker-level fit's parameters with a standard error, how many lie within three of
    /// them of the truth (in the fit's gauge), and how many there are: honest σ's put ~99.7% inside.
    pub within_3_sigma: (usize, usize),
}

/// The workspace [`test_orientations`] draws from: a calibration asked to predict its error there
/// (`workspace:`) predicts what the study measures, also where a session (a recording's hand)
/// covered it unevenly.
pub const TEST_WORKSPACE: PredictionWorkspace = PredictionWorkspace { max_tilt_deg: 30.0, max_yaw_deg: 30.0 };

/// Random orientations of [`TEST_WORKSPACE`] (tilt ≤ 30°, yaw ≤ 30°) that `truth` reaches.
pub fn test_orientations(truth: &Spm, n: usize, seed: u64) -> Vec<Rotation3<f64>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n);
    let (max_tilt, max_yaw) = (TEST_WORKSPACE.max_tilt_deg, TEST_WORKSPACE.max_yaw_deg);
    while out.len() < n {
        let tilt = max_tilt.to_radians() * rng.random::<f64>().sqrt();
        let azimuth = rng.random_range(0.0..std::f64::consts::TAU);
        let yaw = rng.random_range(-max_yaw..max_yaw).to_radians();
        let r = so3::exp(&(Vector3::new(azimuth.cos(), azimuth.sin(), 0.0) * tilt)) * so3::exp(&(Vector3::z() * yaw));
        if truth.ik(&r).is_ok() {
            out.push(r);
        }
    }
    out
}

/// RMS angle (degrees) between what `legs` predicts from the true joints of each test orientation
/// and the truth, in the fit's frames (`G R Hᵀ`).
pub fn workspace_error(legs: &[LegGeometry; 3], truth: &Spm, gauge: &TruthInGauge, tests: &[Rotation3<f64>]) -> f64 {
    let Ok(spm) = Spm::new(*legs) else { return f64::INFINITY };
    let sum: f64 = tests
        .iter()
        .map(|r| {
            let joints = truth.ik(r).expect("test orientations are reachable");
            spm.forward(&joints).map_or(f64::INFINITY, |fit| so3::geodesic_angle(&fit, &gauge.orientation(r)).powi(2))
        })
        .sum();
    (sum / tests.len() as f64).sqrt().to_degrees()
}

/// `∂ω/∂x` of the mechanism at `joints` (3 × N), by central differences of the FDA.
fn orientation_sensitivity(p: &Parameterisation, x: &DVector<f64>, joints: &Vector3<f64>) -> DMatrix<f64> {
    let h = 1e-7;
    let mut s = DMatrix::zeros(3, p.len());
    for i in 0..p.len() {
        let (mut plus, mut minus) = (x.clone(), x.clone());
        plus[i] += h;
        minus[i] -= h;
        let at = |x: &DVector<f64>| Spm::new(p.legs(x)).ok().and_then(|spm| spm.forward(joints).ok());
        if let (Some(a), Some(b)) = (at(&plus), at(&minus)) {
            s.set_column(i, &(so3::log(&(a * b.inverse())) / (2.0 * h)));
        }
    }
    s
}

/// The Cramér–Rao prediction of the RMS orientation error (degrees) over `tests` of a fit with
/// the camera model `camera_model`: the Fisher information of the session's marker observations
/// at the true parameters, whitened by the true stereo noise, inverted and propagated through
/// `∂ω/∂x` at each test orientation.
pub fn cramer_rao(
    session: &Session,
    model: &RobotModel,
    config: &SimConfig,
    tests: &[Rotation3<f64>],
    camera_model: CameraModelKind,
) -> f64 {
    let truth = session.truth.as_ref().expect("a simulated session");
    let camera = truth.parameters.camera.expect("a simulated camera");
    let markers0: Vec<Vector3<f64>> = model.markers.iter().map(|m| m.position).collect();
    let bounds = CalibConfig::default().bounds;
    let p = Parameterisation::for_markers(
        *model.spm.geometry(),
        &camera,
        &markers0,
        &session.markers,
        CameraModel::perfect(camera_model),
        &bounds,
    );
    let true_markers: Vec<Vector3<f64>> = truth.parameters.markers.iter().map(|m| m.position).collect();
    let gauge =
        TruthInGauge::for_markers(&p, &truth.parameters.legs, &camera, &truth.parameters.camera_model, &true_markers);
    let spm_true = truth.parameters.spm().expect("a valid truth");
    let (observations, _) = MarkerObservation::of_session(session, &spm_true);
    let noise = config.camera.stereo_noise();
    let fisher = MarkerResiduals::new(&p, &observations)
        .information_per_pose(&gauge.x, &noise)
        .expect("the truth evaluates")
        .into_iter()
        .fold(DMatrix::zeros(p.len(), p.len()), |sum, (_, m)| sum + m);
    let cov = fisher.try_inverse().expect("the gauge-fixed parameters are identifiable");
    let spm_fit_truth = Spm::new(p.legs(&gauge.x)).expect("the truth in gauge is valid");
    let mean: f64 = tests
        .iter()
        .map(|r| {
            let joints = spm_true.ik(r).expect("reachable");
            let _ = spm_fit_truth.forward(&joints).expect("the truth reaches it");
            let s = orientation_sensitivity(&p, &gauge.x, &joints);
            (&s * &cov * s.transpose()).trace()
        })
        .sum::<f64>()
        / tests.len() as f64;
    mean.sqrt().to_degrees()
}

/// The error of a calibration's mechanism against the truth over `tests`.
pub fn calibration_error(session: &Session, calibration: &Calibration, tests: &[Rotation3<f64>]) -> f64 {
    let truth = session.truth.as_ref().expect("a simulated session");
    let camera = truth.parameters.camera.expect("a simulated camera");
    let gauge = TruthInGauge::new(
        &calibration.parameterisation,
        &truth.parameters.legs,
        &camera.rotation,
        &Rotation3::identity(),
    );
    let spm_true = truth.parameters.spm().expect("a valid truth");
    workspace_error(&calibration.parameters.legs, &spm_true, &gauge, tests)
}

/// The RMS angle (degrees) between `fit` and `truth` after the least-squares rotations `G`, `H`
/// common to every pose (`truth ≈ G fit H`), by Gauss–Newton.
pub fn up_to_common_rotations(fit: &[Rotation3<f64>], truth: &[Rotation3<f64>]) -> f64 {
    let (mut g, mut h) = (Rotation3::identity(), Rotation3::identity());
    let residuals = |g: &Rotation3<f64>, h: &Rotation3<f64>| -> Vec<Vector3<f64>> {
        fit.iter().zip(truth).map(|(f, t)| so3::log(&(g * f * h * t.inverse()))).collect()
    };
    for _ in 0..10 {
        let e = residuals(&g, &h);
        let (mut btb, mut bte) = (DMatrix::<f64>::zeros(6, 6), DVector::<f64>::zeros(6));
        for (ej, t) in e.iter().zip(truth) {
            let mut b = DMatrix::<f64>::zeros(3, 6);
            b.view_mut((0, 0), (3, 3)).copy_from(&Matrix3::identity());
            b.view_mut((0, 3), (3, 3)).copy_from(t.matrix());
            btb += b.transpose() * &b;
            bte += b.transpose() * ej;
        }
        let Ok(step) = btb.pseudo_inverse(1e-12).map(|inv| -(inv * bte)) else { break };
        g = so3::exp(&Vector3::new(step[0], step[1], step[2])) * g;
        h *= so3::exp(&Vector3::new(step[3], step[4], step[5]));
    }
    let e = residuals(&g, &h);
    (e.iter().map(|v| v.norm_squared()).sum::<f64>() / e.len() as f64).sqrt().to_degrees()
}

/// The calibrated mechanism's RMS orientation error (degrees) against the truth at the test
/// orientations, measured as `compare` and the report's `predicted_error_deg` measure it: up to
/// the rotations common to every pose, which no measurement sees.
pub fn calibration_error_up_to_common_rotations(
    session: &Session,
    calibration: &Calibration,
    tests: &[Rotation3<f64>],
) -> f64 {
    let truth = session.truth.as_ref().expect("a simulated session");
    let spm_true = truth.parameters.spm().expect("a valid truth");
    let Ok(spm) = calibration.parameters.spm() else { return f64::INFINITY };
    let (mut fitted, mut true_r) = (Vec::new(), Vec::new());
    for r in tests {
        // The joints put the rigid mechanism at `r`; the platform is where its sag (if the truth
        // has one) turns it further.
        let real = spm_true.sagged(r);
        let joints = spm_true.ik(&real).expect("test orientations are reachable");
        let Ok(f) = spm.forward(&joints) else { return f64::INFINITY };
        fitted.push(f);
        true_r.push(real);
    }
    up_to_common_rotations(&fitted, &true_r)
}

/// Simulate `config` with `seed`, calibrate at both levels (defaults) and score them against the truth.
pub fn run_session(config: &SimConfig, model: &RobotModel, seed: u64, tests: usize) -> SessionResult {
    run_session_with(config, model, seed, tests, &CalibConfig::default())
}

/// [`run_session`] with the marker-level fit's settings `settings` (its folds are turned off).
pub fn run_session_with(
    config: &SimConfig,
    model: &RobotModel,
    seed: u64,
    tests: usize,
    settings: &CalibConfig,
) -> SessionResult {
    let mut c = config.clone();
    c.seed = seed;
    let (session, _) = c.simulate(model, &mut |_| {}).expect("the simulation succeeds");
    let truth = session.truth.as_ref().expect("a simulated session");
    let spm_true = truth.parameters.spm().expect("a valid truth");
    let tests = test_orientations(&spm_true, tests, seed ^ 0x5eed);
    let markers = CalibConfig { folds: 0, ..settings.clone() };
    let fitted = calibrate(&session, model, &markers, &mut |_| {}).expect("the marker-level fit succeeds");
    let orientations = CalibConfig { fit: FitLevel::Orientations, holdout_every: 0, ..CalibConfig::default() };
    let by_orientation = calibrate(&session, model, &orientations, &mut |_| {}).ok();
    let camera = truth.parameters.camera.expect("a simulated camera");
    let gauge =
        TruthInGauge::new(&fitted.parameterisation, &truth.parameters.legs, &camera.rotation, &Rotation3::identity());
    let true_markers: Vec<Vector3<f64>> = truth.parameters.markers.iter().map(|m| m.position).collect();
    let in_gauge = TruthInGauge::for_markers(
        &fitted.parameterisation,
        &truth.parameters.legs,
        &camera,
        &truth.parameters.camera_model,
        &true_markers,
    );
    SessionResult {
        markers_deg: calibration_error(&session, &fitted, &tests),
        orientations_deg: by_orientation.as_ref().map(|c| calibration_error(&session, c, &tests)),
        nominal_deg: workspace_error(model.spm.geometry(), &spm_true, &gauge, &tests),
        // The bound of the camera model fitted (with `auto`, the one it chose).
        cramer_rao_deg: cramer_rao(&session, model, &c, &tests, fitted.parameters.camera_model.kind),
        fitted_camera: fitted.parameters.camera_model,
        observations: fitted.report.markers.as_ref().map_or(0, |m| m.observations),
        within_3_sigma: within_3_sigma(&fitted, &in_gauge.x),
    }
}

/// How many of `calibration`'s parameters with a standard error lie within three of them of
/// `truth` (the true parameters in its gauge), out of how many.
fn within_3_sigma(calibration: &Calibration, truth: &DVector<f64>) -> (usize, usize) {
    let x = &calibration.calibrated.x;
    let z: Vec<f64> = (0..x.len())
        .filter_map(|i| {
            let sigma = calibration.covariance[(i, i)].sqrt();
            (sigma.is_finite() && sigma > 0.0).then(|| ((x[i] - truth[i]) / sigma).abs())
        })
        .collect();
    (z.iter().filter(|z| **z <= 3.0).count(), z.len())
}

/// RMS over sessions of per-session RMS figures.
pub fn pooled(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.collect();
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}
