//! A session folder: `session.yaml`, `joints.csv`, `markers.csv` (a free-motion recording has
//! `encoders.csv` and `captures.csv` instead of the two CSV files), and for simulated sessions
//! `truth.yaml` (the true parameters) and `truth_orientations.csv` (the true MP orientations).
//!
//! What is an error (loading stops, naming file, line and column): malformed YAML or CSV, an
//! unknown key in `session.yaml`, fewer than 3 or repeated marker names, no model, non-numbers
//! and NaN/inf, a repeated pose or (pose, marker) pair, an unknown marker name, marker rows for a
//! pose that `joints.csv` does not have, an empty session, a reference pose that is not in
//! `joints.csv`, an empty station or one whose captures are not one pose (`joints.csv`), a
//! recording with captures in fewer than 3 camera frames, files of both kinds in one folder
//! (which session is meant cannot be told), and more marker slots (listed markers × poses) than
//! memory should hold. Every check is linear in the names and rows (hash look-ups, no searches).
//!
//! A pose with fewer than 3 markers seen (none at all included) is data like any other: the
//! marker-level fit uses each observation, and only the per-pose vision estimator skips it (and
//! says so). The warnings a load returns are a free-motion recording's: camera frames that fall
//! outside the encoder stream, left out.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};

use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use super::joints::{JointReading, StationSpans, read_joints, write_joints};
use super::markers::{MarkerRow, read_markers, write_markers};
use super::orientations::{OrientationRecord, read_orientations, write_orientations};
use super::streams::{StreamLimits, Streams, captures_csv, encoders_csv};
use crate::io::files::{FileError, in_parallel, relative_path, write_atomic};
use crate::math::constellation::{self, MARKER_NOISE_M};
use crate::model::{CameraModel, Parameters};

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
    /// Line of `markers.csv` of each seen marker (0 when unseen or not read from a file).
    pub marker_lines: Vec<usize>,
    /// The station (captures the operator meant as one pose), when recorded.
    pub station: Option<u64>,
    /// What each camera of the session's rig saw at this pose, pixel by pixel (empty for a
    /// session of points); `markers` then holds the points the rig triangulates from them.
    pub pixels: Vec<SeenPixel>,
}

/// A marker seen by one camera of a rig (`pixels.csv`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeenPixel {
    /// Marker index (as in the session's `markers`).
    pub marker: usize,
    /// Camera index (as in the rig's `cameras`).
    pub camera: usize,
    /// `(u, v)` (px).
    pub pixel: nalgebra::Vector2<f64>,
    /// Line of `pixels.csv` (0 when not read from a file).
    pub line: usize,
}

impl SessionPose {
    /// How many markers the camera saw.
    pub fn seen(&self) -> usize {
        self.markers.iter().filter(|m| m.is_some()).count()
    }
}

/// The ground truth of a simulated session.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// The true parameters (with the true camera registration).
    pub parameters: Parameters,
    /// True MP orientation of each pose (P → B).
    pub orientations: BTreeMap<u64, Rotation3<f64>>,
}

/// A joint-plus-vision session.
#[derive(Debug, Clone, PartialEq)]
pub struct Session {
    /// Session name (`session.yaml`).
    pub name: String,
    /// Free-text description.
    pub description: Option<String>,
    /// The model (URDF), resolved against the session folder or taken from `--model`.
    pub model: PathBuf,
    /// Marker names, in the order of `SessionPose::markers`.
    pub markers: Vec<String>,
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
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: pose {}: {}", self.path.display(), self.line, self.pose, self.message)
    }
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SessionFile {
    name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    model: Option<PathBuf>,
    markers: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    reference_pose: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    description: Option<String>,
}

impl Session {
    /// The reference pose.
    ///
    /// # Panics
    /// If `reference_pose` is not one of the poses (never for a session from [`Session::load`] or the simulator).
    pub fn reference(&self) -> &SessionPose {
        self.poses.iter().find(|p| p.id == self.reference_pose).expect("validated on load")
    }

    /// The session with the captures of each station merged into one pose, as the per-pose
    /// estimator needs (one marker at a time gives no pose with three): the station's first
    /// capture's id, reading and time, and every marker it saw (the first sighting of each).
    /// Poses without a station stay as they are. The motion between captures is then blamed on
    /// the mechanism — the reason the marker-level fit uses every capture's own reading.
    pub fn by_station(&self) -> Session {
        let mut poses: Vec<SessionPose> = Vec::new();
        let mut at: HashMap<u64, usize> = HashMap::new();
        for pose in &self.poses {
            let merged = pose.station.and_then(|s| at.get(&s)).map(|&k| &mut poses[k]);
            match merged {
                Some(into) => {
                    for (k, m) in pose.markers.iter().enumerate() {
                        if into.markers[k].is_none() && m.is_some() {
                            into.markers[k] = *m;
                            into.marker_lines[k] = pose.marker_lines[k];
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
        let reference_pose = poses.iter().find(|p| p.seen() >= MIN_MARKERS).unwrap_or(&poses[0]).id;
        let truth = self.truth.as_ref().map(|t| Truth {
            parameters: t.parameters.clone(),
            orientations: poses.iter().filter_map(|p| t.orientations.get(&p.id).map(|r| (p.id, *r))).collect(),
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
        check_marker_names(&file.markers).map_err(|(key, reason)| at(&key, reason))?;
        let model = match (model, &file.model) {
            (Some(m), _) => m.to_path_buf(),
            (None, Some(m)) => dir.join(m),
            (None, None) => return Err(at("model", "no `model` given here and no --model on the command line".into())),
        };
        let joints_path = dir.join("joints.csv");
        if session_kind(dir)? == Kind::Recording {
            let streams = Streams::read(dir, &file.markers, &StreamLimits::default())?;
            let frames = streams.captures.chunk_by(|a, b| a.time_s == b.time_s).count();
            check_slots(file.markers.len(), frames, "camera frames in captures.csv").map_err(|r| at("markers", r))?;
            let session = Session {
                rig: None,
                name: file.name,
                description: file.description,
                model,
                markers: file.markers,
                reference_pose: 0,
                poses: Vec::new(),
                truth: read_truth(dir)?,
                streams: Some(std::sync::Arc::new(streams)),
                folder: Some(dir.to_path_buf()),
            };
            return Ok(session.at_latency(0.0));
        }
        let markers_path = dir.join("markers.csv");
        // The files are independent: the biggest is read on a second core.
        let ((readings, truth), rows) =
            in_parallel(|| (read_joints(&joints_path), read_truth(dir)), || read_markers(&markers_path, &file.markers));
        let readings = readings?;
        if readings.is_empty() {
            return Err(FileError::new(&joints_path, "empty session: no poses"));
        }
        check_slots(file.markers.len(), readings.len(), "poses in joints.csv").map_err(|r| at("markers", r))?;
        let rows = rows?;
        let poses = assemble_poses(&readings, &rows, file.markers.len(), &markers_path)?;
        let mut warnings = Vec::new();
        check_station_markers(&poses, &file.markers, &markers_path, &mut warnings)?;
        warnings.extend(beyond_a_turn(&poses, &joints_path));
        // The per-pose estimator measures from the reference pose; the marker-level fit needs none.
        // Default: the first pose whose markers fix an orientation, else the first that sees
        // enough markers for the estimator, else the first.
        let reference_pose = file.reference_pose.unwrap_or_else(|| default_reference(&poses));
        if !poses.iter().any(|p| p.id == reference_pose) {
            return Err(at("reference_pose", format!("reference pose {reference_pose} is not in joints.csv")));
        }
        let truth = truth?;
        let session = Session {
            rig: None,
            name: file.name,
            description: file.description,
            model,
            markers: file.markers,
            reference_pose,
            poses,
            truth,
            streams: None,
            folder: Some(dir.to_path_buf()),
        };
        Ok((session, warnings))
    }

    /// A static session from poses already in memory (named `name`, read with the URDF `model`),
    /// checked as a session folder is: the marker names, one marker slot per name in every pose,
    /// distinct pose ids, finite joints; the reference pose the first that sees three markers.
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
            if p.markers.len() != markers.len() {
                let reason =
                    format!("pose {}: {} marker slots for {} marker names", p.id, p.markers.len(), markers.len());
                return Err(at(row, reason));
            }
        }
        let reference_pose = poses.iter().find(|p| p.seen() >= MIN_MARKERS).unwrap_or(&poses[0]).id;
        Ok(Session {
            rig: None,
            name: name.to_string(),
            description: None,
            model: model.to_path_buf(),
            markers,
            reference_pose,
            poses,
            truth: None,
            streams: None,
            folder: None,
        })
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
    /// (the captures sharing a time stamp), numbered in order, its joints interpolated in the
    /// encoder stream at the frame's time less the latency. Frames that fall outside the encoder
    /// stream at that latency are left out, each with a warning naming its `captures.csv` line.
    /// A session without streams is returned as it is.
    pub fn at_latency(&self, latency_s: f64) -> (Session, Vec<Warning>) {
        self.at_latency_within(latency_s, (latency_s, latency_s))
    }

    /// As [`Session::at_latency`], keeping only the frames that lie inside the encoder stream for
    /// every latency in `range` (`lo ≤ latency_s ≤ hi`): a fit that estimates the latency within
    /// those bounds then works on the same frames whatever value it tries.
    pub fn at_latency_within(&self, latency_s: f64, (lo, hi): (f64, f64)) -> (Session, Vec<Warning>) {
        let Some(streams) = &self.streams else { return (self.clone(), Vec::new()) };
        let m = self.markers.len();
        let (mut poses, mut warnings): (Vec<SessionPose>, Vec<Warning>) = (Vec::new(), Vec::new());
        for frame in streams.captures.chunk_by(|a, b| a.time_s == b.time_s) {
            let time = frame[0].time_s;
            let inside = streams.joints_at(time - lo).and(streams.joints_at(time - hi));
            let Some(joints) = inside.and(streams.joints_at(time - latency_s)) else {
                let at = if lo == hi {
                    format!("at a latency of {lo} s")
                } else {
                    format!("for a latency in [{lo}, {hi}] s")
                };
                warnings.push(Warning {
                    path: streams.captures_path.clone(),
                    line: frame[0].line,
                    pose: poses.len() as u64,
                    message: format!("the frame at {time} s falls outside the encoder stream {at}: left out"),
                });
                continue;
            };
            let mut pose = SessionPose {
                pixels: Vec::new(),
                id: poses.len() as u64,
                joints,
                time_s: Some(time),
                markers: vec![None; m],
                line: frame[0].line,
                marker_lines: vec![0; m],
                station: None,
            };
            for c in frame {
                pose.markers[c.marker] = Some(c.position);
                pose.marker_lines[c.marker] = c.line;
            }
            poses.push(pose);
        }
        let reference_pose = poses.iter().find(|p| p.seen() >= MIN_MARKERS).or(poses.first()).map_or(0, |p| p.id);
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
    /// `session.yaml` last, so a folder without it is an interrupted write, never a session.
    ///
    /// # Errors
    /// A [`FileError`] when `dir` holds something that is not a session or a file cannot be written.
    ///
    /// # Panics
    /// Never in practice: serialising the session's YAML cannot fail.
    pub fn write(&self, dir: &Path) -> Result<(), FileError> {
        Session::check_destination(dir)?;
        if self.streams.is_none() {
            check_stations(&self.poses, &dir.join("joints.csv"))?;
        }
        std::fs::create_dir_all(dir).map_err(|e| FileError::new(dir, format!("cannot create the folder: {e}")))?;
        if let Some(streams) = &self.streams {
            // A free-motion recording is its streams; its poses are derived from them on loading.
            write_atomic(&dir.join("encoders.csv"), encoders_csv(&streams.encoders).as_bytes())?;
            write_atomic(&dir.join("captures.csv"), captures_csv(&streams.captures, &self.markers).as_bytes())?;
            if let Some(truth) = &self.truth {
                truth.parameters.write(&dir.join("truth.yaml"))?;
            }
            let file = SessionFile {
                name: self.name.clone(),
                model: Some(relative_path(dir, &self.model)?),
                markers: self.markers.clone(),
                reference_pose: None,
                description: self.description.clone(),
            };
            // A session replaced here leaves no file of the other kind (or a truth it lacks).
            let stale = if self.truth.is_some() {
                &["truth_orientations.csv"][..]
            } else {
                &["truth.yaml", "truth_orientations.csv"]
            };
            remove_stale(dir, STATIC_FILES.iter().chain(stale))?;
            let yaml = serde_yaml::to_string(&file).expect("session serialises");
            return write_atomic(&dir.join("session.yaml"), yaml.as_bytes());
        }
        let readings: Vec<_> = self
            .poses
            .iter()
            .map(|p| JointReading { pose: p.id, line: 0, joints: p.joints, time_s: p.time_s, station: p.station })
            .collect();
        write_joints(&dir.join("joints.csv"), &readings)?;
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
        if let Some(truth) = &self.truth {
            truth.parameters.write(&dir.join("truth.yaml"))?;
            let records: Vec<_> = truth
                .orientations
                .iter()
                .map(|(&pose, &rotation)| OrientationRecord { pose, mode: None, rotation, extra: vec![], line: 0 })
                .collect();
            write_atomic(&dir.join("truth_orientations.csv"), write_orientations(&records).as_bytes())?;
        }
        let file = SessionFile {
            name: self.name.clone(),
            model: Some(relative_path(dir, &self.model)?),
            markers: self.markers.clone(),
            reference_pose: Some(self.reference_pose),
            description: self.description.clone(),
        };
        let stale = if self.truth.is_some() { &[][..] } else { &["truth.yaml", "truth_orientations.csv"] };
        remove_stale(dir, RECORDING_FILES.iter().chain(stale))?;
        let yaml = serde_yaml::to_string(&file).expect("session serialises");
        write_atomic(&dir.join("session.yaml"), yaml.as_bytes())
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

/// The first reading more than a turn from zero, as a warning: a joint of an SPM seldom turns that
/// far, and a reading of 18 in a `_rad` column is most often 18 degrees (the fit would then see
/// poses near singularities, not a unit mistake).
fn beyond_a_turn(poses: &[SessionPose], joints_path: &Path) -> Option<Warning> {
    let pose = poses.iter().find(|p| p.joints.amax() > std::f64::consts::TAU)?;
    let largest = poses.iter().map(|p| p.joints.amax()).fold(0.0, f64::max);
    Some(Warning {
        path: joints_path.to_path_buf(),
        line: pose.line,
        pose: pose.id,
        message: format!(
            "a joint reads {:.3} rad, more than a turn (the largest reading is {largest:.3}): are the readings in \
             degrees? The `theta*_rad` columns are radians",
            pose.joints.amax()
        ),
    })
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
            "station {station} captures marker `{}` twice (markers.csv lines {} and {}, poses {} and {})",
            names[twice], first.1, second.1, poses[first.0].id, poses[second.0].id
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
        });
    }
    Ok(())
}

/// Remove the `files` of an earlier session in `dir` that the session written there does not
/// have (a recording written over a static session, or the reverse), so that the folder holds
/// one session, not two that disagree.
fn remove_stale<'a>(dir: &Path, files: impl Iterator<Item = &'a &'a str>) -> Result<(), FileError> {
    for name in files {
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

/// What a session folder holds: a static (or sequential) session or a free-motion recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// `joints.csv` and `markers.csv`.
    Static,
    /// `encoders.csv` and `captures.csv`.
    Recording,
}

const STATIC_FILES: [&str; 2] = ["joints.csv", "markers.csv"];
const RECORDING_FILES: [&str; 2] = ["encoders.csv", "captures.csv"];

/// Which kind of session `dir` holds; a folder with files of both kinds is an error naming them
/// (which pair is meant cannot be told). A folder with neither is read as a static session (whose
/// reader then names the missing `joints.csv`).
fn session_kind(dir: &Path) -> Result<Kind, FileError> {
    let present = |files: [&'static str; 2]| -> Vec<&'static str> {
        files.into_iter().filter(|f| dir.join(f).exists()).collect()
    };
    let (statics, streams) = (present(STATIC_FILES), present(RECORDING_FILES));
    match (statics.is_empty(), streams.is_empty()) {
        (false, false) => Err(FileError::new(
            dir,
            format!(
                "holds files of a static session ({}) and of a free-motion recording ({}): a session folder holds one pair, joints.csv and markers.csv or encoders.csv and captures.csv, and which one is meant here cannot be told; move the other out",
                statics.join(", "),
                streams.join(", ")
            ),
        )),
        (true, false) => Ok(Kind::Recording),
        _ => Ok(Kind::Static),
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
    Ok(Some(Truth { parameters, orientations }))
}
