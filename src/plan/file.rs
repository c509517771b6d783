//! `plan.csv`: `step,qw,qx,qy,qz,theta1_rad,theta2_rad,theta3_rad`, one row per pose in capture
//! order — the MP orientation to reach and the joint readings the model expects there.

use std::path::Path;

use nalgebra::{Rotation3, Vector3};

use crate::io::files::{FileError, push_numbers};
use crate::io::table::{Table, first_repeat};
use crate::math::so3;

/// One pose of a plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedPose {
    /// Its place in the capture order, from 1.
    pub step: u64,
    /// The MP orientation to reach (P → B).
    pub rotation: Rotation3<f64>,
    /// The joint readings the model expects there.
    pub joints: Vector3<f64>,
}

const COLUMNS: [&str; 8] = ["step", "qw", "qx", "qy", "qz", "theta1_rad", "theta2_rad", "theta3_rad"];

/// `plan.csv` text.
pub(crate) fn plan_csv(poses: &[PlannedPose]) -> String {
    let mut text = COLUMNS.join(",") + "\n";
    for p in poses {
        text.push_str(&p.step.to_string());
        push_numbers(&mut text, &so3::to_wxyz(&p.rotation));
        push_numbers(&mut text, p.joints.as_slice());
        text.push('\n');
    }
    text
}

/// Read `plan.csv` in its step order. A repeated step, a quaternion whose norm is not 1 (within
/// 1e-6) and any non-number are errors naming the line; an empty plan is an error.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first problem.
pub(crate) fn read_plan(path: &Path) -> Result<Vec<PlannedPose>, FileError> {
    let mut table = Table::open(path, &COLUMNS)?;
    let mut poses = table.read_all(|row, _| {
        let (step, rotation) = (row.index(0)?, row.quaternion(1)?);
        let joints = Vector3::new(row.number(5)?, row.number(6)?, row.number(7)?);
        Ok((PlannedPose { step, rotation, joints }, row.line))
    })?;
    if let Some((step, line)) = first_repeat(poses.iter().map(|(p, line)| (p.step, *line))) {
        return Err(table.error_at(line, 0, format!("step {step} appears twice")));
    }
    if poses.is_empty() {
        return Err(FileError::new(path, "the plan has no poses"));
    }
    poses.sort_by_key(|(p, _)| p.step);
    Ok(poses.into_iter().map(|(p, _)| p).collect())
}

impl PlannedPose {
    /// Read a `plan.csv`: its quaternions must agree with its joint readings and any non-number is
    /// an error naming the line; an empty plan is an error.
    ///
    /// # Errors
    /// A [`FileError`] naming the line and column of the first problem.
    pub fn read(path: &Path) -> Result<Vec<PlannedPose>, FileError> {
        read_plan(path)
    }

    /// `plan.csv` text.
    pub fn csv(poses: &[PlannedPose]) -> String {
        plan_csv(poses)
    }
}
