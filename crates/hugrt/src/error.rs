//! The error of the library's whole jobs (a rendering, a scene's statistics, a generated
//! scene written to a file): each step's own error, with the file or spec it concerns.

use crate::accel::SpecError;
use crate::scene::{InstanceError, SceneError, ViewError};
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The error is part of the message, not a separate cause (as [`SceneError`]'s): printing
    /// the chain of causes would repeat it.
    #[error("structure {spec}: {error}")]
    Spec { spec: String, error: SpecError },
    #[error(transparent)]
    View(#[from] ViewError),
    #[error(transparent)]
    Instances(#[from] InstanceError),
    /// A scene with nothing to hit, where something was to be rendered.
    #[error("{0}: no primitives")]
    Empty(String),
    /// A setting outside what the job accepts, named.
    #[error("{0}")]
    Invalid(String),
    /// An output file whose name says a format hugrt does not write.
    #[error("{}: {reason}", path.display())]
    Format { path: PathBuf, reason: String },
    #[error("writing {}: {error}", path.display())]
    Write {
        path: PathBuf,
        error: std::io::Error,
    },
}

impl Error {
    pub(crate) fn spec(spec: &str, error: SpecError) -> Error {
        Error::Spec {
            spec: spec.to_string(),
            error,
        }
    }

    pub(crate) fn write(path: &std::path::Path, error: std::io::Error) -> Error {
        Error::Write {
            path: path.to_path_buf(),
            error,
        }
    }
}
