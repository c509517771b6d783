//! Residuals of the fit and their analytic Jacobian.
//!
//! The camera measures `Q_j`, the rotation of the MP's markers from the reference pose to pose j
//! (camera frame). The model predicts `R_j = FDA(θ_j)` (P → B). With `A` the orientation of the
//! reference pose's markers in the camera, they agree when `Q_j A = R_CB R_j`; the residual is the
//! rotation vector `r_j = log(Q_j A R_jᵀ R_CBᵀ)` (camera frame, radians).
//!
//! `A` is a parameter of its own instead of `R_CB FDA(θ_0)`: the reference pose's measurement error
//! enters every `Q_j` alike, and a free `A` absorbs it exactly, so that it cannot bias the
//! mechanism's parameters; the reference pose is then just one more pose (its `Q_0 = I`).
//!
//! Derivatives (all perturbations on the left, `X ← exp(ε) X`; `J_l` the left Jacobian of SO(3)):
//! `dr = J_l⁻¹(r) Q_j ε_A` for `A`, `dr = −J_l⁻¹(r) M ε_C` for `R_CB` (`M = Q_j A R_jᵀ R_CBᵀ`), and
//! for the mechanism `dr = J_l⁻¹(r) M R_CB Ã⁻¹ F_x dx`, by the implicit function theorem on the
//! closure equations `f_i = w_i · R v0_i − cos α2_i = 0` (`Ã` rows `(v_i × w_i)ᵀ`, `F_x = ∂f/∂x`).

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};

use super::params::{Kind, Parameterisation};
use crate::dataset::Session;
use crate::model::{FdaError, LegGeometry, Spm, SpmError};
use crate::so3;
use crate::vision::SessionEstimate;

/// One pose of the fit: joint readings and the measured rotation from the reference pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Pose id.
    pub pose: u64,
    /// Joint readings.
    pub joints: Vector3<f64>,
    /// `Q_j`, camera frame.
    pub measured: Rotation3<f64>,
    /// Markers the vision estimate used (its noise depends on it).
    pub markers: usize,
}

/// An observation with the orientation a model predicts from its joints.
pub type Predicted = (Observation, Rotation3<f64>);

/// A pose whose forward kinematics failed, and why.
pub type Unpredicted = (u64, FdaError);

/// The estimated poses of a session as observations, each with the orientation `spm` predicts
/// from its joints; the poses whose forward kinematics fails, with the error.
///
/// # Panics
/// If `vision` holds a pose that is not in `session` (an estimate of another session).
pub fn observations(session: &Session, vision: &SessionEstimate, spm: &Spm) -> (Vec<Predicted>, Vec<Unpredicted>) {
    let (mut kept, mut failed) = (Vec::new(), Vec::new());
    let joints_of: std::collections::HashMap<u64, Vector3<f64>> =
        session.poses.iter().map(|p| (p.id, p.joints)).collect();
    for (pose, estimate) in &vision.poses {
        let joints = joints_of[pose];
        match spm.forward(&joints) {
            Ok(r) => kept.push((
                Observation { pose: *pose, joints, measured: estimate.rotation, markers: estimate.markers_used },
                r,
            )),
            Err(e) => failed.push((*pose, e)),
        }
    }
    (kept, failed)
}

/// Residuals (and optionally their Jacobian) at a parameter vector.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// Per-pose residual rotation vectors (radians), camera frame.
    pub residuals: Vec<Vector3<f64>>,
    /// Predicted MP orientations `R_j` (P → B).
    pub orientations: Vec<Rotation3<f64>>,
    /// `3n × N`: rows `3j..3j+3` belong to pose j.
    pub jacobian: Option<DMatrix<f64>>,
    /// Sensitivity of each predicted orientation to the parameters, `∂ω_j/∂x` (3 × N), for the
    /// orientation uncertainty.
    pub orientation_jacobians: Option<Vec<DMatrix<f64>>>,
}

/// Why the model could not be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    #[error("the parameters do not make a valid manipulator: {0}")]
    /// The parameters make no valid manipulator.
    Geometry(SpmError),
    #[error("pose {pose}: at a camera latency of {latency_s} s its frame falls outside the encoder stream")]
    /// A frame falls outside the encoder stream at the latency tried.
    OutsideStream {
        /// Pose (frame) id.
        pose: u64,
        /// The latency tried (s).
        latency_s: f64,
    },
    #[error("pose {pose}: forward kinematics failed: {error}")]
    /// The forward kinematics of a pose failed.
    Fda {
        /// Pose id.
        pose: u64,
        /// Why.
        error: FdaError,
    },
}

/// Evaluate the residuals at `x`. The FDA of each pose starts from `warm` (the orientations of the
/// previous evaluation) when given, else continues from home.
///
/// # Errors
/// An [`EvalError`] when the parameters make no valid manipulator or a pose's FDA fails.
pub fn evaluate(
    p: &Parameterisation,
    x: &DVector<f64>,
    observations: &[Observation],
    warm: Option<&[Rotation3<f64>]>,
    with_jacobian: bool,
) -> Result<Evaluation, EvalError> {
    evaluate_with(p, x, observations, warm, with_jacobian, true)
}

/// [`evaluate`], the mechanism's Jacobian columns computed only when `mechanism` is set.
pub(crate) fn evaluate_with(
    p: &Parameterisation,
    x: &DVector<f64>,
    observations: &[Observation],
    warm: Option<&[Rotation3<f64>]>,
    with_jacobian: bool,
    mechanism: bool,
) -> Result<Evaluation, EvalError> {
    let legs = p.legs(x);
    let spm = Spm::new(legs).map_err(EvalError::Geometry)?;
    let (camera, reference) = (p.camera(x), p.reference(x));
    let n = observations.len();
    let mut eval = Evaluation {
        residuals: Vec::with_capacity(n),
        orientations: Vec::with_capacity(n),
        jacobian: with_jacobian.then(|| DMatrix::zeros(3 * n, p.len())),
        orientation_jacobians: with_jacobian.then(|| Vec::with_capacity(n)),
    };
    let frames = Frames::new(p, x);
    for (j, obs) in observations.iter().enumerate() {
        let r = match warm {
            Some(w) => spm.track(&obs.joints, &w[j]),
            None => spm.forward(&obs.joints),
        }
        .map_err(|error| EvalError::Fda { pose: obs.pose, error })?;
        let m = obs.measured * reference * r.inverse() * camera.inverse();
        let residual = so3::log(&m);
        if let (Some(jac), Some(sens)) = (eval.jacobian.as_mut(), eval.orientation_jacobians.as_mut()) {
            let d_omega = if mechanism {
                frames.orientation_sensitivity(&spm, &legs, &obs.joints, &r)
            } else {
                DMatrix::zeros(3, p.len())
            };
            let jl_inv = so3::left_jacobian_inverse(&residual);
            let mech = jl_inv * m.matrix() * camera.matrix();
            let mut block = -(mech * &d_omega);
            let (c, a) = p.registration_vectors(x);
            let (jc, ja) = (so3::left_jacobian(&c), so3::left_jacobian(&a));
            for (i, e) in p.entries.iter().enumerate() {
                match e.kind {
                    Kind::Camera { k } => block.set_column(i, &(-(jl_inv * m.matrix() * jc.column(k)))),
                    Kind::Reference { k } => block.set_column(i, &(jl_inv * obs.measured.matrix() * ja.column(k))),
                    _ => {}
                }
            }
            jac.view_mut((3 * j, 0), (3, p.len())).copy_from(&block);
            sens.push(d_omega);
        }
        eval.residuals.push(residual);
        eval.orientations.push(r);
    }
    Ok(eval)
}

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

    /// `∂ω/∂x = −Ã⁻¹ F_x` (3 × N; zero columns for the registration).
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
        let (sp, cp) = (theta + g.delta).sin_cos();
        let y = g.u.cross(&g.z);
        match kind {
            Kind::Alpha1 { .. } => (-g.u * sa + (g.z * cp + y * sp) * ca).dot(v),
            Kind::Alpha2 { .. } => g.alpha2.sin(),
            Kind::Offset { .. } => ((-g.z * sp + y * cp) * sa).dot(v),
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
            Kind::Camera { .. }
            | Kind::Reference { .. }
            | Kind::Translation { .. }
            | Kind::Marker { .. }
            | Kind::Latency => 0.0,
        }
    }
}
