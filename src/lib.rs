//! spmcal — calibration of spherical parallel manipulators (first of all the Agile Wrist)
//! from joint readings and stereo-camera marker positions.
//!
//! Data flows one way: dataset → vision → calib (uses model) → compare / record.

pub mod calib;
pub mod compare;
pub mod dataset;
pub mod files;
pub mod model;
pub mod polar;
pub mod record;
pub mod sim;
pub mod so3;
pub mod table;
pub mod vision;
