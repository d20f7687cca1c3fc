//! The subcommands, and what they share.

pub mod bench;
pub mod dataset;
pub mod describe;
pub mod poses;
pub mod preview;
pub mod project;
pub mod render;
pub mod scene;
pub mod speed_accuracy;
pub mod vision_input;

/// Creates the folder of a file the user named and checks it is writable before any long work;
/// prints what it cleaned up.
pub fn prepare_file(path: &std::path::Path) -> anyhow::Result<()> {
    let notes = omnisim::output::folder::prepare_file(path)
        .map_err(|e| anyhow::anyhow!(e).context(format!("cannot write {}", path.display())))?;
    for note in notes {
        crate::streams::stderr(format_args!("note: {note}"))?;
    }
    Ok(())
}
