//! The shareable HTML report (`calibrate --report`): a well-formed, self-contained document with
//! every section in order, one inline SVG plot per plot section, the verdict stating the report's
//! own cross-validated numbers against the config's threshold, and the text report's tables.

use std::process::Command;

use quick_xml::Reader;
use quick_xml::events::Event;

#[test]
fn the_report_has_every_section_and_plot_with_the_reports_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let (params, html) = (dir.path().join("p.yaml"), dir.path().join("report.html"));
    let run = Command::new(env!("CARGO_BIN_EXE_spmcal"))
        .args(["calibrate", "--dataset", "datasets/agile_wrist_sim_400", "--out"])
        .arg(&params)
        .arg("--report")
        .arg(&html)
        .arg("--json")
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let text = std::fs::read_to_string(&html).unwrap();
    // Self-contained: no script, no link or image fetched from anywhere.
    for outside in ["<script", "http://", "https://", "<img", "<link"] {
        let allowed =
            outside == "http://" && text.matches(outside).count() == text.matches("http://www.w3.org/").count();
        assert!(!text.contains(outside) || allowed, "{outside}");
    }
    // Parsed as XML: sections in order, each plot section with one SVG.
    let mut reader = Reader::from_str(&text);
    let (mut sections, mut svgs_in): (Vec<String>, Vec<String>) = (Vec::new(), Vec::new());
    loop {
        match reader.read_event().unwrap() {
            Event::Start(e) if e.name().as_ref() == b"section" => {
                let id = e.try_get_attribute("id").unwrap().unwrap().unescape_value().unwrap().to_string();
                sections.push(id);
            }
            Event::Start(e) if e.name().as_ref() == b"svg" => {
                svgs_in.push(sections.last().cloned().unwrap_or_default())
            }
            Event::Eof => break,
            _ => {}
        }
    }
    assert_eq!(sections, ["verdict", "per-pose", "residuals", "parameters", "identifiability", "coverage", "tables"]);
    assert_eq!(svgs_in, ["per-pose", "residuals", "parameters", "identifiability", "coverage"]);
    // The verdict says the report's numbers (3 decimals) and the config's threshold.
    let cv = &report["results"]["cross_validation"];
    for key in ["calibrated_rms", "nominal_rms"] {
        let shown = format!("{:.3} mm", cv[key].as_f64().unwrap());
        assert!(text.contains(&shown), "{shown}");
    }
    assert!(text.contains("PASS") && text.contains("threshold 1.000 mm"));
    // Every free parameter is on the ±2σ plot, and the weakest directions are named.
    for p in report["results"]["parameters"].as_array().unwrap() {
        assert!(text.contains(p["name"].as_str().unwrap()), "{p}");
    }
    assert_eq!(text.matches("<li>weak: ").count(), 3);
    // The tables are the text report's.
    assert!(text.contains("FDA vs camera, markers (mm)") && text.contains("identifiability:"));
}

#[test]
fn a_calibration_above_the_configs_threshold_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("c.yaml");
    std::fs::write(&config, "pass_held_out_mm: 0.01\n").unwrap();
    let html = dir.path().join("report.html");
    let run = Command::new(env!("CARGO_BIN_EXE_spmcal"))
        .args(["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--config"])
        .arg(&config)
        .arg("--out")
        .arg(dir.path().join("p.yaml"))
        .arg("--report")
        .arg(&html)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let text = std::fs::read_to_string(&html).unwrap();
    assert!(text.contains("<b>WARN</b>") && text.contains("threshold 0.010 mm"), "{}", &text[..600]);
}
