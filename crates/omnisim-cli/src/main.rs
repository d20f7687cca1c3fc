//! `omnisim`: render simulated cameras in planar-face scenes, export scenes, benchmark.
//!
//! Thin by design: argument parsing, files and progress bars; the work is in the `omnisim`
//! library.

// Every line goes through `streams`: the print macros panic on a full or closed stream.
#![deny(clippy::print_stdout, clippy::print_stderr)]
#![allow(
    clippy::doc_markdown,
    reason = "doc comments here are clap's --help text, which shows backticks as they are"
)]

mod camera_args;
mod commands;
mod memory;
mod poses;
mod progress;
mod run_folder;
mod streams;
mod warnings;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "omnisim",
    version,
    about = "Ground-truth images, range and point clouds from simulated cameras in virtual rooms",
    long_about = "Ground-truth images, range and point clouds from simulated cameras in virtual rooms.\n\n\
Scenes are RON files of coloured planar faces (see scenes/). Cameras: pinhole, stereo, \
equirectangular and cylindrical panoramas, and catadioptric (hyperbolic, parabolic or spherical \
mirror), traced exactly ray by ray. Frames: \
metres, radians inside; world z up; body x forward, y left, z up; pose rotation \
R = Rx(θx)·Ry(θy)·Rz(θz) as in the reference paper.\n\n\
Examples:\n  omnisim render scenes/env1.ron --camera omni --pose 1.5,0,0.4,0,0,60 --out out/\n  \
omnisim poses grid --x=-2:2:0.5 --y=-1:0.5:0.5 --z 0.4 --out grid.txt\n  \
omnisim render scenes/env1.ron --camera omni --poses-file grid.txt --out out/grid",
    after_long_help = "Environment:\n  \
RAYON_NUM_THREADS       CPU worker threads (default: one a core; at most four a core)\n  \
WGPU_BACKEND            GPU backends to try: vulkan, metal, dx12, gl (default: Vulkan, Metal, DX12)\n  \
WGPU_ADAPTER_NAME       part of the GPU adapter's name to use, any case\n  \
WGPU_POWER_PREF         low or high: which adapter to prefer\n  \
OMNISIM_PROGRESS_SECONDS  seconds between progress lines when standard error is no terminal (default 10)\n  \
BENCH_CACHE             where bench finds the anchor scenes room and clutter (default ~/.cache/omnisim-bench)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Render(commands::render::RenderArgs),
    /// Check a scene file, or export its triangles for other tools.
    #[command(subcommand)]
    Scene(commands::scene::SceneCommand),
    #[command(subcommand)]
    Poses(commands::poses::PosesCommand),
    Bench(commands::bench::BenchArgs),
    Dataset(commands::dataset::DatasetArgs),
    Describe(commands::describe::DescribeArgs),
    Project(commands::project::ProjectArgs),
    Localize(commands::localize::LocalizeArgs),
    Preview(commands::preview::PreviewArgs),
}

fn main() -> std::process::ExitCode {
    keep_freed_memory();
    report_file_size_limits();
    quiet_wayland_probe();
    if let Err(error) = start_thread_pool() {
        let _ = streams::stderr(format_args!("error: {error}"));
        return std::process::ExitCode::FAILURE;
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => commands::render::run(&args),
        Command::Scene(command) => commands::scene::run(command),
        Command::Poses(command) => commands::poses::run(command),
        Command::Bench(args) => commands::bench::run(&args),
        Command::Dataset(args) => commands::dataset::run(args),
        Command::Describe(args) => commands::describe::run(&args),
        Command::Project(args) => commands::project::run(&args),
        Command::Localize(args) => commands::localize::run(&args),
        Command::Preview(args) => commands::preview::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) if streams::is_broken_pipe(&error) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            // With standard error gone or full there is no one to tell; the exit code says it.
            let _ = streams::stderr(format_args!("error: {}", describe(&error)));
            std::process::ExitCode::FAILURE
        }
    }
}

/// Asks glibc to keep freed memory for the next allocation instead of handing it back to the
/// kernel. By default every block over 32 MiB is its own mapping, unmapped when freed, so each
/// frame's hit planes (48 bytes a pixel: 48 MiB at 1024²) came back as fresh pages, faulted and
/// zeroed again: 7–20 ms of a 1024² fast CPU render that takes 28 ms without it
/// (docs/benchmarks.md, "Interval packets and frame buffers"). The cost: resident memory stays
/// at the peak of every allocator arena for the whole run instead of shrinking between
/// frames, and zeroed allocations are zeroed by hand instead of arriving as fresh zero pages.
/// glibc only; other C libraries keep their own policy.
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets allocator parameters; called before any other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_MAX, 0);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

/// Threads a core at most that `RAYON_NUM_THREADS` may ask for: more only cost memory (a stack
/// and an allocator arena each) and start-up time; at 99,999 the pool took longer to start than
/// any render, and where the address space is limited it never started at all.
const THREADS_PER_CORE_AT_MOST: usize = 4;

/// The stack sizes `RUST_MIN_STACK` may set for the threads this program starts: below the
/// smallest the workers overflowed (at 16 KiB), above the largest they were refused.
const THREAD_STACK: std::ops::RangeInclusive<usize> = (2 << 20)..=(64 << 20);

/// Starts rayon's threads now, while the command reads its scene, rather than at the first
/// parallel call (the BVH build's, whose time would include the threads' start): as many as
/// `RAYON_NUM_THREADS` (or rayon's older `RAYON_RS_NUM_CPUS`) asks up to
/// [`THREADS_PER_CORE_AT_MOST`] a core, else one a core. rayon's global pool can be started
/// once: where the system refuses the threads (a process or address-space limit), the error
/// says what to lower, rather than a panic at the first parallel call.
fn start_thread_pool() -> anyhow::Result<()> {
    keep_thread_stacks_in_range();
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let most = cores.saturating_mul(THREADS_PER_CORE_AT_MOST);
    let threads = match asked_threads() {
        Some((name, asked)) if asked > most => {
            warn(format_args!(
                "{name}={asked} is more than {THREADS_PER_CORE_AT_MOST} threads for each of this machine's \
                 {cores} cores; using {most}"
            ));
            most
        }
        Some((_, asked)) => asked,
        None => cores,
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .map_err(|error| {
            anyhow::anyhow!(
                "cannot start {threads} worker threads ({error}): set RAYON_NUM_THREADS to fewer, or raise the limit \
                 on processes (ulimit -u) or on address space (ulimit -v)"
            )
        })
}

/// The worker threads asked for, and by which variable, as rayon reads them: a count above
/// zero in `RAYON_NUM_THREADS`; `0` there means rayon's default; otherwise its older
/// `RAYON_RS_NUM_CPUS` above zero.
fn asked_threads() -> Option<(&'static str, usize)> {
    let count = |name: &str| std::env::var(name).ok().and_then(|text| text.parse::<usize>().ok());
    match count("RAYON_NUM_THREADS") {
        Some(0) => None,
        Some(threads) => Some(("RAYON_NUM_THREADS", threads)),
        None => count("RAYON_RS_NUM_CPUS")
            .filter(|&threads| threads > 0)
            .map(|threads| ("RAYON_RS_NUM_CPUS", threads)),
    }
}

/// Sets `RUST_MIN_STACK` inside [`THREAD_STACK`] (with a warning) where it is set outside,
/// before any thread starts: the Rust runtime reads it once, for every thread after.
fn keep_thread_stacks_in_range() {
    let Some(asked) = std::env::var_os("RUST_MIN_STACK") else {
        return;
    };
    let bytes = asked.to_str().and_then(|text| text.trim().parse::<usize>().ok());
    if bytes.is_some_and(|bytes| THREAD_STACK.contains(&bytes)) {
        return;
    }
    let kept = bytes.unwrap_or(0).clamp(*THREAD_STACK.start(), *THREAD_STACK.end());
    warn(format_args!(
        "RUST_MIN_STACK={} is not a stack size from {} to {} bytes; using {kept}",
        asked.to_string_lossy(),
        THREAD_STACK.start(),
        THREAD_STACK.end()
    ));
    // SAFETY: called in main before any other thread exists (the pool starts after it).
    unsafe { std::env::set_var("RUST_MIN_STACK", kept.to_string()) };
}

/// A warning on standard error before the command runs (nothing to stop if it cannot be said).
fn warn(message: std::fmt::Arguments) {
    let _ = streams::stderr(format_args!("warning: {message}"));
}

/// A write past the process's file-size limit (`ulimit -f`) raises SIGXFSZ, which kills the
/// process silently and leaves its temporaries; ignored, the write fails with EFBIG instead,
/// and the command says which file and stops as after any write error (resumable).
fn report_file_size_limits() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to ignore; called before any other thread exists.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

/// Mesa's Vulkan device-select layer looks for a Wayland compositor whenever adapters are
/// listed, and without XDG_RUNTIME_DIR libwayland prints "XDG_RUNTIME_DIR is invalid or not set"
/// twice. With no runtime dir there is no compositor to find; an absolute path to no folder says
/// so to libwayland as quietly as an empty folder would, and leaves nothing behind when the
/// process is killed (a private folder made here was left in the temporary folder each time).
fn quiet_wayland_probe() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|dir| !dir.is_empty()) {
        return;
    }
    // SAFETY: called first thing in main, before any other thread exists.
    unsafe { std::env::set_var("XDG_RUNTIME_DIR", "/nonexistent/omnisim-no-runtime-dir") };
}

/// The error and its causes joined by ": ", leaving out a cause whose text the message already
/// holds (library errors quote their OS error, which is also their source), and the limit to
/// raise where a process limit caused it.
fn describe(error: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in error.chain().map(ToString::to_string) {
        if !message.contains(&cause) {
            if !message.is_empty() {
                message.push_str(": ");
            }
            message.push_str(&cause);
        }
    }
    if let Some(limit) = error
        .chain()
        .find_map(|cause| process_limit(cause.downcast_ref::<std::io::Error>()?))
    {
        message.push_str(limit);
    }
    message
}

/// What to do where the system refused because of one of the process's limits (`ulimit`),
/// which its own words ("File too large", "Too many open files") do not say.
fn process_limit(error: &std::io::Error) -> Option<&'static str> {
    /// EMFILE, which has no `ErrorKind` of its own: 24 on every Unix.
    const TOO_MANY_OPEN_FILES: i32 = 24;
    if error.kind() == std::io::ErrorKind::FileTooLarge {
        Some(" (the file would pass the process's file-size limit, `ulimit -f`, or the file system's)")
    } else if cfg!(unix) && error.raw_os_error() == Some(TOO_MANY_OPEN_FILES) {
        Some(" (more files open than the limit allows: see or raise `ulimit -n`)")
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    /// A cause that is a process limit's refusal gets the limit to raise, wherever it sits in
    /// the chain; other errors get nothing added.
    #[test]
    fn process_limits_are_named() {
        let too_large =
            anyhow::Error::new(std::io::Error::from(std::io::ErrorKind::FileTooLarge)).context("cannot write x");
        assert!(
            super::describe(&too_large).ends_with("file-size limit, `ulimit -f`, or the file system's)"),
            "{}",
            super::describe(&too_large)
        );
        #[cfg(unix)]
        {
            let open = anyhow::Error::new(std::io::Error::from_raw_os_error(24)).context("cannot open y");
            assert!(
                super::describe(&open).ends_with("see or raise `ulimit -n`)"),
                "{}",
                super::describe(&open)
            );
        }
        let other = anyhow::Error::new(std::io::Error::from(std::io::ErrorKind::NotFound)).context("z");
        assert!(!super::describe(&other).contains("ulimit"));
    }

    #[test]
    fn causes_already_quoted_are_not_repeated() {
        let os = std::io::Error::from(std::io::ErrorKind::NotFound);
        let quoted = anyhow::Error::new(std::io::Error::other(format!("cannot read x: {os}")));
        let error = anyhow::Error::new(os).context(format!(
            "cannot read x: {}",
            std::io::Error::from(std::io::ErrorKind::NotFound)
        ));
        assert_eq!(
            super::describe(&error).matches("not found").count(),
            1,
            "{}",
            super::describe(&error)
        );
        assert_eq!(
            super::describe(&quoted.context("rendering")),
            format!("rendering: {}", "cannot read x: entity not found")
        );
    }

    #[test]
    fn command_line_definition_is_consistent() {
        use clap::CommandFactory;
        super::Cli::command().debug_assert();
    }
}
