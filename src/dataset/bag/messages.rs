//! The ROS 2 message types a bag holds for spmcal — joint states, marker points, a rigid body's
//! pose (`PoseStamped`, `TransformStamped`, or one transform of a `tf2_msgs/msg/TFMessage`) — as
//! serde structs decoded from (and encoded to) CDR by `re_cdr`, and the schemas they are checked
//! against. Field order and types are the ROS 2 definitions' (`common_interfaces`, `geometry2`);
//! CDR aligns each primitive to its size, nested structs adding no padding of their own.
//!
//! A CDR message starts with a 4-byte encapsulation header: the representation identifier
//! (`00 00` plain CDR big-endian, `00 01` little-endian — what ROS 2 writes) and two option bytes;
//! alignment counts from after it. XCDR2 (`00 06`/`00 07`, 8-byte values aligned to 4) is refused,
//! not misread.

use re_cdr::{BigEndian, LittleEndian};
use serde::{Deserialize, Serialize};

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct Time {
    pub(crate) sec: i32,
    pub(crate) nanosec: u32,
}

impl Time {
    /// The time `seconds` after the epoch, to the nanosecond; `None` outside `int32` seconds.
    pub(crate) fn of_seconds(seconds: f64) -> Option<Time> {
        let ns = (seconds * 1e9).round();
        if !ns.is_finite() || ns < 0.0 || ns >= f64::from(i32::MAX) * 1e9 {
            return None;
        }
        let ns = ns as u64;
        Some(Time { sec: (ns / 1_000_000_000) as i32, nanosec: (ns % 1_000_000_000) as u32 })
    }

    /// Nanoseconds since the epoch (an MCAP log time).
    pub(crate) fn nanoseconds(self) -> u64 {
        self.sec.max(0) as u64 * 1_000_000_000 + u64::from(self.nanosec)
    }
}

/// `std_msgs/msg/Header` (strings borrowed from the message: an hour's 3.6 million joint states
/// decode without allocating them).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Header<'a> {
    pub(crate) stamp: Time,
    pub(crate) frame_id: &'a str,
}

/// `sensor_msgs/msg/JointState`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct JointState<'a> {
    #[serde(borrow)]
    pub(crate) header: Header<'a>,
    #[serde(borrow)]
    pub(crate) name: Vec<&'a str>,
    pub(crate) position: Vec<f64>,
    pub(crate) velocity: Vec<f64>,
    pub(crate) effort: Vec<f64>,
}

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct Point {
    pub(crate) x: f64,
    pub(crate) y: f64,
    pub(crate) z: f64,
}

/// `geometry_msgs/msg/PointStamped`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct PointStamped<'a> {
    #[serde(borrow)]
    pub(crate) header: Header<'a>,
    pub(crate) point: Point,
}

/// `geometry_msgs/msg/Quaternion` (ROS order: the scalar last).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct Quaternion {
    pub(crate) x: f64,
    pub(crate) y: f64,
    pub(crate) z: f64,
    pub(crate) w: f64,
}

/// `geometry_msgs/msg/Pose`: the body's frame in the header's (position m, orientation body →
/// header frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct Pose {
    pub(crate) position: Point,
    pub(crate) orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseStamped` (vrpn_mocap, the OptiTrack and Vicon bridges).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct PoseStamped<'a> {
    #[serde(borrow)]
    pub(crate) header: Header<'a>,
    pub(crate) pose: Pose,
}

/// `geometry_msgs/msg/Transform`: `child_frame_id`'s frame in the header's; `translation` is a
/// `geometry_msgs/msg/Vector3`, three float64 `x y z` laid out as a [`Point`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct Transform {
    pub(crate) translation: Point,
    pub(crate) rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct TransformStamped<'a> {
    #[serde(borrow)]
    pub(crate) header: Header<'a>,
    pub(crate) child_frame_id: &'a str,
    pub(crate) transform: Transform,
}

/// `tf2_msgs/msg/TFMessage`: what `/tf` and `/tf_static` carry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct TfMessage<'a> {
    #[serde(borrow)]
    pub(crate) transforms: Vec<TransformStamped<'a>>,
}

/// A message type spmcal reads: its ROS name and the `ros2msg` schema a bag records for it.
pub(crate) struct MessageType {
    /// e.g. `sensor_msgs/msg/JointState`.
    pub(crate) name: &'static str,
    /// The top-level field declarations (type and name) the schema must hold, in order.
    pub(crate) fields: &'static [&'static str],
    /// The full `ros2msg` schema, as `ros2 bag record` writes it.
    pub(crate) schema: &'static str,
}

/// The definitions a `ros2msg` schema appends for the header (as `ros2 bag record` writes them).
macro_rules! header_definitions {
    () => {
        "================================================================================\n\
         MSG: std_msgs/Header\n\
         builtin_interfaces/Time stamp\n\
         string frame_id\n\
         ================================================================================\n\
         MSG: builtin_interfaces/Time\n\
         int32 sec\n\
         uint32 nanosec\n"
    };
}

/// `sensor_msgs/msg/JointState`.
pub(crate) const JOINT_STATE: MessageType = MessageType {
    name: "sensor_msgs/msg/JointState",
    fields: &[
        "std_msgs/Header header",
        "string[] name",
        "float64[] position",
        "float64[] velocity",
        "float64[] effort",
    ],
    schema: concat!(
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
        header_definitions!()
    ),
};

/// `geometry_msgs/msg/PointStamped`.
pub(crate) const POINT_STAMPED: MessageType = MessageType {
    name: "geometry_msgs/msg/PointStamped",
    fields: &["std_msgs/Header header", "Point point"],
    schema: concat!(
        "std_msgs/Header header\nPoint point\n",
        "================================================================================\n\
         MSG: geometry_msgs/Point\n\
         float64 x\n\
         float64 y\n\
         float64 z\n",
        header_definitions!()
    ),
};

/// The definitions a `ros2msg` schema appends for `geometry_msgs/Quaternion`.
macro_rules! quaternion_definition {
    () => {
        "================================================================================\n\
         MSG: geometry_msgs/Quaternion\n\
         float64 x 0\n\
         float64 y 0\n\
         float64 z 0\n\
         float64 w 1\n"
    };
}

/// The definitions a `ros2msg` schema appends for `geometry_msgs/Transform`'s own types.
macro_rules! transform_definitions {
    () => {
        concat!(
            "================================================================================\n\
             MSG: geometry_msgs/Transform\n\
             Vector3 translation\n\
             Quaternion rotation\n\
             ================================================================================\n\
             MSG: geometry_msgs/Vector3\n\
             float64 x\n\
             float64 y\n\
             float64 z\n",
            quaternion_definition!()
        )
    };
}

/// `geometry_msgs/msg/PoseStamped`.
pub(crate) const POSE_STAMPED: MessageType = MessageType {
    name: "geometry_msgs/msg/PoseStamped",
    fields: &["std_msgs/Header header", "Pose pose"],
    schema: concat!(
        "std_msgs/Header header\nPose pose\n",
        "================================================================================\n\
         MSG: geometry_msgs/Pose\n\
         Point position\n\
         Quaternion orientation\n\
         ================================================================================\n\
         MSG: geometry_msgs/Point\n\
         float64 x\n\
         float64 y\n\
         float64 z\n",
        quaternion_definition!(),
        header_definitions!()
    ),
};

/// `geometry_msgs/msg/TransformStamped`.
pub(crate) const TRANSFORM_STAMPED: MessageType = MessageType {
    name: "geometry_msgs/msg/TransformStamped",
    fields: &["std_msgs/Header header", "string child_frame_id", "Transform transform"],
    schema: concat!(
        "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
        transform_definitions!(),
        header_definitions!()
    ),
};

/// `tf2_msgs/msg/TFMessage`.
pub(crate) const TF_MESSAGE: MessageType = MessageType {
    name: "tf2_msgs/msg/TFMessage",
    fields: &["geometry_msgs/TransformStamped[] transforms"],
    schema: concat!(
        "geometry_msgs/TransformStamped[] transforms\n",
        "================================================================================\n\
         MSG: geometry_msgs/TransformStamped\n\
         std_msgs/Header header\n\
         string child_frame_id\n\
         Transform transform\n",
        transform_definitions!(),
        header_definitions!()
    ),
};

impl MessageType {
    /// `name` (a schema's) is this type's: `pkg/msg/Type`, or the older `pkg/Type`.
    pub(crate) fn names(&self, name: &str) -> bool {
        name == self.name || name == self.name.replace("/msg/", "/")
    }

    /// Why a recorded schema (`name`, `encoding`, `data`) is not this type's, or `None`: the name
    /// must match (`pkg/msg/Type`, or the older `pkg/Type`), the encoding be `ros2msg` and the
    /// top-level declarations (comments, blank lines and constants aside) be this type's fields.
    pub(crate) fn mismatch(&self, name: &str, encoding: &str, data: &[u8]) -> Option<String> {
        if !self.names(name) {
            return Some(format!("the schema is `{name}`, not `{}`", self.name));
        }
        if encoding != "ros2msg" {
            return Some(format!("the schema of `{}` is encoded as `{encoding}`; spmcal reads `ros2msg`", self.name));
        }
        let Ok(text) = std::str::from_utf8(data) else {
            return Some(format!("the schema of `{}` is not UTF-8 text", self.name));
        };
        let top = text.split("\n===").next().unwrap_or("");
        let declared: Vec<String> = top
            .lines()
            .map(|l| l.split('#').next().unwrap_or("").split_whitespace().collect::<Vec<_>>().join(" "))
            .filter(|l| !l.is_empty() && !l.contains('='))
            .collect();
        // A type of the message's own package may be written with or without it (`Pose`,
        // `geometry_msgs/Pose`), as may the header (`std_msgs/Header`, `Header`).
        let normal = |f: &str| f.replace("std_msgs/", "").replace("geometry_msgs/", "");
        let expected: Vec<String> = self.fields.iter().map(|f| normal(f)).collect();
        let declared: Vec<String> = declared.iter().map(|f| normal(f)).collect();
        (declared != expected).then(|| {
            format!(
                "the recorded schema of `{}` declares [{}], not [{}]: another version of the message",
                self.name,
                declared.join("; "),
                expected.join("; ")
            )
        })
    }
}

/// Decode a CDR message (with its encapsulation header) as `T`.
///
/// # Errors
/// The reason, in words: too short, an encapsulation that is not plain CDR, or a body that does
/// not decode as `T`.
pub(crate) fn decode<'a, T: Deserialize<'a>>(data: &'a [u8]) -> Result<T, String> {
    if data.len() < 4 {
        return Err(format!("{} bytes: shorter than a CDR encapsulation header", data.len()));
    }
    let body = &data[4..];
    let decoded = match (data[0], data[1]) {
        (0, 0) => re_cdr::from_bytes::<T, BigEndian>(body),
        (0, 1) => re_cdr::from_bytes::<T, LittleEndian>(body),
        (a, b) => return Err(format!("encapsulation {a:02x} {b:02x} is not plain CDR (00 00 or 00 01)")),
    };
    decoded.map(|(value, _)| value).map_err(|e| format!("does not decode: {e}"))
}

/// Encode `value` as a little-endian CDR message (with its encapsulation header).
pub(crate) fn encode<T: Serialize>(value: &T) -> Vec<u8> {
    let mut out = vec![0, 1, 0, 0];
    // Serialising these plain structs into a Vec cannot fail.
    out.extend(re_cdr::to_vec::<T, LittleEndian>(value).expect("plain structs encode"));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schemas_spmcal_writes_are_the_ones_it_accepts() {
        for t in [&JOINT_STATE, &POINT_STAMPED] {
            assert_eq!(t.mismatch(t.name, "ros2msg", t.schema.as_bytes()), None);
            assert!(t.mismatch(t.name, "ros2idl", t.schema.as_bytes()).is_some());
        }
        let other = "std_msgs/Header header\nstring[] name\nfloat32[] position\n";
        assert!(JOINT_STATE.mismatch(JOINT_STATE.name, "ros2msg", other.as_bytes()).unwrap().contains("float32[]"));
        assert!(JOINT_STATE.mismatch("sensor_msgs/msg/Imu", "ros2msg", b"").unwrap().contains("Imu"));
    }

    #[test]
    fn a_joint_state_survives_cdr_and_its_layout_is_the_standard_one() {
        let m = JointState {
            header: Header { stamp: Time { sec: 1, nanosec: 2 }, frame_id: "f" },
            name: vec!["theta1"],
            position: vec![0.5],
            velocity: vec![],
            effort: vec![],
        };
        let bytes = encode(&m);
        // header 4 | sec 4 | nanosec 4 | frame_id: len 4 + "f\0" 2 | pad 2 | names: 4, len 4 +
        // "theta1\0" 7 | pad 1 | positions: 4 (at 32, then 8-aligned: pad 4) + 8 | two empty 4 + 4.
        assert_eq!(&bytes[..12], &[0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]);
        assert_eq!(bytes.len(), 4 + 4 + 4 + 4 + 2 + 2 + 4 + 4 + 7 + 1 + 4 + 4 + 8 + 4 + 4);
        assert_eq!(decode::<JointState>(&bytes).unwrap(), m);
        assert!(decode::<JointState>(&bytes[..20]).unwrap_err().contains("does not decode"));
        assert!(decode::<JointState>(&[0, 2, 0, 0]).unwrap_err().contains("not plain CDR"));
        // XCDR2 aligns 8-byte values to 4: refused, not misread.
        assert!(decode::<JointState>(&[0, 7, 0, 0, 1, 0, 0, 0]).unwrap_err().contains("not plain CDR"));
    }

    /// The bytes Python's `rosbags` serialises for `type` in byte order `endian` (`le`, `be`), as
    /// tests/data/bags/rosbags_cdr.py printed them.
    fn rosbags_bytes(type_name: &str, endian: &str) -> Vec<u8> {
        let text = include_str!("../../../tests/data/bags/rosbags_cdr.txt");
        let hex = text
            .lines()
            .find_map(|l| l.strip_prefix(&format!("{type_name} {endian} ")))
            .expect("the fixture has every type in both byte orders");
        (0..hex.len()).step_by(2).map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap()).collect()
    }

    /// The fixture's values (written out in rosbags_cdr.py).
    fn wrist() -> TransformStamped<'static> {
        TransformStamped {
            header: Header { stamp: Time { sec: 1_700_000_001, nanosec: 5 }, frame_id: "mocap" },
            child_frame_id: "wrist",
            transform: Transform {
                translation: Point { x: -0.03, y: 0.04, z: 0.65 },
                rotation: Quaternion { x: 0.0, y: 0.0, z: 0.6, w: 0.8 },
            },
        }
    }

    #[test]
    fn rigid_body_messages_decode_from_what_rosbags_writes_and_encode_to_the_same_bytes() {
        let pose = PoseStamped {
            header: Header { stamp: Time { sec: 1_700_000_000, nanosec: 123_456_789 }, frame_id: "world" },
            pose: Pose {
                position: Point { x: 0.125, y: -0.25, z: 0.7 },
                orientation: Quaternion { x: 0.1, y: -0.2, z: 0.3, w: 0.927_361_849_549_570_4 },
            },
        };
        let other = TransformStamped {
            header: Header { stamp: Time { sec: 1_700_000_001, nanosec: 5 }, frame_id: "world" },
            child_frame_id: "base_link_x",
            transform: Transform {
                translation: Point { x: 1.0, y: 2.0, z: 3.0 },
                rotation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 },
            },
        };
        let tf = TfMessage { transforms: vec![other, wrist()] };
        for endian in ["le", "be"] {
            let bytes = rosbags_bytes("PoseStamped", endian);
            assert_eq!(decode::<PoseStamped>(&bytes).unwrap(), pose, "{endian}");
            let bytes = rosbags_bytes("TransformStamped", endian);
            assert_eq!(decode::<TransformStamped>(&bytes).unwrap(), wrist(), "{endian}");
            let bytes = rosbags_bytes("TFMessage", endian);
            assert_eq!(decode::<TfMessage>(&bytes).unwrap(), tf, "{endian}");
        }
        // spmcal's writer (little-endian, as ROS 2) gives rosbags' bytes exactly, the padding
        // before each float64 after a string included.
        assert_eq!(encode(&pose), rosbags_bytes("PoseStamped", "le"));
        assert_eq!(encode(&wrist()), rosbags_bytes("TransformStamped", "le"));
        assert_eq!(encode(&tf), rosbags_bytes("TFMessage", "le"));
        // A message cut short does not decode as a shorter one.
        let bytes = rosbags_bytes("TFMessage", "le");
        assert!(decode::<TfMessage>(&bytes[..bytes.len() - 8]).unwrap_err().contains("does not decode"));
    }

    #[test]
    fn the_rigid_body_schemas_accept_what_rosbags_and_ros2_bag_record_write() {
        for t in [&POSE_STAMPED, &TRANSFORM_STAMPED, &TF_MESSAGE] {
            assert_eq!(t.mismatch(t.name, "ros2msg", t.schema.as_bytes()), None, "{}", t.name);
        }
        // rosbags qualifies every type; the .msg files (which `ros2 bag record` copies) leave the
        // package's own unqualified and carry comments.
        let rosbags = "std_msgs/Header header\ngeometry_msgs/Pose pose\n====\nMSG: geometry_msgs/Pose\n";
        assert_eq!(POSE_STAMPED.mismatch("geometry_msgs/msg/PoseStamped", "ros2msg", rosbags.as_bytes()), None);
        let record = "# A Pose with reference coordinate frame and timestamp\n\nstd_msgs/Header header\nPose pose\n";
        assert_eq!(POSE_STAMPED.mismatch("geometry_msgs/PoseStamped", "ros2msg", record.as_bytes()), None);
        let tf = "geometry_msgs/TransformStamped[] transforms\n";
        assert_eq!(TF_MESSAGE.mismatch("tf2_msgs/msg/TFMessage", "ros2msg", tf.as_bytes()), None);
        let e = POINT_STAMPED.mismatch("geometry_msgs/msg/PoseStamped", "ros2msg", rosbags.as_bytes()).unwrap();
        assert!(e.contains("PoseStamped") && e.contains("PointStamped"), "{e}");
        let e = TRANSFORM_STAMPED.mismatch(
            TRANSFORM_STAMPED.name,
            "ros2msg",
            b"std_msgs/Header header\nTransform transform\n",
        );
        assert!(e.unwrap().contains("another version"));
    }

    #[test]
    fn times_convert_to_the_nanosecond() {
        let t = Time::of_seconds(12.345_678_901).unwrap();
        assert_eq!((t.sec, t.nanosec), (12, 345_678_901));
        assert_eq!(t.nanoseconds(), 12_345_678_901);
        assert!(Time::of_seconds(-1.0).is_none() && Time::of_seconds(f64::NAN).is_none());
    }
}
