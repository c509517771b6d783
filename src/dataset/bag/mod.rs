//! ROS 2 bags (rosbag2, MCAP storage) as sessions: joint encoders as `sensor_msgs/msg/JointState`,
//! markers as `geometry_msgs/msg/PointStamped` in the camera frame (format in docs/conventions.md; mapping
//! in [`mapping`]). A bag is a free-motion recording, or a static session when the joints rest
//! around every capture; [`write`] makes a bag of a session (the streams exact to the nanosecond;
//! static poses at their own times when 0.2 s apart or more, else 0, 1, 2 … s).

mod body;
mod mapping;
mod messages;
mod read;
mod still;
mod write;

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

pub(crate) use write::write;

use super::session::{Session, SessionPose, Warning};
use super::streams::{Capture, EncoderSample, MIN_FRAMES, StreamLimits, Streams, unplaceable};
use crate::io::files::FileError;
use still::{median, resting};

/// `path` is a bag: an `.mcap` file, or a folder with `metadata.yaml` or `.mcap` files and no
/// `session.yaml`.
pub(crate) fn is_bag(path: &Path) -> bool {
    if path.is_dir() {
        let has_mcap = || {
            std::fs::read_dir(path)
                .map(|d| d.filter_map(Result::ok).any(|e| e.path().extension().is_some_and(|x| x == "mcap")))
                .unwrap_or(false)
        };
        !path.join("session.yaml").exists() && (path.join("metadata.yaml").exists() || has_mcap())
    } else {
        // By its name, or by its first bytes (an MCAP file renamed, or without an extension).
        let magic = || {
            let mut start = [0u8; 8];
            std::fs::File::open(path).and_then(|mut f| std::io::Read::read_exact(&mut f, &mut start)).is_ok()
                && &start == b"\x89MCAP0\r\n"
        };
        path.extension().is_some_and(|x| x == "mcap") || (path.is_file() && magic())
    }
}

/// The model a bag is read with when neither `--model` nor the mapping names one: the command
/// line's default, relative to the working directory.
/// Load the bag at `bag` as a session of the model at `model`, else the mapping's, else the
/// default model (the shipped Agile Wrist); `progress` gets the bytes read so far and the bag's
/// total.
///
/// # Errors
/// A [`FileError`] naming the file, and the topic and message or the mapping key, of the first
/// problem; a bag without a model to read it with.
pub(crate) fn load(
    bag: &Path,
    model: Option<&Path>,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<(Session, Vec<Warning>), FileError> {
    let mapping = mapping::Mapping::beside(bag)?;
    let model = match (model, &mapping.model) {
        (Some(m), _) => m.to_path_buf(),
        (None, Some(_)) if let Some(missing) = &mapping.model_missing => return Err(missing.clone()),
        (None, Some(m)) => m.clone(),
        // The command line's default model.
        (None, None) => PathBuf::from(crate::model::shipped::DEFAULT_MODEL),
    };
    let markers: Vec<String> = crate::model::RobotModel::load(&model)
        .map_err(|e| FileError::new(&model, e.to_string()))?
        .markers
        .iter()
        .map(|m| m.name.clone())
        .collect();
    let files = read::bag_files(bag)?;
    let total: u64 = files.iter().filter_map(|f| std::fs::metadata(f).ok()).map(|m| m.len()).sum();
    let data = read::read_bag(&files, &mapping, &markers, &mut |done| progress(done, total))?;
    let name = bag.file_stem().map_or_else(|| "bag".to_string(), |s| s.to_string_lossy().into_owned());
    let description = Some(format!(
        "ROS 2 bag {}; times in s from {} s after the epoch ({} clock){}",
        bag.display(),
        data.epoch_s.unwrap_or(0),
        match mapping.clock {
            mapping::Clock::Header => "header.stamp",
            mapping::Clock::Receive => "receive",
        },
        mapping.path.as_ref().map_or(String::new(), |p| format!("; mapping {}", p.display()))
    ));
    let session = Session {
        rig: None,
        name,
        description,
        model,
        markers,
        body: None,
        reference_pose: 0,
        poses: Vec::new(),
        truth: None,
        streams: None,
        folder: None,
    };
    // A mapped body is read alone; unmapped, a body on the default topic when there are no markers.
    if mapping.body_mapped || (data.captures.is_empty() && !data.bodies.is_empty()) {
        return body_session(bag, session, data, &mapping);
    }
    let mut captures = data.captures;
    // Topics interleave by receive time: order the captures by their own time (stable).
    captures.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    check_captures(bag, &captures, &session.markers)?;
    match still_poses(&data.encoders, &captures, mapping.still_rad, mapping.min_rest_s) {
        Some(poses) => Ok((static_session(session, poses)?, Vec::new())),
        None => {
            let mut streams = streams(bag, data.encoders, captures)?;
            streams.bag_topics = Some(mapping.marker_topics());
            Ok(Session { streams: Some(std::sync::Arc::new(streams)), ..session }.at_latency(0.0))
        }
    }
}

/// The session of the bag's rigid body: static when the joints rest around every pose of it,
/// else a free-motion recording.
fn body_session(
    bag: &Path,
    session: Session,
    data: read::BagData,
    mapping: &mapping::Mapping,
) -> Result<(Session, Vec<Warning>), FileError> {
    let name = body::name(mapping, data.body_child.as_deref());
    let session = Session { markers: Vec::new(), body: Some(name), ..session };
    body::check_count(bag, &data.bodies, mapping)?;
    let times: Vec<f64> = data.bodies.iter().map(|b| b.time_s).collect();
    match resting(&data.encoders, &times, mapping.still_rad, mapping.min_rest_s) {
        Some((rests, of)) => Ok((body::static_session(bag, session, rests, &of, &data.bodies)?, Vec::new())),
        None => {
            check_encoders(bag, &data.encoders)?;
            body::recording(bag, session, data.encoders, data.bodies, mapping)
        }
    }
}

/// Enough camera frames, and no marker twice in one frame.
fn check_captures(bag: &Path, captures: &[Capture], names: &[String]) -> Result<(), FileError> {
    for frame in captures.chunk_by(|a, b| a.time_s == b.time_s) {
        for (k, c) in frame.iter().enumerate() {
            if frame[..k].iter().any(|d| d.marker == c.marker) {
                let reason = format!(
                    "marker `{}` is captured twice at {} s (message {} on its topic)",
                    names[c.marker], c.time_s, c.line
                );
                return Err(FileError::new(bag, reason));
            }
        }
    }
    let frames = captures.chunk_by(|a, b| a.time_s == b.time_s).count();
    if frames < MIN_FRAMES {
        let reason = format!(
            "holds markers in {frames} camera frame(s) ({} points): a session needs at least {MIN_FRAMES}, and a calibration many more",
            captures.len()
        );
        return Err(FileError::new(bag, reason));
    }
    Ok(())
}

/// A free-motion recording's streams, checked as `encoders.csv` is (the gap limit) and every
/// capture placeable for some latency within the bound.
fn streams(bag: &Path, encoders: Vec<EncoderSample>, captures: Vec<Capture>) -> Result<Streams, FileError> {
    check_encoders(bag, &encoders)?;
    let bound = StreamLimits::default().latency_bound_s;
    if let Some((c, first, last)) = unplaceable(&encoders, &captures, bound) {
        let reason = format!(
            "the marker point at {} s (message {} on its topic) lies outside the joint states ({first} s to {last} s) for every latency within ±{bound} s",
            c.time_s, c.line
        );
        return Err(FileError::new(bag, reason));
    }
    Ok(Streams {
        captures_path: bag.to_path_buf(),
        encoders,
        captures,
        pixels: Vec::new(),
        bag_topics: None,
        bodies: Vec::new(),
    })
}

/// A free-motion recording's joint states, checked as `encoders.csv` is: time increasing across
/// the bag's files, two at least, no gap over the limit.
fn check_encoders(bag: &Path, encoders: &[EncoderSample]) -> Result<(), FileError> {
    let limits = StreamLimits::default();
    // Each file's clock is checked as it is read; a split bag's files must follow each other too.
    if let Some(w) = encoders.windows(2).find(|w| w[1].time_s <= w[0].time_s) {
        let reason = format!(
            "the joint states go back in time from one file of the bag to the next ({} s after {} s)",
            w[1].time_s, w[0].time_s
        );
        return Err(FileError::new(bag, reason));
    }
    if encoders.len() < 2 {
        return Err(FileError::new(bag, format!("{} joint states: a recording needs at least two", encoders.len())));
    }
    if let Some(w) = encoders.windows(2).find(|w| w[1].time_s - w[0].time_s > limits.max_encoder_gap_s) {
        let reason = format!(
            "a gap of {:.4} s in the joint states (from {} s), longer than the limit of {} s",
            w[1].time_s - w[0].time_s,
            w[0].time_s,
            limits.max_encoder_gap_s
        );
        return Err(FileError::new(bag, reason));
    }
    Ok(())
}

/// A static pose read from a bag: its first capture's time, the joints' median over the rest,
/// each marker's captures (indexed like the session's markers).
type RestingPose = (f64, Vector3<f64>, Vec<Vec<Vector3<f64>>>);

/// The poses of a static marker bag ([`resting`]) with each marker's captures, or `None`.
fn still_poses(
    encoders: &[EncoderSample],
    captures: &[Capture],
    still: f64,
    min_rest_s: f64,
) -> Option<Vec<RestingPose>> {
    let times: Vec<f64> = captures.iter().map(|c| c.time_s).collect();
    let (rests, of) = resting(encoders, &times, still, min_rest_s)?;
    let mut poses: Vec<RestingPose> = rests.into_iter().map(|(t, joints)| (t, joints, Vec::new())).collect();
    for (c, &k) in captures.iter().zip(&of) {
        let markers = &mut poses[k].2;
        if markers.len() <= c.marker {
            markers.resize(c.marker + 1, Vec::new());
        }
        markers[c.marker].push(c.position);
    }
    Some(poses)
}

/// The static session of `poses` (time, joints, each marker's captures), numbered from 0, checked
/// and given its reference pose as a session from memory is ([`Session::from_poses`]).
fn static_session(session: Session, poses: Vec<RestingPose>) -> Result<Session, FileError> {
    let count = session.markers.len();
    let poses: Vec<SessionPose> = poses
        .into_iter()
        .enumerate()
        .map(|(id, (time_s, joints, seen))| {
            let markers = (0..count)
                .map(|k| {
                    seen.get(k)
                        .filter(|v| !v.is_empty())
                        .map(|v| Vector3::from_fn(|i, _| median(v.iter().map(|p| p[i]).collect())))
                })
                .collect();
            SessionPose {
                pixels: Vec::new(),
                id: id as u64,
                joints,
                time_s: Some(time_s),
                markers,
                line: 0,
                marker_lines: vec![0; count],
                station: None,
                body: None,
            }
        })
        .collect();
    let made = Session::from_poses(&session.name, &session.model, session.markers, poses)?;
    Ok(Session { description: session.description, ..made })
}
