//! How the MP's orientation moves with the mechanism's parameters at a pose, `∂ω/∂x = −Ã⁻¹ F_x`,
//! by the implicit function theorem on the closure equations `f_i = w_i · R v0_i − cos α2_i = 0`
//! (`Ã` rows `(v_i × w_i)ᵀ`, `F_x = ∂f/∂x`; perturbations on the left, `R ← exp(ε) R` in B).
//! Both fit levels' Jacobians are built on it. The platform's sag turns the rigid mechanism's
//! orientation once more (`Spm::sagged`): [`through_sag`] carries the rigid derivatives to the
//! platform as it is and adds the sag's own column.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};

use super::parameterisation::{Kind, Parameterisation};
use crate::math::so3;
use crate::model::{LegGeometry, Spm};

/// Per-leg quantities of the parameterisation at `x` that every pose's derivative uses.
pub(crate) struct Frames<'a> {
    p: &'a Parameterisation,
    /// Per leg: `J_l(φ_u) e_k` and `J_l(φ_v0) e_k` for each tilt direction.
    actuated: [Vec<Vector3<f64>>; 3],
    platform: [Vec<Vector3<f64>>; 3],
}

impl<'a> Frames<'a> {
    pub(crate) fn new(p: &'a Parameterisation, x: &DVector<f64>) -> Self {
        let actuated = std::array::from_fn(|leg| {
            let jl = so3::left_jacobian(&p.tilts(x, leg).0);
            p.actuated_dirs[leg].iter().map(|d| jl * d).collect()
        });
        let platform = std::array::from_fn(|leg| {
            let jl = so3::left_jacobian(&p.tilts(x, leg).1);
            p.platform_dirs[leg].iter().map(|d| jl * d).collect()
        });
        Frames { p, actuated, platform }
    }

    /// `∂ω/∂x = −Ã⁻¹ F_x` (3 × N; zero columns for the registration) of the rigid mechanism at its
    /// orientation `r` ([`Spm::rigid`]).
    pub(crate) fn orientation_sensitivity(
        &self,
        spm: &Spm,
        legs: &[LegGeometry; 3],
        joints: &Vector3<f64>,
        r: &Rotation3<f64>,
    ) -> DMatrix<f64> {
        let w = spm.intermediate_axes(joints);
        let v = spm.platform_axes(r);
        let a = Matrix3::from_rows(&[0, 1, 2].map(|i| v[i].cross(&w[i]).transpose()));
        let a_inv = a.try_inverse().unwrap_or_else(Matrix3::zeros);
        let mut f = DMatrix::zeros(3, self.p.len());
        for (col, e) in self.p.entries.iter().enumerate() {
            if let Some(leg) = e.kind.leg() {
                f[(leg, col)] = self.closure_derivative(e.kind, &legs[leg], joints[leg], &w[leg], &v[leg], r);
            }
        }
        let product = a_inv * f;
        -DMatrix::from_column_slice(3, self.p.len(), product.as_slice())
    }

    /// `∂f_i/∂x` for one parameter of leg i at a pose.
    fn closure_derivative(
        &self,
        kind: Kind,
        g: &LegGeometry,
        theta: f64,
        w: &Vector3<f64>,
        v: &Vector3<f64>,
        r: &Rotation3<f64>,
    ) -> f64 {
        let (sa, ca) = g.alpha1.sin_cos();
        let (sp, cp) = (g.scale * theta + g.delta).sin_cos();
        let y = g.u.cross(&g.z);
        match kind {
            Kind::Alpha1 { .. } => (-g.u * sa + (g.z * cp + y * sp) * ca).dot(v),
            Kind::Alpha2 { .. } => g.alpha2.sin(),
            Kind::Offset { .. } => ((-g.z * sp + y * cp) * sa).dot(v),
            // φ = sθ + δ: the scale moves the joint's angle θ times as far as the offset does.
            Kind::Scale { .. } => theta * ((-g.z * sp + y * cp) * sa).dot(v),
            Kind::PlatformTilt { leg, k } => w.dot(&(r * self.platform[leg][k].cross(&g.v0))),
            Kind::ActuatedTilt { leg, k } => {
                // u moves by du; z = N(z⁰ − (z⁰·u) u) follows it; y = u × z.
                let du = self.actuated[leg][k].cross(&g.u);
                let z0 = self.p.initial[leg].z;
                let m = z0 - g.u * z0.dot(&g.u);
                let dm = -g.u * z0.dot(&du) - du * z0.dot(&g.u);
                let dz = (dm - g.z * g.z.dot(&dm)) / m.norm();
                let dy = du.cross(&g.z) + g.u.cross(&dz);
                (du * ca + (dz * cp + dy * sp) * sa).dot(v)
            }
            Kind::PlatformSag
            | Kind::Camera { .. }
            | Kind::Reference { .. }
            | Kind::Translation { .. }
            | Kind::Marker { .. }
            | Kind::CameraTerm { .. }
            | Kind::Rig { .. }
            | Kind::Latency
            | Kind::ClockRate => 0.0,
        }
    }
}

/// The rigid mechanism's sensitivity `s` (3 × N, at its orientation `rigid`) carried to the
/// platform as it is, `R_obs = exp(c·a(R)) R` with `a(R) = (R z) × (−z)`: a turn `ω` of the rigid
/// platform turns it by `(E + c J_l(c a) D) ω`, `E = exp(c a)`, `D = ∂a/∂ω = [−z]× [R z]×`; the sag's
/// own column (`sag`, its index) is `J_l(c a) a`. Nothing to do for a rigid mechanism without the
/// sag among the parameters.
pub(crate) fn through_sag(spm: &Spm, rigid: &Rotation3<f64>, s: &mut DMatrix<f64>, sag: Option<usize>) {
    let c = spm.platform_sag();
    let arm = crate::model::sag_arm(rigid);
    if c != 0.0 {
        let jl = so3::left_jacobian(&(arm * c));
        let up: Vector3<f64> = Vector3::z();
        let d: Matrix3<f64> = (-up).cross_matrix() * (rigid * up).cross_matrix();
        let m: Matrix3<f64> = so3::exp(&(arm * c)).matrix() + jl * d * c;
        let turned: DMatrix<f64> = DMatrix::from_fn(3, 3, |a, b| m[(a, b)]) * &*s;
        s.copy_from(&turned);
    }
    if let Some(i) = sag {
        let column = so3::left_jacobian(&(arm * c)) * arm;
        s.set_column(i, &column);
    }
}
