//! Standard output and standard error that a closed reader or a full disk cannot crash:
//! `println!` and `eprintln!` panic on both, and with standard error full the panic's own
//! message fails too, so the process ended with code 101 and nothing said. Every line the
//! commands print goes through here, and a failed write ends the command like any other error.

use std::io::Write;

/// Which standard stream a write failed on: the context of the error, so that `main` can tell
/// a reader that stopped reading standard output from a failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CannotWrite {
    Stdout,
    Stderr,
}

impl std::fmt::Display for CannotWrite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CannotWrite::Stdout => "cannot write to standard output",
            CannotWrite::Stderr => "cannot write to standard error",
        })
    }
}

/// `error`, from writing to standard output.
pub(crate) fn stdout_error(error: std::io::Error) -> anyhow::Error {
    anyhow::Error::new(error).context(CannotWrite::Stdout)
}

/// Writes one line to standard output.
pub(crate) fn stdout(text: impl std::fmt::Display) -> anyhow::Result<()> {
    writeln!(std::io::stdout().lock(), "{text}").map_err(stdout_error)
}

/// Writes one line (a message, note or warning) to standard error.
pub(crate) fn stderr(text: impl std::fmt::Display) -> anyhow::Result<()> {
    writeln!(std::io::stderr().lock(), "{text}").map_err(|e| anyhow::Error::new(e).context(CannotWrite::Stderr))
}

/// Whether `error` is standard output's reader having gone (`| head`): the reader chose to
/// stop, which is not a failure. Standard error's reader going is one: what it was told is lost.
pub(crate) fn is_broken_pipe(error: &anyhow::Error) -> bool {
    error.downcast_ref::<CannotWrite>() == Some(&CannotWrite::Stdout)
        && error.chain().any(|cause| {
            cause
                .downcast_ref::<std::io::Error>()
                .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
        })
}
