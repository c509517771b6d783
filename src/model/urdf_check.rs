//! What `check_urdf` (urdfdom) rejects, checked on the parsed URDF before anything reads it:
//! unique, non-empty names; every joint's parent and child links exist; no link is the child of
//! two joints; one root; no cycle; and every number (origins, axes, limits, inertials, shape
//! sizes) finite, with non-negative masses and shape sizes and non-zero axes of moving joints.

use std::collections::{HashMap, HashSet};

use urdf_rs::{Geometry, JointType, Pose, Robot};

/// A fault of the tree: the joint or link it is in, and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Fault {
    Joint(String, String),
    Link(String, String),
    Robot(String),
}

fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

fn pose_ok(pose: &Pose) -> bool {
    finite(&pose.xyz.0) && finite(&pose.rpy.0)
}

fn geometry_fault(geometry: &Geometry) -> Option<String> {
    let sizes: Vec<f64> = match geometry {
        Geometry::Box { size } => size.0.to_vec(),
        Geometry::Cylinder { radius, length } | Geometry::Capsule { radius, length } => vec![*radius, *length],
        Geometry::Sphere { radius } => vec![*radius],
        Geometry::Mesh { scale, .. } => scale.map_or(vec![], |s| s.0.to_vec()),
    };
    (!sizes.iter().all(|s| s.is_finite() && *s >= 0.0))
        .then(|| format!("has a shape size that is negative or not finite: {sizes:?}"))
}

fn link_fault(link: &urdf_rs::Link) -> Option<String> {
    if link.name.trim().is_empty() {
        return Some("has an empty name".into());
    }
    let i = &link.inertial;
    let inertia = [i.inertia.ixx, i.inertia.ixy, i.inertia.ixz, i.inertia.iyy, i.inertia.iyz, i.inertia.izz];
    if !(pose_ok(&i.origin) && finite(&inertia) && i.mass.value.is_finite() && i.mass.value >= 0.0) {
        return Some("has an inertial with a negative mass or a number that is not finite".into());
    }
    for (kind, origin, geometry) in link
        .visual
        .iter()
        .map(|v| ("visual", &v.origin, &v.geometry))
        .chain(link.collision.iter().map(|c| ("collision", &c.origin, &c.geometry)))
    {
        if !pose_ok(origin) {
            return Some(format!("has a {kind} origin that is not finite"));
        }
        if let Some(reason) = geometry_fault(geometry) {
            return Some(format!("{kind}: {reason}"));
        }
    }
    None
}

fn joint_fault(joint: &urdf_rs::Joint, links: &HashSet<&str>) -> Option<String> {
    if joint.name.trim().is_empty() {
        return Some("has an empty name".into());
    }
    for (role, link) in [("parent", &joint.parent.link), ("child", &joint.child.link)] {
        if !links.contains(link.as_str()) {
            return Some(format!("names {role} link `{link}`, which does not exist"));
        }
    }
    if joint.parent.link == joint.child.link {
        return Some(format!("has link `{}` as both parent and child", joint.child.link));
    }
    if !pose_ok(&joint.origin) {
        return Some(format!(
            "has an origin that is not finite: xyz {:?} rpy {:?}",
            joint.origin.xyz.0, joint.origin.rpy.0
        ));
    }
    let axis = joint.axis.xyz.0;
    let moving = !matches!(joint.joint_type, JointType::Fixed | JointType::Floating);
    if !finite(&axis) || (moving && axis.iter().all(|c| *c == 0.0)) {
        return Some(format!("has a zero-length or non-finite axis {axis:?}"));
    }
    let l = &joint.limit;
    if !finite(&[l.lower, l.upper, l.effort, l.velocity]) {
        return Some("has a limit that is not finite".into());
    }
    None
}

/// Check the tree; the first fault found.
pub(crate) fn check(robot: &Robot) -> Result<(), Fault> {
    let mut links = HashSet::new();
    for link in &robot.links {
        if let Some(reason) = link_fault(link) {
            return Err(Fault::Link(link.name.clone(), reason));
        }
        if !links.insert(link.name.as_str()) {
            return Err(Fault::Link(link.name.clone(), "is defined twice".into()));
        }
    }
    if links.is_empty() {
        return Err(Fault::Robot("has no links".into()));
    }
    let mut joints = HashSet::new();
    let mut parent_of: HashMap<&str, &str> = HashMap::new();
    for joint in &robot.joints {
        if let Some(reason) = joint_fault(joint, &links) {
            return Err(Fault::Joint(joint.name.clone(), reason));
        }
        if !joints.insert(joint.name.as_str()) {
            return Err(Fault::Joint(joint.name.clone(), "is defined twice".into()));
        }
        if let Some(other) = parent_of.insert(joint.child.link.as_str(), joint.name.as_str()) {
            let reason = format!("makes link `{}` a child a second time (of joint `{other}` too)", joint.child.link);
            return Err(Fault::Joint(joint.name.clone(), reason));
        }
    }
    let parents: HashMap<&str, &str> =
        robot.joints.iter().map(|j| (j.child.link.as_str(), j.parent.link.as_str())).collect();
    let roots: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).filter(|l| !parents.contains_key(l)).collect();
    if roots.len() != 1 {
        let more = if roots.len() > 5 { " …" } else { "" };
        let shown = &roots[..roots.len().min(5)];
        return Err(Fault::Robot(format!(
            "has {} root links {shown:?}{more}; a URDF tree has exactly one",
            roots.len()
        )));
    }
    // With one root and one parent per link, a link that cannot reach the root lies on a cycle (or
    // hangs from one). Each link's walk towards the root stops at a link met on an earlier walk,
    // which reaches the root (that walk ended without a cycle), so every link is walked over once:
    // linear in the size of the tree, however deep. A link met again on the current walk closes a
    // cycle.
    let mut walk_of: HashMap<&str, usize> = HashMap::with_capacity(robot.links.len());
    for (walk, link) in robot.links.iter().enumerate() {
        let mut at = link.name.as_str();
        loop {
            if let Some(&seen) = walk_of.get(at) {
                if seen == walk {
                    return Err(Fault::Link(
                        link.name.clone(),
                        "is on a cycle of joints: a URDF must be a tree".into(),
                    ));
                }
                break;
            }
            walk_of.insert(at, walk);
            match parents.get(at) {
                Some(p) => at = p,
                None => break,
            }
        }
    }
    Ok(())
}
