use std::path::PathBuf;

/// Why a scene could not be loaded or written. Every variant names the file; the ones about
/// content name the line, the column and the object, so the message alone says where to look.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file could not be read (missing, not a regular file, too large, not text).
    #[error(transparent)]
    Input(#[from] crate::input::InputError),
    #[error("{}:{line}:{column}: {message}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{}{}: object '{object}': {message}", path.display(), location.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
    Invalid {
        path: PathBuf,
        /// (line, column) of the object's `name` field, 1-based.
        location: Option<(usize, usize)>,
        object: String,
        message: String,
    },
    #[error("{}: {message}", path.display())]
    Scene { path: PathBuf, message: String },
    #[error("cannot write {}: {source}", path.display())]
    Write { path: PathBuf, source: std::io::Error },
}
