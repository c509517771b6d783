//! File plumbing shared by every reader and writer: atomic writes and located errors.

use std::fmt;
use std::path::{Path, PathBuf};

/// An error in an input file, located as precisely as the format allows.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct FileError {
    pub path: PathBuf,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// Column name (CSV) or field (YAML), when known.
    pub column: Option<String>,
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
    pub fn new(path: &Path, reason: impl Into<String>) -> Self {
        FileError { path: path.to_path_buf(), line: None, column: None, reason: reason.into() }
    }

    pub fn at_line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }

    pub fn in_column(mut self, column: impl Into<String>) -> Self {
        self.column = Some(column.into());
        self
    }

    /// A YAML error: serde_yaml gives line and column except for a missing field.
    pub fn from_yaml(path: &Path, e: &serde_yaml::Error) -> Self {
        let err = FileError::new(path, e.to_string());
        match e.location() {
            Some(loc) => err.at_line(loc.line()),
            None => err,
        }
    }
}

/// Write `contents` to `path` atomically: a temporary file in the same folder, then a rename,
/// so that a reader never sees a half-written file and a failure leaves the old one intact.
pub fn write_atomic(path: &Path, contents: &[u8]) -> Result<(), FileError> {
    use std::io::Write;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let fail = |e: std::io::Error| FileError::new(path, format!("cannot write: {e}"));
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(fail)?;
    tmp.write_all(contents).map_err(fail)?;
    // A temporary file is private (0600); the result is an ordinary file, like any other output.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file().set_permissions(std::fs::Permissions::from_mode(0o644)).map_err(fail)?;
    }
    tmp.as_file().sync_all().map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

/// Read a whole text file, naming it in the error.
pub fn read_text(path: &Path) -> Result<String, FileError> {
    std::fs::read_to_string(path).map_err(|e| FileError::new(path, format!("cannot read: {e}")))
}

/// A number for a text file: shortest text that reads back to the same `f64`, in plain
/// notation where that is readable and in exponent notation for very small or large values.
pub fn number(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-4..1e7).contains(&a) { format!("{x}") } else { format!("{x:e}") }
}

/// The path of `target` relative to the folder `from` (both must exist), e.g. `../../models/a.urdf`.
pub fn relative_path(from: &Path, target: &Path) -> Result<PathBuf, FileError> {
    let canon = |p: &Path| p.canonicalize().map_err(|e| FileError::new(p, format!("cannot resolve: {e}")));
    let (from, target) = (canon(from)?, canon(target)?);
    let common = from.components().zip(target.components()).take_while(|(a, b)| a == b).count();
    let mut out: PathBuf = from.components().skip(common).map(|_| "..").collect();
    out.extend(target.components().skip(common));
    Ok(out)
}

/// Read a YAML settings file into `T`, then `check` it; a value `check` refuses is reported at the
/// line of its key (serde has no location for values it accepted).
pub fn read_checked_yaml<T: serde::de::DeserializeOwned>(
    path: &Path,
    check: impl Fn(&T) -> Result<(), (&'static str, String)>,
) -> Result<T, FileError> {
    let text = read_text(path)?;
    let value: T = serde_yaml::from_str(&text).map_err(|e| FileError::from_yaml(path, &e))?;
    check(&value).map_err(|(key, reason)| {
        let err = FileError::new(path, reason).in_column(key);
        match yaml_key_line(&text, key) {
            Some(line) => err.at_line(line),
            None => err,
        }
    })?;
    Ok(value)
}

/// Line of the first `key:` in a YAML text, for errors about values serde accepted but we refuse.
pub fn yaml_key_line(text: &str, key: &str) -> Option<usize> {
    text.lines().position(|l| l.trim_start().trim_start_matches("- ").starts_with(&format!("{key}:"))).map(|i| i + 1)
}

/// `a/b/../c` → `a/c`, without touching the file system (for paths recorded in files).
pub fn tidy_path(path: &Path) -> PathBuf {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tidy_path_removes_dot_segments_only_where_it_can() {
        assert_eq!(tidy_path(Path::new("configs/../models/a.urdf")), Path::new("models/a.urdf"));
        assert_eq!(tidy_path(Path::new("../../models/./a.urdf")), Path::new("../../models/a.urdf"));
        assert_eq!(tidy_path(Path::new("/x/y/../../z")), Path::new("/z"));
    }

    #[test]
    fn numbers_read_back_exactly() {
        for x in [0.0, 1.0, -0.5, 1e-17, 123456789.123, 6.02e23, -2.5e-5, std::f64::consts::PI] {
            assert_eq!(number(x).parse::<f64>().unwrap(), x, "{}", number(x));
        }
    }
}
