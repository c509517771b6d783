//! A stereo camera: its registration to the base, its two lenses, and its noise model.

use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::config::Camera;
use crate::model::{CameraModel, CameraModelKind, CameraRegistration, CameraTerms};

// The camera's settings are read with the rest of the config (`config`); what the camera does
// with them is here.
impl Camera {
    /// The nominal registration: camera centre `height_m` above O, optical axis (camera z)
    /// pointing down, camera x along base x (so camera y is base −y).
    pub fn looking_down(&self) -> CameraRegistration {
        let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)));
        CameraRegistration::from_centre(rotation, &Vector3::new(0.0, 0.0, self.height_m))
    }

    /// The camera model the settings make: the smallest that has every term set (projective when
    /// a perspective term is, affine when a scale of y or a shear is, a depth scale when only that
    /// is, else a perfect camera).
    pub fn model(&self) -> CameraModel {
        let terms = CameraTerms {
            depth_scale: self.depth_scale,
            scale_y: self.scale_y,
            shear_xy: self.shear_xy,
            shear_xz: self.shear_xz,
            shear_yz: self.shear_yz,
            perspective_x: self.perspective_x,
            perspective_y: self.perspective_y,
            perspective_z: self.perspective_z,
        };
        let set = terms.model(CameraModelKind::Projective);
        set.with_kind(CameraModelKind::smallest(|t| set.value(t) != t.perfect()))
    }

    /// Measure a point given in B with the camera at `registration`: transform to the camera
    /// frame, distort by the camera model, then add stereo noise — lateral noise across the line of sight growing with the
    /// distance (a pixel subtends `z / f`), depth noise along it growing with the squared distance
    /// (triangulation error ∝ z² / (f · baseline)) — and, rarely, an outlier.
    ///
    /// # Panics
    /// If a noise deviation is not finite or the outlier probability lies outside [0, 1] (configs
    /// are checked when read).
    pub(crate) fn measure<R: Rng + ?Sized>(
        &self,
        point_b: &Vector3<f64>,
        registration: &CameraRegistration,
        rng: &mut R,
    ) -> Measurement {
        let exact = registration.to_camera(point_b);
        let model = self.model();
        let exact = if model.is_perfect() { exact } else { model.distort(&exact) };
        let distance = exact.norm();
        let along = exact / distance;
        let across1 =
            along.cross(&Vector3::x()).try_normalize(1e-9).unwrap_or_else(|| along.cross(&Vector3::y()).normalize());
        let across2 = along.cross(&across1);
        let gauss = |sigma: f64, rng: &mut R| Normal::new(0.0, sigma).expect("validated deviation").sample(rng);
        let scale = distance / self.reference_distance_m;
        let (depth_sigma, lateral_sigma) = (self.depth_sigma_m * scale * scale, self.lateral_sigma_m * scale);
        let mut position = exact
            + along * gauss(depth_sigma, rng)
            + across1 * gauss(lateral_sigma, rng)
            + across2 * gauss(lateral_sigma, rng);
        let outlier = rng.random_bool(self.outlier_probability);
        if outlier {
            position += Vector3::from_fn(|_, _| gauss(self.outlier_sigma_m, rng));
        }
        Measurement { position, outlier }
    }
}

/// The two lens centres in B, half a baseline either side of the centre along camera x.
pub(crate) fn lenses(registration: &CameraRegistration, baseline: f64) -> [Vector3<f64>; 2] {
    let c = registration.centre();
    let x = registration.rotation.inverse() * Vector3::x();
    [c - x * (baseline / 2.0), c + x * (baseline / 2.0)]
}

/// What one measurement did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Measurement {
    /// Marker centre in the camera frame, with noise.
    pub(crate) position: Vector3<f64>,
    /// Drawn from the outlier distribution.
    pub(crate) outlier: bool,
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use nalgebra::Vector3;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use crate::sim::SimConfig;

    #[test]
    fn stereo_noise_grows_with_the_square_of_the_distance() {
        let config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
        let registration = config.camera.looking_down(); // 0.8 m above O
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let spread_at = |height: f64, rng: &mut ChaCha8Rng| {
            // A point `height` below the camera: depth error is along camera z.
            let point = Vector3::new(0.0, 0.0, 0.8 - height);
            let n = 20_000;
            let var: f64 = (0..n)
                .map(|_| {
                    let m = config.camera.measure(&point, &registration, rng);
                    (m.position.z - height).powi(2)
                })
                .sum::<f64>()
                / n as f64;
            var.sqrt()
        };
        let (near, far) = (spread_at(0.8, &mut rng), spread_at(1.6, &mut rng));
        // (Lateral noise grows linearly: tested through the marker-level fit's noise estimate.)
        // σ(1.6 m) / σ(0.8 m) = 4; with 20,000 samples each estimate is within ~1.5% (3σ).
        assert!((far / near - 4.0).abs() < 0.15, "ratio {}", far / near);
        assert!((near - config.camera.depth_sigma_m).abs() < 0.03 * config.camera.depth_sigma_m);
    }
}
