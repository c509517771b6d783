//! What the data say about the fitted parameters: the covariance, each parameter's standard error
//! and significance, strong correlations, the identifiability of the free directions, and the
//! uncertainty it leaves in the predicted orientations.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::config::CalibConfig;
use super::fit::{FitOutcome, weighted_normal};
use super::identify::{Identifiability, analyse_gram};
use super::params::Parameterisation;
use crate::math::stats::Stats;

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
    let w = &outcome.weighting;
    let m = outcome.evaluation.residuals.len();
    let chi2: f64 = outcome
        .evaluation
        .residuals
        .iter()
        .enumerate()
        .map(|(j, r)| w.weights[j] * w.whiten(j, r).norm_squared())
        .sum();
    let dof = (3 * m).saturating_sub(idx.len()).max(1) as f64;
    let inv = if h.iter().all(|x| x.is_finite()) {
        h.clone().pseudo_inverse(1e-14 * h.amax()).unwrap_or_else(|_| DMatrix::zeros(idx.len(), idx.len()))
    } else {
        DMatrix::from_element(idx.len(), idx.len(), f64::NAN)
    };
    let mut full = DMatrix::zeros(n, n);
    for (a, &i) in idx.iter().enumerate() {
        for (b, &k) in idx.iter().enumerate() {
            full[(i, k)] = inv[(a, b)] * chi2 / dof;
        }
    }
    full
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

/// Uncertainty (1σ, RMS over the three axes, degrees) of each residual's prediction: the
/// propagation `J_j Cov J_jᵀ` of the parameter covariance through the residual Jacobian. For the
/// orientation-level fit this is each pose's predicted orientation as the camera sees it,
/// `R_CB R_j Aᵀ`; it carries the strong correlations between axis tilts and the camera rotation
/// that a base-frame figure would ignore.
pub(crate) fn residual_uncertainty<N>(outcome: &FitOutcome<N>, cov: &DMatrix<f64>) -> Option<Stats> {
    let jac = outcome.evaluation.jacobian.as_ref()?;
    let values: Vec<f64> = (0..outcome.evaluation.residuals.len())
        .map(|j| {
            let block = jac.rows(3 * j, 3);
            ((block * cov * block.transpose()).trace() / 3.0).max(0.0).sqrt().to_degrees()
        })
        .collect();
    Stats::of(&values)
}

/// Uncertainty (1σ, RMS over the three axes, degrees) of each pose's predicted orientation in B:
/// the parameter covariance propagated through `∂ω/∂x`.
pub(crate) fn orientation_uncertainty<N>(outcome: &FitOutcome<N>, cov: &DMatrix<f64>) -> Option<Stats> {
    let sens = outcome.evaluation.orientation_jacobians.as_ref()?;
    let values: Vec<f64> =
        sens.iter().map(|s| ((s * cov * s.transpose()).trace() / 3.0).max(0.0).sqrt().to_degrees()).collect();
    Stats::of(&values)
}
