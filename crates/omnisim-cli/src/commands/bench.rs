//! `omnisim bench`: rays per second, BVH build time, peak memory and tests per ray, one JSON
//! object per backend.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::bail;
use clap::{Args, ValueEnum};
use glam::dvec3;
use omnisim::advanced::GpuStages;
use omnisim::scene::{Face, SceneObject};
use omnisim::{BackendChoice, Planes, Pose, Renderer, Scene};
use serde_json::json;

use super::render::TracerArg;
use crate::camera_args::CameraArgs;
use crate::poses::parse_pose;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum BenchBackend {
    Gpu,
    Cpu,
    /// The GPU (if an adapter opens, software ones included) and then the CPU.
    Both,
}

/// Shortest warm-up of a timed backend (unless `--warmup 0`).
const WARM_UP_TIME: std::time::Duration = std::time::Duration::from_millis(500);

/// Measure tracing speed: median time per image over --runs after --warmup renders.
///
/// Prints one JSON object per backend on stdout: Mrays/s (primary rays, one per pixel, from
/// the median), median/min/max ms per image, BVH build ms, the built BVH's heap bytes
/// (`bvh_bytes`), triangle count, backend, adapter, the process's peak resident memory and,
/// for the CPU, box and triangle tests per ray
/// (counted in one extra, untimed pass; the fast tracer's triangle tests are f32 lanes, and
/// its f64 tests are counted apart). For the GPU, `gpu_stages_ms` and `reshade_gpu_stages_ms`
/// split the medians: host submit, wait for the GPU (passes and copies), host readback into
/// the frame, and each pass's GPU time where the adapter has timestamp queries.
#[derive(Debug, Clone, Args)]
#[command(after_help = "Examples:\n  \
omnisim bench scenes/env1.ron --camera equirect --size 1024x1024 --backend both\n  \
omnisim bench room --camera equirect --size 1024x1024 --pose 3,2,1.5 --backend cpu\n  \
omnisim bench scenes/env1.ron --camera equirect --size 1024x1024 --synthetic-triangles 200000")]
pub(crate) struct BenchArgs {
    /// Scene file (RON), or the name of a scene: `env1`, `env2` (in ./scenes) or an anchor
    /// scene of the repository's bench/compare.sh (room, clutter; it writes them to
    /// $BENCH_CACHE, default ~/.cache/omnisim-bench).
    #[arg(default_value = "scenes/env1.ron")]
    pub scene: PathBuf,
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Viewpoint and rotation x,y,z,θx,θy,θz (metres, degrees).
    #[arg(long, value_parser = parse_pose, default_value = "0,0,0.4,0,0,0", allow_hyphen_values = true)]
    pub pose: Pose,
    #[arg(long, value_enum, default_value = "both")]
    pub backend: BenchBackend,
    /// Which tracer the CPU backend uses.
    #[arg(long, value_enum, default_value = "fast")]
    pub tracer: TracerArg,
    /// Timed renders per backend (the median is reported), 1 to 100000.
    #[arg(long, default_value_t = 7, value_parser = |text: &str| count_in(text, 1, MOST_RUNS))]
    pub runs: usize,
    /// Untimed renders first (shader compilation, caches, ray tables), and for at least half
    /// a second unless 0: on a shared machine the first tens of milliseconds of a small
    /// image's renders ran up to 2× slower than the rest. 0 to 100000.
    #[arg(long, default_value_t = 2, value_parser = |text: &str| count_in(text, 0, MOST_RUNS))]
    pub warmup: usize,
    /// Instead of rays per second, measure time per image against error for every method
    /// (CPU f64, GPU f32, 1/4/16 samples on edges, the paper's shortcut) and draw the chart
    /// to this SVG file; one JSON object per method on stdout.
    #[arg(long)]
    pub chart: Option<PathBuf>,
    /// With --chart: draw it from the lines an earlier --chart run printed (as
    /// docs/speed-accuracy.jsonl holds them) instead of measuring; scene and camera name it.
    #[arg(long, requires = "chart")]
    pub chart_from: Option<PathBuf>,
    /// Time tracing to hit planes only (face, range, point, normal), without shading: what
    /// Open3D's `RaycastingScene.cast_rays` computes, for side-by-side figures.
    #[arg(long)]
    pub hits_only: bool,
    /// Add a wavy height-field mesh of about this many triangles over the floor, to measure a
    /// heavy scene (at most 50 million, the mesh limit).
    #[arg(long, value_parser = |text: &str| count_in(text, 1, MOST_SYNTHETIC_TRIANGLES))]
    pub synthetic_triangles: Option<usize>,
}

pub(crate) fn run(args: &BenchArgs) -> anyhow::Result<()> {
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let camera = args.camera.build()?.first_camera();
    let mut scene = Scene::load(resolve_scene(&args.scene)?)?;
    if let Some(count) = args.synthetic_triangles {
        add_height_field(&mut scene, count)?;
    }
    if let Some(chart) = &args.chart {
        super::prepare_file(chart)?;
        return match &args.chart_from {
            Some(records) => super::speed_accuracy::redraw(&scene, &camera, records, chart),
            None => super::speed_accuracy::run(&scene, &camera, &args.pose, args.runs, chart),
        };
    }
    let choices = match args.backend {
        BenchBackend::Gpu => vec![BackendChoice::Gpu],
        BenchBackend::Cpu => vec![BackendChoice::Cpu],
        BenchBackend::Both => vec![BackendChoice::Gpu, BackendChoice::Cpu],
    };
    let (width, height) = camera.size();
    for choice in choices {
        let opened = Renderer::new(choice).and_then(|mut renderer| {
            renderer.set_cpu_tracer(args.tracer.into());
            if let Some(gpu) = renderer.gpu_renderer() {
                gpu.time_passes(true);
            }
            let prepared = renderer.prepare(&scene)?;
            Ok((renderer, prepared))
        });
        let (renderer, prepared) = match opened {
            Err(e) if args.backend == BenchBackend::Both => {
                crate::streams::stderr(format_args!("note: no GPU measured: {e}"))?;
                continue;
            }
            opened => opened?,
        };
        let planes = if args.hits_only { Planes::HITS } else { Planes::COLOUR };
        let render = || renderer.render(&prepared, &camera, &args.pose, planes);
        let warming = Instant::now();
        let mut warmed = 0;
        while warmed < args.warmup || (args.warmup > 0 && warming.elapsed() < WARM_UP_TIME) {
            render()?;
            warmed += 1;
        }
        let mut times = Vec::with_capacity(args.runs);
        let mut reshade_times = Vec::with_capacity(args.runs);
        let mut render_stages = Vec::with_capacity(args.runs);
        let mut reshade_stages = Vec::with_capacity(args.runs);
        let mut hits = 0;
        for _ in 0..args.runs {
            let start = Instant::now();
            let mut frame = render()?;
            times.push(start.elapsed().as_secs_f64());
            render_stages.extend(renderer.gpu_stages());
            hits = frame.hit_count();
            let start = Instant::now();
            renderer.reshade(&prepared, &camera, &args.pose, &mut frame, Planes::COLOUR)?;
            reshade_times.push(start.elapsed().as_secs_f64());
            reshade_stages.extend(renderer.gpu_stages());
        }
        let median_seconds = median(&mut times);
        let rays = f64::from(width) * f64::from(height);
        let tests = (choice == BackendChoice::Cpu).then(|| {
            let counts = renderer
                .cpu_tracer()
                .count_tests(prepared.geometry(), &camera, &args.pose);
            let per_ray = |count: u64| count as f64 / rays;
            (
                per_ray(counts.node_tests),
                per_ray(counts.primitive_tests),
                per_ray(counts.exact_tests),
            )
        });
        let lights_on = scene.lighting.as_ref().map_or(0, |l| l.lights_on().count());
        let record = json!({
            "scene": scene.name,
            "triangles": prepared.geometry().triangles().len(),
            "bvh_build_ms": prepared.geometry().build_time().as_secs_f64() * 1e3,
            "bvh_bytes": prepared.geometry().heap_bytes(),
            "lit": scene.lighting.is_some(),
            "lights_on": lights_on,
            "reshade_median_ms": median(&mut reshade_times) * 1e3,
            "planes": if args.hits_only { "hits" } else { "colour" },
            "camera": camera.model_name(),
            "width": width,
            "height": height,
            "hit_pixels": hits,
            "backend": renderer.backend_name(),
            "device": renderer.device_name(),
            // The CPU backend's pool (RAYON_NUM_THREADS where set), not the machine's cores.
            "threads": rayon::current_num_threads(),
            "warmup": warmed,
            "runs": args.runs,
            "median_ms": median_seconds * 1e3,
            "min_ms": times[0] * 1e3,
            "max_ms": times[times.len() - 1] * 1e3,
            "mrays_per_s": rays / median_seconds / 1e6,
            "tracer": (choice == BackendChoice::Cpu).then_some(match args.tracer {
                TracerArg::Fast => "fast",
                TracerArg::FastPortable => "fast-portable",
                TracerArg::Reference => "reference",
            }),
            "node_tests_per_ray": tests.map(|t| t.0),
            "triangle_tests_per_ray": tests.map(|t| t.1),
            "f64_triangle_tests_per_ray": tests.map(|t| t.2),
            "peak_rss_mb": peak_rss_bytes().map(|b| b as f64 / 1e6),
            "gpu_stages_ms": stage_medians(&render_stages),
            "reshade_gpu_stages_ms": stage_medians(&reshade_stages),
        });
        crate::streams::stdout(record)?;
    }
    Ok(())
}

/// Each GPU stage's median over the timed frames, ms (null for the CPU backend; a pass time
/// null where the adapter has no timestamp queries or the pass did not run).
fn stage_medians(stages: &[GpuStages]) -> serde_json::Value {
    let Some(first) = stages.first() else {
        return serde_json::Value::Null;
    };
    let median_ms = |stage: fn(&GpuStages) -> Option<Duration>| {
        let mut times: Vec<f64> = stages.iter().filter_map(stage).map(|t| t.as_secs_f64()).collect();
        (times.len() == stages.len()).then(|| median(&mut times) * 1e3)
    };
    json!({
        "bands": first.bands,
        "submit": median_ms(|s| Some(s.submit)),
        "wait": median_ms(|s| Some(s.wait)),
        "readback": median_ms(|s| Some(s.readback)),
        "trace_pass": median_ms(|s| s.trace_pass),
        "shade_pass": median_ms(|s| s.shade_pass),
    })
}

/// Median of `times` (sorted in place).
fn median(times: &mut [f64]) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// The scene file `scene` names: itself if it is a file, else a scene name looked up in
/// ./scenes and in the anchor cache of bench/compare.sh.
fn resolve_scene(scene: &Path) -> anyhow::Result<PathBuf> {
    let is_name = scene.components().count() == 1 && scene.extension().is_none();
    if scene.is_file() || !is_name {
        return Ok(scene.to_path_buf());
    }
    // Empty counts as unset, as in bench/*.sh's `${BENCH_CACHE:-…}`.
    let cache = (std::env::var_os("BENCH_CACHE").filter(|cache| !cache.is_empty()))
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|home| Path::new(&home).join(".cache/omnisim-bench")));
    let file = scene.with_extension("ron");
    let candidates: Vec<PathBuf> = [Some(PathBuf::from("scenes")), cache]
        .into_iter()
        .flatten()
        .map(|folder| folder.join(&file))
        .collect();
    match candidates.iter().find(|path| path.is_file()) {
        Some(path) => Ok(path.clone()),
        None => bail!(
            "no scene file {} and no scene named {} in {} (bench/compare.sh in omnisim's repository writes the anchor scenes room and clutter)",
            scene.display(),
            scene.display(),
            candidates
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// This process's peak resident memory (Linux: `VmHWM`); `None` where the system does not say.
fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|line| line.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// A wavy height field of ~`count` triangles, 10 cm above the scene's floor, over the middle
/// 60 % of its footprint; each triangle is its own face with a colour that varies across it.
/// Most timed or warm-up renders: far beyond any median worth taking, and their times fit.
const MOST_RUNS: usize = 100_000;
/// Most synthetic triangles: a mesh file's limit.
const MOST_SYNTHETIC_TRIANGLES: usize = 50_000_000;

/// A whole number from `low` to `high`, for counts that size allocations.
fn count_in(text: &str, low: usize, high: usize) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if (low..=high).contains(&n) => Ok(n),
        _ => Err(format!("'{text}' is not a whole number from {low} to {high}")),
    }
}

fn add_height_field(scene: &mut Scene, count: usize) -> anyhow::Result<()> {
    let Some((lo, hi)) = scene.bounds() else {
        bail!("the scene is empty")
    };
    if count < 2 {
        bail!("--synthetic-triangles must be at least 2");
    }
    let cells = ((count as f64 / 2.0).sqrt().ceil() as usize).max(1);
    let centre = (lo + hi) / 2.0;
    let half = (hi - lo) * 0.3;
    let object = scene.objects.len() as u32;
    scene.objects.push(SceneObject {
        name: "synthetic height field".into(),
        kind: "Mesh",
    });
    let point = |i: usize, j: usize| {
        let (s, t) = (i as f64 / cells as f64, j as f64 / cells as f64);
        let x = centre.x - half.x + 2.0 * half.x * s;
        let y = centre.y - half.y + 2.0 * half.y * t;
        let z = lo.z + 0.1 + 0.05 * ((s * 40.0).sin() * (t * 33.0).cos() + 1.0);
        dvec3(x, y, z)
    };
    for i in 0..cells {
        for j in 0..cells {
            let colour = [(40 + i * 200 / cells) as u8, (40 + j * 200 / cells) as u8, 120];
            let (a, b, c, d) = (point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1));
            for vertices in [[a, b, c], [a, c, d]] {
                scene.faces.push(Face {
                    vertices: vertices.into(),
                    colour,
                    object,
                });
            }
        }
    }
    Ok(())
}
