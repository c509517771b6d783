//! The C interface from C: the committed header is cbindgen's, and `tests/track.c`, compiled by
//! the system C compiler against the static library, loads a parameters file, tracks 10,000
//! steps without one allocation (malloc/calloc/realloc wrapped and counted) and gives the same
//! orientations as `Spm::track` in Rust, bit for bit. Skips (saying so) without a C compiler.

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
}

/// A fresh folder under the system's temporary folder (no dependency for one directory).
fn tempfile_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("spmcal-c-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
