//! Scene loaders: glTF 2.0 files and the built-in Cornell box.

mod attributes;
pub mod builtin;
mod draco;
pub mod gltf;
mod graph;
mod instancing;
pub mod limits;
pub mod media;
mod meshopt;
mod resources;
pub mod save;
pub mod sidecar;
mod tangents;
mod variants;

pub use limits::Limits;
use std::path::{Path, PathBuf};

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
    /// A buffer or image the file names could not be read.
    #[error("{what}: cannot read {uri} ({reason}), named by {path}")]
    Resource {
        /// The file that names it.
        path: PathBuf,
        /// Which one, as "buffer 0" or "image 2".
        what: String,
        /// Its URI as the file gives it (a data URI is shown as "a data URI").
        uri: String,
        /// What went wrong, in one line.
        reason: String,
    },
    /// Loading would exceed the memory limit (or walk too many node placements); refused before allocating.
    #[error("scene too large: {path}: {reason}")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// How much and why, in one line.
        reason: String,
    },
}

/// A refusal before the file it concerns is attached.
#[derive(Debug)]
enum Refusal {
    /// Unreadable or invalid input.
    Invalid(String),
    /// A buffer or image that cannot be read: which, its URI, why.
    Resource(String, String, String),
    /// Over the limits.
    TooLarge(String),
}

impl From<String> for Refusal {
    fn from(reason: String) -> Self {
        Self::Invalid(reason)
    }
}

impl Refusal {
    /// The error for the file at `path`.
    fn at(self, path: &Path) -> LoadError {
        let path = path.to_owned();
        match self {
            Self::Invalid(reason) => LoadError::File { path, reason },
            Self::Resource(what, uri, reason) => LoadError::Resource { path, what, uri, reason },
            Self::TooLarge(reason) => LoadError::TooLarge { path, reason },
        }
    }
}
