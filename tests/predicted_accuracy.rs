//! The report's predicted error is the error the user gets: on simulated sessions (a new true
//! geometry and misplaced markers each), `predicted_error_deg` / `predicted_error_mm` against the
//! error the calibrated model achieves against the independent truth, measured as `compare`
//! measures it. The full study (20 sessions of four kinds) is `examples/predicted_accuracy`.

use std::path::Path;

use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[path = "../examples/predicted_accuracy/accuracy.rs"]
mod accuracy;
#[allow(dead_code)]
#[path = "../examples/marker_efficiency/study.rs"]
mod study;

fn sessions(config: &str, poses: Option<usize>, n: u64) -> Vec<accuracy::Accuracy> {
    let mut c = SimConfig::read(Path::new(config)).unwrap();
    if let Some(p) = poses {
        c.poses = p;
    }
    let model = RobotModel::load(&c.model).unwrap();
    (0..n).map(|s| accuracy::run(&c, &model, 20_000 + s, 200)).collect()
}

#[test]
fn the_predicted_error_is_the_achieved_error() {
    let mut rows = sessions("configs/simulate_agile_wrist.yaml", Some(200), 6);
    rows.extend(sessions("configs/simulate_agile_wrist_free_motion.yaml", None, 2));
    for r in &rows {
        eprintln!(
            "predicted {:.4}° achieved {:.4}° (90%: {:.4}–{:.4}, dof {:.1}); predicted {:.4} mm achieved {:.4} mm",
            r.predicted_deg,
            r.achieved_deg,
            r.interval_deg[0],
            r.interval_deg[1],
            r.dof_deg,
            r.predicted_mm,
            r.achieved_mm
        );
        // One session's achieved RMS is one draw of a weighted χ² of ~10 effective degrees of
        // freedom: 90% of them fall within 0.74–1.59× of the prediction; the old figure (the
        // gauge's common rotation included) was 5–10× the achieved error.
        assert!((0.5..2.0).contains(&(r.predicted_deg / r.achieved_deg)), "{r:?}");
        assert!((0.5..2.0).contains(&(r.predicted_mm / r.achieved_mm)), "{r:?}");
    }
    // Pooled over 8 sessions the relative spread of the RMS is ~8% (√(2 / (8 · 10)) / 2): the
    // study measures 0.98–1.02 (± 0.03–0.05) over 60 sessions of each kind.
    let deg = accuracy::pooled_ratio(&rows, |r| r.predicted_deg, |r| r.achieved_deg);
    let mm = accuracy::pooled_ratio(&rows, |r| r.predicted_mm, |r| r.achieved_mm);
    let se = accuracy::pooled_ratio_std_error(&rows, |r| r.predicted_deg, |r| r.achieved_deg);
    eprintln!("pooled ratio predicted / achieved: {deg:.3} ± {se:.3} (deg), {mm:.3} (mm)");
    assert!((0.8..1.25).contains(&deg) && (0.8..1.25).contains(&mm), "{deg} {mm}");
    // The 90% interval holds the achieved error in most sessions (8 sessions: at least 5 even if
    // each were inside with only 70%).
    assert!(rows.iter().filter(|r| r.inside_deg()).count() >= 6);
    assert!(rows.iter().filter(|r| r.inside_mm()).count() >= 6);
    // The standard errors behind it are honest: ~99.7% of the parameters within 3σ, ~95% within 2σ,
    // ~68% within 1σ (266 parameters, but correlated within a session: ±0.14 is ~3 binomial
    // standard deviations at half that many independent ones; 0.774 measured here, 0.65–0.73 per
    // group over the study's 80 sessions).
    let z: Vec<f64> = rows.iter().flat_map(|r| r.z.iter().map(|(_, z)| *z)).collect();
    let within = |k: f64| z.iter().filter(|v| **v <= k).count() as f64 / z.len() as f64;
    eprintln!("{} parameters: within 1σ {:.3}, 2σ {:.3}, 3σ {:.3}", z.len(), within(1.0), within(2.0), within(3.0));
    assert!(within(3.0) >= 0.97 && within(2.0) >= 0.9 && (0.55..0.82).contains(&within(1.0)));
}
