//! Sessions seen through their cameras' pixels: `pixels.csv` with the rig in `cameras.yaml`
//! (Kalibr's camchain), static and free-motion.
//!
//! The facts checked are independent of the reader: pixels made here by projecting known points
//! through a known rig ([`Rig::project`]) and written by hand, read back exactly and triangulated
//! back onto the points; a camchain written by PyYAML (`tests/data/camchain/make_camchain.py`)
//! read with the numbers that script wrote; write → read round trips; and each bad input refused
//! at its file and line, computed from the text that breaks it.

use std::path::Path;

#[path = "common/outside_tool.rs"]
mod outside_tool;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector2, Vector3};
use spmcal::dataset::Session;
use spmcal::model::{DistortionModel, Lens, Rig, RigCamera};

const MARKERS: [&str; 4] = ["m1", "m2", "m3", "m4"];

/// A stereo rig: two cameras 0.12 m apart (the second turned by about 3°), each with its own
/// radial-tangential distortion.
fn rig() -> Rig {
    let lens = |intrinsics, distortion| Lens {
        intrinsics,
        distortion_model: DistortionModel::Radtan,
        distortion,
        resolution: [1280, 800],
    };
    let second = Isometry3::from_parts(
        Translation3::new(-0.12, 0.0, 0.0),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.004, 0.05, -0.002)),
    );
    Rig {
        cameras: vec![
            RigCamera {
                name: "cam0".into(),
                lens: lens([905.5, 903.25, 641.2, 398.7], [-0.12, 0.05, 0.001, -0.002]),
                from_previous: Isometry3::identity(),
            },
            RigCamera {
                name: "cam1".into(),
                lens: lens([899.75, 901.0, 636.4, 402.1], [-0.1, 0.03, -0.0015, 0.0008]),
                from_previous: second,
            },
        ],
    }
}

/// Marker `k`'s point (cam0's frame, m) at pose `i`: the nominal wrist's markers turned by 0.1 rad
/// per pose about a tilted axis, 0.7 m in front of the camera.
fn point(i: usize, k: usize) -> Vector3<f64> {
    let markers = [[0.0, 0.075, 0.06], [-0.065, -0.0375, 0.06], [0.065, -0.0375, 0.06], [0.0, 0.0, 0.22]];
    let turn = UnitQuaternion::from_scaled_axis(Vector3::new(0.6, 0.8, 0.0) * (0.1 * i as f64));
    Vector3::new(0.02, -0.01, 0.7) + turn * Vector3::from(markers[k])
}

fn pixel(rig: &Rig, camera: usize, y: &Vector3<f64>) -> Vector2<f64> {
    rig.project(camera, y).expect("in front of the camera").lens.pixel
}

/// The camchain of `rig` written here, in Kalibr's layout (block lists), independently of
/// spmcal's writer; numbers as Rust writes them (the shortest text that reads back).
fn kalibr_text(rig: &Rig) -> String {
    let list = |v: &[f64]| v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ");
    let mut out = String::new();
    for (k, camera) in rig.cameras.iter().enumerate() {
        out += &format!("cam{k}:\n");
        if k > 0 {
            out += "  T_cn_cnm1:\n";
            let m = camera.from_previous.to_homogeneous();
            for r in 0..4 {
                out += &format!("  - [{}]\n", list(&[m[(r, 0)], m[(r, 1)], m[(r, 2)], m[(r, 3)]]));
            }
        }
        let lens = &camera.lens;
        out += &format!(
            "  camera_model: pinhole\n  intrinsics: [{}]\n  distortion_model: radtan\n  distortion_coeffs: [{}]\n  resolution: [{}, {}]\n  rostopic: /cam{k}/image_raw\n",
            list(&lens.intrinsics),
            list(&lens.distortion),
            lens.resolution[0],
            lens.resolution[1]
        );
    }
    out
}

fn session_yaml() -> String {
    let model = std::fs::canonicalize("models/agile_wrist.urdf").unwrap();
    format!("name: pixels\nmodel: {}\nmarkers: [m1, m2, m3, m4]\n", model.display())
}

/// The pixel rows of one capture (`at`: its pose or time, as written): every marker seen by both
/// cameras, except — when `one_camera` — by cam0 alone.
fn rows(rig: &Rig, at: &str, i: usize, one_camera: bool) -> String {
    let mut out = String::new();
    for (k, name) in MARKERS.iter().enumerate() {
        for c in 0..if one_camera { 1 } else { 2 } {
            let p = pixel(rig, c, &point(i, k));
            out += &format!("{at},{name},cam{c},{:?},{:?}\n", p.x, p.y);
        }
    }
    out
}

/// A static pixel session of four poses: pose 2 seen by cam0 only, pose 3's `m4` by cam1 only
/// and its `m3` by neither.
fn static_files(rig: &Rig) -> Vec<(&'static str, String)> {
    let mut joints = String::from("pose,theta1_rad,theta2_rad,theta3_rad\n");
    let mut pixels = String::from("pose,marker,camera,u_px,v_px\n");
    for i in 0..4 {
        joints += &format!("{i},{},{},{}\n", 0.1 * i as f64, -0.05 * i as f64, 0.02);
        match i {
            3 => {
                for (k, c) in [(0, 0), (0, 1), (1, 0), (1, 1), (3, 1)] {
                    let p = pixel(rig, c, &point(i, k));
                    pixels += &format!("3,{},cam{c},{:?},{:?}\n", MARKERS[k], p.x, p.y);
                }
            }
            _ => pixels += &rows(rig, &i.to_string(), i, i == 2),
        }
    }
    vec![
        ("session.yaml", session_yaml()),
        ("joints.csv", joints),
        ("pixels.csv", pixels),
        ("cameras.yaml", kalibr_text(rig)),
    ]
}

fn write_folder(files: &[(&str, String)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    dir
}

/// Every number of a rig by its bits, with its names and resolutions: equal lists are bitwise equal rigs.
fn bits(rig: &Rig) -> Vec<String> {
    let mut out = Vec::new();
    for c in &rig.cameras {
        let q = c.from_previous.rotation.coords;
        let numbers = c
            .lens
            .intrinsics
            .iter()
            .chain(&c.lens.distortion)
            .chain(q.iter())
            .chain(c.from_previous.translation.vector.iter());
        out.push(format!("{} {:?} {:?}", c.name, c.lens.distortion_model, c.lens.resolution));
        out.extend(numbers.map(|x| format!("{:016x}", x.to_bits())));
    }
    out
}

/// The read rig against the one written: the lenses and translations bit for bit, each rotation
/// within a picoradian-scale grid step (the reader's canonical form: 2⁻⁴⁰ per quaternion
/// component, so at most about 1.6e-12 rad).
fn assert_same_rig(read: &Rig, written: &Rig) {
    assert_eq!(read.cameras.len(), written.cameras.len());
    for (a, b) in read.cameras.iter().zip(&written.cameras) {
        assert_eq!((&a.name, a.lens), (&b.name, b.lens));
        assert_eq!(a.from_previous.translation, b.from_previous.translation);
        let angle = a.from_previous.rotation.angle_to(&b.from_previous.rotation);
        assert!(angle < 2e-12, "{}: {angle:e} rad", a.name);
    }
}

#[test]
fn a_static_pixel_session_reads_back_its_pixels_exactly_and_triangulates_its_points() {
    let rig = rig();
    let files = static_files(&rig);
    let dir = write_folder(&files);
    let (session, warnings) = Session::load(dir.path(), None).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_same_rig(session.rig.as_deref().unwrap(), &rig);
    assert_eq!(session.poses.len(), 4);
    // The pixels exactly as written, each at its line.
    let text = &files[2].1;
    for (line, row) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = row.split(',').collect();
        let pose = &session.poses[f[0].parse::<usize>().unwrap()];
        let p = pose.pixels.iter().find(|p| p.line == line + 1).unwrap();
        assert_eq!(MARKERS[p.marker], f[1]);
        assert_eq!(format!("cam{}", p.camera), f[2]);
        assert_eq!(p.pixel, Vector2::new(f[3].parse().unwrap(), f[4].parse().unwrap()));
    }
    assert_eq!(session.poses.iter().map(|p| p.pixels.len()).sum::<usize>(), text.lines().count() - 1);
    // A marker seen by both cameras is triangulated where it is: the unprojection converges to
    // 1e-14, the canonical rotation moves a ray by at most 1.6e-12 rad (1.1e-12 m at 0.7 m), and
    // depth along a 0.12 m baseline at 0.7 m amplifies lateral errors about sixfold: 1e-11 m at
    // most; 1e-9 m leaves a margin of a hundred.
    for (i, pose) in session.poses.iter().enumerate() {
        for k in 0..4 {
            let both = i < 2 || (i == 3 && k < 2);
            match (both, pose.markers[k]) {
                (true, Some(m)) => {
                    let error = (m - point(i, k)).norm();
                    assert!(error < 1e-9, "pose {i} marker {k}: {error:e} m");
                    let first = pose.pixels.iter().filter(|p| p.marker == k).map(|p| p.line).min().unwrap();
                    assert_eq!(pose.marker_lines[k], first);
                }
                (false, None) => assert_eq!(pose.marker_lines[k], 0),
                (both, seen) => panic!("pose {i} marker {k}: seen by both cameras {both}, triangulated {seen:?}"),
            }
        }
    }
    // Pose 2, seen by one camera only, is data all the same: its pixels, no point.
    assert_eq!((session.poses[2].pixels.len(), session.poses[2].seen()), (4, 0));
}

/// Encoders at 1 kHz moving linearly for a second; pixels at 0.2, 0.4, 0.6 and 0.8 s on the
/// camera's clock, the frame at 0.6 s seen by cam0 only.
fn recording_files(rig: &Rig) -> Vec<(&'static str, String)> {
    let mut encoders = String::from("time_s,theta1_rad,theta2_rad,theta3_rad\n");
    for k in 0..=1000 {
        let t = k as f64 / 1000.0;
        encoders += &format!("{t},{},{},{}\n", 0.1 * t, -0.2 * t, 0.05 + 0.3 * t);
    }
    let mut pixels = String::from("time_s,marker,camera,u_px,v_px\n");
    for (i, time) in ["0.2", "0.4", "0.6", "0.8"].iter().enumerate() {
        pixels += &rows(rig, time, i, i == 2);
    }
    vec![
        ("session.yaml", session_yaml()),
        ("encoders.csv", encoders),
        ("pixels.csv", pixels),
        ("cameras.yaml", kalibr_text(rig)),
    ]
}

#[test]
fn a_pixel_recording_makes_one_pose_per_capture_time_with_its_pixels() {
    let rig = rig();
    let dir = write_folder(&recording_files(&rig));
    let (session, warnings) = Session::load(dir.path(), None).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let streams = session.streams.as_deref().unwrap();
    // The points of the three frames both cameras saw; the fourth has pixels only.
    assert_eq!(streams.capture_count(), 12);
    let (poses, warnings) = session.at_latency(0.04);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(poses.poses.len(), 4, "one pose per capture time, the one-camera frame too");
    for (i, pose) in poses.poses.iter().enumerate() {
        let t = 0.2 * (i + 1) as f64;
        assert_eq!(pose.time_s, Some([0.2, 0.4, 0.6, 0.8][i]));
        // Joints linear in time: the interpolation at t − 40 ms is exact to rounding.
        let expected = Vector3::new(0.1, -0.2, 0.3) * (t - 0.04) + Vector3::new(0.0, 0.0, 0.05);
        assert!((pose.joints - expected).amax() < 1e-12, "{i}: {}", pose.joints - expected);
        assert_eq!(pose.pixels.len(), if i == 2 { 4 } else { 8 });
        assert_eq!(pose.line, 2 + [0, 8, 16, 20][i], "the frame's first row of pixels.csv");
        for k in 0..4 {
            match pose.markers[k] {
                Some(m) => assert!((m - point(i, k)).norm() < 1e-9, "frame {i} marker {k}"),
                None => assert_eq!(i, 2, "frame {i} marker {k} not triangulated"),
            }
        }
    }
}

fn assert_same_poses(a: &Session, b: &Session) {
    assert_eq!(a.poses.len(), b.poses.len());
    for (p, q) in a.poses.iter().zip(&b.poses) {
        assert_eq!((p.id, p.joints, p.time_s, p.markers.clone()), (q.id, q.joints, q.time_s, q.markers.clone()));
        let pixels = |s: &spmcal::dataset::SessionPose| -> Vec<(usize, usize, Vector2<f64>)> {
            s.pixels.iter().map(|x| (x.marker, x.camera, x.pixel)).collect()
        };
        assert_eq!(pixels(p), pixels(q));
    }
}

#[test]
fn a_pixel_session_written_and_read_back_is_the_same_session() {
    let rig = rig();
    for files in [static_files(&rig), recording_files(&rig)] {
        let dir = write_folder(&files);
        let (session, _) = Session::load(dir.path(), None).unwrap();
        let out = tempfile::tempdir().unwrap();
        let copy = out.path().join("copy");
        session.write(&copy).unwrap();
        for name in ["pixels.csv", "cameras.yaml"] {
            assert!(copy.join(name).exists(), "{name}");
        }
        for name in ["markers.csv", "captures.csv"] {
            assert!(!copy.join(name).exists(), "{name}");
        }
        let (again, _) = Session::load(&copy, None).unwrap();
        assert_eq!(bits(again.rig.as_deref().unwrap()), bits(session.rig.as_deref().unwrap()));
        assert_same_poses(&again, &session);
        if session.streams.is_some() {
            assert_same_poses(&again.at_latency(0.03).0, &session.at_latency(0.03).0);
        }
        // The same session as points (its poses at latency 0) over it leaves no pixel file behind.
        let mut points = session.at_latency(0.0).0;
        (points.rig, points.streams) = (None, None);
        points.poses.iter_mut().for_each(|p| p.pixels.clear());
        points.write(&copy).unwrap();
        assert!(!copy.join("pixels.csv").exists() && !copy.join("cameras.yaml").exists());
        let (points_again, _) = Session::load(&copy, None).unwrap();
        assert!(points_again.rig.is_none());
    }
}

#[test]
fn a_camchain_written_by_spmcal_reads_back_identically() {
    // A rig made in memory comes back with its rotations in canonical form (within 1.6e-12 rad),
    // all else bit for bit; from then on, write → read is the identity, bit for bit, text and rig.
    let rig = rig();
    let dir = write_folder(&static_files(&rig));
    let (mut session, _) = Session::load(dir.path(), None).unwrap();
    session.rig = Some(std::sync::Arc::new(rig.clone()));
    let out = tempfile::tempdir().unwrap();
    let folder = |k: usize| out.path().join(format!("write{k}"));
    session.write(&folder(1)).unwrap();
    let (read, _) = Session::load(&folder(1), None).unwrap();
    assert_same_rig(read.rig.as_deref().unwrap(), &rig);
    read.write(&folder(2)).unwrap();
    let (again, _) = Session::load(&folder(2), None).unwrap();
    assert_eq!(bits(again.rig.as_deref().unwrap()), bits(read.rig.as_deref().unwrap()));
    again.write(&folder(3)).unwrap();
    let text = |k: usize| std::fs::read_to_string(folder(k).join("cameras.yaml")).unwrap();
    assert_eq!(text(3), text(2));
}

/// A camera's pose relative to the one before it: rotation vector (rad) and translation (m).
type Pose = (Vector3<f64>, Vector3<f64>);

/// The numbers `make_camchain.py` wrote, as Rust reads the same decimal text.
fn pyyaml_rig() -> [(Lens, Option<Pose>); 3] {
    let radtan = DistortionModel::Radtan;
    let lens = |intrinsics, distortion_model, distortion| Lens {
        intrinsics,
        distortion_model,
        distortion,
        resolution: [752, 480],
    };
    [
        (
            lens([458.654, 457.296, 367.215, 248.375], radtan, [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]),
            None,
        ),
        (
            lens([457.587, 456.134, 379.999, 255.238], radtan, [-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05]),
            Some((
                Vector3::new(0.0141, -0.0003, 0.0023),
                Vector3::new(-0.110073808127187, 0.000399121547014, -0.000853702503357),
            )),
        ),
        (
            lens([460.0, 459.5, 370.25, 250.75], DistortionModel::Equidistant, [0.01, -0.002, 1.0e-05, 0.0]),
            Some((Vector3::new(-0.02, 0.35, 0.001), Vector3::new(0.2, -0.01, 0.03))),
        ),
    ]
}

#[test]
fn a_camchain_written_by_pyyaml_in_kalibrs_layout_reads() {
    let fixture = std::fs::read_to_string("tests/data/camchain/kalibr_pyyaml.yaml").unwrap();
    let rig = rig();
    let mut files = static_files(&rig);
    files[3].1 = fixture;
    // Pixels inside its 752 × 480 images: the first pose's, shifted into them.
    files[2].1 = "pose,marker,camera,u_px,v_px\n0,m1,cam0,300.5,200.25\n0,m1,cam2,310.0,190.0\n".into();
    let dir = write_folder(&files);
    let (session, _) = Session::load(dir.path(), None).unwrap();
    let read = session.rig.as_deref().unwrap();
    assert_eq!(read.cameras.len(), 3);
    for (k, (camera, (lens, pose))) in read.cameras.iter().zip(pyyaml_rig()).enumerate() {
        assert_eq!((camera.name.clone(), camera.lens), (format!("cam{k}"), lens));
        // Each camera relative to the one before: Rodrigues' formula in Python against nalgebra's
        // exponential, both to rounding (1e-16), then the canonical form (1.6e-12 rad).
        let (rotation, translation) = pose.unwrap_or((Vector3::zeros(), Vector3::zeros()));
        assert_eq!(camera.from_previous.translation.vector, translation);
        let angle = camera.from_previous.rotation.angle_to(&UnitQuaternion::from_scaled_axis(rotation));
        assert!(angle < 2e-12, "cam{k}: {angle:e} rad");
    }
    // cam2 after cam1 after cam0: the chain composes.
    let expected = pyyaml_rig();
    let to = |k: usize| {
        let (r, t) = expected[k].1.unwrap();
        Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_scaled_axis(r))
    };
    let chained = to(2) * to(1);
    let composed = read.from_cam0(2);
    // The translation goes through cam1's rotation (1.6e-12 rad at 0.2 m: 3e-13 m).
    assert!((composed.translation.vector - chained.translation.vector).norm() < 1e-12);
    assert!(composed.rotation.angle_to(&chained.rotation) < 4e-12);
}

/// The 1-based line of `text` on which `needle` first occurs.
fn line_of(text: &str, needle: &str) -> usize {
    text[..text.find(needle).unwrap_or_else(|| panic!("{needle}"))].matches('\n').count() + 1
}

/// The error loading the static session with `file`'s text edited by `edit`.
fn refusal(file: &str, edit: impl Fn(&str) -> String) -> spmcal::io::FileError {
    let mut files = static_files(&rig());
    for (name, text) in files.iter_mut() {
        if *name == file {
            *text = edit(text);
        }
    }
    let dir = write_folder(&files);
    let e = Session::load(dir.path(), None).unwrap_err();
    assert_eq!(e.path, dir.path().join(file), "{e}");
    e
}

#[test]
fn each_bad_camchain_or_pixel_row_is_refused_at_its_file_and_line() {
    let cameras = kalibr_text(&rig());
    let pixels = &static_files(&rig())[2].1;
    let cam1 = line_of(&cameras, "cam1:");
    // (what is broken, in which file, the edit, the line it must name, the reason)
    type Edit = Box<dyn Fn(&str) -> String>;
    let cases: Vec<(&str, Edit, usize, &str)> = vec![
        (
            "cameras.yaml",
            Box::new(|t: &str| {
                let second = t.rfind("  intrinsics:").unwrap();
                let end = second + t[second..].find('\n').unwrap() + 1;
                format!("{}{}", &t[..second], &t[end..])
            }),
            cam1,
            "`cam1` has no `intrinsics`",
        ),
        (
            "cameras.yaml",
            Box::new(|t: &str| {
                // Scale the first row of the rotation by 1.01: no longer orthonormal.
                let row = t.find("  - [").unwrap() + 5;
                let end = row + t[row..].find(',').unwrap();
                let value: f64 = t[row..end].parse().unwrap();
                format!("{}{:?}{}", &t[..row], value * 1.01, &t[end..])
            }),
            line_of(&cameras, "T_cn_cnm1:"),
            "the rotation of `T_cn_cnm1` is not a rotation",
        ),
        (
            "cameras.yaml",
            Box::new(|t: &str| {
                t.replacen("  rostopic: /cam1/image_raw", "  rostopic: /cam1/image_raw\n  frame_rate: 20", 1)
            }),
            line_of(&cameras, "  rostopic: /cam1/image_raw") + 1,
            "unknown key `frame_rate` in `cam1`",
        ),
        (
            "cameras.yaml",
            Box::new(|t: &str| {
                let at = t.find("cam1:").unwrap();
                format!("{}{}", &t[..at], t[at..].replacen("distortion_model: radtan", "distortion_model: fisheye", 1))
            }),
            cam1 + line_of(&cameras[cameras.find("cam1:").unwrap()..], "distortion_model:") - 1,
            "distortion model `fisheye` is not one spmcal reads: `radtan`, `equidistant` or `none`",
        ),
        (
            "pixels.csv",
            Box::new(|t: &str| t.replacen(",m3,cam1,", ",m3,cam7,", 1)),
            line_of(pixels, ",m3,cam1,"),
            "camera `cam7` is not in cameras.yaml (cam0, cam1)",
        ),
        (
            // Pose 1's m2 seen by cam0 relabelled cam1: the repeat is the row after it.
            "pixels.csv",
            Box::new(|t: &str| t.replacen("\n1,m2,cam0,", "\n1,m2,cam1,", 1)),
            line_of(pixels, "\n1,m2,cam1,") + 1,
            "marker `m2` is seen twice by camera `cam1` at pose 1",
        ),
        (
            "pixels.csv",
            Box::new(|t: &str| {
                let lines = t.lines().map(|l| match l.strip_prefix("2,m4,cam0,") {
                    Some(rest) => format!("2,m4,cam0,1280.25,{}", rest.split(',').nth(1).unwrap()),
                    None => l.to_string(),
                });
                lines.map(|l| l + "\n").collect()
            }),
            line_of(pixels, "\n2,m4,cam0,") + 1,
            "u = 1280.25 px is outside camera `cam0`'s image",
        ),
    ];
    for (file, edit, line, reason) in cases {
        let e = refusal(file, &edit);
        assert_eq!(e.line, Some(line), "{e}");
        assert!(e.reason.contains(reason), "{e}");
    }
}

#[test]
fn points_beside_pixels_pixels_without_a_rig_and_one_camera_only() {
    let rig = rig();
    let mut files = static_files(&rig);
    files.push(("markers.csv", "pose,marker,x_m,y_m,z_m\n0,m1,0.0,0.0,0.7\n".into()));
    let dir = write_folder(&files);
    let e = Session::load(dir.path(), None).unwrap_err().to_string();
    assert!(e.contains("holds marker points (markers.csv) and pixels (pixels.csv)"), "{e}");
    let files = static_files(&rig);
    let dir = write_folder(&files[..3]);
    let e = Session::load(dir.path(), None).unwrap_err().to_string();
    assert!(e.contains("cameras.yaml: missing: pixels.csv names the cameras of a rig"), "{e}");
    // One camera only: valid data, no point triangulated.
    let one = Rig { cameras: rig.cameras[..1].to_vec() };
    let mut files = static_files(&rig);
    files[3].1 = kalibr_text(&one);
    files[2].1 = files[2].1.lines().filter(|l| !l.contains(",cam1,")).map(|l| format!("{l}\n")).collect();
    let dir = write_folder(&files);
    let (session, warnings) = Session::load(dir.path(), None).unwrap();
    assert!(warnings.is_empty());
    assert!(session.poses.iter().all(|p| p.seen() == 0 && !p.pixels.is_empty()));
    assert_eq!(session.rig.as_deref().unwrap().cameras.len(), 1);
}

/// A simulated session seen through a rig (0.3 px of pixel noise), written to files and read back,
/// calibrates at the pixel level exactly as the same session in memory: the files carry every
/// pixel and the rig the fit uses, bit for bit (the rig as the file holds it: its rotation in
/// canonical form).
#[test]
fn a_simulated_pixel_session_written_to_files_calibrates_as_in_memory() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let model = spmcal::model::RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap();
    let mut config = spmcal::sim::SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    (config.poses, config.camera.lateral_sigma_m, config.camera.depth_sigma_m) = (40, 0.0, 0.0);
    let (mut session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let rig = rig();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(34);
    let noise = Normal::new(0.0, 0.3).unwrap();
    for pose in &mut session.poses {
        let seen: Vec<(usize, Vector3<f64>)> =
            pose.markers.iter().enumerate().filter_map(|(k, m)| Some((k, (*m)?))).collect();
        for (k, y) in seen {
            for camera in 0..2 {
                let mut p = session_pixel(&rig, camera, &y);
                p.pixel += Vector2::new(noise.sample(&mut rng), noise.sample(&mut rng));
                pose.pixels.push(spmcal::dataset::SeenPixel { marker: k, ..p });
            }
        }
    }
    session.rig = Some(std::sync::Arc::new(rig));
    let out = tempfile::tempdir().unwrap();
    session.write(out.path()).unwrap();
    let (read, _) = Session::load(out.path(), None).unwrap();
    // In memory: the rig as the file holds it (its canonical rotation), the pixels as simulated.
    session.rig = read.rig.clone();
    let calibration_config = spmcal::calib::CalibConfig { folds: 0, ..Default::default() };
    // Every fitted number; the header's statistics aside, whose per-pose orientations come from
    // the points (here triangulated, in memory the simulator's).
    let fit = |s: &Session| {
        let parameters = spmcal::calib::calibrate(s, &model, &calibration_config, &mut |_| {}).unwrap().parameters;
        spmcal::model::Parameters { fit: None, ..parameters }
    };
    assert_eq!(fit(&read), fit(&session));
}

fn session_pixel(rig: &Rig, camera: usize, y: &Vector3<f64>) -> spmcal::dataset::SeenPixel {
    spmcal::dataset::SeenPixel { marker: 0, camera, pixel: pixel(rig, camera, y), line: 0 }
}

/// Kalibr reads camchains with PyYAML (YAML 1.1), to which `1e-7` is a string: every number of a
/// camchain spmcal writes must be, to PyYAML, a float (an integer for the resolution) of the very
/// value spmcal wrote — the value spmcal reads back (its text is the shortest that reads back).
#[test]
fn pyyaml_reads_every_number_of_a_camchain_spmcal_writes_as_spmcal_does() {
    let mut rig = rig();
    rig.cameras[0].lens.distortion = [-0.12, 1e-7, 7.3e-7, -2.5e-12];
    rig.cameras[1].lens.intrinsics = [1e3, 901.0, 636.4, 402.1];
    let dir = write_folder(&static_files(&rig));
    let (mut session, _) = Session::load(dir.path(), None).unwrap();
    session.rig = Some(std::sync::Arc::new(rig));
    let out = tempfile::tempdir().unwrap();
    session.write(out.path()).unwrap();
    let script = format!(
        r#"
import yaml
chain = yaml.safe_load(open({:?}))
for name in sorted(chain, key=lambda n: int(n[3:])):
    cam = chain[name]
    rows = [cam["intrinsics"], cam["distortion_coeffs"]] + cam.get("T_cn_cnm1", [])
    print(" ".join(type(x).__name__ + ":" + repr(x) for row in rows for x in row))
    print(" ".join(type(x).__name__ + ":" + repr(x) for x in cam["resolution"]))
"#,
        out.path().join("cameras.yaml").display().to_string()
    );
    let output = match std::process::Command::new("python3").arg("-c").arg(&script).output() {
        Ok(o) if String::from_utf8_lossy(&o.stderr).contains("No module named 'yaml'") => {
            return outside_tool::missing("Python's PyYAML", "pip install pyyaml");
        }
        Ok(o) => o,
        Err(_) => return outside_tool::missing("python3", "install Python 3 with pip install pyyaml"),
    };
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let text = String::from_utf8(output.stdout).unwrap();
    let mut lines = text.lines();
    for camera in &session.rig.as_deref().unwrap().cameras {
        let m = camera.from_previous.to_homogeneous();
        let mut numbers: Vec<f64> = camera.lens.intrinsics.iter().chain(&camera.lens.distortion).copied().collect();
        if camera.name != "cam0" {
            numbers.extend((0..4).flat_map(|r| (0..4).map(move |c| m[(r, c)])));
        }
        let floats: Vec<f64> = lines
            .next()
            .unwrap()
            .split(' ')
            .map(|f| {
                f.strip_prefix("float:").unwrap_or_else(|| panic!("{}: `{f}` is not a float to PyYAML", camera.name))
            })
            .map(|f| f.parse().unwrap())
            .collect();
        assert_eq!(
            floats.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            numbers.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        let resolution = camera.lens.resolution.map(|n| format!("int:{n}")).join(" ");
        assert_eq!(lines.next(), Some(resolution.as_str()));
    }
}

/// `convert --points` writes a pixel session's triangulated points — as a session folder, or as a
/// bag, which carries points only (without `--points` the bag is refused, saying so): the points
/// read back are the ones the rig triangulates.
#[test]
fn convert_writes_a_pixel_sessions_triangulated_points_as_a_folder_or_a_bag() {
    let dir = tempfile::tempdir().unwrap();
    let dataset = "datasets/agile_wrist_stereo_200";
    let convert = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_spmcal"))
            .args(["convert", "--dataset", dataset])
            .args(extra)
            .output()
            .unwrap()
    };
    let bag = dir.path().join("points.mcap");
    let refused = convert(&["--to-bag", bag.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && stderr.contains("--points") && !bag.exists(), "{stderr}");
    let folder = dir.path().join("points");
    for extra in [["--out", folder.to_str().unwrap()], ["--to-bag", bag.to_str().unwrap()]] {
        let run = convert(&[extra[0], extra[1], "--points"]);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    }
    let (pixels, _) = Session::load(Path::new(dataset), None).unwrap();
    let expected = pixels.as_points();
    assert!(expected.rig.is_none() && expected.poses.iter().all(|p| p.pixels.is_empty()));
    for path in [&folder, &bag] {
        let (points, _) = Session::load(path, None).unwrap();
        assert!(points.rig.is_none(), "{}", path.display());
        assert_eq!(points.poses.len(), expected.poses.len(), "{}", path.display());
        for (a, b) in points.poses.iter().zip(&expected.poses) {
            assert_eq!(a.joints, b.joints);
            for (m, n) in a.markers.iter().zip(&b.markers) {
                match (m, n) {
                    // Written with 9 significant digits: within a nanometre.
                    (Some(m), Some(n)) => assert!((m - n).norm() < 1e-9, "{m} {n}"),
                    _ => assert_eq!(m.is_some(), n.is_some()),
                }
            }
        }
    }
}

/// `compare` on a pixel session gives each set in degrees and in pixels; through the rig the
/// calibration refined (`--cameras`, from `--cameras-out`) the calibrated parameters reproject at
/// the pixel noise, through the session's miscalibrated file well above it.
#[test]
fn compare_measures_a_pixel_session_in_pixels_through_the_rig_it_is_given() {
    let dir = tempfile::tempdir().unwrap();
    let dataset = "datasets/agile_wrist_stereo_200";
    let (params, cameras) = (dir.path().join("p.yaml"), dir.path().join("cameras.yaml"));
    let spmcal = || std::process::Command::new(env!("CARGO_BIN_EXE_spmcal"));
    let run = spmcal()
        .args(["calibrate", "--dataset", dataset, "--json", "--out"])
        .arg(&params)
        .arg("--cameras-out")
        .arg(&cameras)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    // σ per coordinate of each camera: a pixel's expected error norm is √2 σ.
    let noise: Vec<f64> = report["results"]["markers"]["rig"]["pixel_noise_px"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n[1].as_f64().unwrap())
        .collect();
    let per_pixel = (2.0 * noise.iter().map(|s| s * s).sum::<f64>() / noise.len() as f64).sqrt();
    let compare = |extra: &[&std::ffi::OsStr]| -> Vec<(String, String, f64)> {
        let run = spmcal()
            .args(["compare", "--dataset", dataset, "--json", "--params"])
            .arg(&params)
            .args(extra)
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
        json["results"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                (c["label"].as_str().unwrap().into(), c["unit"].as_str().unwrap().into(), c["rms"].as_f64().unwrap())
            })
            .collect()
    };
    let px = |rows: &[(String, String, f64)], label: &str| {
        rows.iter().find(|(l, u, _)| l == label && u == "px").map(|r| r.2).unwrap()
    };
    let file = compare(&[]);
    let refined = compare(&["--cameras".as_ref(), cameras.as_os_str()]);
    for rows in [&file, &refined] {
        let units: Vec<&str> = rows.iter().map(|(_, u, _)| u.as_str()).collect();
        assert_eq!(units, ["deg", "px", "deg", "px"], "nominal and calibrated, each in degrees and pixels");
    }
    // Through the refined rig the residual is the noise (the fit's own figure: 200 poses of ~8
    // pixels, the RMS within a few percent of √2 σ; 15 % allows the fit's degrees of freedom and
    // the Huber weights); through the file's, the file's errors show (measured 4.2 px).
    let calibrated = px(&refined, "calibrated");
    assert!((calibrated / per_pixel - 1.0).abs() < 0.15, "{calibrated} px against {per_pixel} px of noise");
    assert!(px(&file, "calibrated") > 5.0 * calibrated, "{file:?}");
    assert!(px(&refined, "nominal") > 10.0 * calibrated, "{refined:?}");
    let points = spmcal()
        .args(["compare", "--dataset", "datasets/agile_wrist_sim_20", "--cameras"])
        .arg(&cameras)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&points.stderr);
    assert!(!points.status.success() && stderr.contains("session of points"), "{stderr}");
    // A camchain of other cameras, or of other image sizes, is refused, naming what differs.
    let text = std::fs::read_to_string(&cameras).unwrap();
    for (name, changed, says) in [
        (
            "one.yaml",
            text[..text.find("cam1:").unwrap()].to_string(),
            "its cameras (cam0) are not the session's (cam0, cam1",
        ),
        (
            "smaller.yaml",
            text.replacen("[1280, 800]", "[640, 400]", 1),
            "camera `cam0`'s image is 640 × 400 pixels in it, 1280 × 800",
        ),
    ] {
        assert_ne!(changed, text, "{name} differs");
        let other = cameras.with_file_name(name);
        std::fs::write(&other, changed).unwrap();
        let run = spmcal()
            .args(["compare", "--dataset", dataset, "--params"])
            .arg(&params)
            .arg("--cameras")
            .arg(&other)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && stderr.contains(says) && stderr.contains(name), "{stderr}");
    }
}
