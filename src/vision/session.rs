//! The vision estimate of a whole session: every pose against the reference pose, markers
//! matched by name, poses that cannot be estimated listed with their reason.

use std::collections::HashMap;
use std::path::PathBuf;

use nalgebra::Vector3;

use super::centre::{CentreOfRotation, centre_of_rotation};
use super::pose::{MarkerError, Method, PoseEstimate, Reference};
use crate::dataset::{MIN_MARKERS, Session, SessionPose};
use crate::math::constellation::Degeneracy;
use crate::math::so3;

/// A pose the estimator could not use, and why; located, where the session was read from files, at
/// the file and line of the marker row the reason is about (`markers.csv:14: pose 3: …`; a
/// free-motion recording's `captures.csv` by its path).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}{}{reason}{}", place(.file, *.line), subject(*.pose, .reason), role(*.reference, *.pose))]
#[non_exhaustive]
pub struct VisionError {
    /// Pose id.
    pub pose: u64,
    /// Why it was skipped.
    pub reason: MarkerError,
    /// The file the pose's markers came from: a recording's `captures.csv`, else `markers.csv` of
    /// the session folder; `None` for a session made in memory.
    pub file: Option<PathBuf>,
    /// The line of that file the reason is about (the second of two coincident markers, else the
    /// pose's first marker row); 0 when unknown or about the file as a whole.
    pub line: usize,
    /// Whether the pose is the session's reference pose (which makes the error the estimate's).
    pub reference: bool,
}

/// What the reference pose is for, when the error is about it.
fn role(reference: bool, pose: u64) -> String {
    match reference {
        true => format!(
            "; pose {pose} is the reference pose, from which the per-pose estimator measures every pose: it needs one whose markers fix an orientation (`reference_pose` in session.yaml)"
        ),
        false => String::new(),
    }
}

/// `pose N: `, unless the reason is about the session as a whole.
fn subject(pose: u64, reason: &MarkerError) -> String {
    match reason {
        MarkerError::NoPoseWithThree { .. } => String::new(),
        _ => format!("pose {pose}: "),
    }
}

/// `file:line: `, `file: ` or nothing.
fn place(file: &Option<PathBuf>, line: usize) -> String {
    match (file, line) {
        (Some(file), 0) => format!("{}: ", file.display()),
        (Some(file), line) => format!("{}:{line}: ", file.display()),
        (None, _) => String::new(),
    }
}

impl VisionError {
    /// The error `reason` about `pose` of `session`, located at the marker row it is about.
    /// `used` are the markers (indices into the session's) the estimate used, in order: a
    /// degeneracy names them by their place in that list.
    fn at(session: &Session, pose: &SessionPose, used: &[usize], reason: MarkerError) -> VisionError {
        let line_of = |k: usize| pose.marker_lines.get(k).copied().filter(|&l| l > 0);
        let row = match &reason {
            MarkerError::Degenerate(Degeneracy::Coincident { second, .. }) => {
                used.get(second.saturating_sub(1)).and_then(|&k| line_of(k))
            }
            _ => (0..pose.markers.len()).filter(|&k| pose.markers[k].is_some()).find_map(line_of),
        };
        let whole = matches!(reason, MarkerError::NoPoseWithThree { .. });
        let file = match &session.streams {
            Some(streams) => Some(streams.captures_path.clone()),
            None if row.is_some() || (whole && session.folder.is_some()) => {
                // A pixel session's points are triangulated from its pixels.csv rows.
                let name = if session.rig.is_some() { "pixels.csv" } else { "markers.csv" };
                Some(session.folder.as_ref().map_or_else(|| PathBuf::from(name), |f| f.join(name)))
            }
            None => None,
        };
        let reference = pose.id == session.reference_pose && !whole;
        VisionError { pose: pose.id, reason, file, line: row.unwrap_or(0), reference }
    }
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
    if session.body.is_some() {
        return Ok(body_poses(session, method));
    }
    if let Some(best) = session.poses.iter().max_by_key(|p| p.seen()).filter(|p| p.seen() < MIN_MARKERS) {
        let mut e = VisionError::at(session, best, &[], MarkerError::NoPoseWithThree { most: best.seen() });
        // About the file as a whole, not one row of it.
        e.line = 0;
        return Err(e);
    }
    let reference = session.reference();
    // Poses are estimated independently: big sessions in two halves, one per core.
    let half = if session.poses.len() >= PARALLEL_ABOVE { session.poses.len() / 2 } else { 0 };
    let (first, second) = session.poses.split_at(half);
    let (first, second) =
        crate::in_parallel(|| estimate_some(session, first, method), || estimate_some(session, second, method));
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

/// A rigid body's session: the tracker measured each pose's orientation itself, so the estimate of
/// a pose is its body's turn from the reference pose's (`Q_j = R_j R_0ᵀ`, body → tracker) and its
/// origin's move — exact as far as the tracker is, with nothing for either method to filter.
fn body_poses(session: &Session, method: Method) -> SessionEstimate {
    let reference = session.reference().body.as_ref().map(|b| (b.rotation, b.position));
    let poses: Vec<(u64, PoseEstimate)> = session
        .poses
        .iter()
        .filter_map(|p| {
            let (b, (r0, c0)) = (p.body.as_ref()?, reference?);
            let rotation = b.rotation * r0.inverse();
            Some((
                p.id,
                PoseEstimate {
                    rotation,
                    putative: rotation.into_inner(),
                    stretch: nalgebra::Matrix3::identity(),
                    error: 0.0,
                    translation: b.position - c0,
                    centroid: b.position,
                    reference_centroid: c0,
                    markers_used: 0,
                    redundant: false,
                    polar_iterations: 0,
                },
            ))
        })
        .collect();
    SessionEstimate {
        method,
        reference_pose: session.reference_pose,
        centre: centre_of_rotation(poses.iter().map(|(_, e)| e)),
        method_difference: vec![0.0; poses.len()],
        poses,
        skipped: Vec::new(),
    }
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
fn estimate_some(session: &Session, poses: &[SessionPose], method: Method) -> Result<Estimates, VisionError> {
    let reference = session.reference();
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
        let fail = |reason| VisionError::at(session, pose, &used, reason);
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
