//! Scene loaders: glTF 2.0 files and the built-in Cornell box.

pub mod builtin;
pub mod gltf;
pub mod sidecar;
mod tangents;

use std::path::PathBuf;

/// Why a scene could not be loaded; its `Display` is one line.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read or parsed.
    #[error("cannot load {path}: {reason}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong, in one line.
        reason: String,
    },
}
