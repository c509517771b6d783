//! Capture planning against random poses (README table and figure): for N ∈ {12, 20, 40, 80}, a
//! plan of N poses (made once on the nominal model) and N, 2N and 4N random reachable poses,
//! each calibrated on several true geometries; the RMS orientation error against the truth,
//! beside the plan's own prediction. Writes `examples/plan_study/plan_study.svg`.
//! Run: `cargo run --release --example plan_study [geometries]` (default 40). A failed fit is
//! counted, not hidden.

use std::collections::BTreeMap;
use std::path::Path;

use plotters::prelude::*;
use spmcal::model::RobotModel;
use spmcal::plan::{Plan, PlanSettings};
use spmcal::sim::SimConfig;

mod study;
use study::{calibrated_error, pooled};

fn main() {
    let geometries: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(40);
    let config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).expect("shipped config");
    let model = RobotModel::load(&config.model).expect("shipped model");
    let mut random: BTreeMap<usize, f64> = BTreeMap::new();
    let mut planned_points = Vec::new();
    println!(
        "| N | plan: predicted (°) | plan: achieved (°) | N random (°) | 2N random (°) | 4N random (°) | random poses the plan is worth (predicted) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for n in [12, 20, 40, 80] {
        let settings = PlanSettings { poses: n, ..PlanSettings::default() };
        let planned = Plan::design(&model, None, &config, &settings, None).expect("a plan");
        let rotations: Vec<_> = planned.poses.iter().map(|p| p.rotation).collect();
        let mut row = |poses: Option<usize>| -> (f64, String) {
            let errors: Vec<Option<f64>> = (0..geometries)
                .map(|g| {
                    let mut c = config.clone();
                    c.poses = poses.unwrap_or(n);
                    calibrated_error(&c, &model, 30_000 + g, poses.is_none().then_some(&rotations[..]))
                })
                .collect();
            let ok: Vec<f64> = errors.iter().flatten().copied().collect();
            let failed = errors.len() - ok.len();
            let value = pooled(ok.into_iter());
            if let Some(p) = poses {
                random.insert(p, value);
            }
            let note = if failed > 0 { format!(" ({failed} fits failed)") } else { String::new() };
            (value, format!("{value:.4}{note}"))
        };
        let (achieved, achieved_text) = row(None);
        let columns = [row(Some(n)).1, row(Some(2 * n)).1, row(Some(4 * n)).1];
        let needed = planned.summary.random_poses_needed.map_or("> all".to_string(), |r| r.to_string());
        let predicted = planned.summary.plan.rms_deg;
        println!(
            "| {n} | {predicted:.4} | {achieved_text} | {} | {} | {} | {needed} |",
            columns[0], columns[1], columns[2]
        );
        planned_points.push((n, predicted, achieved));
    }
    figure(&random, &planned_points, Path::new("examples/plan_study/plan_study.svg")).expect("the figure");
}

/// Error against poses, log–log: random poses, the plan as achieved and as predicted.
fn figure(
    random: &BTreeMap<usize, f64>,
    planned: &[(usize, f64, f64)],
    path: &Path,
) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (720, 440)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Orientation error after calibration against the truth", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(56)
        .build_cartesian_2d(
            (10f64..400f64).log_scale().with_key_points(vec![10.0, 12.0, 20.0, 40.0, 80.0, 160.0, 320.0]),
            (0.1f64..4f64).log_scale().with_key_points(vec![0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0]),
        )?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| format!("{y:.2}"))
        .x_desc("poses captured (four markers each)")
        .y_desc("RMS error over the workspace (°)")
        .draw()?;
    let random: Vec<(f64, f64)> = random.iter().map(|(&n, &e)| (n as f64, e)).collect();
    chart
        .draw_series(LineSeries::new(random.clone(), BLACK.stroke_width(2)))?
        .label("random reachable poses")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    chart.draw_series(random.iter().map(|&p| Circle::new(p, 3, BLACK.filled())))?;
    let achieved: Vec<(f64, f64)> = planned.iter().map(|&(n, _, a)| (n as f64, a)).collect();
    let blue = RGBColor(31, 119, 180);
    chart
        .draw_series(LineSeries::new(achieved.clone(), blue.stroke_width(3)))?
        .label("planned poses (spmcal plan), achieved")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], blue.stroke_width(3)));
    chart.draw_series(achieved.iter().map(|&p| Circle::new(p, 4, blue.filled())))?;
    let orange = RGBColor(255, 127, 14);
    let predicted: Vec<(f64, f64)> = planned.iter().map(|&(n, p, _)| (n as f64, p)).collect();
    chart
        .draw_series(DashedLineSeries::new(predicted, 6, 4, orange.stroke_width(2)))?
        .label("planned poses, predicted by the plan")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], orange.stroke_width(2)));
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE.mix(0.9)).draw()?;
    root.present()?;
    Ok(())
}
