//! `markers.csv`: `pose,marker,x_m,y_m,z_m`, marker centres in the camera frame; a marker the
//! camera did not see has no row.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use crate::io::files::{FileError, push_numbers, write_atomic};
use crate::io::table::{Row, Table, first_repeat};

/// One marker measurement.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MarkerRow {
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
pub(crate) fn read_markers(path: &Path, names: &[String]) -> Result<Vec<MarkerRow>, FileError> {
    let mut table = Table::open(path, &["pose", "marker", "x_m", "y_m", "z_m"])?;
    let lookup = MarkerLookup::new(names);
    let out = table.read_all(|row, _| {
        let (pose, marker) = (row.index(0)?, lookup.marker(row, 1)?);
        let position = marker_position(row, 2)?;
        Ok(MarkerRow { pose, marker, position, line: row.line })
    })?;
    if let Some(((pose, marker), line)) = first_repeat(out.iter().map(|r| ((r.pose, r.marker), r.line))) {
        return Err(table.error_at(line, 1, format!("marker `{}` of pose {pose} appears twice", names[marker])));
    }
    Ok(out)
}

/// The largest marker coordinate accepted (m): a stereo camera measures markers within a few
/// metres. A bigger number is no measurement (millimetres given as metres, a corrupt row), and far
/// beyond it (1e200) the distances between markers overflow to infinity.
pub(crate) const MAX_COORDINATE_M: f64 = 100.0;

/// The largest marker coordinate a reader accepts (m): the mechanism is a desk joystick, its
/// camera a metre or so away; a stereo camera of this kind measures within a few metres. In
/// millimetres, every marker more than 17 mm from the camera has a coordinate beyond it.
pub(crate) const MAX_MEASURED_M: f64 = 10.0;

/// The reason a marker coordinate `value` (m) is refused, when it is beyond [`MAX_MEASURED_M`]:
/// it looks like millimetres.
pub(crate) fn millimetres_reason(value: f64) -> Option<String> {
    let shown = crate::io::files::number(value);
    if value.abs() <= MAX_MEASURED_M {
        None
    } else if value.abs() <= 1000.0 * MAX_MEASURED_M {
        Some(format!(
            "{shown} m is farther than the {MAX_MEASURED_M} m a camera measures this mechanism's markers within: it \
             looks like millimetres; spmcal reads metres ({shown} mm is {} m)",
            crate::io::files::number(value / 1000.0)
        ))
    } else {
        Some(format!(
            "{shown} m is no marker position: a camera measures this mechanism's markers within {MAX_MEASURED_M} m"
        ))
    }
}

/// The marker position in the three columns from `first` (`x_m`, `y_m`, `z_m`): finite numbers
/// within [`MAX_MEASURED_M`] of the camera, else an error at the row and column (millimetres are
/// the usual mistake).
pub(crate) fn marker_position(row: &Row<'_>, first: usize) -> Result<Vector3<f64>, FileError> {
    let mut position = Vector3::zeros();
    for (i, value) in position.iter_mut().enumerate() {
        *value = row.number(first + i)?;
        if let Some(reason) = millimetres_reason(*value) {
            return Err(row.error(first + i, reason));
        }
    }
    Ok(position)
}

/// `markers.csv` text, with full precision.
pub(crate) fn markers_csv(rows: &[MarkerRow], names: &[String]) -> String {
    let mut text = String::from("pose,marker,x_m,y_m,z_m\n");
    for r in rows {
        let _ = write!(text, "{},{}", r.pose, names[r.marker]);
        push_numbers(&mut text, r.position.as_slice());
        text.push('\n');
    }
    text
}

/// Write `markers.csv` atomically.
///
/// # Errors
/// A [`FileError`] when the file cannot be written; an existing file is then left unchanged.
pub(crate) fn write_markers(path: &Path, rows: &[MarkerRow], names: &[String]) -> Result<(), FileError> {
    write_atomic(path, markers_csv(rows, names).as_bytes())
}

/// The session's marker names by their bytes: one hash look-up per row, whatever the number of
/// names (a linear search per row is rows × names).
pub(crate) struct MarkerLookup<'a> {
    names: &'a [String],
    index: foldhash::HashMap<&'a [u8], usize>,
}

impl<'a> MarkerLookup<'a> {
    /// The look-up of `names` (the first of a repeated name wins; `session.yaml` refuses repeats).
    pub(crate) fn new(names: &'a [String]) -> Self {
        let mut index = foldhash::HashMap::default();
        index.reserve(names.len());
        for (k, name) in names.iter().enumerate() {
            index.entry(name.as_bytes()).or_insert(k);
        }
        MarkerLookup { names, index }
    }

    /// The `k`-th field of `row` as a marker of the session (its index in the names); an unknown
    /// name is an error naming it and the session's names (the first few when there are many).
    pub(crate) fn marker(&self, row: &Row<'_>, k: usize) -> Result<usize, FileError> {
        let bytes = row.field(k);
        self.index.get(bytes).copied().ok_or_else(|| {
            const SHOWN: usize = 12;
            let shown = String::from_utf8_lossy(bytes);
            let mut listed = self.names.iter().take(SHOWN).map(String::as_str).collect::<Vec<_>>().join(", ");
            if self.names.len() > SHOWN {
                listed += &format!(", … ({} in all)", self.names.len());
            }
            row.error(k, format!("unknown marker `{shown}` (session.yaml lists {listed})"))
        })
    }
}
