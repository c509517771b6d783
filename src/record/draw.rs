//! Logging a [`Scene`]: what each entity looks like.

use std::path::Path;

use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use rerun::{Arrows3D, Color, LineStrips3D, Pinhole, Points2D, Points3D, Scalars, TextDocument, Transform3D};

use super::scene::{FIT_TABLE, ImagePlanes, RecordError, Scene};
use crate::model::Spm;
use crate::report::tables;

/// Radii (m) of the spheres the proximal and distal links move on, as in the nominal model.
const PROXIMAL_RADIUS: f64 = 0.13;
const DISTAL_RADIUS: f64 = 0.16;
/// Points per drawn arc.
const ARC_POINTS: usize = 12;

fn f32x3(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

fn quaternion(r: &Rotation3<f64>) -> rerun::Quaternion {
    let q = UnitQuaternion::from_rotation_matrix(r);
    rerun::Quaternion::from_xyzw([q.i as f32, q.j as f32, q.k as f32, q.w as f32])
}

/// Points along the great circle from direction `a` to direction `b`, at `radius`.
fn arc(a: &Vector3<f64>, b: &Vector3<f64>, radius: f64) -> Vec<[f32; 3]> {
    let (a, b) = (a.normalize(), b.normalize());
    let axis = a.cross(&b);
    let angle = axis.norm().atan2(a.dot(&b));
    let axis = if axis.norm() > 1e-12 { axis.normalize() } else { Vector3::zeros() };
    (0..ARC_POINTS)
        .map(|k| {
            let t = angle * k as f64 / (ARC_POINTS - 1) as f64;
            f32x3(&(crate::math::so3::exp(&(axis * t)) * a * radius))
        })
        .collect()
}

/// The colour of an MP frame source.
fn colour(name: &str) -> Color {
    match name {
        "fda_nominal" => Color::from_rgb(150, 150, 150),
        "fda_calibrated" => Color::from_rgb(40, 170, 80),
        "vision" => Color::from_rgb(240, 140, 20),
        "truth" => Color::from_rgb(40, 110, 230),
        _ => Color::from_rgb(180, 60, 180),
    }
}

/// The colour of a layer of pixels in an image plane.
fn pixel_colour(name: &str) -> Color {
    match name {
        "measured" => Color::from_rgb(240, 140, 20),
        "predicted" => Color::from_rgb(40, 170, 80),
        "nominal" => Color::from_rgb(150, 150, 150),
        _ => Color::from_rgb(180, 60, 180),
    }
}

/// The entity of camera `name`'s image plane (a Pinhole, placed relative to cam0, the camera
/// frame `world/camera`).
pub(crate) fn image_plane(name: &str) -> String {
    format!("world/camera/{name}")
}

/// A pixel in Rerun's image coordinates: Kalibr's (and OpenCV's) put the top-left pixel's centre
/// at (0, 0), Rerun puts the image's top-left corner there (that pixel's centre at (0.5, 0.5)).
fn rerun_pixel(u: f64, v: f64) -> [f32; 2] {
    [(u + 0.5) as f32, (v + 0.5) as f32]
}

fn axes(length: f32) -> Arrows3D {
    Arrows3D::from_vectors([[length, 0.0, 0.0], [0.0, length, 0.0], [0.0, 0.0, length]]).with_colors([
        Color::from_rgb(220, 50, 50),
        Color::from_rgb(50, 200, 50),
        Color::from_rgb(50, 80, 230),
    ])
}

pub(super) struct Logger<'a> {
    pub rec: &'a rerun::RecordingStream,
    pub path: &'a Path,
}

impl Logger<'_> {
    fn log(&self, entity: &str, data: &impl rerun::AsComponents) -> Result<(), RecordError> {
        self.rec.log(entity, data).map_err(|e| self.error(entity, e))
    }

    fn log_static(&self, entity: &str, data: &impl rerun::AsComponents) -> Result<(), RecordError> {
        self.rec.log_static(entity, data).map_err(|e| self.error(entity, e))
    }

    fn error(&self, entity: &str, e: rerun::RecordingStreamError) -> RecordError {
        RecordError::Log { path: self.path.to_path_buf(), entity: entity.to_string(), reason: e.to_string() }
    }

    pub(crate) fn scene(&mut self, scene: &Scene) -> Result<(), RecordError> {
        self.fixed(scene)?;
        self.poses(scene)?;
        self.iterations(scene)
    }

    /// What does not change: base, actuated axes, camera, documents.
    fn fixed(&self, scene: &Scene) -> Result<(), RecordError> {
        self.log_static("world/base", &axes(0.1))?;
        let g = scene.mechanism.geometry();
        let u: Vec<[f32; 3]> = g.iter().map(|l| f32x3(&(l.u * 0.25))).collect();
        self.log_static("world/base/actuated_axes", &Arrows3D::from_vectors(u).with_labels(["u1", "u2", "u3"]))?;
        if let Some(reg) = &scene.registration {
            let centre = reg.centre();
            self.log_static(
                "world/camera",
                &Transform3D::from_translation_rotation(f32x3(&centre), quaternion(&reg.rotation.inverse())),
            )?;
            self.log_static("world/camera/axes", &axes(0.1))?;
            self.log_static("world/camera/centre", &Points3D::new([[0.0f32, 0.0, 0.0]]).with_labels(["camera"]))?;
        }
        if let Some(planes) = &scene.image_planes {
            self.image_planes(planes)?;
        }
        for (name, text) in &scene.documents {
            self.log_static(
                &format!("parameters/{name}"),
                &TextDocument::new(text.as_str()).with_media_type(rerun::MediaType::markdown()),
            )?;
        }
        // The MP's marker tetrahedron, drawn in each MP frame.
        let m: Vec<[f32; 3]> = scene.model.markers.iter().map(|k| f32x3(&k.position)).collect();
        if m.len() >= 3 {
            let mut outline = m.clone();
            outline.push(m[0]);
            for frame in &scene.frames {
                let entity = format!("world/mp/{}/markers", frame.name);
                self.log_static(&entity, &LineStrips3D::new([outline.clone()]).with_colors([colour(&frame.name)]))?;
                self.log_static(&format!("world/mp/{}/axes", frame.name), &axes(0.06))?;
            }
        }
        Ok(())
    }

    /// Each camera of a pixel session as a Pinhole (its intrinsics and resolution; Rerun draws
    /// no distortion) placed relative to cam0 by the rig.
    fn image_planes(&self, planes: &ImagePlanes) -> Result<(), RecordError> {
        for (c, camera) in planes.rig.cameras.iter().enumerate() {
            let entity = image_plane(&camera.name);
            // The camera's own frame in cam0's: the inverse of cam0 → camera.
            let pose = planes.rig.from_cam0(c).inverse();
            let q = pose.rotation;
            let rotation = rerun::Quaternion::from_xyzw([q.i as f32, q.j as f32, q.k as f32, q.w as f32]);
            self.log_static(
                &entity,
                &Transform3D::from_translation_rotation(f32x3(&pose.translation.vector), rotation),
            )?;
            let [fu, fv, pu, pv] = camera.lens.intrinsics;
            let [pu, pv] = rerun_pixel(pu, pv);
            let [width, height] = camera.lens.resolution;
            let pinhole = Pinhole::new([[fu as f32, 0.0, 0.0], [0.0, fv as f32, 0.0], [pu, pv, 1.0]])
                .with_resolution([width as f32, height as f32])
                .with_camera_xyz(rerun::components::ViewCoordinates::RDF)
                .with_image_plane_distance(0.05f32);
            self.log_static(&entity, &pinhole)?;
            // The image's edges, so that the 2-D view shows where in the image the markers are.
            let (w, h) = (width as f32, height as f32);
            self.log_static(
                &format!("{entity}/border"),
                &rerun::LineStrips2D::new([[[0.0, 0.0], [w, 0.0], [w, h], [0.0, h], [0.0, 0.0]]])
                    .with_colors([Color::from_rgb(110, 110, 110)]),
            )?;
        }
        Ok(())
    }

    /// A pose's pixels in every camera's image plane, one entity per layer (empty where the
    /// camera saw nothing, so that no pose shows another's).
    fn pose_pixels(&self, scene: &Scene, planes: &ImagePlanes, pose: u64) -> Result<(), RecordError> {
        for layer in &planes.layers {
            let pixels = layer.pixels.get(&pose).map_or(&[][..], Vec::as_slice);
            for (c, camera) in planes.rig.cameras.iter().enumerate() {
                let (points, labels): (Vec<[f32; 2]>, Vec<String>) = pixels
                    .iter()
                    .filter(|(camera, _, _)| *camera == c)
                    .map(|(_, m, p)| {
                        (rerun_pixel(p.x, p.y), scene.session.markers.get(*m).cloned().unwrap_or_default())
                    })
                    .unzip();
                // The measured pixels carry the markers' names; the predictions beside them are
                // smaller and unlabelled (three labels a marker would hide the points).
                let measured = layer.name == "measured";
                let entity = format!("{}/{}", image_plane(&camera.name), layer.name);
                let points = Points2D::new(points)
                    .with_colors([pixel_colour(&layer.name)])
                    .with_radii([rerun::Radius::new_ui_points(if measured { 4.0 } else { 2.5 })]);
                self.log(&entity, &if measured { points.with_labels(labels) } else { points })?;
            }
        }
        Ok(())
    }

    /// Everything per pose, on the `pose` (and `time`) timelines.
    fn poses(&self, scene: &Scene) -> Result<(), RecordError> {
        let spm: &Spm = &scene.mechanism;
        let mut previous = None;
        for pose in &scene.session.poses {
            self.rec.set_time_sequence("pose", pose.id as i64);
            if let Some(t) = pose.time_s {
                self.rec.set_duration_secs("time", t);
            }
            let r = match previous {
                Some(prev) => spm.track(&pose.joints, &prev).or_else(|_| spm.forward(&pose.joints)),
                None => spm.forward(&pose.joints),
            };
            if let Ok(r) = r {
                previous = Some(r);
                self.mechanism(spm, &pose.joints, &r)?;
                let model_markers: Vec<[f32; 3]> =
                    scene.model.markers.iter().map(|m| f32x3(&(r * m.position))).collect();
                let predicted = match &scene.fitted_markers {
                    Some(fitted) => {
                        self.log(
                            "world/markers/model",
                            &Points3D::new(model_markers)
                                .with_colors([Color::from_rgb(150, 150, 150)])
                                .with_radii([0.003f32]),
                        )?;
                        fitted.iter().map(|p| f32x3(&(r * p))).collect()
                    }
                    None => model_markers,
                };
                self.log(
                    "world/markers/predicted",
                    &Points3D::new(predicted).with_colors([Color::from_rgb(40, 170, 80)]).with_radii([0.004f32]),
                )?;
            }
            if let Some(reg) = &scene.registration {
                let (points, labels): (Vec<[f32; 3]>, Vec<String>) = pose
                    .markers
                    .iter()
                    .zip(&scene.session.markers)
                    .filter_map(|(m, name)| {
                        let corrected = scene.camera_model.undistort(&(*m)?)?;
                        Some((f32x3(&reg.to_base(&corrected)), name.clone()))
                    })
                    .unzip();
                self.log(
                    "world/markers/measured",
                    &Points3D::new(points)
                        .with_labels(labels)
                        .with_colors([Color::from_rgb(240, 140, 20)])
                        .with_radii([0.006f32]),
                )?;
            }
            if let Some(planes) = &scene.image_planes {
                self.pose_pixels(scene, planes, pose.id)?;
            }
            for frame in &scene.frames {
                if let Some(r) = frame.rotations.get(&pose.id) {
                    self.log(&format!("world/mp/{}", frame.name), &Transform3D::from_rotation(quaternion(r)))?;
                }
            }
            for series in &scene.series {
                if let Some(v) = series.values.get(&pose.id) {
                    self.log(&format!("errors/{}", series.name), &Scalars::single(*v))?;
                }
            }
        }
        Ok(())
    }

    /// The legs as arcs: proximal from `u` to `w` on its sphere, distal from `w` to `v` on its own.
    fn mechanism(&self, spm: &Spm, joints: &Vector3<f64>, r: &Rotation3<f64>) -> Result<(), RecordError> {
        let w = spm.intermediate_axes(joints);
        let v = spm.platform_axes(r);
        for (i, g) in spm.geometry().iter().enumerate() {
            let leg = format!("world/legs/leg{}", i + 1);
            self.log(
                &format!("{leg}/proximal"),
                &LineStrips3D::new([arc(&g.u, &w[i], PROXIMAL_RADIUS)]).with_radii([0.008f32]),
            )?;
            self.log(
                &format!("{leg}/distal"),
                &LineStrips3D::new([arc(&w[i], &v[i], DISTAL_RADIUS)]).with_radii([0.008f32]),
            )?;
        }
        Ok(())
    }

    /// The fit: a table (static, for the default layout) and plots on the `iteration` timeline.
    fn iterations(&self, scene: &Scene) -> Result<(), RecordError> {
        self.rec.reset_time();
        if !scene.iterations.is_empty() {
            let table =
                TextDocument::new(tables::iterations(&scene.iterations)).with_media_type(rerun::MediaType::markdown());
            self.log_static(FIT_TABLE, &table)?;
        }
        for it in &scene.iterations {
            self.rec.set_time_sequence("iteration", it.iteration as i64);
            self.log("fit/cost", &Scalars::single(it.cost))?;
            self.log("fit/step", &Scalars::single(it.step))?;
            self.log("fit/rms", &Scalars::single(it.rms))?;
        }
        Ok(())
    }
}
