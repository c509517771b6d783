//! What every command shares: its output files, written together after the work (so a failed run
//! changes no file), standard output, recordings and progress bars.

use std::path::Path;
use std::sync::Mutex;

use anyhow::Result;
use spmcal::FileError;
use spmcal::io::StagedFile;
use spmcal::record::{RecordingSummary, Scene};

/// The outputs of one command, reserved before the work and written together after it, so that a
/// failed run changes no existing file: every destination is checked first (not a folder, its
/// folder takes new files) by creating its temporary file; [`Outputs::commit`] renames them all
/// into place only when every one was written.
#[derive(Debug, Default)]
pub(crate) struct Outputs {
    staged: Vec<StagedFile>,
}

/// A reserved output of an [`Outputs`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Slot(usize);

impl Outputs {
    /// No outputs yet.
    pub(crate) fn new() -> Self {
        Outputs::default()
    }

    /// Reserve `path` as an output.
    ///
    /// # Errors
    /// `path` is a folder, is reserved twice, or its folder does not take a new file.
    pub(crate) fn reserve(&mut self, path: &Path) -> Result<Slot, FileError> {
        if self.staged.iter().any(|f| f.destination() == path) {
            return Err(FileError::new(path, "is given as two different outputs"));
        }
        self.staged.push(StagedFile::create(path)?);
        Ok(Slot(self.staged.len() - 1))
    }

    /// Write `contents` into the temporary file of `slot`.
    ///
    /// # Errors
    /// The write fails (e.g. the disk is full).
    pub(crate) fn write(&mut self, slot: Slot, contents: &[u8]) -> Result<(), FileError> {
        self.staged[slot.0].write(contents)
    }

    /// Put every output in place: all synced first, then all renamed over their destinations.
    ///
    /// # Errors
    /// Syncing or renaming fails; outputs renamed before the failure stay in place.
    pub(crate) fn commit(self) -> Result<(), FileError> {
        for file in &self.staged {
            file.sync()?;
        }
        for file in self.staged {
            file.persist()?;
        }
        Ok(())
    }
}

/// Print to standard output; a closed pipe is an error that `main` ends quietly on.
pub(crate) fn out(text: &str) -> Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    stdout.write_all(text.as_bytes())?;
    stdout.flush()?;
    Ok(())
}

/// Reserve an optional output before any work, so a failed run changes no file.
pub(crate) fn reserve(outputs: &mut Outputs, path: Option<&Path>) -> Result<Option<Slot>> {
    Ok(path.map(|p| outputs.reserve(p)).transpose()?)
}

/// The table goes to its `--out` file, else to standard output unless `--json` owns it.
pub(crate) fn table_to(outputs: &mut Outputs, slot: Option<Slot>, json: bool, table: &str) -> Result<()> {
    match slot {
        Some(slot) => outputs.write(slot, table.as_bytes())?,
        None if !json => out(table)?,
        None => {}
    }
    Ok(())
}

/// Write a recording into its reserved slot and say so on standard error.
pub(crate) fn record(outputs: &Outputs, slot: Slot, scene: &Scene) -> Result<RecordingSummary> {
    let file = &outputs.staged[slot.0];
    let summary = scene.write_staged(file.temp_path(), file.destination())?;
    eprintln!("recording: {} ({} poses, {} bytes)", summary.path.display(), summary.poses, summary.bytes);
    Ok(summary)
}

/// A progress bar on standard error for `total` steps (hidden when it is not a terminal).
pub(crate) fn progress_bar(total: usize, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    bar
}

/// The warnings and notes printed so far, for the `--json` envelope (which carries every one).
static SAID: Mutex<(Vec<String>, Vec<String>)> = Mutex::new((Vec::new(), Vec::new()));

/// Print a warning (`warning: …` on standard error) and keep it for the `--json` envelope.
pub(crate) fn warn(message: impl std::fmt::Display) {
    let message = message.to_string();
    eprintln!("warning: {message}");
    SAID.lock().unwrap_or_else(std::sync::PoisonError::into_inner).0.push(message);
}

/// Print a note (`note: …` on standard error: expected, harmless) and keep it for the envelope.
pub(crate) fn note(message: impl std::fmt::Display) {
    let message = message.to_string();
    eprintln!("note: {message}");
    SAID.lock().unwrap_or_else(std::sync::PoisonError::into_inner).1.push(message);
}

/// The warnings and notes [`warn`] and [`note`] printed so far.
pub(crate) fn said() -> (Vec<String>, Vec<String>) {
    SAID.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone()
}
