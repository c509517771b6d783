//! What maps to what in a bag: `spmcal.yaml` beside the `.mcap` file (or inside the bag folder).
//! Every key is optional; a bag recorded with the default names needs no file at all (markers on
//! `/markers`, or a rigid body as `PoseStamped` or `TransformStamped` on `/body`). A bag holds
//! markers or a body, not both.
//!
//! ```yaml
//! model: agile_wrist                 # a shipped model's name, or a URDF's path relative to this
//!                                     # file (--model wins; default: agile_wrist)
//! joints:
//!   topic: /joint_states              # sensor_msgs/msg/JointState
//!   names: [theta1, theta2, theta3]   # the actuated joints, in `name`
//!   units: rad                        # rad | deg
//! markers:                            # geometry_msgs/msg/PointStamped, in the camera frame
//!   topic: /markers                   # one topic whose header.frame_id names the marker ...
//!   frame_ids: {tracker/m1: m1}       # ... by these names (default: the marker's own)
//!   topics: {/tracker/m1: m1}         # or a topic per marker (default: /markers/<name>)
//!   camera_frame: camera              # a topic per marker: header.frame_id must be this
//! body:                               # or a rigid body on the platform (markers then not read):
//!   topic: /vrpn_mocap/wrist/pose     # PoseStamped or TransformStamped, as the schema says (default /body) ...
//!   tf: /tf                           # ... or tf2_msgs/msg/TFMessage on this topic (default /tf) ...
//!   child_frame: wrist                # ... the transforms to this frame (required with `tf`; on a
//!                                     # TransformStamped topic, its child_frame_id checked)
//!   parent_frame: world               # header.frame_id of every pose (default: the first's)
//! clock: header                       # header (header.stamp, the sensors' time) | receive
//! still_rad: 0.0005                   # joints resting within this ...
//! min_rest_s: 0.05                    # ... this long around every capture: a static session
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::io::files::FileError;

/// The mapping file's name.
pub(crate) const MAPPING_FILE: &str = "spmcal.yaml";

/// Which time a message is placed at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Clock {
    /// `header.stamp`: when the sensor measured.
    #[default]
    Header,
    /// The bag's receive (log) time: when the recorder got the message.
    Receive,
}

/// Joint position units.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Units {
    /// Radians (the ROS convention).
    #[default]
    Rad,
    /// Degrees.
    Deg,
}

/// The joint-state topic.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct Joints {
    pub(crate) topic: String,
    pub(crate) names: [String; 3],
    pub(crate) units: Units,
}

impl Default for Joints {
    fn default() -> Self {
        Joints {
            topic: "/joint_states".into(),
            names: ["theta1".into(), "theta2".into(), "theta3".into()],
            units: Units::Rad,
        }
    }
}

/// The marker topics.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct Markers {
    /// The one topic whose `header.frame_id` names the marker.
    pub(crate) topic: String,
    /// `frame_id` → marker, on that topic (default: the marker's own name).
    pub(crate) frame_ids: BTreeMap<String, String>,
    /// Topic → marker, a topic per marker (default: `/markers/<name>`).
    pub(crate) topics: BTreeMap<String, String>,
    /// On a topic per marker, the frame every point must be in.
    pub(crate) camera_frame: Option<String>,
}

impl Default for Markers {
    fn default() -> Self {
        Markers { topic: "/markers".into(), frame_ids: BTreeMap::new(), topics: BTreeMap::new(), camera_frame: None }
    }
}

/// The topic a rigid body's poses are read from when the mapping names none.
pub(crate) const DEFAULT_BODY_TOPIC: &str = "/body";

/// The `body` key as written: a rigid body on the platform, tracked by motion capture.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct BodyKeys {
    topic: Option<String>,
    tf: Option<String>,
    child_frame: Option<String>,
    parent_frame: Option<String>,
}

/// Where a rigid body's poses are.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum BodySource {
    /// A topic of `PoseStamped` or `TransformStamped` (the schema says which); a
    /// `TransformStamped`'s `child_frame_id` must be `child_frame` when given.
    Topic { topic: String, child_frame: Option<String> },
    /// The transforms to `child_frame` among those of a `TFMessage` topic.
    Tf { topic: String, child_frame: String },
}

/// The rigid body of the mapping.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Body {
    pub(crate) source: BodySource,
    /// Every pose's `header.frame_id` must be this (`None`: the first pose's).
    pub(crate) parent_frame: Option<String>,
}

impl Default for Body {
    fn default() -> Self {
        Body { source: BodySource::Topic { topic: DEFAULT_BODY_TOPIC.into(), child_frame: None }, parent_frame: None }
    }
}

impl Body {
    /// The topic the poses are on.
    pub(crate) fn topic(&self) -> &str {
        body_topic(&self.source)
    }

    /// The body as a message names it: `` `/body` `` or `` frame `wrist` on `/tf` ``.
    pub(crate) fn describe(&self) -> String {
        match &self.source {
            BodySource::Topic { topic, .. } => format!("topic `{topic}`"),
            BodySource::Tf { topic, child_frame } => format!("frame `{child_frame}` on `{topic}`"),
        }
    }

    /// The body of the keys as written, checked: a topic, or `tf` with a child frame.
    fn of(keys: BodyKeys) -> Result<Body, String> {
        let BodyKeys { topic, tf, child_frame, parent_frame } = keys;
        let source = match (topic, tf, child_frame) {
            (Some(_), Some(_), _) => return Err("`body` names both `topic` and `tf`: a body is on one of them".into()),
            (Some(topic), None, child_frame) => BodySource::Topic { topic, child_frame },
            (None, tf, Some(child_frame)) => BodySource::Tf { topic: tf.unwrap_or_else(|| "/tf".into()), child_frame },
            (None, _, None) => {
                let reason =
                    "`body` needs `topic` (PoseStamped or TransformStamped) or `child_frame` (on `tf`, default /tf)";
                return Err(reason.into());
            }
        };
        let child = match &source {
            BodySource::Topic { child_frame, .. } => child_frame.as_deref(),
            BodySource::Tf { child_frame, .. } => Some(child_frame.as_str()),
        };
        if body_topic(&source).is_empty() || child.is_some_and(str::is_empty) || parent_frame.as_deref() == Some("") {
            return Err("`body` names an empty topic or frame".into());
        }
        Ok(Body { source, parent_frame })
    }
}

/// The topic a body's poses are on.
fn body_topic(source: &BodySource) -> &str {
    match source {
        BodySource::Topic { topic, .. } | BodySource::Tf { topic, .. } => topic,
    }
}

/// The whole mapping.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct Mapping {
    pub(crate) model: Option<PathBuf>,
    /// Why `model` names no model, said only when the bag is read with it (`--model` wins).
    #[serde(skip)]
    pub(crate) model_missing: Option<FileError>,
    pub(crate) joints: Joints,
    pub(crate) markers: Markers,
    /// The rigid body as written (checked into `body`).
    #[serde(rename = "body")]
    body_keys: Option<BodyKeys>,
    /// The rigid body: the mapping's, else a `PoseStamped` or `TransformStamped` on `/body`.
    #[serde(skip)]
    pub(crate) body: Body,
    /// The mapping names a body: a bag without it is refused rather than read as markers.
    #[serde(skip)]
    pub(crate) body_mapped: bool,
    pub(crate) clock: Clock,
    /// Joints resting within this (rad, each joint) around the captures make a static pose.
    pub(crate) still_rad: f64,
    /// ... for at least this long (s).
    pub(crate) min_rest_s: f64,
    /// Where it was read from (`None`: the defaults).
    #[serde(skip)]
    pub(crate) path: Option<PathBuf>,
}

impl Default for Mapping {
    fn default() -> Self {
        Mapping {
            model: None,
            model_missing: None,
            joints: Joints::default(),
            markers: Markers::default(),
            body_keys: None,
            body: Body::default(),
            body_mapped: false,
            clock: Clock::Header,
            still_rad: 5e-4,
            min_rest_s: 0.05,
            path: None,
        }
    }
}

impl Mapping {
    /// The mapping for the bag at `bag` (a `.mcap` file or a bag folder): `spmcal.yaml` in the
    /// folder, else the defaults.
    ///
    /// # Errors
    /// A [`FileError`] naming the key of an unreadable or out-of-range value.
    pub(crate) fn beside(bag: &Path) -> Result<Mapping, FileError> {
        let folder = if bag.is_dir() { bag } else { crate::io::files::parent_folder(bag) };
        let path = folder.join(MAPPING_FILE);
        if !path.exists() {
            return Ok(Mapping::default());
        }
        let (mut mapping, keys) = crate::io::yaml::read::<Mapping>(&path)?;
        if !(mapping.still_rad.is_finite() && mapping.still_rad > 0.0 && mapping.still_rad < 0.1) {
            let reason = format!("`still_rad` must be above 0 and below 0.1 rad (got {})", mapping.still_rad);
            return Err(keys.error(&path, "still_rad", reason));
        }
        if !(mapping.min_rest_s.is_finite() && mapping.min_rest_s > 0.0 && mapping.min_rest_s <= 10.0) {
            let reason = format!("`min_rest_s` must be above 0 and at most 10 s (got {})", mapping.min_rest_s);
            return Err(keys.error(&path, "min_rest_s", reason));
        }
        let names = &mapping.joints.names;
        if names[0] == names[1] || names[1] == names[2] || names[0] == names[2] {
            return Err(keys.error(&path, "joints", format!("`names` lists a joint twice: {names:?}")));
        }
        if let Some(written) = mapping.body_keys.take() {
            mapping.body = Body::of(written).map_err(|reason| keys.error(&path, "body", reason))?;
            mapping.body_mapped = true;
        }
        mapping.model = mapping.model.map(|m| crate::io::files::resolve_reference(folder, &m));
        mapping.model_missing = mapping
            .model
            .as_deref()
            .and_then(crate::model::shipped::missing)
            .map(|reason| keys.error(&path, "model", reason));
        mapping.path = Some(path);
        Ok(mapping)
    }

    /// The marker (index into `names`) a point on `topic` with `frame_id` is, `Ok(None)` when the
    /// topic carries no markers.
    ///
    /// # Errors
    /// Why the point cannot be placed: an unknown `frame_id`, or one other than the camera frame.
    pub(crate) fn marker_of(&self, topic: &str, frame_id: &str, names: &[String]) -> Result<Option<usize>, String> {
        let index = |name: &str| names.iter().position(|n| n == name);
        let m = &self.markers;
        if topic == m.topic {
            let name = m.frame_ids.get(frame_id).map_or(frame_id, String::as_str);
            return index(name).map(Some).ok_or_else(|| {
                format!(
                    "header.frame_id `{frame_id}` names no marker of the model ({}): name the marker, or map it under `markers: frame_ids` in {MAPPING_FILE}",
                    names.join(", ")
                )
            });
        }
        let by_topic = match self.marker_topic(topic, names) {
            Some(name) => Some(index(name).ok_or_else(|| {
                format!("{MAPPING_FILE} maps topic `{topic}` to marker `{name}`, which the model does not have")
            })?),
            None => None,
        };
        if let (Some(_), Some(frame)) = (by_topic, &m.camera_frame)
            && frame != frame_id
        {
            return Err(format!("header.frame_id is `{frame_id}`, not the camera frame `{frame}`"));
        }
        Ok(by_topic)
    }

    /// The topic carries the points of markers (on the one marker topic, or a topic of their own).
    pub(crate) fn carries_markers(&self, topic: &str, names: &[String]) -> bool {
        topic == self.markers.topic || self.marker_topic(topic, names).is_some()
    }

    /// The marker topics as a warning names them: `marker topic `/markers``, or `its marker's
    /// topic` when markers are mapped to topics of their own.
    pub(crate) fn marker_topics(&self) -> String {
        if self.markers.topics.is_empty() {
            format!("marker topic `{}`", self.markers.topic)
        } else {
            "its marker's topic".to_string()
        }
    }

    /// The marker whose own topic `topic` is: as `markers: topics` maps it, or by default
    /// `/markers/<name>` for a marker of the model (`names`).
    fn marker_topic<'a>(&'a self, topic: &'a str, names: &[String]) -> Option<&'a str> {
        let m = &self.markers;
        match m.topics.get(topic) {
            Some(name) => Some(name),
            None if m.topics.is_empty() => topic.strip_prefix("/markers/").filter(|n| names.iter().any(|k| k == n)),
            None => None,
        }
    }

    /// A joint position in radians.
    pub(crate) fn radians(&self, value: f64) -> f64 {
        match self.joints.units {
            Units::Rad => value,
            Units::Deg => value.to_radians(),
        }
    }
}
