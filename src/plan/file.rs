//! `plan.csv`: `step,qw,qx,qy,qz,theta1_rad,theta2_rad,theta3_rad`, one row per pose in capture
//! order — the MP orientation to reach and the joint readings the model expects there.

use std::path::Path;

use nalgebra::{Rotation3, Vector3};

use crate::io::files::{FileError, push_numbers};
use crate::io::table::Table;
use crate::math::so3;
use crate::sim::{PlanRow, PlanSource, SimConfig};

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

/// Read `plan.csv`: its rows, each with its line. The steps number the rows 1, 2, 3, … in file
/// order: a repeated step, a missing one, a first step other than 1 and a row out of step order
/// are errors naming the line, as are a quaternion whose norm is not 1 (within 1e-6) and any
/// non-number; an empty plan is an error. Linear: one pass, one hash map of the steps.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first problem.
fn read_rows(path: &Path) -> Result<Vec<(PlannedPose, usize)>, FileError> {
    let mut table = Table::open(path, &COLUMNS)?;
    let poses = table.read_all(|row, _| {
        let (step, rotation) = (row.index(0)?, row.quaternion(1)?);
        let joints = Vector3::new(row.number(5)?, row.number(6)?, row.number(7)?);
        Ok((PlannedPose { step, rotation, joints }, row.line))
    })?;
    if poses.is_empty() {
        return Err(FileError::new(path, "the plan has no poses"));
    }
    // The first row whose step is not its place in the file says what is wrong with the steps.
    let Some(k) = poses.iter().enumerate().position(|(k, (p, _))| p.step != k as u64 + 1) else {
        return Ok(poses);
    };
    let (step, line) = (poses[k].0.step, poses[k].1);
    let expected = k as u64 + 1;
    let reason = if step == 0 {
        "step 0: the steps number the rows from 1".to_string()
    } else if step < expected {
        // The rows before are steps 1 … k in order: step s is row s − 1.
        format!("step {step} appears twice (also at line {})", poses[step as usize - 1].1)
    } else {
        let lines: foldhash::HashMap<u64, usize> = poses[k..].iter().map(|(p, line)| (p.step, *line)).collect();
        match lines.get(&expected) {
            Some(later) => {
                format!("step {step} comes before step {expected} (line {later}): the rows must be in step order")
            }
            None if expected == 1 => format!("the first step is {step}: the steps number the rows from 1"),
            None => format!("step {step} follows step {}: step {expected} is missing", expected - 1),
        }
    };
    Err(table.error_at(line, 0, reason))
}

/// Read `plan.csv`: its poses in step order, which is its rows' order (see [`read_rows`]).
///
/// # Errors
/// A [`FileError`] naming the line and column of the first problem.
pub(crate) fn read_plan(path: &Path) -> Result<Vec<PlannedPose>, FileError> {
    Ok(read_rows(path)?.into_iter().map(|(p, _)| p).collect())
}

impl PlannedPose {
    /// Read a `plan.csv`: steps 1, 2, 3, … in file order (a gap, a repeat or a step out of order
    /// is an error naming the line), unit quaternions, numbers everywhere; an empty plan is an
    /// error. Whether its joints agree with its quaternions needs the model: see
    /// [`PlannedPose::read_into`].
    ///
    /// # Errors
    /// A [`FileError`] naming the line and column of the first problem.
    pub fn read(path: &Path) -> Result<Vec<PlannedPose>, FileError> {
        read_plan(path)
    }

    /// Read a `plan.csv` (as [`PlannedPose::read`]) into a simulation config: its orientations
    /// as the poses to capture (`plan`, and `poses` their number) and its rows (`plan_source`:
    /// the file, each row's line, step and joints), so that [`SimConfig::simulate`] refuses,
    /// naming the file and line, a row the model cannot reach, one outside the config's
    /// workspace, and one whose joints contradict its quaternion under the model.
    ///
    /// # Errors
    /// A [`FileError`] naming the line and column of the first problem of the file.
    pub fn read_into(path: &Path, config: &mut SimConfig) -> Result<Vec<PlannedPose>, FileError> {
        let rows = read_rows(path)?;
        config.poses = rows.len();
        config.plan = Some(rows.iter().map(|(p, _)| p.rotation).collect());
        config.plan_source = Some(PlanSource {
            path: path.to_path_buf(),
            rows: rows.iter().map(|&(p, line)| PlanRow { step: p.step, line, joints: p.joints }).collect(),
        });
        Ok(rows.into_iter().map(|(p, _)| p).collect())
    }

    /// `plan.csv` text.
    pub fn csv(poses: &[PlannedPose]) -> String {
        plan_csv(poses)
    }
}
