//! Reading a bag in one pass: MCAP records streamed through `mcap`'s sans-io reader (the file is
//! never held in memory, only the samples spmcal keeps), the message types decoded from CDR, each
//! message checked where it stands (topic, message number, reason).

use std::collections::HashMap;
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{SendError, SyncSender};

use mcap::records::Record;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use nalgebra::Vector3;

use super::mapping::{BodySource, Clock, Mapping};
use super::messages::{
    Header, JOINT_STATE, JointState, MessageType, POINT_STAMPED, POSE_STAMPED, PointStamped, PoseStamped, Quaternion,
    TF_MESSAGE, TRANSFORM_STAMPED, TfMessage, TransformStamped, decode,
};
use crate::dataset::{BodyCapture, BodyPose, Capture, EncoderSample};
use crate::io::files::FileError;

/// What a bag holds for spmcal, times in seconds from the whole second of its first message.
#[derive(Debug, Default)]
pub(crate) struct BagData {
    /// Joint samples, time strictly increasing.
    pub(crate) encoders: Vec<EncoderSample>,
    /// Marker captures in the order read (`line`: the message's number in the bag).
    pub(crate) captures: Vec<Capture>,
    /// The rigid body's poses in the order read, time strictly increasing (`line`: the
    /// message's number on its topic).
    pub(crate) bodies: Vec<BodyCapture>,
    /// The frame the body's poses are in (their `header.frame_id`).
    pub(crate) body_frame: Option<String>,
    /// The body's frame as the first `TransformStamped` names it (`child_frame_id`).
    pub(crate) body_child: Option<String>,
    /// The whole second (since the epoch) the times count from.
    pub(crate) epoch_s: Option<i64>,
}

/// One channel of the bag and what it carries for spmcal.
struct Channel {
    topic: String,
    role: Role,
    /// Messages read on it so far.
    count: usize,
    /// The last time on it (s), for the clock check.
    last_s: Option<f64>,
    /// Its schema's name (to suggest a mapping for a topic not read).
    schema: String,
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Role {
    Joints,
    Markers,
    /// The rigid body as `PoseStamped`.
    Pose,
    /// The rigid body as `TransformStamped`.
    Transform,
    /// The rigid body among the transforms of a `TFMessage`.
    Tf,
    Ignored,
}

impl Role {
    /// The message type a channel of this role must carry.
    fn expected(self) -> Option<&'static MessageType> {
        match self {
            Role::Joints => Some(&JOINT_STATE),
            Role::Markers => Some(&POINT_STAMPED),
            Role::Pose => Some(&POSE_STAMPED),
            Role::Transform => Some(&TRANSFORM_STAMPED),
            Role::Tf => Some(&TF_MESSAGE),
            Role::Ignored => None,
        }
    }

    fn is_body(self) -> bool {
        matches!(self, Role::Pose | Role::Transform | Role::Tf)
    }
}

/// The bag files to read: the `.mcap` file itself, or a bag folder's files in the order its
/// `metadata.yaml` lists them (else by name).
///
/// # Errors
/// A folder without MCAP files, or recorded with the sqlite3 storage (to be converted first).
pub(crate) fn bag_files(bag: &Path) -> Result<Vec<PathBuf>, FileError> {
    if !bag.is_dir() {
        return Ok(vec![bag.to_path_buf()]);
    }
    let metadata = bag.join("metadata.yaml");
    if metadata.is_file() {
        // Within the limits every YAML input is held to (depth, size, aliases), scanned in linear
        // time before serde_yaml sees it.
        let (value, _) = crate::io::yaml::read::<serde_yaml::Value>(&metadata)?;
        let info = &value["rosbag2_bagfile_information"];
        if let Some(storage) = info["storage_identifier"].as_str().filter(|s| *s != "mcap") {
            return Err(FileError::new(
                &metadata,
                format!(
                    "the bag is stored as `{storage}`; spmcal reads MCAP: convert it with `ros2 bag convert -i {} -o out.yaml` (out.yaml: `output_bags: [{{uri: rec_mcap, storage_id: mcap}}]`)",
                    bag.display()
                ),
            ));
        }
        if let Some(files) = info["relative_file_paths"].as_sequence() {
            return Ok(files.iter().filter_map(|f| f.as_str()).map(|f| bag.join(f)).collect());
        }
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(bag)
        .map_err(|e| FileError::new(bag, format!("cannot read the bag folder: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    // Split bags number their files (`rec_2.mcap` before `rec_10.mcap`): by name, numbers by value.
    files.sort_by_key(|p| natural_key(&p.to_string_lossy()));
    if files.is_empty() {
        return Err(FileError::new(bag, "a bag folder without `.mcap` files (and no session.yaml)"));
    }
    Ok(files)
}

/// A file name as text and numbers, so that numbered files sort by their numbers.
fn natural_key(name: &str) -> Vec<(String, u64)> {
    let mut key = Vec::new();
    let (mut text, mut number) = (String::new(), None::<u64>);
    for ch in name.chars() {
        match ch.to_digit(10) {
            Some(d) => number = Some(number.unwrap_or(0).saturating_mul(10).saturating_add(u64::from(d))),
            None => {
                if let Some(n) = number.take() {
                    key.push((std::mem::take(&mut text), n));
                }
                text.push(ch);
            }
        }
    }
    key.push((text, number.unwrap_or(0)));
    key
}

/// Read the joint states and marker points of `files` under `mapping`, the markers named
/// `markers`; `progress` gets the bytes read so far. Two threads: one reads and decompresses the
/// MCAP records, the other decodes the messages (an hour at 1 kHz is 3.6 million of them).
///
/// # Errors
/// A [`FileError`] naming the file, and the topic and message number, of the first problem.
pub(crate) fn read_bag(
    files: &[PathBuf],
    mapping: &Mapping,
    markers: &[String],
    progress: &mut dyn FnMut(u64),
) -> Result<BagData, FileError> {
    let mut data = BagData::default();
    let mut done = 0u64;
    for file in files {
        let container = Container { mapping, markers, file };
        let mut decoder = Decoder {
            mapping,
            markers,
            file,
            channels: Vec::new(),
            slots: vec![NONE; 1 << 16],
            data,
            body_last_s: None,
            child_frames: std::collections::BTreeSet::new(),
        };
        std::thread::scope(|scope| {
            let (send, receive) = std::sync::mpsc::sync_channel::<Event>(4);
            let reading = scope.spawn(move || container.stream(&send));
            let decoded = decoder.consume(&receive, &mut |bytes| progress(done + bytes));
            // A decoding error drops the receiver, which stops the reader: its own error comes first
            // only when it ended the stream.
            drop(receive);
            // The MCAP reader is another crate's: should it fail on a file in a way its errors do
            // not cover, that is this file's error, not the program's end.
            let read =
                reading.join().unwrap_or_else(|_| Err(FileError::new(file, "the MCAP reader failed on this file")));
            decoded.and(read)
        })?;
        done += std::fs::metadata(file).map_or(0, |m| m.len());
        decoder.check_topics()?;
        data = decoder.data;
    }
    Ok(data)
}

/// Check that time `t` follows `last` (`strict`: strictly) and make it the last.
fn advance(last: &mut Option<f64>, t: f64, strict: bool) -> Result<(), String> {
    if let Some(before) = *last
        && (t < before || (strict && t == before))
    {
        let what = if t == before { "repeats" } else { "goes back from" };
        return Err(format!("clock {what} the previous message's ({t} s after {before} s)"));
    }
    *last = Some(t);
    Ok(())
}

/// What the reading thread hands the decoding one.
enum Event {
    /// A channel of the bag (checked when it carries joints or markers).
    Channel { id: u16, topic: String, role: Role, schema: String },
    /// Messages on joint or marker channels, their bytes back to back.
    Messages(Batch),
    /// Bytes of the file read so far.
    Progress(u64),
}

/// Messages handed over at once.
#[derive(Default)]
struct Batch {
    bytes: Vec<u8>,
    /// Channel, log time (ns) and bytes of each message.
    items: Vec<(u16, u64, std::ops::Range<usize>)>,
}

/// Messages per batch.
const BATCH: usize = 4096;

/// Bytes read from the file at a time.
const READ_SIZE: usize = 1 << 20;

/// The largest record or chunk (compressed or not) a bag may hold: writers chunk at about a
/// megabyte (rosbag2 and Foxglove at 768 KiB), and a corrupt length field must be an error before
/// it is an allocation of its size (or an overflow in the reader).
const RECORD_LENGTH_LIMIT: usize = 256 << 20;

/// No channel in a slot.
const NONE: u32 = u32::MAX;

/// What the reading side keeps between records: the schemas by id, each declared channel's role
/// by id, the batch being filled.
struct Records {
    schemas: HashMap<u16, (String, String, Vec<u8>)>,
    roles: Vec<Option<Role>>,
    batch: Batch,
}

/// The reading side: MCAP records, schemas checked, messages of interest passed on.
struct Container<'a> {
    mapping: &'a Mapping,
    markers: &'a [String],
    file: &'a Path,
}

impl Container<'_> {
    fn error(&self, reason: impl Into<String>) -> FileError {
        FileError::new(self.file, reason)
    }

    /// Feed the file to the MCAP reader and pass on what the decoder needs; stops quietly when the
    /// decoder has stopped listening.
    fn stream(&self, send: &SyncSender<Event>) -> Result<(), FileError> {
        let mut file = std::fs::File::open(self.file).map_err(|e| self.error(format!("cannot open: {e}")))?;
        // Each chunk's CRC checked before any of its messages is read: a flipped byte is an error,
        // not a wrong joint angle.
        let options = LinearReaderOptions::default()
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(RECORD_LENGTH_LIMIT);
        let mut mcap = LinearReader::new_with_options(options);
        let mut state = Records { schemas: HashMap::new(), roles: vec![None; 1 << 16], batch: Batch::default() };
        let mut read = 0u64;
        while let Some(event) = mcap.next_event() {
            let event = event.map_err(|e| {
                self.error(format!("not a readable MCAP file (truncated or corrupt near byte {read}): {e}"))
            })?;
            let handed = match event {
                LinearReadEvent::ReadRequest(wanted) => {
                    let buffer = mcap.insert(wanted.clamp(1, READ_SIZE));
                    let n = file.read(buffer).map_err(|e| self.error(format!("cannot read: {e}")))?;
                    mcap.notify_read(n);
                    read += n as u64;
                    send.send(Event::Progress(read))
                }
                LinearReadEvent::Record { data, opcode } => {
                    let record = mcap::parse_record(opcode, data)
                        .map_err(|e| self.error(format!("a corrupt MCAP record near byte {read}: {e}")))?;
                    self.record(record, &mut state, send)?
                }
            };
            if handed.is_err() {
                return Ok(());
            }
        }
        // The decoder may have stopped already: then its error is the one to report.
        let _ = send.send(Event::Messages(state.batch));
        Ok(())
    }

    /// One MCAP record: a schema kept, a channel checked and announced (once: chunked files repeat
    /// it in every chunk that uses it, and in the summary), a message of interest batched. The
    /// inner result is the hand-over's (an error when the decoder stopped listening).
    fn record(
        &self,
        record: Record<'_>,
        state: &mut Records,
        send: &SyncSender<Event>,
    ) -> Result<Result<(), SendError<Event>>, FileError> {
        Ok(match record {
            Record::Schema { header, data } => {
                state.schemas.insert(header.id, (header.name, header.encoding, data.into_owned()));
                Ok(())
            }
            Record::Channel(c) if state.roles[usize::from(c.id)].is_some() => Ok(()),
            Record::Channel(c) => {
                let schema = state.schemas.get(&c.schema_id).map_or_else(String::new, |s| s.0.clone());
                let role = self.role(&c.topic, &schema);
                if let Some(expected) = role.expected() {
                    self.check_channel(&state.schemas, &c.topic, expected, c.schema_id, &c.message_encoding)?;
                }
                state.roles[usize::from(c.id)] = Some(role);
                send.send(Event::Channel { id: c.id, topic: c.topic, role, schema })
            }
            Record::Message { header, data } => match state.roles[usize::from(header.channel_id)] {
                None => {
                    let reason = format!("a message on channel {} that the bag never declared", header.channel_id);
                    return Err(self.error(reason));
                }
                Some(Role::Ignored) => Ok(()),
                Some(_) => {
                    let batch = &mut state.batch;
                    let from = batch.bytes.len();
                    batch.bytes.extend_from_slice(&data);
                    batch.items.push((header.channel_id, header.log_time, from..batch.bytes.len()));
                    if batch.items.len() < BATCH { Ok(()) } else { send.send(Event::Messages(std::mem::take(batch))) }
                }
            },
            _ => Ok(()),
        })
    }

    /// What the channel on `topic` with the schema named `schema` carries for spmcal: a body on
    /// its own topic is a `TransformStamped` when its schema says so, else a `PoseStamped` (checked
    /// as one); a mapped body leaves the markers unread.
    fn role(&self, topic: &str, schema: &str) -> Role {
        let body = &self.mapping.body;
        if topic == self.mapping.joints.topic {
            Role::Joints
        } else if topic == body.topic() {
            match body.source {
                BodySource::Tf { .. } => Role::Tf,
                BodySource::Topic { .. } if TRANSFORM_STAMPED.names(schema) => Role::Transform,
                BodySource::Topic { .. } => Role::Pose,
            }
        } else if !self.mapping.body_mapped && self.mapping.carries_markers(topic, self.markers) {
            Role::Markers
        } else {
            Role::Ignored
        }
    }

    /// The channel's message encoding and schema are the expected type's.
    fn check_channel(
        &self,
        schemas: &HashMap<u16, (String, String, Vec<u8>)>,
        topic: &str,
        expected: &MessageType,
        schema_id: u16,
        encoding: &str,
    ) -> Result<(), FileError> {
        if encoding != "cdr" {
            return Err(self.error(format!("topic `{topic}`: message encoding `{encoding}`; spmcal reads ROS 2 `cdr`")));
        }
        let Some((name, schema_encoding, text)) = schemas.get(&schema_id) else {
            return Err(self.error(format!("topic `{topic}`: no schema recorded; expected `{}`", expected.name)));
        };
        let body_types = [&POSE_STAMPED, &TRANSFORM_STAMPED, &TF_MESSAGE];
        let file = super::mapping::MAPPING_FILE;
        let hint = if expected.name == POSE_STAMPED.name && TF_MESSAGE.names(name) {
            format!(" (transforms are read as `body: {{tf: {topic}, child_frame: <the body's frame>}}` in {file})")
        } else if expected.name == POSE_STAMPED.name {
            " (a rigid body's topic carries geometry_msgs/msg/PoseStamped or TransformStamped)".to_string()
        } else if !body_types.iter().any(|t| t.name == expected.name) && body_types.iter().any(|t| t.names(name)) {
            format!(" (a rigid body is mapped under `body` in {file})")
        } else {
            String::new()
        };
        match expected.mismatch(name, schema_encoding, text) {
            Some(reason) => Err(self.error(format!("topic `{topic}`: {reason}{hint}"))),
            None => Ok(()),
        }
    }
}

/// The decoding side: each message checked where it stands, the samples kept.
struct Decoder<'a> {
    mapping: &'a Mapping,
    markers: &'a [String],
    file: &'a Path,
    channels: Vec<Channel>,
    /// Channel id → index in `channels` (`NONE`: not declared).
    slots: Vec<u32>,
    data: BagData,
    /// The body's last time (s): its own clock check, `/tf` mixing many frames' stamps.
    body_last_s: Option<f64>,
    /// Child frames seen on the body's `/tf` topic (to list when the body's is not among them).
    child_frames: std::collections::BTreeSet<String>,
}

impl Decoder<'_> {
    fn error(&self, reason: impl Into<String>) -> FileError {
        FileError::new(self.file, reason)
    }

    /// Decode every event until the reader ends.
    fn consume(
        &mut self,
        receive: &std::sync::mpsc::Receiver<Event>,
        progress: &mut dyn FnMut(u64),
    ) -> Result<(), FileError> {
        for event in receive {
            match event {
                Event::Channel { id, topic, role, schema } => {
                    self.slots[usize::from(id)] = self.channels.len() as u32;
                    self.channels.push(Channel { topic, role, count: 0, last_s: None, schema });
                }
                Event::Messages(batch) => {
                    for (id, log_ns, range) in &batch.items {
                        let c = self.slots[usize::from(*id)] as usize;
                        self.channels[c].count += 1;
                        let data = &batch.bytes[range.clone()];
                        match self.channels[c].role {
                            Role::Joints => self.joint_state(c, *log_ns, data)?,
                            Role::Markers => self.point(c, *log_ns, data)?,
                            Role::Pose | Role::Transform | Role::Tf => self.body(c, *log_ns, data)?,
                            Role::Ignored => {}
                        }
                    }
                }
                Event::Progress(bytes) => progress(bytes),
            }
        }
        Ok(())
    }

    /// The message's time (s from the first message's whole second) on the mapping's clock, and a
    /// clock check on its channel (`strict`: strictly increasing).
    fn time(&mut self, channel: usize, stamp: super::messages::Time, log_ns: u64, strict: bool) -> Result<f64, String> {
        let t = self.seconds(stamp, log_ns)?;
        advance(&mut self.channels[channel].last_s, t, strict).map_err(|r| format!("the {r}"))?;
        Ok(t)
    }

    /// The message's time (s from the first message's whole second) on the mapping's clock.
    fn seconds(&mut self, stamp: super::messages::Time, log_ns: u64) -> Result<f64, String> {
        if self.mapping.clock == Clock::Header && stamp.nanosec >= 1_000_000_000 {
            return Err(format!("header.stamp.nanosec is {}: not a time (at most 999,999,999)", stamp.nanosec));
        }
        let (sec, nanosec) = match self.mapping.clock {
            Clock::Header => (i64::from(stamp.sec), i64::from(stamp.nanosec)),
            Clock::Receive => ((log_ns / 1_000_000_000) as i64, (log_ns % 1_000_000_000) as i64),
        };
        let epoch = *self.data.epoch_s.get_or_insert(sec);
        Ok((sec - epoch) as f64 + nanosec as f64 * 1e-9)
    }

    fn at(&self, channel: usize, reason: &str) -> FileError {
        let c = &self.channels[channel];
        self.error(format!("topic `{}`, message {}: {reason}", c.topic, c.count))
    }

    fn joint_state(&mut self, channel: usize, log_ns: u64, data: &[u8]) -> Result<(), FileError> {
        let m: JointState = decode(data).map_err(|r| self.at(channel, &format!("sensor_msgs/msg/JointState {r}")))?;
        if m.position.len() != m.name.len() {
            let reason = format!("{} names but {} positions", m.name.len(), m.position.len());
            return Err(self.at(channel, &reason));
        }
        let mut joints = Vector3::zeros();
        for (k, wanted) in self.mapping.joints.names.iter().enumerate() {
            let Some(i) = m.name.iter().position(|n| *n == wanted) else {
                let reason = format!(
                    "joint `{wanted}` is not in `name` {:?} (map the actuated joints under `joints: names`)",
                    m.name
                );
                return Err(self.at(channel, &reason));
            };
            let value = m.position[i];
            if !value.is_finite() {
                return Err(self.at(channel, &format!("joint `{wanted}` is at {value}: not a number")));
            }
            joints[k] = self.mapping.radians(value);
            if let Some(reason) = crate::dataset::joints::degrees_reason(joints[k]) {
                let reason = format!("joint `{wanted}`: {reason} (a bag in degrees maps `joints: units: deg`)");
                return Err(self.at(channel, &reason));
            }
        }
        let time_s = self.time(channel, m.header.stamp, log_ns, true).map_err(|r| self.at(channel, &r))?;
        self.data.encoders.push(EncoderSample { time_s, joints });
        Ok(())
    }

    fn point(&mut self, channel: usize, log_ns: u64, data: &[u8]) -> Result<(), FileError> {
        let m: PointStamped =
            decode(data).map_err(|r| self.at(channel, &format!("geometry_msgs/msg/PointStamped {r}")))?;
        let marker = match self.mapping.marker_of(&self.channels[channel].topic, m.header.frame_id, self.markers) {
            Ok(Some(marker)) => marker,
            Ok(None) => return Ok(()),
            Err(reason) => return Err(self.at(channel, &reason)),
        };
        let position = Vector3::new(m.point.x, m.point.y, m.point.z);
        if !position.iter().all(|v| v.is_finite()) {
            return Err(self.at(channel, &format!("the point {position:?} is not finite")));
        }
        // As markers.csv and captures.csv bound a coordinate: beyond it, millimetres.
        if let Some(reason) = position.iter().find_map(|v| crate::dataset::markers::millimetres_reason(*v)) {
            return Err(self.at(channel, &format!("the point {position:?}: {reason}")));
        }
        // One topic carries the markers of a frame at one stamp: time may repeat there.
        let time_s = self.time(channel, m.header.stamp, log_ns, false).map_err(|r| self.at(channel, &r))?;
        let line = self.channels[channel].count;
        self.data.captures.push(Capture { time_s, marker, position, line });
        Ok(())
    }

    /// A message on the body's channel: a `PoseStamped`, a `TransformStamped`, or a `TFMessage`
    /// whose transforms to the body's frame are kept.
    fn body(&mut self, channel: usize, log_ns: u64, data: &[u8]) -> Result<(), FileError> {
        let role = self.channels[channel].role;
        let type_name = role.expected().map_or("", |t| t.name);
        let undecodable = |r: String| format!("{type_name} {r}");
        match role {
            Role::Pose => {
                let m: PoseStamped = decode(data).map_err(|r| self.at(channel, &undecodable(r)))?;
                let p = m.pose.position;
                self.body_pose(channel, log_ns, &m.header, Vector3::new(p.x, p.y, p.z), m.pose.orientation)
            }
            Role::Transform => {
                let m: TransformStamped = decode(data).map_err(|r| self.at(channel, &undecodable(r)))?;
                if let BodySource::Topic { child_frame: Some(child), .. } = &self.mapping.body.source
                    && child != m.child_frame_id
                {
                    let reason = format!("child_frame_id is `{}`, not the body's frame `{child}`", m.child_frame_id);
                    return Err(self.at(channel, &reason));
                }
                if self.data.body_child.is_none() {
                    self.data.body_child = Some(m.child_frame_id.to_string());
                }
                let t = m.transform.translation;
                self.body_pose(channel, log_ns, &m.header, Vector3::new(t.x, t.y, t.z), m.transform.rotation)
            }
            _ => {
                let m: TfMessage = decode(data).map_err(|r| self.at(channel, &undecodable(r)))?;
                let mapping = self.mapping;
                let BodySource::Tf { child_frame, .. } = &mapping.body.source else {
                    // A TFMessage channel is the body's only on `tf`.
                    return Ok(());
                };
                for t in &m.transforms {
                    if t.child_frame_id == child_frame {
                        let v = t.transform.translation;
                        self.body_pose(channel, log_ns, &t.header, Vector3::new(v.x, v.y, v.z), t.transform.rotation)?;
                    } else if self.child_frames.len() < 64 {
                        self.child_frames.insert(t.child_frame_id.to_string());
                    }
                }
                Ok(())
            }
        }
    }

    /// One pose of the body, checked: in the parent frame (the mapping's, else the first pose's),
    /// finite, in metres, a unit quaternion, later than the last.
    fn body_pose(
        &mut self,
        channel: usize,
        log_ns: u64,
        header: &Header<'_>,
        position: Vector3<f64>,
        q: Quaternion,
    ) -> Result<(), FileError> {
        let frame = self.mapping.body.parent_frame.as_deref().or(self.data.body_frame.as_deref());
        if let Some(frame) = frame
            && frame != header.frame_id
        {
            let whose =
                if self.mapping.body.parent_frame.is_some() { "`body: parent_frame`" } else { "the first pose's" };
            let reason = format!("header.frame_id is `{}`, not `{frame}` ({whose})", header.frame_id);
            return Err(self.at(channel, &reason));
        }
        if self.data.body_frame.is_none() {
            self.data.body_frame = Some(header.frame_id.to_string());
        }
        let line = self.channels[channel].count;
        // Checked as a row of poses.csv is; the quaternion in ROS order here.
        let pose = BodyPose::new(position, [q.w, q.x, q.y, q.z], line).map_err(|(column, reason)| {
            let reason = match column {
                "qw" => format!(
                    "the orientation (x y z w) {} {} {} {} has norm {}, not 1: not a unit quaternion",
                    q.x,
                    q.y,
                    q.z,
                    q.w,
                    crate::io::files::number((q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt())
                ),
                axis => format!("the position's {}: {reason}", &axis[..1]),
            };
            self.at(channel, &reason)
        })?;
        let time_s = self.seconds(header.stamp, log_ns).map_err(|r| self.at(channel, &r))?;
        advance(&mut self.body_last_s, time_s, true).map_err(|r| self.at(channel, &format!("the body's {r}")))?;
        self.data.bodies.push(BodyCapture { time_s, pose });
        Ok(())
    }

    /// What to map for a rigid body the bag seems to hold on a topic not read: `; ` and a
    /// suggestion per such topic, or nothing.
    fn body_hint(&self) -> String {
        let mut hints = Vec::new();
        for c in self.channels.iter().filter(|c| c.role == Role::Ignored) {
            let topic = &c.topic;
            if POSE_STAMPED.names(&c.schema) || TRANSFORM_STAMPED.names(&c.schema) {
                hints.push(format!("`{topic}` holds {}: a rigid body, read with `body: {{topic: {topic}}}`", c.schema));
            } else if TF_MESSAGE.names(&c.schema) && topic != "/tf_static" {
                hints.push(format!(
                    "`{topic}` holds {}: read the body's frame with `body: {{tf: {topic}, child_frame: <its frame>}}`",
                    c.schema
                ));
            }
        }
        hints.iter().map(|h| format!("; {h}")).collect()
    }

    /// The joint topic and a marker or body topic were in the bag (with the body's frame, on `/tf`).
    fn check_topics(&self) -> Result<(), FileError> {
        let topics: Vec<&str> = self.channels.iter().map(|c| c.topic.as_str()).collect();
        let has = |role: Role| self.channels.iter().any(|c| c.role == role);
        let listed = || {
            let mut t = topics.clone();
            t.sort_unstable();
            t.join(", ")
        };
        if !has(Role::Joints) {
            let reason = format!(
                "no topic `{}` (sensor_msgs/msg/JointState) in the bag; its topics: {} — name the joint topic under `joints: topic` in {}",
                self.mapping.joints.topic,
                listed(),
                super::mapping::MAPPING_FILE
            );
            return Err(self.error(reason));
        }
        let file = super::mapping::MAPPING_FILE;
        let body = &self.mapping.body;
        let has_body = self.channels.iter().any(|c| c.role.is_body());
        if self.mapping.body_mapped && !has_body {
            let reason = format!(
                "no topic `{}` (the rigid body of `body` in {file}) in the bag; its topics: {}",
                body.topic(),
                listed()
            );
            return Err(self.error(reason + &self.body_hint()));
        }
        if !has(Role::Markers) && !has_body {
            let reason = format!(
                "no marker topic (`{}` or `/markers/<name>`, geometry_msgs/msg/PointStamped) nor rigid body (`{}`, geometry_msgs/msg/PoseStamped or TransformStamped) in the bag; its topics: {} — map them under `markers` or `body` in {file}",
                self.mapping.markers.topic,
                body.topic(),
                listed(),
            );
            return Err(self.error(reason + &self.body_hint()));
        }
        if let BodySource::Tf { topic, child_frame } = &body.source
            && has_body
            && self.data.bodies.is_empty()
        {
            let seen: Vec<&str> = self.child_frames.iter().map(String::as_str).collect();
            let reason = format!(
                "no transform to frame `{child_frame}` on `{topic}` (`body: child_frame` in {file}); its child frames: {}",
                if seen.is_empty() { "none".to_string() } else { seen.join(", ") }
            );
            return Err(self.error(reason));
        }
        Ok(())
    }
}
