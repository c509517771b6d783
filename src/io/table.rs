//! Reading CSV tables by column name, with errors that name the file, line and column.
//! Extra columns are allowed (and ignored); required ones must be present, optional ones may be.
//!
//! Tables are big (a ten-minute recording has 600,000 encoder rows), so the rows are read into
//! one reused byte record and the fields are parsed straight from its bytes: nothing is
//! allocated per row or per field, and surrounding blanks are skipped as the field is read.

use std::path::{Path, PathBuf};

use crate::io::files::FileError;

/// A CSV file opened for reading columns by name, one row at a time.
pub(crate) struct Table {
    reader: csv::Reader<std::fs::File>,
    record: csv::ByteRecord,
    layout: Layout,
}

/// What a row needs to read its fields and to locate its errors.
struct Layout {
    path: PathBuf,
    /// Size of the file in bytes.
    size: u64,
    /// Column index of each requested name; `None` for an optional column the file lacks.
    columns: Vec<Option<usize>>,
    names: Vec<String>,
}

/// One data row: its 1-based line in the file and the requested fields, by their position in
/// the request (an absent optional column reads as an empty field).
pub(crate) struct Row<'a> {
    layout: &'a Layout,
    record: &'a csv::ByteRecord,
    pub(crate) line: usize,
}

impl Table {
    /// Open `path` and locate the `required` columns in its header.
    pub(crate) fn open(path: &Path, required: &[&str]) -> Result<Self, FileError> {
        Self::open_with_optional(path, required, &[])
    }

    /// Open `path`, locate the `required` columns, then the `optional` ones (which may be absent).
    pub(crate) fn open_with_optional(path: &Path, required: &[&str], optional: &[&str]) -> Result<Self, FileError> {
        let file = std::fs::File::open(path).map_err(|e| FileError::new(path, format!("cannot read: {e}")))?;
        let mut reader = csv::ReaderBuilder::new().from_reader(file);
        let header = reader.byte_headers().map_err(|e| FileError::new(path, format!("bad header: {e}")).at_line(1))?;
        let header: Vec<String> = header.iter().map(|h| String::from_utf8_lossy(h.trim_ascii()).into_owned()).collect();
        let find = |name: &&str| header.iter().position(|h| h == name);
        let mut columns = Vec::with_capacity(required.len() + optional.len());
        for name in required {
            let column = find(name).ok_or_else(|| {
                let listed = header.join(",");
                FileError::new(path, format!("the header has no column `{name}` (it has: {listed})")).at_line(1)
            })?;
            columns.push(Some(column));
        }
        columns.extend(optional.iter().map(find));
        let names = required.iter().chain(optional).map(|s| s.to_string()).collect();
        let size = std::fs::metadata(path).map_or(0, |m| m.len());
        let layout = Layout { path: path.to_path_buf(), size, columns, names };
        Ok(Table { reader, record: csv::ByteRecord::new(), layout })
    }

    /// The next data row, `None` at the end; a malformed row is an error naming its line.
    pub(crate) fn next_row(&mut self) -> Result<Option<Row<'_>>, FileError> {
        let more = self.reader.read_byte_record(&mut self.record).map_err(|e| {
            let err = FileError::new(&self.layout.path, format!("malformed CSV: {e}"));
            match e.position() {
                Some(p) => err.at_line(p.line() as usize),
                None => err,
            }
        })?;
        if !more {
            return Ok(None);
        }
        let line = self.record.position().map_or(0, |p| p.line() as usize);
        Ok(Some(Row { layout: &self.layout, record: &self.record, line }))
    }

    /// Every data row parsed by `parse` (which also sees the rows parsed before it), or the first
    /// error; the output is sized once, from the file's size.
    pub(crate) fn read_all<T>(
        &mut self,
        mut parse: impl FnMut(&Row<'_>, &[T]) -> Result<T, FileError>,
    ) -> Result<Vec<T>, FileError> {
        let mut out = Vec::new();
        while let Some(row) = self.next_row()? {
            if out.is_empty() {
                out.reserve(row.expected_rows());
            }
            let item = parse(&row, &out)?;
            out.push(item);
        }
        Ok(out)
    }

    /// An error at `line`, in the `k`-th requested column.
    pub(crate) fn error_at(&self, line: usize, k: usize, reason: impl Into<String>) -> FileError {
        FileError::new(&self.layout.path, reason).at_line(line).in_column(&self.layout.names[k])
    }
}

/// The first row, in file order, whose key an earlier row already had: that key and the row's
/// line. `keys` are `(key, line)` in file order. Files are usually written in key order, which
/// one pass confirms; otherwise the keys are sorted (no hashing of hundreds of thousands of rows).
pub(crate) fn first_repeat<K: Ord + Copy>(keys: impl Iterator<Item = (K, usize)> + Clone) -> Option<(K, usize)> {
    let mut previous = None;
    let ordered = keys.clone().all(|(key, _)| previous.replace(key).is_none_or(|p| p < key));
    if ordered {
        return None;
    }
    let mut sorted: Vec<(K, usize)> = keys.collect();
    sorted.sort_unstable();
    sorted.windows(2).filter(|w| w[0].0 == w[1].0).map(|w| w[1]).min_by_key(|&(_, line)| line)
}

impl Row<'_> {
    /// A guess at the number of data rows of the file (its size over this row's length), to size
    /// the output once rather than grow it through a dozen copies.
    fn expected_rows(&self) -> usize {
        let row = self.record.as_slice().len() + self.record.len();
        (self.layout.size as usize / row.max(1)).min(1 << 24)
    }

    /// The `k`-th requested field, without surrounding blanks (empty for an absent optional column).
    pub(crate) fn field(&self, k: usize) -> &[u8] {
        self.layout.columns[k].and_then(|c| self.record.get(c)).unwrap_or(b"").trim_ascii()
    }

    /// Whether the `k`-th requested column is in the file.
    pub(crate) fn has_column(&self, k: usize) -> bool {
        self.layout.columns[k].is_some()
    }

    /// An error in the `k`-th requested column of this row.
    pub(crate) fn error(&self, k: usize, reason: impl Into<String>) -> FileError {
        FileError::new(&self.layout.path, reason).at_line(self.line).in_column(&self.layout.names[k])
    }

    /// The `k`-th field as a finite number.
    pub(crate) fn number(&self, k: usize) -> Result<f64, FileError> {
        let bytes = self.field(k);
        let shown = || String::from_utf8_lossy(bytes);
        let value: f64 = std::str::from_utf8(bytes)
            .ok()
            .and_then(|t| t.parse().ok())
            .ok_or_else(|| self.error(k, format!("`{}` is not a number", shown())))?;
        if !value.is_finite() {
            return Err(self.error(k, format!("`{}` is not finite", shown())));
        }
        Ok(value)
    }

    /// The `k`-th field as a finite number, or `None` when that optional column is absent.
    pub(crate) fn optional_number(&self, k: usize) -> Result<Option<f64>, FileError> {
        if self.has_column(k) { self.number(k).map(Some) } else { Ok(None) }
    }

    /// The rotation of the unit quaternion `[qw, qx, qy, qz]` in the requested columns `k..k + 4`;
    /// a quaternion whose norm is not 1 (within what printing it with four digits leaves) is an
    /// error in column `k`; one within it is normalised.
    pub(crate) fn quaternion(&self, k: usize) -> Result<nalgebra::Rotation3<f64>, FileError> {
        let q = [self.number(k)?, self.number(k + 1)?, self.number(k + 2)?, self.number(k + 3)?];
        crate::math::so3::from_printed_wxyz(q).map_err(|n| {
            let tolerance = crate::math::so3::PRINTED_QUATERNION_TOLERANCE;
            self.error(
                k,
                format!("quaternion {q:?} has norm {}, not 1 (within {tolerance})", crate::io::files::number(n)),
            )
        })
    }

    /// The `k`-th field as a pose number (non-negative integer).
    pub(crate) fn index(&self, k: usize) -> Result<u64, FileError> {
        let bytes = self.field(k);
        std::str::from_utf8(bytes).ok().and_then(|t| t.parse().ok()).ok_or_else(|| {
            let shown = String::from_utf8_lossy(bytes);
            self.error(k, format!("`{shown}` is not a pose number (a non-negative integer)"))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_repeat_is_found_in_any_order_at_its_first_repeated_line() {
        let sorted = [(1, 2), (2, 3), (5, 4)];
        assert_eq!(first_repeat(sorted.iter().copied()), None);
        let shuffled = [(5, 2), (1, 3), (2, 4)];
        assert_eq!(first_repeat(shuffled.iter().copied()), None);
        // 5 repeats at line 4, 3 at line 5: line 4 comes first; a third 5 does not change that.
        let repeated = [(5, 2), (3, 3), (5, 4), (3, 5), (5, 6)];
        assert_eq!(first_repeat(repeated.iter().copied()), Some((5, 4)));
        assert_eq!(first_repeat([(7, 2), (7, 3)].iter().copied()), Some((7, 3)));
    }

    #[test]
    fn fields_are_read_from_bytes_with_blanks_quotes_and_bad_text_located() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let mut text = b"pose, marker ,x_m\n 3 ,\"m1\", 0.25 \n4,m\xff,1e-3\n".to_vec();
        text.extend_from_slice(b"5,m1,\xff\n");
        std::fs::write(&path, text).unwrap();
        let mut table = Table::open_with_optional(&path, &["pose", "marker", "x_m"], &["station"]).unwrap();
        let row = table.next_row().unwrap().unwrap();
        assert_eq!((row.line, row.index(0).unwrap(), row.field(1)), (2, 3, &b"m1"[..]));
        assert_eq!((row.number(2).unwrap(), row.optional_number(3).unwrap(), row.has_column(3)), (0.25, None, false));
        let row = table.next_row().unwrap().unwrap();
        assert_eq!(row.field(1), b"m\xff");
        assert_eq!(row.number(2).unwrap(), 1e-3);
        let row = table.next_row().unwrap().unwrap();
        let err = row.number(2).unwrap_err().to_string();
        assert!(err.ends_with("t.csv:4: column `x_m`: `\u{fffd}` is not a number"), "{err}");
        assert!(table.next_row().unwrap().is_none());
    }

    #[test]
    fn the_expected_row_count_is_near_the_truth_and_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let body: String = (0..1000).map(|k| format!("{k},0.{k:04}\n")).collect();
        std::fs::write(&path, format!("pose,x_m\n{body}")).unwrap();
        let mut table = Table::open(&path, &["pose", "x_m"]).unwrap();
        let guess = table.next_row().unwrap().unwrap().expected_rows();
        assert!((1000..=2000).contains(&guess), "{guess}");
    }
}
