//! Reading CSV tables by column name, with errors that name the file, line and column.
//! Extra columns are allowed (and ignored); required ones must be present, optional ones may be.

use std::path::{Path, PathBuf};

use crate::files::FileError;

/// A CSV file opened for reading columns by name.
pub(crate) struct Table {
    path: PathBuf,
    reader: csv::Reader<std::fs::File>,
    /// Column index of each requested name; `None` for an optional column the file lacks.
    columns: Vec<Option<usize>>,
    names: Vec<String>,
}

/// One data row: its 1-based line in the file and the requested fields, in the order asked
/// (an absent optional column reads as an empty field).
pub(crate) struct Row {
    pub(crate) line: usize,
    pub(crate) fields: Vec<String>,
}

impl Table {
    /// Open `path` and locate the `required` columns in its header.
    pub(crate) fn open(path: &Path, required: &[&str]) -> Result<Self, FileError> {
        Self::open_with_optional(path, required, &[])
    }

    /// Open `path`, locate the `required` columns, then the `optional` ones (which may be absent).
    pub(crate) fn open_with_optional(path: &Path, required: &[&str], optional: &[&str]) -> Result<Self, FileError> {
        let file = std::fs::File::open(path).map_err(|e| FileError::new(path, format!("cannot read: {e}")))?;
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(file);
        let header = reader.headers().map_err(|e| FileError::new(path, format!("bad header: {e}")).at_line(1))?.clone();
        let find = |name: &&str| header.iter().position(|h| h == *name);
        let mut columns = Vec::with_capacity(required.len() + optional.len());
        for name in required {
            let listed = header.iter().collect::<Vec<_>>().join(",");
            let column = find(name).ok_or_else(|| {
                FileError::new(path, format!("the header has no column `{name}` (it has: {listed})")).at_line(1)
            })?;
            columns.push(Some(column));
        }
        columns.extend(optional.iter().map(find));
        let names = required.iter().chain(optional).map(|s| s.to_string()).collect();
        Ok(Table { path: path.to_path_buf(), reader, columns, names })
    }

    /// The data rows, each with its line number; a malformed row is an error naming its line.
    pub(crate) fn rows(&mut self) -> impl Iterator<Item = Result<Row, FileError>> + '_ {
        let path = self.path.clone();
        let columns = self.columns.clone();
        self.reader.records().map(move |record| {
            let record = record.map_err(|e| {
                let err = FileError::new(&path, format!("malformed CSV: {e}"));
                match e.position() {
                    Some(p) => err.at_line(p.line() as usize),
                    None => err,
                }
            })?;
            let line = record.position().map_or(0, |p| p.line() as usize);
            let field = |c: &Option<usize>| c.and_then(|c| record.get(c)).unwrap_or("").to_string();
            Ok(Row { line, fields: columns.iter().map(field).collect() })
        })
    }

    /// All data rows, or the first malformed one's error.
    pub(crate) fn all_rows(&mut self) -> Result<Vec<Row>, FileError> {
        self.rows().collect()
    }

    /// An error at `row`, in the `k`-th requested column.
    pub(crate) fn error(&self, row: &Row, k: usize, reason: impl Into<String>) -> FileError {
        FileError::new(&self.path, reason).at_line(row.line).in_column(&self.names[k])
    }

    /// The `k`-th field of `row` as a finite number.
    pub(crate) fn number(&self, row: &Row, k: usize) -> Result<f64, FileError> {
        let text = &row.fields[k];
        let value: f64 = text.parse().map_err(|_| self.error(row, k, format!("`{text}` is not a number")))?;
        if !value.is_finite() {
            return Err(self.error(row, k, format!("`{text}` is not finite")));
        }
        Ok(value)
    }

    /// The `k`-th field as a finite number, or `None` when that optional column is absent.
    pub(crate) fn optional_number(&self, row: &Row, k: usize) -> Result<Option<f64>, FileError> {
        if self.columns[k].is_none() { Ok(None) } else { self.number(row, k).map(Some) }
    }

    /// The `k`-th field of `row` as a pose number (non-negative integer).
    pub(crate) fn index(&self, row: &Row, k: usize) -> Result<u64, FileError> {
        let text = &row.fields[k];
        text.parse().map_err(|_| self.error(row, k, format!("`{text}` is not a pose number (a non-negative integer)")))
    }
}
