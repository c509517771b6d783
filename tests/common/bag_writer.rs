//! ROS 2 bags for the tests, written without spmcal's own writer: the `mcap` crate and a plain-CDR
//! encoder of this file's own (the OMG layout, either byte order), with the schemas as the ROS 2
//! message definitions give them.

// Each test target uses part of this file.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A plain-CDR encoder (the layout of the OMG spec, alignment from after the 4-byte header).
pub struct Cdr {
    pub bytes: Vec<u8>,
    big: bool,
}

impl Cdr {
    pub fn new(big: bool) -> Self {
        Cdr { bytes: vec![0, if big { 0 } else { 1 }, 0, 0], big }
    }
    pub fn align(&mut self, n: usize) {
        while !(self.bytes.len() - 4).is_multiple_of(n) {
            self.bytes.push(0);
        }
    }
    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.bytes.extend(if self.big { v.to_be_bytes() } else { v.to_le_bytes() });
    }
    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.bytes.extend(if self.big { v.to_be_bytes() } else { v.to_le_bytes() });
    }
    pub fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.bytes.extend(s.as_bytes());
        self.bytes.push(0);
    }
    pub fn header(&mut self, ns: u64, frame: &str) {
        self.u32((ns / 1_000_000_000) as u32);
        self.u32((ns % 1_000_000_000) as u32);
        self.string(frame);
    }
}

pub fn joint_state(ns: u64, names: &[&str], positions: &[f64], big: bool) -> Vec<u8> {
    let mut c = Cdr::new(big);
    c.header(ns, "");
    c.u32(names.len() as u32);
    names.iter().for_each(|n| c.string(n));
    c.u32(positions.len() as u32);
    positions.iter().for_each(|p| c.f64(*p));
    c.u32(0);
    c.u32(0);
    c.bytes
}

pub fn point(ns: u64, frame: &str, p: [f64; 3], big: bool) -> Vec<u8> {
    let mut c = Cdr::new(big);
    c.header(ns, frame);
    p.iter().for_each(|v| c.f64(*v));
    c.bytes
}

const JOINT_STATE_SCHEMA: &str = "# This is a message that holds data to describe the state of a set of torque controlled joints.\n\
std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n\
================================================================================\nMSG: std_msgs/Header\n\
builtin_interfaces/Time stamp\nstring frame_id\n";
const POINT_STAMPED_SCHEMA: &str = "# This represents a Point with reference coordinate frame and timestamp\n\
std_msgs/Header header\nPoint point\n\
================================================================================\nMSG: geometry_msgs/Point\n\
float64 x\nfloat64 y\nfloat64 z\n";

/// A message to write: topic, log time (ns), CDR bytes.
pub type Message = (String, u64, Vec<u8>);

/// A rigid body's pose: position (m) and orientation `[x, y, z, w]` (ROS order).
pub type BodyPose = ([f64; 3], [f64; 4]);

fn pose_fields(c: &mut Cdr, (p, q): BodyPose) {
    p.iter().chain(&q).for_each(|v| c.f64(*v));
}

/// `geometry_msgs/msg/PoseStamped`: header, then `pose` (position x y z, orientation x y z w).
pub fn pose_stamped(ns: u64, frame: &str, pose: BodyPose, big: bool) -> Vec<u8> {
    let mut c = Cdr::new(big);
    c.header(ns, frame);
    pose_fields(&mut c, pose);
    c.bytes
}

fn transform_fields(c: &mut Cdr, ns: u64, parent: &str, child: &str, pose: BodyPose) {
    c.header(ns, parent);
    c.string(child);
    pose_fields(c, pose);
}

/// `geometry_msgs/msg/TransformStamped`: header, `child_frame_id`, then `transform` (translation,
/// rotation: the same seven float64 as a pose).
pub fn transform_stamped(ns: u64, parent: &str, child: &str, pose: BodyPose, big: bool) -> Vec<u8> {
    let mut c = Cdr::new(big);
    transform_fields(&mut c, ns, parent, child, pose);
    c.bytes
}

/// `tf2_msgs/msg/TFMessage`: a sequence (u32 count) of `TransformStamped` (stamp ns, parent, child, pose).
pub fn tf_message(transforms: &[(u64, &str, &str, BodyPose)], big: bool) -> Vec<u8> {
    let mut c = Cdr::new(big);
    c.u32(transforms.len() as u32);
    for &(ns, parent, child, pose) in transforms {
        transform_fields(&mut c, ns, parent, child, pose);
    }
    c.bytes
}

const TIME_DEFINITIONS: &str = "================================================================================\nMSG: builtin_interfaces/Time\n\
int32 sec\nuint32 nanosec\n";
const TRANSFORM_DEFINITIONS: &str = "================================================================================\nMSG: geometry_msgs/Transform\n\
Vector3 translation\nQuaternion rotation\n\
================================================================================\nMSG: geometry_msgs/Vector3\n\
float64 x\nfloat64 y\nfloat64 z\n\
================================================================================\nMSG: geometry_msgs/Quaternion\n\
float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";

/// The message types of the test bags, with their schemas (the `.msg` files' text, comments and
/// all, as `ros2 bag record` copies it).
#[derive(Clone, Copy, PartialEq, Debug)]
pub enum Type {
    JointState,
    PointStamped,
    PoseStamped,
    TransformStamped,
    TfMessage,
}

impl Type {
    pub fn name(self) -> &'static str {
        match self {
            Type::JointState => "sensor_msgs/msg/JointState",
            Type::PointStamped => "geometry_msgs/msg/PointStamped",
            Type::PoseStamped => "geometry_msgs/msg/PoseStamped",
            Type::TransformStamped => "geometry_msgs/msg/TransformStamped",
            Type::TfMessage => "tf2_msgs/msg/TFMessage",
        }
    }

    pub fn schema(self) -> String {
        match self {
            Type::JointState => JOINT_STATE_SCHEMA.to_string(),
            Type::PointStamped => POINT_STAMPED_SCHEMA.to_string(),
            Type::PoseStamped => format!(
                "# A Pose with reference coordinate frame and timestamp\n\nstd_msgs/Header header\nPose pose\n\
                 ================================================================================\nMSG: geometry_msgs/Pose\n\
                 # A representation of pose in free space, composed of position and orientation.\n\n\
                 Point position\nQuaternion orientation\n{TIME_DEFINITIONS}"
            ),
            Type::TransformStamped => format!(
                "# This expresses a transform from coordinate frame header.frame_id\n\
                 # to the coordinate frame child_frame_id at the time of header.stamp\n\n\
                 std_msgs/Header header\n\nstring child_frame_id # the frame id of the child frame\n\
                 Transform transform\n{TRANSFORM_DEFINITIONS}{TIME_DEFINITIONS}"
            ),
            Type::TfMessage => format!(
                "geometry_msgs/TransformStamped[] transforms\n\
                 ================================================================================\nMSG: geometry_msgs/TransformStamped\n\
                 std_msgs/Header header\nstring child_frame_id\nTransform transform\n{TRANSFORM_DEFINITIONS}{TIME_DEFINITIONS}"
            ),
        }
    }

    /// The type of the test bags' topics: joint states on `/joint…`, points on `/markers…`,
    /// transforms on `/tf…`, a `TransformStamped` on `/mocap…`, else a `PoseStamped`.
    pub fn of_topic(topic: &str) -> Type {
        if topic.starts_with("/joint") {
            Type::JointState
        } else if topic.starts_with("/markers") {
            Type::PointStamped
        } else if topic.starts_with("/tf") {
            Type::TfMessage
        } else if topic.starts_with("/mocap") {
            Type::TransformStamped
        } else {
            Type::PoseStamped
        }
    }
}

/// Write `messages` as an MCAP bag at `path`, each topic's type [`Type::of_topic`].
pub fn write_bag(path: &Path, messages: &[Message], encoding: &str) {
    let mut w = mcap::Writer::new(std::io::BufWriter::new(std::fs::File::create(path).unwrap())).unwrap();
    let mut schemas: BTreeMap<&str, u16> = BTreeMap::new();
    let mut channels: BTreeMap<String, u16> = BTreeMap::new();
    for (k, (topic, ns, data)) in messages.iter().enumerate() {
        let id = match channels.get(topic) {
            Some(id) => *id,
            None => {
                let t = Type::of_topic(topic);
                let schema = match schemas.get(t.name()) {
                    Some(id) => *id,
                    None => {
                        let id = w.add_schema(t.name(), "ros2msg", t.schema().as_bytes()).unwrap();
                        schemas.insert(t.name(), id);
                        id
                    }
                };
                let id = w.add_channel(schema, topic, encoding, &BTreeMap::new()).unwrap();
                channels.insert(topic.clone(), id);
                id
            }
        };
        let header =
            mcap::records::MessageHeader { channel_id: id, sequence: k as u32, log_time: *ns, publish_time: *ns };
        w.write_to_known_channel(&header, data).unwrap();
    }
    w.finish().unwrap();
}

pub fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("spmcal-bags-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
