//! The subcommands, and what they share.

use anyhow::Context;

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

/// Refuses a path that is not UTF-8 where `recorded_in` (what records it, e.g. "render.json
/// records the scene's file") writes it to JSON, which holds only UTF-8.
pub(crate) fn recordable(path: &std::path::Path, recorded_in: &str) -> anyhow::Result<()> {
    if path.to_str().is_none() {
        anyhow::bail!(
            "{} is not a UTF-8 name: {recorded_in}, in JSON, which holds only UTF-8; rename it",
            path.display()
        );
    }
    Ok(())
}

/// Refuses to replace an existing file at `path` whose first bytes `ours` does not recognise
/// as a file this command writes (`--out env1.ron` would have overwritten the scene, `scene
/// export` a scene's own mesh); `what` names such files in the message. A missing file is
/// fine; anything but a regular file (a folder, a FIFO, a device) is not ours.
pub(crate) fn refuse_replacing_other_files(
    path: &std::path::Path,
    ours: impl Fn(&[u8]) -> bool,
    what: &str,
) -> anyhow::Result<()> {
    // Only a regular file is opened: a link to a FIFO would wait for a writer.
    let start = match omnisim::input::open_regular(path, u64::MAX) {
        Ok(file) => {
            let mut start = Vec::with_capacity(FIRST_BYTES);
            std::io::Read::read_to_end(&mut std::io::Read::take(file, FIRST_BYTES as u64), &mut start)
                .with_context(|| format!("cannot read {}", path.display()))?;
            Some(start)
        }
        Err(omnisim::input::InputError::NotAFile { .. }) => None,
        Err(omnisim::input::InputError::Io { error, .. }) if error.kind() == std::io::ErrorKind::NotFound => {
            return Ok(());
        }
        // One that cannot be read (no permission) may be anyone's: never replaced unseen.
        Err(error) => {
            return Err(anyhow::Error::new(error)).with_context(|| {
                format!(
                    "{} exists and cannot be read to tell whether it is {what}; choose another output, or remove it \
                     first",
                    path.display()
                )
            });
        }
    };
    if !start.is_some_and(|start| ours(&start)) {
        anyhow::bail!(
            "{} exists and is not {what}; choose another output, or remove it first",
            path.display()
        );
    }
    Ok(())
}

/// Bytes [`refuse_replacing_other_files`] reads to recognise a file.
const FIRST_BYTES: usize = 512;

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
