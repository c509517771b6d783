//! The vision accuracy study (not a timing): angular RMS error of the paper's estimator and of
//! Kabsch's against the simulated truth, at several camera noise levels. Prints the README's table
//! and writes `examples/vision_accuracy/vision_accuracy.svg`.
//! Run: `cargo run --release --example vision_accuracy`.

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

/// A log–log plot of both methods' RMS error against the depth noise (plotters, as the HTML report).
fn svg(rows: &[AccuracyRow]) -> String {
    use plotters::prelude::*;
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (560, 360)).into_drawing_area();
        root.fill(&WHITE).expect("draw");
        let depth: Vec<f64> = rows.iter().map(|r| r.depth_sigma_mm).collect();
        let errors: Vec<f64> = rows.iter().flat_map(|r| [r.paper_rms_deg, r.kabsch_rms_deg]).collect();
        let (x0, x1) = (depth[0] / 1.5, depth[depth.len() - 1] * 1.5);
        let (y0, y1) = (
            errors.iter().copied().fold(f64::INFINITY, f64::min) / 1.5,
            errors.iter().copied().fold(0.0, f64::max) * 1.5,
        );
        let mut chart = ChartBuilder::on(&root)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .expect("draw");
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .x_desc("depth noise σ at 0.8 m (mm; lateral σ = depth σ / 4)")
            .y_desc("RMS orientation error (°)")
            .x_label_formatter(&|x| format!("{x}"))
            .y_label_formatter(&|y| format!("{y}"))
            .draw()
            .expect("draw");
        for (label, colour, pick) in
            [("paper (LS + polar)", RGBColor(214, 39, 40), 0), ("kabsch (optimal)", RGBColor(31, 119, 180), 1)]
        {
            let points: Vec<(f64, f64)> = rows
                .iter()
                .map(|r| (r.depth_sigma_mm, if pick == 0 { r.paper_rms_deg } else { r.kabsch_rms_deg }))
                .collect();
            chart
                .draw_series(LineSeries::new(points, colour.stroke_width(2)))
                .expect("draw")
                .label(label)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .draw()
            .expect("draw");
        root.present().expect("draw");
    }
    out
}
