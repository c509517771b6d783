//! The vision accuracy study (not a timing): angular RMS error of the paper's estimator and of
//! Kabsch's against the simulated truth, at several camera noise levels. Prints the README's table
//! and writes `examples/vision_accuracy/vision_accuracy.svg`.
//! Run: `cargo run --release --example vision_accuracy`.

use std::fmt::Write as _;
use std::path::Path;

use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;
mod study;
use study::{AccuracyRow, accuracy_study};

fn main() {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    config.poses = 400;
    let model = RobotModel::load(&config.model).expect("shipped model");
    let scales = [0.25, 0.5, 1.0, 2.0, 4.0, 8.0];
    let mut rows = Vec::new();
    for sequential in [false, true] {
        config.capture.sequential = sequential;
        rows.push((sequential, accuracy_study(&config, &model, &scales).expect("simulation succeeds")));
    }
    println!(
        "| capture | lateral σ (mm) | depth σ (mm) | paper RMS (°) | kabsch RMS (°) | paper / kabsch | mean e_j |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (sequential, study) in &rows {
        for r in study {
            println!(
                "| {} | {:.2} | {:.2} | {:.4} | {:.4} | {:.3} | {:.4} |",
                if *sequential { "sequential" } else { "simultaneous" },
                r.lateral_sigma_mm,
                r.depth_sigma_mm,
                r.paper_rms_deg,
                r.kabsch_rms_deg,
                r.paper_rms_deg / r.kabsch_rms_deg,
                r.mean_e
            );
        }
    }
    std::fs::write("examples/vision_accuracy/vision_accuracy.svg", svg(&rows[0].1)).expect("write the figure");
    println!("figure: examples/vision_accuracy/vision_accuracy.svg");
}

/// A log–log plot of both methods' RMS error against the depth noise.
fn svg(rows: &[AccuracyRow]) -> String {
    let (w, h, m) = (560.0, 360.0, 60.0);
    let xs: Vec<f64> = rows.iter().map(|r| r.depth_sigma_mm.log10()).collect();
    let ys: Vec<f64> = rows.iter().flat_map(|r| [r.paper_rms_deg, r.kabsch_rms_deg]).map(f64::log10).collect();
    let (x0, x1) = (xs[0].floor(), xs[xs.len() - 1].ceil());
    let (y0, y1) = (
        ys.iter().cloned().fold(f64::INFINITY, f64::min).floor(),
        ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max).ceil(),
    );
    let px = |x: f64| m + (x - x0) / (x1 - x0) * (w - 1.5 * m);
    let py = |y: f64| h - m - (y - y0) / (y1 - y0) * (h - 1.7 * m);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    for d in (x0 as i32)..=(x1 as i32) {
        let x = px(d as f64);
        let _ = writeln!(
            s,
            "<line x1=\"{x}\" y1=\"{}\" x2=\"{x}\" y2=\"{}\" stroke=\"#ddd\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            py(y0),
            py(y1),
            h - m + 18.0,
            10f64.powi(d)
        );
    }
    for d in (y0 as i32)..=(y1 as i32) {
        let y = py(d as f64);
        let _ = writeln!(
            s,
            "<line x1=\"{}\" y1=\"{y}\" x2=\"{}\" y2=\"{y}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>",
            px(x0),
            px(x1),
            m - 6.0,
            y + 4.0,
            10f64.powi(d)
        );
    }
    for (label, colour, pick, dy) in
        [("paper (LS + polar)", "#d62728", 0, 0.0), ("kabsch (optimal)", "#1f77b4", 1, 18.0)]
    {
        let points: Vec<String> = rows
            .iter()
            .map(|r| {
                let y = if pick == 0 { r.paper_rms_deg } else { r.kabsch_rms_deg };
                format!("{:.1},{:.1}", px(r.depth_sigma_mm.log10()), py(y.log10()))
            })
            .collect();
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"2\"/>",
            points.join(" ")
        );
        let _ = writeln!(s, "<text x=\"{}\" y=\"{}\" fill=\"{colour}\">{label}</text>", m + 10.0, m - 20.0 + dy);
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">depth noise σ at 0.8 m (mm; lateral σ = depth σ / 4)</text>",
        w / 2.0,
        h - 12.0
    );
    let _ = writeln!(
        s,
        "<text transform=\"translate(16,{}) rotate(-90)\" text-anchor=\"middle\">RMS orientation error (°)</text>",
        h / 2.0
    );
    s.push_str("</svg>\n");
    s
}
