//! `joints.csv`: `pose,theta1_rad,theta2_rad,theta3_rad` (extra columns such as `time_s` allowed).

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use crate::files::{FileError, number, write_atomic};
use crate::table::Table;

/// Joint readings of one pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointReading {
    pub pose: u64,
    /// Line of the file it came from (0 when not read from a file).
    pub line: usize,
    pub joints: Vector3<f64>,
}

const COLUMNS: [&str; 4] = ["pose", "theta1_rad", "theta2_rad", "theta3_rad"];

/// Read `joints.csv`; non-numbers, non-finite values and repeated poses are errors naming the line.
pub fn read_joints(path: &Path) -> Result<Vec<JointReading>, FileError> {
    let mut table = Table::open(path, &COLUMNS)?;
    let mut seen = HashSet::new();
    let mut out = Vec::new();
    let rows: Vec<_> = table.rows().collect::<Result<_, _>>()?;
    for row in rows {
        let pose = table.index(&row, 0)?;
        if !seen.insert(pose) {
            return Err(table.error(&row, 0, format!("pose {pose} appears twice")));
        }
        let joints = Vector3::new(
            table.number(&row, 1)?,
            table.number(&row, 2)?,
            table.number(&row, 3)?,
        );
        out.push(JointReading {
            pose,
            line: row.line,
            joints,
        });
    }
    Ok(out)
}

/// Write `joints.csv` atomically, with full precision.
pub fn write_joints(path: &Path, readings: &[JointReading]) -> Result<(), FileError> {
    let mut text = COLUMNS.join(",") + "\n";
    for r in readings {
        let _ = writeln!(
            text,
            "{},{},{},{}",
            r.pose,
            number(r.joints[0]),
            number(r.joints[1]),
            number(r.joints[2])
        );
    }
    write_atomic(path, text.as_bytes())
}
