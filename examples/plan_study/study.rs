//! Planned against random poses: for each true geometry (a simulation seed), calibrate on the
//! poses of a plan (made once, on the nominal model) and on random reachable poses, and measure
//! the calibrated mechanism's orientation error against the truth over fresh workspace
//! orientations. Shared by `examples/plan_study` (README table) and `tests/plan.rs`.

use nalgebra::Rotation3;
use spmcal::calib::{CalibConfig, calibrate};
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod efficiency;
pub use efficiency::pooled;

/// The RMS orientation error (degrees) against the truth of a calibration on `config` with
/// `seed` (the true geometry), on `plan`'s poses when given, else on `config.poses` random ones.
pub fn calibrated_error(
    config: &SimConfig,
    model: &RobotModel,
    seed: u64,
    plan: Option<&[Rotation3<f64>]>,
) -> Option<f64> {
    let mut c = config.clone();
    c.seed = seed;
    c.plan = plan.map(<[_]>::to_vec);
    let (session, _) = c.simulate(model, &mut |_| {}).ok()?;
    let truth = session.truth.as_ref()?;
    let spm = truth.parameters.spm().ok()?;
    // The workspace the plan predicts over: poses a session may capture (away from the
    // singularities the simulator and the plan's candidates avoid).
    let w = &config.workspace;
    let tests: Vec<Rotation3<f64>> = efficiency::test_orientations(&spm, 240, seed ^ 0x5eed)
        .into_iter()
        .filter(|r| {
            let joints = spm.ik(r).expect("test orientations are reachable");
            spm.jacobians(&joints, r).conditioning() >= w.min_conditioning
                && spm.branch_margins(&joints, r).max() <= -w.min_branch_margin
        })
        .take(60)
        .collect();
    let fit = calibrate(&session, model, &CalibConfig { folds: 0, ..CalibConfig::default() }, &mut |_| {}).ok()?;
    Some(efficiency::calibration_error_up_to_common_rotations(&session, &fit, &tests))
}
