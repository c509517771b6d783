//! A stereo camera: its registration to the base, its two lenses, and its noise model.

use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::config::Camera;
use crate::model::CameraRegistration;

/// The nominal registration: camera centre `height` above O, optical axis (camera z) pointing
/// down, camera x along base x (so camera y is base −y).
pub fn looking_down(height: f64) -> CameraRegistration {
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)));
    CameraRegistration::from_centre(rotation, &Vector3::new(0.0, 0.0, height))
}

/// The two lens centres in B, half a baseline either side of the centre along camera x.
pub(crate) fn lenses(registration: &CameraRegistration, baseline: f64) -> [Vector3<f64>; 2] {
    let c = registration.centre();
    let x = registration.rotation.inverse() * Vector3::x();
    [c - x * (baseline / 2.0), c + x * (baseline / 2.0)]
}

/// What one measurement did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Marker centre in the camera frame, with noise.
    pub position: Vector3<f64>,
    /// Drawn from the outlier distribution.
    pub outlier: bool,
}

/// Measure a point given in B: transform to the camera frame, then add stereo noise — lateral
/// noise across the line of sight growing with the distance (a pixel subtends `z / f`), depth noise
/// along it growing with the squared distance (triangulation error ∝ z² / (f · baseline)) — and,
/// rarely, an outlier.
///
/// # Panics
/// If a noise deviation is not finite or the outlier probability lies outside [0, 1] (configs
/// are checked when read).
pub fn measure<R: Rng + ?Sized>(
    point_b: &Vector3<f64>,
    registration: &CameraRegistration,
    camera: &Camera,
    rng: &mut R,
) -> Measurement {
    let exact = registration.to_camera(point_b);
    let distance = exact.norm();
    let along = exact / distance;
    let across1 =
        along.cross(&Vector3::x()).try_normalize(1e-9).unwrap_or_else(|| along.cross(&Vector3::y()).normalize());
    let across2 = along.cross(&across1);
    let gauss = |sigma: f64, rng: &mut R| Normal::new(0.0, sigma).expect("validated deviation").sample(rng);
    let scale = distance / camera.reference_distance_m;
    let (depth_sigma, lateral_sigma) = (camera.depth_sigma_m * scale * scale, camera.lateral_sigma_m * scale);
    let mut position = exact
        + along * gauss(depth_sigma, rng)
        + across1 * gauss(lateral_sigma, rng)
        + across2 * gauss(lateral_sigma, rng);
    let outlier = rng.random_bool(camera.outlier_probability);
    if outlier {
        position += Vector3::from_fn(|_, _| gauss(camera.outlier_sigma_m, rng));
    }
    Measurement { position, outlier }
}
