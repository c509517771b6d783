//! The C interface from C: the committed header is cbindgen's, and `tests/track.c`, compiled by
//! the system C compiler against the static library, loads a parameters file, tracks 10,000
//! steps without one allocation (malloc/calloc/realloc wrapped and counted). What each check of
//! its output shows:
//!
//! - **Bit for bit with `Spm::track`** (Rust, from the C program's own readings): the C
//!   interface passes the readings and the previous orientation through unchanged and returns
//!   what the library computes — no conversion, copy or ordering fault. It cannot catch a fault
//!   of the tracking itself: `spmcal_track` calls `Spm::track`, so both sides are the same code.
//! - **The readings are the program's trajectory** (recomputed here from its formula): the loop
//!   tracked the motion it was meant to, not, say, a reading left at zero.
//! - **IK of every tracked orientation gives the readings back to 1e-10 rad** (Rust's `Spm::ik`):
//!   an independent fact about the tracking. IK is closed-form per leg on the home branches and
//!   shares nothing with the tracking's Newton iteration on the loop closures; an orientation off
//!   the readings' pose (a lagging step, another assembly mode, a stalled iteration) does not give
//!   them back.
//!
//! Skips (saying so) without a C compiler.

use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "../../tests/common/outside_tool.rs"]
mod outside_tool;

use spmcal::math::so3;
use spmcal::model::Parameters;

#[test]
fn the_committed_header_is_the_generated_one() {
    let generated = include_str!(concat!(env!("OUT_DIR"), "/spmcal.h"));
    let committed = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("include/spmcal.h")).unwrap();
    assert!(committed == generated, "capi/include/spmcal.h is stale: copy it from {}", env!("OUT_DIR"));
}

/// The folder of the library's build outputs (`target/<profile>`), from this test's own path.
fn build_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent().and_then(Path::parent).unwrap().to_path_buf()
}

#[test]
fn a_c_program_tracks_ten_thousand_steps_without_allocating_and_matches_rust_bit_for_bit_on_both_mechanisms() {
    let compiler = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    if Command::new(&compiler).arg("--version").output().is_err() {
        return outside_tool::missing(&format!("a C compiler `{compiler}`"), "Debian: apt-get install gcc");
    }
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let library = build_dir().join("libspmcal_c.a");
    assert!(
        library.exists(),
        "{} not built: `cargo build --release -p spmcal-c` first (.ci/run does)",
        library.display()
    );
    let dir = tempfile_dir();
    let program = dir.join("track");
    let compiled = Command::new(&compiler)
        .args(["-std=c99", "-O2", "-Wall", "-Werror", "-I"])
        .arg(manifest.join("include"))
        .arg(manifest.join("tests/track.c"))
        .arg(&library)
        .args(["-Wl,--wrap=malloc", "-Wl,--wrap=calloc", "-Wl,--wrap=realloc", "-lm", "-lpthread", "-ldl", "-o"])
        .arg(&program)
        .output()
        .unwrap();
    assert!(compiled.status.success(), "{}", String::from_utf8_lossy(&compiled.stderr));
    // Both shipped mechanisms: the Agile Wrist (home on the negative branch) and Orbita3d (coaxial,
    // home on the positive branch): the branch signs travel in the parameters file.
    for truth in ["agile_wrist_sim_20", "orbita3d_sim_400"] {
        tracks_as_rust_does(&program, &manifest.join(format!("../datasets/{truth}/truth.yaml")));
    }
    // Joint scales travel in the parameters file too (`φ = sθ + δ`): the IK round trip below is
    // then on the scaled readings.
    tracks_as_rust_does(&program, &scaled_truth(manifest, "tracked"));
}

/// The 20-pose session's truth with joint scales off by +0.4 / −0.3 / +0.2 %, in a temporary file.
fn scaled_truth(manifest: &Path, name: &str) -> PathBuf {
    let mut params = Parameters::read(&manifest.join("../datasets/agile_wrist_sim_20/truth.yaml")).unwrap();
    for (g, s) in params.legs.iter_mut().zip([1.004, 0.997, 1.002]) {
        g.scale = s;
    }
    let path = tempfile_dir().join(format!("scaled_truth_{name}.yaml"));
    std::fs::write(&path, params.to_yaml()).unwrap();
    path
}

/// `spmcal_forward` and `spmcal_ik` of a model with joint scales are the library's (what the
/// command line's `fda` and `ik` print) bit for bit, and a scale changes the readings of a pose
/// by its factor.
#[test]
fn forward_and_ik_with_joint_scales_are_the_librarys() {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = scaled_truth(manifest, "forward");
    let spm = Parameters::read(&path).unwrap().spm().unwrap();
    let c_path = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    let mut model = std::ptr::null_mut();
    // SAFETY: a valid string and a pointer to write to.
    assert_eq!(unsafe { spmcal_c::spmcal_model_load(c_path.as_ptr(), &mut model) }, spmcal_c::SpmcalStatus::Ok);
    let unscaled =
        Parameters::read(&manifest.join("../datasets/agile_wrist_sim_20/truth.yaml")).unwrap().spm().unwrap();
    for omega in [[0.2, -0.1, 0.3], [-0.25, 0.15, -0.2], [0.05, 0.3, 0.1]] {
        let r = so3::exp(&nalgebra::Vector3::from(omega));
        let (mut joints, mut q) = ([0.0; 3], [0.0; 4]);
        let wxyz = so3::to_wxyz(&r);
        // SAFETY: a loaded model and arrays of the documented lengths.
        unsafe {
            assert_eq!(spmcal_c::spmcal_ik(model, wxyz.as_ptr(), joints.as_mut_ptr()), spmcal_c::SpmcalStatus::Ok);
            assert_eq!(spmcal_c::spmcal_forward(model, joints.as_ptr(), q.as_mut_ptr()), spmcal_c::SpmcalStatus::Ok);
        }
        // The rotation the C side reads back from the quaternion.
        let theta = spm.ik(&so3::from_wxyz(wxyz).unwrap()).unwrap();
        assert_eq!(joints.map(f64::to_bits), [theta[0], theta[1], theta[2]].map(f64::to_bits));
        assert_eq!(q.map(f64::to_bits), so3::to_wxyz(&spm.forward(&theta).unwrap()).map(f64::to_bits));
        assert!(so3::geodesic_angle(&so3::from_wxyz(q).unwrap(), &r) < 1e-12);
        let plain = unscaled.ik(&r).unwrap();
        for (i, s) in [1.004, 0.997, 1.002].iter().enumerate() {
            assert!((s * joints[i] - plain[i]).abs() < 1e-12, "leg {i}: {} vs {}", s * joints[i], plain[i]);
        }
    }
    // SAFETY: from `spmcal_model_load`, not used afterwards.
    unsafe { spmcal_c::spmcal_model_free(model) };
}

/// Run the compiled `program` on `parameters` and compare its every step with Rust's.
fn tracks_as_rust_does(program: &Path, parameters: &Path) {
    let run = Command::new(program).arg(parameters).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "exit {:?}: {stderr}", run.status.code());
    eprintln!("{stderr}");
    assert!(stderr.contains("allocations during 10000 tracking steps: 0"), "{stderr}");
    // The same loop in Rust, from the C program's own readings.
    let spm = Parameters::read(parameters).unwrap().spm().unwrap();
    let lines: Vec<Vec<f64>> = String::from_utf8(run.stdout)
        .unwrap()
        .lines()
        .map(|l| l.split(' ').map(|h| f64::from_bits(u64::from_str_radix(h, 16).unwrap())).collect())
        .collect();
    assert_eq!(lines.len(), 10_001);
    let joints = |l: &[f64]| nalgebra::Vector3::new(l[0], l[1], l[2]);
    let mut q = so3::to_wxyz(&spm.forward(&joints(&lines[0])).unwrap());
    assert_eq!(q.map(f64::to_bits), [lines[0][3], lines[0][4], lines[0][5], lines[0][6]].map(f64::to_bits));
    for (k, line) in lines[1..].iter().enumerate() {
        let previous = so3::from_wxyz(q).unwrap();
        q = so3::to_wxyz(&spm.track(&joints(line), &previous).unwrap());
        let from_c = [line[3], line[4], line[5], line[6]];
        assert_eq!(q.map(f64::to_bits), from_c.map(f64::to_bits), "step {}", k + 1);
    }
    // Independent of the tracking: the readings are track.c's trajectory (1 kHz), and the
    // closed-form IK of each orientation the C program tracked gives its readings back.
    let trajectory = |k: usize| {
        let t = k as f64 / 1000.0;
        [0.30 * (0.9 * t).sin(), 0.25 * (1.3 * t + 1.0).sin() - 0.21, 0.20 * (0.7 * t + 2.0).sin() - 0.18]
    };
    let (mut worst_reading, mut worst_ik, mut farthest) = (0.0f64, 0.0f64, 0.0f64);
    let start = so3::from_wxyz([lines[0][3], lines[0][4], lines[0][5], lines[0][6]]).unwrap();
    for (k, line) in lines.iter().enumerate() {
        let expected = trajectory(k);
        worst_reading = (0..3).map(|i| (line[i] - expected[i]).abs()).fold(worst_reading, f64::max);
        let r = so3::from_wxyz([line[3], line[4], line[5], line[6]]).unwrap();
        let back = spm.ik(&r).unwrap();
        worst_ik = (0..3).map(|i| wrap(back[i] - line[i]).abs()).fold(worst_ik, f64::max);
        farthest = farthest.max(so3::geodesic_angle(&r, &start));
    }
    eprintln!("readings off the trajectory by {worst_reading:.1e}; IK round trip {worst_ik:.1e} rad");
    assert!(worst_reading < 1e-12, "the C program's readings are not its trajectory: {worst_reading:e}");
    assert!(worst_ik < 1e-10, "IK of the tracked orientations misses the readings by {worst_ik:e} rad");
    // And the trajectory moves the platform (a check of a motionless loop would be void).
    assert!(farthest > 0.1, "the tracked orientations stay within {farthest} rad of the first");
}

/// An angle difference wrapped into (-π, π].
fn wrap(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    a - two_pi * (a / two_pi).round()
}

/// A fresh folder under the system's temporary folder (no dependency for one directory).
fn tempfile_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("spmcal-c-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
