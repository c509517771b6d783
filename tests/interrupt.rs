//! An interrupted run leaves nothing behind (issue 37): `calibrate` of a ten-minute recording with
//! three outputs (`--out`, `--rrd`, `--report`), interrupted by SIGINT and by SIGTERM once its
//! staged temporary files exist, exits 130 / 143 with one line and leaves its output folder empty.
#![cfg(unix)]

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

/// The entries of `dir`, hidden ones included.
fn entries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect()
}

#[test]
fn an_interrupted_calibration_leaves_nothing_and_says_so() {
    let work = tempfile::tempdir().unwrap();
    let mut sim = SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).unwrap();
    sim.recording.as_mut().unwrap().duration_s = 600.0;
    let model = RobotModel::load(&sim.model).unwrap();
    let recording = work.path().join("recording");
    sim.simulate(&model, &mut |_| {}).unwrap().0.write(&recording).unwrap();
    for (signal, code) in [("INT", 130), ("TERM", 143)] {
        let out = work.path().join(format!("out_{signal}"));
        std::fs::create_dir(&out).unwrap();
        let child = Command::new(env!("CARGO_BIN_EXE_spmcal"))
            .args(["calibrate", "--dataset", recording.to_str().unwrap()])
            .args(["--out", out.join("p.yaml").to_str().unwrap()])
            .args(["--rrd", out.join("r.rrd").to_str().unwrap()])
            .args(["--report", out.join("h.html").to_str().unwrap()])
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // The outputs are staged before any work: interrupt once their temporary files exist (a
        // calibration of ten minutes of recording takes about a second after that).
        let started = Instant::now();
        while entries(&out).len() < 3 && started.elapsed() < Duration::from_secs(20) {
            std::thread::sleep(Duration::from_millis(2));
        }
        assert_eq!(entries(&out).len(), 3, "the three outputs were not staged: {:?}", entries(&out));
        let kill = Command::new("kill").arg(format!("-{signal}")).arg(child.id().to_string()).status().unwrap();
        assert!(kill.success());
        let result = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(code), "SIG{signal}: {stderr}");
        assert!(stderr.contains(&format!("interrupted (SIG{signal})")), "{stderr}");
        assert!(entries(&out).is_empty(), "SIG{signal} left {:?}", entries(&out));
    }
}
