//! What the data say about the fitted parameters: the covariance, each parameter's standard error
//! and significance, strong correlations, the identifiability of the free directions, and the
//! uncertainty it leaves in the predicted orientations.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::config::CalibConfig;
use super::fit::{FitOutcome, weighted_normal};
use super::identify::{Identifiability, analyse_gram};
use super::parameterisation::Parameterisation;
use crate::math::so3::WORKSPACE_BANDS_DEG;

/// One angle parameter of the report, in degrees (`change` is the departure from nominal; the
/// marker level reports `t_CB`, the markers' positions and the latency apart).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterReport {
    /// Parameter name, e.g. `leg2.alpha1`.
    pub name: String,
    /// Departure from nominal, degrees.
    pub change_deg: f64,
    /// Standard error, degrees (`None` when frozen; a regularised parameter keeps its own).
    pub std_error_deg: Option<f64>,
    /// Held at its initial value.
    pub frozen: bool,
    /// Ended at its bound (no standard error: the data want it further).
    pub at_bound: bool,
}

/// A strong correlation between two fitted parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Correlation {
    /// First parameter.
    pub a: String,
    /// Second parameter.
    pub b: String,
    /// Correlation coefficient.
    pub rho: f64,
}

/// `JᵀWJ` of an outcome over every parameter (whitened, weighted), without copying the Jacobian.
fn weighted_gram<N>(outcome: &FitOutcome<N>) -> DMatrix<f64> {
    let all: Vec<usize> = (0..outcome.evaluation.jacobian.as_ref().map_or(0, |j| j.ncols())).collect();
    weighted_normal(&outcome.evaluation, &outcome.weighting, &all).0
}

/// The identifiability of the `free` parameters at `start` (its Jacobian and weighting).
pub(crate) fn identifiability_at<N>(
    p: &Parameterisation,
    start: &FitOutcome<N>,
    free: &[bool],
    config: &CalibConfig,
) -> Identifiability {
    let free_idx: Vec<usize> = (0..p.len()).filter(|&i| free[i]).collect();
    let names: Vec<String> = p.entries.iter().map(|e| e.name.clone()).collect();
    analyse_gram(&weighted_gram(start), &free_idx, &names, config.min_singular_ratio)
}

/// `σ̂² (J̃ᵀ W J̃ + Λ)⁻¹` over the free parameters, embedded in the full vector (zero rows for the
/// others); `σ̂²` is the weighted whitened residual variance per degree of freedom (≈ 1 when the
/// whitening fits the noise).
pub(crate) fn covariance<N>(outcome: &FitOutcome<N>, free: &[bool], prior: Option<&DMatrix<f64>>) -> DMatrix<f64> {
    let n = free.len();
    let idx: Vec<usize> = (0..n).filter(|&i| free[i]).collect();
    let full_h = weighted_gram(outcome);
    let mut h = DMatrix::zeros(idx.len(), idx.len());
    for (a, &i) in idx.iter().enumerate() {
        for (b, &k) in idx.iter().enumerate() {
            h[(a, b)] = full_h[(i, k)] + prior.map_or(0.0, |l| l[(i, k)]);
        }
    }
    let scale = residual_scale(outcome, idx.len());
    let inv = if h.iter().all(|x| x.is_finite()) {
        crate::math::linalg::symmetric_pseudo_inverse(&h, 1e-14)
            .unwrap_or_else(|| DMatrix::from_element(idx.len(), idx.len(), f64::NAN))
    } else {
        DMatrix::from_element(idx.len(), idx.len(), f64::NAN)
    };
    let mut full = DMatrix::zeros(n, n);
    for (a, &i) in idx.iter().enumerate() {
        for (b, &k) in idx.iter().enumerate() {
            full[(i, k)] = inv[(a, b)] * scale;
        }
    }
    full
}

/// Releasing held parameter `i`: the change a fit with it free as well would make (one
/// Gauss–Newton step from the solution, the `free` parameters re-adjusting with it) and the
/// standard error it would have — a score test of holding it. `None` when the data cannot tell it
/// from the free parameters.
pub(crate) fn released<N>(outcome: &FitOutcome<N>, free: &[bool], i: usize) -> Option<(f64, f64)> {
    let idx: Vec<usize> = (0..free.len()).filter(|&k| free[k] || k == i).collect();
    let a = idx.iter().position(|&k| k == i)?;
    let (hessian, gradient) = weighted_normal(&outcome.evaluation, &outcome.weighting, &idx);
    let inverse = hessian.cholesky()?.inverse();
    let change = -(inverse.row(a) * &gradient)[(0, 0)];
    let variance = inverse[(a, a)] * residual_scale(outcome, idx.len());
    (variance.is_finite() && variance > 0.0).then(|| (change, variance.sqrt()))
}

/// `σ̂²`: the weighted whitened residual variance per degree of freedom (`free` parameters).
pub(crate) fn residual_scale<N>(outcome: &FitOutcome<N>, free: usize) -> f64 {
    let w = &outcome.weighting;
    let chi2: f64 = outcome
        .evaluation
        .residuals
        .iter()
        .enumerate()
        .map(|(j, r)| w.weights[j] * w.whiten(j, r).norm_squared())
        .sum();
    let dof = w.total_rows().saturating_sub(free).max(1) as f64;
    chi2 / dof
}

/// The standard error of parameter `i`, `None` when it is not free.
pub(crate) fn std_error(cov: &DMatrix<f64>, free: &[bool], i: usize) -> Option<f64> {
    free[i].then(|| cov[(i, i)].max(0.0).sqrt())
}

/// Every parameter with its change and standard error, converted as angles to degrees (the marker
/// level keeps only the angles).
pub(crate) fn parameter_reports(
    p: &Parameterisation,
    x: &DVector<f64>,
    cov: &DMatrix<f64>,
    free: &[bool],
) -> Vec<ParameterReport> {
    p.entries
        .iter()
        .enumerate()
        .map(|(i, e)| ParameterReport {
            name: e.name.clone(),
            change_deg: x[i].to_degrees(),
            std_error_deg: std_error(cov, free, i).map(f64::to_degrees),
            frozen: !free[i] && !p.at_bound(x, i),
            at_bound: p.at_bound(x, i),
        })
        .collect()
}

/// The platform's sag's standard error (degrees per unit of arm) when it was fitted.
pub(crate) fn platform_sag_std_error_deg(p: &Parameterisation, cov: &DMatrix<f64>, free: &[bool]) -> Option<f64> {
    let i = p.entries.iter().position(|e| e.kind == super::parameterisation::Kind::PlatformSag)?;
    std_error(cov, free, i).map(f64::to_degrees)
}

/// The parameters whose change from nominal is under twice its standard error.
pub(crate) fn not_significant(reports: &[ParameterReport]) -> Vec<String> {
    reports
        .iter()
        .filter(|r| r.std_error_deg.is_some_and(|se| r.change_deg.abs() < 2.0 * se))
        .map(|r| r.name.clone())
        .collect()
}

/// Parameter pairs whose correlation is at least `threshold` in magnitude, strongest first.
pub(crate) fn correlations(p: &Parameterisation, cov: &DMatrix<f64>, threshold: f64) -> Vec<Correlation> {
    let mut out = Vec::new();
    for i in 0..p.len() {
        for k in (i + 1)..p.len() {
            let d = (cov[(i, i)] * cov[(k, k)]).sqrt();
            if d > 0.0 && (cov[(i, k)] / d).abs() >= threshold {
                out.push(Correlation {
                    a: p.entries[i].name.clone(),
                    b: p.entries[k].name.clone(),
                    rho: cov[(i, k)] / d,
                });
            }
        }
    }
    out.sort_by(|a, b| b.rho.abs().total_cmp(&a.rho.abs()));
    out
}

/// The expected error of the calibrated model on an unseen pose of the session's workspace, from
/// the parameter covariance: the one "how good is my model" figure of every view of the report.
///
/// In degrees (`predicted_error_deg`): the RMS angle between the orientation the calibrated FDA
/// gives for a pose's joints and the true one, measured as `compare` measures it — up to the
/// rotations common to every pose that no measurement sees (a rotation of the base, carried by
/// the camera registration; one of the platform, carried by the markers or the reference pose),
/// which are projected out. In millimetres (`predicted_error_mm`, marker level): the RMS distance
/// between where the calibrated model, registration and markers put a marker and where it truly is.
/// Neither includes the camera's noise.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PredictedError {
    /// Expected RMS over the session's poses (degrees or mm): an unseen pose drawn from the
    /// session's own workspace — or, for degrees, from `workspace` when the config names one.
    pub rms: f64,
    /// The workspace the orientation error is predicted over (the config's `workspace`); `None`:
    /// the session's own poses.
    pub workspace: Option<super::config::PredictionWorkspace>,
    /// The largest per-pose figure.
    pub max: f64,
    /// Where the RMS error of this calibration lies with 90% probability (5th and 95th
    /// percentiles): the parameter error is one draw, and the RMS it makes over the workspace is a
    /// weighted χ² of few effective degrees of freedom (`effective_dof`), matched by a scaled χ²
    /// (Satterthwaite; percentiles by Wilson–Hilferty).
    pub interval_90: [f64; 2],
    /// Effective degrees of freedom of the squared error, `tr(QΣ)² / tr((QΣ)²)` (`Q` the mean of
    /// the per-pose `JᵀJ`, `Σ` the covariance): how many independent parameter directions share it.
    pub effective_dof: f64,
    /// `(pose, expected RMS)` of each pose (the RMS over its markers at the marker level).
    pub per_pose: Vec<(u64, f64)>,
    /// The map over the workspace: the poses' figures by band of tilt and of |yaw| (10° bands),
    /// where to add poses.
    pub by_region: Vec<RegionError>,
}

/// The predicted error over one band of tilt and |yaw| of the session's poses.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RegionError {
    /// Tilt band, degrees (`[30, inf]` for the last).
    pub tilt_deg: [f64; 2],
    /// |Yaw| band, degrees.
    pub yaw_deg: [f64; 2],
    /// Poses in it.
    pub poses: usize,
    /// RMS of their predicted errors.
    pub rms: f64,
    /// The worst of them.
    pub worst: f64,
}

/// The per-pose figures `values` of poses at `orientations`, by band of tilt and |yaw|.
fn by_region(orientations: &[nalgebra::Rotation3<f64>], values: &[f64]) -> Vec<RegionError> {
    let mut cells = [[(0.0f64, 0.0f64, 0usize); 4]; 4];
    for (r, v) in orientations.iter().zip(values) {
        let (tilt, yaw) = crate::math::so3::workspace_band(r);
        let cell = &mut cells[tilt][yaw];
        *cell = (cell.0 + v * v, cell.1.max(*v), cell.2 + 1);
    }
    let mut out = Vec::new();
    for (t, row) in cells.iter().enumerate() {
        for (y, &(sum, worst, poses)) in row.iter().enumerate() {
            if poses > 0 {
                out.push(RegionError {
                    tilt_deg: [WORKSPACE_BANDS_DEG[t], WORKSPACE_BANDS_DEG[t + 1]],
                    yaw_deg: [WORKSPACE_BANDS_DEG[y], WORKSPACE_BANDS_DEG[y + 1]],
                    poses,
                    rms: (sum / poses as f64).sqrt(),
                    worst,
                });
            }
        }
    }
    out
}

impl PredictedError {
    /// From the per-pose figures, the mean-square `q_cov = QΣ` (its trace is the mean square in
    /// the model's unit²) and the factor to the reported unit.
    fn of(per_pose: Vec<(u64, f64)>, q_cov: &DMatrix<f64>, unit: f64) -> Option<Self> {
        let mean_square = q_cov.trace();
        let squares = (q_cov * q_cov).trace();
        if per_pose.is_empty() || !mean_square.is_finite() || mean_square <= 0.0 || squares <= 0.0 {
            return None;
        }
        let k = mean_square * mean_square / squares;
        // Wilson–Hilferty: χ²_k quantile ≈ k (1 − 2/(9k) + z √(2/(9k)))³.
        let quantile = |z: f64| {
            let a = 2.0 / (9.0 * k);
            (1.0 - a + z * a.sqrt()).max(0.0).powi(3)
        };
        let rms = mean_square.sqrt() * unit;
        let max = per_pose.iter().map(|(_, v)| *v).fold(0.0, f64::max);
        Some(PredictedError {
            rms,
            max,
            interval_90: [rms * quantile(-1.645).sqrt(), rms * quantile(1.645).sqrt()],
            effective_dof: k,
            workspace: None,
            per_pose,
            by_region: Vec::new(),
        })
    }
}

/// The predicted orientation error (degrees) of the poses with sensitivities `sens` (`∂ω/∂x` in B,
/// 3 × N, one per pose), orientations `orientations` and ids `poses`, under `cov`, with the
/// columns `fda` of the FDA's own parameters (a latency is not the FDA's). The first-order error
/// at pose j is `δω_j = S_j δx`; a base rotation ψ_B and a platform rotation ψ_P common to every
/// pose add `ψ_B + R_j ψ_P`, and their least-squares fit over the poses is projected out:
/// `S̃_j = S_j − [I R_j] C`, `C = (Σ Bᵀ B)⁺ Σ Bᵀ S`, and the per-pose mean square is
/// `tr(S̃_j Cov S̃_jᵀ)`.
pub(crate) fn predicted_orientation_error(
    sens: &[DMatrix<f64>],
    orientations: &[nalgebra::Rotation3<f64>],
    poses: &[u64],
    fda: &[bool],
    cov: &DMatrix<f64>,
) -> Option<PredictedError> {
    if sens.is_empty() || sens.len() != poses.len() {
        return None;
    }
    let n = cov.ncols();
    let common = common_rotations(sens, orientations, fda)?;
    let mut q = DMatrix::<f64>::zeros(n, n);
    // One pose's projected sensitivity at a time: an hour-long recording has 54,000 of them.
    let per_pose_ms: Vec<f64> = sens
        .iter()
        .zip(orientations)
        .map(|(s, r)| {
            let s = common.project(s, r);
            q += s.transpose() * &s;
            (&s * cov * s.transpose()).trace().max(0.0)
        })
        .collect();
    let per_pose: Vec<(u64, f64)> =
        poses.iter().zip(&per_pose_ms).map(|(&p, ms)| (p, ms.sqrt().to_degrees())).collect();
    let values: Vec<f64> = per_pose.iter().map(|(_, v)| *v).collect();
    let mut predicted = PredictedError::of(per_pose, &(q / per_pose_ms.len() as f64 * cov), 1f64.to_degrees())?;
    predicted.by_region = by_region(orientations, &values);
    Some(predicted)
}

/// How to project out of the orientation sensitivities `sens` (`∂ω/∂x` in B, 3 × N, one per pose
/// at `orientations`, restricted to the columns `fda`) the rotations common to every pose:
/// `S̃_j = S_j − [I R_j] C`, `C = (Σ Bᵀ B)⁺ Σ Bᵀ S` — a base rotation ψ_B and a platform rotation
/// ψ_P common to every pose move pose j by `ψ_B + R_j ψ_P`, and no measurement sees them (the
/// camera registration and the markers carry them). `None` when the lengths differ or the
/// projection fails.
pub(crate) fn common_rotations<'a>(
    sens: &[DMatrix<f64>],
    orientations: &[nalgebra::Rotation3<f64>],
    fda: &'a [bool],
) -> Option<CommonRotations<'a>> {
    if sens.is_empty() || sens.len() != orientations.len() {
        return None;
    }
    let n = sens[0].ncols();
    let (mut btb, mut bts) = (DMatrix::<f64>::zeros(6, 6), DMatrix::<f64>::zeros(6, n));
    for (s, r) in sens.iter().zip(orientations) {
        let b = common_design(r);
        btb += b.transpose() * &b;
        bts += b.transpose() * masked(s, fda);
    }
    let common = crate::math::linalg::symmetric_pseudo_inverse(&btb, 1e-12)? * bts;
    Some(CommonRotations { common, fda })
}

/// The rotations common to every pose, fitted to the sensitivities: `C` of
/// [`common_rotations`], with the columns it keeps.
pub(crate) struct CommonRotations<'a> {
    common: DMatrix<f64>,
    fda: &'a [bool],
}

impl CommonRotations<'_> {
    /// `S̃ = S − [I R] C` of one pose (`s` its sensitivity, `r` its orientation).
    pub(crate) fn project(&self, s: &DMatrix<f64>, r: &nalgebra::Rotation3<f64>) -> DMatrix<f64> {
        masked(s, self.fda) - common_design(r) * &self.common
    }
}

/// `s` with the columns `fda` does not keep zeroed.
fn masked(s: &DMatrix<f64>, fda: &[bool]) -> DMatrix<f64> {
    let mut s = s.clone();
    for (i, keep) in fda.iter().enumerate() {
        if !keep {
            s.column_mut(i).fill(0.0);
        }
    }
    s
}

/// `[I R]` (3 × 6): how a base rotation and a platform rotation move a pose at `r`.
fn common_design(r: &nalgebra::Rotation3<f64>) -> DMatrix<f64> {
    let mut b = DMatrix::<f64>::zeros(3, 6);
    b.view_mut((0, 0), (3, 3)).copy_from(&nalgebra::Matrix3::identity());
    b.view_mut((0, 3), (3, 3)).copy_from(r.matrix());
    b
}

/// The expected squared prediction error (unit², of each residual): `tr(J_j Cov J_jᵀ)`.
pub(crate) fn residual_mean_squares<N>(outcome: &FitOutcome<N>, cov: &DMatrix<f64>) -> Option<Vec<f64>> {
    let jac = outcome.evaluation.jacobian.as_ref()?;
    let m = outcome.evaluation.residuals.len();
    // `tr(J_j C J_jᵀ) = Σ (J_j C) ∘ J_j`, `J C` a chunk of rows at a time: one matrix product per
    // chunk instead of two small ones per observation (100,000 observations: 0.3 s → ~0.03 s).
    const CHUNK: usize = 1024;
    let mut out = Vec::with_capacity(m);
    for start in (0..m).step_by(CHUNK) {
        let rows = 3 * (m - start).min(CHUNK);
        let block = jac.rows(3 * start, rows);
        let product = block * cov;
        for j in 0..rows / 3 {
            let a = product.rows(3 * j, 3);
            let b = block.rows(3 * j, 3);
            out.push(a.component_mul(&b).sum().max(0.0));
        }
    }
    Some(out)
}

/// The predicted marker error (mm, or px for a pixel session's: `scale` from the residuals'
/// unit) of a marker-level fit: per observation `ms[j] = tr(J_j Cov J_jᵀ)`
/// ([`residual_mean_squares`]), grouped by the pose ids `poses` (one per observation).
pub(crate) fn predicted_marker_error<N>(
    outcome: &FitOutcome<N>,
    scale: f64,
    ms: &[f64],
    cov: &DMatrix<f64>,
    poses: &[u64],
    orientation_of: impl Fn(usize) -> nalgebra::Rotation3<f64>,
) -> Option<PredictedError> {
    if ms.is_empty() || ms.len() != poses.len() {
        return None;
    }
    let (mut order, mut rotations) = (Vec::new(), Vec::new());
    let mut sums: std::collections::HashMap<u64, (f64, usize)> = std::collections::HashMap::new();
    for (j, (&p, &v)) in poses.iter().zip(ms).enumerate() {
        let e = sums.entry(p).or_insert_with(|| {
            order.push(p);
            rotations.push(orientation_of(j));
            (0.0, 0)
        });
        e.0 += v;
        e.1 += 1;
    }
    let per_pose: Vec<(u64, f64)> = order
        .iter()
        .map(|p| {
            let (s, c) = sums[p];
            (*p, (s / c as f64).sqrt() * scale)
        })
        .collect();
    let values: Vec<f64> = per_pose.iter().map(|(_, v)| *v).collect();
    let jac = outcome.evaluation.jacobian.as_ref()?;
    let q = jac.tr_mul(jac) / ms.len() as f64;
    let mut predicted = PredictedError::of(per_pose, &(q * cov), scale)?;
    predicted.by_region = by_region(&rotations, &values);
    Some(predicted)
}
