//! Motion-capture rigid bodies in ROS 2 bags (issue 37): `PoseStamped`, `TransformStamped` and a
//! frame of `/tf` read, mapped by `body` in `spmcal.yaml`; every bad body bag or mapping refused
//! naming the file, the topic and message (or the key) and the reason; a simulated body session
//! written as a bag — by spmcal and by Python's `rosbags` (tests/data/bags/write_body_bag.py, as
//! vrpn_mocap, a TransformStamped bridge and `/tf` publish a body) — calibrates as its session
//! folder does: bit for bit from rosbags (the folder's own numbers), to the last digits from
//! spmcal's writer (its quaternions made from the rotation matrices).

use std::path::{Path, PathBuf};

use spmcal::calib::{CalibConfig, calibrate};
use spmcal::dataset::Session;
use spmcal::math::so3;
use spmcal::model::RobotModel;
use spmcal::sim::{RigidBodySettings, SimConfig};

#[path = "common/outside_tool.rs"]
mod outside_tool;

#[path = "common/bag_writer.rs"]
mod bag_writer;
use bag_writer::{BodyPose, Message, joint_state, pose_stamped, tf_message, tmp, transform_stamped, write_bag};

const MODEL: &str = "models/agile_wrist.urdf";
const NAMES: [&str; 3] = ["theta1", "theta2", "theta3"];

/// A body's pose at step `k` of [`small`]: near the camera, turning slowly about z.
fn pose_at(k: u64) -> BodyPose {
    let half = 0.001 * k as f64;
    ([0.01, 0.02, 0.7], [0.0, 0.0, half.sin(), half.cos()])
}

/// A small free-motion body bag's messages (2 s of joints at 100 Hz, the body at 10 Hz on
/// `topic`): `PoseStamped` on a pose topic, `TransformStamped` to `wrist` on `/mocap…`, or on
/// `/tf` the wrist beside another body, with the robot's frames in messages of their own.
fn small(topic: &str) -> Vec<Message> {
    let mut out = Vec::new();
    for k in 0..200u64 {
        let ns = k * 10_000_000;
        let t = k as f64 * 0.01;
        out.push(("/joint_states".into(), ns, joint_state(ns, &NAMES, &[0.1 * t, -0.05 * t, 0.02 * t], false)));
        if k % 10 == 5 {
            let data = if topic.starts_with("/tf") {
                let tray = ([0.3, -0.1, 0.02], [0.0, 0.0, 0.0, 1.0]);
                tf_message(&[(ns, "world", "tray", tray), (ns, "world", "wrist", pose_at(k))], false)
            } else if topic.starts_with("/mocap") {
                transform_stamped(ns, "world", "wrist", pose_at(k), false)
            } else {
                pose_stamped(ns, "world", pose_at(k), false)
            };
            out.push((topic.to_string(), ns, data));
            if topic.starts_with("/tf") {
                let link = ([0.0, 0.0, 0.1], [0.0, 0.0, 0.0, 1.0]);
                out.push((topic.to_string(), ns + 1, tf_message(&[(ns - 3_000_000, "base", "link1", link)], false)));
            }
        }
    }
    out
}

/// The bag of `messages` in a folder of its own, with `mapping` as its `spmcal.yaml` when given.
fn bag(name: &str, messages: &[Message], mapping: Option<&str>) -> PathBuf {
    let dir = tmp(&format!("body-{name}"));
    let bag = dir.join("rec.mcap");
    write_bag(&bag, messages, "cdr");
    if let Some(text) = mapping {
        std::fs::write(dir.join("spmcal.yaml"), text).unwrap();
    }
    bag
}

fn refused(name: &str, messages: &[Message], mapping: Option<&str>) -> String {
    Session::load(&bag(name, messages, mapping), Some(Path::new(MODEL))).unwrap_err().to_string()
}

#[test]
fn a_body_the_bag_holds_but_the_mapping_does_not_name_is_named_with_the_mapping_that_reads_it() {
    let e = refused("unmapped-pose", &small("/vrpn_mocap/wrist/pose"), None);
    assert!(e.contains("no marker topic") && e.contains("nor rigid body (`/body`"), "{e}");
    assert!(
        e.contains("`/vrpn_mocap/wrist/pose` holds geometry_msgs/msg/PoseStamped: a rigid body, read with `body: {topic: /vrpn_mocap/wrist/pose}`"),
        "{e}"
    );
    let e = refused("unmapped-tf", &small("/tf"), None);
    assert!(
        e.contains(
            "`/tf` holds tf2_msgs/msg/TFMessage: read the body's frame with `body: {tf: /tf, child_frame: <its frame>}`"
        ),
        "{e}"
    );
    // Mapped, but to a frame /tf does not carry: the frames it does carry are listed.
    let e = refused("tf-frame", &small("/tf"), Some("body: {child_frame: platform}\n"));
    assert!(
        e.contains("no transform to frame `platform` on `/tf`") && e.contains("its child frames: link1, tray, wrist"),
        "{e}"
    );
    // Mapped to a topic the bag does not have.
    let e = refused("missing", &small("/tf"), Some("body: {topic: /vrpn_mocap/wrist/pose}\n"));
    assert!(
        e.contains("no topic `/vrpn_mocap/wrist/pose` (the rigid body of `body`") && e.contains("`/tf` holds"),
        "{e}"
    );
}

#[test]
fn a_bad_body_mapping_is_refused_at_its_key() {
    let messages = small("/vrpn_mocap/wrist/pose");
    let e = refused("both", &messages, Some("clock: header\nbody:\n  topic: /a\n  tf: /tf\n"));
    assert!(e.contains("spmcal.yaml:2: column `body`: `body` names both `topic` and `tf`"), "{e}");
    let e = refused("neither", &messages, Some("body: {parent_frame: world}\n"));
    assert!(e.contains("`body` needs `topic`"), "{e}");
    let e = refused("unknown", &messages, Some("body: {topic: /a, child: wrist}\n"));
    assert!(e.contains("spmcal.yaml") && e.contains("unknown field `child`"), "{e}");
    let e = refused("empty", &messages, Some("body: {topic: ''}\n"));
    assert!(e.contains("empty topic or frame"), "{e}");
}

/// `messages` with the body's message at step 25 (the third) replaced by `data`.
fn with_third_pose(topic: &str, data: Vec<u8>) -> Vec<Message> {
    let mut m = small(topic);
    let at = m.iter().position(|x| x.0 == topic && x.1 == 250_000_000).unwrap();
    m[at].2 = data;
    m
}

#[test]
fn bad_body_messages_are_refused_naming_the_topic_the_message_and_the_reason() {
    let topic = "/vrpn_mocap/wrist/pose";
    let mapping = Some("body: {topic: /vrpn_mocap/wrist/pose}\n");
    let at = 250_000_000;
    let e = refused("frame", &with_third_pose(topic, pose_stamped(at, "camera", pose_at(25), false)), mapping);
    assert!(
        e.contains(
            "topic `/vrpn_mocap/wrist/pose`, message 3: header.frame_id is `camera`, not `world` (the first pose's)"
        ),
        "{e}"
    );
    let parent = Some("body: {topic: /vrpn_mocap/wrist/pose, parent_frame: mocap}\n");
    let e = refused("parent", &small(topic), parent);
    assert!(e.contains("message 1: header.frame_id is `world`, not `mocap` (`body: parent_frame`)"), "{e}");
    let long = ([0.01, 0.02, 0.7], [0.0, 0.0, 0.6, 0.81]);
    let e = refused("norm", &with_third_pose(topic, pose_stamped(at, "world", long, false)), mapping);
    assert!(
        e.contains("message 3: the orientation (x y z w) 0 0 0.6 0.81 has norm 1.008")
            && e.contains("not a unit quaternion"),
        "{e}"
    );
    let mm = ([10.0, 20.0, 700.0], [0.0, 0.0, 0.0, 1.0]);
    let e = refused("mm", &with_third_pose(topic, pose_stamped(at, "world", mm, false)), mapping);
    assert!(e.contains("message 3: the position") && e.contains("millimetres"), "{e}");
    let e =
        refused("back", &with_third_pose(topic, pose_stamped(at - 200_000_000, "world", pose_at(5), false)), mapping);
    assert!(e.contains("message 3: the body's clock goes back"), "{e}");
    let mut cut = small(topic);
    let third = cut.iter().position(|x| x.0 == topic && x.1 == at).unwrap();
    cut[third].2.truncate(40);
    let e = refused("short", &cut, mapping);
    assert!(e.contains("message 3: geometry_msgs/msg/PoseStamped does not decode"), "{e}");
    // A TransformStamped to another frame than the mapping's.
    let mocap = Some("body: {topic: /mocap/wrist, child_frame: platform}\n");
    let e = refused("child", &small("/mocap/wrist"), mocap);
    assert!(
        e.contains("topic `/mocap/wrist`, message 1: child_frame_id is `wrist`, not the body's frame `platform`"),
        "{e}"
    );
    // The body's topic carrying points: the schema says so.
    let mut points: Vec<Message> = small(topic).into_iter().filter(|m| m.0 == "/joint_states").collect();
    points.push(("/markers/m1".into(), 5, bag_writer::point(5, "camera", [0.0, 0.0, 0.7], false)));
    let e = refused("points", &points, Some("body: {topic: /markers/m1}\n"));
    assert!(
        e.contains(
            "topic `/markers/m1`: the schema is `geometry_msgs/msg/PointStamped`, not `geometry_msgs/msg/PoseStamped`"
        ),
        "{e}"
    );
    // On /tf the body's own stamps must increase; the robot's frames, stamped earlier, do not count.
    let tf = Some("body: {child_frame: wrist}\n");
    let wrist = |ns: u64| tf_message(&[(ns, "world", "wrist", pose_at(5))], false);
    let e = refused("tf-back", &with_third_pose("/tf", wrist(at - 200_000_000)), tf);
    assert!(e.contains("topic `/tf`, message 5: the body's clock goes back"), "{e}");
}

/// A simulated session of the default rigid body (0.3 mm, 0.1°), written to a folder and loaded
/// back from it (the session the bags must give exactly): `poses` static poses, or a free-motion
/// recording of `seconds` with its times on whole nanoseconds (a bag's stamps hold no finer).
fn folder_session(poses: usize, seconds: Option<f64>, seed: u64, dir: &Path) -> Session {
    let config_path = match seconds {
        Some(_) => "configs/simulate_agile_wrist_free_motion.yaml",
        None => "configs/simulate_agile_wrist.yaml",
    };
    let mut config = SimConfig::read(Path::new(config_path)).unwrap();
    (config.poses, config.seed) = (poses, seed);
    if let (Some(r), Some(s)) = (config.recording.as_mut(), seconds) {
        r.duration_s = s;
    }
    config.camera.rigid_body = Some(RigidBodySettings::default());
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    session.write(dir).unwrap();
    if seconds.is_some() {
        // Every time to the nanosecond, in the folder's own files.
        for file in ["encoders.csv", "poses.csv"] {
            let text = std::fs::read_to_string(dir.join(file)).unwrap();
            let mut lines = text.lines();
            let mut out = format!("{}\n", lines.next().unwrap());
            for line in lines {
                let (t, rest) = line.split_once(',').unwrap();
                out += &format!("{},{rest}\n", seconds_of(nanoseconds(t.parse().unwrap())));
            }
            std::fs::write(dir.join(file), out).unwrap();
        }
    }
    Session::load(dir, Some(Path::new(MODEL))).unwrap().0
}

fn nanoseconds(t: f64) -> u64 {
    (t * 1e9).round() as u64
}

fn seconds_of(ns: u64) -> f64 {
    (ns / 1_000_000_000) as f64 + (ns % 1_000_000_000) as f64 * 1e-9
}

/// The rows of the folder's `poses.csv` as [`write_body_bag.py`] takes them — `ns,x,y,z,qx,qy,qz,qw`,
/// the numbers as written (so that Python parses the same doubles) — and its joint states
/// (`ns,θ1,θ2,θ3`): a recording's encoders, or each static pose's joints resting for 0.1 s, its
/// body at the rest's start. Stamps from 1.7·10⁹ s after the epoch, as a real bag's.
fn tables(session: &Session, dir: &Path) -> (String, String) {
    const EPOCH: u64 = 1_700_000_000_000_000_000;
    let (mut joints, mut body) = (String::new(), String::new());
    let poses = std::fs::read_to_string(dir.join("poses.csv")).unwrap();
    let recording = session.streams.is_some();
    for (k, line) in poses.lines().skip(1).enumerate() {
        let v: Vec<&str> = line.split(',').collect();
        let ns = if recording {
            EPOCH + nanoseconds(v[0].parse().unwrap())
        } else {
            let pose = &session.poses[k];
            assert_eq!(pose.id.to_string(), v[0], "poses.csv in the session's order");
            let ns = EPOCH + nanoseconds(pose.time_s.unwrap());
            for step in 0..11u64 {
                let j = pose.joints;
                joints += &format!("{},{},{},{}\n", ns + step * 10_000_000, j[0], j[1], j[2]);
            }
            ns
        };
        body += &format!("{ns},{},{},{},{},{},{},{}\n", v[1], v[2], v[3], v[5], v[6], v[7], v[4]);
    }
    if recording {
        let encoders = std::fs::read_to_string(dir.join("encoders.csv")).unwrap();
        for line in encoders.lines().skip(1) {
            let (t, rest) = line.split_once(',').unwrap();
            joints += &format!("{},{rest}\n", EPOCH + nanoseconds(t.parse().unwrap()));
        }
    }
    (joints, body)
}

/// The bag Python's `rosbags` writes of `session` (folder `dir`) in `mode` (`pose`, `transform`,
/// `tf`), with the mapping that reads it; `None` when `rosbags` is missing (the check skipped).
fn rosbags_bag(session: &Session, dir: &Path, mode: &str) -> Option<PathBuf> {
    let out = tmp(&format!("rosbags-{mode}-{}", session.poses.len()));
    let (joints, body) = tables(session, dir);
    std::fs::write(out.join("joints.csv"), joints).unwrap();
    std::fs::write(out.join("body.csv"), body).unwrap();
    let bag = out.join("bag");
    let script = Path::new("tests/data/bags/write_body_bag.py");
    let run = std::process::Command::new("python3")
        .arg(script)
        .args([mode, &out.join("joints.csv").to_string_lossy(), &out.join("body.csv").to_string_lossy()])
        .arg(&bag)
        .output();
    match run {
        Ok(o) if o.status.success() => {}
        Ok(o) if String::from_utf8_lossy(&o.stderr).contains("No module named 'rosbags'") => {
            outside_tool::missing("Python's `rosbags`", "pip install rosbags");
            return None;
        }
        Ok(o) => panic!("write_body_bag.py failed: {}", String::from_utf8_lossy(&o.stderr)),
        Err(_) => {
            outside_tool::missing("python3", "install Python 3 with pip install rosbags");
            return None;
        }
    }
    let mapping = match mode {
        "pose" => "body: {topic: /vrpn_mocap/wrist/pose, parent_frame: world}\n",
        "transform" => "body: {topic: /mocap/wrist, child_frame: wrist}\n",
        _ => "body: {tf: /tf, child_frame: wrist, parent_frame: world}\n",
    };
    std::fs::write(bag.join("spmcal.yaml"), mapping).unwrap();
    Some(bag)
}

fn parameters(session: &Session) -> nalgebra::DVector<f64> {
    fit(session).calibrated.x
}

fn fit(session: &Session) -> spmcal::calib::Calibration {
    let model = RobotModel::load(Path::new(MODEL)).unwrap();
    let config = CalibConfig { folds: 0, ..CalibConfig::default() };
    calibrate(session, &model, &config, &mut |_| {}).unwrap()
}

/// The same poses: joints, times and the body's position bit for bit, its orientation bit for
/// bit too (`exact`) or within `ROUND_TRIP_RAD`.
fn assert_same_poses(a: &Session, b: &Session, exact: bool, what: &str) {
    assert_eq!(a.poses.len(), b.poses.len(), "{what}");
    for (p, q) in a.poses.iter().zip(&b.poses) {
        assert_eq!((p.joints, p.time_s), (q.joints, q.time_s), "{what}: pose {}", p.id);
        let (x, y) = (p.body.unwrap(), q.body.unwrap());
        assert_eq!(x.position, y.position, "{what}: pose {}", p.id);
        if exact {
            assert_eq!(x.rotation, y.rotation, "{what}: pose {}", p.id);
        } else {
            assert!(so3::geodesic_angle(&x.rotation, &y.rotation) < ROUND_TRIP_RAD, "{what}: pose {}", p.id);
        }
    }
}

/// spmcal's writer turns the body's rotation matrix into the message's quaternion, which the
/// reader turns back into a matrix: exact to a few ulps (1e-16 each), not to the bit — 1e-15 rad
/// holds them with room, and would catch a swapped component or a lost sign (radians).
const ROUND_TRIP_RAD: f64 = 1e-15;

/// Parameters after a round trip of `ROUND_TRIP_RAD` in every orientation. The fit stops when it
/// has proven the optimum within 1e-3 of a standard error (its Newton decrement) or when a full
/// step moves no parameter by more than `step_tolerance_deg` (1e-7° = 1.7e-9 rad, or m, or s), so
/// data that differ in their last bits may stop it anywhere within either: two fits agree within
/// 2e-3 σ plus that step, parameter by parameter (`expected`'s σ: the square root of its
/// covariance's diagonal; none for a parameter held at a bound) — a misread pose moves them by
/// far more.
fn assert_close(x: &nalgebra::DVector<f64>, expected: &spmcal::calib::Calibration, what: &str) {
    let step = CalibConfig::default().step_tolerance_deg.to_radians();
    for (k, (a, b)) in x.iter().zip(expected.calibrated.x.iter()).enumerate() {
        let sigma = expected.covariance[(k, k)].sqrt();
        assert!((a - b).abs() <= 2e-3 * sigma + step, "{what}: parameter {k} {a} against {b} (σ {sigma:e})");
    }
}

#[test]
fn a_static_body_bag_calibrates_exactly_as_its_folder_session() {
    let dir = tmp("static-folder");
    let folder = folder_session(30, None, 81, &dir.join("session"));
    let reference = fit(&folder);
    let expected = reference.calibrated.x.clone();
    let model = Some(Path::new(MODEL));
    // spmcal's own writer, read back without a mapping.
    let bag = dir.join("static.mcap");
    folder.write_bag(&bag).unwrap();
    let (session, warnings) = Session::load(&bag, model).unwrap();
    assert!(warnings.is_empty() && session.streams.is_none(), "a static session");
    assert_eq!(session.body, folder.body, "the body's name travels as the child frame");
    assert_same_poses(&session, &folder, false, "spmcal's bag");
    assert_close(&parameters(&session), &reference, "spmcal's bag");
    // And back to a folder: the same joints.
    let (back, again) = (dir.join("back"), dir.join("again"));
    session.write(&back).unwrap();
    folder.write(&again).unwrap();
    let read = |d: &Path, f: &str| std::fs::read_to_string(d.join(f)).unwrap();
    assert_eq!(read(&back, "joints.csv"), read(&again, "joints.csv"));
    // Python's rosbags, as vrpn_mocap, a TransformStamped bridge and /tf publish the body.
    for mode in ["pose", "transform", "tf"] {
        let Some(bag) = rosbags_bag(&folder, &dir.join("session"), mode) else { return };
        let (session, _) = Session::load(&bag, model).unwrap();
        assert!(session.streams.is_none(), "{mode}: a static session");
        assert_eq!(session.body.as_deref(), Some("wrist"), "{mode}");
        assert_same_poses(&session, &folder, true, mode);
        assert_eq!(parameters(&session), expected, "{mode}");
    }
}

#[test]
fn a_free_motion_body_bag_calibrates_exactly_as_its_folder_recording() {
    let dir = tmp("free-folder");
    let folder = folder_session(0, Some(5.0), 82, &dir.join("session"));
    let streams = folder.streams.as_ref().expect("a recording");
    let reference = fit(&folder);
    let expected = reference.calibrated.x.clone();
    let model = Some(Path::new(MODEL));
    let bag = dir.join("free.mcap");
    folder.write_bag(&bag).unwrap();
    let (session, _) = Session::load(&bag, model).unwrap();
    let from_bag = session.streams.as_ref().expect("a recording");
    assert_eq!(from_bag.encoder_count(), streams.encoder_count());
    // Times to the nanosecond, positions to the bit (lines are the message's number, not the CSV's).
    let poses = |s: &spmcal::dataset::Streams| -> Vec<_> { s.body_poses().map(|(t, b)| (t, b.position)).collect() };
    assert_eq!(poses(from_bag), poses(streams));
    assert_same_poses(&session, &folder, false, "spmcal's bag");
    assert_close(&parameters(&session), &reference, "spmcal's bag");
    for mode in ["pose", "tf"] {
        let Some(bag) = rosbags_bag(&folder, &dir.join("session"), mode) else { return };
        let (session, _) = Session::load(&bag, model).unwrap();
        assert!(session.streams.is_some(), "{mode}: a recording");
        assert_same_poses(&session, &folder, true, mode);
        assert_eq!(parameters(&session), expected, "{mode}");
    }
}

#[test]
fn the_cdr_bytes_the_unit_tests_decode_are_what_rosbags_writes() {
    // src/dataset/bag/messages.rs decodes tests/data/bags/rosbags_cdr.txt without Python; here
    // the file is checked against a fresh run of the script that made it.
    let run = std::process::Command::new("python3").arg("tests/data/bags/rosbags_cdr.py").output();
    let out = match run {
        Ok(o) if o.status.success() => o.stdout,
        Ok(o) if String::from_utf8_lossy(&o.stderr).contains("No module named 'rosbags'") => {
            return outside_tool::missing("Python's `rosbags`", "pip install rosbags");
        }
        Ok(o) => panic!("rosbags_cdr.py failed: {}", String::from_utf8_lossy(&o.stderr)),
        Err(_) => return outside_tool::missing("python3", "install Python 3 with pip install rosbags"),
    };
    let fixture = std::fs::read_to_string("tests/data/bags/rosbags_cdr.txt").unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), fixture);
}
