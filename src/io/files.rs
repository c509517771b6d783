//! File plumbing shared by every reader and writer: atomic writes and located errors.

use std::fmt;
use std::path::{Path, PathBuf};

/// An error in an input file, located as precisely as the format allows.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub struct FileError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// Column name (CSV) or field (YAML), when known.
    pub column: Option<String>,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if let Some(column) = &self.column {
            write!(f, ": column `{column}`")?;
        }
        write!(f, ": {}", self.reason)
    }
}

impl FileError {
    /// An error about `path` as a whole.
    pub fn new(path: &Path, reason: impl Into<String>) -> Self {
        FileError { path: path.to_path_buf(), line: None, column: None, reason: reason.into() }
    }

    /// Locate it at a 1-based line.
    pub fn at_line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }

    /// Locate it in a column (CSV) or field (YAML).
    pub fn in_column(mut self, column: impl Into<String>) -> Self {
        self.column = Some(column.into());
        self
    }

    /// A YAML error: serde_yaml gives line and column except for a missing field. Every setting
    /// of ours that takes one of several words is an enum of unit variants, which serde_yaml, given
    /// a list or a map, says wants "a YAML tag starting with '!'": a word is what it wants.
    pub(crate) fn from_yaml(path: &Path, e: &serde_yaml::Error) -> Self {
        let message = e.to_string().replace("expected a YAML tag starting with '!'", "expected one word (its value)");
        let err = FileError::new(path, message);
        match e.location() {
            Some(loc) => err.at_line(loc.line()),
            None => err,
        }
    }
}

/// Write `contents` to `path` atomically: a temporary file in the same folder, then a rename,
/// so that a reader never sees a half-written file and a failure leaves the old one intact.
///
/// # Errors
/// A [`FileError`] when the temporary file cannot be created, written or renamed.
#[cfg(feature = "full")]
pub(crate) fn write_atomic(path: &Path, contents: &[u8]) -> Result<(), FileError> {
    let mut file = StagedFile::create(path)?;
    file.write(contents)?;
    file.commit()
}

/// A file written atomically: a temporary file beside its destination, renamed over it by
/// [`StagedFile::commit`], so that a reader never sees a half-written file and a failure leaves
/// the old one intact. Dropped without a commit, the temporary file is removed and the
/// destination left as it was. Several files put in place together [`StagedFile::sync`] every one
/// before they [`StagedFile::persist`] any.
#[cfg(feature = "full")]
#[derive(Debug)]
pub struct StagedFile {
    destination: PathBuf,
    tmp: tempfile::NamedTempFile,
    _unfinished: Unfinished,
}

/// The temporary files of the staged files not yet put in place or dropped: what a process ended
/// by a signal must remove ([`StagedFile::discard_unfinished`]), since no destructor runs then.
#[cfg(feature = "full")]
static UNFINISHED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// A temporary file's place in [`UNFINISHED`], given up when the staged file is put in place or
/// dropped.
#[cfg(feature = "full")]
#[derive(Debug)]
struct Unfinished(PathBuf);

#[cfg(feature = "full")]
impl Unfinished {
    fn register(path: &Path) -> Unfinished {
        UNFINISHED.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(path.to_path_buf());
        Unfinished(path.to_path_buf())
    }
}

#[cfg(feature = "full")]
impl Drop for Unfinished {
    fn drop(&mut self) {
        let mut list = UNFINISHED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(at) = list.iter().position(|p| *p == self.0) {
            list.swap_remove(at);
        }
    }
}

#[cfg(feature = "full")]
impl StagedFile {
    /// Start a new version of `path` by creating its temporary file (which checks that the
    /// destination can be written before any work).
    ///
    /// # Errors
    /// `path` is a folder, or its folder does not take a new file.
    pub fn create(path: &Path) -> Result<Self, FileError> {
        if path.is_dir() {
            return Err(FileError::new(path, "is a folder; an output file was expected"));
        }
        // A device or a pipe would be replaced by the finished file's rename (as root, even
        // /dev/null): only a regular file, or a new one, is an output.
        if path.exists() && !path.is_file() {
            return Err(FileError::new(
                path,
                "is not a regular file (a device or a pipe): outputs are written to a temporary file renamed into \
                 place, which would replace it; give a file's path",
            ));
        }
        let folder = parent_folder(path);
        if !folder.is_dir() {
            let reason = format!("cannot write here: its folder {} does not exist", folder.display());
            return Err(FileError::new(path, reason));
        }
        let tmp = tempfile::Builder::new()
            .prefix(".spmcal-")
            .suffix(".tmp")
            .tempfile_in(folder)
            .map_err(|e| FileError::new(path, format!("cannot write in its folder: {}", e.kind())))?;
        let unfinished = Unfinished::register(tmp.path());
        Ok(StagedFile { destination: path.to_path_buf(), tmp, _unfinished: unfinished })
    }

    /// Remove the temporary file of every staged file not yet put in place, for a process about to
    /// end without running destructors (a signal): afterwards no destination has changed and no
    /// temporary file is left. New staged files cannot be created after it (the list stays locked
    /// until the process ends).
    pub fn discard_unfinished() {
        let list = UNFINISHED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        for path in list.iter() {
            let _ = std::fs::remove_file(path);
        }
        std::mem::forget(list);
    }

    /// The temporary file, for writers that open a path themselves.
    pub fn temp_path(&self) -> &Path {
        self.tmp.path()
    }

    /// The final destination.
    pub fn destination(&self) -> &Path {
        &self.destination
    }

    /// Write `contents` into the temporary file (replacing what an earlier write put there).
    ///
    /// # Errors
    /// The write fails (e.g. the disk is full).
    pub fn write(&mut self, contents: &[u8]) -> Result<(), FileError> {
        use std::io::{Seek, Write};
        let fail = |e: std::io::Error| FileError::new(&self.destination, format!("cannot write: {e}"));
        let file = self.tmp.as_file_mut();
        file.set_len(0).map_err(fail)?;
        file.rewind().map_err(fail)?;
        file.write_all(contents).map_err(fail)
    }

    /// Give the temporary file ordinary permissions and sync it to the disk: the first half of
    /// [`StagedFile::commit`].
    ///
    /// # Errors
    /// Setting the permissions or syncing fails.
    pub fn sync(&self) -> Result<(), FileError> {
        let fail = |e: std::io::Error| FileError::new(&self.destination, format!("cannot write: {e}"));
        // A temporary file is private (0600); the result is an ordinary file, like any other output.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            self.tmp.as_file().set_permissions(std::fs::Permissions::from_mode(0o644)).map_err(fail)?;
        }
        std::fs::File::open(self.tmp.path()).and_then(|f| f.sync_all()).map_err(fail)
    }

    /// Rename the (synced) temporary file over the destination: the second half of
    /// [`StagedFile::commit`].
    ///
    /// # Errors
    /// The rename fails.
    pub fn persist(self) -> Result<(), FileError> {
        let StagedFile { destination, tmp, _unfinished } = self;
        tmp.persist(&destination).map_err(|e| FileError::new(&destination, format!("cannot write: {}", e.error)))?;
        Ok(())
    }

    /// Put the file in place: ordinary permissions, synced, renamed over the destination.
    ///
    /// # Errors
    /// Syncing or renaming fails.
    pub fn commit(self) -> Result<(), FileError> {
        self.sync()?;
        self.persist()
    }
}

/// `a()` and `b()` at the same time, `b` on a second thread (reading the files of a session).
#[cfg(feature = "full")]
pub(crate) fn in_parallel<A: Send, B: Send>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B + Send) -> (A, B) {
    std::thread::scope(|s| {
        let second = s.spawn(b);
        let first = a();
        (first, second.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)))
    })
}

/// The folder a file is written in (`.` for a bare file name).
#[cfg(feature = "full")]
pub(crate) fn parent_folder(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

#[cfg(feature = "full")] // the lean core reads its files through io::yaml
/// Read a whole text file, naming it in the error.
///
/// # Errors
/// A [`FileError`] when the file cannot be read or is not UTF-8.
pub(crate) fn read_text(path: &Path) -> Result<String, FileError> {
    std::fs::read_to_string(path).map_err(|e| FileError::new(path, format!("cannot read: {e}")))
}

/// A number for a text file: the shortest text that reads back to the same `f64` (Ryū), in
/// plain notation where that is readable and in exponent notation for very small or large values.
#[cfg(feature = "full")]
pub(crate) fn number(x: f64) -> String {
    ryu::Buffer::new().format(x).to_owned()
}

/// Append `,x` for each of `values` to a CSV line, each as [`number`] writes it, without
/// allocating (tables of a long recording have millions of numbers).
#[cfg(feature = "full")]
pub(crate) fn push_numbers(line: &mut String, values: &[f64]) {
    let mut buffer = ryu::Buffer::new();
    for &x in values {
        line.push(',');
        line.push_str(buffer.format(x));
    }
}

/// Whether a model reference is written as a name (one component, no extension: a shipped
/// model's `agile_wrist`), not a path.
pub(crate) fn is_name(reference: &Path) -> bool {
    reference.components().count() == 1
        && reference.extension().is_none()
        && matches!(reference.components().next(), Some(std::path::Component::Normal(_)))
}

/// A model reference written in a file in `folder`, as the working folder sees it: a name or an
/// absolute path as written, a relative path joined to `folder`.
pub(crate) fn resolve_reference(folder: &Path, reference: &Path) -> PathBuf {
    if is_name(reference) || reference.is_absolute() || folder.as_os_str().is_empty() {
        reference.to_path_buf()
    } else {
        folder.join(reference)
    }
}

/// `a/b/../c` → `a/c`, without touching the file system (for paths recorded in files).
#[cfg(feature = "full")]
pub(crate) fn tidy_path(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(out.components().next_back(), Some(Component::Normal(_))) => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

#[cfg(feature = "full")]
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tidy_path_removes_dot_segments_only_where_it_can() {
        assert_eq!(tidy_path(Path::new("configs/../models/a.urdf")), Path::new("models/a.urdf"));
        assert_eq!(tidy_path(Path::new("../../models/./a.urdf")), Path::new("../../models/a.urdf"));
        assert_eq!(tidy_path(Path::new("/x/y/../../z")), Path::new("/z"));
    }

    proptest::proptest! {
        #[test]
        fn any_number_reads_back_exactly(bits in proptest::num::u64::ANY) {
            let x = f64::from_bits(bits);
            let mut line = String::new();
            push_numbers(&mut line, &[x, -x]);
            let back: Vec<f64> = line[1..].split(',').map(|t| t.parse().unwrap()).collect();
            if x.is_nan() {
                proptest::prop_assert!(back.iter().all(|b| b.is_nan()));
            } else {
                proptest::prop_assert_eq!(back, vec![x, -x]);
                proptest::prop_assert_eq!(number(x).parse::<f64>().unwrap(), x);
            }
        }
    }

    #[test]
    fn numbers_read_back_exactly() {
        for x in [0.0, 1.0, -0.5, 1e-17, 123456789.123, 6.02e23, -2.5e-5, std::f64::consts::PI] {
            assert_eq!(number(x).parse::<f64>().unwrap(), x, "{}", number(x));
        }
    }
}
