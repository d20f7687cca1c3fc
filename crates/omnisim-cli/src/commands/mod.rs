//! The subcommands, and what they share.

pub(crate) mod bench;
pub(crate) mod dataset;
pub(crate) mod describe;
pub(crate) mod localize;
pub(crate) mod poses;
pub(crate) mod preview;
pub(crate) mod project;
pub(crate) mod render;
pub(crate) mod scene;
pub(crate) mod speed_accuracy;
pub(crate) mod sweep;
pub(crate) mod vision_input;

/// Creates the folder of a file the user named and checks it is writable before any long work;
/// prints what it cleaned up.
pub(crate) fn prepare_file(path: &std::path::Path) -> anyhow::Result<()> {
    let notes = omnisim::output::folder::prepare_file(path)
        .map_err(|e| anyhow::anyhow!(e).context(format!("cannot write {}", path.display())))?;
    for note in notes {
        crate::streams::stderr(format_args!("note: {note}"))?;
    }
    Ok(())
}
