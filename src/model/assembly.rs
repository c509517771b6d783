//! Every assembly mode of the FDA, by polynomial elimination (no starting guess).
//!
//! With the joints known, each platform axis `v_i` lies on a cone of half-angle `α2_i`
//! about `w_i`: `v_i(ψ_i) = cos α2 w_i + sin α2 (cos ψ_i p_i + sin ψ_i q_i)`.
//! Rigidity gives two equations in `(ψ1, ψ2)`:
//!
//! * `E1 = v1·v2 − v0_1·v0_2 = 0`;
//! * `E2 = v3·w3 − cos α2_3 = 0`, where `v3` is written bilinearly in `(v1, v2)` from the
//!   coordinates of `v0_3` in the orthonormal frame of `(v0_1, v0_2)` (exact when `E1` holds).
//!
//! Both are bilinear in `(1, cos ψ1, sin ψ1) ⊗ (1, cos ψ2, sin ψ2)`. With half-angle tangents they
//! become quadratics in `t2` with coefficients quadratic in `t1`; their resultant in `t2` is the
//! octic in `t1` of Gosselin et al. (1994), here for general geometry. Its real roots give `ψ1`,
//! `E1` then gives `ψ2` in closed form, the pair gives `R`, and Newton on the three closure
//! equations polishes it. `ψ1 = π` (the root at infinity of `t1`) is always tried as well.

use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};

use super::geometry::HomeBranch;
use super::spm::{Branch, Spm};
use crate::math::so3;

/// One real solution of the FDA.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AssemblyMode {
    /// MP orientation (P → B).
    pub rotation: Rotation3<f64>,
    /// Branch of each leg at this solution.
    pub branches: [Branch; 3],
    /// Conditioning index of the closure Jacobian (0 at a parallel singularity).
    pub conditioning: f64,
    /// Largest closure residual after polishing.
    pub residual: f64,
}

impl AssemblyMode {
    /// True when all three legs are on their working branch.
    pub fn all_working(&self) -> bool {
        self.branches.iter().all(|b| *b == Branch::Working)
    }

    /// Branch signs as text, e.g. `"--+"`: the sign of `(u×w)·v` of each leg, for legs whose
    /// home branches are `home` ([`Spm::home_branches`]).
    pub fn branch_label(&self, home: &[HomeBranch; 3]) -> String {
        self.branches.iter().zip(home).map(|(b, h)| b.sign_char(*h)).collect()
    }
}

/// `(1, cos ψ, sin ψ)`.
fn trig_basis(psi: f64) -> [f64; 3] {
    let (s, c) = psi.sin_cos();
    [1.0, c, s]
}

/// `(1 + t²)·(1, cos ψ, sin ψ)` as polynomials in `t = tan(ψ/2)`, coefficients of `t⁰, t¹, t²`.
const HALF_ANGLE: [[f64; 3]; 3] = [[1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [0.0, 2.0, 0.0]];

/// Bilinear form `Σ_jk K[j][k] f_j(ψ1) f_k(ψ2)` evaluated at two angles.
fn eval_bilinear(k: &Matrix3<f64>, psi1: f64, psi2: f64) -> f64 {
    let (f1, f2) = (trig_basis(psi1), trig_basis(psi2));
    (0..3).map(|j| (0..3).map(|l| k[(j, l)] * f1[j] * f2[l]).sum::<f64>()).sum()
}

/// The bilinear form as a quadratic in `t2` whose coefficients are quadratics in `t1`:
/// `result[m][n]` is the coefficient of `t2^m t1^n`.
fn to_half_angle(k: &Matrix3<f64>) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (m, row) in out.iter_mut().enumerate() {
        for (n, cell) in row.iter_mut().enumerate() {
            *cell = (0..3)
                .flat_map(|j| (0..3).map(move |l| (j, l)))
                .map(|(j, l)| k[(j, l)] * HALF_ANGLE[j][n] * HALF_ANGLE[l][m])
                .sum();
        }
    }
    out
}

fn poly_mul<const A: usize, const B: usize, const C: usize>(a: &[f64; A], b: &[f64; B]) -> [f64; C] {
    let mut c = [0.0; C];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            c[i + j] += x * y;
        }
    }
    c
}

fn poly_sub<const N: usize>(a: &[f64; N], b: &[f64; N]) -> [f64; N] {
    std::array::from_fn(|i| a[i] - b[i])
}

/// Resultant in `t2` of `a0 + a1 t2 + a2 t2²` and `b0 + b1 t2 + b2 t2²` (coefficients quadratic
/// in `t1`): `(a2 b0 − a0 b2)² − (a2 b1 − a1 b2)(a1 b0 − a0 b1)`, of degree 8 in `t1`.
fn resultant(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [f64; 9] {
    let cross = |i: usize, j: usize| -> [f64; 5] { poly_sub(&poly_mul(&a[i], &b[j]), &poly_mul(&a[j], &b[i])) };
    let (c20, c21, c10) = (cross(2, 0), cross(2, 1), cross(1, 0));
    poly_sub(&poly_mul(&c20, &c20), &poly_mul(&c21, &c10))
}

/// Real roots of `Σ c_k t^k` from the eigenvalues of the companion matrix, after scaling `t` so
/// that the extreme coefficients balance. Roots with an imaginary part below `1e-5 (1 + |t|)` count
/// as real: a near-double root splits into such a pair by rounding, and Newton polishing decides.
/// So does a root whose imaginary part comes back NaN: nalgebra's Schur form gives a 2×2 block at a
/// double real root a NaN imaginary part (two modes sharing leg 1's platform axis, as symmetric
/// designs have; the Agile Wrist with reversed platform axes lost its working mode to it).
pub(crate) fn real_roots(coefficients: &[f64]) -> Vec<f64> {
    let scale = coefficients.iter().fold(0.0_f64, |m, c| m.max(c.abs()));
    let mut c: Vec<f64> = coefficients.to_vec();
    while c.len() > 1 && c.last().is_some_and(|l| l.abs() <= 1e-14 * scale) {
        c.pop();
    }
    let n = c.len() - 1;
    if n == 0 || scale == 0.0 {
        return Vec::new();
    }
    let low = c.iter().position(|x| x.abs() > 1e-14 * scale).unwrap_or(0);
    let rho = if low < n { (c[low].abs() / c[n].abs()).powf(1.0 / (n - low) as f64) } else { 1.0 };
    let rho = if rho.is_finite() && rho > 0.0 { rho } else { 1.0 };
    let mut companion = DMatrix::<f64>::zeros(n, n);
    for k in 0..n {
        companion[(0, n - 1 - k)] = -c[k] * rho.powi(k as i32 - n as i32) / c[n];
        if k + 1 < n {
            companion[(k + 1, k)] = 1.0;
        }
    }
    companion
        .complex_eigenvalues()
        .iter()
        .filter(|z| {
            z.re.is_finite()
                && z.im.abs().partial_cmp(&(1e-5 * (1.0 + z.re.abs()))) != Some(std::cmp::Ordering::Greater)
        })
        .map(|z| z.re * rho)
        .collect()
}

impl Spm {
    /// Every real solution (at most 8) of the FDA for the joint readings, each polished by
    /// Newton to the closure tolerance and labelled with its leg branches; sorted by distance
    /// from home. Independent of any starting guess.
    pub fn all_modes(&self, joints: &Vector3<f64>) -> Vec<AssemblyMode> {
        if !joints.iter().all(|j| j.is_finite()) {
            return Vec::new();
        }
        let w = self.intermediate_axes(joints);
        let cone = |i: usize| -> [Vector3<f64>; 3] {
            let leg = &self.legs[i];
            let p = w[i].cross(&leg.u).normalize();
            let q = w[i].cross(&p);
            [w[i] * leg.cos_a2, p * leg.sin_a2, q * leg.sin_a2]
        };
        let (e1, e2) = (cone(0), cone(1));
        let (v01, v02, v03) = (self.legs[0].v0, self.legs[1].v0, self.legs[2].v0);
        let k12 = v01.dot(&v02);
        let s12 = v01.cross(&v02).norm();
        let frame0 = so3::pair_frame(&v01, &v02);
        let c = frame0.transpose() * v03;
        let (g1, g2, g3) = (c[0] - c[1] * k12 / s12, c[1] / s12, c[2] / s12);
        let w3 = w[2];
        let first = Matrix3::from_fn(|j, l| e1[j].dot(&e2[l]) - if j + l == 0 { k12 } else { 0.0 });
        let second = Matrix3::from_fn(|j, l| {
            let mut x = g3 * e1[j].cross(&e2[l]).dot(&w3);
            if l == 0 {
                x += g1 * e1[j].dot(&w3);
            }
            if j == 0 {
                x += g2 * e2[l].dot(&w3);
            }
            if j + l == 0 {
                x -= self.legs[2].cos_a2;
            }
            x
        });
        let octic = resultant(&to_half_angle(&first), &to_half_angle(&second));
        let mut psi1s: Vec<f64> = real_roots(&octic).into_iter().map(|t| 2.0 * t.atan()).collect();
        psi1s.push(std::f64::consts::PI);

        let mut modes: Vec<AssemblyMode> = Vec::with_capacity(8);
        for psi1 in psi1s {
            for psi2 in second_angles(&first, &second, psi1) {
                let v1 = e1[0] + e1[1] * psi1.cos() + e1[2] * psi1.sin();
                let v2 = e2[0] + e2[1] * psi2.cos() + e2[2] * psi2.sin();
                let guess = Rotation3::from_matrix_unchecked(so3::pair_frame(&v1, &v2) * frame0.transpose());
                self.add_polished(&w, joints, &guess, &mut modes);
            }
        }
        // Distance from home grows as the trace falls: sort on the trace, largest first.
        modes.sort_by(|a, b| b.rotation.matrix().trace().total_cmp(&a.rotation.matrix().trace()));
        modes
    }

    /// Polish `guess` by Newton; keep it if it converged and is not already listed.
    fn add_polished(
        &self,
        w: &[Vector3<f64>; 3],
        joints: &Vector3<f64>,
        guess: &Rotation3<f64>,
        modes: &mut Vec<AssemblyMode>,
    ) {
        let Ok((rotation, _)) = self.newton(w, guess, 30) else {
            return;
        };
        // Same solution: matrices equal to 1e-8 (converged copies agree to ~1e-15).
        if modes.iter().any(|m| (m.rotation.matrix() - rotation.matrix()).amax() < 1e-8) {
            return;
        }
        modes.push(AssemblyMode {
            rotation,
            branches: self.branches(joints, &rotation),
            conditioning: self.jacobians(joints, &rotation).conditioning(),
            residual: self.closure_residual(joints, &rotation).amax(),
        });
    }
}

/// The `ψ2` that solve `E1(ψ1, ·) = 0` (closed form) and nearly solve `E2`: the one that fits `E2`
/// best, and the other as well when it fits too (a common double root).
fn second_angles(first: &Matrix3<f64>, second: &Matrix3<f64>, psi1: f64) -> Vec<f64> {
    let f1 = trig_basis(psi1);
    let coef = |l: usize| (0..3).map(|j| first[(j, l)] * f1[j]).sum::<f64>();
    let (a0, a1, a2) = (coef(0), coef(1), coef(2));
    let rho = a1.hypot(a2);
    if rho <= 1e-12 * (a0.abs() + 1.0) {
        return Vec::new();
    }
    let ratio = -a0 / rho;
    if ratio.abs() > 1.0 + 1e-3 {
        return Vec::new();
    }
    let (base, gamma) = (a2.atan2(a1), ratio.clamp(-1.0, 1.0).acos());
    let mut options = [base + gamma, base - gamma].map(|psi2| (eval_bilinear(second, psi1, psi2).abs(), psi2));
    options.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Loose filters: a root of the octic known to ~1e-8 leaves E2 ~1e-8; Newton does the rest.
    let mut out = Vec::with_capacity(2);
    if options[0].0 < 1e-2 {
        out.push(options[0].1);
    }
    if options[1].0 < 1e-6 {
        out.push(options[1].1);
    }
    out
}
