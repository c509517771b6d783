//! `camera_model: auto`: the simplest camera model the data support.
//!
//! The candidates are nested — rigid, depth_scale, affine, projective, each with the terms of the
//! one before and more — so each is the largest, projective, with the terms it lacks held at a
//! perfect camera's values. The largest is fitted once (the same robust fit the calibration runs);
//! every candidate is then scored by k-fold cross-validation from that one fit, as
//! `validation.rs` scores the calibration: without fold `f`, the candidate's parameters are one
//! Gauss–Newton step from the projective solution `x` on the other folds' normal equations, the
//! terms it lacks moved back to a perfect camera's (`δ_h = −x_h`) and the rest re-solved
//! (`δ_m = −H_mm⁻¹ (g_m + H_mh δ_h)`), and fold `f`'s observations are predicted there. A
//! candidate costs a solve per fold and one evaluation of the observations, no fit: `auto` costs
//! one fit of the projective model more than naming its choice, which the calibration then runs
//! exactly as if it had been named (so `auto` gives what naming its choice gives, bit for bit).
//! One step from the largest model's solution is what nested least-squares problems need: the
//! problem is nearly linear over the camera terms' few percent, and where a candidate is far
//! worse (a rigid fit of a camera 2% long) its score, if anything a little high, is far from the
//! others anyway.
//!
//! The choice is the one-standard-error rule (Breiman et al., *Classification and Regression
//! Trees*, 1984; Hastie et al., *The Elements of Statistical Learning*, §7.10): the simplest
//! candidate whose held-out mean squared error exceeds the best one's by at most one standard
//! error of the difference. Each held-out residual is weighed by the camera's noise (whitened by
//! the projective fit's noise model, as the fit weighs it: the held-out log-likelihood up to
//! constants), so that the precise lateral components count for what they tell, not the depth
//! noise three times their size; gross errors are left out. The difference is paired — the same
//! held-out observations — and its standard error is taken over poses (stations), whose
//! observations share an orientation and are not independent. A bigger model must so earn its
//! terms: on a perfect camera its extra terms fit noise and rarely beat the rigid one by a
//! standard error. (Scored in plain millimetres instead, the choice found the study's projective
//! camera in 46 of 50 sessions and a camera 0.3% long in 44; weighed, in 50 of 50 each, with the
//! same 49 of 50 rigid choices on a perfect camera.) The report shows each candidate's
//! cross-validated RMS in millimetres beside the choice.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::fit::FitOutcome;
use super::parameterisation::Kind;
use super::residuals::Residuals;
use super::validation::{FoldNormals, fold_assignment, warm_start};
use crate::model::CameraModelKind;

/// Which camera model `camera_model: auto` chose, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraModelChoice {
    /// The model chosen (and fitted).
    pub chosen: CameraModelKind,
    /// Folds of the cross-validation that scored the candidates (0: there was no choice to make).
    pub folds: usize,
    /// Every candidate with its score, simplest first (empty when there was no choice to make).
    pub candidates: Vec<CameraCandidate>,
    /// The choice and its reason in one sentence, as the text report and the parameters file say it.
    pub summary: String,
}

/// One candidate camera model of `auto`, scored on unseen poses.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraCandidate {
    /// The model.
    pub model: CameraModelKind,
    /// Its cross-validated RMS marker error, mm.
    pub cross_validated_rms_mm: f64,
    /// Its held-out mean squared whitened error per observation (each residual weighed by the
    /// camera's noise: 3 for a model that predicts to the noise), what the choice compares.
    pub whitened_ms: f64,
    /// `whitened_ms` less the best candidate's: within one standard error of it, the data cannot
    /// tell this candidate from the best.
    pub excess_whitened_ms: f64,
    /// The standard error of `excess_whitened_ms`.
    pub excess_whitened_ms_std_error: f64,
}

impl CameraModelChoice {
    /// No choice to make: `chosen`, for the reason `why`.
    pub(crate) fn without_choice(chosen: CameraModelKind, why: &str) -> Self {
        CameraModelChoice { chosen, folds: 0, candidates: Vec::new(), summary: format!("auto: {why}") }
    }

    /// The simplest candidate within one standard error of the best.
    fn of(folds: usize, candidates: Vec<CameraCandidate>) -> Self {
        let within = |c: &&CameraCandidate| c.excess_whitened_ms <= c.excess_whitened_ms_std_error;
        let chosen = candidates.iter().find(within).map_or(CameraModelKind::Rigid, |c| c.model);
        let rms = |c: &CameraCandidate| c.cross_validated_rms_mm;
        let others: Vec<String> = candidates
            .iter()
            .filter(|c| c.model != chosen)
            .enumerate()
            .map(|(i, c)| format!("{} {:.4}{}", c.model.name(), rms(c), if i == 0 { " mm" } else { "" }))
            .collect();
        let own = candidates.iter().find(|c| c.model == chosen).map_or(f64::NAN, rms);
        let summary = format!(
            "auto: cross-validated {own:.4} mm over {folds} folds; {} — the simplest within one standard error of the \
             best, errors weighed by the camera's noise",
            others.join(", ")
        );
        CameraModelChoice { chosen, folds, candidates, summary }
    }
}

/// The most observations the choice fits: beyond, every k-th pose (station) of the session, spread
/// over all of it. Its power is then far beyond what the camera errors that matter need (a depth
/// error of 0.3% is found in 50 of 50 sessions of 750 observations), and a camera error too small
/// to show in 4,000 observations biases the mechanism by less than the statistical error even of
/// 100,000 (it scales alike with the data), while the choice costs a fixed amount however long
/// the session.
pub(crate) const MOST_OBSERVATIONS: usize = 4_000;

/// The rows of `problem` the choice fits: every k-th group (station, else pose) in order of
/// appearance, k the smallest that keeps them within `most`; `None` when every row fits.
pub(crate) fn subsample<M: Residuals>(problem: &M, most: usize) -> Option<Vec<usize>> {
    let n = problem.len();
    if n <= most {
        return None;
    }
    let k = n.div_ceil(most.max(1));
    let mut order: std::collections::HashMap<(bool, u64), usize> = std::collections::HashMap::new();
    let rows = (0..n)
        .filter(|&j| {
            let next = order.len();
            (*order.entry(problem.group(j)).or_insert(next)).is_multiple_of(k)
        })
        .collect();
    Some(rows)
}

/// Choose among the nested camera models from `outcome`, the fit of the projective model to
/// `problem` (free parameters `free`, weak `prior` as the fit had it), by `folds`-fold
/// cross-validation; observations beyond `gross_sigmas` robust standard deviations are not
/// scored. `None` when nothing could be predicted.
pub(crate) fn choose<M: Residuals>(
    problem: &M,
    outcome: &FitOutcome<M::Noise>,
    free: &[bool],
    prior: Option<&(DMatrix<f64>, DVector<f64>)>,
    folds: usize,
    gross_sigmas: f64,
) -> Option<CameraModelChoice> {
    let fold_of = fold_assignment(problem, folds);
    let normals = FoldNormals::new(outcome, free, &fold_of, folds);
    let p = problem.parameterisation();
    // Per candidate, the squared held-out error of each observation scored (in the model's unit,
    // and whitened by the fit's noise model), in one order.
    let mut squared: Vec<Vec<f64>> = vec![Vec::new(); CameraModelKind::ALL.len()];
    let mut whitened = squared.clone();
    let mut scored: Vec<usize> = Vec::new();
    let scale = problem.unit_scale();
    let gross = |j: usize| {
        let w = &outcome.weighting;
        w.whiten(j, &outcome.evaluation.residuals[j]).norm() / w.sigma > gross_sigmas
    };
    for fold in 0..folds {
        let rows: Vec<usize> = (0..fold_of.len()).filter(|&j| fold_of[j] == fold).collect();
        if rows.is_empty() || rows.len() == fold_of.len() {
            continue;
        }
        let test = problem.subset(&rows);
        let warm = warm_start(problem, &test, &rows, outcome);
        let predicted: Option<Vec<_>> = CameraModelKind::ALL
            .iter()
            .map(|kind| {
                let held =
                    |i: usize| matches!(p.entries[i].kind, Kind::CameraTerm { term } if !kind.terms().contains(&term));
                let x = leave_out_holding(&normals, prior, &outcome.x, fold, &held);
                test.evaluate(&x, Some(&warm), false).or_else(|_| test.evaluate(&x, None, false)).ok()
            })
            .collect();
        let Some(predicted) = predicted else { continue };
        for (a, &j) in rows.iter().enumerate().filter(|(_, j)| !gross(**j)) {
            scored.push(j);
            for (k, evaluation) in predicted.iter().enumerate() {
                let r = evaluation.residuals[a];
                squared[k].push((r.norm() * scale).powi(2));
                whitened[k].push(outcome.weighting.whiten(j, &r).norm_squared());
            }
        }
    }
    if scored.is_empty() {
        return None;
    }
    let groups: Vec<(bool, u64)> = scored.iter().map(|&j| problem.group(j)).collect();
    let mean = |v: &Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
    let scores: Vec<f64> = whitened.iter().map(mean).collect();
    let best = (0..scores.len()).min_by(|&a, &b| scores[a].total_cmp(&scores[b]))?;
    let candidates = CameraModelKind::ALL
        .iter()
        .enumerate()
        .map(|(k, &model)| {
            let (excess, std_error) = paired_excess(&whitened[k], &whitened[best], &groups);
            CameraCandidate {
                model,
                cross_validated_rms_mm: mean(&squared[k]).sqrt(),
                whitened_ms: scores[k],
                excess_whitened_ms: excess,
                excess_whitened_ms_std_error: std_error,
            }
        })
        .collect();
    Some(CameraModelChoice::of(folds, candidates))
}

/// The mean of `a − b` per observation and its standard error over the groups the observations
/// belong to (a group's observations are not independent: the error is that of a ratio of sums
/// over independent groups).
fn paired_excess(a: &[f64], b: &[f64], groups: &[(bool, u64)]) -> (f64, f64) {
    let mut totals: std::collections::HashMap<(bool, u64), (f64, f64)> = std::collections::HashMap::new();
    for ((x, y), g) in a.iter().zip(b).zip(groups) {
        let t = totals.entry(*g).or_insert((0.0, 0.0));
        t.0 += x - y;
        t.1 += 1.0;
    }
    let n = a.len() as f64;
    let mean = a.iter().zip(b).map(|(x, y)| x - y).sum::<f64>() / n;
    let count = totals.len() as f64;
    // Var(Σ_g (d_g − mean · n_g)) estimated from the groups, with the small-sample factor G/(G−1).
    let spread: f64 = totals.values().map(|(d, m)| (d - mean * m).powi(2)).sum();
    let std_error = (spread * count / (count - 1.0).max(1.0)).sqrt() / n;
    (mean, std_error)
}

/// The parameters fitted without fold `fold` with the parameters `held` picks at zero (a perfect
/// camera's terms: the fit started them there): one constrained Gauss–Newton step from `x` on the
/// other folds' normal equations. Where the step cannot be solved, the held terms alone move.
fn leave_out_holding(
    normals: &FoldNormals,
    prior: Option<&(DMatrix<f64>, DVector<f64>)>,
    x: &DVector<f64>,
    fold: usize,
    held: &dyn Fn(usize) -> bool,
) -> DVector<f64> {
    let (h, g) = normals.without(fold, x, prior);
    let free = &normals.free;
    let n = free.len();
    let fixed: Vec<bool> = free.iter().map(|&i| held(i)).collect();
    let shift = DVector::from_fn(n, |a, _| if fixed[a] { -x[free[a]] } else { 0.0 });
    let rhs = -(g + &h * &shift);
    let moving: Vec<usize> = (0..n).filter(|&a| !fixed[a]).collect();
    let h_mm = DMatrix::from_fn(moving.len(), moving.len(), |a, b| h[(moving[a], moving[b])]);
    let rhs_m = DVector::from_fn(moving.len(), |a, _| rhs[moving[a]]);
    let step = h_mm.cholesky().map(|c| c.solve(&rhs_m));
    let mut moved = x.clone();
    for (a, &i) in free.iter().enumerate() {
        moved[i] += shift[a];
    }
    if let Some(step) = step {
        for (a, &m) in moving.iter().enumerate() {
            moved[free[m]] += step[a];
        }
    }
    moved
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(model: CameraModelKind, rms: f64, excess: f64, se: f64) -> CameraCandidate {
        let whitened_ms = 3.0 + excess;
        CameraCandidate {
            model,
            cross_validated_rms_mm: rms,
            whitened_ms,
            excess_whitened_ms: excess,
            excess_whitened_ms_std_error: se,
        }
    }

    #[test]
    fn the_simplest_candidate_within_one_standard_error_of_the_best_is_chosen() {
        use CameraModelKind::*;
        let scores = |depth_excess: f64| {
            vec![
                candidate(Rigid, 1.23, 0.70, 0.05),
                candidate(DepthScale, 0.91, depth_excess, 0.004),
                candidate(Affine, 0.91, 0.001, 0.002),
                candidate(Projective, 0.909, 0.0, 0.0),
            ]
        };
        let choice = CameraModelChoice::of(5, scores(0.003));
        assert_eq!(choice.chosen, DepthScale);
        assert_eq!(
            choice.summary,
            "auto: cross-validated 0.9100 mm over 5 folds; rigid 1.2300 mm, affine 0.9100, projective 0.9090 — the \
             simplest within one standard error of the best, errors weighed by the camera's noise"
        );
        // Beyond one standard error the depth scale is not enough: the next model within is.
        assert_eq!(CameraModelChoice::of(5, scores(0.005)).chosen, Affine);
    }

    #[test]
    fn the_paired_standard_error_counts_groups_not_observations() {
        // Two observations a group, each group's pair alike: the error is that of 3 groups.
        let a = [2.0, 2.0, 1.0, 1.0, 3.0, 3.0];
        let b = [0.0; 6];
        let groups = [(false, 1), (false, 1), (false, 2), (false, 2), (false, 3), (false, 3)];
        let (mean, se) = paired_excess(&a, &b, &groups);
        assert!((mean - 2.0).abs() < 1e-15);
        // Group totals 4, 2, 6 (mean 2 per observation, 4 per group): deviations 0, −2, 2;
        // Σ = 8, × 3/2 = 12, √12 / 6.
        assert!((se - 12f64.sqrt() / 6.0).abs() < 1e-15, "{se}");
    }
}
