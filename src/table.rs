//! Reading CSV tables by column name, with errors that name the file, line and column.
//! Extra columns are allowed (and ignored); required ones must be present.

use std::path::{Path, PathBuf};

use crate::files::FileError;

/// A CSV file opened for reading required columns by name.
pub struct Table {
    path: PathBuf,
    reader: csv::Reader<std::fs::File>,
    columns: Vec<usize>,
    names: Vec<String>,
}

/// One data row: its 1-based line in the file and the required fields, in the order asked.
pub struct Row {
    pub line: usize,
    pub fields: Vec<String>,
}

impl Table {
    /// Open `path` and locate the `required` columns in its header.
    pub fn open(path: &Path, required: &[&str]) -> Result<Self, FileError> {
        let file = std::fs::File::open(path)
            .map_err(|e| FileError::new(path, format!("cannot read: {e}")))?;
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(file);
        let header = reader
            .headers()
            .map_err(|e| FileError::new(path, format!("bad header: {e}")).at_line(1))?
            .clone();
        let columns = required
            .iter()
            .map(|name| {
                header.iter().position(|h| h == *name).ok_or_else(|| {
                    FileError::new(
                        path,
                        format!(
                            "the header has no column `{name}` (it has: {})",
                            header.iter().collect::<Vec<_>>().join(",")
                        ),
                    )
                    .at_line(1)
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Table {
            path: path.to_path_buf(),
            reader,
            columns,
            names: required.iter().map(|s| s.to_string()).collect(),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The data rows, each with its line number; a malformed row is an error naming its line.
    pub fn rows(&mut self) -> impl Iterator<Item = Result<Row, FileError>> + '_ {
        let path = self.path.clone();
        let columns = self.columns.clone();
        self.reader.records().map(move |record| {
            let record = record.map_err(|e| {
                let line = e.position().map(|p| p.line() as usize);
                let err = FileError::new(&path, format!("malformed CSV: {e}"));
                match line {
                    Some(l) => err.at_line(l),
                    None => err,
                }
            })?;
            let line = record.position().map_or(0, |p| p.line() as usize);
            Ok(Row {
                line,
                fields: columns
                    .iter()
                    .map(|&c| record.get(c).unwrap_or("").to_string())
                    .collect(),
            })
        })
    }

    /// An error at `row`, in the `k`-th required column.
    pub fn error(&self, row: &Row, k: usize, reason: impl Into<String>) -> FileError {
        FileError::new(&self.path, reason)
            .at_line(row.line)
            .in_column(&self.names[k])
    }

    /// The `k`-th required field of `row` as a finite number.
    pub fn number(&self, row: &Row, k: usize) -> Result<f64, FileError> {
        let text = &row.fields[k];
        let value: f64 = text
            .parse()
            .map_err(|_| self.error(row, k, format!("`{text}` is not a number")))?;
        if !value.is_finite() {
            return Err(self.error(row, k, format!("`{text}` is not finite")));
        }
        Ok(value)
    }

    /// The `k`-th required field of `row` as a non-negative integer.
    pub fn index(&self, row: &Row, k: usize) -> Result<u64, FileError> {
        let text = &row.fields[k];
        text.parse().map_err(|_| {
            self.error(
                row,
                k,
                format!("`{text}` is not a pose number (a non-negative integer)"),
            )
        })
    }
}
