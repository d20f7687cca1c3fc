//! `omnisim preview`: the bird's-eye picture of a data-set spec, as SVG and PNG.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use omnisim_dataset::{Dataset, preview};

/// Draw a data set seen from above: the scene's faces in their colours with the room's extent
/// and a scale bar, every set's poses (one colour per set) with heading arrows, occluders,
/// lights (point lights where they are and where a set moves them, directional ones as arrows)
/// with each set's light changes, and red crosses at poses skipped for lying inside an object
/// or outside the scene (the reference paper's Fig. 7). Nothing is rendered: it takes seconds.
#[derive(Debug, Clone, Args)]
#[command(
    after_help = "Examples:\n  omnisim preview scenes/env1-dataset.ron --out env1-dataset\n    \
(writes env1-dataset.svg and env1-dataset.png)\n  omnisim preview scenes/env1-dataset.ron --out pictures/plan"
)]
pub(crate) struct PreviewArgs {
    /// Data-set spec (RON), e.g. scenes/env1-dataset.ron.
    pub spec: PathBuf,
    /// Output prefix: writes PREFIX.svg and PREFIX.png (their folder is created); a folder
    /// (an existing one, or a path ending in '/') gets FOLDER/preview.svg and .png. Existing
    /// files there are replaced only if they are a preview omnisim drew.
    #[arg(long)]
    pub out: PathBuf,
}

pub(crate) fn run(mut args: PreviewArgs) -> anyhow::Result<()> {
    let names_a_folder = args
        .out
        .as_os_str()
        .to_string_lossy()
        .ends_with(std::path::MAIN_SEPARATOR)
        || args.out.is_dir();
    if names_a_folder {
        args.out.push("preview");
    }
    let dataset = Dataset::load(&args.spec)?;
    for warning in &dataset.warnings {
        crate::streams::stderr(format_args!("warning: {warning}"))?;
    }
    let picture = preview::draw(&dataset)?;
    let [svg, png] = preview::Preview::paths(&args.out);
    for path in [&svg, &png] {
        super::prepare_file(path)?;
    }
    // A preview omnisim drew is replaced, SVG and PNG; any other file at either name is
    // refused (a PNG is taken for a preview's only beside the preview's SVG).
    let what = "a preview omnisim drew";
    super::refuse_replacing_other_files(&svg, preview::Preview::wrote, what)?;
    if !svg.exists() {
        super::refuse_replacing_other_files(&png, |_| false, what)?;
    }
    let written = picture
        .write(&args.out)
        .with_context(|| format!("cannot write the preview {}.svg/.png", args.out.display()))?;
    crate::streams::stderr(format_args!(
        "{} pose(s) of {} set(s), {} skipped; {}×{} px",
        picture.poses,
        dataset.sets.len(),
        picture.skipped,
        picture.view.size.0,
        picture.view.size.1
    ))?;
    for path in written {
        crate::streams::stdout(path.display())?;
    }
    Ok(())
}
