//! The README's figures come from programs, not from a keyboard: every table the README marks
//! with `<!-- figures: docs/results/<study>.md -->` on the line above it must show only numbers that
//! the study's last output holds (`cargo run --release --example <study>` writes that file; the
//! benchmark table's comes from `python3 benches/results.py` after `cargo bench`). A number in the
//! README matches when the output holds one that rounds to it at the README's precision; the first
//! column (labels such as "static, 200 poses") is not checked. A README figure typed by hand, or
//! left behind when a study was re-run, fails here naming the row and the number.

use std::path::Path;

/// The numbers of a piece of text, each with its count of decimals: `-0.00055`, `99.9`, `2,000`
/// (a thousands separator dropped), `1e-3`; the Unicode minus read as a minus. A digit run glued
/// to a letter or a dot before it (`x2`, `v0.36`) is a name, not a figure.
fn numbers(text: &str) -> Vec<(f64, usize)> {
    let chars: Vec<char> = without_thousands_separators(&text.replace('−', "-")).chars().collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let glued = i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '.' || chars[i - 1] == '_');
        if !chars[i].is_ascii_digit() || glued {
            i += 1;
            continue;
        }
        let start = i;
        let digits = |mut j: usize| {
            while j < chars.len() && chars[j].is_ascii_digit() {
                j += 1;
            }
            j
        };
        i = digits(i);
        let mut decimals = 0;
        if i + 1 < chars.len() && chars[i] == '.' && chars[i + 1].is_ascii_digit() {
            let end = digits(i + 1);
            decimals = end - i - 1;
            i = end;
        }
        let mut exponent = 0;
        if i + 1 < chars.len() && chars[i] == 'e' {
            let sign = usize::from(matches!(chars.get(i + 1), Some('-' | '+')));
            if chars.get(i + 1 + sign).is_some_and(char::is_ascii_digit) {
                let end = digits(i + 1 + sign);
                exponent = chars[i + 1..end].iter().collect::<String>().parse().unwrap_or(0);
                i = end;
            }
        }
        let negative = start > 0 && chars[start - 1] == '-';
        let value: f64 = chars[start..i].iter().collect::<String>().parse().unwrap_or(f64::NAN);
        // A number in scientific notation is as precise as its mantissa, scaled.
        found.push((if negative { -value } else { value }, (decimals as i32 - exponent).max(0) as usize));
    }
    found
}

/// `2,000` → `2000`: a comma between a digit and exactly three digits.
fn without_thousands_separators(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let digit = |k: usize| chars.get(k).is_some_and(char::is_ascii_digit);
    let separator =
        |k: usize| chars[k] == ',' && k > 0 && digit(k - 1) && (1..=3).all(|d| digit(k + d)) && !digit(k + 4);
    (0..chars.len()).filter(|&k| !separator(k)).map(|k| chars[k]).collect()
}

/// Whether `candidate` (from a study's output) rounds to `shown` at `decimals` places.
fn rounds_to(candidate: f64, shown: f64, decimals: usize) -> bool {
    let scale = 10f64.powi(decimals as i32);
    (candidate * scale).round() == (shown * scale).round()
}

/// A table row: its line in the README and its cells.
type Row = (usize, Vec<String>);

/// The README's tables that name their results file: (file, rows of cells below the header).
fn marked_tables(readme: &str) -> Vec<(String, Vec<Row>)> {
    let lines: Vec<&str> = readme.lines().collect();
    let mut tables = Vec::new();
    for (k, line) in lines.iter().enumerate() {
        let Some(file) = line.trim().strip_prefix("<!-- figures: ").and_then(|l| l.strip_suffix(" -->")) else {
            continue;
        };
        let rows = lines[k + 1..]
            .iter()
            .enumerate()
            .take_while(|(_, l)| l.starts_with('|'))
            .skip(2) // the header and the separator
            .map(|(j, l)| (k + 2 + j, l.trim_matches('|').split('|').map(|c| c.trim().to_string()).collect()))
            .collect();
        tables.push((file.to_string(), rows));
    }
    tables
}

#[test]
fn every_figure_of_a_marked_readme_table_is_in_its_studys_last_output() {
    let readme = std::fs::read_to_string("README.md").unwrap();
    let tables = marked_tables(&readme);
    // The accuracy, predicted-accuracy, camera-model, pixels, joint-scale, clock-rate, verdict and
    // benchmark tables.
    assert!(tables.len() >= 8, "only {} marked tables in README.md", tables.len());
    for study in ["pixels", "joint_scales", "clock_rate", "verdict"] {
        let file = format!("docs/results/{study}.md");
        assert!(tables.iter().any(|(f, _)| *f == file), "the {study} table is marked");
    }
    let mut problems = Vec::new();
    for (file, rows) in &tables {
        assert!(!rows.is_empty(), "README.md: the table under `<!-- figures: {file} -->` has no rows");
        let Ok(output) = std::fs::read_to_string(Path::new(file)) else {
            problems.push(format!("{file}: missing (run the study that writes it)"));
            continue;
        };
        let available = numbers(&output);
        for (line, cells) in rows {
            for cell in cells.iter().skip(1) {
                for (shown, decimals) in numbers(cell) {
                    if !available.iter().any(|(c, _)| rounds_to(*c, shown, decimals)) {
                        problems.push(format!("README.md:{line}: {shown} (in `{cell}`) is not in {file}"));
                    }
                }
            }
        }
    }
    assert!(problems.is_empty(), "figures the studies did not print:\n{}", problems.join("\n"));
}

#[test]
fn numbers_are_read_as_a_reader_reads_them() {
    let got = numbers("| 0.0145° | 1.02 ± 0.03 | 58 of 60 | −0.00001 | 2,000 poses | 3.6 M | 1e-3 | x2 | v0.36 |");
    let values: Vec<f64> = got.iter().map(|n| n.0).collect();
    assert_eq!(values, [0.0145, 1.02, 0.03, 58.0, 60.0, -0.00001, 2000.0, 3.6, 1e-3]);
    assert_eq!(got[0].1, 4);
    assert_eq!(got[8].1, 3);
    // Rounding, not truncation, and not a looser precision.
    assert!(rounds_to(0.05237, 0.0524, 4) && !rounds_to(0.05237, 0.0523, 4));
    assert!(rounds_to(0.5090, 0.509, 3) && !rounds_to(0.5096, 0.509, 3));
    assert!(rounds_to(60.0, 60.0, 0) && !rounds_to(61.0, 60.0, 0));
}
