//! `omnisim poses`: pose files for data sets (grid maps, trajectories, random test poses),
//! in the format `render --poses-file` reads.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use glam::{DVec3, dvec3};
use omnisim::advanced::SceneBvh;
use omnisim::atomic_file::write_atomically;
use omnisim::input::shown_number;
use omnisim::pose_sets::{self, RandomPoses};
use omnisim::{Pose, Scene};

/// Write poses for a data set: one "x y z θx θy θz" per line (metres, degrees).
#[derive(Debug, Subcommand)]
pub(crate) enum PosesCommand {
    /// A grid map: every combination of the x, y and z values.
    #[command(after_help = "Example:\n  omnisim poses grid --x=-2:2:0.5 --y=-1:0.5:0.5 --z 0.4 --out grid.txt")]
    Grid {
        /// x values, START:STOP:STEP (inclusive) or one value, metres.
        #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
        x: Values,
        /// y values, START:STOP:STEP or one value, metres.
        #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
        y: Values,
        /// z values, START:STOP:STEP or one value, metres.
        #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
        z: Values,
        /// Rotation of every pose, θx,θy,θz in degrees.
        #[arg(long, value_parser = parse_triple, default_value = "0,0,0", allow_hyphen_values = true)]
        angles: DVec3,
        #[command(flatten)]
        out: Output,
    },
    /// A trajectory: poses every --spacing metres along straight lines through the waypoints,
    /// each turned (θz) to face the direction of travel.
    #[command(
        after_help = "Example:\n  omnisim poses trajectory --through=-2,-1,0.4 --through 2,-1,0.4 --through 2,0.3,0.4 --through=-2,0.3,0.4 --spacing 0.1"
    )]
    Trajectory {
        /// A waypoint x,y,z in metres; give two or more, in order.
        #[arg(long = "through", value_parser = parse_position, allow_hyphen_values = true, required = true)]
        waypoints: Vec<DVec3>,
        /// Distance between consecutive poses, metres.
        #[arg(long, default_value_t = 0.1)]
        spacing: f64,
        #[command(flatten)]
        out: Output,
    },
    /// Random test poses inside a scene, reproducible with --seed, kept --clearance away from
    /// every surface along the six axis directions.
    #[command(
        after_help = "Example:\n  omnisim poses random scenes/env1.ron --count 100 --z 0.4 --seed 7 --out test.txt"
    )]
    Random {
        /// Scene file (RON).
        scene: PathBuf,
        #[arg(long, default_value_t = 100)]
        count: usize,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Height: one value or LOW:HIGH in metres [default: anywhere in the scene's bounds].
        #[arg(long, value_parser = parse_interval, allow_hyphen_values = true)]
        z: Option<(f64, f64)>,
        /// Largest |θx| and |θy| in degrees; θz is drawn over the full turn.
        #[arg(long, default_value_t = 0.0)]
        max_tilt: f64,
        /// Free distance kept from every surface along ±x, ±y, ±z, metres.
        #[arg(long, default_value_t = 0.2)]
        clearance: f64,
        #[command(flatten)]
        out: Output,
    },
}

#[derive(Debug, Args)]
pub(crate) struct Output {
    /// Pose file to write [default: standard output].
    #[arg(long)]
    out: Option<PathBuf>,
}

fn number(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("'{text}' is not a finite number"))
}

/// The most poses one file may hold (a billion-pose typo should fail, not exhaust memory).
const MAX_POSES: usize = 10_000_000;

/// The values of one grid axis.
#[derive(Debug, Clone)]
pub(crate) struct Values(Vec<f64>);

fn parse_range(text: &str) -> Result<Values, String> {
    let parts: Vec<f64> = text.split(':').map(number).collect::<Result<_, _>>()?;
    match parts[..] {
        [v] => Ok(Values(vec![v])),
        [start, stop, step] if step > 0.0 && stop >= start => {
            if (stop - start) / step >= MAX_POSES as f64 {
                return Err(format!(
                    "'{text}' makes more than {MAX_POSES} values; use a larger step"
                ));
            }
            Ok(Values(pose_sets::steps(start, stop, step)))
        }
        _ => Err(format!(
            "'{text}' is not VALUE or START:STOP:STEP with STEP > 0 and STOP ≥ START"
        )),
    }
}

fn parse_interval(text: &str) -> Result<(f64, f64), String> {
    let parts: Vec<f64> = text.split(':').map(number).collect::<Result<_, _>>()?;
    match parts[..] {
        [v] => Ok((v, v)),
        [low, high] if high >= low => Ok((low, high)),
        _ => Err(format!("'{text}' is not VALUE or LOW:HIGH with HIGH ≥ LOW")),
    }
}

fn parse_triple(text: &str) -> Result<DVec3, String> {
    let parts: Vec<f64> = text.split(',').map(number).collect::<Result<_, _>>()?;
    match parts[..] {
        [x, y, z] => Ok(dvec3(x, y, z)),
        _ => Err(format!("'{text}' is not three comma-separated numbers")),
    }
}

/// A position, `x,y,z` in metres, where scenes may lie (as `--pose` takes it).
fn parse_position(text: &str) -> Result<DVec3, String> {
    let position = parse_triple(text)?;
    crate::poses::check_position(&position.to_array(), &omnisim::input::shown(text, 80))?;
    Ok(position)
}

/// How every pose file this command writes starts.
const HEADER: &str = "# omnisim poses";

fn write(poses: &[Pose], kind: &str, out: &Output) -> anyhow::Result<()> {
    let fill = |w: &mut dyn Write| -> std::io::Result<()> {
        writeln!(
            w,
            "{HEADER} ({kind}): x y z (metres) θx θy θz (degrees, R = Rx·Ry·Rz); render --poses-file"
        )?;
        for pose in poses {
            // + 0.0 turns −0 into 0.
            let (p, a) = (pose.position + 0.0, pose.angles_degrees() + 0.0);
            writeln!(w, "{} {} {} {} {} {}", p.x, p.y, p.z, a.x, a.y, a.z)?;
        }
        Ok(())
    };
    match &out.out {
        Some(path) => {
            // A FIFO is refused before it is opened (opening it waits for a writer).
            super::prepare_file(path)?;
            super::refuse_replacing_other_files(
                path,
                |start| start.starts_with(HEADER.as_bytes()),
                "a pose file omnisim wrote",
            )?;
            write_atomically(path, |file| fill(file)).with_context(|| format!("cannot write {}", path.display()))?;
            crate::streams::stderr(format_args!("{} poses written to {}", poses.len(), path.display()))?;
        }
        None => fill(&mut std::io::stdout().lock()).map_err(crate::streams::stdout_error)?,
    }
    Ok(())
}

pub(crate) fn run(command: PosesCommand) -> anyhow::Result<()> {
    match command {
        PosesCommand::Grid { x, y, z, angles, out } => {
            let count = x.0.len() as f64 * y.0.len() as f64 * z.0.len() as f64;
            if count > MAX_POSES as f64 {
                bail!("the grid has {count} poses; at most {MAX_POSES} are written, use larger steps");
            }
            let poses = pose_sets::grid(&x.0, &y.0, &z.0, angles * (std::f64::consts::PI / 180.0));
            write(&poses, "grid", &out)
        }
        PosesCommand::Trajectory {
            waypoints,
            spacing,
            out,
        } => {
            if waypoints.len() < 2 {
                bail!("a trajectory needs two or more --through waypoints");
            }
            if !(spacing.is_finite() && spacing > 0.0) {
                bail!(
                    "--spacing must be a positive number of metres, not {}",
                    shown_number(spacing)
                );
            }
            let length: f64 = waypoints.windows(2).map(|w| w[0].distance(w[1])).sum();
            if length == 0.0 {
                bail!("the --through waypoints are all the same point: a trajectory needs two different ones");
            }
            if length / spacing > MAX_POSES as f64 {
                bail!(
                    "{} m every {} m is more than {MAX_POSES} poses; use a larger --spacing",
                    shown_number(length),
                    shown_number(spacing)
                );
            }
            write(&pose_sets::trajectory(&waypoints, spacing), "trajectory", &out)
        }
        PosesCommand::Random {
            scene,
            count,
            seed,
            z,
            max_tilt,
            clearance,
            out,
        } => {
            omnisim::input::check_regular(&scene, omnisim::input::SCENE_LIMIT)?;
            if !(1..=MAX_POSES).contains(&count) {
                bail!("--count must be from 1 to {MAX_POSES}, not {count}");
            }
            if !(max_tilt.is_finite() && (0.0..=90.0).contains(&max_tilt)) {
                bail!("--max-tilt is the largest |θx| and |θy| in degrees, from 0 to 90, not {max_tilt}");
            }
            if !(clearance.is_finite() && clearance >= 0.0) {
                bail!("--clearance must be a distance in metres, 0 or more, not {clearance}");
            }
            let scene = Scene::load(&scene)?;
            let (lo, hi) = scene.bounds().context("the scene is empty")?;
            let (z_low, z_high) = z.unwrap_or((lo.z, hi.z));
            let spec = RandomPoses {
                count,
                seed,
                low: dvec3(lo.x, lo.y, z_low),
                high: dvec3(hi.x, hi.y, z_high),
                max_tilt: max_tilt.to_radians(),
                clearance,
            };
            let poses = pose_sets::random(&scene, &SceneBvh::build(&scene)?, &spec).with_context(|| {
                format!("could not find {count} positions {clearance} m clear of every surface; lower --clearance, widen --z or ask for fewer")
            })?;
            write(&poses, "random", &out)
        }
    }
}
