//! How well a calibration predicts data it has not seen: k-fold cross-validation over the fitted
//! observations (groups — stations, else poses — kept together), the calibrated model against the
//! nominal one with its best-fit registration, in the model's unit (mm or degrees).
//!
//! The fit without a fold is one Gauss–Newton step from the full fit, `x_f = x − H_f⁻¹ g_f`, with
//! `H_f`, `g_f` the normal equations of the other folds at `x` (weights and noise model of the full
//! fit): the full solution is a minimum of the sum over all folds, so leaving one out moves it by
//! a small step that one Newton step on a nearly linear least-squares problem takes to second
//! order (tests/markers.rs checks it against refitting). Each fold costs a solve of the free
//! parameters' normal equations (33 × 33 at the marker level with four markers) and an
//! evaluation, not a fit.

use nalgebra::{DMatrix, DVector, Rotation3};
use serde::Serialize;

use super::config::FitLevel;
use super::fit::{FitOutcome, weighted_normal_of};
use super::residuals::Residuals;

/// The error on unseen data: k-fold cross-validation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrossValidation {
    /// Folds.
    pub folds: usize,
    /// Held-out observations predicted.
    pub observations: usize,
    /// Held-out observations that the model fitted without their fold could not predict (its
    /// forward kinematics failed from every start): counted for neither model.
    pub unpredicted: usize,
    /// The fit level.
    #[serde(skip)]
    pub level: FitLevel,
    /// The unit of the errors: `mm` (markers), `px` (a pixel session's), `deg` (orientations).
    pub unit: &'static str,
    /// RMS held-out error of the nominal model with its best-fit registration.
    pub nominal_rms: f64,
    /// The same for the calibrated model.
    pub calibrated_rms: f64,
    /// Mean reduction of the squared held-out error per observation (unit²), and its standard
    /// error: the calibration is clearly better when the reduction exceeds twice its standard error.
    pub reduction: f64,
    /// Standard error of `reduction`.
    pub reduction_std_error: f64,
    /// The calibrated model predicts unseen data clearly better than the nominal one.
    pub clearly_better: bool,
    /// Standard error of the calibrated model's mean squared held-out error (unit²).
    pub calibrated_ms_std_error: f64,
    /// A rigid body's orientations, held out with its positions (which the fields above are
    /// about): the nominal and the calibrated model's RMS error (deg).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_rms_deg: Option<[f64; 2]>,
    /// Their mean reduction of the squared error per orientation (deg²), and its standard error:
    /// the calibration is clearly better when either kind's reduction exceeds twice its own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_reduction_deg2: Option<[f64; 2]>,
    /// The calibrated model's residual on each held-out observation, `(observation, residual)`:
    /// what the model check tests.
    #[serde(skip)]
    pub(crate) held_out: Vec<(usize, nalgebra::Vector3<f64>)>,
}

/// The groups (stations, else poses) of the model's observations: the most folds there can be.
pub(crate) fn groups<M: Residuals>(model: &M) -> usize {
    let mut seen = std::collections::HashSet::new();
    (0..model.len()).filter(|&j| seen.insert(model.group(j))).count()
}

/// The fold of each observation: groups (stations, else poses) dealt out in order of appearance.
pub(crate) fn fold_assignment<M: Residuals>(model: &M, k: usize) -> Vec<usize> {
    let mut groups: std::collections::HashMap<(bool, u64), usize> = std::collections::HashMap::new();
    (0..model.len())
        .map(|j| {
            let next = groups.len();
            *groups.entry(model.group(j)).or_insert(next) % k
        })
        .collect()
}

/// k-fold cross-validation of `calibrated` (parameters `free`, with `prior`) against `nominal`
/// (parameters `registration`) on `model`'s observations; `None` with fewer than two folds or
/// nothing to predict.
pub(crate) fn cross_validate<M: Residuals>(
    model: &M,
    [nominal, calibrated]: [&FitOutcome<M::Noise>; 2],
    [free, registration]: [&[bool]; 2],
    prior: Option<&(DMatrix<f64>, DVector<f64>)>,
    folds: usize,
) -> Option<CrossValidation> {
    if folds < 2 {
        return None;
    }
    let fold_of = fold_assignment(model, folds);
    let scale = model.unit_scale();
    let (mut nominal_sq, mut calibrated_sq, mut unpredicted) = (Vec::new(), Vec::new(), 0);
    // A rigid body's orientations (deg²), apart from its positions.
    let (mut nominal_turn, mut calibrated_turn) = (Vec::new(), Vec::new());
    let mut held_out = Vec::new();
    let by_fold =
        [FoldNormals::new(nominal, registration, &fold_of, folds), FoldNormals::new(calibrated, free, &fold_of, folds)];
    for fold in 0..folds {
        let rows: Vec<usize> = (0..fold_of.len()).filter(|&j| fold_of[j] == fold).collect();
        if rows.is_empty() || rows.len() == fold_of.len() {
            continue;
        }
        let test = model.subset(&rows);
        let predict = |outcome: &FitOutcome<M::Noise>, normals: &FoldNormals, prior| {
            let x = normals.leave_out(&outcome.x, fold, prior);
            // Each test pose's FDA starts from the full fit's orientation of it; where tracking
            // cannot follow, from home (the working mode by continuation).
            let warm = warm_start(model, &test, &rows, outcome);
            test.evaluate(&x, Some(&warm), false).or_else(|_| test.evaluate(&x, None, false)).ok()
        };
        match (predict(nominal, &by_fold[0], None), predict(calibrated, &by_fold[1], prior)) {
            (Some(n), Some(c)) => {
                for ((&j, a), b) in rows.iter().zip(&n.residuals).zip(&c.residuals) {
                    match model.is_orientation(j) {
                        true => {
                            nominal_turn.push(a.norm().to_degrees().powi(2));
                            calibrated_turn.push(b.norm().to_degrees().powi(2));
                        }
                        false => {
                            nominal_sq.push((a.norm() * scale).powi(2));
                            calibrated_sq.push((b.norm() * scale).powi(2));
                        }
                    }
                }
                held_out.extend(rows.iter().copied().zip(c.residuals.iter().copied()));
            }
            _ => unpredicted += rows.len(),
        }
    }
    let n = nominal_sq.len();
    if n == 0 {
        return None;
    }
    let [mean, se] = mean_reduction(&nominal_sq, &calibrated_sq);
    let turn = (!nominal_turn.is_empty()).then(|| mean_reduction(&nominal_turn, &calibrated_turn));
    let rms = |v: &[f64]| (v.iter().sum::<f64>() / v.len() as f64).sqrt();
    let cal_mean = calibrated_sq.iter().sum::<f64>() / n as f64;
    let cal_var = calibrated_sq.iter().map(|v| (v - cal_mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64;
    Some(CrossValidation {
        folds,
        observations: n + nominal_turn.len(),
        unpredicted,
        level: model.level(),
        unit: model.unit(),
        nominal_rms: rms(&nominal_sq),
        calibrated_rms: rms(&calibrated_sq),
        reduction: mean,
        reduction_std_error: se,
        clearly_better: mean > 2.0 * se || turn.is_some_and(|[m, s]| m > 2.0 * s),
        calibrated_ms_std_error: (cal_var / n as f64).sqrt(),
        orientation_rms_deg: turn.map(|_| [rms(&nominal_turn), rms(&calibrated_turn)]),
        orientation_reduction_deg2: turn,
        held_out,
    })
}

/// The mean reduction of the squared error per observation from `nominal` to `calibrated`, and its
/// standard error.
fn mean_reduction(nominal: &[f64], calibrated: &[f64]) -> [f64; 2] {
    let n = nominal.len();
    let d: Vec<f64> = nominal.iter().zip(calibrated).map(|(a, b)| a - b).collect();
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64;
    [mean, (var / n as f64).sqrt()]
}

/// The full fit's orientation of each of `test`'s poses (`rows` of `model`): where each held-out
/// pose's forward kinematics starts.
pub(super) fn warm_start<M: Residuals, N>(
    model: &M,
    test: &M,
    rows: &[usize],
    outcome: &FitOutcome<N>,
) -> Vec<Rotation3<f64>> {
    let mut warm = Vec::with_capacity(test.poses());
    for (a, &full) in rows.iter().enumerate() {
        if warm.len() == test.pose_of(a) {
            warm.push(outcome.evaluation.orientations[model.pose_of(full)]);
        }
    }
    warm
}

/// The normal equations of a fit split by fold: `H = Σ_k H_k`, `g = Σ_k g_k` over the free
/// parameters, each fold's from its own rows of the whitened, weighted Jacobian.
pub(super) struct FoldNormals {
    /// The free parameters' indices, in the order of the normal equations' rows.
    pub(super) free: Vec<usize>,
    h: Vec<DMatrix<f64>>,
    g: Vec<DVector<f64>>,
}

impl FoldNormals {
    pub(super) fn new<N>(outcome: &FitOutcome<N>, free: &[bool], fold_of: &[usize], folds: usize) -> Self {
        let free: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
        let (h, g) = (0..folds)
            .map(|fold| {
                let rows: Vec<usize> = (0..fold_of.len()).filter(|&j| fold_of[j] == fold).collect();
                weighted_normal_of(&outcome.evaluation, &outcome.weighting, &free, &rows)
            })
            .unzip();
        FoldNormals { free, h, g }
    }

    /// `H` and `g` of every fold but `fold` at `x`, with the weak prior `(Λ, x₀)` on the
    /// unidentifiable directions when the fit had one.
    pub(super) fn without(
        &self,
        fold: usize,
        x: &DVector<f64>,
        prior: Option<&(DMatrix<f64>, DVector<f64>)>,
    ) -> (DMatrix<f64>, DVector<f64>) {
        let mut h: DMatrix<f64> = self.h.iter().enumerate().filter(|(k, _)| *k != fold).map(|(_, h)| h).sum();
        let mut g: DVector<f64> = self.g.iter().enumerate().filter(|(k, _)| *k != fold).map(|(_, g)| g).sum();
        if let Some((lambda, x0)) = prior {
            let d = x - x0;
            for (a, &i) in self.free.iter().enumerate() {
                g[a] += (lambda.row(i) * &d)[0];
                for (b, &k) in self.free.iter().enumerate() {
                    h[(a, b)] += lambda[(i, k)];
                }
            }
        }
        (h, g)
    }

    /// The parameters fitted without fold `fold`: one Gauss–Newton step from `x`.
    fn leave_out(&self, x: &DVector<f64>, fold: usize, prior: Option<&(DMatrix<f64>, DVector<f64>)>) -> DVector<f64> {
        let (h, g) = self.without(fold, x, prior);
        let mut moved = x.clone();
        if let Some(step) = h.cholesky().map(|c| c.solve(&g)) {
            for (a, &i) in self.free.iter().enumerate() {
                moved[i] -= step[a];
            }
        }
        moved
    }
}
