//! Free-motion recordings: `encoders.csv` (`time_s,theta1_rad,theta2_rad,theta3_rad`, e.g. 1 kHz)
//! and `captures.csv` (`time_s,marker,x_m,y_m,z_m`, e.g. 15 Hz), two streams on their own clocks —
//! or, for a recording seen through its cameras' pixels, `pixels.csv`
//! (`time_s,marker,camera,u_px,v_px`, the rows of one capture sharing its time) with the rig in
//! `cameras.yaml` instead of `captures.csv`: the streams then keep the pixel rows, and as captures
//! the points the rig triangulates from each capture's pixels.
//!
//! A capture stamped `t` on the camera's clock was taken at `(t − τ) / (1 + ρ·10⁻⁶)` on the
//! encoders' clock ([`Clock`]: τ the camera's latency at the encoders' time 0, ρ the rate
//! difference of the two clocks in ppm, 0 unless fitted), where the joints are interpolated
//! linearly between the two samples around it.
//! Every problem is an error naming the file, line and column: time stamps that do not increase,
//! a gap in the encoder stream longer than the limit (the interpolation would bridge motion it
//! never saw), a capture outside the encoder stream for every latency within the bound.

use std::path::Path;

use nalgebra::Vector3;

use std::fmt::Write as _;

use super::body::{BodyCapture, check_frames, read_body_captures};
use super::markers::MarkerLookup;
use super::pixels::{PixelRow, SeenPixel, read_timed_pixels, triangulate};
use crate::io::files::{FileError, number, push_numbers};
use crate::io::table::{Table, first_repeat};
use crate::model::Rig;

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

/// The camera's clock against the encoders': a capture stamped `t` on the camera's clock was
/// taken at `(t − τ) / (1 + ρ·10⁻⁶)` on the encoders' clock.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Clock {
    /// τ: the latency at the encoders' time 0 (s).
    pub(crate) latency_s: f64,
    /// ρ: how much faster the camera's clock runs (ppm).
    pub(crate) rate_ppm: f64,
}

impl Clock {
    /// A clock that runs at the encoders' rate, `latency_s` behind them.
    pub(crate) fn latency(latency_s: f64) -> Self {
        Clock { latency_s, rate_ppm: 0.0 }
    }

    /// The encoders' time of a capture stamped `camera_time_s`.
    pub(crate) fn encoder_time(&self, camera_time_s: f64) -> f64 {
        (camera_time_s - self.latency_s) / (1.0 + self.rate_ppm * 1e-6)
    }

    /// The latency at the encoders' time `encoder_time_s`: `τ + ρ·10⁻⁶·t` (a capture taken then
    /// is stamped that much later).
    pub(crate) fn latency_at(&self, encoder_time_s: f64) -> f64 {
        self.latency_s + self.rate_ppm * 1e-6 * encoder_time_s
    }
}

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
    /// The `captures.csv` (or `pixels.csv`) they were read from (warnings name its lines).
    pub(crate) captures_path: std::path::PathBuf,
    /// Encoder samples, time strictly increasing.
    pub(crate) encoders: Vec<EncoderSample>,
    /// Captures, time non-decreasing (several markers may share a frame): `captures.csv`'s, or
    /// the points the rig triangulates from each capture's pixels (each at the line of its
    /// marker's first pixel row).
    pub(crate) captures: Vec<Capture>,
    /// The rows of `pixels.csv`, time non-decreasing, for a recording seen through its pixels
    /// (empty for one of points).
    pub(crate) pixels: Vec<PixelRow<f64>>,
    /// For a recording read from a bag, its marker topics as a warning names them (`line` of a
    /// capture is then its message's index on its topic).
    pub(crate) bag_topics: Option<String>,
    /// A rigid body's poses, time strictly increasing, for a recording of a body (`poses.csv`;
    /// `captures` and `pixels` are then empty).
    pub(crate) bodies: Vec<BodyCapture>,
}

/// One camera frame of a recording: the captures and pixels that share its time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Frame<'a> {
    /// Its time on the camera's clock (s).
    pub(crate) time_s: f64,
    /// Its marker points.
    pub(crate) captures: &'a [Capture],
    /// Its pixels.
    pub(crate) pixels: &'a [PixelRow<f64>],
    /// The body's pose, in a recording of a rigid body.
    pub(crate) body: Option<&'a BodyCapture>,
}

impl Frame<'_> {
    /// The line of its first row (of `pixels.csv` when it has pixels).
    pub(crate) fn line(&self) -> usize {
        let body = self.body.map(|b| b.pose.line);
        self.pixels.first().map(|p| p.seen.line).or(self.captures.first().map(|c| c.line)).or(body).unwrap_or(0)
    }
}

/// A marker of a recording whose pixels the rig could not triangulate: `(time, marker, line of
/// its first pixel row, the cameras)`.
pub(crate) type Unmet = (f64, usize, usize, Vec<usize>);

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
        let joints = super::joints::joint_values(row, 1)?;
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
        Ok(Streams { captures_path, encoders, captures, pixels: Vec::new(), bag_topics: None, bodies: Vec::new() })
    }

    /// Read the recording seen through its pixels in `dir` — `encoders.csv`, `pixels.csv` with the
    /// rig of `cameras.yaml` — and check that every pixel row can be placed in the encoder stream
    /// for some latency within the bound; with the markers whose pixels the rig could not
    /// triangulate.
    ///
    /// # Errors
    /// A [`FileError`] naming the file, line and column of the first problem.
    pub(crate) fn read_pixels(
        dir: &Path,
        names: &[String],
        rig: &Rig,
        limits: &StreamLimits,
    ) -> Result<(Streams, Vec<Unmet>), FileError> {
        let encoders = read_encoders(&dir.join("encoders.csv"), limits)?;
        let path = dir.join("pixels.csv");
        let pixels = read_timed_pixels(&path, names, rig)?;
        let frames = pixels.chunk_by(|a, b| a.at == b.at).count();
        if frames < MIN_FRAMES {
            let reason = format!(
                "holds pixels in {frames} camera frame{}: almost nothing to calibrate from — a recording needs markers seen in at least {MIN_FRAMES} camera frames (three orientations of the MP are the fewest that fix the camera's registration), and a calibration many more",
                if frames == 1 { "" } else { "s" }
            );
            return Err(FileError::new(&path, reason));
        }
        let bound = limits.latency_bound_s;
        let (first, last) = (encoders[0].time_s, encoders[encoders.len() - 1].time_s);
        if let Some(p) = pixels.iter().find(|p| p.at + bound < first || p.at - bound > last) {
            let reason = format!(
                "the pixel at {} s lies outside the encoder stream ({first} s to {last} s) for every latency within ±{bound} s",
                p.at
            );
            return Err(FileError::new(&path, reason).at_line(p.seen.line).in_column("time_s"));
        }
        Ok(Streams::of_pixels(path, encoders, pixels, rig))
    }

    /// The streams of a recording seen through its pixels (time non-decreasing), its captures the
    /// points `rig` triangulates from each camera frame's pixels; with the markers whose pixels
    /// it could not triangulate. (What the simulator makes, and what [`Streams::read_pixels`] reads.)
    pub(crate) fn of_pixels(
        captures_path: std::path::PathBuf,
        encoders: Vec<EncoderSample>,
        pixels: Vec<PixelRow<f64>>,
        rig: &Rig,
    ) -> (Streams, Vec<Unmet>) {
        let (mut captures, mut unmet) = (Vec::new(), Vec::new());
        for frame in pixels.chunk_by(|a, b| a.at == b.at) {
            let time_s = frame[0].at;
            let seen: Vec<SeenPixel> = frame.iter().map(|p| p.seen).collect();
            let t = triangulate(rig, &seen);
            captures.extend(t.points.into_iter().map(|(marker, position, line)| Capture {
                time_s,
                marker,
                position,
                line,
            }));
            unmet.extend(t.unmet.into_iter().map(|(marker, line, cameras)| (time_s, marker, line, cameras)));
        }
        (Streams { captures_path, encoders, captures, pixels, bag_topics: None, bodies: Vec::new() }, unmet)
    }

    /// The camera frames, in time order: the captures and pixels of each distinct time (a body
    /// recording's frames: one per body pose).
    pub(crate) fn frames(&self) -> impl Iterator<Item = Frame<'_>> {
        let (mut captures, mut pixels) = (&self.captures[..], &self.pixels[..]);
        let bodies = self.bodies.iter().map(|b| Frame { time_s: b.time_s, captures: &[], pixels: &[], body: Some(b) });
        let points = std::iter::from_fn(move || {
            let time_s = match (captures.first(), pixels.first()) {
                (Some(c), Some(p)) => c.time_s.min(p.at),
                (Some(c), None) => c.time_s,
                (None, Some(p)) => p.at,
                (None, None) => return None,
            };
            let nc = captures.iter().take_while(|c| c.time_s == time_s).count();
            let np = pixels.iter().take_while(|p| p.at == time_s).count();
            let frame = Frame { time_s, captures: &captures[..nc], pixels: &pixels[..np], body: None };
            (captures, pixels) = (&captures[nc..], &pixels[np..]);
            Some(frame)
        });
        // A recording holds a body's poses or marker observations, never both.
        bodies.chain(points)
    }

    /// The streams of a recording of a rigid body: the encoder samples and the body's poses on
    /// the tracker's clock, read from `captures_path` (a `poses.csv` or a bag). What the CSV
    /// reader ([`Streams::read_body`]), a bag's reader and the simulator all make.
    ///
    /// # Errors
    /// A [`FileError`] on `captures_path` when the poses' times do not strictly increase (at the
    /// first that does not), when there are fewer than [`MIN_FRAMES`] or one lies outside the
    /// encoder stream for every latency within `latency_bound_s` (`encoders` not empty).
    pub(crate) fn of_body(
        captures_path: std::path::PathBuf,
        encoders: Vec<EncoderSample>,
        bodies: Vec<BodyCapture>,
        latency_bound_s: f64,
    ) -> Result<Streams, FileError> {
        let at = |b: &BodyCapture, reason: String| {
            FileError::new(&captures_path, reason).at_line(b.pose.line).in_column("time_s")
        };
        if let Some(w) = bodies.windows(2).find(|w| w[1].time_s <= w[0].time_s) {
            return Err(at(
                &w[1],
                format!("time {} s does not come after the previous pose's {} s", w[1].time_s, w[0].time_s),
            ));
        }
        check_frames(&captures_path, bodies.len())?;
        let (first, last) = (encoders[0].time_s, encoders[encoders.len() - 1].time_s);
        let bound = latency_bound_s;
        if let Some(b) = bodies.iter().find(|b| b.time_s + bound < first || b.time_s - bound > last) {
            let reason = format!(
                "the body pose at {} s lies outside the encoder stream ({first} s to {last} s) for every latency within ±{bound} s",
                b.time_s
            );
            return Err(at(b, reason));
        }
        Ok(Streams { captures_path, encoders, captures: Vec::new(), pixels: Vec::new(), bag_topics: None, bodies })
    }

    /// Read the recording of a rigid body in `dir`: `encoders.csv` and `poses.csv`.
    ///
    /// # Errors
    /// A [`FileError`] naming the file, line and column of the first problem.
    pub(crate) fn read_body(dir: &Path, limits: &StreamLimits) -> Result<Streams, FileError> {
        let encoders = read_encoders(&dir.join("encoders.csv"), limits)?;
        let path = dir.join("poses.csv");
        let bodies = read_body_captures(&path)?;
        Streams::of_body(path, encoders, bodies, limits.latency_bound_s)
    }

    /// The body's poses of a recording of a rigid body: each as its time on the tracker's clock
    /// (s) and the pose; nothing for a recording of markers.
    pub fn body_poses(&self) -> impl Iterator<Item = (f64, &super::BodyPose)> {
        self.bodies.iter().map(|b| (b.time_s, &b.pose))
    }

    /// The camera time from the recording's first frame to its last (s).
    pub(crate) fn camera_span_s(&self) -> f64 {
        let times = self.captures.iter().map(|c| c.time_s).chain(self.pixels.iter().map(|p| p.at));
        let times = times.chain(self.bodies.iter().map(|b| b.time_s));
        let (first, last) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| (lo.min(t), hi.max(t)));
        (last - first).max(0.0)
    }

    /// How many encoder samples the recording holds.
    pub fn encoder_count(&self) -> usize {
        self.encoders.len()
    }

    /// The pixels of a recording seen through its cameras (`pixels.csv`'s rows, time
    /// non-decreasing): each as its capture's time on the camera's clock (s) and what was seen;
    /// nothing for a recording of points.
    pub fn pixels(&self) -> impl Iterator<Item = (f64, &super::SeenPixel)> {
        self.pixels.iter().map(|r| (r.at, &r.seen))
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
