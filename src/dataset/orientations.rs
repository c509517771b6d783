//! Orientation tables: `pose,qw,qx,qy,qz` (unit quaternion, scalar first, MP frame → base frame),
//! with an optional `mode` column after `pose` for the FDA's assembly modes.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Rotation3;

use crate::io::files::{FileError, push_numbers};
use crate::io::table::Table;
use crate::math::so3;

/// One orientation of a table.
#[derive(Debug, Clone, PartialEq)]
pub struct OrientationRecord {
    /// Pose id.
    pub pose: u64,
    /// Assembly mode index (FDA with all modes), if any.
    pub mode: Option<usize>,
    /// MP orientation (P → B).
    pub rotation: Rotation3<f64>,
    /// Extra trailing columns, `(name, value)`, written after the quaternion.
    pub extra: Vec<(String, String)>,
    /// Line of the file it came from (0 when not read from a file).
    pub line: usize,
}

/// Read `pose,qw,qx,qy,qz`; a quaternion whose norm is not 1 (within 1e-6) is an error.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first bad value or non-unit quaternion.
pub(crate) fn read_orientations(path: &Path) -> Result<Vec<OrientationRecord>, FileError> {
    let mut table = Table::open(path, &["pose", "qw", "qx", "qy", "qz"])?;
    table.read_all(|row, _| {
        let (pose, rotation) = (row.index(0)?, row.quaternion(1)?);
        Ok(OrientationRecord { pose, mode: None, rotation, extra: Vec::new(), line: row.line })
    })
}

/// The table as CSV text; a `mode` column follows `pose` when any record has a mode, and the
/// extra columns of the first record name the trailing columns.
pub(crate) fn write_orientations(records: &[OrientationRecord]) -> String {
    let with_mode = records.iter().any(|r| r.mode.is_some());
    let mut text = String::from(if with_mode { "pose,mode,qw,qx,qy,qz" } else { "pose,qw,qx,qy,qz" });
    if let Some(first) = records.first() {
        for (name, _) in &first.extra {
            text.push(',');
            text.push_str(name);
        }
    }
    text.push('\n');
    for r in records {
        let _ = write!(text, "{}", r.pose);
        if with_mode {
            let _ = write!(text, ",{}", r.mode.unwrap_or(0));
        }
        push_numbers(&mut text, &so3::to_wxyz(&r.rotation));
        for (_, value) in &r.extra {
            let _ = write!(text, ",{value}");
        }
        text.push('\n');
    }
    text
}

impl OrientationRecord {
    /// Read `pose,qw,qx,qy,qz`; a quaternion whose norm is not 1 (within 1e-6) is an error.
    ///
    /// # Errors
    /// A [`FileError`] naming the line and column of the first bad value or non-unit quaternion.
    pub fn read(path: &Path) -> Result<Vec<OrientationRecord>, FileError> {
        read_orientations(path)
    }

    /// The table as CSV text; a `mode` column follows `pose` when any record has a mode, and the
    /// extra columns of the first record name the trailing columns.
    pub fn csv(records: &[OrientationRecord]) -> String {
        write_orientations(records)
    }
}
