//! A fixture for tests/architecture.rs: the import forms of the tree before issue 33, in miniature.
pub mod calib;
mod report;
pub mod record;

/// Defined in lib.rs and imported from below: an arrow running back up.
pub struct Settings;
