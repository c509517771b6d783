//! Rigid bodies: what a motion-capture system (OptiTrack, Vicon, vrpn) reports instead of
//! markers — per capture, the pose of a body frame attached to the MP, in the tracker's frame.
//!
//! `poses.csv` holds them: `pose,x_m,y_m,z_m,qw,qx,qy,qz` in a static session (beside
//! `joints.csv`), `time_s,x_m,y_m,z_m,qw,qx,qy,qz` in a free-motion recording (beside
//! `encoders.csv`, on the tracker's clock). The quaternion is scalar first, body frame → tracker
//! frame, as every quaternion of spmcal. `session.yaml` names the body (`body: platform`) instead
//! of listing markers.
//!
//! Every body pose, whatever it was read from (this file or a bag's messages), is made by
//! [`BodyPose::new`], which checks it: finite numbers, a position within the metres a tracker
//! measures (millimetres are the usual mistake), a quaternion of unit norm.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Rotation3, UnitQuaternion, Vector3};

use crate::io::files::{FileError, number, push_numbers};
use crate::io::table::{Row, Table, first_repeat};
use crate::math::so3;

/// A rigid body's pose as the tracker reported it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyPose {
    /// The body frame's origin in the tracker's frame (m).
    pub position: Vector3<f64>,
    /// The body frame's orientation: body frame → tracker frame.
    pub rotation: Rotation3<f64>,
    /// Line of `poses.csv` (for a bag, the message's index on its topic; 0 when made in memory).
    pub line: usize,
}

/// How far from 1 a quaternion's norm may be (trackers and their exports print 5–7 digits: a
/// quaternion rounded to 6 decimals is within 4·10⁻⁶ of unit norm; 10⁻³ is a wrong column).
pub(crate) const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

impl BodyPose {
    /// The pose at `position` (m) with the quaternion `wxyz` (scalar first), normalised; the
    /// reason it is refused otherwise: a non-finite number, a coordinate that looks like
    /// millimetres, a quaternion whose norm is not 1 within [`QUATERNION_NORM_TOLERANCE`].
    ///
    /// # Errors
    /// The reason, in words, with the column it concerns (`x_m`… or `qw`).
    pub(crate) fn new(position: Vector3<f64>, wxyz: [f64; 4], line: usize) -> Result<BodyPose, (&'static str, String)> {
        const AXES: [&str; 3] = ["x_m", "y_m", "z_m"];
        for (k, v) in position.iter().enumerate() {
            if !v.is_finite() {
                return Err((AXES[k], format!("{v} is not a finite position")));
            }
            if let Some(reason) = super::markers::millimetres_reason(*v) {
                return Err((
                    AXES[k],
                    reason.replace(
                        "a camera measures this mechanism's markers",
                        "a tracker measures this mechanism's rigid body",
                    ),
                ));
            }
        }
        let q = nalgebra::Quaternion::new(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
        let norm = q.norm();
        if !norm.is_finite() || (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
            return Err((
                "qw",
                format!(
                    "quaternion {wxyz:?} has norm {}, not 1: a body's orientation is a unit quaternion, scalar first (qw,qx,qy,qz)",
                    number(norm)
                ),
            ));
        }
        let rotation = UnitQuaternion::from_quaternion(q).to_rotation_matrix();
        Ok(BodyPose { position, rotation, line })
    }

    /// The pose in the seven columns from `first` of `row` (`x_m,y_m,z_m,qw,qx,qy,qz`).
    fn of_row(row: &Row<'_>, first: usize) -> Result<BodyPose, FileError> {
        let mut v = [0.0; 7];
        for (i, value) in v.iter_mut().enumerate() {
            *value = row.number(first + i)?;
        }
        BodyPose::new(Vector3::new(v[0], v[1], v[2]), [v[3], v[4], v[5], v[6]], row.line).map_err(|(column, reason)| {
            let k = first + ["x_m", "y_m", "z_m", "qw"].iter().position(|c| *c == column).unwrap_or(3);
            row.error(k, reason)
        })
    }
}

/// A body pose captured at a time of a free-motion recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BodyCapture {
    /// Time on the tracker's clock (s).
    pub(crate) time_s: f64,
    /// The body's pose.
    pub(crate) pose: BodyPose,
}

/// One row of a static session's `poses.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BodyRow {
    /// Pose id.
    pub(crate) pose: u64,
    /// The body's pose at it.
    pub(crate) body: BodyPose,
}

const POSE_COLUMNS: [&str; 8] = ["pose", "x_m", "y_m", "z_m", "qw", "qx", "qy", "qz"];
const TIMED_COLUMNS: [&str; 8] = ["time_s", "x_m", "y_m", "z_m", "qw", "qx", "qy", "qz"];

/// Read a static session's `poses.csv`: one body pose per pose id, each checked by
/// [`BodyPose::new`]; a repeated pose is an error at its second row.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first problem.
pub(crate) fn read_body_poses(path: &Path) -> Result<Vec<BodyRow>, FileError> {
    let mut table = Table::open(path, &POSE_COLUMNS)?;
    let out = table.read_all(|row, _| Ok(BodyRow { pose: row.index(0)?, body: BodyPose::of_row(row, 1)? }))?;
    if let Some((pose, line)) = first_repeat(out.iter().map(|r| (r.pose, r.body.line))) {
        return Err(table.error_at(line, 0, format!("pose {pose} appears twice")));
    }
    Ok(out)
}

/// Read a recording's `poses.csv`: time strictly increasing (one body pose per tracker frame),
/// at least [`super::streams::MIN_FRAMES`] of them.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first problem.
pub(crate) fn read_body_captures(path: &Path) -> Result<Vec<BodyCapture>, FileError> {
    let mut table = Table::open(path, &TIMED_COLUMNS)?;
    let out = table.read_all(|row, before: &[BodyCapture]| {
        let time_s = row.number(0)?;
        if let Some(last) = before.last().filter(|l| time_s <= l.time_s) {
            let what = if time_s == last.time_s { "repeats" } else { "goes back from" };
            return Err(row.error(0, format!("time {time_s} s {what} the previous capture's {} s", last.time_s)));
        }
        Ok(BodyCapture { time_s, pose: BodyPose::of_row(row, 1)? })
    })?;
    check_frames(path, out.len())?;
    Ok(out)
}

/// A recording needs body poses at [`super::streams::MIN_FRAMES`] times at least.
pub(crate) fn check_frames(path: &Path, frames: usize) -> Result<(), FileError> {
    let min = super::streams::MIN_FRAMES;
    if frames >= min {
        return Ok(());
    }
    Err(FileError::new(
        path,
        format!(
            "holds {frames} body pose(s): almost nothing to calibrate from — a recording needs the body at {min} times at least (a calibration many more: each gives 6 numbers, against some 30 parameters)"
        ),
    ))
}

/// A static session's `poses.csv` text, full precision.
pub(crate) fn body_poses_csv<'a>(rows: impl Iterator<Item = (u64, &'a BodyPose)>) -> String {
    let mut text = POSE_COLUMNS.join(",") + "\n";
    for (pose, body) in rows {
        let _ = write!(text, "{pose}");
        push_pose(&mut text, body);
    }
    text
}

/// A recording's `poses.csv` text, full precision.
pub(crate) fn body_captures_csv(captures: &[BodyCapture]) -> String {
    let mut text = TIMED_COLUMNS.join(",") + "\n";
    for c in captures {
        text.push_str(&number(c.time_s));
        push_pose(&mut text, &c.pose);
    }
    text
}

fn push_pose(text: &mut String, body: &BodyPose) {
    push_numbers(text, body.position.as_slice());
    push_numbers(text, &so3::to_wxyz(&body.rotation));
    text.push('\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_body_pose_refuses_what_is_not_one() {
        let at = Vector3::new(0.1, 0.2, 0.9);
        let half = std::f64::consts::FRAC_1_SQRT_2;
        let ok = BodyPose::new(at, [half, 0.0, 0.0, half], 3).unwrap();
        assert!((ok.rotation.angle() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // A quaternion printed to 6 decimals is accepted (and normalised).
        assert!(BodyPose::new(at, [0.866025, 0.0, 0.0, 0.5], 3).is_ok());
        assert_eq!(BodyPose::new(at, [1.0, 0.1, 0.0, 0.0], 3).unwrap_err().0, "qw");
        assert_eq!(BodyPose::new(Vector3::new(0.1, 250.0, 0.9), [1.0, 0.0, 0.0, 0.0], 3).unwrap_err().0, "y_m");
        let mm = BodyPose::new(Vector3::new(0.1, 250.0, 0.9), [1.0, 0.0, 0.0, 0.0], 3).unwrap_err().1;
        assert!(mm.contains("millimetres"), "{mm}");
        assert_eq!(BodyPose::new(Vector3::new(f64::NAN, 0.0, 0.0), [1.0, 0.0, 0.0, 0.0], 3).unwrap_err().0, "x_m");
    }
}
