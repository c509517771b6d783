//! A bag's rigid body as a session, through the constructors a `poses.csv` session is made with:
//! a static session ([`Session::of_body`]) when the joints rest around every pose of the body, else
//! a free-motion recording ([`Streams::of_body`]). The body is named by its frame (the mapping's
//! `child_frame`, else a `TransformStamped`'s `child_frame_id`), else by its topic
//! (`/vrpn_mocap/wrist/pose` → `wrist`).

use std::path::Path;

use nalgebra::Vector3;

use super::mapping::{BodySource, Mapping};
use super::still::{RestingJoints, median};
use crate::dataset::streams::{MIN_FRAMES, Streams};
use crate::dataset::{BodyCapture, BodyPose, Session, SessionPose, Warning};
use crate::io::files::FileError;
use crate::math::so3;

/// Enough poses of the body for a session.
///
/// # Errors
/// A [`FileError`] on the bag naming the body and how many poses it has.
pub(super) fn check_count(bag: &Path, bodies: &[BodyCapture], mapping: &Mapping) -> Result<(), FileError> {
    if bodies.len() >= MIN_FRAMES {
        return Ok(());
    }
    let reason = format!(
        "holds the body ({}) at {} time(s): a session needs at least {MIN_FRAMES}, and a calibration many more",
        mapping.body.describe(),
        bodies.len()
    );
    Err(FileError::new(bag, reason))
}

/// The static session of the body resting at `rests` (each rest's time and joints; `of`: the rest
/// of each body pose), checked as a `poses.csv` session is; `session` holds the bag's name,
/// description, model and body.
///
/// # Errors
/// A [`FileError`] from [`Session::of_body`], or on the bag when a rest's poses have no mean.
pub(super) fn static_session(
    bag: &Path,
    session: Session,
    rests: Vec<RestingJoints>,
    of: &[usize],
    bodies: &[BodyCapture],
) -> Result<Session, FileError> {
    let mut seen: Vec<Vec<BodyPose>> = vec![Vec::new(); rests.len()];
    for (b, &k) in bodies.iter().zip(of) {
        seen[k].push(b.pose);
    }
    let mut poses = Vec::with_capacity(rests.len());
    for (id, ((time_s, joints), seen)) in rests.into_iter().zip(seen).enumerate() {
        let body = resting_pose(&seen).map_err(|reason| FileError::new(bag, reason))?;
        poses.push(SessionPose {
            pixels: Vec::new(),
            id: id as u64,
            joints,
            time_s: Some(time_s),
            markers: Vec::new(),
            line: 0,
            marker_lines: Vec::new(),
            station: None,
            body: Some(body),
        });
    }
    let body = session.body.clone().unwrap_or_default();
    let made = Session::of_body(&session.name, &session.model, &body, poses)?;
    Ok(Session { description: session.description, ..made })
}

/// The free-motion recording of the body (`encoders` checked already), every pose placeable
/// within the latency bound.
///
/// # Errors
/// A [`FileError`] on the bag naming the body's topic and message of a pose outside the joint
/// states, or from [`Streams::of_body`].
pub(super) fn recording(
    bag: &Path,
    session: Session,
    encoders: Vec<crate::dataset::EncoderSample>,
    bodies: Vec<BodyCapture>,
    mapping: &Mapping,
) -> Result<(Session, Vec<Warning>), FileError> {
    let bound = crate::dataset::streams::StreamLimits::default().latency_bound_s;
    let (first, last) = (encoders[0].time_s, encoders[encoders.len() - 1].time_s);
    if let Some(b) = bodies.iter().find(|b| b.time_s + bound < first || b.time_s - bound > last) {
        let reason = format!(
            "the body's pose at {} s ({}, message {}) lies outside the joint states ({first} s to {last} s) for every latency within ±{bound} s",
            b.time_s,
            mapping.body.describe(),
            b.pose.line
        );
        return Err(FileError::new(bag, reason));
    }
    let mut streams = Streams::of_body(bag.to_path_buf(), encoders, bodies, bound)?;
    streams.bag_topics = Some(format!("body topic `{}`", mapping.body.topic()));
    Ok(Session { streams: Some(std::sync::Arc::new(streams)), ..session }.at_latency(0.0))
}

/// The body's name: its frame when the mapping or a `TransformStamped` gives it, else its topic's
/// last name other than `pose` (`/vrpn_mocap/wrist/pose` → `wrist`, `/body` → `body`).
pub(super) fn name(mapping: &Mapping, child_frame_id: Option<&str>) -> String {
    match &mapping.body.source {
        BodySource::Tf { child_frame, .. } | BodySource::Topic { child_frame: Some(child_frame), .. } => {
            child_frame.clone()
        }
        BodySource::Topic { topic, child_frame: None } => match child_frame_id.filter(|c| !c.trim().is_empty()) {
            Some(child) => child.to_string(),
            None => {
                let mut names = topic.split('/').filter(|n| !n.is_empty() && *n != "pose");
                names.next_back().unwrap_or("body").to_string()
            }
        },
    }
}

/// The body's pose over a rest: its one pose as read (exact), else the median position and the
/// component median of the quaternions (signs aligned with the first's), normalised — made by
/// [`BodyPose::new`] as every body pose is.
fn resting_pose(seen: &[BodyPose]) -> Result<BodyPose, String> {
    if let [one] = seen {
        return Ok(*one);
    }
    let position = Vector3::from_fn(|i, _| median(seen.iter().map(|p| p.position[i]).collect()));
    let first = so3::to_wxyz(&seen[0].rotation);
    let aligned: Vec<[f64; 4]> = seen
        .iter()
        .map(|p| {
            let q = so3::to_wxyz(&p.rotation);
            let same = q.iter().zip(&first).map(|(a, b)| a * b).sum::<f64>() >= 0.0;
            if same { q } else { q.map(|v| -v) }
        })
        .collect();
    let q: [f64; 4] = std::array::from_fn(|i| median(aligned.iter().map(|a| a[i]).collect()));
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let line = seen[0].line;
    BodyPose::new(position, q.map(|v| v / norm), line)
        .map_err(|(_, reason)| format!("the body's poses resting from message {line} on have no median pose: {reason}"))
}
