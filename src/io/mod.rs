//! File plumbing: atomic writes and located errors, YAML with line numbers, CSV by column name.

pub(crate) mod files;
#[cfg(feature = "full")]
pub(crate) mod table;
pub(crate) mod yaml;

pub use files::FileError;
#[cfg(feature = "full")]
pub use files::StagedFile;
