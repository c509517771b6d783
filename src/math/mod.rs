//! Mathematics that knows nothing of manipulators: rotations, the polar decomposition, bounded
//! decompositions and marker constellations.

#[cfg(feature = "full")]
pub mod constellation;
pub(crate) mod linalg;
pub mod polar;
pub mod so3;
pub mod stats;
