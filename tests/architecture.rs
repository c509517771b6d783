//! The architecture of docs/architecture.md, kept true: data flows one way through the library's
//! floors (no module imports one on a floor above it, nor an item defined in `lib.rs`, the top),
//! no two files import each other, directly or round a circle, and `main.rs` only dispatches.
//!
//! What counts as an import of a file: every path that names it or an item it defines, whatever
//! its form — `crate::a::b`, `super::b`, `self::b`, `b::X` where `b` is a child module, and
//! `x::Y` where `x` was brought in by an earlier `use` (`use super::levels; levels::Marker`) —
//! in `use` declarations and in code alike, with a folder's re-exports (`pub use child::Item` in
//! its `mod.rs`) followed to the file that defines the item. A `mod.rs` is a file like any
//! other: its `mod` declarations and re-exports of its own children are its facade, not imports,
//! but any other code in it imports what it names — so a `mod.rs` that calls a child which
//! imports the `mod.rs` back is a circle. The checker runs on `src/` and on a fixture of the
//! tree before issue 33 (`tests/data/architecture/old_tree`), where it must find that tree's
//! circles and its arrow back up.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The floors of docs/architecture.md, bottom first; `lib.rs` (the module path `""`) is above them.
const FLOORS: &[&[&str]] = &[
    &["math", "io"],
    &["model"],
    &["dataset"],
    &["vision", "sim"],
    &["calib"],
    &["plan", "compare"],
    &["record", "report"],
    &["cli"],
];

fn floor(module: &str) -> Option<usize> {
    if module.is_empty() {
        return Some(FLOORS.len());
    }
    let top = module.split("::").next().unwrap_or("");
    FLOORS.iter().position(|f| f.contains(&top))
}

/// Every `.rs` file under `src`, by module path (`calib::fit`; `""` for lib.rs).
fn modules(src: &Path) -> BTreeMap<String, PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(src, &mut files);
    files
        .into_iter()
        .filter(|f| f.file_name().is_some_and(|n| n != "main.rs"))
        .map(|f| {
            let rel = f.strip_prefix(src).unwrap().with_extension("");
            let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
            if parts.last().is_some_and(|p| p == "mod" || p == "lib") {
                parts.pop();
            }
            (parts.join("::"), f)
        })
        .collect()
}

/// The code of a file without its `#[cfg(test)]` module, its comments and its string literals.
fn code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let text = match text.find("#[cfg(test)]\nmod tests {") {
        Some(at) => &text[..at],
        None => &text,
    };
    let without_comments: String =
        text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n");
    // String literals hold messages, not paths.
    let mut out = String::with_capacity(without_comments.len());
    let mut in_string = false;
    let mut escaped = false;
    for c in without_comments.chars() {
        match (in_string, c) {
            (true, '\\') if !escaped => escaped = true,
            (true, '"') if !escaped => in_string = false,
            (true, _) => escaped = false,
            (false, '"') => in_string = true,
            (false, _) => out.push(c),
        }
    }
    out
}

/// `a::{b, c::{d, e}}` written out as ` a::b  a::c::d  a::c::e `.
fn expand_groups(code: &str) -> String {
    let mut out = String::new();
    let mut rest = code;
    while let Some(open) = rest.find("::{") {
        let prefix_start = rest[..open]
            .rfind(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':' || c == '@'))
            .map_or(0, |i| i + 1);
        out.push_str(&rest[..prefix_start]);
        let prefix = &rest[prefix_start..open];
        let mut depth = 0;
        let mut end = rest.len() - 1;
        for (i, c) in rest[open + 2..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + 2 + i;
                        break;
                    }
                }
                _ => {}
            }
        }
        for item in split_top(&rest[open + 3..end]) {
            let item = item.trim();
            match item {
                "" => {}
                "self" => out.push_str(&format!(" {prefix} ")),
                _ => out.push_str(&format!(" {prefix}::{} ", expand_groups(item).trim())),
            }
        }
        rest = &rest[end + 1..];
    }
    out.push_str(rest);
    out
}

/// Split at commas outside braces.
fn split_top(s: &str) -> Vec<String> {
    let (mut parts, mut depth, mut current) = (Vec::new(), 0, String::new());
    for c in s.chars() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(std::mem::take(&mut current));
                continue;
            }
            _ => {}
        }
        current.push(c);
    }
    parts.push(current);
    // A nested group's items come out as several paths separated by spaces.
    parts.into_iter().flat_map(|p| expand_groups(&p).split_whitespace().map(String::from).collect::<Vec<_>>()).collect()
}

/// The `use` declarations of some code, each as `(visibility, its paths written out)`, and the
/// code that remains without them. A declaration starts a line and ends at its `;` (a group may
/// span lines; no `;` stands inside one).
fn use_declarations(code: &str) -> (Vec<(String, Vec<String>)>, String) {
    let (mut declarations, mut rest) = (Vec::new(), String::new());
    let mut lines = code.lines();
    while let Some(line) = lines.next() {
        let trimmed = line.trim_start();
        let declaration = trimmed.find("use ").filter(|&at| is_visibility(&trimmed[..at]));
        let Some(at) = declaration else {
            rest.push_str(line);
            rest.push('\n');
            continue;
        };
        let mut body = trimmed[at + 4..].to_string();
        while !body.contains(';') {
            let Some(next) = lines.next() else { break };
            body.push(' ');
            body.push_str(next);
        }
        let (statement, after) = body.split_once(';').unwrap_or((&body, ""));
        rest.push_str(after);
        rest.push('\n');
        // `a as b` kept as one word through the expansion of groups.
        let statement = statement.split_whitespace().collect::<Vec<_>>().join(" ").replace(" as ", "@as@");
        let paths = expand_groups(&statement).split_whitespace().map(String::from).collect();
        declarations.push((trimmed[..at].trim().to_string(), paths));
    }
    (declarations, rest)
}

fn is_visibility(s: &str) -> bool {
    let s = s.trim();
    s.is_empty() || s == "pub" || (s.starts_with("pub(") && s.ends_with(')'))
}

/// The module path a path written in `module` starts from, and the rest of its segments:
/// `crate::`, `super::`, `self::`, a child module of `module`, or an alias brought in by `use`.
fn anchor(
    path: &str,
    module: &[String],
    children: &BTreeSet<String>,
    aliases: &BTreeMap<String, Vec<String>>,
) -> Option<Vec<String>> {
    let segments: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
    let (head, mut rest) = segments.split_first()?;
    let mut full: Vec<String> = match *head {
        "crate" => Vec::new(),
        "super" => module[..module.len().saturating_sub(1)].to_vec(),
        "self" => module.to_vec(),
        h if children.contains(h) => module.iter().cloned().chain([h.to_string()]).collect(),
        h => aliases.get(h)?.clone(),
    };
    while let Some((&"super", r)) = rest.split_first() {
        full.pop();
        rest = r;
    }
    full.extend(rest.iter().map(|s| s.to_string()));
    Some(full)
}

/// A `use` declaration: its visibility and its paths written out.
type UseDeclaration = (String, Vec<String>);

/// A file read: its module path, the path's segments, its `use` declarations and its other code.
type Parsed = (String, Vec<String>, Vec<UseDeclaration>, String);

/// One source tree's imports between files.
struct Tree {
    modules: BTreeMap<String, PathBuf>,
    /// `(folder module, item name)` → the full path it re-exports.
    reexports: BTreeMap<(String, String), Vec<String>>,
    edges: BTreeMap<String, BTreeSet<String>>,
}

impl Tree {
    fn read(src: &Path) -> Tree {
        let modules = modules(src);
        let mut tree = Tree { modules, reexports: BTreeMap::new(), edges: BTreeMap::new() };
        let parsed: Vec<Parsed> = tree
            .modules
            .iter()
            .map(|(module, path)| {
                let parts: Vec<String> =
                    if module.is_empty() { Vec::new() } else { module.split("::").map(String::from).collect() };
                let (uses, rest) = use_declarations(&code(path));
                (module.clone(), parts, uses, rest)
            })
            .collect();
        // Re-exports first: a path may pass through any folder's facade.
        for (module, parts, uses, _) in &parsed {
            let children = tree.children(module);
            for (visibility, paths) in uses {
                if visibility.is_empty() {
                    continue;
                }
                for p in paths {
                    let (p, name) = split_alias(p);
                    if let Some(full) = anchor(&p, parts, &children, &BTreeMap::new()) {
                        tree.reexports.insert((module.clone(), name), full);
                    }
                }
            }
        }
        for (module, parts, uses, rest) in &parsed {
            let children = tree.children(module);
            let mut aliases = BTreeMap::new();
            let mut targets = BTreeSet::new();
            for (visibility, paths) in uses {
                for p in paths {
                    let (p, name) = split_alias(p);
                    let Some(full) = anchor(&p, parts, &children, &BTreeMap::new()) else { continue };
                    // A folder re-exporting its own child is its facade, not an import.
                    let facade = !visibility.is_empty()
                        && full.len() > parts.len()
                        && full.starts_with(parts)
                        && children.contains(&full[parts.len()]);
                    if !facade {
                        targets.extend(tree.resolve(&full));
                    }
                    aliases.insert(name, full);
                }
            }
            let words = expand_groups(rest);
            for word in words.split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')) {
                if !word.contains("::") {
                    continue;
                }
                if let Some(full) = anchor(word, parts, &children, &aliases) {
                    targets.extend(tree.resolve(&full));
                }
            }
            targets.remove(module);
            tree.edges.insert(module.clone(), targets);
        }
        tree
    }

    /// The child modules of `module` (the files below a folder's `mod.rs` or `lib.rs`).
    fn children(&self, module: &str) -> BTreeSet<String> {
        self.modules
            .keys()
            .filter_map(|m| {
                let rest = if module.is_empty() { Some(m.as_str()) } else { m.strip_prefix(&format!("{module}::")) };
                rest.filter(|r| !r.is_empty() && !r.contains("::")).map(String::from)
            })
            .collect()
    }

    /// The file a path leads to: the deepest module it names, through re-exports; `""` (lib.rs)
    /// for an item defined there. `None` for paths outside the crate's modules.
    fn resolve(&self, path: &[String]) -> Option<String> {
        let mut current = String::new();
        for (k, segment) in path.iter().enumerate() {
            let next = if current.is_empty() { segment.clone() } else { format!("{current}::{segment}") };
            if self.modules.contains_key(&next) {
                current = next;
            } else if let Some(target) = self.reexports.get(&(current.clone(), segment.clone())) {
                let mut further = target.clone();
                further.extend(path[k + 1..].iter().cloned());
                return if further == path { Some(current) } else { self.resolve(&further) };
            } else {
                break;
            }
        }
        Some(current)
    }

    /// Imports that go up the floors.
    fn upward(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (module, targets) in &self.edges {
            let Some(mine) = floor(module) else { continue };
            for target in targets {
                if floor(target).is_some_and(|f| f > mine) {
                    let shown = if target.is_empty() { "lib.rs" } else { target };
                    out.push(format!("{module} → {shown}"));
                }
            }
        }
        out
    }

    /// The import circles (strongly connected components of more than one file), each sorted.
    fn circles(&self) -> Vec<Vec<String>> {
        struct State<'a> {
            edges: &'a BTreeMap<String, BTreeSet<String>>,
            index: BTreeMap<&'a str, usize>,
            low: BTreeMap<&'a str, usize>,
            stack: Vec<&'a str>,
            circles: Vec<Vec<String>>,
        }
        fn visit<'a>(v: &'a str, s: &mut State<'a>) {
            let i = s.index.len();
            s.index.insert(v, i);
            s.low.insert(v, i);
            s.stack.push(v);
            for w in s.edges.get(v).into_iter().flatten() {
                let w = w.as_str();
                if !s.index.contains_key(w) {
                    visit(w, s);
                    let lw = s.low[w];
                    s.low.insert(v, s.low[v].min(lw));
                } else if s.stack.contains(&w) {
                    let iw = s.index[w];
                    s.low.insert(v, s.low[v].min(iw));
                }
            }
            if s.low[v] == s.index[v] {
                let mut component = Vec::new();
                while let Some(w) = s.stack.pop() {
                    component.push(w.to_string());
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    component.sort();
                    s.circles.push(component);
                }
            }
        }
        let mut state = State {
            edges: &self.edges,
            index: BTreeMap::new(),
            low: BTreeMap::new(),
            stack: Vec::new(),
            circles: Vec::new(),
        };
        for v in self.edges.keys() {
            if !state.index.contains_key(v.as_str()) {
                visit(v, &mut state);
            }
        }
        state.circles.sort();
        state.circles
    }
}

/// `a::b as c` (written `a::b@as@c`) → (`a::b`, `c`); `a::b` → (`a::b`, `b`).
fn split_alias(path: &str) -> (String, String) {
    match path.split_once("@as@") {
        Some((p, alias)) => (p.trim().to_string(), alias.trim().to_string()),
        None => (path.to_string(), path.rsplit("::").next().unwrap_or(path).to_string()),
    }
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn no_module_imports_one_on_a_higher_floor() {
    let tree = Tree::read(&src());
    let upward = tree.upward();
    assert!(upward.is_empty(), "imports up the floors of docs/architecture.md: {upward:#?}");
    // Every top-level module has its floor (a new one must be placed in the architecture).
    for module in tree.modules.keys().filter(|m| !m.is_empty()) {
        let top = module.split("::").next().unwrap();
        assert!(floor(top).is_some(), "`{top}` has no floor in docs/architecture.md and in FLOORS");
    }
}

#[test]
fn no_two_files_import_each_other_round_a_circle() {
    let tree = Tree::read(&src());
    let circles = tree.circles();
    assert!(circles.is_empty(), "import circles: {circles:#?}");
    // The checker sees imports at all: the pipeline imports the fit.
    assert!(tree.edges["calib::pipeline"].contains("calib::fit"), "{:?}", tree.edges["calib::pipeline"]);
}

#[test]
fn the_checker_finds_the_old_trees_circles_and_its_arrow_back_up() {
    let tree = Tree::read(Path::new("tests/data/architecture/old_tree/src"));
    // `use super::levels; levels::MarkerLevel` one way, `use crate::calib::pipeline::Level` back;
    // code in `record/mod.rs` calling `draw`, which imports `super::Scene` back.
    let circles = tree.circles();
    assert_eq!(
        circles,
        [
            vec!["calib::levels::markers".to_string(), "calib::pipeline".to_string()],
            vec!["record".to_string(), "record::draw".to_string()]
        ],
        "{:#?}",
        tree.edges
    );
    // An item defined in lib.rs, imported from below.
    assert_eq!(tree.upward(), ["report → lib.rs"], "{:#?}", tree.edges);
    // A folder's re-export of its own child is its facade, not an import.
    assert!(!tree.edges["calib"].contains("calib::pipeline"), "{:?}", tree.edges["calib"]);
}

#[test]
fn main_only_dispatches() {
    let main = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/main.rs")).unwrap();
    let code_lines = main.lines().filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with("//")).count();
    assert!(code_lines <= 40, "src/main.rs has {code_lines} lines of code: commands belong in src/cli/");
    assert!(!main.contains("spmcal::calib") && !main.contains("spmcal::dataset"), "main.rs calls the library");
}
