//! The documentation holds together: every relative link and image in `README.md` and
//! `docs/*.md` points at a file or folder that exists (and, for a `#fragment` into a Markdown
//! page, at a heading of that page), every docs page is linked from the README, and the README
//! stays short enough to show the shape of the tool.
//!
//! Standard library only. Links inside fenced code blocks and inline code spans are not links.

use std::collections::{BTreeMap, HashMap};
use std::fs;
use std::path::{Path, PathBuf};

/// The README's line budget (issue 18).
const README_MAX_LINES: usize = 300;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `README.md` and every `docs/*.md`, in a stable order.
fn pages() -> Vec<PathBuf> {
    let mut pages = vec![root().join("README.md")];
    let docs = root().join("docs");
    let mut in_docs: Vec<PathBuf> = fs::read_dir(&docs)
        .unwrap_or_else(|e| panic!("{}: {e}", docs.display()))
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|ext| ext == "md"))
        .collect();
    in_docs.sort();
    pages.extend(in_docs);
    pages
}

fn read(path: &Path) -> String {
    fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn relative(path: &Path) -> String {
    path.strip_prefix(root()).unwrap_or(path).display().to_string()
}

/// A link or image found in a page: its 1-based line and its target as written.
#[derive(Debug)]
struct Link {
    line: usize,
    target: String,
}

/// The lines of `text` outside fenced code blocks (```` ``` ```` or `~~~`), with their 1-based numbers.
fn prose_lines(text: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut fence: Option<(char, usize)> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        let marker = trimmed.chars().next().filter(|c| *c == '`' || *c == '~');
        let run = marker.map_or(0, |c| trimmed.chars().take_while(|x| *x == c).count());
        match fence {
            Some((c, n)) => {
                // A closing fence: the same character, at least as long, nothing after it.
                if marker == Some(c) && run >= n && trimmed[run..].trim().is_empty() {
                    fence = None;
                }
            }
            None if indent <= 3 && run >= 3 => fence = Some((marker.unwrap(), run)),
            None => out.push((i + 1, line)),
        }
    }
    out
}

/// `line` with its inline code spans (`` `…` ``, ``` ``…`` ```) blanked out.
fn without_code_spans(line: &str) -> String {
    let chars: Vec<char> = line.chars().collect();
    let mut out = String::with_capacity(line.len());
    let mut i = 0;
    while i < chars.len() {
        if chars[i] != '`' {
            out.push(chars[i]);
            i += 1;
            continue;
        }
        let run = chars[i..].iter().take_while(|c| **c == '`').count();
        // Find the closing run of exactly the same length.
        let mut j = i + run;
        let mut close = None;
        while j < chars.len() {
            if chars[j] == '`' {
                let r = chars[j..].iter().take_while(|c| **c == '`').count();
                if r == run {
                    close = Some(j);
                    break;
                }
                j += r;
            } else {
                j += 1;
            }
        }
        match close {
            Some(j) => {
                out.extend(std::iter::repeat_n(' ', j + run - i));
                i = j + run;
            }
            None => {
                // An unmatched run is literal text.
                out.extend(std::iter::repeat_n('`', run));
                i += run;
            }
        }
    }
    out
}

/// Every inline link or image target (`[text](target)`, `![alt](target "title")`) and every
/// reference definition (`[label]: target`) outside code.
fn links(text: &str) -> Vec<Link> {
    let mut found = Vec::new();
    for (number, line) in prose_lines(text) {
        let line = without_code_spans(line);
        // Reference definitions.
        let trimmed = line.trim_start();
        if line.len() - trimmed.len() <= 3
            && trimmed.starts_with('[')
            && let Some(end) = trimmed.find("]:")
            && !trimmed[1..end].contains(']')
            && end > 1
        {
            if let Some(target) = trimmed[end + 2..].split_whitespace().next() {
                found.push(Link { line: number, target: target.trim_matches(['<', '>']).to_string() });
            }
            continue;
        }
        // Inline links and images: each `](` after a `[` opens a target.
        let mut from = 0;
        while let Some(at) = line[from..].find("](") {
            let open = from + at + 2;
            from = open;
            if !line[..open].contains('[') {
                continue;
            }
            // The target runs to the matching `)`; a title after a space is dropped.
            let mut depth = 0usize;
            let mut end = None;
            for (k, c) in line[open..].char_indices() {
                match c {
                    '(' => depth += 1,
                    ')' if depth == 0 => {
                        end = Some(open + k);
                        break;
                    }
                    ')' => depth -= 1,
                    _ => {}
                }
            }
            let Some(end) = end else { continue };
            let inside = line[open..end].trim();
            let target = if let Some(rest) = inside.strip_prefix('<') {
                rest.split('>').next().unwrap_or("")
            } else {
                inside.split_whitespace().next().unwrap_or("")
            };
            found.push(Link { line: number, target: target.to_string() });
            from = end;
        }
    }
    found
}

/// True for a target with a URL scheme (`https:`, `mailto:`, …) or a protocol-relative `//host`.
fn is_external(target: &str) -> bool {
    if target.starts_with("//") {
        return true;
    }
    match target.find(':') {
        Some(colon) => {
            let scheme = &target[..colon];
            scheme.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                && scheme.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
        }
        None => false,
    }
}

/// `%XX` escapes decoded (a malformed escape is kept as written).
fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && i + 3 <= bytes.len()
            && let Some(byte) =
                std::str::from_utf8(&bytes[i + 1..i + 3]).ok().and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(byte);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// GitHub's anchor for a heading: lowercase, spaces to `-`, every character other than letters,
/// digits, `-` and `_` removed.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a page's ATX headings (outside code blocks), with GitHub's `-1`, `-2`, …
/// suffixes for repeated headings.
fn anchors(text: &str) -> Vec<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = Vec::new();
    for (_, line) in prose_lines(text) {
        let trimmed = line.trim_start();
        if line.len() - trimmed.len() > 3 {
            continue;
        }
        let level = trimmed.chars().take_while(|c| *c == '#').count();
        if !(1..=6).contains(&level) {
            continue;
        }
        let rest = &trimmed[level..];
        if !(rest.is_empty() || rest.starts_with(' ') || rest.starts_with('\t')) {
            continue;
        }
        // A closing sequence of `#`s is not part of the heading.
        let rest = rest.trim();
        let rest = match rest.trim_end_matches('#') {
            stripped if stripped.is_empty() || stripped.ends_with(' ') => stripped.trim_end(),
            _ => rest,
        };
        // Inline code keeps its text; emphasis markers go (`slug` drops `*`, `` ` `` anyway).
        let base = slug(rest);
        let count = seen.entry(base.clone()).or_insert(0);
        let anchor = if *count == 0 { base } else { format!("{base}-{count}") };
        *count += 1;
        out.push(anchor);
    }
    out
}

/// Every broken relative link of `page` (text given), one message each, naming page, line and link.
fn broken_links(page: &Path, text: &str, anchors_of: &mut BTreeMap<PathBuf, Vec<String>>) -> Vec<String> {
    let folder = page.parent().unwrap();
    let name = relative(page);
    let mut broken = Vec::new();
    for Link { line, target } in links(text) {
        if target.is_empty() {
            broken.push(format!("{name}:{line}: link `{target}`: empty target"));
            continue;
        }
        if is_external(&target) {
            continue;
        }
        let (path_part, fragment) = match target.split_once('#') {
            Some((p, f)) => (p, Some(percent_decode(f))),
            None => (target.as_str(), None),
        };
        let path_part = percent_decode(path_part.split('?').next().unwrap());
        let resolved = if path_part.is_empty() {
            page.to_path_buf()
        } else if let Some(from_root) = path_part.strip_prefix('/') {
            root().join(from_root)
        } else {
            folder.join(&path_part)
        };
        if !resolved.exists() {
            broken.push(format!("{name}:{line}: link `{target}`: {} does not exist", relative(&normalise(&resolved))));
            continue;
        }
        let Some(fragment) = fragment else { continue };
        if !(resolved.is_file() && resolved.extension().is_some_and(|ext| ext == "md")) {
            continue; // Anchors into source files (`#L10`) or folders are not checked.
        }
        let key = normalise(&resolved);
        let list = anchors_of.entry(key.clone()).or_insert_with(|| anchors(&read(&resolved)));
        if !list.contains(&fragment) {
            broken.push(format!(
                "{name}:{line}: link `{target}`: {} has no heading with anchor `#{fragment}`",
                relative(&key)
            ));
        }
    }
    broken
}

/// `a/b/../c` → `a/c` (lexically; the path is known to exist or is only reported).
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

#[test]
fn every_relative_link_in_readme_and_docs_resolves() {
    let mut anchors_of = BTreeMap::new();
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = read(&page);
        checked += links(&text).len();
        broken.extend(broken_links(&page, &text, &mut anchors_of));
    }
    assert!(checked > 0, "no links found at all: the link finder is broken");
    assert!(broken.is_empty(), "{} broken link(s):\n  {}", broken.len(), broken.join("\n  "));
}

#[test]
fn readme_fits_its_line_budget() {
    let lines = read(&root().join("README.md")).lines().count();
    assert!(
        lines <= README_MAX_LINES,
        "README.md has {lines} lines; at most {README_MAX_LINES} (move detail to docs/)"
    );
}

#[test]
fn readme_links_every_docs_page() {
    let readme = root().join("README.md");
    let targets: Vec<String> = links(&read(&readme))
        .into_iter()
        .map(|link| link.target.split('#').next().unwrap().trim_start_matches("./").to_string())
        .collect();
    let missing: Vec<String> =
        pages().iter().skip(1).map(|page| relative(page.as_path())).filter(|page| !targets.contains(page)).collect();
    assert!(missing.is_empty(), "README.md does not link to: {}", missing.join(", "));
}

/// The repository cites nothing outside itself: no file (docs, code, Python, models, test data)
/// names the design notes the project was built from, or a folder beside the checkout. Users'
/// conventions and formats are `docs/conventions.md` and `docs/formats.md`.
#[test]
fn nothing_cites_files_outside_the_repository() {
    // Spelled in pieces, so that this file does not cite them itself.
    let needles = [["DESIGN", ".md"].concat(), ["../", "shared/"].concat(), ["shared/", "DESIGN"].concat()];
    let mut found = Vec::new();
    let mut stack = vec![root().to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            if path.is_dir() {
                // Build output, git's own files and Python's caches are not the repository's text.
                if !matches!(name.as_str(), ".git" | "target" | "__pycache__" | ".mypy_cache" | ".pytest_cache") {
                    stack.push(path);
                }
                continue;
            }
            let Ok(text) = fs::read_to_string(&path) else { continue };
            for (k, line) in text.lines().enumerate() {
                if needles.iter().any(|n| line.contains(n.as_str())) {
                    found.push(format!("{}:{}: {}", relative(&path), k + 1, line.trim()));
                }
            }
        }
    }
    assert!(found.is_empty(), "files cite what is not in the repository:\n{}", found.join("\n"));
    // The check can fail: a line that cites it is found.
    assert!(needles.iter().any(|n| format!("see {}", needles[0]).contains(n.as_str())));
}

/// The checker itself, on small pieces of Markdown: it must be able to fail.
#[test]
fn the_link_finder_and_slugs_behave() {
    let text = "# Title\n\
                See [a](a.md), ![img](pics/x.png \"title\") and [b](<b c.md#Part>).\n\
                `[not](a link)` and [web](https://example.org) [mail](mailto:x@y.z) [same](#title)\n\
                ```sh\n\
                [inside](fence.md)\n\
                ```\n\
                [ref]: ref/target.md\n\
                ## What `calibrate` prints\n\
                ## Title\n";
    let targets: Vec<String> = links(text).into_iter().map(|l| format!("{}:{}", l.line, l.target)).collect();
    assert_eq!(
        targets,
        [
            "2:a.md",
            "2:pics/x.png",
            "2:b c.md#Part",
            "3:https://example.org",
            "3:mailto:x@y.z",
            "3:#title",
            "7:ref/target.md"
        ]
    );
    assert!(is_external("https://example.org") && is_external("mailto:x@y.z") && !is_external("docs/a.md"));
    assert_eq!(anchors(text), ["title", "what-calibrate-prints", "title-1"]);
    assert_eq!(slug("Accuracy: paper vs Kabsch"), "accuracy-paper-vs-kabsch");
    assert_eq!(slug("Marker-level fit (`fit: markers`)"), "marker-level-fit-fit-markers");
    assert_eq!(percent_decode("a%20b.md"), "a b.md");

    // A page with one good and two bad links reports exactly the bad ones, naming line and link.
    let page = root().join("README.md");
    let text = "[ok](docs)\n\n[gone](no/such/file.md)\n[anchor](README.md#no-such-heading)\n";
    let broken = broken_links(&page, text, &mut BTreeMap::new());
    assert_eq!(broken.len(), 2, "{broken:?}");
    assert!(broken[0].starts_with("README.md:3: link `no/such/file.md`"), "{}", broken[0]);
    assert!(broken[1].starts_with("README.md:4: link `README.md#no-such-heading`"), "{}", broken[1]);
}
