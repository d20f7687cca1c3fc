//! Standard output that a closed reader or a full disk cannot crash (`println!` panics on both).

use std::io::Write;

/// Writes one line to standard output.
pub fn line(text: impl std::fmt::Display) -> anyhow::Result<()> {
    writeln!(std::io::stdout().lock(), "{text}")
        .map_err(|e| anyhow::Error::new(e).context("cannot write to standard output"))
}

/// Whether `error` is standard output's reader having gone (`| head`): the reader chose to
/// stop, which is not a failure.
pub fn is_broken_pipe(error: &anyhow::Error) -> bool {
    error.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
