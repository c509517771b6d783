//! Reading a bag in one pass: MCAP records streamed through `mcap`'s sans-io reader (the file is
//! never held in memory, only the samples spmcal keeps), the two message types decoded from CDR,
//! each message checked where it stands (topic, message number, reason).

use std::collections::HashMap;
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{SendError, SyncSender};

use mcap::records::Record;
use mcap::sans_io::{LinearReadEvent, LinearReader};
use nalgebra::Vector3;

use super::mapping::{Clock, Mapping};
use super::messages::{JOINT_STATE, JointState, POINT_STAMPED, PointStamped, decode};
use crate::dataset::{Capture, EncoderSample};
use crate::io::files::FileError;

/// What a bag holds for spmcal, times in seconds from the whole second of its first message.
#[derive(Debug, Default)]
pub(crate) struct BagData {
    /// Joint samples, time strictly increasing.
    pub(crate) encoders: Vec<EncoderSample>,
    /// Marker captures in the order read (`line`: the message's number in the bag).
    pub(crate) captures: Vec<Capture>,
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
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Role {
    Joints,
    Markers,
    Ignored,
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
        let mut decoder = Decoder { mapping, markers, file, channels: Vec::new(), slots: vec![NONE; 1 << 16], data };
        std::thread::scope(|scope| {
            let (send, receive) = std::sync::mpsc::sync_channel::<Event>(4);
            let reading = scope.spawn(move || container.stream(&send));
            let decoded = decoder.consume(&receive, &mut |bytes| progress(done + bytes));
            // A decoding error drops the receiver, which stops the reader: its own error comes first
            // only when it ended the stream.
            drop(receive);
            let read = reading.join().expect("the reader does not panic");
            decoded.and(read)
        })?;
        done += std::fs::metadata(file).map_or(0, |m| m.len());
        decoder.check_topics()?;
        data = decoder.data;
    }
    Ok(data)
}

/// What the reading thread hands the decoding one.
enum Event {
    /// A channel of the bag (checked when it carries joints or markers).
    Channel { id: u16, topic: String, role: Role },
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
        let mut mcap = LinearReader::new();
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
                let role = self.role(&c.topic);
                if role != Role::Ignored {
                    self.check_channel(&state.schemas, &c.topic, role, c.schema_id, &c.message_encoding)?;
                }
                state.roles[usize::from(c.id)] = Some(role);
                send.send(Event::Channel { id: c.id, topic: c.topic, role })
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

    fn role(&self, topic: &str) -> Role {
        if topic == self.mapping.joints.topic {
            Role::Joints
        } else if self.mapping.carries_markers(topic, self.markers) {
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
        role: Role,
        schema_id: u16,
        encoding: &str,
    ) -> Result<(), FileError> {
        let expected = if role == Role::Joints { &JOINT_STATE } else { &POINT_STAMPED };
        if encoding != "cdr" {
            return Err(self.error(format!("topic `{topic}`: message encoding `{encoding}`; spmcal reads ROS 2 `cdr`")));
        }
        let Some((name, schema_encoding, text)) = schemas.get(&schema_id) else {
            return Err(self.error(format!("topic `{topic}`: no schema recorded; expected `{}`", expected.name)));
        };
        match expected.mismatch(name, schema_encoding, text) {
            Some(reason) => Err(self.error(format!("topic `{topic}`: {reason}"))),
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
                Event::Channel { id, topic, role } => {
                    self.slots[usize::from(id)] = self.channels.len() as u32;
                    self.channels.push(Channel { topic, role, count: 0, last_s: None });
                }
                Event::Messages(batch) => {
                    for (id, log_ns, range) in &batch.items {
                        let c = self.slots[usize::from(*id)] as usize;
                        self.channels[c].count += 1;
                        let data = &batch.bytes[range.clone()];
                        match self.channels[c].role {
                            Role::Joints => self.joint_state(c, *log_ns, data)?,
                            Role::Markers => self.point(c, *log_ns, data)?,
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
        if self.mapping.clock == Clock::Header && stamp.nanosec >= 1_000_000_000 {
            return Err(format!("header.stamp.nanosec is {}: not a time (at most 999,999,999)", stamp.nanosec));
        }
        let (sec, nanosec) = match self.mapping.clock {
            Clock::Header => (i64::from(stamp.sec), i64::from(stamp.nanosec)),
            Clock::Receive => ((log_ns / 1_000_000_000) as i64, (log_ns % 1_000_000_000) as i64),
        };
        let epoch = *self.data.epoch_s.get_or_insert(sec);
        let t = (sec - epoch) as f64 + nanosec as f64 * 1e-9;
        let c = &mut self.channels[channel];
        if let Some(last) = c.last_s
            && (t < last || (strict && t == last))
        {
            let what = if t == last { "repeats" } else { "goes back from" };
            return Err(format!("the clock {what} the previous message's ({t} s after {last} s)"));
        }
        c.last_s = Some(t);
        Ok(t)
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

    /// The joint topic and some marker topic were in the bag.
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
        if !has(Role::Markers) {
            let reason = format!(
                "no marker topic (`{}` or `/markers/<name>`, geometry_msgs/msg/PointStamped) in the bag; its topics: {} — map them under `markers` in {}",
                self.mapping.markers.topic,
                listed(),
                super::mapping::MAPPING_FILE
            );
            return Err(self.error(reason));
        }
        Ok(())
    }
}
