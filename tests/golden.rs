//! Behaviour unchanged (issue 18): `calibrate` (both fit levels), `compare`, `plan` and `export`
//! run on the shipped datasets, and their outputs are checked against files captured before the
//! refactor, in `tests/data/golden/` (captured from commit 3062e2bbae4f129d003cd4fdf19c56d6b6e52b31).
//!
//! What is compared, per case (one `#[test]` each, named after the case):
//! - standard output: JSON (`--json`) value by value, or the text report line by line;
//! - parameters files (`*params.yaml`) field by field;
//! - every other file written (plan CSV, exported URDF and companion YAML) line by line.
//!
//! Numbers agree when `|new − old| ≤ 1e-9 · max(1, |old|, |new|)` (1e-9 absolute, relative for
//! large values); integers in JSON and YAML exactly; strings, keys, array lengths and all text
//! between the numbers of a line exactly. Nothing is ignored: the only part of an output that
//! differs between two runs is the temporary output folder the test passes (`--out`, `--urdf`,
//! echoed in `inputs`, the export summary and the report's `wrote …` line); it is written as
//! `<OUT>` in the golden files and replaced by `<OUT>` in the new output before comparing. No
//! output holds a timing or a date. Key order (JSON, YAML) is not compared; the golden JSON files
//! are written one field a line with keys sorted. `compare` and `export` read the golden
//! parameters files, so a change in `calibrate` shows in the `calibrate_*` cases alone.
//!
//! Regenerate the golden files ONLY for a deliberate change of behaviour (say which in the
//! commit), from the repository root:
//!
//! ```sh
//! SPMCAL_GOLDEN=regenerate cargo test --release --test golden -- --test-threads=1
//! git diff --stat tests/data/golden    # review every changed value
//! ```
//!
//! (`--test-threads=1`: tests run in name order, so the `calibrate_*` cases write the parameters
//! files that `compare_*` and `export_*` read before those run.) `SPMCAL_GOLDEN_BIN=/path/to/spmcal`
//! runs another binary instead of this build's (the files were captured with the binary of the
//! commit above, built by `cargo test --release --no-run --test cli`).

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// The placeholder for the temporary output folder, in arguments and golden files.
const OUT: &str = "<OUT>";
/// The golden files' folder, relative to the repository root.
const GOLDEN: &str = "tests/data/golden";

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn binary() -> PathBuf {
    std::env::var_os("SPMCAL_GOLDEN_BIN").map(PathBuf::from).unwrap_or_else(|| env!("CARGO_BIN_EXE_spmcal").into())
}

fn regenerating() -> bool {
    std::env::var("SPMCAL_GOLDEN").is_ok_and(|v| v == "regenerate")
}

/// What standard output holds.
#[derive(Clone, Copy)]
enum Stdout {
    Json,
    Text,
}

/// Runs `spmcal args` from the repository root with `<OUT>` standing for a fresh temporary folder,
/// then compares (or, regenerating, writes) its standard output as `<case>.stdout.json|txt` and
/// each of `files` (written into `<OUT>`) as `<case>.<file>`.
fn case(name: &str, stdout: Stdout, args: &[&str], files: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    // Canonical, so that a path the program resolves still matches the placeholder's.
    let out_dir = dir.path().canonicalize().unwrap();
    let out_str = out_dir.to_str().unwrap();
    let args: Vec<String> = args.iter().map(|a| a.replace(OUT, out_str)).collect();
    let started = std::time::Instant::now();
    let run = Command::new(binary()).args(&args).current_dir(root()).output().unwrap();
    eprintln!("{name}: spmcal {} ({:.2} s)", args.join(" "), started.elapsed().as_secs_f64());
    assert!(
        run.status.success(),
        "{name}: spmcal {} failed ({}):\n{}",
        args.join(" "),
        run.status,
        String::from_utf8_lossy(&run.stderr)
    );
    let normalise = |text: &str| text.replace(out_str, OUT);

    let mut outputs = Vec::new();
    let text = normalise(&String::from_utf8(run.stdout).expect("standard output is UTF-8"));
    outputs.push(match stdout {
        Stdout::Json => (format!("{name}.stdout.json"), text),
        Stdout::Text => (format!("{name}.stdout.txt"), text),
    });
    for file in files {
        let written = std::fs::read_to_string(out_dir.join(file))
            .unwrap_or_else(|e| panic!("{name}: spmcal {} wrote no readable `{file}`: {e}", args.join(" ")));
        outputs.push((format!("{name}.{file}"), normalise(&written)));
    }

    let golden_dir = root().join(GOLDEN);
    if regenerating() {
        for (golden, text) in &outputs {
            let text = if golden.ends_with(".json") {
                // One field a line, so that a regeneration's diff shows the fields that changed.
                let value: Value = serde_json::from_str(text).unwrap();
                let mut pretty = String::new();
                write_json(&mut pretty, &value, 0);
                pretty + "\n"
            } else {
                text.clone()
            };
            std::fs::write(golden_dir.join(golden), text).unwrap();
        }
        eprintln!("{name}: golden files regenerated");
        return;
    }

    let mut failures = Vec::new();
    for (golden, new) in &outputs {
        let path = golden_dir.join(golden);
        let old = std::fs::read_to_string(&path).unwrap_or_else(|e| {
            panic!("{name}: cannot read the golden file {}: {e} (see tests/golden.rs to regenerate)", path.display())
        });
        let mut diffs = Diffs::default();
        if golden.ends_with(".json") {
            diffs.values("", &parse_json(&old, golden, "golden"), &parse_json(new, golden, "new"));
        } else if golden.ends_with("params.yaml") {
            diffs.values("", &parse_yaml(&old, golden, "golden"), &parse_yaml(new, golden, "new"));
        } else {
            diffs.text(&old, new);
        }
        if !diffs.0.is_empty() {
            let shown = diffs.0.len().min(40);
            let mut report = format!("{GOLDEN}/{golden}: {} difference(s) (golden → new)", diffs.0.len());
            for d in &diffs.0[..shown] {
                report += &format!("\n  {d}");
            }
            if shown < diffs.0.len() {
                report += &format!("\n  … and {} more", diffs.0.len() - shown);
            }
            failures.push(report);
        }
    }
    assert!(
        failures.is_empty(),
        "{name}: spmcal {} no longer gives the captured output:\n{}",
        args.join(" "),
        failures.join("\n")
    );
}

/// JSON indented by field, with arrays of numbers and strings kept on one line.
fn write_json(out: &mut String, value: &Value, depth: usize) {
    let indent = |out: &mut String, depth: usize| out.extend(std::iter::repeat_n("  ", depth));
    match value {
        Value::Object(map) if !map.is_empty() => {
            out.push_str("{\n");
            for (k, (key, v)) in map.iter().enumerate() {
                indent(out, depth + 1);
                out.push_str(&serde_json::to_string(key).unwrap());
                out.push_str(": ");
                write_json(out, v, depth + 1);
                out.push_str(if k + 1 < map.len() { ",\n" } else { "\n" });
            }
            indent(out, depth);
            out.push('}');
        }
        Value::Array(items) if !flat(value) => {
            out.push_str("[\n");
            for (k, v) in items.iter().enumerate() {
                indent(out, depth + 1);
                write_json(out, v, depth + 1);
                out.push_str(if k + 1 < items.len() { ",\n" } else { "\n" });
            }
            indent(out, depth);
            out.push(']');
        }
        _ => out.push_str(&serde_json::to_string(value).unwrap()),
    }
}

/// An array of numbers, strings, booleans and nulls only (empty included).
fn flat(value: &Value) -> bool {
    value.as_array().is_some_and(|items| items.iter().all(|v| !v.is_object() && !v.is_array()))
}

fn parse_json(text: &str, file: &str, which: &str) -> Value {
    serde_json::from_str(text).unwrap_or_else(|e| panic!("{file} ({which}): not JSON: {e}"))
}

/// A YAML document as a JSON value (the parameters file has string keys only).
fn parse_yaml(text: &str, file: &str, which: &str) -> Value {
    let yaml: serde_yaml::Value =
        serde_yaml::from_str(text).unwrap_or_else(|e| panic!("{file} ({which}): not YAML: {e}"));
    serde_json::to_value(yaml).unwrap_or_else(|e| panic!("{file} ({which}): not a plain YAML tree: {e}"))
}

/// `a` and `b` agree to 1e-9, absolute below 1 and relative above.
fn close(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

/// The differences found in one file, each naming its field or line, the golden and the new value.
#[derive(Default)]
struct Diffs(Vec<String>);

impl Diffs {
    fn values(&mut self, at: &str, old: &Value, new: &Value) {
        let field = if at.is_empty() { "(document)" } else { at };
        match (old, new) {
            (Value::Object(a), Value::Object(b)) => {
                // Wall-clock times (`stages[].seconds`) differ from run to run.
                for (key, x) in a.iter().filter(|(key, _)| *key != "seconds") {
                    let here = if at.is_empty() { key.clone() } else { format!("{at}.{key}") };
                    match b.get(key) {
                        Some(y) => self.values(&here, x, y),
                        None => self.0.push(format!("field `{here}`: {x} → (missing)")),
                    }
                }
                for (key, y) in b.iter().filter(|(key, _)| !a.contains_key(*key)) {
                    let here = if at.is_empty() { key.clone() } else { format!("{at}.{key}") };
                    self.0.push(format!("field `{here}`: (absent) → {y}"));
                }
            }
            (Value::Array(a), Value::Array(b)) => {
                if a.len() != b.len() {
                    self.0.push(format!("field `{field}`: {} elements → {} elements", a.len(), b.len()));
                }
                for (k, (x, y)) in a.iter().zip(b).enumerate() {
                    self.values(&format!("{at}[{k}]"), x, y);
                }
            }
            (Value::Number(a), Value::Number(b)) => {
                let same = match (a.as_i64(), b.as_i64(), a.as_u64(), b.as_u64()) {
                    (Some(x), Some(y), _, _) => x == y,
                    (_, _, Some(x), Some(y)) => x == y,
                    _ => close(a.as_f64().unwrap(), b.as_f64().unwrap()),
                };
                if !same && (a.is_f64() || b.is_f64()) {
                    let difference = b.as_f64().unwrap() - a.as_f64().unwrap();
                    self.0.push(format!("field `{field}`: {a} → {b} (difference {difference:e})"));
                } else if !same {
                    self.0.push(format!("field `{field}`: {a} → {b}"));
                }
            }
            _ if old == new => {}
            _ => self.0.push(format!("field `{field}`: {old} → {new}")),
        }
    }

    /// Line by line; within a line the text between numbers must be identical and the numbers close.
    /// Lines added or removed are shown once, as the block between the common start and end.
    fn text(&mut self, old: &str, new: &str) {
        let (a, b): (Vec<_>, Vec<_>) = (old.lines().collect(), new.lines().collect());
        let same = |x: &str, y: &str| x == y || same_line(x, y);
        let start = a.iter().zip(&b).take_while(|(x, y)| same(x, y)).count();
        if a.len() == b.len() {
            for (k, (x, y)) in a.iter().zip(&b).enumerate().skip(start) {
                if !same(x, y) {
                    self.0.push(format!("line {}:\n    golden: {x}\n    new:    {y}", k + 1));
                }
            }
            return;
        }
        let end = a[start..].iter().rev().zip(b[start..].iter().rev()).take_while(|(x, y)| same(x, y)).count();
        let block = |lines: &[&str]| {
            let shown: Vec<_> = lines.iter().take(20).map(|l| format!("\n      {l}")).collect();
            let more = if lines.len() > 20 { format!("\n      … {} more", lines.len() - 20) } else { String::new() };
            shown.concat() + &more
        };
        self.0.push(format!(
            "{} lines → {} lines; golden lines {}–{}:{}\n    became new lines {}–{}:{}",
            a.len(),
            b.len(),
            start + 1,
            a.len() - end,
            block(&a[start..a.len() - end]),
            start + 1,
            b.len() - end,
            block(&b[start..b.len() - end]),
        ));
    }
}

fn same_line(a: &str, b: &str) -> bool {
    let (a, b) = (tokens(a), tokens(b));
    a.len() == b.len()
        && a.iter().zip(&b).all(|(x, y)| match (x, y) {
            (Token::Number(x), Token::Number(y)) => close(*x, *y),
            _ => x == y,
        })
}

#[derive(PartialEq, Debug)]
enum Token<'a> {
    Number(f64),
    Other(&'a str),
}

/// A line cut into numbers (an optional sign not following a letter or digit, digits, a fraction,
/// an exponent) and the text between them.
fn tokens(line: &str) -> Vec<Token<'_>> {
    let bytes = line.as_bytes();
    let digit = |k: usize| bytes.get(k).is_some_and(u8::is_ascii_digit);
    let mut out = Vec::new();
    let (mut k, mut other) = (0, 0);
    while k < bytes.len() {
        let after_word = k > 0 && (bytes[k - 1].is_ascii_alphanumeric() || bytes[k - 1] == b'_');
        let signed = matches!(bytes[k], b'-' | b'+') && !after_word;
        let body = if signed { k + 1 } else { k };
        let starts = digit(body) || (bytes.get(body) == Some(&b'.') && digit(body + 1));
        if !starts {
            k += 1;
            continue;
        }
        let mut end = body;
        while digit(end) {
            end += 1;
        }
        if bytes.get(end) == Some(&b'.') {
            end += 1;
            while digit(end) {
                end += 1;
            }
        }
        if matches!(bytes.get(end), Some(b'e' | b'E')) {
            let exp = if matches!(bytes.get(end + 1), Some(b'-' | b'+')) { end + 2 } else { end + 1 };
            if digit(exp) {
                end = exp;
                while digit(end) {
                    end += 1;
                }
            }
        }
        match line[k..end].parse::<f64>() {
            Ok(x) => {
                if other < k {
                    out.push(Token::Other(&line[other..k]));
                }
                out.push(Token::Number(x));
                other = end;
                k = end;
            }
            Err(_) => k += 1,
        }
    }
    if other < bytes.len() {
        out.push(Token::Other(&line[other..]));
    }
    out
}

#[test]
fn the_line_comparison_tolerates_1e_9_and_nothing_else() {
    assert!(same_line("a 1.0, -2.5e-3 m1", "a 1.0000000001, -2.5000000001e-3 m1"));
    assert!(!same_line("a 1.0, b", "a 1.00001, b"));
    assert!(!same_line("a 1.0, b", "a 1.0; b"));
    assert!(same_line("leg1.alpha1 +0.5", "leg1.alpha1 +0.5000000000001"));
    assert!(!same_line("leg1.alpha1", "leg2.alpha1"));
    assert!(same_line("1e9", "1000000000.5"));
    assert_eq!(tokens("x=-1.5e-3,y"), vec![Token::Other("x="), Token::Number(-1.5e-3), Token::Other(",y")]);
}

/// The orientation-level fit: the built-in settings with `fit: orientations`.
const ORIENTATIONS: &str = "tests/data/golden/config_orientations.yaml";
const PARAMS_400: &str = "tests/data/golden/calibrate_markers_sim_400.params.yaml";
const PARAMS_400_ORIENTATIONS: &str = "tests/data/golden/calibrate_orientations_sim_400.params.yaml";
const PARAMS_SEQUENTIAL: &str = "tests/data/golden/calibrate_markers_sequential_200.params.yaml";

/// One test per case: `name: stdout kind, [arguments], [files written into <OUT>];`.
macro_rules! golden {
    ($($name:ident: $stdout:ident, [$($arg:expr),* $(,)?], [$($file:expr),* $(,)?];)*) => {$(
        #[test]
        fn $name() {
            case(stringify!($name), Stdout::$stdout, &[$($arg),*], &[$($file),*]);
        }
    )*};
}

golden! {
    // The marker-level fit (the default) on every shipped session with markers, as JSON and as text.
    calibrate_markers_sim_20: Json,
        ["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--out", "<OUT>/params.yaml", "--json"],
        ["params.yaml"];
    calibrate_markers_sim_400: Json,
        ["calibrate", "--dataset", "datasets/agile_wrist_sim_400", "--out", "<OUT>/params.yaml", "--json"],
        ["params.yaml"];
    calibrate_markers_sequential_200: Json,
        ["calibrate", "--dataset", "datasets/agile_wrist_sequential_200", "--out", "<OUT>/params.yaml", "--json"],
        ["params.yaml"];
    calibrate_markers_free_motion_120s: Json,
        ["calibrate", "--dataset", "datasets/agile_wrist_free_motion_120s", "--out", "<OUT>/params.yaml", "--json"],
        ["params.yaml"];
    calibrate_markers_sim_20_text: Text,
        ["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--out", "<OUT>/params.yaml"], [];
    calibrate_markers_sim_400_text: Text,
        ["calibrate", "--dataset", "datasets/agile_wrist_sim_400", "--out", "<OUT>/params.yaml"], [];
    calibrate_markers_sequential_200_text: Text,
        ["calibrate", "--dataset", "datasets/agile_wrist_sequential_200", "--out", "<OUT>/params.yaml"], [];
    calibrate_markers_free_motion_120s_text: Text,
        ["calibrate", "--dataset", "datasets/agile_wrist_free_motion_120s", "--out", "<OUT>/params.yaml"], [];

    // The orientation-level fit on the sessions of discrete poses (the sequential one by its stations;
    // the free-motion recording, one marker a frame, is refused).
    calibrate_orientations_sim_20: Json,
        ["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--config", ORIENTATIONS,
         "--out", "<OUT>/params.yaml", "--json"],
        ["params.yaml"];
    calibrate_orientations_sim_400: Json,
        ["calibrate", "--dataset", "datasets/agile_wrist_sim_400", "--config", ORIENTATIONS,
         "--out", "<OUT>/params.yaml", "--json"],
        ["params.yaml"];
    calibrate_orientations_sequential_200: Json,
        ["calibrate", "--dataset", "datasets/agile_wrist_sequential_200", "--config", ORIENTATIONS,
         "--out", "<OUT>/params.yaml", "--json"],
        ["params.yaml"];
    calibrate_orientations_sim_20_text: Text,
        ["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--config", ORIENTATIONS,
         "--out", "<OUT>/params.yaml"], [];
    calibrate_orientations_sim_400_text: Text,
        ["calibrate", "--dataset", "datasets/agile_wrist_sim_400", "--config", ORIENTATIONS,
         "--out", "<OUT>/params.yaml"], [];
    calibrate_orientations_sequential_200_text: Text,
        ["calibrate", "--dataset", "datasets/agile_wrist_sequential_200", "--config", ORIENTATIONS,
         "--out", "<OUT>/params.yaml"], [];

    // The nominal model, then beside it the calibrated one (the golden parameters file), at both levels.
    compare_sim_400_nominal: Json,
        ["compare", "--dataset", "datasets/agile_wrist_sim_400", "--json"], [];
    compare_sim_400_calibrated: Json,
        ["compare", "--dataset", "datasets/agile_wrist_sim_400", "--params", PARAMS_400, "--json"], [];
    compare_sim_400_calibrated_markers: Json,
        ["compare", "--dataset", "datasets/agile_wrist_sim_400", "--params", PARAMS_400, "--level", "markers",
         "--json"], [];
    compare_sequential_200_calibrated: Json,
        ["compare", "--dataset", "datasets/agile_wrist_sequential_200", "--params", PARAMS_SEQUENTIAL, "--json"], [];

    // Plans: the multiplicative algorithm (over 150 candidates), the cone program (up to 150), a
    // session augmented, and a calibrated geometry.
    plan_multiplicative: Json,
        ["plan", "--poses", "10", "--candidates", "200", "--out", "<OUT>/plan.csv", "--json"], ["plan.csv"];
    plan_cone_program: Json,
        ["plan", "--poses", "8", "--candidates", "50", "--out", "<OUT>/plan.csv", "--json"], ["plan.csv"];
    plan_augment: Json,
        ["plan", "--poses", "6", "--candidates", "200", "--augment", "datasets/agile_wrist_sim_20",
         "--out", "<OUT>/plan.csv", "--json"], ["plan.csv"];
    plan_calibrated: Json,
        ["plan", "--poses", "10", "--candidates", "200", "--params", PARAMS_400, "--out", "<OUT>/plan.csv",
         "--json"], ["plan.csv"];

    // A calibrated URDF and its companion, from each fit's parameters.
    export_markers_sim_400: Json,
        ["export", "--params", PARAMS_400, "--urdf", "<OUT>/agile_wrist_calibrated.urdf", "--json"],
        ["agile_wrist_calibrated.urdf", "agile_wrist_calibrated.yaml"];
    export_orientations_sim_400: Json,
        ["export", "--params", PARAMS_400_ORIENTATIONS, "--urdf", "<OUT>/agile_wrist_calibrated.urdf", "--json"],
        ["agile_wrist_calibrated.urdf", "agile_wrist_calibrated.yaml"];
}
