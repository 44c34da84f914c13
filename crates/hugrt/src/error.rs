//! The error of the library's whole jobs (a rendering, a scene's statistics, a generated
//! scene written to a file): each step's own error, with the file or spec it concerns.

use crate::accel::SpecError;
use crate::scene::{SceneError, ViewError};
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("structure {spec}: {source}")]
    Spec { spec: String, source: SpecError },
    #[error(transparent)]
    View(#[from] ViewError),
    /// A scene with nothing to hit, where something was to be rendered.
    #[error("{0}: no primitives")]
    Empty(String),
    /// A setting outside what the job accepts, named.
    #[error("{0}")]
    Invalid(String),
    /// An output file whose name says a format hugrt does not write.
    #[error("{path}: {reason}")]
    Format { path: PathBuf, reason: String },
    #[error("writing {path}: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl Error {
    pub(crate) fn spec(spec: &str, source: SpecError) -> Error {
        Error::Spec {
            spec: spec.to_string(),
            source,
        }
    }

    pub(crate) fn write(path: &std::path::Path, source: std::io::Error) -> Error {
        Error::Write {
            path: path.to_path_buf(),
            source,
        }
    }
}
