//! The fit: one trust-region loop of Gauss–Newton steps, with clarabel where bounds bind.
//!
//! Each iteration linearises the residuals, `r(x + Δ) ≈ r + J Δ`, weights each observation (a
//! pose's rotation or a marker's position) by its robust (Huber) weight — iteratively reweighted
//! least squares, whose fixed point is the Huber estimate — and minimises the model
//!
//! ```text
//! minimise ½ Δᵀ (Jᵀ W J + Λ) Δ + (Jᵀ W r + Λ (x − x_prior))ᵀ Δ
//! subject to |x_k + Δ_k| ≤ bound_k   (physical bounds, a nonnegative cone)
//!            ‖Δ‖ ≤ ρ                 (trust region, a second-order cone)
//! ```
//!
//! by a Cholesky solve when its unconstrained minimum (the Gauss–Newton step) satisfies both
//! constraints, else by clarabel (`Λ` is the weak prior on unidentifiable directions, if any; `‖Δ‖`
//! takes each parameter in its own unit: radians for angles, metres for positions, seconds for the
//! latency). A step is accepted when the actual reduction of the weighted cost is at least a
//! quarter of the predicted one; a rejected step shrinks the radius to a quarter of itself, a good
//! step that reached the radius doubles it. The fit stops on the Newton decrement (see [`fit`]).

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SecondOrderConeT, SolverStatus, SupportedConeT,
};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::config::{CalibConfig, Loss};
use super::parameterisation::Parameterisation;
use super::residuals::{EvalError, Evaluation, Residuals};

/// Median of the norm of a `d`-D isotropic Gaussian with unit deviation per axis (`d` = 1, 2, 3:
/// half-normal, Rayleigh, Maxwell): the robust scale of residual norms of `d` rows is their
/// median over this.
fn chi_median(rows: u8) -> f64 {
    match rows {
        1 => 0.6745,
        2 => 1.1774,
        _ => 1.5382,
    }
}

/// Numerical settings of one fit.
#[derive(Debug, Clone)]
pub(crate) struct FitSettings {
    /// Iteration budget.
    pub max_iterations: u32,
    /// Initial trust-region radius, in the parameters' units (radians for the angles; the same
    /// number counts as metres or seconds for a position or the latency).
    pub initial_radius: f64,
    /// Converged when the full step moves no parameter by more than this (radians, or metres or
    /// seconds alike); the Newton decrement usually stops the fit first.
    pub step_tolerance: f64,
    /// Loss on each observation's residual.
    pub loss: Loss,
    /// Huber threshold in robust standard deviations.
    pub huber_threshold: f64,
    /// Which parameters move.
    pub free: Vec<bool>,
    /// Weak prior `½ (x − x_prior)ᵀ Λ (x − x_prior)` on unidentifiable directions.
    pub prior: Option<(DMatrix<f64>, DVector<f64>)>,
    /// The calibration stage the fit is, as its iterations name it.
    pub stage: &'static str,
}

impl FitSettings {
    /// The settings `config` asks for, with `free` parameters and no prior.
    pub(crate) fn from_config(config: &CalibConfig, free: Vec<bool>) -> Self {
        FitSettings {
            max_iterations: config.max_iterations,
            initial_radius: config.initial_radius_deg.to_radians(),
            step_tolerance: config.step_tolerance_deg.to_radians(),
            loss: config.loss,
            huber_threshold: config.huber_threshold,
            free,
            prior: None,
            stage: "fit",
        }
    }
}

/// One iteration, for the log and the recording.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct IterationLog {
    /// The calibration stage: `calibration`, or `refit without gross errors`.
    pub stage: &'static str,
    /// Whether the residuals were whitened by the estimated noise model (false for the first
    /// steps, taken before the noise is estimated).
    pub whitened: bool,
    /// Iteration number within its stage, from 1.
    pub iteration: u32,
    /// Weighted, whitened cost `½ Σ w_j |S_j r_j|²` before the step.
    pub cost: f64,
    /// RMS residual before the step, in the model's unit: degrees (orientations) or
    /// millimetres (markers).
    pub rms: f64,
    /// Length of the proposed step, in the parameters' own units (radians; marker positions in
    /// metres, the latency in seconds).
    pub step: f64,
    /// Trust-region radius (in the same units as `step`).
    pub radius: f64,
    /// Actual over predicted reduction.
    pub ratio: f64,
    /// Whether the step was taken.
    pub accepted: bool,
    /// Interior-point iterations clarabel needed (0 for a Gauss–Newton step).
    pub solver_iterations: u32,
    /// What found the step.
    pub solver: Solver,
    /// The Newton decrement before the step: the distance to the optimum of the current
    /// weighting, in standard errors (the fit stops below 1e-3).
    pub decrement: f64,
}

/// How a successful fit ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Convergence {
    /// The Newton decrement at the settled weights fell below 1e-3 standard errors (or the full
    /// step below the step tolerance, or no decrease the cost can resolve, or — a rough cost — a
    /// full Gauss–Newton step promising under 0.3 standard errors was not confirmed).
    Converged,
    /// No step of useful size reduced the cost (the trust radius collapsed), or the iteration
    /// budget ran out with the cost flat: a minimum to working precision, not a clean convergence.
    StalledAtMinimum,
}

/// A fit whose cost changes by less than this fraction over the last five iterations is at its
/// minimum whatever its steps: the cost is a sum over hundreds of residuals, so 1e-10 of it is
/// far below anything the data can tell apart.
pub(crate) const RELATIVE_COST_TOLERANCE: f64 = 1e-10;
/// Iterations over which a stalled cost is judged.
const STALL_WINDOW: usize = 5;

/// A converged fit.
#[derive(Debug, Clone)]
pub(crate) struct FitOutcome<N> {
    /// How the fit ended.
    pub status: Convergence,
    /// The parameter vector at the solution.
    pub x: DVector<f64>,
    /// Residuals (and Jacobian) at the solution.
    pub evaluation: Evaluation,
    /// The weighting at the solution.
    pub weighting: Weighting<N>,
    /// Every iteration.
    pub log: Vec<IterationLog>,
}

/// Why a fit failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    #[error("cannot evaluate the model at the start point: {0}")]
    /// The model cannot be evaluated at the start point.
    Start(EvalError),
    #[error("cannot evaluate the model after iteration {iteration}: {error}")]
    /// The model cannot be evaluated where an accepted step (or the solution) put it.
    Evaluation {
        /// The iteration whose step was accepted.
        iteration: u32,
        /// Why.
        error: EvalError,
    },
    #[error("clarabel failed on the subproblem of iteration {iteration}: status {status}")]
    /// clarabel failed on a trust-region subproblem.
    Solver {
        /// Iteration of the fit.
        iteration: u32,
        /// clarabel's status.
        status: String,
    },
    #[error(
        "the fit did not converge within `max_iterations` = {iterations} iterations (last step {step:.3e}, radius {radius:.3e}, in the parameters' units; {}): raise `max_iterations`",
        if *.judged { format!("the cost still falling by {relative_decrease:.1e} per iteration") } else { "too few iterations to tell a minimum from progress".to_string() }
    )]
    /// The iteration budget ran out while the cost was still falling.
    IterationLimit {
        /// Iterations done.
        iterations: u32,
        /// Last step length (rad).
        step: f64,
        /// Trust radius at the end (rad).
        radius: f64,
        /// Relative cost decrease per iteration at the end.
        relative_decrease: f64,
        /// Whether enough iterations were done to tell a stall from progress (else the budget was
        /// simply too small to judge).
        judged: bool,
    },
    #[error("the fit diverged at iteration {iteration}: {reason}")]
    /// The cost or the step became non-finite.
    Diverged {
        /// Iteration where it happened.
        iteration: u32,
        /// What became non-finite.
        reason: String,
    },
}

/// How the residuals are weighted: each observation whitened by `S = Σ^{-1/2}` of the model's
/// noise (estimated from the residuals once the unwhitened phase has converged), then weighted by
/// its Huber weight on the whitened norm, at a robust scale `σ` fixed for the phase.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Weighting<N> {
    /// Per observation.
    pub whitening: Vec<Matrix3<f64>>,
    /// Huber weight per observation, in (0, 1].
    pub weights: Vec<f64>,
    /// Robust scale of the whitened norms.
    pub sigma: f64,
    /// The model's noise, once estimated.
    pub noise: Option<N>,
    /// The rows each observation's residual really has (3, or 2 for a pixel): its degrees of
    /// freedom.
    pub rows: Vec<u8>,
}

impl<N> Weighting<N> {
    /// No whitening, unit weights, for the observations of `model`.
    pub(crate) fn isotropic<M: Residuals<Noise = N>>(model: &M) -> Self {
        let observations = model.len();
        Weighting {
            whitening: vec![Matrix3::identity(); observations],
            weights: vec![1.0; observations],
            sigma: 1.0,
            noise: None,
            rows: (0..observations).map(|j| model.rows(j) as u8).collect(),
        }
    }

    /// The residual rows the observations have in all (their degrees of freedom before the fit).
    pub(crate) fn total_rows(&self) -> usize {
        self.rows.iter().map(|&r| usize::from(r)).sum()
    }

    /// Whiten by the noise `model` estimates from the residuals at the current weights.
    pub(crate) fn estimate<M: Residuals<Noise = N>>(&mut self, model: &M, residuals: &[Vector3<f64>]) {
        let noise = model.estimate_noise(residuals, &self.weights);
        self.whitening = model.whitening(&noise);
        self.noise = Some(noise);
    }

    /// Robust scale of the whitened norms (each over the median norm of its rows' Gaussian).
    pub(crate) fn rescale(&mut self, residuals: &[Vector3<f64>]) {
        self.sigma =
            robust_scale((0..residuals.len()).map(|j| self.whiten(j, &residuals[j]).norm() / chi_median(self.rows[j])));
    }

    /// Huber weights of the whitened norms at the current scale.
    pub(crate) fn reweight(&mut self, residuals: &[Vector3<f64>], loss: Loss, threshold: f64) {
        for (j, w) in self.weights.iter_mut().enumerate() {
            *w = loss_weight(loss, (self.whitening[j] * residuals[j]).norm(), threshold * self.sigma);
        }
    }

    /// The whitened residual of observation `j`.
    pub(crate) fn whiten(&self, j: usize, r: &Vector3<f64>) -> Vector3<f64> {
        self.whitening[j] * r
    }

    fn cost(&self, residuals: &[Vector3<f64>]) -> f64 {
        0.5 * residuals.iter().enumerate().map(|(j, r)| self.weights[j] * self.whiten(j, r).norm_squared()).sum::<f64>()
    }
}

/// Robust scale of residual norms already divided by their Gaussian's median norm
/// ([`chi_median`]): their median, floored so that a perfect fit does not divide by zero.
fn robust_scale(norms: impl Iterator<Item = f64>) -> f64 {
    let mut sorted: Vec<f64> = norms.collect();
    sorted.sort_by(f64::total_cmp);
    sorted.get(sorted.len() / 2).copied().unwrap_or(0.0).max(1e-15)
}

/// The weight `loss` gives a residual of norm `norm` when the quadratic zone ends at `limit`:
/// 1 inside, `limit / norm` beyond (Huber's IRLS weight).
fn loss_weight(loss: Loss, norm: f64, limit: f64) -> f64 {
    match loss {
        Loss::Huber if norm > limit => limit / norm,
        _ => 1.0,
    }
}

fn prior_cost(settings: &FitSettings, x: &DVector<f64>) -> f64 {
    settings.prior.as_ref().map_or(0.0, |(lambda, x0)| {
        let d = x - x0;
        0.5 * d.dot(&(lambda * &d))
    })
}

/// What stays fixed during a fit.
struct Problem<'a, M> {
    model: &'a M,
    settings: &'a FitSettings,
    /// Indices of the free parameters.
    free: Vec<usize>,
}

/// Relative precision of the cost: a sum over hundreds of poses of residuals that the FDA resolves
/// to ~1e-14 rad. A predicted reduction below this is noise.
const PRECISION: f64 = 1e-12;

/// The fit has converged when the step to the optimum of the current weighting (the estimated
/// noise model and robust scale, the Huber weights of the current point) is shorter than
/// this many standard errors in the metric of the parameters' covariance (the Newton decrement
/// `Δᵀ H Δ` over the residual variance): the parameters are then within a thousandth of their
/// uncertainty of the fixed point, and the next step would move them a millionth.
const DECREMENT_TOLERANCE: f64 = 1e-3;

/// A step that the cost does not confirm, within this many standard errors of the model's optimum,
/// ends the fit: the cost is rough below that scale (see `trust_region_step`).
const ROUGH_DECREMENT: f64 = 0.3;

/// The longest step along a Gauss–Newton direction the curvature test may try, in its lengths.
const MAX_EXTRAPOLATION: f64 = 3.0;

/// The unwhitened fit only has to bring the residuals near their minimum for the noise model to
/// be estimated from them: a hundredth of a standard error changes the estimated σ's by far less
/// than their own uncertainty (a tenth moved the nominal registration's whitened fixed point).
const UNWHITENED_TOLERANCE: f64 = 0.01;

/// Fit `x` from `x0` to the observations by two-step feasible generalised least squares in one
/// trust-region loop: unwhitened until the step to the optimum is below a hundredth of a standard
/// error ([`UNWHITENED_TOLERANCE`]: the nominal model's residuals are its error, not the camera's
/// noise), then whitened by the noise the model estimates from the residuals there (per-class
/// covariances, or the stereo σ's), with the robust scale taken there too. The Huber weights
/// (iteratively reweighted least squares) follow every accepted point, so that they settle while
/// the parameters converge instead of each reweighting re-converging from the last. (Re-estimating
/// the noise at every point — iterated FGLS — was tried: with few poses the orientation level's
/// per-class covariances collapse onto the directions the fit makes small, and the fit drifts.) Each step is the Gauss–Newton step when it lies inside the trust region and the
/// bounds (a Cholesky solve), else clarabel's bounded subproblem; when a step's actual decrease
/// shows the curvature along it differs from the Gauss–Newton model's (a weak direction of a
/// small session, where the residuals' own curvature matters), the minimum along it is tried too.
/// The fit stops when the Newton decrement at the re-estimated weights is below
/// [`DECREMENT_TOLERANCE`] standard errors (or the full step below the step tolerance): a stop
/// proven by the gradient and the curvature, not by a short step alone.
///
/// # Errors
/// A [`FitError`] when the start cannot be evaluated, clarabel fails, the budget runs out while the cost still falls or the fit diverges.
pub(crate) fn fit<M: Residuals>(
    model: &M,
    x0: &DVector<f64>,
    settings: &FitSettings,
    on_iteration: &mut dyn FnMut(&IterationLog),
) -> Result<FitOutcome<M::Noise>, FitError> {
    let n = model.parameterisation().len();
    let free: Vec<usize> = (0..n).filter(|&i| settings.free[i]).collect();
    let problem = Problem { model, settings, free };
    let mut x = x0.clone();
    let mut eval = model.evaluate(&x, None, true).map_err(FitError::Start)?;
    let mut region = Region { radius: settings.initial_radius, normal: None };
    let mut log: Vec<IterationLog> = Vec::new();
    let mut weighting = Weighting::isotropic(model);
    // The unwhitened phase's robust scale is the start's (the nominal model's error sets it,
    // so that phase is nearly least squares); the whitened phase's is taken where it begins.
    weighting.rescale(&eval.residuals);
    // The Huber weights follow every accepted point; the noise model is estimated once, where the
    // unwhitened fit has (loosely) converged, and the robust scale there.
    let mut whitened = false;
    let mut weighted_at = None;
    let status = loop {
        let iteration = log.len() as u32 + 1;
        if weighted_at.as_ref() != Some(&x) {
            weighting.reweight(&eval.residuals, settings.loss, settings.huber_threshold);
            weighted_at = Some(x.clone());
            region.normal = None;
        }
        if iteration > settings.max_iterations {
            break iteration_limit(&log, region.radius)?;
        }
        let tolerance = if whitened { DECREMENT_TOLERANCE } else { UNWHITENED_TOLERANCE };
        let (mut entry, stop) =
            problem.trust_region_step(&mut x, &mut eval, &weighting, &mut region, iteration, tolerance)?;
        (entry.stage, entry.whitened) = (settings.stage, whitened);
        on_iteration(&entry);
        log.push(entry);
        match stop {
            Some(Convergence::Converged) if !whitened => {
                weighting.estimate(model, &eval.residuals);
                weighting.rescale(&eval.residuals);
                weighted_at = None;
                whitened = true;
                // The whitened cost is a new function: its steps need not be as short.
                region.radius = region.radius.max(settings.initial_radius);
            }
            Some(stop) => break stop,
            None => {}
        }
    };
    Ok(FitOutcome { status, x, evaluation: eval, weighting, log })
}

/// The iteration budget is spent: a fit whose cost no longer falls is at its minimum (stalled);
/// one still improving is an error naming the config key to raise.
fn iteration_limit(log: &[IterationLog], radius: f64) -> Result<Convergence, FitError> {
    let last = log.last().copied();
    let window = &log[log.len().saturating_sub(STALL_WINDOW)..];
    let (first, latest) = (window.first().map_or(0.0, |l| l.cost), last.map_or(0.0, |l| l.cost));
    let relative_decrease = if first > 0.0 { (first - latest) / first / window.len().max(1) as f64 } else { 0.0 };
    // Too few iterations to judge a stall: the budget was simply too small.
    if window.len() == STALL_WINDOW && relative_decrease.abs() <= RELATIVE_COST_TOLERANCE {
        return Ok(Convergence::StalledAtMinimum);
    }
    let (iterations, step) = (log.len() as u32, last.map_or(0.0, |l| l.step));
    let judged = window.len() == STALL_WINDOW;
    Err(FitError::IterationLimit { iterations, step, radius, relative_decrease, judged })
}

/// The trust region between iterations: its radius, and the normal equations of the current
/// point and weighting (kept while steps are rejected: neither has changed).
struct Region {
    radius: f64,
    normal: Option<(DMatrix<f64>, DVector<f64>)>,
}

/// A step and how it was found.
struct Step {
    /// Over the free parameters.
    delta: DVector<f64>,
    /// The Gauss–Newton step (inside the trust region and the bounds), or clarabel's.
    solver: Solver,
    /// clarabel's interior-point iterations (0 for a Gauss–Newton step).
    solver_iterations: u32,
    /// The step reaches no trust-region boundary: it is the minimiser of the model within the
    /// bounds, so its predicted decrease measures the distance to the optimum.
    interior: bool,
}

/// What found a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Solver {
    /// The Gauss–Newton step, by a Cholesky solve of the normal equations: it lay inside the trust
    /// region and the bounds.
    GaussNewton,
    /// clarabel's solution of the bounded trust-region subproblem (a cone program).
    Clarabel,
}

impl<M: Residuals> Problem<'_, M> {
    /// The step from `x`: Gauss–Newton where it is feasible, else clarabel's subproblem.
    fn step(
        &self,
        x: &DVector<f64>,
        hessian: &DMatrix<f64>,
        gradient: &DVector<f64>,
        radius: f64,
        iteration: u32,
    ) -> Result<Step, FitError> {
        let p = self.model.parameterisation();
        let newton = hessian.clone().cholesky().map(|c| -c.solve(gradient));
        if let Some(delta) = newton.filter(|d| d.iter().all(|v| v.is_finite())) {
            let inside_bounds = self
                .free
                .iter()
                .zip(delta.iter())
                .all(|(&i, d)| p.entries[i].bound.is_none_or(|b| (x[i] + d).abs() <= b * (1.0 - 1e-9)));
            if inside_bounds && delta.norm() <= radius {
                return Ok(Step { delta, solver: Solver::GaussNewton, solver_iterations: 0, interior: true });
            }
        }
        let (delta, solver_iterations) = solve_subproblem(p, x, &self.free, hessian, gradient, radius)
            .map_err(|status| FitError::Solver { iteration, status })?;
        let interior = delta.norm() < 0.99 * radius;
        Ok(Step { delta, solver: Solver::Clarabel, solver_iterations, interior })
    }

    /// One trust-region iteration with the weighting of the current point; returns its log entry
    /// and whether the fit has stopped: converged (the Newton decrement below tolerance, the full
    /// step below the step tolerance, or no decrease the cost can resolve) or stalled at a minimum
    /// (a collapsed radius).
    fn trust_region_step(
        &self,
        x: &mut DVector<f64>,
        eval: &mut Evaluation,
        weighting: &Weighting<M::Noise>,
        region: &mut Region,
        iteration: u32,
        tolerance: f64,
    ) -> Result<(IterationLog, Option<Convergence>), FitError> {
        let (model, settings, free) = (self.model, self.settings, &self.free);
        let data_cost = weighting.cost(&eval.residuals);
        let cost = data_cost + prior_cost(settings, x);
        if !cost.is_finite() {
            return Err(FitError::Diverged { iteration, reason: format!("the cost is {cost}") });
        }
        let Region { radius, normal } = region;
        let (hessian, gradient) = &*normal.get_or_insert_with(|| normal_equations(eval, weighting, free, settings, x));
        let step = self.step(x, hessian, gradient, *radius, iteration)?;
        let delta = &step.delta;
        let (slope, curvature) = (gradient.dot(delta), delta.dot(&(hessian * delta)));
        let predicted = -(0.5 * curvature + slope);
        // The residual variance per degree of freedom: the decrement in its units is the squared
        // distance to the optimum in standard errors.
        let dof = weighting.total_rows().saturating_sub(free.len()).max(1) as f64;
        let variance = (2.0 * data_cost / dof).max(f64::MIN_POSITIVE);
        let decrement = (2.0 * predicted.max(0.0) / variance).sqrt();
        let converged = step.interior && (decrement < tolerance || delta.amax() < settings.step_tolerance)
            || predicted <= PRECISION * cost;
        let step_norm = delta.norm();
        if !step_norm.is_finite() {
            return Err(FitError::Diverged { iteration, reason: "the step is not finite".into() });
        }
        let trial_cost = |alpha: f64| -> Option<(DVector<f64>, Evaluation, f64)> {
            let mut trial_x = x.clone();
            for (k, &i) in free.iter().enumerate() {
                trial_x[i] += alpha * delta[k];
            }
            let trial = model.evaluate(&trial_x, Some(&eval.orientations), false).ok()?;
            let c = weighting.cost(&trial.residuals) + prior_cost(settings, &trial_x);
            Some((trial_x, trial, c))
        };
        let mut best = trial_cost(1.0);
        let actual = best.as_ref().map_or(f64::NEG_INFINITY, |(_, _, c)| cost - c);
        let ratio = if predicted > 0.0 { actual / predicted } else { 0.0 };
        let mut alpha = 1.0;
        // The cost along the step is (nearly) quadratic: its actual decrease at the full step gives
        // the true curvature along it, and so the minimum along it. When the Gauss–Newton model's
        // curvature is off by more than a fifth, that minimum is tried as well — short of the step
        // (the model too flat), or beyond it within the bounds (too steep: a large-residual
        // direction, or Huber weights that keep moving the same way).
        if actual.is_finite() && !(0.8..=1.2).contains(&ratio) {
            let true_curvature = 2.0 * (-actual - slope);
            let minimum = -slope / true_curvature;
            let p = model.parameterisation();
            let feasible = |a: f64| {
                free.iter()
                    .zip(delta.iter())
                    .all(|(&i, d)| p.entries[i].bound.is_none_or(|b| (x[i] + a * d).abs() <= b))
            };
            let promising = true_curvature > 0.0
                && (0.05..MAX_EXTRAPOLATION).contains(&minimum)
                && (minimum - 1.0).abs() > 0.05
                && feasible(minimum);
            if let Some(other) = promising.then(|| trial_cost(minimum)).flatten().filter(|(_, _, c)| *c < cost - actual)
            {
                best = Some(other);
                alpha = minimum;
            }
        }
        let gain = best.as_ref().map_or(f64::NEG_INFINITY, |(_, _, c)| cost - c);
        let predicted_at = -(alpha * slope + 0.5 * alpha * alpha * curvature);
        let accepted = predicted_at > 0.0 && gain > 0.25 * predicted_at || (converged && gain >= 0.0);
        let entry = IterationLog {
            stage: settings.stage,
            whitened: false,
            iteration,
            cost,
            rms: model.report_rms(&eval.residuals),
            step: step_norm * alpha,
            radius: *radius,
            ratio,
            accepted,
            solver_iterations: step.solver_iterations,
            solver: step.solver,
            decrement,
        };
        if accepted {
            let (trial_x, trial, _) = best.expect("an accepted step was evaluated");
            *x = trial_x;
            // The old Jacobian becomes the new one's storage before the new is made: one
            // Jacobian alive, not two (an hour-long recording's is 44 MB).
            model.recycle(std::mem::take(eval));
            *eval = model
                .evaluate(x, Some(&trial.orientations), true)
                .map_err(|error| FitError::Evaluation { iteration, error })?;
            if ratio > 0.75 && step_norm > 0.9 * *radius {
                *radius = (2.0 * *radius).min(0.5);
            }
        } else if !converged {
            // The model mispredicts beyond a quarter of this step: the next stays within it. (A
            // converged fit's last step may be rejected for rounding alone: the radius stays.)
            *radius = 0.25 * step_norm.min(*radius);
        }
        // A step that does not deliver while the optimum of the model is less than
        // `ROUGH_DECREMENT` standard errors away: below that scale the cost is rougher than its
        // model (a free-motion recording's joints interpolated between quantised encoder
        // samples), and x is at its minimum to within it; the log's decrement says how close. (A
        // full Gauss–Newton step, or one the trust region cut short after such a step failed: the
        // decrement is the distance to the model's optimum either way.)
        let rough = !accepted && decrement < ROUGH_DECREMENT;
        let done = if converged || rough {
            Some(Convergence::Converged)
        } else {
            (!accepted && *radius < settings.step_tolerance).then_some(Convergence::StalledAtMinimum)
        };
        Ok((entry, done))
    }
}

/// `Jᵀ W J + Λ` and `Jᵀ W r + Λ (x − x_prior)` over the free parameters.
pub(crate) fn normal_equations<N>(
    eval: &Evaluation,
    weighting: &Weighting<N>,
    free: &[usize],
    settings: &FitSettings,
    x: &DVector<f64>,
) -> (DMatrix<f64>, DVector<f64>) {
    let (mut hessian, mut gradient) = weighted_normal(eval, weighting, free);
    if let Some((lambda, x0)) = &settings.prior {
        let d = x - x0;
        let full_gradient = lambda * d;
        for (a, &i) in free.iter().enumerate() {
            gradient[a] += full_gradient[i];
            for (b, &k) in free.iter().enumerate() {
                hessian[(a, b)] += lambda[(i, k)];
            }
        }
    }
    (hessian, gradient)
}

/// `Jᵀ W J` and `Jᵀ W r` over the columns `free`, `W` the whitening and weights.
pub(crate) fn weighted_normal<N>(
    eval: &Evaluation,
    weighting: &Weighting<N>,
    free: &[usize],
) -> (DMatrix<f64>, DVector<f64>) {
    let rows: Vec<usize> = (0..eval.residuals.len()).collect();
    weighted_normal_of(eval, weighting, free, &rows)
}

/// [`weighted_normal`] over the residuals `rows` only.
pub(crate) fn weighted_normal_of<N>(
    eval: &Evaluation,
    weighting: &Weighting<N>,
    free: &[usize],
    rows: &[usize],
) -> (DMatrix<f64>, DVector<f64>) {
    let jac = eval.jacobian.as_ref().expect("evaluated with the Jacobian");
    let n = free.len();
    let m = rows.len();
    // The whitened, weighted rows of the free columns, a chunk of observations at a time (the
    // chunk stays in cache and no Jacobian-sized copy is made), each chunk added by one GEMM.
    const CHUNK: usize = 1024;
    let mut block = DMatrix::zeros(3 * CHUNK.min(m), n);
    let mut r = DVector::zeros(3 * CHUNK.min(m));
    let mut hessian = DMatrix::zeros(n, n);
    let mut gradient = DVector::zeros(n);
    for start in (0..m).step_by(CHUNK) {
        let len = (m - start).min(CHUNK);
        for a in 0..len {
            let j = rows[start + a];
            let s = weighting.whitening[j] * weighting.weights[j].sqrt();
            r.fixed_rows_mut::<3>(3 * a).copy_from(&(s * eval.residuals[j]));
            if n == jac.ncols() {
                // Every column free (the usual case): one 3 × 3 by 3 × N product in place.
                block.fixed_rows_mut::<3>(3 * a).gemm(1.0, &s, &jac.fixed_rows::<3>(3 * j), 0.0);
                continue;
            }
            for (k, &i) in free.iter().enumerate() {
                let column = s * jac.fixed_view::<3, 1>(3 * j, i);
                block.fixed_view_mut::<3, 1>(3 * a, k).copy_from(&column);
            }
        }
        crate::math::linalg::gram_into(&block, 3 * len, &mut hessian);
        for k in 0..n {
            gradient[k] += block.view((0, k), (3 * len, 1)).dot(&r.rows(0, 3 * len));
        }
    }
    (hessian, gradient)
}

/// The clarabel subproblem: bounds as a nonnegative cone, the trust region as a second-order cone.
/// It is solved in Jacobi-scaled variables `Δ = S Δ̃`, `S = diag(P)^{-1/2}`, with the objective
/// divided by `|S q|`, so that clarabel sees unit curvatures and an O(1) gradient however small the
/// residuals have become.
fn solve_subproblem(
    p: &Parameterisation,
    x: &DVector<f64>,
    free: &[usize],
    hessian: &DMatrix<f64>,
    gradient: &DVector<f64>,
    radius: f64,
) -> Result<(DVector<f64>, u32), String> {
    let n = free.len();
    let scale = DVector::from_fn(n, |k, _| {
        let d = hessian[(k, k)];
        if d > 0.0 { 1.0 / d.sqrt() } else { 1.0 }
    });
    let q_scaled = gradient.component_mul(&scale);
    let normaliser = q_scaled.norm().max(f64::MIN_POSITIVE);
    // Upper triangle of the scaled P, column by column.
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for c in 0..n {
        for r in 0..=c {
            rowval.push(r);
            nzval.push(hessian[(r, c)] * scale[r] * scale[c] / normaliser);
        }
        colptr.push(rowval.len());
    }
    let p_matrix = CscMatrix::new(n, n, colptr, rowval, nzval);
    let bounded: Vec<(usize, f64)> =
        free.iter().enumerate().filter_map(|(k, &i)| p.entries[i].bound.map(|b| (k, b))).collect();
    let rows = 2 * bounded.len() + n + 1;
    let mut a = vec![vec![0.0; n]; rows];
    let mut b = vec![0.0; rows];
    for (row, &(k, bound)) in bounded.iter().enumerate() {
        let value = x[free[k]];
        a[2 * row][k] = scale[k];
        b[2 * row] = bound - value;
        a[2 * row + 1][k] = -scale[k];
        b[2 * row + 1] = bound + value;
    }
    let soc = 2 * bounded.len();
    b[soc] = radius;
    for k in 0..n {
        a[soc + 1 + k][k] = -scale[k];
    }
    let a_matrix = CscMatrix::from(a.iter().map(|r| r.iter()));
    let mut cones: Vec<SupportedConeT<f64>> = Vec::new();
    if !bounded.is_empty() {
        cones.push(NonnegativeConeT(2 * bounded.len()));
    }
    cones.push(SecondOrderConeT(n + 1));
    let settings = DefaultSettingsBuilder::default().verbose(false).build().expect("valid clarabel settings");
    let q: Vec<f64> = q_scaled.iter().map(|v| v / normaliser).collect();
    let mut solver =
        DefaultSolver::new(&p_matrix, &q, &a_matrix, &b, &cones, settings).map_err(|e| format!("{e:?}"))?;
    solver.solve();
    let solution = &solver.solution;
    let step = DVector::from_vec(solution.x.clone()).component_mul(&scale);
    match solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => Ok((step, solution.iterations)),
        // Stalled close to the optimum: the step is still a feasible candidate, and the trust
        // region's ratio test accepts it only if it really reduces the cost.
        SolverStatus::InsufficientProgress | SolverStatus::MaxIterations if step.iter().all(|v| v.is_finite()) => {
            Ok((step, solution.iterations))
        }
        status => Err(format!("{status:?}")),
    }
}
