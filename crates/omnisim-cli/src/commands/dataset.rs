//! `omnisim dataset`: render a data set from a spec, resumably and in shards; `merge` checks
//! the frames and writes the index files and manifest.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, Subcommand};
use omnisim::Renderer;
use omnisim_dataset::{self, Dataset, RunOptions, Shard};

use super::render::BackendArg;
use crate::progress::Progress;

/// Render a data set: map and test sets of one scene from one spec file (README, "Data sets").
///
/// Each set gets its own folder under --out, with ground-truth files per frame, noisy copies
/// (*-noisy.*) where the set has noise, TUM (tum/) and EuRoC (mav0/) layouts as asked, and a
/// contact sheet (contact-sheet.png); manifest.json lists every file with its SHA-256. A killed run resumes with the same command; --shard
/// K/N renders every N-th frame from the K-th (0 ≤ K < N); `omnisim dataset merge` then checks
/// the shards and writes the index files and the manifest.
#[derive(Debug, Clone, Args)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    after_help = "Examples:\n  omnisim preview scenes/env1-dataset.ron --out env1-plan   (check the poses first)\n  \
omnisim dataset scenes/env1-dataset.ron --out data/env1\n  \
omnisim dataset scenes/env1-dataset.ron --out data/env1 --shard 0/4\n  omnisim dataset merge data/env1"
)]
pub(crate) struct DatasetArgs {
    #[command(subcommand)]
    pub command: Option<DatasetCommand>,
    /// Data-set spec (RON), e.g. scenes/env1-dataset.ron.
    #[arg(required = true)]
    pub spec: Option<PathBuf>,
    /// Output folder (created if missing); holds one spec's data set.
    #[arg(long, required = true)]
    pub out: Option<PathBuf>,
    /// Render only slice K of N (0 ≤ K < N): $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT, $JOB_COMPLETION_INDEX/N.
    #[arg(long)]
    pub shard: Option<Shard>,
    /// Remove another spec's data set from --out first (only the files it recorded).
    #[arg(long)]
    pub overwrite: bool,
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: BackendArg,
}

#[derive(Debug, Clone, Subcommand)]
pub(crate) enum DatasetCommand {
    /// Check a data set's frames (every file's size and SHA-256, every frame present) and write
    /// the layouts' index files and manifest.json. With more than one folder, the frames of the
    /// others (shards rendered apart) are checked and copied into the first.
    Merge {
        /// The data-set folder, then any shard folders to merge into it.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
    },
}

pub(crate) fn run(args: DatasetArgs) -> anyhow::Result<()> {
    if let Some(DatasetCommand::Merge { dirs }) = args.command {
        let started = Instant::now();
        let (dest, sources) = dirs.split_first().context("merge needs a data-set folder")?;
        let summary =
            omnisim_dataset::merge(dest, sources).with_context(|| format!("cannot merge into {}", dest.display()))?;
        crate::streams::stderr(format_args!(
            "merged {} frames: {} files, {:.1} MB checked, in {:.1} s; wrote {}",
            summary.frames,
            summary.files,
            summary.bytes as f64 / 1e6,
            started.elapsed().as_secs_f64(),
            dest.join("manifest.json").display()
        ))?;
        return Ok(());
    }
    let (Some(spec), Some(out)) = (args.spec, args.out) else {
        anyhow::bail!("give a spec file and --out DIR, or `merge DIR...`");
    };
    let started = Instant::now();
    let dataset = Dataset::load(&spec)?;
    for warning in &dataset.warnings {
        crate::streams::stderr(format_args!("warning: {warning}"))?;
    }
    let renderer = Renderer::new(args.backend.into())?;
    crate::streams::stderr(format_args!(
        "backend: {} on {} — {}",
        renderer.backend_name(),
        renderer.device_name(),
        renderer.reason()
    ))?;
    let options = RunOptions {
        shard: args.shard,
        overwrite: args.overwrite,
        ..RunOptions::default()
    };
    let mut progress = Progress::new("frames");
    let run_started = Instant::now();
    // A progress line that cannot be written stops the run like any failure (resumable).
    let mut unwritten = None;
    let summary = match dataset.run(&renderer, &out, &options, &mut |frame| match progress.step(
        frame.done,
        frame.total,
        !frame.rendered,
        &format!("set '{}', frame {}", frame.set, frame.index),
    ) {
        Ok(()) => ControlFlow::Continue(()),
        Err(error) => {
            unwritten = Some(error);
            ControlFlow::Break(())
        }
    }) {
        Ok(summary) => summary,
        // The folder or the spec must change: resuming would fail the same way.
        Err(final_error) if final_error.needs_a_change() => return Err(final_error.into()),
        Err(stopped) => {
            return Err(anyhow::Error::new(stopped).context(format!(
                "data set {} into {} stopped: remove the cause and run the same command again to resume after the \
                 frames already finished (if any; they are kept)",
                spec.display(),
                out.display()
            )));
        }
    };
    progress.finish();
    if let Some(error) = unwritten {
        return Err(error);
    }
    for note in &summary.notes {
        crate::streams::stderr(format_args!("note: {note}"))?;
    }
    // Frames: from the start of the run to the last frame written; then the checks and index
    // files (manifest, layouts, contact sheets).
    let frames_done = progress.last_step().unwrap_or(run_started);
    let seconds = (frames_done - run_started).as_secs_f64();
    crate::streams::stderr(format_args!(
        "{} frame(s) rendered ({} already done), {:.1} MB written in {seconds:.2} s ({:.2} frames/s) on {}; \
         {:.2} s in all ({:.2} s after the last frame: {})",
        summary.rendered,
        summary.resumed,
        summary.bytes as f64 / 1e6,
        summary.rendered as f64 / seconds.max(1e-9),
        renderer.backend_name(),
        started.elapsed().as_secs_f64(),
        frames_done.elapsed().as_secs_f64(),
        if summary.merged {
            "checks, index files, manifest"
        } else {
            "nothing to merge yet"
        }
    ))?;
    match args.shard {
        Some(shard) => crate::streams::stderr(format_args!(
            "shard {}/{} done; when every shard is, run: omnisim dataset merge {}",
            shard.index,
            shard.count,
            out.display()
        ))?,
        None => crate::streams::stderr(format_args!("wrote {}", out.join("manifest.json").display()))?,
    }
    Ok(())
}
