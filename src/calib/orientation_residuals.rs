//! The orientation-level model: one rotation residual per pose and its analytic Jacobian.
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

use super::config::FitLevel;
use super::parameterisation::{Kind, Parameterisation};
use super::residuals::{EvalError, Evaluation, Residuals};
use super::sensitivity::{Frames, through_sag};
use crate::dataset::Session;
use crate::math::so3;
use crate::model::{FdaError, Spm};
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
pub(crate) type Predicted = (Observation, Rotation3<f64>);

/// A pose whose forward kinematics failed, and why.
pub(crate) type Unpredicted = (u64, FdaError);

/// The estimated poses of a session as observations, each with the orientation `spm` predicts
/// from its joints; the poses whose forward kinematics fails, with the error.
///
/// # Panics
/// If `vision` holds a pose that is not in `session` (an estimate of another session).
pub(crate) fn observations(
    session: &Session,
    vision: &SessionEstimate,
    spm: &Spm,
) -> (Vec<Predicted>, Vec<Unpredicted>) {
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

/// Classes with fewer poses than this share the pooled covariance.
const MIN_CLASS: usize = 12;

/// The residual covariance of each class of poses (by the markers the estimate used):
/// `(markers used, poses, Σ_r)` (rad²). A stereo camera measures depth several times worse than
/// across, and a pose seen with three markers has no redundancy to filter its noise.
pub(crate) type ResidualClasses = Vec<(usize, usize, Matrix3<f64>)>;

/// The orientation-level model: one rotation residual per pose, `r_j = log(Q_j A R_jᵀ R_CBᵀ)`.
#[derive(Debug, Clone)]
pub(crate) struct OrientationResiduals<'a> {
    p: &'a Parameterisation,
    observations: Vec<Observation>,
    /// Whether the mechanism's Jacobian columns (most of the cost) are computed.
    mechanism: bool,
}

impl<'a> OrientationResiduals<'a> {
    /// The model of `observations`.
    pub(crate) fn new(p: &'a Parameterisation, observations: &[Observation]) -> Self {
        OrientationResiduals { p, observations: observations.to_vec(), mechanism: true }
    }

    /// The observations.
    pub(crate) fn observations(&self) -> &[Observation] {
        &self.observations
    }
}

impl Residuals for OrientationResiduals<'_> {
    type Noise = ResidualClasses;

    fn parameterisation(&self) -> &Parameterisation {
        self.p
    }

    fn len(&self) -> usize {
        self.observations.len()
    }

    fn with_columns(mut self, columns: Vec<bool>) -> Self {
        self.mechanism = self.p.entries.iter().zip(&columns).any(|(e, &c)| c && e.kind.moves_platform());
        self
    }

    fn subset(&self, rows: &[usize]) -> Self {
        let observations = rows.iter().map(|&j| self.observations[j]).collect();
        OrientationResiduals { observations, ..*self }
    }

    fn group(&self, j: usize) -> (bool, u64) {
        (false, self.observations[j].pose)
    }

    fn pose_of(&self, j: usize) -> usize {
        j
    }

    fn observed(&self, _x: &DVector<f64>) -> Vec<super::residuals::Observed> {
        self.observations
            .iter()
            .map(|o| super::residuals::Observed { joints: o.joints, ..Default::default() })
            .collect()
    }

    fn poses(&self) -> usize {
        self.observations.len()
    }

    fn unit_scale(&self) -> f64 {
        // As `f64::to_degrees` computes it, so that figures in degrees agree to the bit.
        180.0f64 / std::f64::consts::PI
    }

    fn level(&self) -> FitLevel {
        FitLevel::Orientations
    }

    fn estimate_noise(&self, residuals: &[Vector3<f64>], weights: &[f64]) -> ResidualClasses {
        let everyone: Vec<usize> = (0..residuals.len()).collect();
        let pooled = weighted_covariance(residuals, &everyone, weights);
        let mut counts: Vec<usize> = self.observations.iter().map(|o| o.markers).collect();
        counts.sort_unstable();
        counts.dedup();
        counts
            .iter()
            .map(|&m| {
                let members: Vec<usize> =
                    everyone.iter().copied().filter(|&j| self.observations[j].markers == m).collect();
                let cov =
                    if members.len() >= MIN_CLASS { weighted_covariance(residuals, &members, weights) } else { pooled };
                (m, members.len(), cov)
            })
            .collect()
    }

    fn whitening(&self, classes: &ResidualClasses) -> Vec<Matrix3<f64>> {
        let roots: Vec<(usize, Matrix3<f64>)> = classes.iter().map(|(m, _, c)| (*m, inverse_root(c))).collect();
        let root_of = |m: usize| roots.iter().find(|(k, _)| *k == m).map_or_else(Matrix3::identity, |(_, r)| *r);
        self.observations.iter().map(|o| root_of(o.markers)).collect()
    }

    /// The FDA of each pose starts from `warm` (the orientations of the previous evaluation) when
    /// given, else continues from home.
    fn evaluate(
        &self,
        x: &DVector<f64>,
        warm: Option<&[Rotation3<f64>]>,
        with_jacobian: bool,
    ) -> Result<Evaluation, EvalError> {
        let (p, observations) = (self.p, &self.observations[..]);
        let mechanism = self.mechanism;
        let legs = p.legs(x);
        let spm = p.spm(x).map_err(EvalError::Geometry)?;
        let sag = p.entries.iter().position(|e| e.kind == Kind::PlatformSag).filter(|_| mechanism);
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
                    let rigid = spm.rigid(&r);
                    let mut s = frames.orientation_sensitivity(&spm, &legs, &obs.joints, &rigid);
                    through_sag(&spm, &rigid, &mut s, sag);
                    s
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
}

fn weighted_covariance(residuals: &[Vector3<f64>], members: &[usize], weights: &[f64]) -> Matrix3<f64> {
    let total: f64 = members.iter().map(|&j| weights[j]).sum::<f64>().max(f64::MIN_POSITIVE);
    members.iter().map(|&j| residuals[j] * residuals[j].transpose() * weights[j]).sum::<Matrix3<f64>>() / total
}

/// `Σ^{-1/2}`, with the spectrum floored so that noise-free data (zero residuals) stays defined.
pub(crate) fn inverse_root(covariance: &Matrix3<f64>) -> Matrix3<f64> {
    let Some(eig) = crate::math::linalg::bounded_symmetric_eigen(covariance) else {
        return Matrix3::identity();
    };
    let floor = (eig.eigenvalues.max() * 1e-8).max(1e-30);
    let inv_root = Matrix3::from_diagonal(&eig.eigenvalues.map(|l| 1.0 / l.max(floor).sqrt()));
    eig.eigenvectors * inv_root * eig.eigenvectors.transpose()
}
