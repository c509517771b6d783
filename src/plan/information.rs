//! What each candidate pose would tell the marker-level fit, and what the user wants to know.
//!
//! A candidate's information is the Fisher information of its marker observations,
//! `M_c = Σ_k J_kᵀ Σ_k⁻¹ J_k`, at the parameters planned around and under the config's stereo
//! noise (`J_k` the Jacobian of marker `k`'s predicted camera position, `Σ_k` its stereo
//! covariance). What the user wants is the mechanism's orientation over the workspace, measured as
//! the calibration's report and `compare` measure it — up to a rotation of the base and one of the
//! platform common to every pose, which no measurement sees — so the design criterion weighs the
//! parameters' covariance by `L = mean_e G̃_eᵀ G̃_e`, `G̃_e` the sensitivity `∂ω_e/∂x` of the
//! orientation the model predicts at workspace pose `e` with those common rotations (fitted over
//! the workspace) projected out; the candidates themselves sample the workspace. `tr(L M⁻¹)` is
//! then the report's `predicted_error_deg`, squared, over the workspace (I-optimality).

use nalgebra::{DMatrix, DVector};

use crate::calib::{
    EvalError, MarkerObservation, MarkerResiduals, Parameterisation, Residuals as _, StereoNoise, common_rotations,
};
use crate::model::CameraRegistration;
use crate::sim::{Camera, Candidate};

/// The candidates' information and the workspace weighting.
#[derive(Debug, Clone)]
pub(crate) struct Information {
    /// `M_c` per candidate (p × p).
    pub(crate) per_candidate: Vec<DMatrix<f64>>,
    /// `G_c` per candidate (3 × p): the orientation's sensitivity to the parameters there.
    pub(crate) sensitivities: Vec<DMatrix<f64>>,
    /// `G̃_c` per candidate: `G_c` less the rotations common to the workspace.
    pub(crate) projected: Vec<DMatrix<f64>>,
    /// `L = mean_e G̃_eᵀ G̃_e` over the workspace's poses (p × p).
    pub(crate) workspace: DMatrix<f64>,
}

impl Information {
    /// The information of each candidate's visible markers under `noise`, and the workspace
    /// weighting over the poses `workspace` (where the accuracy counts: the workspace's poses
    /// without the candidates' safety margin), at `x = 0` of `p` (the parameters planned
    /// around); `camera` places the markers in the camera frame as the model predicts them.
    ///
    /// # Errors
    /// The model cannot be evaluated at a candidate (in words).
    pub(crate) fn of(
        p: &Parameterisation,
        camera: &CameraRegistration,
        candidates: &[Candidate],
        workspace: &[Candidate],
        noise: &StereoNoise,
    ) -> Result<Information, EvalError> {
        let x0 = DVector::zeros(p.len());
        let rig = p.rig(&x0);
        // What each candidate's visible markers give: the point, or a pixel per camera of a pixel
        // session's rig that sees it within its image.
        let observations = |c: usize, marker: usize| -> Vec<MarkerObservation> {
            let candidate = &candidates[c];
            let y = camera.rotation * (candidate.rotation * p.marker(&x0, marker)) + camera.translation;
            let observation = |measured, camera| MarkerObservation {
                pose: c as u64,
                marker,
                joints: candidate.joints,
                measured,
                camera,
                line: 0,
                station: None,
                time_s: None,
                rotation: false,
            };
            match &rig {
                None => vec![observation(p.camera_model(&x0).distort(&y), None)],
                Some(rig) => (0..rig.cameras.len())
                    .filter_map(|k| {
                        let pixel = rig.project(k, &y)?.lens.pixel;
                        let [w, h] = rig.cameras[k].lens.resolution;
                        let inside =
                            pixel.x >= -0.5 && pixel.y >= -0.5 && pixel.x < w as f64 - 0.5 && pixel.y < h as f64 - 0.5;
                        inside.then(|| observation(nalgebra::Vector3::new(pixel.x, pixel.y, 0.0), Some(k)))
                    })
                    .collect(),
            }
        };
        let seen: Vec<MarkerObservation> = (0..candidates.len())
            .flat_map(|c| candidates[c].visible.iter().map(move |&k| (c, k)))
            .flat_map(|(c, k)| observations(c, k))
            .collect();
        let mut per_candidate = vec![DMatrix::zeros(p.len(), p.len()); candidates.len()];
        for (c, m) in MarkerResiduals::new(p, &seen).information_per_pose(&x0, noise)? {
            per_candidate[c as usize] = m;
        }
        // One observation per pose gives every pose's orientation sensitivity, seen or not.
        let sensitivities_of = |poses: &[Candidate]| -> Result<Vec<DMatrix<f64>>, EvalError> {
            let every: Vec<MarkerObservation> = poses
                .iter()
                .enumerate()
                .map(|(k, c)| MarkerObservation {
                    pose: k as u64,
                    marker: 0,
                    joints: c.joints,
                    measured: nalgebra::Vector3::zeros(),
                    camera: None,
                    line: 0,
                    station: None,
                    time_s: None,
                    rotation: false,
                })
                .collect();
            // Always there when the Jacobian is asked for.
            Ok(MarkerResiduals::new(p, &every).evaluate(&x0, None, true)?.orientation_jacobians.unwrap_or_default())
        };
        let sensitivities = sensitivities_of(candidates)?;
        let in_workspace = sensitivities_of(workspace)?;
        let rotations: Vec<_> = workspace.iter().map(|c| c.rotation).collect();
        let every_column = vec![true; p.len()];
        // The rotations common to every pose of the workspace, projected out of each pose.
        let common = common_rotations(&in_workspace, &rotations, &every_column);
        let project = |s: &[DMatrix<f64>], poses: &[Candidate]| -> Vec<DMatrix<f64>> {
            match &common {
                Some(common) => s.iter().zip(poses).map(|(g, c)| common.project(g, &c.rotation)).collect(),
                None => s.to_vec(),
            }
        };
        let projected = project(&sensitivities, candidates);
        let mut weighting = DMatrix::zeros(p.len(), p.len());
        for g in project(&in_workspace, workspace) {
            weighting += g.transpose() * &g;
        }
        weighting /= workspace.len().max(1) as f64;
        Ok(Information { per_candidate, sensitivities, projected, workspace: weighting })
    }
}

impl Information {
    /// The same information over the parameters `keep` only (in that order): each candidate's
    /// information and the weighting restricted to them, the sensitivities' columns selected (the
    /// common rotations are projected out of every column alike, so selecting commutes with it).
    pub(crate) fn select(&self, keep: &[usize]) -> Information {
        let square = |m: &DMatrix<f64>| DMatrix::from_fn(keep.len(), keep.len(), |a, b| m[(keep[a], keep[b])]);
        let columns = |m: &DMatrix<f64>| DMatrix::from_fn(m.nrows(), keep.len(), |r, b| m[(r, keep[b])]);
        Information {
            per_candidate: self.per_candidate.iter().map(square).collect(),
            sensitivities: self.sensitivities.iter().map(columns).collect(),
            projected: self.projected.iter().map(columns).collect(),
            workspace: square(&self.workspace),
        }
    }
}

// The simulated camera's noise in the terms of the marker-level fit: here and not in `sim`,
// which sits on a floor below the fit's noise model (`calib`).
impl Camera {
    /// The noise model of this (simulated) camera, as the marker-level fit sees it.
    pub fn stereo_noise(&self) -> StereoNoise {
        StereoNoise::points(self.reference_distance_m, self.lateral_sigma_m, self.depth_sigma_m)
    }
}

/// The predicted RMS orientation error (rad, the norm of the error vector, the common rotations
/// left out) at each of the candidates' poses, for parameter covariance `covariance`.
pub(crate) fn orientation_errors(info: &Information, covariance: &DMatrix<f64>) -> Vec<f64> {
    info.projected.iter().map(|g| (g * covariance * g.transpose()).trace().max(0.0).sqrt()).collect()
}

/// The markers no candidate shows (their positions cannot be calibrated).
pub(super) fn unseen_markers(candidates: &[Candidate], markers: usize) -> Vec<usize> {
    (0..markers).filter(|k| !candidates.iter().any(|c| c.visible.contains(k))).collect()
}
