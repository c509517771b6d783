//! `joints.csv`: `pose,theta1_rad,theta2_rad,theta3_rad`, optional `time_s` and `station`; other
//! extra columns are allowed and ignored.
//!
//! A `station` groups the captures the operator meant as one pose (sequential capture, one
//! marker at a time): when the file has the column, every row needs one, and the captures of one
//! station must read nearly the same joints (within [`MAX_STATION_SPREAD_DEG`]).

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use crate::io::files::{FileError, push_numbers, write_atomic};
use crate::io::table::{Row, Table, first_repeat};

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

/// The requested column `station` (after the four of [`COLUMNS`] and `time_s`).
const STATION: usize = 5;

/// Largest difference of any joint reading between two captures of one station (degrees).
///
/// A station is the captures the operator meant as one pose: the per-pose estimator merges them
/// into one (the first capture's reading, every capture's markers), so they must read nearly the
/// same joints. The hand holding a pose drifts between captures, and 5° lies well above that
/// drift: the largest spread of a station in the shipped `agile_wrist_sequential_200` (a drift
/// of 0.2° per axis between captures) is 1.45° of joint motion (median 0.5°), and a hand drifting
/// 0.5° per axis between captures (2.5 times that) spreads a station by 3.1° at most (200
/// stations simulated). Distinct poses lie further apart: nine in ten consecutive stations of
/// that dataset differ by more than 12.8° (median 31°). Captures farther apart than 5° are not
/// one pose held by a hand, but a station number given to two poses. (1° would refuse the
/// shipped dataset.)
pub(crate) const MAX_STATION_SPREAD_DEG: f64 = 5.0;

/// Read `joints.csv`; non-numbers, non-finite values, repeated poses, an empty or non-integer
/// `station`, and a station whose captures read joints more than [`MAX_STATION_SPREAD_DEG`]
/// apart are errors naming the line (the station's, the other capture's line too).
///
/// # Errors
/// A [`FileError`] naming the line and column of the first bad value, missing column, repeated
/// pose or station too wide to be one pose.
pub(crate) fn read_joints(path: &Path) -> Result<Vec<JointReading>, FileError> {
    let mut table = Table::open_with_optional(path, &COLUMNS, &["time_s", "station"])?;
    let mut stations = StationSpans::default();
    let out = table.read_all(|row, _| {
        let pose = row.index(0)?;
        let joints = joint_values(row, 1)?;
        let time_s = row.optional_number(4)?;
        let station = if row.has_column(STATION) { Some(station_number(row)?) } else { None };
        if let Some(far) = station.and_then(|s| stations.add(s, &joints, row.line)) {
            let other = format!("the one at line {}", far.earlier);
            let reason = far.describe(station.unwrap_or_default(), "this capture", &other);
            return Err(row.error(STATION, reason + " (a station number given to two poses?)"));
        }
        Ok(JointReading { pose, line: row.line, joints, time_s, station })
    })?;
    if let Some((pose, line)) = first_repeat(out.iter().map(|r| (r.pose, r.line))) {
        return Err(table.error_at(line, 0, format!("pose {pose} appears twice")));
    }
    Ok(out)
}

/// The largest joint reading accepted (rad): a full turn. An SPM's actuated joints turn less than
/// that either way from home; a bigger number is an angle in degrees (45° written as `45`).
pub(crate) const MAX_JOINT_RAD: f64 = std::f64::consts::TAU;

/// The reason a joint reading `value` (rad) is refused, when it is beyond a turn: it looks like
/// degrees.
pub(crate) fn degrees_reason(value: f64) -> Option<String> {
    (value.abs() > MAX_JOINT_RAD).then(|| {
        format!(
            "{} rad is more than a full turn: it looks like degrees; spmcal reads joints in radians ({}° is {:.6} rad)",
            crate::io::files::number(value),
            crate::io::files::number(value),
            value.to_radians()
        )
    })
}

/// The three joint readings (rad) in the columns from `first`: numbers within a turn, else an
/// error at the row and column (degrees are the usual mistake).
pub(crate) fn joint_values(row: &Row<'_>, first: usize) -> Result<Vector3<f64>, FileError> {
    let mut joints = Vector3::zeros();
    for (i, value) in joints.iter_mut().enumerate() {
        *value = row.number(first + i)?;
        if let Some(reason) = degrees_reason(*value) {
            return Err(row.error(first + i, reason));
        }
    }
    Ok(joints)
}

/// The `station` field of a row: a non-negative integer, never empty when the file has the column.
fn station_number(row: &Row<'_>) -> Result<u64, FileError> {
    let bytes = row.field(STATION);
    if bytes.is_empty() {
        return Err(row.error(
            STATION,
            "the station is empty: when the file has a `station` column, every capture needs its station (a non-negative integer)",
        ));
    }
    std::str::from_utf8(bytes).ok().and_then(|t| t.parse().ok()).ok_or_else(|| {
        let shown = String::from_utf8_lossy(bytes);
        row.error(STATION, format!("`{shown}` is not a station number (a non-negative integer)"))
    })
}

/// The joint readings of each station seen so far, as offsets from its first capture: the
/// smallest and largest per joint, each with where it came from (a line, or a pose's index). One
/// hash look-up per capture.
#[derive(Default)]
pub(crate) struct StationSpans {
    spans: foldhash::HashMap<u64, StationSpan>,
}

struct StationSpan {
    first: Vector3<f64>,
    /// Per joint: the smallest and the largest offset from `first` (rad), with where they came from.
    low: [(f64, usize); 3],
    high: [(f64, usize); 3],
}

/// Two captures of one station too far apart to be one pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TooFar {
    /// Where the earlier capture came from (as given to [`StationSpans::add`]).
    pub earlier: usize,
    /// The joint (0-based) in which they differ most.
    pub joint: usize,
    /// How far apart they read it (rad).
    pub apart: f64,
}

impl TooFar {
    /// What is wrong, `this` and `other` naming the two captures (e.g. "this capture" and "the
    /// one at line 5").
    pub(crate) fn describe(&self, station: u64, this: &str, other: &str) -> String {
        format!(
            "station {station}: {this} and {other} read `theta{}_rad` {:.2}° apart, more than the {MAX_STATION_SPREAD_DEG}° a station's captures may differ: they cannot be one pose",
            self.joint + 1,
            self.apart.to_degrees()
        )
    }
}

impl StationSpans {
    /// Add a capture of station `station` read at `joints`, from `at` (a line or an index); the
    /// earlier capture it lies more than [`MAX_STATION_SPREAD_DEG`] from in some joint, if any.
    pub(crate) fn add(&mut self, station: u64, joints: &Vector3<f64>, at: usize) -> Option<TooFar> {
        let Some(span) = self.spans.get_mut(&station) else {
            let start = [(0.0, at); 3];
            self.spans.insert(station, StationSpan { first: *joints, low: start, high: start });
            return None;
        };
        let limit = MAX_STATION_SPREAD_DEG.to_radians();
        for joint in 0..3 {
            // Offsets wrap into (−π, π]: a station across ±180° is not spread by a turn.
            let offset = crate::math::so3::wrap_angle(joints[joint] - span.first[joint]);
            let (low, high) = (span.low[joint], span.high[joint]);
            if offset - low.0 > limit {
                return Some(TooFar { earlier: low.1, joint, apart: offset - low.0 });
            }
            if high.0 - offset > limit {
                return Some(TooFar { earlier: high.1, joint, apart: high.0 - offset });
            }
            if offset < low.0 {
                span.low[joint] = (offset, at);
            }
            if offset > high.0 {
                span.high[joint] = (offset, at);
            }
        }
        None
    }
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
