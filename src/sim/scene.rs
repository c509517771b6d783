//! The mechanism's collision geometry posed at a configuration (parry): link–link collisions
//! and occlusion of a marker's line of sight.

use nalgebra::{Isometry3, Rotation3, UnitQuaternion, Vector3};
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::{Ray, intersection_test};
use parry3d_f64::shape::SharedShape;

use crate::math::so3;
use crate::model::{Body, RobotModel, Shape, Spm};

/// The bodies in a fixed order: base, proximal 1–3, distal 1–3, platform.
const BODIES: [Body; 8] = [
    Body::Base,
    Body::Proximal(0),
    Body::Proximal(1),
    Body::Proximal(2),
    Body::Distal(0),
    Body::Distal(1),
    Body::Distal(2),
    Body::Platform,
];

fn body_index(body: Body) -> usize {
    BODIES.iter().position(|b| *b == body).expect("every body is listed")
}

/// Bodies joined by a joint touch by design; their contact is not a collision.
fn adjacent(a: Body, b: Body) -> bool {
    use Body::*;
    matches!((a, b), (Base, Proximal(_)) | (Proximal(_), Base) | (Distal(_), Platform) | (Platform, Distal(_)))
        || matches!((a, b), (Proximal(i), Distal(j)) | (Distal(j), Proximal(i)) if i == j)
}

/// Rotation of each body about O (all bodies of an SPM only rotate).
pub(crate) type BodyRotations = [Rotation3<f64>; 8];

struct PlacedShape {
    body: usize,
    shape: SharedShape,
    /// Pose of the parry shape in B at the home pose (URDF z-axis conventions already applied).
    at_home: Isometry3<f64>,
}

/// Collision geometry of a model, ready to be posed.
pub(crate) struct CollisionScene {
    shapes: Vec<PlacedShape>,
    /// Per leg, the home directions the links carry: `(u, w(0))` for the proximal and
    /// `(w(0), v0)` for the distal link.
    home_axes: [[Vector3<f64>; 3]; 3],
}

fn to_pose(iso: &Isometry3<f64>) -> Pose {
    Pose::from(*iso)
}

fn to_vector(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

impl CollisionScene {
    /// The model's collision primitives. URDF cylinders and capsules run along z, parry's
    /// cylinders along y: a quarter turn about x maps one onto the other.
    pub(crate) fn new(model: &RobotModel) -> Self {
        let y_to_z = Isometry3::from_parts(
            Default::default(),
            UnitQuaternion::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, 0.0),
        );
        let shapes = model
            .shapes
            .iter()
            .map(|s| {
                let (shape, local) = match s.shape {
                    Shape::Cylinder { radius, length } => (SharedShape::cylinder(length / 2.0, radius), y_to_z),
                    Shape::Capsule { radius, length } => {
                        (SharedShape::capsule_z(length / 2.0, radius), Isometry3::identity())
                    }
                    Shape::Cuboid { half_extents: h } => (SharedShape::cuboid(h.x, h.y, h.z), Isometry3::identity()),
                    Shape::Sphere { radius } => (SharedShape::ball(radius), Isometry3::identity()),
                };
                PlacedShape { body: body_index(s.body), shape, at_home: s.pose_at_home * local }
            })
            .collect();
        let home = model.spm.geometry();
        let home_axes = [0, 1, 2].map(|i| {
            let g = &home[i];
            [g.u, g.u * g.alpha1.cos() + g.z * g.alpha1.sin(), g.v0]
        });
        CollisionScene { shapes, home_axes }
    }

    /// Rotation of every body for joint readings `joints` and MP orientation `r` of manipulator
    /// `spm` (the true geometry in a simulation): each link carries its two axes.
    pub(crate) fn body_rotations(&self, spm: &Spm, joints: &Vector3<f64>, r: &Rotation3<f64>) -> BodyRotations {
        let w = spm.intermediate_axes(joints);
        let v = spm.platform_axes(r);
        let g = spm.geometry();
        let mut out = [Rotation3::identity(); 8];
        for i in 0..3 {
            let [u0, w0, v0] = &self.home_axes[i];
            out[1 + i] = so3::carry(u0, w0, &g[i].u, &w[i]);
            out[4 + i] = so3::carry(w0, v0, &w[i], &v[i]);
        }
        out[7] = *r;
        out
    }

    fn posed(&self, rotations: &BodyRotations, s: &PlacedShape) -> Pose {
        to_pose(&(Isometry3::from_parts(Default::default(), rotations[s.body].into()) * s.at_home))
    }

    /// The first pair of non-adjacent bodies whose shapes intersect, if any (first in the
    /// model's order of shapes).
    ///
    /// Sweep and prune: the shapes' bounding boxes sorted along x, and only the pairs whose boxes
    /// overlap are tested exactly — a model with many shapes costs about its number of shapes
    /// (times the few each one overlaps), not its number of pairs. A box holds its shape, so no
    /// intersecting pair is missed: the answer is the one of testing every pair.
    pub(crate) fn collision(&self, rotations: &BodyRotations) -> Option<(Body, Body)> {
        let posed: Vec<Pose> = self.shapes.iter().map(|s| self.posed(rotations, s)).collect();
        let boxes: Vec<Aabb> = self.shapes.iter().zip(&posed).map(|(s, p)| s.shape.compute_aabb(p)).collect();
        let mut order: Vec<usize> = (0..self.shapes.len()).collect();
        order.sort_by(|&a, &b| boxes[a].mins.x.total_cmp(&boxes[b].mins.x));
        let mut first: Option<(usize, usize)> = None;
        for (k, &i) in order.iter().enumerate() {
            for &j in &order[k + 1..] {
                if boxes[j].mins.x > boxes[i].maxs.x {
                    break;
                }
                let (a, b) = (i.min(j), i.max(j));
                let (sa, sb) = (&self.shapes[a], &self.shapes[b]);
                let (ba, bb) = (BODIES[sa.body], BODIES[sb.body]);
                let overlap = |lo: f64, hi: f64, lo2: f64, hi2: f64| lo <= hi2 && lo2 <= hi;
                let (p, q) = (&boxes[a], &boxes[b]);
                if first.is_some_and(|f| f <= (a, b))
                    || sa.body == sb.body
                    || adjacent(ba, bb)
                    || !overlap(p.mins.y, p.maxs.y, q.mins.y, q.maxs.y)
                    || !overlap(p.mins.z, p.maxs.z, q.mins.z, q.maxs.z)
                {
                    continue;
                }
                let hit = intersection_test(&posed[a], sa.shape.as_ref(), &posed[b], sb.shape.as_ref());
                if hit.is_ok_and(|h| h.intersecting) {
                    first = Some((a, b));
                }
            }
        }
        first.map(|(a, b)| (BODIES[self.shapes[a].body], BODIES[self.shapes[b].body]))
    }

    /// The body that hides the segment from a marker centre to a lens, if any. The segment starts
    /// `marker_radius` out of the marker, so that the surface it sits on does not hide it.
    pub(crate) fn occluder(
        &self,
        rotations: &BodyRotations,
        marker: &Vector3<f64>,
        lens: &Vector3<f64>,
        marker_radius: f64,
    ) -> Option<Body> {
        let to_lens = lens - marker;
        let length = to_lens.norm();
        let dir = to_lens / length;
        let ray = Ray::new(to_vector(&(marker + dir * marker_radius)), to_vector(&dir));
        let reach = length - marker_radius;
        self.shapes
            .iter()
            .find(|s| s.shape.as_ref().cast_ray(&self.posed(rotations, s), &ray, reach, true).is_some())
            .map(|s| BODIES[s.body])
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::sim::SimConfig;

    #[test]
    fn a_marker_behind_a_link_is_occluded() {
        let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap();
        let scene = CollisionScene::new(&model);
        let home = scene.body_rotations(&model.spm, &model.spm.home_joints(), &Rotation3::identity());
        // The middle of leg 1's distal arc (radius 0.16 m from z1 to v0_1): a point inside the
        // sphere seen from a point outside it along the same direction is hidden by that link.
        let g = model.spm.geometry()[0];
        let mid = (g.z + g.v0).normalize();
        let occluder = scene.occluder(&home, &(mid * 0.10), &(mid * 1.0), 0.006);
        assert_eq!(occluder, Some(Body::Distal(0)));
        // The MP markers seen from below the base are hidden; from the camera above they are not.
        for m in &model.markers[..3] {
            assert!(scene.occluder(&home, &m.position, &Vector3::new(0.0, 0.0, -1.0), 0.006).is_some());
            assert_eq!(scene.occluder(&home, &m.position, &Vector3::new(0.06, 0.0, 0.8), 0.006), None);
        }
    }

    #[test]
    fn colliding_poses_are_detected_and_never_written() {
        let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).unwrap();
        let scene = CollisionScene::new(&model);
        let spm = &model.spm;
        let rotations = |r: &Rotation3<f64>| scene.body_rotations(spm, &spm.ik(r).unwrap(), r);
        assert_eq!(scene.collision(&rotations(&Rotation3::identity())), None, "home must be collision-free");
        // 30° of tilt with 30° of yaw: neighbouring links meet (a corner of the workspace).
        let corner = so3::exp(&(Vector3::x() * 30f64.to_radians())) * so3::exp(&(Vector3::z() * 30f64.to_radians()));
        assert!(scene.collision(&rotations(&corner)).is_some());

        let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
        config.poses = 150;
        let (session, summary) = config.simulate(&model, &mut |_| {}).unwrap();
        assert!(summary.rejected_collision > 0, "the ±30°/±30° workspace has colliding corners");
        let truth = session.truth.unwrap();
        let true_spm = truth.parameters.spm().unwrap();
        for (id, r) in &truth.orientations {
            let joints = true_spm.ik(r).unwrap();
            assert_eq!(scene.collision(&scene.body_rotations(&true_spm, &joints, r)), None, "pose {id} collides");
        }
    }
}
