use std::path::PathBuf;

/// Why a scene could not be loaded or written. Every variant names the file; the ones about
/// content name the line, the column and the object, so the message alone says where to look.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file could not be read (missing, not a regular file, too large, not text).
    #[error(transparent)]
    Input(#[from] crate::input::InputError),
    /// The file is not valid RON for the scene schema.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Parse {
        /// The scene file.
        path: PathBuf,
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// An object is well formed but not a valid shape (degenerate, non-planar, not finite).
    #[error("{}{}: object '{object}': {message}", path.display(), location.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
    Invalid {
        /// The scene file.
        path: PathBuf,
        /// (line, column) of the object's `name` field, 1-based.
        location: Option<(usize, usize)>,
        /// Name of the object.
        object: String,
        /// What is wrong with it.
        message: String,
    },
    /// The scene as a whole is wrong (no faces, or a bad lighting section).
    #[error("{}: {message}", path.display())]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An export could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file being written.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
}
