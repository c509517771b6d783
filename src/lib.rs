#![deny(missing_docs, unreachable_pub)]
#![warn(clippy::missing_errors_doc, clippy::missing_panics_doc)]
//! spmcal — calibration of spherical parallel manipulators (first of all the Agile Wrist)
//! from joint readings and stereo-camera marker positions.
//!
//! Data flows one way (docs/architecture.md): math, io → model → dataset → vision, sim → calib →
//! plan, compare → record, html.
//!
//! Leg numbering: in the API a leg is an index 0, 1, 2 — into `[LegGeometry; 3]`, in
//! [`model::Spm::ik_leg`], [`model::Body::Proximal`], and in the `leg` field of every error; what
//! a person reads numbers them 1, 2, 3 — messages (`leg 2: …`), parameter names (`leg2.alpha1`),
//! recording entities (`world/legs/leg2`).
//!
//! Using a (calibrated) model at run time, e.g. in a 1 kHz haptic loop — all a controller needs is
//! the lean core, `spmcal = { version = "0.1", default-features = false }` (the model and the
//! parameters file on nalgebra, serde and thiserror; the default feature `full` adds the rest):
//!
//! ```
//! use nalgebra::Vector3;
//! use spmcal::model::Parameters;
//!
//! // A parameters file: calibrated (`spmcal calibrate --out params.yaml`) or any other; here the
//! // true geometry of a simulated session.
//! let spm = Parameters::read(std::path::Path::new("datasets/agile_wrist_sim_20/truth.yaml"))?.spm()?;
//!
//! // Once: the working-mode orientation, by continuation from home (1.38 µs).
//! let mut r = spm.forward(&Vector3::new(0.10, -0.05, 0.02))?;
//! // Every tick: Newton from the previous orientation (492 ns, no allocation). A pose near a
//! // singularity or off the working mode is an error, never a silently wrong branch.
//! for k in 1..=10 {
//!     let joints = Vector3::new(0.10 + 0.001 * k as f64, -0.05, 0.02);
//!     r = spm.track(&joints, &r)?;
//! }
//! let [qw, qx, qy, qz] = spmcal::math::so3::to_wxyz(&r); // MP → base, scalar first
//! assert!((qw * qw + qx * qx + qy * qy + qz * qz - 1.0).abs() < 1e-12);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The common path with the default feature `full` — load a model and a session, calibrate,
//! compare nominal and calibrated parameters with the camera, use the result — is in the
//! [`prelude`]:
//!
//! ```
//! # #[cfg(feature = "full")]
//! # {
//! use spmcal::prelude::*;
//! use std::path::Path;
//!
//! let (session, _warnings) = Session::load(Path::new("datasets/agile_wrist_sim_20"), None)?;
//! let model = RobotModel::load(&session.model)?;
//! // FDA and IK of the nominal model: joints → MP orientation → joints.
//! let joints = nalgebra::Vector3::new(0.2, -0.1, 0.05);
//! let r = model.spm.forward(&joints)?;
//! assert!((model.spm.ik(&r)? - joints).amax() < 1e-9);
//! // Calibrate (the marker-level fit by default) and read the one verdict.
//! let calibration = calibrate(&session, &model, &CalibConfig::default(), &mut |_| {})?;
//! assert!(calibration.report.verdict.pass, "{}", calibration.report.verdict);
//! // The camera against each parameter set, per pose: the calibrated one agrees far better.
//! let sets = [
//!     ("nominal".to_string(), Parameters::nominal(&model.spm, None)),
//!     ("calibrated".to_string(), calibration.parameters.clone()),
//! ];
//! let compared = compare(&session, &model, &sets, Method::Kabsch, None)?;
//! assert!(compared[1].errors.rms < compared[0].errors.rms / 2.0);
//! // The calibrated model, ready for a controller.
//! let spm = calibration.parameters.spm()?;
//! let _ = spm.forward(&joints)?;
//! # }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

/// The common path in one import: models and parameters, FDA/IK, sessions, calibration and
/// comparison.
pub mod prelude {
    pub use crate::math::so3;
    pub use crate::model::{Parameters, Spm};
    #[cfg(feature = "full")]
    pub use crate::{
        calib::{CalibConfig, Calibration, FitLevel, calibrate},
        compare::compare,
        dataset::Session,
        model::RobotModel,
        vision::Method,
    };
}

// The lean core (always): the model, the parameters file and their plumbing.
pub mod io;
pub mod math;
pub mod model;
pub use io::FileError;

// Everything else: feature `full` (the default).
#[cfg(feature = "full")]
pub mod calib;
#[cfg(feature = "full")]
pub mod compare;
#[cfg(feature = "full")]
pub mod dataset;
// The HTML report is one method, `Calibration::html`: nothing else of the module is public.
#[cfg(feature = "full")]
pub mod plan;
#[cfg(feature = "full")]
pub mod record;
#[cfg(feature = "full")]
mod report;
#[cfg(feature = "full")]
pub mod sim;
#[cfg(feature = "full")]
pub mod vision;
#[cfg(feature = "full")]
pub(crate) use io::files::in_parallel;
