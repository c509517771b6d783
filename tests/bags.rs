//! ROS 2 bags (issue 23): bags written here with the `mcap` crate and a CDR encoder of this file's
//! own (both byte orders, both marker layouts) calibrate exactly as the equivalent CSV sessions;
//! bad bags are refused naming the topic, the message and the reason; a bag written by Python's
//! `rosbags` (where installed) reads back.

use std::path::Path;

use spmcal::calib::{CalibConfig, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;

#[path = "common/outside_tool.rs"]
mod outside_tool;

#[path = "common/bag_writer.rs"]
mod bag_writer;
use bag_writer::{Message, joint_state, point, tmp, write_bag};

const MODEL: &str = "models/agile_wrist.urdf";

const NAMES: [&str; 3] = ["theta1", "theta2", "theta3"];

/// A static session as a bag: each pose's joints resting for 0.1 s (11 states), its markers at
/// the rest's start — on `/markers` by frame_id, or on `/markers/<name>` (`per_topic`).
fn static_bag(session: &Session, big: bool, per_topic: bool) -> Vec<Message> {
    let mut out = Vec::new();
    for pose in &session.poses {
        let t0 = (pose.time_s.unwrap() * 1e9).round() as u64 + 1_700_000_000_000_000_000;
        for k in 0..11u64 {
            let ns = t0 + k * 10_000_000;
            // Another joint first: the actuated ones are found by name.
            let names = ["gripper", NAMES[2], NAMES[0], NAMES[1]];
            let j = pose.joints;
            out.push(("/joint_states".into(), ns, joint_state(ns, &names, &[0.0, j[2], j[0], j[1]], big)));
        }
        for (m, p) in pose.markers.iter().enumerate() {
            if let Some(p) = p {
                let name = &session.markers[m];
                let (topic, frame) =
                    if per_topic { (format!("/markers/{name}"), "camera") } else { ("/markers".into(), name.as_str()) };
                out.push((topic, t0 + 1, point(t0, frame, [p.x, p.y, p.z], big)));
            }
        }
    }
    out
}

fn parameters(session: &Session) -> nalgebra::DVector<f64> {
    let model = RobotModel::load(Path::new(MODEL)).unwrap();
    calibrate(session, &model, &CalibConfig::default(), &mut |_| {}).unwrap().calibrated.x
}

#[test]
fn a_static_bag_calibrates_exactly_as_its_csv_session_in_either_byte_order_and_layout() {
    let (csv, _) = Session::load(Path::new("datasets/agile_wrist_sim_20"), None).unwrap();
    let expected = parameters(&csv);
    for (big, per_topic) in [(false, false), (true, true)] {
        let dir = tmp(&format!("static-{big}-{per_topic}"));
        let bag = dir.join("static.mcap");
        write_bag(&bag, &static_bag(&csv, big, per_topic), "cdr");
        let (session, warnings) = Session::load(&bag, Some(Path::new(MODEL))).unwrap();
        assert!(warnings.is_empty() && session.streams.is_none(), "a static session");
        assert_eq!(session.poses.len(), csv.poses.len());
        for (a, b) in session.poses.iter().zip(&csv.poses) {
            assert_eq!((a.joints, &a.markers), (b.joints, &b.markers));
        }
        assert_eq!(parameters(&session), expected, "big-endian {big}, a topic per marker {per_topic}");
    }
}

/// A static bag's marker is the median of its messages, on no line of any file: its flagged
/// observations name the pose and marker, never a "markers.csv line 0".
#[test]
fn a_static_bags_flagged_observation_names_its_pose_and_marker_without_a_line() {
    let (mut csv, _) = Session::load(Path::new("datasets/agile_wrist_sim_20"), None).unwrap();
    // A gross error on marker m2 of the first pose from the 8th that sees it: 5 cm, some hundred standard deviations.
    let seen = (7..csv.poses.len()).find(|&k| csv.poses[k].markers[1].is_some()).unwrap();
    *csv.poses[seen].markers[1].as_mut().unwrap() += nalgebra::Vector3::new(0.05, 0.0, 0.0);
    let bag = tmp("flagged").join("static.mcap");
    write_bag(&bag, &static_bag(&csv, false, false), "cdr");
    let (session, _) = Session::load(&bag, Some(Path::new(MODEL))).unwrap();
    let model = RobotModel::load(Path::new(MODEL)).unwrap();
    let fit = calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap();
    let flagged =
        fit.report.flagged.iter().find(|o| o.pose == session.poses[seen].id).expect("the gross error flagged");
    assert_eq!((flagged.marker.as_deref(), flagged.line), (Some("m2"), 0));
    let text = fit.report.to_string();
    let place = format!("pose {} marker m2:", session.poses[seen].id);
    assert!(text.contains(&place) && !text.contains("line 0"), "{text}");
    assert!(text.contains(&format!("excluded pose {} marker m2: gross error", session.poses[seen].id)), "{text}");
    let html = fit.html(&text);
    // The flagged table's line column: a dash.
    assert!(html.contains("markers.csv line</th>") && html.contains(">—</td>"), "a dash for the line");
}

#[test]
fn a_free_motion_bag_calibrates_exactly_as_the_csv_recording_of_the_same_numbers() {
    // The shipped recording's streams, stamped to the nanosecond; the CSV holds the same times.
    let dir = tmp("free");
    let source = Path::new("datasets/agile_wrist_free_motion_120s");
    let stamp = |t: f64| (t * 1e9).round() as u64;
    let seconds = |ns: u64| (ns / 1_000_000_000) as f64 + (ns % 1_000_000_000) as f64 * 1e-9;
    let mut messages = Vec::new();
    let (mut encoders, mut captures) =
        (String::from("time_s,theta1_rad,theta2_rad,theta3_rad\n"), String::from("time_s,marker,x_m,y_m,z_m\n"));
    for row in csv::Reader::from_path(source.join("encoders.csv")).unwrap().records() {
        let v: Vec<f64> = row.unwrap().iter().map(|x| x.parse().unwrap()).collect();
        let ns = stamp(v[0]);
        messages.push(("/joint_states".to_string(), ns, joint_state(ns, &NAMES, &v[1..], false)));
        encoders += &format!("{},{},{},{}\n", seconds(ns), v[1], v[2], v[3]);
    }
    for (k, row) in csv::Reader::from_path(source.join("captures.csv")).unwrap().records().enumerate() {
        let row = row.unwrap();
        let ns = stamp(row[0].parse().unwrap());
        let mut p: Vec<f64> = (2..5).map(|i| row[i].parse().unwrap()).collect();
        // One gross error (5 cm, hundreds of standard deviations) in both, for the reports below.
        if k == 500 {
            p[0] += 0.05;
        }
        messages.push(("/markers".to_string(), ns + 3_000_000, point(ns, &row[1], [p[0], p[1], p[2]], false)));
        captures += &format!("{},{},{},{},{}\n", seconds(ns), &row[1], p[0], p[1], p[2]);
    }
    messages.sort_by_key(|m| m.1);
    let bag = dir.join("free.mcap");
    write_bag(&bag, &messages, "cdr");
    let csv_dir = dir.join("csv");
    std::fs::create_dir_all(&csv_dir).unwrap();
    std::fs::write(csv_dir.join("encoders.csv"), encoders).unwrap();
    std::fs::write(csv_dir.join("captures.csv"), captures).unwrap();
    std::fs::write(csv_dir.join("session.yaml"), "name: free\nmarkers: [m1, m2, m3, m4]\n").unwrap();
    let model = Path::new(MODEL);
    let (from_bag, _) = Session::load(&bag, Some(model)).unwrap();
    let (from_csv, _) = Session::load(&csv_dir, Some(model)).unwrap();
    assert!(from_bag.streams.is_some(), "a free-motion recording");
    let same = |a: &spmcal::dataset::SessionPose, b: &spmcal::dataset::SessionPose| {
        (a.joints, a.time_s, &a.markers) == (b.joints, b.time_s, &b.markers)
    };
    assert_eq!(from_bag.poses.len(), from_csv.poses.len());
    assert!(from_bag.poses.iter().zip(&from_csv.poses).all(|(a, b)| same(a, b)), "the same poses");
    // Warnings name a capture by its message number on the marker topic (its CSV line less the
    // header), across the bag's many chunks (each repeats the channel).
    assert!(from_bag.poses.iter().zip(&from_csv.poses).all(|(a, b)| a.line + 1 == b.line), "message numbers");
    // Every parameter equal — the camera clock's rate among them (two minutes: estimated), its
    // entry the last, after the latency's.
    let (bag_x, csv_x) = (parameters(&from_bag), parameters(&from_csv));
    assert_eq!(bag_x, csv_x);
    let robot = RobotModel::load(Path::new(MODEL)).unwrap();
    let fit = calibrate(&from_bag, &robot, &CalibConfig::default(), &mut |_| {}).unwrap();
    let names: Vec<&str> = fit.parameterisation.entries.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names[names.len() - 2..], ["camera.latency", "camera.clock_rate"]);
    // The gross error is flagged in both; the CSV's report names its captures.csv line, the bag's
    // its pose and marker alone (a message is on no line of any file).
    let csv_fit = calibrate(&from_csv, &robot, &CalibConfig::default(), &mut |_| {}).unwrap();
    let (bag_text, csv_text) = (fit.report.to_string(), csv_fit.report.to_string());
    assert!(csv_text.contains("captures.csv line 502"), "{csv_text}");
    assert!(!bag_text.contains("captures.csv line") && !bag_text.contains("line 0"), "{bag_text}");
    let in_csv = csv_fit.report.flagged.iter().find(|o| o.line == 502).expect("the CSV's gross error flagged");
    let in_bag = fit.report.flagged.iter().find(|o| (o.pose, &o.marker) == (in_csv.pose, &in_csv.marker));
    assert_eq!(
        in_bag.map(|o| o.line),
        Some(0),
        "the bag's gross error flagged at the same pose and marker, without a line"
    );
    assert!(fit.report.markers.as_ref().unwrap().clock_rate_ppm.unwrap().std_error.is_some());
    // And `convert` both ways gives the bag's numbers back.
    let back = dir.join("back.mcap");
    from_bag.write_bag(&back).unwrap();
    let again = Session::load(&back, Some(model)).unwrap().0;
    assert!(
        again.poses.iter().zip(&from_bag.poses).all(|(a, b)| same(a, b)) && again.poses.len() == from_bag.poses.len()
    );
}

#[test]
fn a_split_bag_reads_its_files_in_order_and_their_clocks_must_follow() {
    let messages = small();
    let (first, second) = messages.split_at(messages.len() / 2);
    let dir = tmp("split");
    // By name `rec_10` sorts before `rec_2`; by number it follows.
    write_bag(&dir.join("rec_2.mcap"), first, "cdr");
    write_bag(&dir.join("rec_10.mcap"), second, "cdr");
    let (session, _) = Session::load(&dir, Some(Path::new(MODEL))).unwrap();
    let readings = messages.iter().filter(|m| m.0 == "/joint_states").count();
    assert_eq!(session.streams.as_ref().unwrap().encoder_count(), readings);
    let swapped = tmp("split-swapped");
    write_bag(&swapped.join("rec_1.mcap"), second, "cdr");
    write_bag(&swapped.join("rec_2.mcap"), first, "cdr");
    let e = Session::load(&swapped, Some(Path::new(MODEL))).unwrap_err().to_string();
    assert!(e.contains("go back in time from one file of the bag to the next"), "{e}");
}

/// The error loading `messages` as a bag (with the encoding `encoding`).
fn refused(name: &str, messages: &[Message], encoding: &str) -> String {
    let dir = tmp(name);
    let bag = dir.join("bad.mcap");
    write_bag(&bag, messages, encoding);
    Session::load(&bag, Some(Path::new(MODEL))).unwrap_err().to_string()
}

/// A small valid free-motion bag's messages (2 s at 100 Hz, one marker per 0.1 s frame).
fn small() -> Vec<Message> {
    let mut out = Vec::new();
    for k in 0..200u64 {
        let ns = k * 10_000_000;
        let t = k as f64 * 0.01;
        out.push(("/joint_states".into(), ns, joint_state(ns, &NAMES, &[0.1 * t, -0.05 * t, 0.02 * t], false)));
        if k % 10 == 5 {
            out.push((
                "/markers".into(),
                ns,
                point(ns, ["m1", "m2", "m3", "m4"][(k / 10 % 4) as usize], [0.01, 0.02, 0.7], false),
            ));
        }
    }
    out
}

#[test]
fn bad_bags_are_refused_naming_the_topic_the_message_and_the_reason() {
    assert!(
        Session::load(
            &{
                let dir = tmp("ok");
                let bag = dir.join("ok.mcap");
                write_bag(&bag, &small(), "cdr");
                bag
            },
            Some(Path::new(MODEL))
        )
        .is_ok()
    );
    let mut m = small();
    m[40].2 = joint_state(400_000_000, &["theta1", "theta3"], &[0.0, 0.0], false);
    let e = refused("missing-joint", &m, "cdr");
    assert!(e.contains("topic `/joint_states`, message") && e.contains("joint `theta2` is not in `name`"), "{e}");
    let mut m = small();
    m[3].2 = joint_state(30_000_000, &NAMES, &[0.0, f64::NAN, 0.0], false);
    let e = refused("nan", &m, "cdr");
    assert!(e.contains("topic `/joint_states`, message 4: joint `theta2` is at NaN"), "{e}");
    let mut m = small();
    m[10].2 = joint_state(5_000_000, &NAMES, &[0.0, 0.0, 0.0], false);
    let e = refused("backwards", &m, "cdr");
    assert!(e.contains("message 10") && e.contains("goes back"), "{e}");
    let e = refused("encoding", &small(), "json");
    assert!(e.contains("topic `/joint_states`: message encoding `json`"), "{e}");
    let m: Vec<Message> = small().into_iter().filter(|m| m.0 != "/markers").collect();
    let e = refused("no-markers", &m, "cdr");
    assert!(e.contains("no marker topic") && e.contains("/joint_states"), "{e}");
    let mut m = small();
    m[6].2.truncate(20);
    let e = refused("short", &m, "cdr");
    assert!(e.contains("topic `/markers`, message 1: geometry_msgs/msg/PointStamped does not decode"), "{e}");
    let mut m = small();
    m[6].2 = point(50_000_000, "m9", [0.0, 0.0, 0.7], false);
    let e = refused("frame", &m, "cdr");
    assert!(e.contains("header.frame_id `m9` names no marker"), "{e}");
    // A slow hand keeps the joints within 0.5 mrad for a few samples (40 ms here): still a
    // free-motion recording, not a static session of momentary rests.
    let slow: Vec<Message> = small()
        .into_iter()
        .map(|(topic, ns, data)| {
            if topic != "/joint_states" {
                return (topic, ns, data);
            }
            let t = ns as f64 * 1e-9;
            (topic, ns, joint_state(ns, &NAMES, &[0.01 * t, -0.005 * t, 0.002 * t], false))
        })
        .collect();
    let dir = tmp("slow");
    write_bag(&dir.join("slow.mcap"), &slow, "cdr");
    let (session, _) = Session::load(&dir.join("slow.mcap"), Some(Path::new(MODEL))).unwrap();
    assert!(session.streams.is_some(), "a slow free motion is a recording");
    // A truncated file.
    let dir = tmp("truncated");
    let bag = dir.join("cut.mcap");
    write_bag(&bag, &small(), "cdr");
    let bytes = std::fs::read(&bag).unwrap();
    std::fs::write(&bag, &bytes[..bytes.len() / 2]).unwrap();
    let e = Session::load(&bag, Some(Path::new(MODEL))).unwrap_err().to_string();
    assert!(e.contains("cut.mcap") && e.contains("truncated or corrupt"), "{e}");
}

#[test]
fn a_bag_written_by_pythons_rosbags_reads_back() {
    let dir = tmp("rosbags");
    let script = format!(
        r#"
from rosbags.rosbag2 import Writer, StoragePlugin
from rosbags.typesys import Stores, get_typestore
ts = get_typestore(Stores.ROS2_HUMBLE)
JS, PS = ts.types['sensor_msgs/msg/JointState'], ts.types['geometry_msgs/msg/PointStamped']
H, T, P = ts.types['std_msgs/msg/Header'], ts.types['builtin_interfaces/msg/Time'], ts.types['geometry_msgs/msg/Point']
import numpy as np
with Writer('{}', version=8, storage_plugin=StoragePlugin.MCAP) as w:
    j = w.add_connection('/joint_states', JS.__msgtype__, typestore=ts)
    m = w.add_connection('/markers', PS.__msgtype__, typestore=ts)
    for k in range(200):
        ns = k * 10_000_000
        h = H(stamp=T(sec=ns // 10**9, nanosec=ns % 10**9), frame_id='')
        msg = JS(header=h, name=['theta1', 'theta2', 'theta3'], position=np.array([0.001 * k, -0.0005 * k, 0.0002 * k]), velocity=np.array([], dtype=np.float64), effort=np.array([], dtype=np.float64))
        w.write(j, ns, ts.serialize_cdr(msg, JS.__msgtype__))
        if k % 10 == 5:
            h = H(stamp=T(sec=ns // 10**9, nanosec=ns % 10**9), frame_id='m' + str(1 + (k // 10) % 4))
            w.write(m, ns, ts.serialize_cdr(PS(header=h, point=P(x=0.01, y=0.02, z=0.7)), PS.__msgtype__))
"#,
        dir.join("bag").display()
    );
    let status = std::process::Command::new("python3").arg("-c").arg(&script).output();
    match status {
        Ok(o) if o.status.success() => {}
        Ok(o) if String::from_utf8_lossy(&o.stderr).contains("No module named 'rosbags'") => {
            return outside_tool::missing("Python's `rosbags`", "pip install rosbags");
        }
        Ok(o) => panic!("rosbags failed: {}", String::from_utf8_lossy(&o.stderr)),
        Err(_) => return outside_tool::missing("python3", "install Python 3 with pip install rosbags"),
    }
    let (session, _) = Session::load(&dir.join("bag"), Some(Path::new(MODEL))).unwrap();
    let streams = session.streams.as_ref().expect("a free-motion recording");
    assert_eq!((streams.encoder_count(), streams.capture_count()), (200, 20));
    assert!((session.poses[0].joints - nalgebra::Vector3::new(0.005, -0.0025, 0.001)).amax() < 1e-15);
}

/// The byte offsets of the records of an MCAP file (after its 8-byte magic) and their opcodes.
fn records(bytes: &[u8]) -> Vec<(usize, u8)> {
    let (mut at, mut out) = (8, Vec::new());
    while at + 9 <= bytes.len() {
        out.push((at, bytes[at]));
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        at += 9 + len;
    }
    out
}

/// A corrupt container is an error naming the file, whatever field the corruption hits: a record
/// length near 2⁶⁴ (which overflowed inside the MCAP reader), a chunk's uncompressed size far
/// beyond what a writer makes (an allocation of its size, or a decompression that never ended),
/// and one flipped byte of a chunk's compressed data (which read as a wrong joint angle).
#[test]
fn a_corrupt_bag_container_is_an_error_naming_the_file() {
    let dir = tmp("container");
    let good = dir.join("good.mcap");
    write_bag(&good, &small(), "cdr");
    let bytes = std::fs::read(&good).unwrap();
    let list = records(&bytes);
    let (header, chunk) = (list[0].0, list.iter().find(|r| r.1 == 0x06).unwrap().0);
    // A chunk: opcode, length, start and end times, then its uncompressed size.
    let uncompressed_size = chunk + 1 + 8 + 16;
    let corruptions: [(&str, usize, Vec<u8>); 4] = [
        ("header-length", header + 1, (u64::MAX - 8).to_le_bytes().to_vec()),
        ("chunk-length", chunk + 1, u64::MAX.to_le_bytes().to_vec()),
        ("chunk-size", uncompressed_size, (1u64 << 62).to_le_bytes().to_vec()),
        ("flipped", chunk + 80, vec![bytes[chunk + 80] ^ 0x10]),
    ];
    for (name, at, with) in corruptions {
        let mut bad = bytes.clone();
        bad[at..at + with.len()].copy_from_slice(&with);
        let bag = dir.join(format!("{name}.mcap"));
        std::fs::write(&bag, &bad).unwrap();
        let e = Session::load(&bag, Some(Path::new(MODEL))).unwrap_err().to_string();
        assert!(e.contains(&format!("{name}.mcap")) && e.contains("not a readable MCAP file"), "{name}: {e}");
    }
}

/// Two encoder times less than a nanosecond apart are two samples in `encoders.csv` but one stamp
/// in a bag, which would not read back: writing it is refused, saying why.
#[test]
fn a_recording_whose_encoder_times_share_a_nanosecond_is_not_written_as_a_bag() {
    let dir = tmp("same-ns");
    let source = Path::new("datasets/agile_wrist_free_motion_120s");
    for file in ["captures.csv", "session.yaml"] {
        std::fs::copy(source.join(file), dir.join(file)).unwrap();
    }
    let encoders = std::fs::read_to_string(source.join("encoders.csv")).unwrap();
    // The second sample 0.3 ns after the first (was 1 ms).
    let encoders = encoders.replacen("\n0.001,", "\n0.0000000003,", 1);
    std::fs::write(dir.join("encoders.csv"), encoders).unwrap();
    let (session, _) = Session::load(&dir, Some(Path::new(MODEL))).unwrap();
    let err = session.write_bag(&dir.join("out.mcap")).unwrap_err().to_string();
    assert!(
        err.contains("out.mcap") && err.contains("encoder samples 1 and 2") && err.contains("same nanosecond"),
        "{err}"
    );
    assert!(!dir.join("out.mcap").exists(), "nothing written");
}
