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
    // The workspace the plan predicts over: poses a session may capture, as the simulator accepts
    // them on the true mechanism (reachable, away from singularities, no collisions).
    let tests = config.workspace_orientations(model, &truth.parameters.spm().ok()?, 60, seed ^ 0x5eed);
    let fit = calibrate(&session, model, &CalibConfig { folds: 0, ..CalibConfig::default() }, &mut |_| {}).ok()?;
    Some(efficiency::calibration_error_up_to_common_rotations(&session, &fit, &tests))
}
