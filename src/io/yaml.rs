//! Reading YAML input files safely and with locations.
//!
//! serde_yaml alone leaves three holes: its work on pathological files (deep nesting, alias
//! expansion) is unbounded, a duplicate key is reported without a useful line, and values it
//! accepted but we refuse have no location at all. So every YAML input is first scanned once by a
//! streaming event parser (saphyr-parser), which stops at the first violation of the limits below,
//! rejects duplicate keys at their line, and records the line of every key by its path
//! (`legs[1].alpha1_deg`); only then does serde deserialise the text.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use saphyr_parser::{Event, Parser};
use serde::de::DeserializeOwned;

use crate::io::files::FileError;

/// Largest YAML input accepted: every spmcal YAML file is a few kilobytes.
pub(crate) const MAX_BYTES: usize = 1 << 20;
/// Deepest nesting of mappings and sequences accepted (spmcal's files nest three deep).
pub(crate) const MAX_DEPTH: usize = 16;
/// Most aliases accepted: a few are legitimate; many are an expansion bomb.
pub(crate) const MAX_ALIASES: usize = 64;
/// Most bytes of key paths indexed (each key and sequence item by its full path, e.g.
/// `markers[9999].position_m[2]`): a few times the file for any real file (a parameters file of 1 MiB
/// indexes under 2 MiB), while a long key above many items would make every item's path long
/// (a 500 kB key over 50,000 items: 25 GB).
pub(crate) const MAX_PATH_BYTES: usize = 16 * MAX_BYTES;

/// The line of every key of a YAML document, by path.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct KeyLines(HashMap<String, usize>);

impl KeyLines {
    /// Line (1-based) of the key at `path`, e.g. `bounds.axis_tilt_deg` or `legs[2]` (a sequence
    /// item is located at its first line).
    pub(crate) fn line(&self, path: &str) -> Option<usize> {
        self.0.get(path).copied()
    }

    /// Line of the value at `path`, or of its nearest enclosing key or item that the file has
    /// (`legs[2].v0[1]` → `legs[2].v0` → `legs[2]` → `legs`): a value serde filled in by default
    /// is still located at the entry it belongs to.
    pub(crate) fn nearest_line(&self, path: &str) -> Option<usize> {
        let mut at = path;
        loop {
            if let Some(line) = self.line(at) {
                return Some(line);
            }
            at = parent(at)?;
        }
    }

    /// An error about the value at `path` (a nested key such as `legs[2].v0` or
    /// `markers[1].position_m[0]`), located at its own line — or, when the file does not have that
    /// key, at its nearest enclosing one.
    pub(crate) fn error(&self, file: &Path, path: &str, reason: impl Into<String>) -> FileError {
        let err = FileError::new(file, reason).in_column(path);
        match self.nearest_line(path) {
            Some(line) => err.at_line(line),
            None => err,
        }
    }
}

/// The path that encloses `path`: without its last `[k]` or `.key`; `None` at the top.
fn parent(path: &str) -> Option<&str> {
    if let Some(open) = path.strip_suffix(']').and_then(|p| p.rfind('[')) {
        return Some(&path[..open]);
    }
    path.rfind('.').map(|dot| &path[..dot])
}

enum Container {
    Mapping { prefix: String, key: Option<String>, seen: HashSet<String> },
    Sequence { prefix: String, index: usize },
}

impl Container {
    /// The path of the node that comes next in this container, if it is a value (not a key).
    fn child_path(&self) -> Option<String> {
        match self {
            Container::Mapping { key: Some(k), prefix, .. } => Some(join(prefix, k)),
            Container::Mapping { key: None, .. } => None,
            Container::Sequence { prefix, index } => Some(format!("{prefix}[{index}]")),
        }
    }

    /// A node ended inside this container: advance to the next key or item.
    fn advance(&mut self) {
        match self {
            Container::Mapping { key, .. } => *key = None,
            Container::Sequence { index, .. } => *index += 1,
        }
    }
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() { key.to_string() } else { format!("{prefix}.{key}") }
}

/// Scan `text` within the limits, reject duplicate keys, and index the keys' lines.
pub(crate) fn scan(path: &Path, text: &str) -> Result<KeyLines, FileError> {
    if text.len() > MAX_BYTES {
        return Err(too_large(path, format!("{} bytes", text.len())));
    }
    let mut lines = HashMap::new();
    // Bytes of paths made so far: each is made once, so the work is linear in this bound.
    let mut path_bytes = 0usize;
    let mut stack: Vec<Container> = Vec::new();
    let mut aliases = 0;
    let mut documents = 0;
    for event in Parser::new_from_str(text) {
        let (event, span) = event.map_err(|e| {
            let reason = match e.info() {
                // The scanner's own bound on flow nesting, met before ours.
                info if info.contains("recursion limit") => format!("nested more than {MAX_DEPTH} levels deep"),
                info => format!("malformed YAML: {info}"),
            };
            FileError::new(path, reason).at_line(e.marker().line())
        })?;
        let line = span.start.line();
        let at = |reason: String| FileError::new(path, reason).at_line(line);
        let mut made = |p: &str| {
            path_bytes += p.len();
            match path_bytes > MAX_PATH_BYTES {
                true => Err(at(format!(
                    "the paths of its keys add up to more than {MAX_PATH_BYTES} bytes: keys too long, or too many \
                     under a long one, for a settings file"
                ))),
                false => Ok(()),
            }
        };
        match event {
            Event::DocumentStart(_) => {
                documents += 1;
                if documents > 1 {
                    return Err(at("a second YAML document: a settings file holds one".into()));
                }
            }
            Event::MappingStart(..) | Event::SequenceStart(..) => {
                let prefix = match stack.last() {
                    Some(c) => c.child_path().ok_or_else(|| at("a mapping or sequence used as a key".into()))?,
                    None => String::new(),
                };
                made(&prefix)?;
                if stack.len() >= MAX_DEPTH {
                    return Err(at(format!("nested more than {MAX_DEPTH} levels deep")));
                }
                if let Some(Container::Sequence { .. }) = stack.last() {
                    lines.entry(prefix.clone()).or_insert(line);
                }
                stack.push(if matches!(event, Event::MappingStart(..)) {
                    Container::Mapping { prefix, key: None, seen: HashSet::new() }
                } else {
                    Container::Sequence { prefix, index: 0 }
                });
            }
            Event::MappingEnd | Event::SequenceEnd => {
                stack.pop();
                if let Some(parent) = stack.last_mut() {
                    parent.advance();
                }
            }
            Event::Alias(_) | Event::Scalar(..) => {
                if matches!(event, Event::Alias(_)) {
                    aliases += 1;
                    if aliases > MAX_ALIASES {
                        return Err(at(format!("more than {MAX_ALIASES} aliases")));
                    }
                }
                match stack.last_mut() {
                    Some(Container::Mapping { prefix, key: key @ None, seen }) => {
                        let name = match &event {
                            Event::Scalar(value, ..) => value.to_string(),
                            _ => return Err(at("an alias used as a key".into())),
                        };
                        let full = join(prefix, &name);
                        made(&full)?;
                        if !seen.insert(name.clone()) {
                            let first = lines.get(&full).map_or(String::new(), |l| format!(" (first at line {l})"));
                            return Err(at(format!("duplicate key `{full}`{first}")));
                        }
                        lines.insert(full, line);
                        *key = Some(name);
                    }
                    Some(container) => {
                        if let Container::Sequence { prefix, index } = &*container {
                            let p = format!("{prefix}[{index}]");
                            made(&p)?;
                            lines.entry(p).or_insert(line);
                        }
                        container.advance();
                    }
                    None => {}
                }
            }
            _ => {}
        }
    }
    Ok(KeyLines(lines))
}

/// Read a YAML file into `T` within the limits, with the lines of its keys. A file above
/// [`MAX_BYTES`] is refused before it is read (at most one byte more than the limit is read).
pub(crate) fn read<T: DeserializeOwned>(path: &Path) -> Result<(T, KeyLines), FileError> {
    let text = read_bounded(path)?;
    parse(path, &text)
}

/// The text of a YAML input, at most [`MAX_BYTES`] of it: a bigger file (or a device that never
/// ends) is refused after reading one byte past the limit, never read whole.
pub(crate) fn read_bounded(path: &Path) -> Result<String, FileError> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| FileError::new(path, format!("cannot read: {e}")))?;
    let mut bytes = Vec::new();
    file.take(MAX_BYTES as u64 + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| FileError::new(path, format!("cannot read: {e}")))?;
    if bytes.len() > MAX_BYTES {
        return Err(too_large(path, format!("more than {MAX_BYTES} bytes")));
    }
    // The message `read_to_string` gives, as every other text file's.
    String::from_utf8(bytes).map_err(|_| FileError::new(path, "cannot read: stream did not contain valid UTF-8"))
}

fn too_large(path: &Path, size: String) -> FileError {
    FileError::new(path, format!("{size} is too large for a YAML settings file (limit {MAX_BYTES} bytes)"))
}

/// Parse YAML `text` (read from `path`) into `T`, with the lines of its keys.
pub(crate) fn parse<T: DeserializeOwned>(path: &Path, text: &str) -> Result<(T, KeyLines), FileError> {
    // A byte-order mark (Windows editors write one) is not part of the document: YAML parsers
    // would read it as the start of a second one.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let keys = scan(path, text)?;
    let value: T = serde_yaml::from_str(text).map_err(|e| FileError::from_yaml(path, &e))?;
    Ok((value, keys))
}

#[cfg(feature = "full")]
/// Read a YAML settings file into `T`, then `check` it; a value `check` refuses, as
/// `(key path, reason)`, is reported at the line of its key.
pub(crate) fn read_checked<T: DeserializeOwned>(
    path: &Path,
    check: impl Fn(&T) -> Result<(), (String, String)>,
) -> Result<T, FileError> {
    let (value, keys) = read::<T>(path)?;
    check(&value).map_err(|(key, reason)| keys.error(path, &key, reason))?;
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(text: &str) -> KeyLines {
        scan(Path::new("t.yaml"), text).unwrap()
    }

    #[test]
    fn keys_are_indexed_by_path_and_line() {
        let k = lines("a: 1\nb:\n  c: 2\n  d: [1, 2]\nlegs:\n  - x: 1\n  - x: 2\n    y: 3\n");
        assert_eq!(k.line("a"), Some(1));
        assert_eq!(k.line("b.c"), Some(3));
        assert_eq!(k.line("b.d"), Some(4));
        assert_eq!(k.line("legs[0].x"), Some(6));
        assert_eq!(k.line("legs[1]"), Some(7));
        assert_eq!(k.line("legs[1].y"), Some(8));
    }

    #[test]
    fn nested_keys_items_and_flow_collections_have_their_own_lines() {
        let k = lines(
            "legs:\n  - { a: x, b: y }\n  - a: x\n    v0:\n      - 1.0\n      - .nan\nm:\n  p: [1, 2, 3]\n  q: [4,\n      5]\n",
        );
        assert_eq!(k.line("legs[0]"), Some(2));
        assert_eq!(k.line("legs[0].b"), Some(2));
        assert_eq!(k.line("legs[1].v0"), Some(4));
        assert_eq!(k.line("legs[1].v0[1]"), Some(6));
        assert_eq!(k.line("m.p[2]"), Some(8));
        assert_eq!(k.line("m.q[1]"), Some(10));
        // A key the file lacks is located at the entry that would hold it.
        assert_eq!(k.line("legs[1].delta_deg"), None);
        assert_eq!(k.nearest_line("legs[1].delta_deg"), Some(3));
        assert_eq!(k.nearest_line("legs[1].v0[7]"), Some(4));
        assert_eq!(k.nearest_line("other.x"), None);
        let e = k.error(Path::new("t.yaml"), "legs[1].v0[1]", "not finite");
        assert_eq!((e.line, e.column.as_deref()), (Some(6), Some("legs[1].v0[1]")));
    }

    #[test]
    fn duplicate_keys_are_refused_at_their_line() {
        let e = scan(Path::new("t.yaml"), "a: 1\nb:\n  c: 2\n  c: 3\n").unwrap_err();
        assert_eq!(e.line, Some(4));
        assert!(e.reason.contains("duplicate key `b.c` (first at line 3)"), "{e}");
        // The same key in two mappings is not a duplicate.
        lines("- c: 1\n- c: 2\n");
    }

    #[test]
    fn deep_nesting_and_alias_bombs_are_refused_quickly() {
        let deep = "[".repeat(100_000);
        let e = scan(Path::new("t.yaml"), &deep).unwrap_err();
        assert!(e.reason.contains("nested more than"), "{e}");
        let mut block = String::new();
        for d in 0..40 {
            block.push_str(&format!("{}k{d}:\n", " ".repeat(d)));
        }
        assert!(scan(Path::new("t.yaml"), &block).unwrap_err().reason.contains("nested"));
        let mut bomb = String::from("a: &a [x, x]\n");
        for i in 0..100 {
            bomb.push_str(&format!("b{i}: [*a, *a]\n"));
        }
        assert!(scan(Path::new("t.yaml"), &bomb).unwrap_err().reason.contains("aliases"));
        let huge = format!("# {}\n", "x".repeat(MAX_BYTES));
        assert!(scan(Path::new("t.yaml"), &huge).unwrap_err().reason.contains("too large"));
        // A long (explicit) key above many items: every item's path would repeat it.
        let long_key = format!("? {}\n: [{}]\n", "k".repeat(300_000), ["1"; 300_000].join(","));
        assert!(scan(Path::new("t.yaml"), &long_key).unwrap_err().reason.contains("paths of its keys"));
    }
}
