use thiserror::Error;

/// Why a scene could not be read. Text formats say `file:line`, binary PLY the element.
#[derive(Debug, Error)]
pub enum SceneError {
    /// The error is part of the message, not a separate cause: printing the chain of causes
    /// would repeat it.
    #[error("{path}: {error}")]
    Io { path: String, error: std::io::Error },
    #[error("{path}:{line}: {reason}")]
    Parse {
        path: String,
        line: usize,
        reason: String,
    },
    #[error("{path}: {reason}")]
    Invalid { path: String, reason: String },
    #[error(
        "{path}: unknown scene format (expected .nff, .ply, .obj, .stl, .gltf or .glb, optionally followed by .gz)"
    )]
    UnknownFormat { path: String },
}

impl SceneError {
    pub(crate) fn io(path: &str, error: std::io::Error) -> Self {
        SceneError::Io {
            path: path.to_string(),
            error,
        }
    }
    pub(crate) fn parse(path: &str, line: usize, reason: impl Into<String>) -> Self {
        SceneError::Parse {
            path: path.to_string(),
            line,
            reason: reason.into(),
        }
    }
    pub(crate) fn invalid(path: &str, reason: impl Into<String>) -> Self {
        SceneError::Invalid {
            path: path.to_string(),
            reason: reason.into(),
        }
    }
}
