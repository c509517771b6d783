//! The HTML report in a real browser, headless Chromium, at a desk's width (1280 px) and a phone's
//! (390 px): the page never scrolls sideways (every element inside the window; a wide table
//! scrolls inside its own box), each chart shows exactly one of its two drawings — the one made
//! for that width — with its text at a readable size and its legend below it, and a screenshot
//! is taken at each width. Three reports: the 400-pose session, the 120-s free-motion recording
//! (error against time) and an orientation-level fit.
//!
//! Chromium is an outside tool (Debian: `apt-get install chromium`; `.ci/run` installs it):
//! where it is missing the test is skipped and says so (`tests/common/outside_tool.rs`), and
//! under `CI=true` it fails. `SPMCAL_SCREENSHOTS=docs` also writes the 400-pose report's
//! screenshots to `docs/report_1280.png` and `docs/report_390.png` (the docs show them).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[path = "common/outside_tool.rs"]
mod outside_tool;

/// The smallest chart text a reader is asked to read, CSS pixels: the narrow drawings show theirs
/// at about 11.4 px on a 390-px phone, the wide ones at about 15 px at 1280 px; a drawing made for
/// another width (a 900-px chart squeezed onto a phone: under 5 px) fails.
const SMALLEST_TEXT_PX: f64 = 10.0;

/// Script added to a copy of the report (the report itself has none): once the page is laid out,
/// it writes what it measured, as JSON, into a `<pre id="measured">` that `--dump-dom` prints.
const MEASURE: &str = r#"<script>
addEventListener('load', () => {
  const w = innerWidth, out = { innerWidth: w, scrollWidth: document.documentElement.scrollWidth, outside: [] };
  for (const e of document.body.querySelectorAll('*')) {
    if (e.closest('.table') && !e.classList.contains('table')) continue; // scrolls inside its box
    const r = e.getBoundingClientRect();
    if (r.width > 0 && (r.right > w + 0.5 || r.left < -0.5))
      out.outside.push(e.tagName + ' in #' + (e.closest('section') || {}).id + ': ' + Math.round(r.left) + '..' + Math.round(r.right));
  }
  out.figures = [...document.querySelectorAll('figure')].map(f => {
    const shown = [...f.querySelectorAll('svg')].filter(s => s.getBoundingClientRect().width > 0);
    const sizes = shown.flatMap(s => {
      const scale = s.getBoundingClientRect().width / s.viewBox.baseVal.width;
      return [...s.querySelectorAll('text')].filter(t => t.textContent.trim())
        .map(t => parseFloat(getComputedStyle(t).fontSize) * scale);
    });
    const legend = f.querySelector('.legend');
    const last = shown[shown.length - 1];
    return {
      section: f.closest('section').id,
      shown: shown.map(s => s.getAttribute('class')),
      smallestText: Math.min(...sizes),
      legendBelow: !legend || !last || legend.getBoundingClientRect().top >= last.getBoundingClientRect().bottom - 0.5,
    };
  });
  out.tables = document.querySelectorAll('.table table').length;
  const pre = document.createElement('pre');
  pre.id = 'measured';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"#;

/// The Chromium on this machine: `SPMCAL_CHROMIUM`, or the first of the usual names that runs.
fn chromium() -> Option<PathBuf> {
    let named = std::env::var_os("SPMCAL_CHROMIUM").map(PathBuf::from);
    let usual = ["chromium", "chromium-browser", "google-chrome", "google-chrome-stable"].map(PathBuf::from);
    named.into_iter().chain(usual).find(|c| {
        Command::new(c).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
    })
}

/// Runs headless Chromium on `page` in a `width × height` window with `args`, and returns what
/// it printed (through a file: a pipe left unread while waiting would fill and stall it); a
/// browser that hangs is stopped after two minutes and fails the test.
fn headless(browser: &Path, page: &Path, (width, height): (u32, u32), args: &[&str]) -> String {
    let scratch = tempfile::tempdir().unwrap();
    let printed = scratch.path().join("stdout");
    let mut child = Command::new(browser)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run"])
        .args(["--force-device-scale-factor=1", "--virtual-time-budget=5000"])
        .arg(format!("--user-data-dir={}", scratch.path().join("profile").display()))
        .arg(format!("--window-size={width},{height}"))
        .args(args)
        .arg(format!("file://{}", page.canonicalize().unwrap().display()))
        .stdout(std::fs::File::create(&printed).unwrap())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("{} did not finish with {} in two minutes", browser.display(), page.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    std::fs::read_to_string(&printed).unwrap()
}

/// `spmcal calibrate --report` of `dataset` (with `extra` arguments) into `dir`.
fn report(dir: &Path, name: &str, dataset: &str, extra: &[&str]) -> PathBuf {
    let html = dir.join(format!("{name}.html"));
    let run = Command::new(env!("CARGO_BIN_EXE_spmcal"))
        .args(["calibrate", "--dataset", dataset])
        .args(extra)
        .arg("--out")
        .arg(dir.join(format!("{name}.yaml")))
        .arg("--report")
        .arg(&html)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    html
}

/// What the measuring script found on `page` laid out `width` pixels wide. Headless Chromium's
/// window is at least 500 px wide for `--dump-dom` (its screenshots are not held to it), so the
/// page is measured in a frame of that width (the frame is its viewport: its media queries and
/// `innerWidth` are the frame's), and the frame's result copied out for `--dump-dom`.
fn measured(browser: &Path, page: &Path, width: u32) -> serde_json::Value {
    let html = std::fs::read_to_string(page).unwrap().replacen("</body>", &format!("{MEASURE}</body>"), 1);
    let srcdoc = html.replace('&', "&amp;").replace('"', "&quot;");
    let probe = page.with_extension(format!("{width}.html"));
    let outer = format!(
        "<!DOCTYPE html><html><body style=\"margin:0\"><iframe id=\"page\" style=\"border:0;width:{width}px;height:20000px\" srcdoc=\"{srcdoc}\"></iframe>\
         <script>document.getElementById('page').addEventListener('load', e => {{\
           const pre = document.createElement('pre'); pre.id = 'measured';\
           pre.textContent = e.target.contentDocument.getElementById('measured').textContent;\
           document.body.appendChild(pre); }});</script></body></html>"
    );
    std::fs::write(&probe, outer).unwrap();
    let dom = headless(browser, &probe, (width.max(500) + 100, 2000), &["--dump-dom"]);
    let json = dom
        .rsplit_once("<pre id=\"measured\">")
        .and_then(|(_, rest)| rest.split_once("</pre>"))
        .map(|(json, _)| json.replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&"))
        .unwrap_or_else(|| panic!("no measurement in the DOM of {} at {width} px: {dom:.600}", page.display()));
    serde_json::from_str(&json).unwrap()
}

/// The checks at one width: nothing outside the window, one drawing per chart (the one for this
/// width), its text readable, its legend below it.
fn check(m: &serde_json::Value, name: &str, width: u32) {
    let context = format!("{name} at {width} px: {m:#}");
    assert_eq!(m["innerWidth"].as_u64(), Some(u64::from(width)), "the window is not as asked: {context}");
    assert!(m["scrollWidth"].as_u64().unwrap() <= u64::from(width), "the page scrolls sideways: {context}");
    assert_eq!(m["outside"].as_array().unwrap().len(), 0, "elements outside the window: {context}");
    assert!(m["tables"].as_u64().unwrap() >= 5, "{context}");
    let figures = m["figures"].as_array().unwrap();
    let sections: Vec<&str> = figures.iter().map(|f| f["section"].as_str().unwrap()).collect();
    // A free-motion recording's report adds its camera clock after the errors pose by pose.
    let mut expected_sections = vec!["per-pose", "residuals", "parameters", "identifiability", "coverage"];
    if name.starts_with("free_motion") {
        expected_sections.insert(1, "camera-clock");
    }
    assert_eq!(sections, expected_sections, "{context}");
    let expected = if width < 640 { "narrow" } else { "wide" };
    for f in figures {
        assert_eq!(f["shown"], serde_json::json!([expected]), "{context}");
        let smallest = f["smallestText"].as_f64().unwrap();
        assert!(smallest >= SMALLEST_TEXT_PX, "chart text of {smallest:.1} px in {}: {context}", f["section"]);
        assert_eq!(f["legendBelow"], true, "{context}");
    }
}

/// The PNG's width and height, from its header.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{} is not a PNG", path.display());
    let be = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
    (be(16), be(20))
}

#[test]
fn the_report_reads_at_a_desks_and_a_phones_width() {
    let Some(browser) = chromium() else {
        return outside_tool::missing("Chromium", "Debian: apt-get install chromium");
    };
    let dir = tempfile::tempdir().unwrap();
    let orientations = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden/config_orientations.yaml");
    let reports = [
        ("sim_400", report(dir.path(), "sim_400", "datasets/agile_wrist_sim_400", &[])),
        ("free_motion_120s", report(dir.path(), "free_motion", "datasets/agile_wrist_free_motion_120s", &[])),
        (
            "orientations_sim_20",
            report(
                dir.path(),
                "orientations",
                "datasets/agile_wrist_sim_20",
                &["--config", orientations.to_str().unwrap()],
            ),
        ),
    ];
    for (name, page) in &reports {
        for width in [1280, 390] {
            check(&measured(&browser, page, width), name, width);
        }
    }
    // Screenshots of the 400-pose report: the top of the page, as a reader first sees it.
    let keep = std::env::var_os("SPMCAL_SCREENSHOTS").map(PathBuf::from);
    for (width, height) in [(1280, 1060), (390, 1240)] {
        let png = dir.path().join(format!("report_{width}.png"));
        headless(&browser, &reports[0].1, (width, height), &[&format!("--screenshot={}", png.display())]);
        assert_eq!(png_size(&png), (width, height), "{}", png.display());
        if let Some(keep) = &keep {
            std::fs::copy(&png, keep.join(format!("report_{width}.png"))).unwrap();
        }
    }
}
