//! Cross-checks with tools from outside the project (`check_urdf`, the Rerun CLI, a C compiler,
//! Python's `rosbags`, headless Chromium): where CI runs (`CI=true`) a missing tool fails the test — CI installs
//! them, so a green run means the check ran. Elsewhere the test is skipped, and says so where a
//! person looks: at once on the terminal (written past the test harness's output capture, which
//! hides what a passing test prints) and again at the end of `cargo test`, where the last test
//! target (`tests/zz_skipped_checks.rs`) lists every check skipped since it last ran.

// Each test target uses part of this file.
#![allow(dead_code)]

use std::io::Write;
use std::path::PathBuf;

/// Where skipped checks are recorded until the end-of-run summary lists them: one file per check,
/// in the build directory's scratch folder shared by every test target of the workspace.
pub fn skipped_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("skipped-checks")
}

/// Say that `tool` is missing (`install` says how to get it): panics under CI, else records and
/// prints why the check is skipped. The caller returns afterwards.
pub fn missing(tool: &str, install: &str) {
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{tool} is required where CI runs (CI=true): {install}");
    }
    // libtest runs each test on a thread named after it.
    let thread = std::thread::current();
    let check = format!("{}::{}", env!("CARGO_CRATE_NAME"), thread.name().unwrap_or("unnamed"));
    let line = format!("SKIPPED {check}: {tool} is not installed ({install}); this cross-check did not run");
    let dir = skipped_dir();
    // Best effort: a summary that cannot be recorded is still printed below.
    let _ = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(dir.join(format!("{check}.txt")), &line));
    // `eprintln!` would be captured (and hidden) for a passing test; the raw handle is not.
    let _ = writeln!(std::io::stderr().lock(), "\n{line}");
}
