//! A session folder: `session.yaml`, `joints.csv`, `markers.csv` (a free-motion recording has
//! `encoders.csv` and `captures.csv` instead of the two CSV files; a session seen through its
//! cameras' pixels has `pixels.csv` and `cameras.yaml` instead of `markers.csv` or `captures.csv`),
//! and for simulated sessions `truth.yaml` (the true parameters), `truth_orientations.csv` (the
//! true MP orientations) and, seen through pixels, `truth_cameras.yaml` (the true rig, in the
//! format of `cameras.yaml`).
//!
//! What is an error (loading stops, naming file, line and column): malformed YAML or CSV, an
//! unknown key in `session.yaml`, fewer than 3 or repeated marker names, no model, non-numbers
//! and NaN/inf, a repeated pose or (pose, marker) pair, an unknown marker name, marker rows for a
//! pose that `joints.csv` does not have, an empty session, a reference pose that is not in
//! `joints.csv`, an empty station or one whose captures are not one pose (`joints.csv`), a
//! recording with captures in fewer than 3 camera frames, files of both kinds in one folder
//! (which session is meant cannot be told), points and pixels in one folder, pixels without
//! `cameras.yaml` (or the rig without pixels), and more marker slots (listed markers × poses) than
//! memory should hold. Every check is linear in the names and rows (hash look-ups, no searches).
//!
//! A session seen through its pixels carries them pose by pose (`SessionPose::pixels`) with its
//! rig (`Session::rig`), and as its marker points those the rig triangulates from them — a marker
//! seen by two cameras or more — so that everything that works on points keeps working. A marker
//! whose rays do not meet in front of the cameras gives no point, and a warning.
//!
//! A pose with fewer than 3 markers seen (none at all included) is data like any other: the
//! marker-level fit uses each observation, and only the per-pose vision estimator skips it (and
//! says so). The warnings a load returns are a free-motion recording's camera frames that fall
//! outside the encoder stream, left out, and the markers whose pixels gave no point.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};

use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use super::body::{BodyPose, BodyRow, body_captures_csv, body_poses_csv, read_body_poses};
use super::joints::{JointReading, StationSpans, read_joints, write_joints};
use super::markers::{MarkerRow, read_markers, write_markers};
use super::orientations::{OrientationRecord, read_orientations, write_orientations};
use super::pixels::SeenPixel;
use super::pixels::{
    PixelRow, check_rows, pose_pixels_csv, read_pose_pixels, timed_pixels_csv, triangulate, unmet_message,
};
use super::streams::{Clock, StreamLimits, Streams, Unmet, captures_csv, encoders_csv};
use crate::io::files::{FileError, in_parallel, write_atomic};
use crate::io::table::first_repeat;
use crate::math::constellation::{self, MARKER_NOISE_M};
use crate::model::camchain::{check_writable, read_camchain, write_camchain};
use crate::model::{CameraModel, Parameters, Rig};

/// Fewest markers that determine an orientation (the non-redundant minimum).
pub(crate) const MIN_MARKERS: usize = 3;

/// One pose of a session.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionPose {
    /// Pose id (the `pose` column).
    pub id: u64,
    /// Joint readings θ1, θ2, θ3 (rad).
    pub joints: Vector3<f64>,
    /// Capture time (s), when recorded.
    pub time_s: Option<f64>,
    /// Marker centres in the camera frame, indexed like `Session::markers`; `None` = not seen.
    pub markers: Vec<Option<Vector3<f64>>>,
    /// Line of `joints.csv` (0 when not read from a file).
    pub line: usize,
    /// Line of `markers.csv` (or `captures.csv`) of each seen marker (0 when unseen or not read
    /// from a file, as from a bag).
    pub marker_lines: Vec<usize>,
    /// The station (captures the operator meant as one pose), when recorded.
    pub station: Option<u64>,
    /// What each camera of the session's rig saw at this pose, pixel by pixel (empty for a
    /// session of points); `markers` then holds the points the rig triangulates from them.
    pub pixels: Vec<SeenPixel>,
    /// The pose of the session's rigid body (`Session::body`) the tracker reported here, with
    /// its line of `poses.csv`; `None` for a session of markers, or when the body was not seen.
    pub body: Option<BodyPose>,
}

impl SessionPose {
    /// How many markers the camera saw.
    pub fn seen(&self) -> usize {
        self.markers.iter().filter(|m| m.is_some()).count()
    }

    /// Whether what was seen here fixes the MP's orientation: the body's pose, or three markers.
    pub(crate) fn fixes_orientation(&self) -> bool {
        self.body.is_some() || self.seen() >= MIN_MARKERS
    }
}

/// The ground truth of a simulated session.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// The true parameters (with the true camera registration).
    pub parameters: Parameters,
    /// True MP orientation of each pose (P → B).
    pub orientations: BTreeMap<u64, Rotation3<f64>>,
    /// The true rig of a session seen through its pixels (`truth_cameras.yaml`), where the
    /// session's own (`cameras.yaml`) is what its calibration file states.
    pub rig: Option<crate::model::Rig>,
}

/// A joint-plus-vision session.
#[derive(Debug, Clone, PartialEq)]
pub struct Session {
    /// Session name (`session.yaml`).
    pub name: String,
    /// Free-text description.
    pub description: Option<String>,
    /// The model: a shipped model's name or the URDF's path, resolved against the session folder
    /// or taken from `--model`.
    pub model: PathBuf,
    /// Marker names, in the order of `SessionPose::markers` (empty for a session of a rigid body).
    pub markers: Vec<String>,
    /// The rigid body the tracker reported, by name (`session.yaml`'s `body`), for a session of
    /// a body's poses (`SessionPose::body`, a recording's `Streams::body_poses`) instead of
    /// markers; `None` for a session of markers.
    pub body: Option<String>,
    /// The pose the vision estimator measures rotations from.
    pub reference_pose: u64,
    /// The poses, in file order.
    pub poses: Vec<SessionPose>,
    /// Ground truth, for simulated sessions.
    pub truth: Option<Truth>,
    /// The encoder and camera streams of a free-motion recording, from which `poses` were made
    /// (one per camera frame, joints interpolated at the frame's time less the latency).
    pub streams: Option<std::sync::Arc<Streams>>,
    /// The folder the session was read from, so that messages about its rows name their file in
    /// full; `None` for a session made in memory (simulated, planned, read from a bag).
    pub folder: Option<PathBuf>,
    /// The camera rig of a session seen through its pixels (`cameras.yaml`), as the file gives it.
    pub rig: Option<std::sync::Arc<crate::model::Rig>>,
}

/// A pose left out of the session, and why (a free-motion recording's camera frame that falls
/// outside the encoder stream).
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    /// The file the pose came from.
    pub path: PathBuf,
    /// Its line.
    pub line: usize,
    /// Pose id.
    pub pose: u64,
    /// What is wrong with it.
    pub message: String,
    /// For a pose of a bag, the topic its message came from (`line` is then that message's
    /// index on its topic, not a line).
    pub topic: Option<String>,
    /// Expected and harmless, so a note rather than a warning: a recording's frame at its ends
    /// that falls outside the encoder stream, as when the camera stops after the encoders (the
    /// stream has no gaps, and a capture further out than the latency's bound is refused).
    pub note: bool,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.topic {
            Some(topic) => {
                write!(
                    f,
                    "{}: {topic}, message {}: pose {}: {}",
                    self.path.display(),
                    self.line,
                    self.pose,
                    self.message
                )
            }
            None => write!(f, "{}:{}: pose {}: {}", self.path.display(), self.line, self.pose, self.message),
        }
    }
}

/// What a static session observed: `markers.csv`'s points, or `pixels.csv`'s pixels seen by a rig.
enum Observations<'a> {
    Points(Vec<MarkerRow>),
    Body(Vec<BodyRow>),
    Pixels(Vec<PixelRow<u64>>, &'a Rig),
}

/// What a session folder's readers need of its `session.yaml` to locate their errors there.
struct SessionChecks<'a> {
    yaml_path: &'a Path,
    keys: &'a crate::io::yaml::KeyLines,
    reference_pose: Option<u64>,
}

impl SessionChecks<'_> {
    /// An error about the value of `key` in `session.yaml`, at its line.
    fn error(&self, key: &str, reason: String) -> FileError {
        self.keys.error(self.yaml_path, key, reason)
    }
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SessionFile {
    name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    model: Option<PathBuf>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    markers: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    body: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    reference_pose: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    description: Option<String>,
}

impl Session {
    /// What the marker-level fit observes, by name: a rigid body's origin (named after the body,
    /// marker 0 of its observations), then the markers.
    pub(crate) fn observed_names(&self) -> Vec<String> {
        self.body.iter().chain(&self.markers).cloned().collect()
    }

    /// The reference pose.
    ///
    /// # Panics
    /// If `reference_pose` is not one of the poses (never for a session from [`Session::load`] or the simulator).
    pub fn reference(&self) -> &SessionPose {
        self.poses.iter().find(|p| p.id == self.reference_pose).expect("validated on load")
    }

    /// The session with the captures of each station merged into one pose, as the per-pose
    /// estimator needs (one marker at a time gives no pose with three): the station's first
    /// capture's id, reading and time, and every marker it saw (the first sighting of each, with
    /// that sighting's pixels).
    /// Poses without a station stay as they are. The motion between captures is then blamed on
    /// the mechanism — the reason the marker-level fit uses every capture's own reading.
    pub fn by_station(&self) -> Session {
        let mut poses: Vec<SessionPose> = Vec::new();
        let mut at: HashMap<u64, usize> = HashMap::new();
        for pose in &self.poses {
            let merged = pose.station.and_then(|s| at.get(&s)).map(|&k| &mut poses[k]);
            match merged {
                Some(into) => {
                    if into.body.is_none() {
                        into.body = pose.body;
                    }
                    for (k, m) in pose.markers.iter().enumerate() {
                        if into.markers[k].is_none() && m.is_some() {
                            into.markers[k] = *m;
                            into.marker_lines[k] = pose.marker_lines[k];
                            into.pixels.extend(pose.pixels.iter().filter(|p| p.marker == k));
                        }
                    }
                }
                None => {
                    if let Some(s) = pose.station {
                        at.insert(s, poses.len());
                    }
                    poses.push(pose.clone());
                }
            }
        }
        let reference_pose = poses.iter().find(|p| p.fixes_orientation()).unwrap_or(&poses[0]).id;
        let truth = self.truth.as_ref().map(|t| Truth {
            parameters: t.parameters.clone(),
            orientations: poses.iter().filter_map(|p| t.orientations.get(&p.id).map(|r| (p.id, *r))).collect(),
            rig: t.rig.clone(),
        });
        Session { poses, reference_pose, truth, ..self.clone() }
    }

    /// Load and validate the session folder `dir`; `model` overrides the one named in
    /// `session.yaml`. ([`Session::load`] reads bags too.)
    ///
    /// # Errors
    /// A [`FileError`] naming the file, line and column (or YAML key) of the first problem.
    pub(crate) fn load_folder(dir: &Path, model: Option<&Path>) -> Result<(Session, Vec<Warning>), FileError> {
        let yaml_path = dir.join("session.yaml");
        let (file, keys) = crate::io::yaml::read::<SessionFile>(&yaml_path)?;
        let at = |key: &str, reason: String| keys.error(&yaml_path, key, reason);
        match &file.body {
            Some(body) => check_body_name(body, &file.markers).map_err(|reason| at("body", reason))?,
            None => check_marker_names(&file.markers).map_err(|(key, reason)| at(&key, reason))?,
        }
        let reference_pose = file.reference_pose;
        let model_given = model;
        let model = match (model, &file.model) {
            (Some(m), _) => m.to_path_buf(),
            (None, Some(m)) => crate::io::files::resolve_reference(dir, m),
            (None, None) => return Err(at("model", "no `model` given here and no --model on the command line".into())),
        };
        if let (None, Some(reason)) = (model_given, crate::model::shipped::missing(&model)) {
            return Err(at("model", reason));
        }
        let layout = session_kind(dir)?;
        match (layout.body, &file.body) {
            (false, Some(body)) => {
                let reason = format!("names the body `{body}`, but the folder holds no poses.csv (its poses)");
                return Err(at("body", reason));
            }
            (true, None) => {
                let reason = "the folder holds poses.csv (a rigid body's poses), but session.yaml lists markers: name the body instead (`body: <name>`)";
                return Err(at("markers", reason.into()));
            }
            _ => {}
        }
        // The rig first: the pixel rows name its cameras.
        let rig = match layout.pixels {
            true => Some(read_camchain(&dir.join("cameras.yaml"))?),
            false => None,
        };
        let session = Session {
            rig: None,
            name: file.name,
            description: file.description,
            model,
            markers: file.markers,
            body: file.body,
            reference_pose: 0,
            poses: Vec::new(),
            truth: None,
            streams: None,
            folder: Some(dir.to_path_buf()),
        };
        let checks = SessionChecks { yaml_path: &yaml_path, keys: &keys, reference_pose };
        match layout.kind {
            Kind::Recording => session.read_recording(rig, &checks),
            Kind::Static => session.read_static(rig, &checks),
        }
    }

    /// The streams of the recording in the session's folder (of points, or of pixels with `rig`),
    /// and its poses at latency 0.
    fn read_recording(
        mut self,
        rig: Option<Rig>,
        checks: &SessionChecks<'_>,
    ) -> Result<(Session, Vec<Warning>), FileError> {
        let dir = self.folder.clone().unwrap_or_default();
        let limits = StreamLimits::default();
        let (streams, unmet) = match &rig {
            Some(rig) => Streams::read_pixels(&dir, &self.markers, rig, &limits)?,
            None if self.body.is_some() => (Streams::read_body(&dir, &limits)?, Vec::new()),
            None => (Streams::read(&dir, &self.markers, &limits)?, Vec::new()),
        };
        let frames: Vec<f64> = streams.frames().map(|f| f.time_s).collect();
        let what = format!("camera frames in {}", file_name(&streams.captures_path));
        check_slots(self.markers.len(), frames.len(), &what).map_err(|r| checks.error("markers", r))?;
        let mut warnings: Vec<Warning> = match &rig {
            Some(rig) => unmet_in_recording(&unmet, &frames, &streams.captures_path, &self.markers, rig),
            None => Vec::new(),
        };
        self.truth = read_truth(&dir)?;
        self.streams = Some(std::sync::Arc::new(streams));
        self.rig = rig.map(std::sync::Arc::new);
        let (session, left_out) = self.at_latency(0.0);
        warnings.extend(left_out);
        Ok((session, warnings))
    }

    /// The poses of the static session in the session's folder: `joints.csv` with `markers.csv`,
    /// or with `pixels.csv` seen by `rig`.
    fn read_static(
        mut self,
        rig: Option<Rig>,
        checks: &SessionChecks<'_>,
    ) -> Result<(Session, Vec<Warning>), FileError> {
        let dir = self.folder.clone().unwrap_or_default();
        let joints_path = dir.join("joints.csv");
        let observations_path = dir.join(match (&rig, &self.body) {
            (Some(_), _) => "pixels.csv",
            (None, Some(_)) => "poses.csv",
            (None, None) => "markers.csv",
        });
        let names = &self.markers;
        let body = self.body.is_some();
        let read_observations = || match &rig {
            Some(rig) => read_pose_pixels(&observations_path, names, rig).map(|rows| Observations::Pixels(rows, rig)),
            None if body => read_body_poses(&observations_path).map(Observations::Body),
            None => read_markers(&observations_path, names).map(Observations::Points),
        };
        // The files are independent: the biggest is read on a second core.
        let ((readings, truth), rows) =
            in_parallel(|| (read_joints(&joints_path), read_truth(&dir)), read_observations);
        let readings = readings?;
        if readings.is_empty() {
            return Err(FileError::new(&joints_path, "empty session: no poses"));
        }
        check_slots(names.len(), readings.len(), "poses in joints.csv").map_err(|r| checks.error("markers", r))?;
        let mut warnings = Vec::new();
        let poses = match rows? {
            Observations::Points(rows) => assemble_poses(&readings, &rows, names.len(), &observations_path)?,
            Observations::Pixels(rows, rig) => {
                let mut poses = assemble_poses(&readings, &[], names.len(), &observations_path)?;
                attach_pixels(&mut poses, &rows, &observations_path)?;
                warnings.extend(triangulate_poses(&mut poses, rig, names, &observations_path));
                poses
            }
            Observations::Body(rows) => {
                let mut poses = assemble_poses(&readings, &[], 0, &observations_path)?;
                attach_bodies(&mut poses, &rows, &observations_path)?;
                poses
            }
        };
        check_station_markers(&poses, names, &observations_path, &mut warnings)?;
        // The per-pose estimator measures from the reference pose; the marker-level fit needs none.
        // Default: the first pose whose markers fix an orientation, else the first that sees
        // enough markers for the estimator, else the first.
        let reference_pose = checks.reference_pose.unwrap_or_else(|| default_reference(&poses));
        if !poses.iter().any(|p| p.id == reference_pose) {
            return Err(checks.error("reference_pose", format!("reference pose {reference_pose} is not in joints.csv")));
        }
        self.truth = truth?;
        self.poses = poses;
        self.reference_pose = reference_pose;
        self.rig = rig.map(std::sync::Arc::new);
        Ok((self, warnings))
    }

    /// A static session from poses already in memory (named `name`, read with the URDF `model`),
    /// checked as a session folder is: the marker names, one marker slot per name in every pose,
    /// distinct pose ids, finite joints within a turn (degrees are refused), marker coordinates
    /// within 10 m (millimetres are refused); the reference pose the first that sees three markers.
    ///
    /// # Errors
    /// A [`FileError`] on `name`, at the pose's row (from 1), saying what is wrong.
    pub fn from_poses(
        name: &str,
        model: &Path,
        markers: Vec<String>,
        poses: Vec<SessionPose>,
    ) -> Result<Session, FileError> {
        let at = |row: usize, reason: String| FileError::new(Path::new(name), reason).at_line(row + 1);
        check_marker_names(&markers).map_err(|(_, reason)| FileError::new(Path::new(name), reason))?;
        check_poses_in_memory(name, &poses)?;
        for (row, p) in poses.iter().enumerate() {
            if p.markers.len() != markers.len() {
                let reason =
                    format!("pose {}: {} marker slots for {} marker names", p.id, p.markers.len(), markers.len());
                return Err(at(row, reason));
            }
            let far =
                p.markers.iter().flatten().flat_map(|m| m.iter()).find_map(|v| super::markers::millimetres_reason(*v));
            if let Some(reason) = far {
                return Err(at(row, format!("pose {}: a marker coordinate: {reason}", p.id)));
            }
        }
        Ok(Session::in_memory(name, model, markers, None, poses))
    }

    /// A static session of a rigid body's poses already in memory (named `name`, read with the
    /// URDF `model`, the body named `body`): what a bag's reader makes of a body's resting poses,
    /// checked as a session folder is — distinct pose ids, finite joints within a turn, each
    /// pose's body as [`BodyPose`]'s constructor made it, no markers; the reference pose the
    /// first where the body was seen.
    ///
    /// # Errors
    /// A [`FileError`] on `name`, at the pose's row (from 1), saying what is wrong.
    // The bag reader's (branch `bags`) constructor of a body's resting poses, as `from_poses` is
    // for markers.
    #[allow(dead_code)]
    pub(crate) fn of_body(name: &str, model: &Path, body: &str, poses: Vec<SessionPose>) -> Result<Session, FileError> {
        let at = |row: usize, reason: String| FileError::new(Path::new(name), reason).at_line(row + 1);
        check_body_name(body, &[]).map_err(|reason| FileError::new(Path::new(name), reason))?;
        check_poses_in_memory(name, &poses)?;
        if let Some((row, p)) = poses.iter().enumerate().find(|(_, p)| !p.markers.is_empty()) {
            return Err(at(row, format!("pose {}: markers in a session of a rigid body", p.id)));
        }
        if poses.iter().all(|p| p.body.is_none()) {
            return Err(FileError::new(Path::new(name), format!("the body `{body}` is seen at no pose")));
        }
        Ok(Session::in_memory(name, model, Vec::new(), Some(body.to_string()), poses))
    }

    fn in_memory(
        name: &str,
        model: &Path,
        markers: Vec<String>,
        body: Option<String>,
        poses: Vec<SessionPose>,
    ) -> Session {
        let reference_pose = poses.iter().find(|p| p.fixes_orientation()).unwrap_or(&poses[0]).id;
        Session {
            rig: None,
            name: name.to_string(),
            description: None,
            model: model.to_path_buf(),
            markers,
            body,
            reference_pose,
            poses,
            truth: None,
            streams: None,
            folder: None,
        }
    }

    /// The session as a perfect camera would have reported it: every marker position (the poses'
    /// and a recording's captures') corrected by the camera model's exact inverse
    /// ([`CameraModel::undistort`]). `None` when `K` is singular or a position has no preimage
    /// (parameters files and configs refuse a model that folds space where the camera sees).
    pub fn undistorted(&self, camera: &CameraModel) -> Option<Session> {
        if camera.is_perfect() {
            return Some(self.clone());
        }
        let mut session = self.clone();
        for pose in session.poses.iter_mut() {
            for m in pose.markers.iter_mut().flatten() {
                *m = camera.undistort(m)?;
            }
        }
        if let Some(streams) = session.streams.as_mut() {
            let streams = std::sync::Arc::make_mut(streams);
            for c in streams.captures.iter_mut() {
                c.position = camera.undistort(&c.position)?;
            }
        }
        Some(session)
    }

    /// A free-motion recording's poses for camera latency `latency_s`: one pose per camera frame
    /// (the captures — points or pixels — sharing a time stamp, the pixels attached to the pose),
    /// numbered in order, its joints interpolated in the
    /// encoder stream at the frame's time less the latency. Frames that fall outside the encoder
    /// stream at that latency are left out, each with a warning naming its `captures.csv` line.
    /// A session without streams is returned as it is.
    pub fn at_latency(&self, latency_s: f64) -> (Session, Vec<Warning>) {
        self.at_clock(latency_s, 0.0)
    }

    /// As [`Session::at_latency`], keeping only the frames that lie inside the encoder stream for
    /// every latency in `range` (`lo ≤ latency_s ≤ hi`): a fit that estimates the latency within
    /// those bounds then works on the same frames whatever value it tries.
    pub fn at_latency_within(&self, latency_s: f64, range: (f64, f64)) -> (Session, Vec<Warning>) {
        self.at_clock_within(Clock::latency(latency_s), range, (0.0, 0.0))
    }

    /// As [`Session::at_latency`] for a camera clock that also runs `rate_ppm` faster than the
    /// encoders': each frame's joints at the encoders' time of its stamp `t`,
    /// `(t − latency_s) / (1 + rate_ppm·10⁻⁶)` (`latency_s` the latency at the encoders' time 0).
    pub fn at_clock(&self, latency_s: f64, rate_ppm: f64) -> (Session, Vec<Warning>) {
        self.at_clock_within(Clock { latency_s, rate_ppm }, (latency_s, latency_s), (rate_ppm, rate_ppm))
    }

    /// As [`Session::at_clock`], keeping only the frames that lie inside the encoder stream for
    /// every clock with its latency in `latency` and its rate in `rate_ppm` (`lo ≤ hi` each): a
    /// fit that estimates them within those bounds then works on the same frames whatever values
    /// it tries. (The encoders' time of a stamp moves monotonically with each, so the four
    /// corners of the box bound it.)
    pub(crate) fn at_clock_within(
        &self,
        clock: Clock,
        (lo, hi): (f64, f64),
        (slow, fast): (f64, f64),
    ) -> (Session, Vec<Warning>) {
        let Some(streams) = &self.streams else { return (self.clone(), Vec::new()) };
        let m = self.markers.len();
        let (mut poses, mut warnings): (Vec<SessionPose>, Vec<Warning>) = (Vec::new(), Vec::new());
        // A pose's id is its frame's place in the recording, whichever frames a clock leaves out:
        // the same frame has the same id at every latency tried, and a left-out one its own.
        for (id, frame) in (0u64..).zip(streams.frames()) {
            let time = frame.time_s;
            let corners = [(lo, slow), (lo, fast), (hi, slow), (hi, fast)];
            let inside = corners.iter().all(|&(latency_s, rate_ppm)| {
                streams.joints_at(Clock { latency_s, rate_ppm }.encoder_time(time)).is_some()
            });
            let Some(joints) = streams.joints_at(clock.encoder_time(time)).filter(|_| inside) else {
                let at = match (lo == hi, slow == fast) {
                    (true, true) if slow == 0.0 => format!("at a latency of {lo} s"),
                    (true, true) => format!("at a latency of {lo} s and a clock rate of {slow} ppm"),
                    (false, true) if slow == 0.0 => format!("for a latency in [{lo}, {hi}] s"),
                    (false, true) => format!("for a latency in [{lo}, {hi}] s at a clock rate of {slow} ppm"),
                    (true, false) => format!("at a latency of {lo} s for a clock rate in [{slow}, {fast}] ppm"),
                    (false, false) => {
                        format!("for a latency in [{lo}, {hi}] s and a clock rate in [{slow}, {fast}] ppm")
                    }
                };
                warnings.push(Warning {
                    path: streams.captures_path.clone(),
                    line: frame.line(),
                    pose: id,
                    message: format!("the frame at {time} s falls outside the encoder stream {at}: left out"),
                    topic: streams.bag_topics.clone(),
                    note: true,
                });
                continue;
            };
            // A bag's capture is a message, on no line of any file: its markers and body carry no
            // line, so reports and errors name them by pose (the frame's `line` stays its message
            // number, which the warnings give with the topic).
            let from_bag = streams.bag_topics.is_some();
            let mut pose = SessionPose {
                pixels: frame.pixels.iter().map(|p| p.seen).collect(),
                id,
                joints,
                time_s: Some(time),
                markers: vec![None; m],
                line: frame.line(),
                marker_lines: vec![0; m],
                station: None,
                body: frame.body.map(|b| BodyPose { line: if from_bag { 0 } else { b.pose.line }, ..b.pose }),
            };
            for c in frame.captures {
                pose.markers[c.marker] = Some(c.position);
                pose.marker_lines[c.marker] = if from_bag { 0 } else { c.line };
            }
            poses.push(pose);
        }
        let reference_pose = poses.iter().find(|p| p.fixes_orientation()).or(poses.first()).map_or(0, |p| p.id);
        (Session { poses, reference_pose, ..self.clone() }, warnings)
    }

    /// Check, before any work, that a session can be written into `dir`: a session folder (it has
    /// `session.yaml`), an empty folder, or a new folder whose parent exists and takes files.
    ///
    /// # Errors
    /// `dir` is a file, a folder holding something that is not a session, or not writable.
    pub fn check_destination(dir: &Path) -> Result<(), FileError> {
        if dir.exists() && !dir.is_dir() {
            return Err(FileError::new(dir, "is a file; a session is a folder"));
        }
        let occupied = std::fs::read_dir(dir).is_ok_and(|mut entries| entries.next().is_some());
        if occupied && !dir.join("session.yaml").exists() {
            return Err(FileError::new(dir, "the folder is not empty and holds no session: refusing to write into it"));
        }
        let probe_in = if dir.is_dir() { dir } else { crate::io::files::parent_folder(dir) };
        tempfile::tempfile_in(probe_in).map_err(|e| FileError::new(dir, format!("cannot write here: {e}")))?;
        Ok(())
    }

    /// Write the session into `dir` (created if needed). Every file is written atomically and
    /// `session.yaml` last, so a folder without it is an interrupted write, never a session. A
    /// session with a rig is written as its pixels — `pixels.csv` and `cameras.yaml` in place of
    /// `markers.csv` or `captures.csv` — whose triangulated points it gets back on loading.
    ///
    /// # Errors
    /// A [`FileError`] when `dir` holds something that is not a session, a file cannot be written,
    /// or the session could not be read back as it is (pixels without a rig, a camera the rig
    /// does not have or named otherwise than `cam<k>`, a pixel outside its image or seen twice, a
    /// marker point without the pixels it comes from); nothing is written then.
    ///
    /// # Panics
    /// Never in practice: serialising the session's YAML cannot fail.
    pub fn write(&self, dir: &Path) -> Result<(), FileError> {
        Session::check_destination(dir)?;
        if self.streams.is_none() {
            check_stations(&self.poses, &dir.join("joints.csv"))?;
        }
        self.check_pixels(dir)?;
        if let Some(rig) = self.truth.as_ref().and_then(|t| t.rig.as_ref()) {
            let path = dir.join("truth_cameras.yaml");
            check_writable(rig).map_err(|r| FileError::new(&path, format!("{r}; not written")))?;
        }
        std::fs::create_dir_all(dir).map_err(|e| FileError::new(dir, format!("cannot create the folder: {e}")))?;
        let mut written = vec!["session.yaml"];
        if let Some(streams) = &self.streams {
            // A free-motion recording is its streams; its poses are derived from them on loading.
            write_atomic(&dir.join("encoders.csv"), encoders_csv(&streams.encoders).as_bytes())?;
            written.push("encoders.csv");
            match self.rig.as_deref() {
                Some(rig) => {
                    let text = timed_pixels_csv(&streams.pixels, &self.markers, rig);
                    written.extend(self.write_rig(dir, rig, &text)?);
                }
                None if self.body.is_some() => {
                    write_atomic(&dir.join("poses.csv"), body_captures_csv(&streams.bodies).as_bytes())?;
                    written.push("poses.csv");
                }
                None => {
                    let text = captures_csv(&streams.captures, &self.markers);
                    write_atomic(&dir.join("captures.csv"), text.as_bytes())?;
                    written.push("captures.csv");
                }
            }
        } else {
            written.extend(self.write_poses(dir)?);
        }
        if let Some(truth) = &self.truth {
            truth.parameters.write(&dir.join("truth.yaml"))?;
            written.push("truth.yaml");
            if let Some(rig) = &truth.rig {
                write_camchain(&dir.join("truth_cameras.yaml"), rig)?;
                written.push("truth_cameras.yaml");
            }
            if self.streams.is_none() {
                let records: Vec<_> = truth
                    .orientations
                    .iter()
                    .map(|(&pose, &rotation)| OrientationRecord { pose, mode: None, rotation, extra: vec![], line: 0 })
                    .collect();
                write_atomic(&dir.join("truth_orientations.csv"), write_orientations(&records).as_bytes())?;
                written.push("truth_orientations.csv");
            }
        }
        let file = SessionFile {
            name: self.name.clone(),
            model: Some(crate::model::reference_from(dir, &self.model)),
            markers: self.markers.clone(),
            body: self.body.clone(),
            reference_pose: self.streams.is_none().then_some(self.reference_pose),
            description: self.description.clone(),
        };
        // A session replaced here leaves no file of another kind (or a truth it lacks).
        remove_stale(dir, &written)?;
        let yaml = serde_yaml::to_string(&file).expect("session serialises");
        write_atomic(&dir.join("session.yaml"), yaml.as_bytes())
    }

    /// Write a static session's `joints.csv` and its observations — `markers.csv`, or with a rig
    /// `pixels.csv` and `cameras.yaml` — and say which files.
    fn write_poses(&self, dir: &Path) -> Result<Vec<&'static str>, FileError> {
        let readings: Vec<_> = self
            .poses
            .iter()
            .map(|p| JointReading { pose: p.id, line: 0, joints: p.joints, time_s: p.time_s, station: p.station })
            .collect();
        write_joints(&dir.join("joints.csv"), &readings)?;
        let mut written = vec!["joints.csv"];
        if self.body.is_some() {
            let rows = self.poses.iter().filter_map(|p| p.body.as_ref().map(|b| (p.id, b)));
            write_atomic(&dir.join("poses.csv"), body_poses_csv(rows).as_bytes())?;
            written.push("poses.csv");
            return Ok(written);
        }
        if let Some(rig) = self.rig.as_deref() {
            let rows = self.poses.iter().flat_map(|p| p.pixels.iter().map(move |px| (p.id, px)));
            written.extend(self.write_rig(dir, rig, &pose_pixels_csv(rows, &self.markers, rig))?);
            return Ok(written);
        }
        let rows: Vec<_> =
            self.poses
                .iter()
                .flat_map(|p| {
                    p.markers.iter().enumerate().filter_map(move |(k, m)| {
                        m.map(|position| MarkerRow { pose: p.id, marker: k, position, line: 0 })
                    })
                })
                .collect();
        write_markers(&dir.join("markers.csv"), &rows, &self.markers)?;
        written.push("markers.csv");
        Ok(written)
    }

    /// Write `pixels.csv` (its text `pixels`) and the rig's `cameras.yaml`.
    fn write_rig(&self, dir: &Path, rig: &Rig, pixels: &str) -> Result<[&'static str; 2], FileError> {
        write_atomic(&dir.join("pixels.csv"), pixels.as_bytes())?;
        write_camchain(&dir.join("cameras.yaml"), rig)?;
        Ok(PIXEL_FILES)
    }

    /// Check, before anything is written into `dir`, that the session's pixels can be written as
    /// files its reader takes back: pixels only with a rig; a rig whose cameras are named as a
    /// camchain names them; every pixel of a known marker and camera, inside its image, once per
    /// (pose or time, marker, camera), times in order; and no marker point without the pixels it
    /// comes from (a session with a rig is written as its pixels: the point would be lost).
    fn check_pixels(&self, dir: &Path) -> Result<(), FileError> {
        let path = dir.join("pixels.csv");
        let refuse = |reason: String| FileError::new(&path, format!("{reason}; not written"));
        let Some(rig) = self.rig.as_deref() else {
            let pixels = self.poses.iter().any(|p| !p.pixels.is_empty())
                || self.streams.as_ref().is_some_and(|s| !s.pixels.is_empty());
            return match pixels {
                true => Err(refuse("the session has pixels but no rig (cameras.yaml) to name their cameras".into())),
                false => Ok(()),
            };
        };
        check_writable(rig).map_err(|r| FileError::new(&dir.join("cameras.yaml"), format!("{r}; not written")))?;
        let m = self.markers.len();
        match &self.streams {
            Some(streams) => {
                if streams.pixels.is_empty() && !streams.captures.is_empty() {
                    return Err(refuse(
                        "the recording has a rig but only marker points: it is written as its pixels".into(),
                    ));
                }
                let rows = streams.pixels.iter().map(|r| (format!("the pixel at {} s", r.at), &r.seen));
                check_rows(rows, m, rig).map_err(refuse)?;
                if let Some(w) = streams.pixels.windows(2).find(|w| w[1].at < w[0].at) {
                    return Err(refuse(format!("the pixel at {} s comes after one at {} s", w[1].at, w[0].at)));
                }
                let keys = streams.pixels.iter().map(|r| ((r.at.to_bits(), r.seen.marker, r.seen.camera), 0));
                if let Some(((bits, marker, camera), _)) = first_repeat(keys) {
                    let at = format!("at {} s", f64::from_bits(bits));
                    return Err(refuse(self.seen_twice(rig, marker, camera, &at)));
                }
            }
            None => {
                let rows =
                    self.poses.iter().flat_map(|p| p.pixels.iter().map(move |px| (format!("pose {}", p.id), px)));
                check_rows(rows, m, rig).map_err(refuse)?;
                let keys =
                    self.poses.iter().flat_map(|p| p.pixels.iter().map(move |px| ((p.id, px.marker, px.camera), 0)));
                if let Some(((pose, marker, camera), _)) = first_repeat(keys) {
                    return Err(refuse(self.seen_twice(rig, marker, camera, &format!("at pose {pose}"))));
                }
                self.check_points_have_pixels().map_err(refuse)?;
            }
        }
        Ok(())
    }

    fn seen_twice(&self, rig: &Rig, marker: usize, camera: usize, at: &str) -> String {
        format!("marker `{}` is seen twice by camera `{}` {at}", self.markers[marker], rig.cameras[camera].name)
    }

    /// Every marker point of a pose has pixels of its marker in that pose.
    fn check_points_have_pixels(&self) -> Result<(), String> {
        for pose in &self.poses {
            let mut seen = vec![false; pose.markers.len()];
            for p in &pose.pixels {
                if let Some(s) = seen.get_mut(p.marker) {
                    *s = true;
                }
            }
            if let Some(k) = (0..seen.len()).find(|&k| pose.markers[k].is_some() && !seen[k]) {
                return Err(format!(
                    "pose {}: marker `{}` has a point but no pixels, and a session with a rig is written as its pixels (the point would be lost)",
                    pose.id, self.markers[k]
                ));
            }
        }
        Ok(())
    }
}

/// The stations of `poses` as `joints.csv` (at `path`) must hold them for the session to load
/// again: on every pose or on none, and each station's captures one pose (see
/// [`super::joints::MAX_STATION_SPREAD_DEG`]). A writer never writes what its reader refuses.
fn check_stations(poses: &[SessionPose], path: &Path) -> Result<(), FileError> {
    let with = poses.iter().filter(|p| p.station.is_some()).count();
    if let Some(p) = poses.iter().find(|p| p.station.is_none()).filter(|_| with > 0) {
        let reason = format!(
            "pose {} has no station while {with} poses have one: joints.csv gives every pose its station or none; not written",
            p.id
        );
        return Err(FileError::new(path, reason));
    }
    let mut spans = StationSpans::default();
    for (k, p) in poses.iter().enumerate() {
        let Some(station) = p.station else { continue };
        if let Some(far) = spans.add(station, &p.joints, k) {
            let (this, other) = (format!("pose {}", p.id), format!("pose {}", poses[far.earlier].id));
            let reason = far.describe(station, &this, &other)
                + "; a session that would not load is not written (simulated: lower `capture.motion_deg`)";
            return Err(FileError::new(path, reason));
        }
    }
    Ok(())
}

/// The first pose whose markers fix an orientation (at least three, no two coincident, not on a
/// line: [`constellation::check`]), else the first that sees three, else the first.
fn default_reference(poses: &[SessionPose]) -> u64 {
    if let Some(p) = poses.iter().find(|p| p.body.is_some()) {
        return p.id;
    }
    let fixes = |p: &&SessionPose| {
        let points: Vec<_> = p.markers.iter().flatten().copied().collect();
        constellation::check(&points, MARKER_NOISE_M).is_ok()
    };
    let enough = |p: &&SessionPose| p.seen() >= MIN_MARKERS;
    poses.iter().filter(enough).find(fixes).or_else(|| poses.iter().find(enough)).unwrap_or(&poses[0]).id
}

fn names_of(names: &[String], ks: &[usize]) -> String {
    ks.iter().map(|&k| format!("`{}`", names[k])).collect::<Vec<_>>().join(", ")
}

/// A station (the captures meant as one pose, one marker at a time) that captures a marker twice
/// and another never is refused at the second capture's row: a mislabelled capture, most likely
/// (the per-pose estimator would merge the first sighting and drop the other, and the fit would
/// take the wrong label as a gross error). A marker captured twice where every marker was captured
/// (a retake) is data: both captures are used by the marker-level fit, the first by the per-pose
/// estimator, and a warning says so.
///
/// # Errors
/// A [`FileError`] at the `markers.csv` line of the second capture of the repeated marker.
fn check_station_markers(
    poses: &[SessionPose],
    names: &[String],
    markers_path: &Path,
    warnings: &mut Vec<Warning>,
) -> Result<(), FileError> {
    // The captures (pose index, marker line) of each marker of each station, in file order.
    let mut stations: BTreeMap<u64, Vec<Vec<(usize, usize)>>> = BTreeMap::new();
    for (i, pose) in poses.iter().enumerate() {
        let Some(station) = pose.station else { continue };
        let sightings = stations.entry(station).or_insert_with(|| vec![Vec::new(); names.len()]);
        for (k, m) in pose.markers.iter().enumerate() {
            if m.is_some() {
                sightings[k].push((i, pose.marker_lines[k]));
            }
        }
    }
    for (station, sightings) in &stations {
        let Some(twice) = sightings.iter().position(|s| s.len() > 1) else { continue };
        let never: Vec<usize> = (0..names.len()).filter(|&k| sightings[k].is_empty()).collect();
        let (first, second) = (sightings[twice][0], sightings[twice][1]);
        let captures = format!(
            "station {station} captures marker `{}` twice ({} lines {} and {}, poses {} and {})",
            names[twice],
            file_name(markers_path),
            first.1,
            second.1,
            poses[first.0].id,
            poses[second.0].id
        );
        if !never.is_empty() {
            let reason = format!(
                "{captures} and {} never: a mislabelled capture? Fix its label if it was meant as {}, or delete the capture you do not want if it was a retake",
                names_of(names, &never),
                names_of(names, &never[..1])
            );
            return Err(FileError::new(markers_path, reason).at_line(second.1).in_column("marker"));
        }
        warnings.push(Warning {
            path: markers_path.to_path_buf(),
            line: second.1,
            pose: poses[second.0].id,
            message: format!("{captures}: a retake? The marker-level fit uses both; the per-pose estimator the first"),
            topic: None,
            note: false,
        });
    }
    Ok(())
}

/// Remove the files of an earlier session in `dir` that the session written there — its
/// `written` files — does not have (a recording written over a static session, pixels over
/// points, a session without a truth over one with), so that the folder holds one session, not
/// two that disagree.
fn remove_stale(dir: &Path, written: &[&str]) -> Result<(), FileError> {
    let files: [&[&str]; 5] = [&STATIC_FILES, &RECORDING_FILES, &PIXEL_FILES, &BODY_FILES, &TRUTH_FILES];
    for name in files.iter().copied().flatten().filter(|f| !written.contains(f)) {
        let path = dir.join(name);
        match std::fs::remove_file(&path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(FileError::new(&path, format!("cannot remove this file of the session replaced: {e}")));
            }
            _ => {}
        }
    }
    Ok(())
}

/// At least [`MIN_MARKERS`] names, none empty, none repeated: one hash set, linear in the names.
/// The error is `(key, reason)`, the key locating the offending name (`markers[k]`).
fn check_marker_names(names: &[String]) -> Result<(), (String, String)> {
    if names.len() < MIN_MARKERS {
        return Err((
            "markers".into(),
            format!("{} markers listed; at least {MIN_MARKERS} are needed to determine an orientation", names.len()),
        ));
    }
    let mut first: foldhash::HashMap<&str, usize> = foldhash::HashMap::default();
    first.reserve(names.len());
    for (k, name) in names.iter().enumerate() {
        if name.is_empty() {
            return Err((
                format!("markers[{k}]"),
                format!("marker name `` is empty or repeated: marker {} has no name", k + 1),
            ));
        }
        if let Some(&j) = first.get(name.as_str()) {
            let reason = format!(
                "marker name `{name}` is empty or repeated: `{name}` is listed twice (markers {} and {})",
                j + 1,
                k + 1
            );
            return Err((format!("markers[{k}]"), reason));
        }
        first.insert(name, k);
    }
    Ok(())
}

/// The poses of a session made in memory (`name`): at least one, distinct ids, finite joints
/// within a turn (degrees are refused).
fn check_poses_in_memory(name: &str, poses: &[SessionPose]) -> Result<(), FileError> {
    let at = |row: usize, reason: String| FileError::new(Path::new(name), reason).at_line(row + 1);
    if poses.is_empty() {
        return Err(FileError::new(Path::new(name), "empty session: no poses"));
    }
    let mut ids = std::collections::HashSet::new();
    for (row, p) in poses.iter().enumerate() {
        if !ids.insert(p.id) {
            return Err(at(row, format!("pose {} appears twice", p.id)));
        }
        if !p.joints.iter().all(|j| j.is_finite()) {
            return Err(at(row, format!("pose {}: joint readings {:?} are not finite", p.id, p.joints.as_slice())));
        }
        if let Some(reason) = p.joints.iter().find_map(|j| super::joints::degrees_reason(*j)) {
            return Err(at(row, format!("pose {}: {reason}", p.id)));
        }
    }
    Ok(())
}

/// A body's name: not empty, and no markers listed beside it (a session is of markers or of a
/// rigid body).
fn check_body_name(body: &str, markers: &[String]) -> Result<(), String> {
    if body.trim().is_empty() {
        return Err("the body's name is empty".into());
    }
    if !markers.is_empty() {
        return Err(format!(
            "names the body `{body}` and lists {} markers: a session's observations are a rigid body's poses (poses.csv) or markers, not both",
            markers.len()
        ));
    }
    Ok(())
}

/// What a session folder holds: a static (or sequential) session or a free-motion recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// `joints.csv` and `markers.csv` (or `pixels.csv`).
    Static,
    /// `encoders.csv` and `captures.csv` (or `pixels.csv`).
    Recording,
}

/// A session folder's kind and whether it holds pixels (`pixels.csv` and `cameras.yaml`) in place
/// of marker points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layout {
    kind: Kind,
    pixels: bool,
    /// A rigid body's poses (`poses.csv`) in place of markers.
    body: bool,
}

const STATIC_FILES: [&str; 2] = ["joints.csv", "markers.csv"];
const RECORDING_FILES: [&str; 2] = ["encoders.csv", "captures.csv"];
const PIXEL_FILES: [&str; 2] = ["pixels.csv", "cameras.yaml"];
const BODY_FILES: [&str; 1] = ["poses.csv"];
const TRUTH_FILES: [&str; 3] = ["truth.yaml", "truth_orientations.csv", "truth_cameras.yaml"];

/// Which kind of session `dir` holds, of points or of pixels. A folder with files of both kinds,
/// or with both points and pixels, is an error naming them (which is meant cannot be told); so
/// are pixels without the rig that names their cameras and a rig without pixels. A folder with
/// neither kind is read as a static session (whose reader then names the missing `joints.csv`).
fn session_kind(dir: &Path) -> Result<Layout, FileError> {
    let present = |files: [&'static str; 2]| -> Vec<&'static str> {
        files.into_iter().filter(|f| dir.join(f).exists()).collect()
    };
    let (statics, streams, pixels) = (present(STATIC_FILES), present(RECORDING_FILES), present(PIXEL_FILES));
    let kind = match (statics.is_empty(), streams.is_empty()) {
        (false, false) => {
            return Err(FileError::new(
                dir,
                format!(
                    "holds files of a static session ({}) and of a free-motion recording ({}): a session folder holds one pair, joints.csv and markers.csv or encoders.csv and captures.csv (pixels.csv and cameras.yaml in place of markers.csv or captures.csv), and which one is meant here cannot be told; move the other out",
                    statics.join(", "),
                    streams.join(", ")
                ),
            ));
        }
        (true, false) => Kind::Recording,
        _ => Kind::Static,
    };
    let points: Vec<&str> = ["markers.csv", "captures.csv"].into_iter().filter(|f| dir.join(f).exists()).collect();
    let body = dir.join("poses.csv").exists();
    if let Some(other) = points.iter().chain(&pixels).next().filter(|_| body) {
        return Err(FileError::new(
            dir,
            format!(
                "holds a rigid body's poses (poses.csv) and marker observations ({other}): a session's observations are one or the other, and which are meant here cannot be told; move the other out"
            ),
        ));
    }
    match (pixels.contains(&"pixels.csv"), pixels.contains(&"cameras.yaml")) {
        (true, _) if !points.is_empty() => Err(FileError::new(
            dir,
            format!(
                "holds marker points ({}) and pixels (pixels.csv): a session's observations are one or the other, and which are meant here cannot be told; move the other out",
                points.join(", ")
            ),
        )),
        (true, false) => Err(FileError::new(
            &dir.join("cameras.yaml"),
            "missing: pixels.csv names the cameras of a rig, which cameras.yaml (Kalibr's camchain) defines",
        )),
        (false, true) => Err(FileError::new(
            dir,
            "holds cameras.yaml but no pixels.csv: a rig is read for the pixels its cameras saw; give pixels.csv, or move cameras.yaml out",
        )),
        (has_pixels, _) => Ok(Layout { kind, pixels: has_pixels, body }),
    }
}

/// Most marker slots (poses × listed markers) a session may hold: every pose keeps a place for
/// each listed marker (40 bytes), so 2^24 slots are 670 MB — far beyond any real session (an
/// hour of 60 Hz frames with 4 markers is 864,000) and short of exhausting the machine.
const MAX_MARKER_SLOTS: usize = 1 << 24;

/// `markers` listed names for `poses` poses (`what` says which), within [`MAX_MARKER_SLOTS`].
fn check_slots(markers: usize, poses: usize, what: &str) -> Result<(), String> {
    match markers.checked_mul(poses) {
        Some(slots) if slots <= MAX_MARKER_SLOTS => Ok(()),
        _ => Err(format!(
            "{markers} markers listed for {poses} {what} make more than {MAX_MARKER_SLOTS} marker slots (one per marker and pose), more than a session may hold in memory: list only the markers on the MP"
        )),
    }
}

/// Join joint readings and marker rows by pose; marker rows of an unknown pose are an error.
fn assemble_poses(
    readings: &[JointReading],
    rows: &[MarkerRow],
    markers: usize,
    markers_path: &Path,
) -> Result<Vec<SessionPose>, FileError> {
    let mut poses: Vec<SessionPose> = readings
        .iter()
        .map(|r| SessionPose {
            pixels: Vec::new(),
            id: r.pose,
            joints: r.joints,
            time_s: r.time_s,
            markers: vec![None; markers],
            line: r.line,
            marker_lines: vec![0; markers],
            station: r.station,
            body: None,
        })
        .collect();
    let index: foldhash::HashMap<u64, usize> = poses.iter().enumerate().map(|(k, p)| (p.id, k)).collect();
    for row in rows {
        let k = index.get(&row.pose).ok_or_else(|| {
            FileError::new(markers_path, format!("markers for pose {}, which joints.csv does not have", row.pose))
                .at_line(row.line)
                .in_column("pose")
        })?;
        poses[*k].markers[row.marker] = Some(row.position);
        poses[*k].marker_lines[row.marker] = row.line;
    }
    Ok(poses)
}

/// Give each pose of `poses` its body pose of `poses.csv` (at `path`); a row of a pose
/// `joints.csv` does not have is an error.
fn attach_bodies(poses: &mut [SessionPose], rows: &[BodyRow], path: &Path) -> Result<(), FileError> {
    let index: foldhash::HashMap<u64, usize> = poses.iter().enumerate().map(|(k, p)| (p.id, k)).collect();
    for row in rows {
        let k = index.get(&row.pose).ok_or_else(|| {
            FileError::new(path, format!("the body's pose at pose {}, which joints.csv does not have", row.pose))
                .at_line(row.body.line)
                .in_column("pose")
        })?;
        poses[*k].body = Some(row.body);
    }
    Ok(())
}

/// Give each pose of `poses` its rows of `pixels.csv` (at `path`); rows of a pose `joints.csv`
/// does not have are an error.
fn attach_pixels(poses: &mut [SessionPose], rows: &[PixelRow<u64>], path: &Path) -> Result<(), FileError> {
    let index: foldhash::HashMap<u64, usize> = poses.iter().enumerate().map(|(k, p)| (p.id, k)).collect();
    for row in rows {
        let k = index.get(&row.at).ok_or_else(|| {
            FileError::new(path, format!("pixels for pose {}, which joints.csv does not have", row.at))
                .at_line(row.seen.line)
                .in_column("pose")
        })?;
        poses[*k].pixels.push(row.seen);
    }
    Ok(())
}

/// Set each pose's marker points to those `rig` triangulates from its pixels (a marker seen by
/// two cameras or more), each at the line of its first pixel row; the markers whose rays do not
/// meet are warnings naming their first row of `pixels_path`. (For a session made in memory, the
/// simulator's, as for one read.)
pub(crate) fn triangulate_poses(
    poses: &mut [SessionPose],
    rig: &Rig,
    names: &[String],
    pixels_path: &Path,
) -> Vec<Warning> {
    let mut warnings = Vec::new();
    for pose in poses.iter_mut() {
        pose.markers = vec![None; names.len()];
        pose.marker_lines = vec![0; names.len()];
        let t = triangulate(rig, &pose.pixels);
        for (k, point, line) in t.points {
            pose.markers[k] = Some(point);
            pose.marker_lines[k] = line;
        }
        warnings.extend(t.unmet.into_iter().map(|(k, line, cameras)| Warning {
            path: pixels_path.to_path_buf(),
            line,
            pose: pose.id,
            message: unmet_message(names, rig, k, &cameras),
            topic: None,
            note: false,
        }));
    }
    warnings
}

/// The markers of a recording whose pixels gave no point, as warnings; each names its camera
/// frame by its place among `frames` (their times), the pose it is at latency 0 when no frame is
/// left out.
fn unmet_in_recording(unmet: &[Unmet], frames: &[f64], path: &Path, names: &[String], rig: &Rig) -> Vec<Warning> {
    unmet
        .iter()
        .map(|(time, k, line, cameras)| Warning {
            path: path.to_path_buf(),
            line: *line,
            pose: frames.partition_point(|t| t < time) as u64,
            message: unmet_message(names, rig, *k, cameras),
            topic: None,
            note: false,
        })
        .collect()
}

/// The file name of `path`, for messages (`captures.csv`).
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
}

fn read_truth(dir: &Path) -> Result<Option<Truth>, FileError> {
    let path = dir.join("truth.yaml");
    if !path.exists() {
        return Ok(None);
    }
    let parameters = Parameters::read(&path)?;
    let orientations_path = dir.join("truth_orientations.csv");
    let orientations = if orientations_path.exists() {
        read_orientations(&orientations_path)?.into_iter().map(|r| (r.pose, r.rotation)).collect()
    } else {
        BTreeMap::new()
    };
    // The true rig of a session seen through its pixels, in the camchain format of `cameras.yaml`.
    let rig_path = dir.join("truth_cameras.yaml");
    let rig = if rig_path.exists() { Some(read_camchain(&rig_path)?) } else { None };
    Ok(Some(Truth { parameters, orientations, rig }))
}
impl Session {
    /// A pixel session as a tracker that gives points would have recorded it: the points its rig
    /// triangulates from the pixels (each marker two cameras or more saw), without the pixels or
    /// the rig; poses where no marker was triangulated are left out. A session of points is
    /// returned as it is.
    pub fn as_points(&self) -> Session {
        if self.rig.is_none() {
            return self.clone();
        }
        let mut points = Session { rig: None, ..self.clone() };
        points.poses.iter_mut().for_each(|p| p.pixels.clear());
        points.poses.retain(|p| p.seen() > 0);
        points.streams =
            self.streams.as_ref().map(|s| std::sync::Arc::new(Streams { pixels: Vec::new(), ..(**s).clone() }));
        points
    }

    /// The same pixel session seen through `rig` instead of its file's (a calibration's refined
    /// rig, `calibrate --cameras-out`): its pixels through that rig and the points it
    /// triangulates — what the per-pose estimator, `compare` and the recording then see. A session
    /// of points is returned as it is.
    pub fn seen_through(&self, rig: &Rig) -> Session {
        if self.rig.is_none() {
            return self.clone();
        }
        let mut session = Session { rig: Some(std::sync::Arc::new(rig.clone())), ..self.clone() };
        for pose in &mut session.poses {
            pose.markers.iter_mut().for_each(|m| *m = None);
            for (marker, point, _) in triangulate(rig, &pose.pixels).points {
                pose.markers[marker] = Some(point);
            }
        }
        session
    }
}
