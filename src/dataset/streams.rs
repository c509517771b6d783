//! Free-motion recordings: `encoders.csv` (`time_s,theta1_rad,theta2_rad,theta3_rad`, e.g. 1 kHz)
//! and `captures.csv` (`time_s,marker,x_m,y_m,z_m`, e.g. 15 Hz), two streams on their own clocks.
//!
//! A capture stamped `t` on the camera's clock was taken at `t − τ` on the encoders' clock (τ the
//! camera's latency), where the joints are interpolated linearly between the two samples around it.
//! Every problem is an error naming the file, line and column: time stamps that do not increase,
//! a gap in the encoder stream longer than the limit (the interpolation would bridge motion it
//! never saw), a capture outside the encoder stream for every latency within the bound.

use std::path::Path;

use nalgebra::Vector3;

use std::fmt::Write as _;

use super::markers::MarkerLookup;
use crate::io::files::{FileError, number, push_numbers};
use crate::io::table::{Table, first_repeat};

/// One encoder sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct EncoderSample {
    /// Time on the encoders' clock (s).
    pub(crate) time_s: f64,
    /// Joint readings θ1, θ2, θ3 (rad).
    pub(crate) joints: Vector3<f64>,
}

/// One marker captured by the camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Capture {
    /// Time on the camera's clock (s).
    pub(crate) time_s: f64,
    /// Marker index (as in the session's `markers`).
    pub(crate) marker: usize,
    /// Marker centre in the camera frame (m).
    pub(crate) position: Vector3<f64>,
    /// Line of `captures.csv`.
    pub(crate) line: usize,
}

/// Fewest camera frames (distinct time stamps of `captures.csv`) a recording must hold: three
/// orientations of the MP are the fewest that rotate about two axes, which the camera's
/// registration needs (a calibration needs many more, and says how many).
pub(crate) const MIN_FRAMES: usize = 3;

/// Half-width of the window over which the joint velocity is taken (s).
pub(crate) const VELOCITY_WINDOW_S: f64 = 0.01;

/// Limits a recording must meet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StreamLimits {
    /// Longest gap between encoder samples that the interpolation may bridge (s).
    pub max_encoder_gap_s: f64,
    /// Largest camera latency considered, either sign (s).
    pub latency_bound_s: f64,
}

impl Default for StreamLimits {
    /// 50 ms of encoder gap (fifty samples at 1 kHz), ±200 ms of latency.
    fn default() -> Self {
        StreamLimits { max_encoder_gap_s: 0.05, latency_bound_s: 0.2 }
    }
}

/// The two streams of a recording. Outside the crate they are read through the joints at an
/// instant ([`Streams::joints_at`], [`Streams::velocity_at`]) and the session's poses at a camera
/// latency ([`Session::at_latency`](crate::dataset::Session::at_latency)); the rows themselves
/// are the crate's.
#[derive(Debug, Clone, PartialEq)]
pub struct Streams {
    /// The `captures.csv` they were read from (warnings name its lines).
    pub(crate) captures_path: std::path::PathBuf,
    /// Encoder samples, time strictly increasing.
    pub(crate) encoders: Vec<EncoderSample>,
    /// Captures, time non-decreasing (several markers may share a frame).
    pub(crate) captures: Vec<Capture>,
}

/// Read `encoders.csv`: numbers, finite, time strictly increasing, no gap over the limit.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first problem.
pub(crate) fn read_encoders(path: &Path, limits: &StreamLimits) -> Result<Vec<EncoderSample>, FileError> {
    let mut table = Table::open(path, &["time_s", "theta1_rad", "theta2_rad", "theta3_rad"])?;
    let out = table.read_all(|row, before: &[EncoderSample]| {
        let time_s = row.number(0)?;
        if let Some(last) = before.last() {
            if time_s <= last.time_s {
                let what = if time_s == last.time_s { "repeats" } else { "goes back from" };
                return Err(row.error(0, format!("time {time_s} s {what} the previous sample's {} s", last.time_s)));
            }
            if time_s - last.time_s > limits.max_encoder_gap_s {
                return Err(row.error(
                    0,
                    format!(
                        "a gap of {:.4} s in the encoder stream (from {} s), longer than the limit of {} s",
                        time_s - last.time_s,
                        last.time_s,
                        limits.max_encoder_gap_s
                    ),
                ));
            }
        }
        let joints = Vector3::new(row.number(1)?, row.number(2)?, row.number(3)?);
        Ok(EncoderSample { time_s, joints })
    })?;
    if out.len() < 2 {
        return Err(FileError::new(path, format!("{} encoder samples: a stream needs at least two", out.len())));
    }
    Ok(out)
}

/// Read `captures.csv`: numbers, finite, known markers, time non-decreasing, one capture per
/// (time, marker), captures in at least [`MIN_FRAMES`] camera frames.
///
/// # Errors
/// A [`FileError`] naming the line and column of the first problem.
pub(crate) fn read_captures(path: &Path, names: &[String]) -> Result<Vec<Capture>, FileError> {
    let mut table = Table::open(path, &["time_s", "marker", "x_m", "y_m", "z_m"])?;
    let lookup = MarkerLookup::new(names);
    let out = table.read_all(|row, before: &[Capture]| {
        let time_s = row.number(0)?;
        if let Some(last) = before.last().filter(|l| time_s < l.time_s) {
            return Err(
                row.error(0, format!("time {time_s} s goes back from the previous capture's {} s", last.time_s))
            );
        }
        let marker = lookup.marker(row, 1)?;
        let position = super::markers::marker_position(row, 2)?;
        Ok(Capture { time_s, marker, position, line: row.line })
    })?;
    // Time never goes back, so a repeat is within one frame: its time stamp's bits and marker.
    let keys = out.iter().map(|c| ((c.time_s.to_bits(), c.marker), c.line));
    if let Some(((bits, marker), line)) = first_repeat(keys) {
        let time_s = f64::from_bits(bits);
        return Err(table.error_at(line, 1, format!("marker `{}` is captured twice at {time_s} s", names[marker])));
    }
    let frames = out.chunk_by(|a, b| a.time_s == b.time_s).count();
    if frames < MIN_FRAMES {
        let held = match out.len() {
            0 => "no captures (a header only)".to_string(),
            1 => "only 1 capture".to_string(),
            n => format!("only {n} captures, in {frames} camera frame{}", if frames == 1 { "" } else { "s" }),
        };
        return Err(FileError::new(
            path,
            format!(
                "holds {held}: almost nothing to calibrate from — a recording needs markers captured in at least {MIN_FRAMES} camera frames (three orientations of the MP are the fewest that fix the camera's registration), and a calibration many more (each capture gives 3 numbers, against some 30 parameters)"
            ),
        ));
    }
    Ok(out)
}

/// The first capture that lies outside the encoder stream for every latency within ±`bound`, with
/// the stream's first and last times (`encoders` not empty).
pub(crate) fn unplaceable<'a>(
    encoders: &[EncoderSample],
    captures: &'a [Capture],
    bound: f64,
) -> Option<(&'a Capture, f64, f64)> {
    let (first, last) = (encoders[0].time_s, encoders[encoders.len() - 1].time_s);
    captures.iter().find(|c| c.time_s + bound < first || c.time_s - bound > last).map(|c| (c, first, last))
}

impl Streams {
    /// Read both streams of the recording in `dir` and check that every capture can be placed in
    /// the encoder stream for some latency within the bound.
    ///
    /// # Errors
    /// A [`FileError`] naming the file, line and column of the first problem.
    pub(crate) fn read(dir: &Path, names: &[String], limits: &StreamLimits) -> Result<Streams, FileError> {
        let encoders = read_encoders(&dir.join("encoders.csv"), limits)?;
        let captures_path = dir.join("captures.csv");
        let captures = read_captures(&captures_path, names)?;
        let bound = limits.latency_bound_s;
        if let Some((c, first, last)) = unplaceable(&encoders, &captures, bound) {
            return Err(FileError::new(
                &captures_path,
                format!(
                    "the capture at {} s lies outside the encoder stream ({first} s to {last} s) for every latency within ±{bound} s",
                    c.time_s
                ),
            )
            .at_line(c.line)
            .in_column("time_s"));
        }
        Ok(Streams { captures_path, encoders, captures })
    }

    /// How many encoder samples the recording holds.
    pub fn encoder_count(&self) -> usize {
        self.encoders.len()
    }

    /// How many marker captures the recording holds.
    pub fn capture_count(&self) -> usize {
        self.captures.len()
    }

    /// The joints at `time_s` on the encoders' clock, interpolated linearly; `None` outside the
    /// stream.
    pub fn joints_at(&self, time_s: f64) -> Option<Vector3<f64>> {
        let e = &self.encoders;
        if !(time_s >= e[0].time_s && time_s <= e[e.len() - 1].time_s) {
            return None;
        }
        let k = e.partition_point(|s| s.time_s <= time_s).clamp(1, e.len() - 1);
        let (a, b) = (&e[k - 1], &e[k]);
        let f = (time_s - a.time_s) / (b.time_s - a.time_s);
        Some(a.joints + (b.joints - a.joints) * f)
    }

    /// The joint velocity (rad/s) at `time_s`: a central difference over ±`VELOCITY_WINDOW_S`
    /// (one-sided at the ends). The slope of a single 1 ms interval is dominated by the encoders'
    /// quantisation (one count in a millisecond is 20°/s at 14 bits); the latency's derivative
    /// needs the hand's motion, not that noise.
    pub fn velocity_at(&self, time_s: f64) -> Option<Vector3<f64>> {
        let e = &self.encoders;
        let (first, last) = (e[0].time_s, e[e.len() - 1].time_s);
        if !(time_s >= first && time_s <= last) {
            return None;
        }
        let (a, b) = ((time_s - VELOCITY_WINDOW_S).max(first), (time_s + VELOCITY_WINDOW_S).min(last));
        Some((self.joints_at(b)? - self.joints_at(a)?) / (b - a))
    }
}

/// `encoders.csv` text, with full precision.
pub(crate) fn encoders_csv(samples: &[EncoderSample]) -> String {
    let mut text = String::from("time_s,theta1_rad,theta2_rad,theta3_rad\n");
    for e in samples {
        text.push_str(&number(e.time_s));
        push_numbers(&mut text, e.joints.as_slice());
        text.push('\n');
    }
    text
}

/// `captures.csv` text, with full precision.
pub(crate) fn captures_csv(captures: &[Capture], names: &[String]) -> String {
    let mut text = String::from("time_s,marker,x_m,y_m,z_m\n");
    for c in captures {
        let _ = write!(text, "{},{}", number(c.time_s), names[c.marker]);
        push_numbers(&mut text, c.position.as_slice());
        text.push('\n');
    }
    text
}
