//! The one error type of Photon, and the exit code each kind of error maps to.
//!
//! Only `main` prints errors and chooses the process exit code (docs/ARCHITECTURE.md, "Conventions"):
//! 0 success, 1 internal failure, 2 bad input (scene or arguments), 130 cancelled.

use std::path::PathBuf;

/// Everything that can go wrong between reading a scene and writing an image.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene file is unreadable or describes something Photon cannot render.
    /// `object` names the glTF object ("mesh 'Cube' primitive 0", "material 'Glass'").
    #[error("{}: {object}: {message}", path.display())]
    Scene {
        path: PathBuf,
        object: String,
        message: String,
    },
    /// A command-line value or setting is out of range.
    #[error("invalid setting: {0}")]
    Settings(String),
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The user asked to stop (Ctrl+C, SIGTERM, Esc in Blender).
    #[error("cancelled")]
    Cancelled,
    /// A bug or an unexpected failure inside Photon.
    #[error("internal error: {0}")]
    Internal(String),
}

impl Error {
    /// The process exit code docs/ARCHITECTURE.md assigns to this error.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Scene { .. } | Error::Settings(_) => 2,
            Error::Io { .. } => 2,
            Error::Cancelled => 130,
            Error::Internal(_) => 1,
        }
    }

    /// Shorthand for a scene error.
    pub fn scene(
        path: impl Into<PathBuf>,
        object: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Error::Scene {
            path: path.into(),
            object: object.into(),
            message: message.into(),
        }
    }

    /// Shorthand for an I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;
