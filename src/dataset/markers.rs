//! `markers.csv`: `pose,marker,x_m,y_m,z_m`, marker centres in the camera frame; a marker the
//! camera did not see has no row.

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use crate::files::{FileError, number, write_atomic};
use crate::table::Table;

/// One marker measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerRow {
    /// Pose id.
    pub pose: u64,
    /// Index of the marker in the session's marker list.
    pub marker: usize,
    /// Marker centre in the camera frame (m).
    pub position: Vector3<f64>,
    /// Line of the file it came from.
    pub line: usize,
}

/// Read `markers.csv`. Unknown marker names, non-numbers, non-finite coordinates and a repeated
/// (pose, marker) pair are errors naming the line and column.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first bad value, unknown marker or repeated pair.
pub fn read_markers(path: &Path, names: &[String]) -> Result<Vec<MarkerRow>, FileError> {
    let mut table = Table::open(path, &["pose", "marker", "x_m", "y_m", "z_m"])?;
    let mut seen = HashSet::new();
    let mut out = Vec::new();
    for row in table.all_rows()? {
        let pose = table.index(&row, 0)?;
        let name = &row.fields[1];
        let marker = names.iter().position(|n| n == name).ok_or_else(|| {
            table.error(&row, 1, format!("unknown marker `{name}` (session.yaml lists {})", names.join(", ")))
        })?;
        if !seen.insert((pose, marker)) {
            return Err(table.error(&row, 1, format!("marker `{name}` of pose {pose} appears twice")));
        }
        let position = Vector3::new(table.number(&row, 2)?, table.number(&row, 3)?, table.number(&row, 4)?);
        out.push(MarkerRow { pose, marker, position, line: row.line });
    }
    Ok(out)
}

/// `markers.csv` text, with full precision.
pub fn markers_csv(rows: &[MarkerRow], names: &[String]) -> String {
    let mut text = String::from("pose,marker,x_m,y_m,z_m\n");
    for r in rows {
        let p = r.position;
        let _ = writeln!(text, "{},{},{},{},{}", r.pose, names[r.marker], number(p.x), number(p.y), number(p.z));
    }
    text
}

/// Write `markers.csv` atomically.
///
/// # Errors
/// A [`FileError`] when the file cannot be written; an existing file is then left unchanged.
pub fn write_markers(path: &Path, rows: &[MarkerRow], names: &[String]) -> Result<(), FileError> {
    write_atomic(path, markers_csv(rows, names).as_bytes())
}
