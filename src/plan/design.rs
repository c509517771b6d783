//! Optimal designs for the I-criterion `φ(M) = tr(L M⁻¹)`.
//!
//! The continuous design puts weights `w_c ≥ 0`, `Σ w_c = 1`, on the candidates, with information
//! `M(w) = M₀ + Σ w_c M_c` (`M₀`: what an existing session already knows, per planned pose). It
//! is found by the multiplicative algorithm `w_c ← w_c (d_c / Σ w d)^½`, `d_c = tr(M⁻¹ L M⁻¹ M_c)`
//! (Silvey, Titterington & Torsney 1978; with the power ½ it decreases `φ` monotonically for
//! A- and I-criteria, Yu 2010), and checked by the general equivalence theorem: `w` is optimal
//! iff no candidate's directional derivative `d_c` exceeds `Σ w d` (= `φ` without `M₀`). On small
//! candidate sets the same optimum comes from the second-order cone program of Sagnol (2011),
//! solved by clarabel ([`cone_program`]): `plan` uses it on small fresh candidate sets, and the
//! tests check each method against the other.
//!
//! The exact design takes N distinct candidates: the N heaviest of the continuous design, then
//! exchanges (Fedorov) of a chosen pose for a better candidate while `φ` decreases.

use nalgebra::DMatrix;

/// A continuous design.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ContinuousDesign {
    /// Weight of each candidate (sum 1).
    pub weights: Vec<f64>,
    /// `φ(M(w))` for one pose's worth of information (`Σ w = 1`).
    pub criterion: f64,
    /// `max_c d_c / Σ_c w_c d_c`: 1 at the optimum (the equivalence theorem), above 1 before.
    pub equivalence_ratio: f64,
    /// Iterations used.
    pub iterations: usize,
}

/// `φ(M) = tr(L M⁻¹)`, infinite when `M` is not positive definite.
pub(crate) fn criterion(m: &DMatrix<f64>, l: &DMatrix<f64>) -> f64 {
    match m.clone().cholesky() {
        Some(c) => c.inverse().dot(l),
        None => f64::INFINITY,
    }
}

/// The directional derivatives `d_c = tr(M⁻¹ L M⁻¹ M_c)` of every candidate and `φ`, or `None`
/// when `M` is singular.
fn derivatives(m: &DMatrix<f64>, l: &DMatrix<f64>, info: &[DMatrix<f64>]) -> Option<(Vec<f64>, f64)> {
    derivatives_of(m, l, info, &(0..info.len()).collect::<Vec<_>>())
}

/// The I-optimal continuous design over `info` (one matrix per candidate) for weighting `l`,
/// with prior information `m0` (zero for a fresh capture, scaled to one pose), iterated until
/// the equivalence ratio over every candidate is below `1 + tolerance` or `max_iterations`.
///
/// Weights that fall below 1e-6 of the largest are set to zero and their candidates left out of
/// the iterations (a multiplicative update never brings a weight back from that far); the final
/// check covers every candidate, and one that would improve the design comes back.
pub(crate) fn multiplicative(
    info: &[DMatrix<f64>],
    l: &DMatrix<f64>,
    m0: &DMatrix<f64>,
    tolerance: f64,
    max_iterations: usize,
) -> ContinuousDesign {
    multiplicative_from(info, l, m0, vec![1.0 / info.len() as f64; info.len()], tolerance, max_iterations)
}

/// [`multiplicative`] from the weights `start` (summing to 1; zero weights start inactive and
/// come back only through the final check): the polish of another solver's design.
pub(crate) fn multiplicative_from(
    info: &[DMatrix<f64>],
    l: &DMatrix<f64>,
    m0: &DMatrix<f64>,
    start: Vec<f64>,
    tolerance: f64,
    max_iterations: usize,
) -> ContinuousDesign {
    let n = info.len();
    let mut w = start;
    let mut active: Vec<usize> = (0..n).filter(|&c| w[c] > 0.0).collect();
    let mut iterations = 0;
    loop {
        let m = weighted_sum(info, &w, m0);
        let Some((d, phi)) = derivatives_of(&m, l, info, &active) else {
            return ContinuousDesign {
                weights: w,
                criterion: f64::INFINITY,
                equivalence_ratio: f64::INFINITY,
                iterations,
            };
        };
        let average: f64 = active.iter().zip(&d).map(|(&c, dc)| w[c] * dc).sum();
        let ratio = d.iter().copied().fold(0.0, f64::max) / average;
        if ratio <= 1.0 + tolerance || iterations >= max_iterations {
            // Converged on the active candidates: check them all.
            let Some((all, _)) = derivatives_of(&m, l, info, &(0..n).collect::<Vec<_>>()) else {
                return ContinuousDesign { weights: w, criterion: phi, equivalence_ratio: ratio, iterations };
            };
            let ratio_all = all.iter().copied().fold(0.0, f64::max) / average;
            let comeback: Vec<usize> =
                (0..n).filter(|&c| w[c] == 0.0 && all[c] > (1.0 + tolerance) * average).collect();
            if comeback.is_empty() || iterations >= max_iterations {
                return ContinuousDesign { weights: w, criterion: phi, equivalence_ratio: ratio_all, iterations };
            }
            for c in comeback {
                w[c] = 1.0 / n as f64;
                active.push(c);
            }
            active.sort_unstable();
            let total: f64 = w.iter().sum();
            w.iter_mut().for_each(|wc| *wc /= total);
            continue;
        }
        for (&c, dc) in active.iter().zip(&d) {
            w[c] *= (dc / average).max(0.0).sqrt();
        }
        let total: f64 = w.iter().sum();
        w.iter_mut().for_each(|wc| *wc /= total);
        let largest = w.iter().copied().fold(0.0, f64::max);
        for &c in &active {
            if w[c] < 1e-6 * largest {
                w[c] = 0.0;
            }
        }
        active.retain(|&c| w[c] > 0.0);
        iterations += 1;
    }
}

/// The directional derivatives `d_c` of `active` candidates (in that order) and `φ`.
fn derivatives_of(
    m: &DMatrix<f64>,
    l: &DMatrix<f64>,
    info: &[DMatrix<f64>],
    active: &[usize],
) -> Option<(Vec<f64>, f64)> {
    let inverse = m.clone().cholesky()?.inverse();
    let b = &inverse * l * &inverse;
    let part = |of: &[usize]| of.iter().map(|&c| b.dot(&info[c])).collect::<Vec<f64>>();
    let (half, rest) = active.split_at(active.len() / 2);
    let (mut d, second) = crate::in_parallel(|| part(half), || part(rest));
    d.extend(second);
    Some((d, inverse.dot(l)))
}

/// `m0 + Σ_c w_c M_c`, accumulated in place, half the candidates on each of two cores.
pub(super) fn weighted_sum(info: &[DMatrix<f64>], w: &[f64], m0: &DMatrix<f64>) -> DMatrix<f64> {
    let part = |info: &[DMatrix<f64>], w: &[f64], mut m: DMatrix<f64>| {
        for (mc, &wc) in info.iter().zip(w) {
            if wc != 0.0 {
                m.zip_apply(mc, |a, b| *a += wc * b);
            }
        }
        m
    };
    let h = info.len() / 2;
    let zero = DMatrix::zeros(m0.nrows(), m0.ncols());
    let (a, b) = crate::in_parallel(|| part(&info[..h], &w[..h], m0.clone()), || part(&info[h..], &w[h..], zero));
    a + b
}

/// An exact design: N distinct candidates.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ExactDesign {
    /// The chosen candidates.
    pub chosen: Vec<usize>,
    /// `φ(N M₀ + Σ_chosen M_c)`.
    pub criterion: f64,
    /// Exchanges made after the start.
    pub exchanges: usize,
}

/// N distinct candidates: the heaviest of `start`, improved by exchanges while `φ` decreases.
/// `m0` is the prior information of one pose's worth (as for [`multiplicative`]).
pub(crate) fn exact(
    info: &[DMatrix<f64>],
    l: &DMatrix<f64>,
    m0: &DMatrix<f64>,
    n: usize,
    start: &[f64],
) -> ExactDesign {
    let n = n.min(info.len());
    let mut order: Vec<usize> = (0..info.len()).collect();
    order.sort_by(|a, b| start[*b].total_cmp(&start[*a]));
    let mut chosen: Vec<usize> = order[..n].to_vec();
    let mut m = information_of(info, m0, &chosen);
    let mut phi = criterion(&m, l);
    let mut exchanges = 0;
    // Each sweep: the candidates with the largest directional derivatives are tried in place of
    // every chosen pose; the best exchange is made. Stops when none improves φ.
    for _ in 0..200 {
        let Some((d, _)) = derivatives(&m, l, info) else { break };
        let mut outside: Vec<usize> = (0..info.len()).filter(|c| !chosen.contains(c)).collect();
        outside.sort_by(|a, b| d[*b].total_cmp(&d[*a]));
        outside.truncate(EXCHANGE_CANDIDATES);
        let mut best: Option<(usize, usize, f64, DMatrix<f64>)> = None;
        let mut trial = m.clone();
        for (slot, &out) in chosen.iter().enumerate() {
            let without = &m - &info[out];
            for &inside in &outside {
                trial.copy_from(&without);
                trial += &info[inside];
                let value = criterion(&trial, l);
                if value < best.as_ref().map_or(phi * (1.0 - 1e-9), |b| b.2) {
                    best = Some((slot, inside, value, trial.clone()));
                }
            }
        }
        let Some((slot, inside, value, trial)) = best else { break };
        chosen[slot] = inside;
        (m, phi) = (trial, value);
        exchanges += 1;
    }
    chosen.sort_unstable();
    ExactDesign { chosen, criterion: phi, exchanges }
}

/// Candidates tried per sweep of the exchange (those the current design would gain most from).
const EXCHANGE_CANDIDATES: usize = 12;

/// The D-criterion `log det M`, `-∞` when singular.
pub(crate) fn log_det(m: &DMatrix<f64>) -> f64 {
    match m.clone().cholesky() {
        Some(c) => 2.0 * c.l().diagonal().iter().map(|x| x.ln()).sum::<f64>(),
        None => f64::NEG_INFINITY,
    }
}

/// The information of a design of the `chosen` candidates: theirs plus the prior `m0` (one
/// pose's worth) for each of them.
pub(crate) fn information_of(info: &[DMatrix<f64>], m0: &DMatrix<f64>, chosen: &[usize]) -> DMatrix<f64> {
    let mut m = m0 * chosen.len() as f64;
    chosen.iter().for_each(|&c| m += &info[c]);
    m
}

/// The continuous I-optimal design as the second-order cone program of Sagnol (2011), solved by
/// clarabel: with `L = K Kᵀ` and `M_c = A_c A_cᵀ`,
/// `min Σ t_c` over `w, t, Z_c` subject to `Σ_c A_c Z_c = K`, `‖Z_c‖²_F ≤ t_c w_c`, `Σ w_c = 1`;
/// its optimum is `min_w tr(L M(w)⁻¹)` and its `w` an optimal design. Only without prior
/// information (`M₀ = 0`). Practical up to a few hundred candidates.
///
/// # Errors
/// Clarabel does not reach an optimum (its status, in words).
pub(crate) fn cone_program(info: &[DMatrix<f64>], l: &DMatrix<f64>) -> Result<ContinuousDesign, String> {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};
    let p = l.nrows();
    let k = factor(l);
    let a: Vec<DMatrix<f64>> = info.iter().map(factor).collect();
    let r = k.ncols();
    let n = info.len();
    // Variables: w (n), t (n), then Z_c (l_c × r, column-major) for each candidate.
    let mut offset = Vec::with_capacity(n);
    let mut next = 2 * n;
    for a_c in &a {
        offset.push(next);
        next += a_c.ncols() * r;
    }
    let variables = next;
    let mut rows: Vec<(usize, usize, f64)> = Vec::new();
    let mut b: Vec<f64> = Vec::new();
    // Σ_c A_c Z_c = K: one equality per entry (i, j) of K.
    for j in 0..r {
        for i in 0..p {
            let row = b.len();
            for (c, a_c) in a.iter().enumerate() {
                for q in 0..a_c.ncols() {
                    if a_c[(i, q)] != 0.0 {
                        rows.push((row, offset[c] + j * a_c.ncols() + q, a_c[(i, q)]));
                    }
                }
            }
            b.push(k[(i, j)]);
        }
    }
    let row = b.len();
    for c in 0..n {
        rows.push((row, c, 1.0));
    }
    b.push(1.0);
    let equalities = b.len();
    // (t + w, t − w, 2 Z) in the second-order cone ⇔ ‖Z‖² ≤ t w, t, w ≥ 0.
    let mut cones = vec![SupportedConeT::ZeroConeT(equalities)];
    for (c, a_c) in a.iter().enumerate() {
        let first = b.len();
        rows.push((first, n + c, -1.0));
        rows.push((first, c, -1.0));
        rows.push((first + 1, n + c, -1.0));
        rows.push((first + 1, c, 1.0));
        let size = a_c.ncols() * r;
        for v in 0..size {
            rows.push((first + 2 + v, offset[c] + v, -2.0));
        }
        b.extend(std::iter::repeat_n(0.0, 2 + size));
        cones.push(SupportedConeT::SecondOrderConeT(2 + size));
    }
    let a_matrix = csc(b.len(), variables, rows);
    let mut q = vec![0.0; variables];
    q[n..2 * n].iter_mut().for_each(|x| *x = 1.0);
    let p_matrix = CscMatrix::zeros((variables, variables));
    let settings = DefaultSettingsBuilder::default().verbose(false).max_iter(200).build().map_err(|e| e.to_string())?;
    let mut solver =
        DefaultSolver::new(&p_matrix, &q, &a_matrix, &b, &cones, settings).map_err(|e| format!("{e:?}"))?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {}
        status => return Err(format!("the cone program ended {status:?}")),
    }
    let weights: Vec<f64> = solver.solution.x[..n].iter().map(|w| w.max(0.0)).collect();
    let total: f64 = weights.iter().sum();
    let weights: Vec<f64> = weights.iter().map(|w| w / total).collect();
    let m = weighted_sum(info, &weights, &DMatrix::zeros(p, p));
    let ratio = derivatives(&m, l, info).map_or(f64::INFINITY, |(d, phi)| d.iter().copied().fold(0.0, f64::max) / phi);
    Ok(ContinuousDesign {
        weights,
        criterion: solver.solution.obj_val,
        equivalence_ratio: ratio,
        iterations: solver.solution.iterations as usize,
    })
}

/// `F` with `F Fᵀ = S` for a symmetric positive semi-definite `S`, keeping the columns of
/// eigenvalues above 1e-12 of the largest.
fn factor(s: &DMatrix<f64>) -> DMatrix<f64> {
    let Some(eigen) = crate::math::linalg::bounded_symmetric_eigen(s) else { return DMatrix::zeros(s.nrows(), 0) };
    let largest = eigen.eigenvalues.max().max(0.0);
    let keep: Vec<usize> = (0..s.nrows()).filter(|&i| eigen.eigenvalues[i] > 1e-12 * largest).collect();
    DMatrix::from_fn(s.nrows(), keep.len(), |i, j| eigen.eigenvectors[(i, keep[j])] * eigen.eigenvalues[keep[j]].sqrt())
}

/// A compressed sparse column matrix from `(row, column, value)` triplets.
fn csc(rows: usize, columns: usize, mut triplets: Vec<(usize, usize, f64)>) -> clarabel::algebra::CscMatrix<f64> {
    triplets.sort_by_key(|&(r, c, _)| (c, r));
    let mut colptr = vec![0; columns + 1];
    for &(_, c, _) in &triplets {
        colptr[c + 1] += 1;
    }
    for c in 0..columns {
        colptr[c + 1] += colptr[c];
    }
    let rowval = triplets.iter().map(|t| t.0).collect();
    let nzval = triplets.iter().map(|t| t.2).collect();
    clarabel::algebra::CscMatrix::new(rows, columns, colptr, rowval, nzval)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::{cone_program, multiplicative, multiplicative_from};
    use crate::calib::{CalibConfig, Parameterisation};
    use crate::model::RobotModel;
    use crate::plan::Information;
    use crate::sim::{Candidate, SimConfig};

    #[test]
    fn the_continuous_design_meets_the_equivalence_theorem_and_the_cone_programs_optimum() {
        let config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
        let model = RobotModel::load(&config.model).unwrap();
        let camera = config.camera.looking_down();
        let markers: Vec<_> = model.markers.iter().map(|m| m.position).collect();
        let names: Vec<String> = model.markers.iter().map(|m| m.name.clone()).collect();
        let pool = Candidate::draw(&config, &model, &model.spm, &camera, &markers, 80, 2f64.to_radians());
        let p = Parameterisation::for_markers(
            *model.spm.geometry(),
            &camera,
            &markers,
            &names,
            crate::model::CameraModel::rigid(),
            &CalibConfig::default().bounds,
        );
        let info = Information::of(&p, &camera, &pool, &pool, &config.camera.stereo_noise()).unwrap();
        let zero = nalgebra::DMatrix::zeros(p.len(), p.len());
        let design = multiplicative(&info.per_candidate, &info.workspace, &zero, 1e-4, 100_000);
        // The general equivalence theorem: no candidate's directional derivative exceeds the
        // design's by more than the tolerance — the design is optimal to that tolerance, and its
        // criterion within it of the optimum (φ(w) − φ* ≤ (max d − Σ w d) = tolerance · φ).
        assert!(design.equivalence_ratio <= 1.0 + 1e-4, "{}", design.equivalence_ratio);
        let cone = cone_program(&info.per_candidate, &info.workspace).unwrap();
        eprintln!(
            "multiplicative φ = {:.6e} ({} iterations), cone program φ = {:.6e} (equivalence ratio {:.5})",
            design.criterion, design.iterations, cone.criterion, cone.equivalence_ratio
        );
        // Both near the optimum, each within its own equivalence ratio of it (the theorem's
        // bound: φ(w) − φ* ≤ (ratio − 1) φ(w)); the cone program's weights are as good as
        // clarabel's interior point leaves them (ratio 1.0015 measured, since the workspace
        // weighting leaves out the common rotations and so is singular): at most 1.005, a 3×
        // margin on its excess.
        assert!(cone.equivalence_ratio < 1.005, "{}", cone.equivalence_ratio);
        // Their criteria differ by no more than the two gaps together (1.6e-3 of φ here; 4.7e-4 measured).
        let bound = (design.equivalence_ratio - 1.0).max(0.0) + (cone.equivalence_ratio - 1.0).max(0.0);
        assert!(
            (design.criterion - cone.criterion).abs() <= bound * cone.criterion,
            "{} vs {} (bound {bound})",
            design.criterion,
            cone.criterion
        );
        // The polish of `Plan::design` takes the cone program's weights to the tolerance; it and
        // the multiplicative algorithm from the uniform design, two routes each certified within
        // 1e-4 of φ* by the theorem, agree to 2e-4 of φ.
        let polished =
            multiplicative_from(&info.per_candidate, &info.workspace, &zero, cone.weights.clone(), 1e-4, 100_000);
        eprintln!(
            "polished φ = {:.6e}: {:.2e} of the multiplicative design's",
            polished.criterion,
            (polished.criterion / design.criterion - 1.0).abs()
        );
        assert!(polished.equivalence_ratio <= 1.0 + 1e-4 && polished.criterion <= cone.criterion, "{polished:?}");
        let (a, b) = (polished.criterion, design.criterion);
        assert!((a - b).abs() <= 2e-4 * b, "polished {a} vs multiplicative {b}");
    }
}
