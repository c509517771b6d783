//! The FDA of one pose as `spmcal fda` reports it: the working-mode orientation with its
//! conditioning, or every real assembly mode with its leg branches, the working mode first.

use nalgebra::{Rotation3, Vector3};
use serde::Serialize;

use super::spm::{FdaError, Spm};
use crate::math::so3;

/// One assembly mode of a pose.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeReport {
    /// 0 is the working mode when it exists.
    pub mode: usize,
    /// MP orientation, scalar first.
    pub q_wxyz: [f64; 4],
    /// Leg branch signs, e.g. `---`.
    pub branches: String,
    /// Conditioning index of the closure Jacobian.
    pub conditioning: f64,
    /// Whether this is the working mode (continuation from home).
    pub working: bool,
}

/// The FDA of one pose: the working mode ([`FdaPose::working`]) or every assembly mode
/// ([`FdaPose::all_modes`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FdaPose {
    /// Pose number.
    pub pose: u64,
    /// Working-mode orientation (without `--all-modes`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub q_wxyz: Option<[f64; 4]>,
    /// Its conditioning index.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conditioning: Option<f64>,
    /// Every real assembly mode (with `--all-modes`), the working mode first.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub modes: Vec<ModeReport>,
}

impl FdaPose {
    /// The working mode of pose `pose` at `joints` (continuation from home) with the conditioning
    /// index of its closure Jacobian; also its orientation, for a table of orientations.
    ///
    /// # Errors
    /// The working-mode FDA fails (see [`Spm::forward`]).
    pub fn working(spm: &Spm, pose: u64, joints: &Vector3<f64>) -> Result<(FdaPose, Rotation3<f64>), FdaError> {
        let rotation = spm.forward(joints)?;
        let conditioning = spm.jacobians(joints, &rotation).conditioning();
        let q = Some(so3::to_wxyz(&rotation));
        Ok((FdaPose { pose, q_wxyz: q, conditioning: Some(conditioning), modes: Vec::new() }, rotation))
    }

    /// Every real assembly mode of pose `pose` at `joints`, the working mode first.
    pub fn all_modes(spm: &Spm, pose: u64, joints: &Vector3<f64>) -> FdaPose {
        FdaPose { pose, q_wxyz: None, conditioning: None, modes: modes_working_first(spm, joints) }
    }
}

/// Every real assembly mode of `joints`, the working mode (continuation from home), when it
/// exists, first and flagged: the ordering `fda --all-modes` prints.
fn modes_working_first(spm: &Spm, joints: &Vector3<f64>) -> Vec<ModeReport> {
    let working = spm.forward(joints).ok();
    let is_working = |r: &Rotation3<f64>| working.is_some_and(|w| so3::geodesic_angle(r, &w) < 1e-8);
    let mut modes = spm.all_modes(joints);
    modes.sort_by_key(|m| !is_working(&m.rotation));
    modes
        .iter()
        .enumerate()
        .map(|(k, m)| ModeReport {
            mode: k,
            q_wxyz: so3::to_wxyz(&m.rotation),
            branches: m.branch_label(&spm.home_branches()),
            conditioning: m.conditioning,
            working: is_working(&m.rotation),
        })
        .collect()
}
