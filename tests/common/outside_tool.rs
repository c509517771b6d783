//! Cross-checks with tools from outside the project (`check_urdf`, the Rerun CLI, a C compiler):
//! where CI runs (`CI=true`) a missing tool fails the test — CI installs them, so a green run means
//! the check ran; elsewhere the test is skipped with a message that says so.

/// Say that `tool` is missing (`install` says how to get it): panics under CI, else prints why the
/// check is skipped. The caller returns afterwards.
pub fn missing(tool: &str, install: &str) {
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{tool} is required where CI runs (CI=true): {install}");
    }
    eprintln!("SKIPPED: {tool} is not installed ({install}); this cross-check did not run");
}
