//! Opening any session: a session folder (CSV) or a ROS 2 bag, and writing one as a bag — the
//! one place that knows both readers.

use std::path::Path;

use super::bag;
use super::session::{Session, Warning};
use crate::io::files::FileError;

impl Session {
    /// Load and validate the session at `path` — a session folder, or a ROS 2 bag (an `.mcap`
    /// file or a bag folder, read with the `spmcal.yaml` mapping beside it); `model` overrides
    /// the one named in `session.yaml` (or the mapping).
    ///
    /// # Errors
    /// A [`FileError`] naming the file, line and column (or YAML key, or bag topic and message)
    /// of the first problem.
    pub fn load(path: &Path, model: Option<&Path>) -> Result<(Session, Vec<Warning>), FileError> {
        Session::load_with_progress(path, model, &mut |_, _| {})
    }

    /// [`Session::load`], with `progress` told the bytes of a bag read so far and its size.
    ///
    /// # Errors
    /// As [`Session::load`].
    pub fn load_with_progress(
        path: &Path,
        model: Option<&Path>,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(Session, Vec<Warning>), FileError> {
        if bag::is_bag(path) { bag::load(path, model, progress) } else { Session::load_folder(path, model) }
    }

    /// Write the session as a ROS 2 bag (one MCAP file at `path`, written atomically): joint
    /// states on `/joint_states` (`theta1..3`, rad), marker points on `/markers` named by
    /// `header.frame_id` — what [`Session::load`] reads back without a mapping file, to the
    /// nanosecond. A free-motion recording goes as its two streams; a static pose as the joints
    /// resting for 0.1 s with its markers, at its own time when the poses are 0.2 s apart or more,
    /// else at 0, 1, 2 … s (stations and the truth are not carried).
    ///
    /// # Errors
    /// A [`FileError`] when the session is seen through its pixels (a bag carries points), a time
    /// cannot be a ROS stamp (negative, or past 2038) or the file cannot be written.
    pub fn write_bag(&self, path: &Path) -> Result<(), FileError> {
        if self.rig.is_some() {
            // A bag carries marker points: the pixels (and the rig) would be lost without a word.
            let reason = "a session seen through its cameras' pixels cannot be written as a bag (a bag carries marker points): not written";
            return Err(FileError::new(path, reason));
        }
        bag::write(self, path)
    }
}
