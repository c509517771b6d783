//! A camera rig seen through its pixels: each camera's pinhole lens with its distortion
//! (Kalibr's `pinhole` + `radtan` or `equidistant`) and its pose relative to the first camera.
//!
//! A point `y` in `cam0`'s frame (x right, y down, z along the optical axis) is seen by camera `c`
//! at `(u, v) = π_c(T_c y)`: `T_c` maps cam0 coordinates to camera c's (`T_cam0` = identity), and
//! `π` divides by depth (`x = X/Z`, `y = Y/Z`), distorts, then scales and shifts by the
//! intrinsics (`u = fu·x_d + pu`, `v = fv·y_d + pv`). Pixel coordinates are OpenCV's and Kalibr's:
//! the top-left pixel's centre is (0, 0).
//!
//! Distortion, as OpenCV and Kalibr define it:
//! - `radtan` `[k1, k2, r1, r2]`: `x_d = x(1 + k1 r² + k2 r⁴) + 2 r1 x y + r2 (r² + 2x²)`,
//!   `y_d = y(1 + k1 r² + k2 r⁴) + r1 (r² + 2y²) + 2 r2 x y`, `r² = x² + y²`;
//! - `equidistant` `[k1, k2, k3, k4]`: `θ = atan r`, `θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`,
//!   `(x_d, y_d) = (θ_d / r) (x, y)`.
//!
//! The terms a fit may refine ([`RigTerm`]) are each camera's intrinsics and distortion
//! coefficients, and for every camera after the first its rotation (3) and translation relative to
//! cam0; the first baseline's length is the rig's metric scale, which an SPM's motion (rotation
//! only) cannot tell, so only its direction is a term.

use nalgebra::{Isometry3, Matrix2, Matrix2x3, Vector2, Vector3};

/// A lens's distortion model (Kalibr's `distortion_model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DistortionModel {
    /// Radial-tangential (OpenCV's plumb bob): `[k1, k2, r1, r2]`.
    Radtan,
    /// Equidistant fisheye (OpenCV's `fisheye`): `[k1, k2, k3, k4]`.
    Equidistant,
}

impl DistortionModel {
    /// Its name in camchain files.
    pub fn name(self) -> &'static str {
        match self {
            DistortionModel::Radtan => "radtan",
            DistortionModel::Equidistant => "equidistant",
        }
    }

    /// The names of its four coefficients.
    pub fn coefficient_names(self) -> [&'static str; 4] {
        match self {
            DistortionModel::Radtan => ["k1", "k2", "r1", "r2"],
            DistortionModel::Equidistant => ["k1", "k2", "k3", "k4"],
        }
    }
}

/// A pinhole lens: intrinsics and distortion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lens {
    /// `[fu, fv, pu, pv]` (px).
    pub intrinsics: [f64; 4],
    /// The distortion model.
    pub distortion_model: DistortionModel,
    /// Its four coefficients.
    pub distortion: [f64; 4],
    /// `[width, height]` (px).
    pub resolution: [u32; 2],
}

/// A pixel and its derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// `(u, v)` (px).
    pub pixel: Vector2<f64>,
    /// `∂(u, v)/∂z`, `z` the point in the camera's own frame.
    pub d_point: Matrix2x3<f64>,
    /// `∂(u, v)/∂[fu, fv, pu, pv]`.
    pub d_intrinsics: [Vector2<f64>; 4],
    /// `∂(u, v)/∂` each distortion coefficient.
    pub d_distortion: [Vector2<f64>; 4],
}

impl Lens {
    /// The pixel where the lens images `z` (a point in its camera's frame) with the derivatives;
    /// `None` when `z` is not in front of the camera.
    pub fn project(&self, z: &Vector3<f64>) -> Option<Projection> {
        if z.z.is_nan() || z.z <= 1e-9 {
            return None;
        }
        let (x, y) = (z.x / z.z, z.y / z.z);
        let (d, d_xy, d_k) = self.distort(x, y);
        let [fu, fv, pu, pv] = self.intrinsics;
        let f = Matrix2::new(fu, 0.0, 0.0, fv);
        let d_normal = Matrix2x3::new(1.0 / z.z, 0.0, -x / z.z, 0.0, 1.0 / z.z, -y / z.z);
        Some(Projection {
            pixel: Vector2::new(fu * d.x + pu, fv * d.y + pv),
            d_point: f * d_xy * d_normal,
            d_intrinsics: [Vector2::new(d.x, 0.0), Vector2::new(0.0, d.y), Vector2::x(), Vector2::y()],
            d_distortion: d_k.map(|c| f * c),
        })
    }

    /// The distorted normalised coordinates of `(x, y)`, their derivative with respect to
    /// `(x, y)` and to each coefficient.
    pub fn distort(&self, x: f64, y: f64) -> (Vector2<f64>, Matrix2<f64>, [Vector2<f64>; 4]) {
        let [k1, k2, k3, k4] = self.distortion;
        match self.distortion_model {
            DistortionModel::Radtan => {
                let (r1, r2) = (k3, k4);
                let r2n = x * x + y * y;
                let radial = 1.0 + k1 * r2n + k2 * r2n * r2n;
                let d_radial = k1 + 2.0 * k2 * r2n; // ∂radial/∂(r²)
                let xd = x * radial + 2.0 * r1 * x * y + r2 * (r2n + 2.0 * x * x);
                let yd = y * radial + r1 * (r2n + 2.0 * y * y) + 2.0 * r2 * x * y;
                let dxd_dx = radial + x * d_radial * 2.0 * x + 2.0 * r1 * y + r2 * 6.0 * x;
                let dxd_dy = x * d_radial * 2.0 * y + 2.0 * r1 * x + r2 * 2.0 * y;
                let dyd_dx = y * d_radial * 2.0 * x + r1 * 2.0 * x + 2.0 * r2 * y;
                let dyd_dy = radial + y * d_radial * 2.0 * y + r1 * 6.0 * y + 2.0 * r2 * x;
                let d_k = [
                    Vector2::new(x * r2n, y * r2n),
                    Vector2::new(x * r2n * r2n, y * r2n * r2n),
                    Vector2::new(2.0 * x * y, r2n + 2.0 * y * y),
                    Vector2::new(r2n + 2.0 * x * x, 2.0 * x * y),
                ];
                (Vector2::new(xd, yd), Matrix2::new(dxd_dx, dxd_dy, dyd_dx, dyd_dy), d_k)
            }
            DistortionModel::Equidistant => {
                let r = (x * x + y * y).sqrt();
                if r < 1e-12 {
                    // At the axis θ_d / r → 1 and its derivatives vanish.
                    return (Vector2::new(x, y), Matrix2::identity(), [Vector2::zeros(); 4]);
                }
                let theta = r.atan();
                let t2 = theta * theta;
                let poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
                let theta_d = theta * poly;
                // dθ_d/dθ and dθ/dr.
                let d_theta_d = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
                let d_theta = 1.0 / (1.0 + r * r);
                let scale = theta_d / r;
                let d_scale_dr = (d_theta_d * d_theta * r - theta_d) / (r * r);
                let (ux, uy) = (x / r, y / r);
                let j = Matrix2::new(
                    scale + x * d_scale_dr * ux,
                    x * d_scale_dr * uy,
                    y * d_scale_dr * ux,
                    scale + y * d_scale_dr * uy,
                );
                let powers = [t2, t2 * t2, t2 * t2 * t2, t2 * t2 * t2 * t2];
                let d_k = powers.map(|p| Vector2::new(x, y) * (theta * p / r));
                (Vector2::new(x * scale, y * scale), j, d_k)
            }
        }
    }

    /// The normalised coordinates `(x, y)` (the point's direction `(x, y, 1)`) whose image is
    /// `pixel`, by Newton's method on the distortion; `None` when it does not converge.
    pub fn unproject(&self, pixel: &Vector2<f64>) -> Option<Vector2<f64>> {
        let [fu, fv, pu, pv] = self.intrinsics;
        let target = Vector2::new((pixel.x - pu) / fu, (pixel.y - pv) / fv);
        let mut xy = target;
        for _ in 0..50 {
            let (d, j, _) = self.distort(xy.x, xy.y);
            let step = j.try_inverse()? * (target - d);
            xy += step;
            if step.norm() < 1e-14 {
                return Some(xy);
            }
        }
        let (d, _, _) = self.distort(xy.x, xy.y);
        ((d - target).norm() < 1e-10).then_some(xy)
    }

    /// Where the radial distortion folds the image back on itself, if it does before the image's
    /// farthest corner: `(angle off the optical axis in degrees, the share of the way to that
    /// corner the distorted radius reached)`. A lens's distorted radius grows with the angle all
    /// the way to the corner (or to 90°, beyond which the pinhole has no ray); coefficients with a
    /// wrong sign or order (`k1 = -5`) turn it back first, and the pixels beyond have no ray, or
    /// only one through the other side of the image. (The tangential terms, a few thousandths
    /// in a real lens, are left out.)
    pub(crate) fn radial_fold(&self) -> Option<(f64, f64)> {
        let [fu, fv, pu, pv] = self.intrinsics;
        let [width, height] = self.resolution.map(f64::from);
        let corner = [(-0.5, -0.5), (width - 0.5, -0.5), (-0.5, height - 0.5), (width - 0.5, height - 0.5)]
            .iter()
            .map(|(u, v)| ((u - pu) / fu).hypot((v - pv) / fv))
            .fold(0.0, f64::max);
        let [k1, k2, k3, k4] = self.distortion;
        let radius = |theta: f64| match self.distortion_model {
            DistortionModel::Radtan => {
                let r2 = theta.tan().powi(2);
                theta.tan() * (1.0 + k1 * r2 + k2 * r2 * r2)
            }
            DistortionModel::Equidistant => {
                let t2 = theta * theta;
                theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
            }
        };
        // Steps of 0.05° up to 89.95°.
        let mut previous = 0.0;
        for step in 1..1800 {
            let theta = (f64::from(step) * 0.05).to_radians();
            let r = radius(theta);
            if r >= corner {
                return None;
            }
            if r <= previous {
                return Some(((theta.to_degrees() - 0.05), previous / corner));
            }
            previous = r;
        }
        None
    }
}

/// One camera of a rig.
#[derive(Debug, Clone, PartialEq)]
pub struct RigCamera {
    /// Its name (`cam0`, `cam1`, …).
    pub name: String,
    /// Its lens.
    pub lens: Lens,
    /// `T_cn_cnm1`: the previous camera's coordinates to this camera's (identity for the first).
    pub from_previous: Isometry3<f64>,
}

/// A rig of one or more cameras, the first (`cam0`) defining the camera frame C.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// The cameras, in the file's order.
    pub cameras: Vec<RigCamera>,
}

/// A term of a rig that a fit may refine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RigTerm {
    /// Intrinsic `k` (`fu`, `fv`, `pu`, `pv`) of camera `camera`.
    Intrinsic {
        /// Camera index.
        camera: usize,
        /// 0..4: `fu`, `fv`, `pu`, `pv`.
        k: usize,
    },
    /// Distortion coefficient `k` of camera `camera`.
    Distortion {
        /// Camera index.
        camera: usize,
        /// 0..4, in the model's order.
        k: usize,
    },
    /// Component `k` of the rotation vector that turns camera `camera` (≥ 1) relative to cam0:
    /// `R_c = exp(ω) R_c⁰` (rad).
    Rotation {
        /// Camera index (≥ 1).
        camera: usize,
        /// Axis 0..3.
        k: usize,
    },
    /// Component `k` of camera `camera`'s translation relative to cam0 (m), in the camera's own
    /// frame; for camera 1 the two directions across its baseline (its length is held).
    Translation {
        /// Camera index (≥ 1).
        camera: usize,
        /// 0..3 (0..2 for camera 1).
        k: usize,
    },
}

impl RigTerm {
    /// Its name in reports: `cam1.fu`, `cam0.k1`, `cam1.rotation_x`, `cam1.baseline_dir_0`.
    pub fn name(self, rig: &Rig) -> String {
        let camera = |c: usize| rig.cameras.get(c).map_or_else(|| format!("cam{c}"), |cam| cam.name.clone());
        match self {
            RigTerm::Intrinsic { camera: c, k } => format!("{}.{}", camera(c), ["fu", "fv", "pu", "pv"][k]),
            RigTerm::Distortion { camera: c, k } => {
                let names = rig
                    .cameras
                    .get(c)
                    .map_or(["k1", "k2", "k3", "k4"], |cam| cam.lens.distortion_model.coefficient_names());
                format!("{}.{}", camera(c), names[k])
            }
            RigTerm::Rotation { camera: c, k } => format!("{}.rotation_{}", camera(c), ["x", "y", "z"][k]),
            RigTerm::Translation { camera: 1, k } => format!("{}.baseline_direction_{k}", camera(1)),
            RigTerm::Translation { camera: c, k } => format!("{}.translation_{}", camera(c), ["x", "y", "z"][k]),
        }
    }

    /// The camera it belongs to.
    pub fn camera(self) -> usize {
        match self {
            RigTerm::Intrinsic { camera, .. }
            | RigTerm::Distortion { camera, .. }
            | RigTerm::Rotation { camera, .. }
            | RigTerm::Translation { camera, .. } => camera,
        }
    }
}

/// A pixel seen by a camera of a rig at a point, with the derivatives a fit needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigProjection {
    /// The lens's projection (its `d_point` is with respect to the camera's own frame).
    pub lens: Projection,
    /// `∂(u, v)/∂y`, `y` the point in cam0's frame.
    pub d_cam0: Matrix2x3<f64>,
    /// The point in the camera's own frame.
    pub in_camera: Vector3<f64>,
}

impl Rig {
    /// Camera `c`'s pose relative to cam0: `T_c`, cam0 coordinates to camera c's.
    pub fn from_cam0(&self, c: usize) -> Isometry3<f64> {
        self.cameras[..=c].iter().fold(Isometry3::identity(), |t, cam| cam.from_previous * t)
    }

    /// The camera named `name`, by index.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.cameras.iter().position(|c| c.name == name)
    }

    /// The pixel where camera `c` sees the point `y` (cam0's frame), with its derivatives; `None`
    /// when the point is behind the camera.
    pub fn project(&self, c: usize, y: &Vector3<f64>) -> Option<RigProjection> {
        let t = self.from_cam0(c);
        let in_camera = t * nalgebra::Point3::from(*y);
        let lens = self.cameras[c].lens.project(&in_camera.coords)?;
        Some(RigProjection {
            d_cam0: lens.d_point * t.rotation.to_rotation_matrix().matrix(),
            lens,
            in_camera: in_camera.coords,
        })
    }

    /// The point (cam0's frame) nearest in the least-squares sense to the rays through
    /// `pixels` (`(camera, pixel)`, at least two cameras); `None` when the rays are (nearly)
    /// parallel, a pixel cannot be unprojected, or the point lies behind a camera.
    pub fn triangulate(&self, pixels: &[(usize, Vector2<f64>)]) -> Option<Vector3<f64>> {
        let mut a = nalgebra::Matrix3::zeros();
        let mut b = Vector3::zeros();
        let mut rays = Vec::with_capacity(pixels.len());
        for (c, pixel) in pixels {
            let xy = self.cameras.get(*c)?.lens.unproject(pixel)?;
            let t = self.from_cam0(*c).inverse();
            let direction = (t.rotation * Vector3::new(xy.x, xy.y, 1.0)).normalize();
            let origin = t.translation.vector;
            let across = nalgebra::Matrix3::identity() - direction * direction.transpose();
            a += across;
            b += across * origin;
            rays.push((origin, direction));
        }
        if rays.len() < 2 {
            return None;
        }
        let eigen = a.symmetric_eigenvalues();
        if eigen.min() < 1e-10 * eigen.max() {
            return None;
        }
        let point = a.try_inverse()? * b;
        rays.iter().all(|(o, d)| (point - o).dot(d) > 0.0).then_some(point)
    }

    /// The first baseline's length (m): the distance between cam0's and cam1's centres, the rig's
    /// metric scale; 0 for one camera.
    pub fn baseline_m(&self) -> f64 {
        if self.cameras.len() < 2 { 0.0 } else { self.from_cam0(1).translation.vector.norm() }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Translation3, UnitQuaternion};

    use super::*;

    fn lens(model: DistortionModel, distortion: [f64; 4]) -> Lens {
        Lens { intrinsics: [900.0, 905.0, 640.0, 400.0], distortion_model: model, distortion, resolution: [1280, 800] }
    }

    /// Real lenses, a wide one and a fisheye seeing beyond 90° among them, distort a radius that
    /// grows all the way to the image's corner; coefficients of a wrong sign or order turn it back.
    #[test]
    fn a_real_lens_does_not_fold_the_image_and_a_wrong_one_is_found() {
        let wide =
            |distortion| Lens { intrinsics: [600.0, 600.0, 640.0, 400.0], ..lens(DistortionModel::Radtan, distortion) };
        for real in [
            lens(DistortionModel::Radtan, [0.0; 4]),
            lens(DistortionModel::Radtan, [-0.12, 0.05, 0.001, -0.002]),
            wide([-0.3, 0.1, 0.001, -0.001]),
            lens(DistortionModel::Equidistant, [0.02, -0.01, 0.003, -0.001]),
            Lens {
                intrinsics: [400.0, 400.0, 640.0, 400.0],
                ..lens(DistortionModel::Equidistant, [-0.05, 0.01, 0.0, 0.0])
            },
        ] {
            assert_eq!(real.radial_fold(), None, "{real:?}");
        }
        // k1 = -1 on the wide lens: r_d = r (1 - r²) stops growing at r = 0.58 (r_d 0.38), short of
        // the corner's 1.25.
        for folded in [
            wide([-1.0, 0.0, 0.0, 0.0]),
            lens(DistortionModel::Radtan, [-5.0, 0.0, 0.0, 0.0]),
            lens(DistortionModel::Equidistant, [-5.0, 0.0, 0.0, 0.0]),
        ] {
            assert!(folded.radial_fold().is_some(), "{folded:?}");
        }
    }

    fn lenses() -> [Lens; 3] {
        [
            lens(DistortionModel::Radtan, [0.0; 4]),
            lens(DistortionModel::Radtan, [-0.12, 0.05, 0.001, -0.002]),
            lens(DistortionModel::Equidistant, [0.02, -0.01, 0.003, -0.001]),
        ]
    }

    #[test]
    fn every_derivative_of_a_projection_is_its_central_difference() {
        let z = Vector3::new(0.11, -0.07, 0.6);
        let h = 1e-7;
        for lens in lenses() {
            let p = lens.project(&z).unwrap();
            for k in 0..3 {
                let mut dz = Vector3::zeros();
                dz[k] = h;
                let numeric =
                    (lens.project(&(z + dz)).unwrap().pixel - lens.project(&(z - dz)).unwrap().pixel) / (2.0 * h);
                assert!(
                    (numeric - p.d_point.column(k)).norm() < 1e-4,
                    "{lens:?} point {k}: {numeric} vs {}",
                    p.d_point.column(k)
                );
            }
            for k in 0..4 {
                let mut moved = lens;
                moved.intrinsics[k] += 1e-4;
                let numeric = (moved.project(&z).unwrap().pixel - p.pixel) / 1e-4;
                assert!((numeric - p.d_intrinsics[k]).norm() < 1e-6, "intrinsic {k}");
                let (mut up, mut down) = (lens, lens);
                up.distortion[k] += h;
                down.distortion[k] -= h;
                let numeric = (up.project(&z).unwrap().pixel - down.project(&z).unwrap().pixel) / (2.0 * h);
                assert!(
                    (numeric - p.d_distortion[k]).norm() < 1e-4,
                    "{lens:?} coefficient {k}: {numeric} vs {}",
                    p.d_distortion[k]
                );
            }
        }
    }

    #[test]
    fn a_point_is_unprojected_onto_its_ray_and_triangulated_where_it_is() {
        for lens in lenses() {
            let z = Vector3::new(-0.2, 0.13, 0.7);
            let xy = lens.unproject(&lens.project(&z).unwrap().pixel).unwrap();
            assert!((xy - Vector2::new(z.x / z.z, z.y / z.z)).norm() < 1e-12, "{lens:?}");
        }
        let second = Isometry3::from_parts(
            Translation3::new(-0.12, 0.001, 0.002),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.01, -0.08, 0.003)),
        );
        let [a, b, _] = lenses();
        let rig = Rig {
            cameras: vec![
                RigCamera { name: "cam0".into(), lens: a, from_previous: Isometry3::identity() },
                RigCamera { name: "cam1".into(), lens: b, from_previous: second },
            ],
        };
        let y = Vector3::new(0.05, -0.03, 0.55);
        let pixels: Vec<(usize, Vector2<f64>)> = (0..2).map(|c| (c, rig.project(c, &y).unwrap().lens.pixel)).collect();
        assert!((rig.triangulate(&pixels).unwrap() - y).norm() < 1e-10);
        assert!((rig.baseline_m() - second.translation.vector.norm()).abs() < 1e-15);
        // The derivative in cam0's frame is the lens's through the camera's rotation.
        let h = 1e-7;
        let p = rig.project(1, &y).unwrap();
        for k in 0..3 {
            let mut dy = Vector3::zeros();
            dy[k] = h;
            let numeric = (rig.project(1, &(y + dy)).unwrap().lens.pixel
                - rig.project(1, &(y - dy)).unwrap().lens.pixel)
                / (2.0 * h);
            assert!((numeric - p.d_cam0.column(k)).norm() < 1e-4);
        }
        assert!(rig.project(0, &Vector3::new(0.0, 0.0, -1.0)).is_none(), "behind the camera");
    }
}
