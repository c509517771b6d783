//! The architecture of docs/architecture.md, kept true: data flows one way through the library's
//! floors (no module imports one on a floor above it), no two files import each other, directly
//! or round a circle (re-exports of a folder's `mod.rs` followed to the file that defines the
//! item), and `main.rs` only dispatches.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The floors of docs/architecture.md, bottom first.
const FLOORS: &[&[&str]] = &[
    &["math", "io"],
    &["model"],
    &["dataset"],
    &["vision", "sim"],
    &["calib"],
    &["plan", "compare"],
    &["record", "html"],
    &["cli"],
];

fn floor(top: &str) -> Option<usize> {
    FLOORS.iter().position(|f| f.contains(&top))
}

/// Every `.rs` file under `src/`, by module path (`calib::fit`; `""` for lib.rs).
fn modules() -> BTreeMap<String, PathBuf> {
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
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&src, &mut files);
    files
        .into_iter()
        .filter(|f| f.file_name().is_some_and(|n| n != "main.rs"))
        .map(|f| {
            let rel = f.strip_prefix(&src).unwrap().with_extension("");
            let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
            if parts.last().is_some_and(|p| p == "mod" || p == "lib") {
                parts.pop();
            }
            (parts.join("::"), f)
        })
        .collect()
}

/// The code of a file without its `#[cfg(test)]` module and its comments.
fn code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let text = match text.find("#[cfg(test)]\nmod tests {") {
        Some(at) => &text[..at],
        None => &text,
    };
    text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// Paths `crate::a::b…` and `super::a…` in `code`, as segments from the crate root.
fn paths(code: &str, module: &[String]) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    // `use` groups: `use crate::a::{b, c::d}` → crate::a::b, crate::a::c::d (one level of braces).
    let expanded = expand_groups(code);
    let words: Vec<&str> = expanded.split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).collect();
    for word in words {
        let segments: Vec<&str> = word.split("::").filter(|s| !s.is_empty()).collect();
        let (head, rest) = match segments.split_first() {
            Some((h, r)) => (*h, r),
            None => continue,
        };
        let base: Vec<String> = match head {
            "crate" => Vec::new(),
            "super" => module[..module.len().saturating_sub(1)].to_vec(),
            _ => continue,
        };
        let mut full = base;
        let mut rest = rest;
        while let Some((&"super", r)) = rest.split_first() {
            full.pop();
            rest = r;
        }
        full.extend(rest.iter().map(|s| s.to_string()));
        out.push(full);
    }
    out
}

/// `a::{b, c}` written out as `a::b a::c` (nested braces one level deep are enough here).
fn expand_groups(code: &str) -> String {
    let mut out = String::new();
    let mut rest = code;
    while let Some(open) = rest.find("::{") {
        let prefix_start =
            rest[..open].rfind(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).map_or(0, |i| i + 1);
        out.push_str(&rest[..prefix_start]);
        let prefix = &rest[prefix_start..open];
        let mut depth = 0;
        let mut end = open + 2;
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
        let inner = &rest[open + 3..end];
        for item in split_top(inner) {
            let item = item.trim();
            if !item.is_empty() {
                out.push_str(&format!(" {prefix}::{item} "));
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
    // Nested groups are expanded by a second pass.
    parts
        .into_iter()
        .map(|p| expand_groups(&p))
        .flat_map(|p| p.split_whitespace().map(String::from).collect::<Vec<_>>())
        .collect()
}

/// What each folder's `mod.rs` re-exports: `(folder, name)` → the child module defining it.
fn reexports(modules: &BTreeMap<String, PathBuf>) -> BTreeMap<(String, String), String> {
    let mut out = BTreeMap::new();
    for (module, path) in modules {
        if !path.ends_with("mod.rs") && !path.ends_with("lib.rs") {
            continue;
        }
        let text = expand_groups(&code(path));
        for line in text.split(';') {
            let line = line.trim();
            let Some(at) = line.find("use ") else { continue };
            if !line[..at].trim().starts_with("pub") {
                continue;
            }
            for item in line[at + 4..].split_whitespace() {
                let segments: Vec<&str> = item.split("::").collect();
                if segments.len() >= 2 && !["crate", "super", "self"].contains(&segments[0]) {
                    let child =
                        if module.is_empty() { segments[0].to_string() } else { format!("{module}::{}", segments[0]) };
                    let name = segments.last().unwrap().split(" as ").next().unwrap().trim().to_string();
                    out.insert((module.clone(), name), child);
                }
            }
        }
    }
    out
}

/// The file (module) a path leads to: the deepest module it names, through re-exports.
fn resolve(
    path: &[String],
    modules: &BTreeMap<String, PathBuf>,
    reexports: &BTreeMap<(String, String), String>,
) -> Option<String> {
    let mut current = String::new();
    for segment in path {
        let next = if current.is_empty() { segment.clone() } else { format!("{current}::{segment}") };
        if modules.contains_key(&next) {
            current = next;
        } else if let Some(child) = reexports.get(&(current.clone(), segment.clone())) {
            return Some(child.clone());
        } else {
            break;
        }
    }
    (!current.is_empty()).then_some(current)
}

/// Import edges between files: `module` → the files its code names.
fn edges() -> BTreeMap<String, BTreeSet<String>> {
    let modules = modules();
    let reexports = reexports(&modules);
    let mut out = BTreeMap::new();
    for (module, path) in &modules {
        let parts: Vec<String> =
            if module.is_empty() { Vec::new() } else { module.split("::").map(String::from).collect() };
        let is_folder = path.ends_with("mod.rs") || path.ends_with("lib.rs");
        let mut targets = BTreeSet::new();
        for p in paths(&code(path), &parts) {
            if let Some(target) = resolve(&p, &modules, &reexports) {
                // A folder's own children (its facade) and the file itself are not imports.
                if target != *module && !(is_folder && target.starts_with(&format!("{module}::"))) && !module.is_empty()
                {
                    targets.insert(target);
                }
            }
        }
        out.insert(module.clone(), targets);
    }
    out
}

#[test]
fn no_module_imports_one_on_a_higher_floor() {
    let mut upward = Vec::new();
    for (module, targets) in edges() {
        let top = module.split("::").next().unwrap_or("");
        let Some(mine) = floor(top) else { continue };
        for target in targets {
            let their = target.split("::").next().unwrap_or("");
            if floor(their).is_some_and(|f| f > mine) {
                upward.push(format!("{module} → {target}"));
            }
        }
    }
    assert!(upward.is_empty(), "imports up the floors of docs/architecture.md: {upward:#?}");
    // Every top-level module has its floor (a new one must be placed in the architecture).
    for module in modules().keys().filter(|m| !m.is_empty()) {
        let top = module.split("::").next().unwrap();
        assert!(floor(top).is_some(), "`{top}` has no floor in docs/architecture.md and in FLOORS");
    }
}

#[test]
fn no_two_files_import_each_other_round_a_circle() {
    let edges = edges();
    // Tarjan's strongly connected components.
    struct State<'a> {
        edges: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        circles: Vec<Vec<&'a str>>,
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
                component.push(w);
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                s.circles.push(component);
            }
        }
    }
    let mut state =
        State { edges: &edges, index: BTreeMap::new(), low: BTreeMap::new(), stack: Vec::new(), circles: Vec::new() };
    for v in edges.keys() {
        if !state.index.contains_key(v.as_str()) {
            visit(v, &mut state);
        }
    }
    assert!(state.circles.is_empty(), "import circles: {:#?}", state.circles);
    // The checker sees imports at all: the pipeline imports the fit.
    assert!(edges["calib::pipeline"].contains("calib::fit"), "{:?}", edges["calib::pipeline"]);
}

#[test]
fn main_only_dispatches() {
    let main = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/main.rs")).unwrap();
    let code_lines = main.lines().filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with("//")).count();
    assert!(code_lines <= 40, "src/main.rs has {code_lines} lines of code: commands belong in src/cli/");
    assert!(!main.contains("spmcal::calib") && !main.contains("spmcal::dataset"), "main.rs calls the library");
}
