//! `joints.csv`: `pose,theta1_rad,theta2_rad,theta3_rad`, optional `time_s` and `station`; other
//! extra columns are allowed and ignored.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use crate::io::files::{FileError, push_numbers, write_atomic};
use crate::io::table::{Table, first_repeat};

/// Joint readings of one pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointReading {
    /// Pose id.
    pub pose: u64,
    /// Line of the file it came from (0 when not read from a file).
    pub line: usize,
    /// Joint readings θ1, θ2, θ3 (rad).
    pub joints: Vector3<f64>,
    /// Capture time, when the file has a `time_s` column.
    pub time_s: Option<f64>,
    /// The station the capture belongs to (captures meant as one pose), when the file has a
    /// `station` column.
    pub station: Option<u64>,
}

const COLUMNS: [&str; 4] = ["pose", "theta1_rad", "theta2_rad", "theta3_rad"];

/// Read `joints.csv`; non-numbers, non-finite values and repeated poses are errors naming the line.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first bad value, missing column or repeated pose.
pub(crate) fn read_joints(path: &Path) -> Result<Vec<JointReading>, FileError> {
    let mut table = Table::open_with_optional(path, &COLUMNS, &["time_s", "station"])?;
    let out = table.read_all(|row, _| {
        let pose = row.index(0)?;
        let joints = Vector3::new(row.number(1)?, row.number(2)?, row.number(3)?);
        let time_s = row.optional_number(4)?;
        let station = if row.field(5).is_empty() { None } else { Some(row.index(5)?) };
        Ok(JointReading { pose, line: row.line, joints, time_s, station })
    })?;
    if let Some((pose, line)) = first_repeat(out.iter().map(|r| (r.pose, r.line))) {
        return Err(table.error_at(line, 0, format!("pose {pose} appears twice")));
    }
    Ok(out)
}

/// `joints.csv` text, with full precision; `time_s` (`station`) is written when every reading
/// has one.
pub(crate) fn joints_csv(readings: &[JointReading]) -> String {
    let all = |f: fn(&JointReading) -> bool| !readings.is_empty() && readings.iter().all(f);
    let (timed, stations) = (all(|r| r.time_s.is_some()), all(|r| r.station.is_some()));
    let mut text = COLUMNS.join(",");
    text += if timed { ",time_s" } else { "" };
    text += if stations { ",station\n" } else { "\n" };
    for r in readings {
        let _ = write!(text, "{}", r.pose);
        push_numbers(&mut text, r.joints.as_slice());
        if let (true, Some(t)) = (timed, r.time_s) {
            push_numbers(&mut text, &[t]);
        }
        if let (true, Some(s)) = (stations, r.station) {
            let _ = write!(text, ",{s}");
        }
        text.push('\n');
    }
    text
}

/// Write `joints.csv` atomically.
///
/// # Errors
/// A [`FileError`] when the file cannot be written; an existing file is then left unchanged.
pub(crate) fn write_joints(path: &Path, readings: &[JointReading]) -> Result<(), FileError> {
    write_atomic(path, joints_csv(readings).as_bytes())
}

impl JointReading {
    /// Read `joints.csv`; non-numbers, non-finite values and repeated poses are errors naming the line.
    ///
    /// # Errors
    /// A [`FileError`] naming the line and column of the first bad value, missing column or repeated pose.
    pub fn read(path: &Path) -> Result<Vec<JointReading>, FileError> {
        read_joints(path)
    }

    /// `joints.csv` text, with full precision; `time_s` (`station`) is written when every reading
    /// has one.
    pub fn csv(readings: &[JointReading]) -> String {
        joints_csv(readings)
    }
}
