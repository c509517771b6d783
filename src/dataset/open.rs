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
        if bag::is_bag(path) {
            return bag::load(path, model, progress);
        }
        not_a_session(path).map_or_else(|| Session::load_folder(path, model), Err)
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

/// What a dataset path that is neither a bag nor a session folder is, said with what it takes.
fn not_a_session(path: &Path) -> Option<FileError> {
    const TAKES: &str = "a session is a folder with session.yaml, or a ROS 2 bag (an .mcap file or its folder)";
    let reason = if !path.exists() {
        format!("does not exist ({TAKES})")
    } else if path.is_file() {
        let name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        match path.extension().and_then(|x| x.to_str()) {
            Some("db3") => format!(
                "is a ROS 2 bag in SQLite, which spmcal does not read: convert it to MCAP (`ros2 bag convert`) ({TAKES})"
            ),
            _ if ["session.yaml", "joints.csv", "markers.csv", "captures.csv", "poses.csv", "pixels.csv"]
                .contains(&name.as_str()) =>
            {
                let folder = crate::io::files::parent_folder(path);
                format!("is a file of a session: give its folder, {}", folder.display())
            }
            _ => format!("is a file, not a session ({TAKES})"),
        }
    } else if !path.join("session.yaml").exists() {
        let inside: Vec<String> = std::fs::read_dir(path)
            .map(|d| {
                d.filter_map(Result::ok)
                    .filter(|e| e.path().join("session.yaml").exists() || bag::is_bag(&e.path()))
                    .map(|e| e.file_name().to_string_lossy().to_string())
                    .collect()
            })
            .unwrap_or_default();
        match inside.is_empty() {
            true => format!("is not a session: it has no session.yaml ({TAKES})"),
            false => {
                let mut names = inside;
                names.sort();
                format!("is not a session but holds sessions: {}; give one of them", names.join(", "))
            }
        }
    } else {
        return None;
    };
    Some(FileError::new(path, reason))
}
