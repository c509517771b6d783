//! The end of `cargo test`: lists the outside-tool cross-checks that were skipped (their tool was
//! missing) since this summary last ran, so that a green run on a machine without the Rerun CLI,
//! `check_urdf`, a C compiler or Python's `rosbags` says what it did not check. Cargo runs the
//! integration test targets in the order of their names, so this one (`zz_…`) comes after every
//! other; only the library's few doc-tests follow it. Under `CI=true` a missing tool fails its
//! test instead (`tests/common/outside_tool.rs`), so CI never gets here with anything to list.

use std::io::Write;

#[path = "common/outside_tool.rs"]
mod outside_tool;

#[test]
fn summary_of_skipped_checks() {
    let dir = outside_tool::skipped_dir();
    let Ok(entries) = std::fs::read_dir(&dir) else { return };
    let mut records: Vec<_> =
        entries.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "txt")).collect();
    records.sort();
    if records.is_empty() {
        return;
    }
    let mut text = format!("\n==== {} cross-check(s) SKIPPED: their outside tool is missing ====\n", records.len());
    for path in &records {
        text.push_str(&std::fs::read_to_string(path).unwrap_or_default());
        text.push('\n');
        // Listed once: a later run that still lacks the tool records it again.
        let _ = std::fs::remove_file(path);
    }
    text.push_str("(CI runs with CI=true, where a missing tool fails its test; .ci/run installs them.)\n");
    // Past the harness's capture, which would hide the output of a passing test.
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}
