//! `omnisim`: render simulated cameras in planar-face scenes, export scenes, benchmark.
//!
//! Thin by design: argument parsing, files and progress bars; the work is in the `omnisim`
//! library.

mod camera_args;
mod chart_svg;
mod commands;
mod poses;

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
omnisim poses grid --x=-2:2:0.5 --y=-1.5:1.5:0.5 --z 0.4 --out grid.txt\n  \
omnisim render scenes/env1.ron --camera omni --poses-file grid.txt --out out/grid"
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
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => commands::render::run(args),
        Command::Scene(command) => commands::scene::run(command),
        Command::Poses(command) => commands::poses::run(command),
        Command::Bench(args) => commands::bench::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn command_line_definition_is_consistent() {
        use clap::CommandFactory;
        super::Cli::command().debug_assert();
    }
}
