//! A session as a ROS 2 bag (one `.mcap` file, zstd-compressed chunks): joint states on
//! `/joint_states` (`theta1..3`, rad), marker points on `/markers` with `header.frame_id` the
//! marker's name, or a rigid body's poses on `/body` as `geometry_msgs/msg/TransformStamped` from
//! `world` to the body's name (a `TransformStamped`, not a `PoseStamped`, so that the name travels)
//! — the defaults [`super::load`] reads without a mapping file. A free-motion recording's streams
//! go as they are; a static session's pose becomes the joints resting for 0.1 s (eleven states,
//! 10 ms apart) with its markers or body at the first of them.

use std::collections::BTreeMap;
use std::path::Path;

use super::messages::{
    Header, JOINT_STATE, JointState, POINT_STAMPED, Point, PointStamped, Quaternion, TRANSFORM_STAMPED, Time,
    Transform, TransformStamped, encode,
};
use crate::dataset::BodyPose;
use crate::dataset::Session;
use crate::io::files::{FileError, StagedFile};

/// One message to write: its stamp (ns since the epoch), channel, CDR bytes.
type Message = (u64, u16, Vec<u8>);

/// Write `session` as an MCAP bag at `path` (atomically).
///
/// # Errors
/// A [`FileError`] when a time falls outside what a ROS stamp holds (negative, or beyond 2038), or
/// the file cannot be written.
pub(crate) fn write(session: &Session, path: &Path) -> Result<(), FileError> {
    let messages = messages(session).map_err(|reason| FileError::new(path, reason))?;
    let staged = StagedFile::create(path)?;
    let fail = |e: mcap::McapError| FileError::new(path, format!("cannot write the bag: {e}"));
    {
        let file = std::fs::File::create(staged.temp_path())
            .map_err(|e| FileError::new(path, format!("cannot write: {e}")))?;
        let mut writer =
            mcap::WriteOptions::new().profile("ros2").create(std::io::BufWriter::new(file)).map_err(fail)?;
        let joints = writer.add_schema(JOINT_STATE.name, "ros2msg", JOINT_STATE.schema.as_bytes()).map_err(fail)?;
        let (observed, topic) = match session.body {
            None => (&POINT_STAMPED, "/markers"),
            Some(_) => (&TRANSFORM_STAMPED, super::mapping::DEFAULT_BODY_TOPIC),
        };
        let observations = writer.add_schema(observed.name, "ros2msg", observed.schema.as_bytes()).map_err(fail)?;
        let none = BTreeMap::new();
        let channels = [
            writer.add_channel(joints, "/joint_states", "cdr", &none).map_err(fail)?,
            writer.add_channel(observations, topic, "cdr", &none).map_err(fail)?,
        ];
        let mut sequence = [0u32; 2];
        for &(ns, channel, ref data) in &messages {
            let k = channel as usize;
            sequence[k] += 1;
            let header = mcap::records::MessageHeader {
                channel_id: channels[k],
                sequence: sequence[k],
                log_time: ns,
                publish_time: ns,
            };
            writer.write_to_known_channel(&header, data).map_err(fail)?;
        }
        writer.finish().map_err(fail)?;
    }
    staged.commit()
}

/// Every message of the session, in time order (joint states first at equal times).
fn messages(session: &Session) -> Result<Vec<Message>, String> {
    let stamp = |t: f64| {
        Time::of_seconds(t).ok_or_else(|| format!("time {t} s cannot be a ROS stamp (0 to 2^31 s after the epoch)"))
    };
    let joint_state = |t: f64, joints: &nalgebra::Vector3<f64>| -> Result<Message, String> {
        let m = JointState {
            header: Header { stamp: stamp(t)?, frame_id: "" },
            name: vec!["theta1", "theta2", "theta3"],
            position: joints.iter().copied().collect(),
            velocity: Vec::new(),
            effort: Vec::new(),
        };
        Ok((m.header.stamp.nanoseconds(), 0, encode(&m)))
    };
    let point = |t: f64, marker: usize, p: &nalgebra::Vector3<f64>| -> Result<Message, String> {
        let m = PointStamped {
            header: Header { stamp: stamp(t)?, frame_id: &session.markers[marker] },
            point: Point { x: p.x, y: p.y, z: p.z },
        };
        Ok((m.header.stamp.nanoseconds(), 1, encode(&m)))
    };
    let body_name = session.body.as_deref().unwrap_or_default();
    let body = |t: f64, pose: &BodyPose| -> Result<Message, String> {
        // Matrix → quaternion → matrix is exact to a few ulps, not to the bit.
        let [w, x, y, z] = crate::math::so3::to_wxyz(&pose.rotation);
        let p = pose.position;
        let m = TransformStamped {
            header: Header { stamp: stamp(t)?, frame_id: "world" },
            child_frame_id: body_name,
            transform: Transform { translation: Point { x: p.x, y: p.y, z: p.z }, rotation: Quaternion { x, y, z, w } },
        };
        Ok((m.header.stamp.nanoseconds(), 1, encode(&m)))
    };
    let mut out = Vec::new();
    match &session.streams {
        Some(streams) => {
            for s in &streams.encoders {
                out.push(joint_state(s.time_s, &s.joints)?);
            }
            same_nanosecond(&out, "encoder samples")?;
            let cameras = out.len();
            for c in &streams.captures {
                out.push(point(c.time_s, c.marker, &c.position)?);
            }
            for (t, pose) in streams.body_poses() {
                out.push(body(t, pose)?);
            }
            // A body's recording has no marker captures: its messages from `cameras` on are its poses.
            if session.body.is_some() {
                same_nanosecond(&out[cameras..], "body poses")?;
            }
        }
        None => {
            // The poses' own times when they leave room for the rest (0.1 s) and a gap after it.
            let times: Vec<Option<f64>> = session.poses.iter().map(|p| p.time_s).collect();
            let spaced = times.windows(2).all(|w| matches!(w, [Some(a), Some(b)] if b - a >= 0.2))
                && times.first().is_some_and(Option::is_some);
            for (k, pose) in session.poses.iter().enumerate() {
                let t = if spaced { pose.time_s.unwrap_or_default() } else { k as f64 };
                for step in 0..=10 {
                    out.push(joint_state(t + 0.01 * f64::from(step), &pose.joints)?);
                }
                for (marker, p) in pose.markers.iter().enumerate() {
                    if let Some(p) = p {
                        out.push(point(t, marker, p)?);
                    }
                }
                if let Some(b) = &pose.body {
                    out.push(body(t, b)?);
                }
            }
        }
    }
    out.sort_by_key(|&(ns, channel, _)| (ns, channel));
    Ok(out)
}

/// Refuse `messages` of one stream (in time order) of which two share a stamp: a ROS stamp holds
/// whole nanoseconds, and the reader wants this stream's times to increase, as the session's
/// files did — two times less than 1 ns apart would write a bag that does not read back.
fn same_nanosecond(messages: &[Message], what: &str) -> Result<(), String> {
    match messages.windows(2).position(|w| w[0].0 >= w[1].0) {
        Some(k) => Err(format!(
            "{what} {} and {} (in time order) fall on the same nanosecond ({} ns after the epoch): a ROS stamp holds whole nanoseconds, so the bag would not read back; space them 1 ns or more apart",
            k + 1,
            k + 2,
            messages[k].0
        )),
        None => Ok(()),
    }
}
