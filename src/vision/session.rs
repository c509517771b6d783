//! The vision estimate of a whole session: every pose against the reference pose, markers
//! matched by name, poses that cannot be estimated listed with their reason.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::centre::{CentreOfRotation, centre_of_rotation};
use super::pose::{MarkerError, Method, PoseEstimate, Reference};
use crate::dataset::{MIN_MARKERS, Session, SessionPose};
use crate::math::so3;

/// A pose the estimator could not use, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("pose {pose}: {reason}")]
#[non_exhaustive]
pub struct VisionError {
    /// Pose id.
    pub pose: u64,
    /// Why it was skipped.
    pub reason: MarkerError,
}

/// The estimates of a session.
#[derive(Debug, Clone)]
pub struct SessionEstimate {
    /// The estimator used.
    pub method: Method,
    /// The pose rotations are measured from.
    pub reference_pose: u64,
    /// `(pose, estimate)` in session order; the reference pose is included (Q = I).
    pub poses: Vec<(u64, PoseEstimate)>,
    /// Angle (rad) between the paper's and Kabsch's rotation, per estimated pose.
    pub method_difference: Vec<f64>,
    /// Poses skipped, and why.
    pub skipped: Vec<VisionError>,
    /// Centre of rotation of the MP in the camera frame, when determined.
    pub centre: Option<CentreOfRotation>,
}

impl SessionEstimate {
    /// Estimate every pose of `session` against its reference pose. A reference pose whose
    /// markers are degenerate is an error; any other pose that fails is listed in `skipped`. A
    /// session captured one marker at a time is estimated per station ([`Session::by_station`]):
    /// the pose ids are then the stations' first captures.
    ///
    /// # Errors
    /// A [`VisionError`] when no pose (station) sees three markers, or the reference pose's
    /// markers are too few or degenerate.
    ///
    /// # Panics
    /// Never: only seen markers are used.
    pub fn of(session: &Session, method: Method) -> Result<SessionEstimate, VisionError> {
        if session.poses.iter().any(|p| p.station.is_some()) {
            return estimate_poses(&session.by_station(), method);
        }
        estimate_poses(session, method)
    }
}

fn estimate_poses(session: &Session, method: Method) -> Result<SessionEstimate, VisionError> {
    if let Some(best) = session.poses.iter().max_by_key(|p| p.seen()).filter(|p| p.seen() < MIN_MARKERS) {
        return Err(VisionError { pose: best.id, reason: MarkerError::NoPoseWithThree { most: best.seen() } });
    }
    let reference = session.reference();
    // Poses are estimated independently: big sessions in two halves, one per core.
    let half = if session.poses.len() >= PARALLEL_ABOVE { session.poses.len() / 2 } else { 0 };
    let (first, second) = session.poses.split_at(half);
    let (first, second) =
        crate::in_parallel(|| estimate_some(first, reference, method), || estimate_some(second, reference, method));
    let (mut all, second) = (first?, second?);
    all.poses.extend(second.poses);
    all.method_difference.extend(second.method_difference);
    all.skipped.extend(second.skipped);
    Ok(SessionEstimate {
        method,
        reference_pose: reference.id,
        centre: centre_of_rotation(all.poses.iter().map(|(_, e)| e)),
        poses: all.poses,
        method_difference: all.method_difference,
        skipped: all.skipped,
    })
}

/// Sessions with more poses than this are estimated on two cores.
const PARALLEL_ABOVE: usize = 4096;

/// The estimates of some of a session's poses.
#[derive(Default)]
struct Estimates {
    poses: Vec<(u64, PoseEstimate)>,
    method_difference: Vec<f64>,
    skipped: Vec<VisionError>,
}

/// Estimate `poses` against `reference`, each from the markers both saw (one factorisation of the
/// reference per set of markers). A failure of the reference pose itself is an error.
fn estimate_some(poses: &[SessionPose], reference: &SessionPose, method: Method) -> Result<Estimates, VisionError> {
    let markers = reference.markers.len();
    let mut factors: HashMap<Vec<usize>, Reference> = HashMap::new();
    let mut out = Estimates {
        poses: Vec::with_capacity(poses.len()),
        method_difference: Vec::with_capacity(poses.len()),
        skipped: Vec::new(),
    };
    let mut points: Vec<Vector3<f64>> = Vec::with_capacity(markers);
    let mut used: Vec<usize> = Vec::with_capacity(markers);
    for pose in poses {
        used.clear();
        used.extend((0..markers).filter(|&k| pose.markers[k].is_some() && reference.markers[k].is_some()));
        let fail = |reason| VisionError { pose: pose.id, reason };
        let factor = match factors.get(used.as_slice()) {
            Some(f) => f,
            None => {
                let reference_points: Vec<_> = used.iter().map(|&k| reference.markers[k].expect("seen")).collect();
                match Reference::new(&reference_points) {
                    Ok(f) => factors.entry(used.clone()).or_insert(f),
                    Err(reason) if pose.id == reference.id => return Err(fail(reason)),
                    Err(reason) => {
                        out.skipped.push(fail(reason));
                        continue;
                    }
                }
            }
        };
        points.clear();
        points.extend(used.iter().map(|&k| pose.markers[k].expect("seen")));
        match factor.estimate_both(&points) {
            Ok((paper, kabsch)) => {
                out.method_difference.push(so3::geodesic_angle(&paper.rotation, &kabsch.rotation));
                out.poses.push((pose.id, if method == Method::Paper { paper } else { kabsch }));
            }
            Err(reason) if pose.id == reference.id => return Err(fail(reason)),
            Err(reason) => out.skipped.push(fail(reason)),
        }
    }
    Ok(out)
}
