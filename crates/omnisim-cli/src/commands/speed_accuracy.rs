//! `omnisim bench --chart`: time per image against error, for every method and option, each
//! measured against an f64 ground truth with 64 samples per pixel on face edges.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use glam::dvec3;
use omnisim::advanced::CpuTracer;
use omnisim::camera::MirrorRays;
use omnisim::output::atomic::write_atomically;
use omnisim::{BackendChoice, Camera, Frame, Planes, Pose, PreparedScene, Renderer, Scene};
use serde_json::json;

use omnisim_vision::chart::{Point, scatter};

/// Mean absolute colour difference per channel (0–255) and the share of pixels that differ.
fn colour_error(frame: &Frame, truth: &Frame) -> (f64, f64) {
    let mut sum = 0u64;
    let mut differing = 0usize;
    let colour = |f: &'_ Frame| f.colour().map(<[_]>::to_vec).unwrap_or_default();
    for (a, b) in colour(frame).iter().zip(&colour(truth)) {
        let d: u64 = (0..3).map(|k| u64::from(a[k].abs_diff(b[k]))).sum();
        sum += d;
        differing += usize::from(d > 0);
    }
    let pixels = frame.pixels().len() as f64;
    (sum as f64 / (3.0 * pixels), differing as f64 / pixels)
}

/// Median seconds of `runs` renders after one warm-up, and the last frame.
fn timed(runs: usize, mut render: impl FnMut() -> anyhow::Result<Frame>) -> anyhow::Result<(f64, Frame)> {
    let mut frame = render()?;
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs {
        let start = Instant::now();
        frame = render()?;
        times.push(start.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    Ok((times[times.len() / 2], frame))
}

pub(crate) fn run(scene: &Scene, camera: &Camera, pose: &Pose, runs: usize, chart: &Path) -> anyhow::Result<()> {
    let open = |choice, tracer| -> anyhow::Result<(Renderer, PreparedScene)> {
        let mut renderer = Renderer::new(choice)?;
        renderer.set_cpu_tracer(tracer);
        let prepared = renderer.prepare(scene)?;
        Ok((renderer, prepared))
    };
    let cpu = open(BackendChoice::Cpu, CpuTracer::Reference)?;
    let cpu_fast = open(BackendChoice::Cpu, CpuTracer::Fast)?;
    let gpu = open(BackendChoice::Gpu, CpuTracer::Reference).ok();
    if gpu.is_none() {
        crate::streams::stderr("note: no GPU adapter; the chart has CPU methods only")?;
    }
    let render = |(renderer, prepared): &(Renderer, PreparedScene), camera: &Camera, samples| {
        renderer.render_antialiased(prepared, camera, pose, Planes::COLOUR, samples)
    };
    let truth = render(&cpu, camera, 8)?;
    let mut points = Vec::new();
    let mut record = |label: String, seconds: f64, frame: &Frame, truth: &Frame, device: String| {
        let (error, differing) = colour_error(frame, truth);
        crate::streams::stdout(
            json!({ "method": label, "median_ms": seconds * 1e3, "mean_abs_colour_error": error,
                    "pixels_differing": differing, "device": device }),
        )?;
        points.push(Point {
            label,
            x: seconds * 1e3,
            y: error,
        });
        anyhow::Ok(())
    };
    for (name, renderer) in [
        ("CPU f64", Some(&cpu)),
        ("CPU fast", Some(&cpu_fast)),
        ("GPU f32", gpu.as_ref()),
    ] {
        let Some(renderer) = renderer else { continue };
        for samples in [1u32, 2, 4] {
            let (seconds, frame) = timed(runs, || Ok(render(renderer, camera, samples)?))?;
            let label = match samples {
                1 => format!("{name}, 1 sample/px"),
                n => format!("{name}, {} samples on edges", n * n),
            };
            record(label, seconds, &frame, &truth, renderer.0.device_name())?;
        }
    }
    if let Camera::Catadioptric(mirror) = camera
        && mirror.is_central()
    {
        // The reference paper's shortcut, on the aligned mirror and on a camera 1 mm off the
        // focus (where it is refused by validate(), and measured here to show why).
        let shortcut = Camera::Catadioptric(omnisim::camera::Catadioptric {
            rays: MirrorRays::Shortcut,
            ..mirror.clone()
        });
        let mut off_focus = mirror.clone();
        off_focus.misalignment.offset = dvec3(0.001, 0.0, 0.0);
        let off_truth = render(&cpu, &Camera::Catadioptric(off_focus.clone()), 8)?;
        off_focus.rays = MirrorRays::Shortcut;
        let off_shortcut = Camera::Catadioptric(off_focus);
        for (name, method, reference) in [
            ("shortcut, aligned", &shortcut, &truth),
            ("shortcut, camera 1 mm off focus", &off_shortcut, &off_truth),
        ] {
            for samples in [1u32, 4] {
                let (seconds, frame) = timed(runs, || Ok(render(&cpu, method, samples)?))?;
                let label = match samples {
                    1 => format!("CPU f64 {name}, 1 sample/px"),
                    n => format!("CPU f64 {name}, {} samples on edges", n * n),
                };
                record(label, seconds, &frame, reference, cpu.0.device_name())?;
            }
        }
    }
    let (w, h) = camera.size();
    let svg = scatter(
        &format!(
            "{} {w}x{h}, scene {}: speed against accuracy",
            camera.model_name(),
            scene.name
        ),
        "median time per image (ms)",
        "mean |colour error| vs f64, 64 samples on edges (0-255)",
        &points,
        1e-3,
    );
    write_atomically(chart, |out| std::io::Write::write_all(out, svg.as_bytes()))
        .with_context(|| format!("cannot write {}", chart.display()))?;
    crate::streams::stderr(format_args!("wrote {}", chart.display()))?;
    Ok(())
}
