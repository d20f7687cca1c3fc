//! `omnisim bench --chart`: time per image against error, for every method and option, each
//! measured against an f64 ground truth with 64 samples per pixel on face edges; or, with
//! `--chart-from`, the chart of such measurements made before.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use glam::dvec3;
use omnisim::advanced::CpuTracer;
use omnisim::atomic_file::write_atomically;
use omnisim::camera::MirrorRays;
use omnisim::{BackendChoice, Camera, Frame, Planes, Pose, PreparedScene, Renderer, Scene};
use serde::{Deserialize, Serialize};

use omnisim_vision::chart::{Point, scatter};

/// One method measured: a line of `bench --chart`'s standard output (docs/speed-accuracy.jsonl
/// holds such lines). Fields in the order the lines have always had.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Record {
    /// What traced it: `Renderer::device_name`.
    device: String,
    /// Mean absolute colour difference per channel (0–255) from the ground truth.
    mean_abs_colour_error: f64,
    /// Median time per image, milliseconds.
    median_ms: f64,
    /// The method and its samples: "CPU f64, 4 samples on edges".
    method: String,
    /// Share of pixels whose colour differs from the ground truth.
    pixels_differing: f64,
}

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
    let mut records = Vec::new();
    let mut record = |method: String, seconds: f64, frame: &Frame, truth: &Frame, device: String| {
        let (error, differing) = colour_error(frame, truth);
        let record = Record {
            device,
            mean_abs_colour_error: error,
            median_ms: seconds * 1e3,
            method,
            pixels_differing: differing,
        };
        crate::streams::stdout(serde_json::to_string(&record)?)?;
        records.push(record);
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
    write_chart(scene, camera, &records, chart)
}

/// `bench --chart-from`: the chart of the lines `path` holds, measured before, without measuring.
pub(crate) fn redraw(scene: &Scene, camera: &Camera, path: &Path, chart: &Path) -> anyhow::Result<()> {
    let text = omnisim::input::read_text(path, omnisim::input::POSE_FILE_LIMIT)?;
    let records = text
        .lines()
        .enumerate()
        .filter(|(_, line)| !line.trim().is_empty())
        .map(|(i, line)| {
            serde_json::from_str(line)
                .with_context(|| format!("{}:{}: not a line of bench --chart's output", path.display(), i + 1))
        })
        .collect::<anyhow::Result<Vec<Record>>>()?;
    if records.is_empty() {
        anyhow::bail!("{} holds no measurement", path.display());
    }
    write_chart(scene, camera, &records, chart)
}

fn write_chart(scene: &Scene, camera: &Camera, records: &[Record], chart: &Path) -> anyhow::Result<()> {
    let (w, h) = camera.size();
    let subject = format!("{} {w}x{h}, scene {}", camera.model_name(), scene.name);
    let svg = draw(&subject, records);
    write_atomically(chart, |out| std::io::Write::write_all(out, svg.as_bytes()))
        .with_context(|| format!("cannot write {}", chart.display()))?;
    crate::streams::stderr(format_args!("wrote {}", chart.display()))?;
    Ok(())
}

/// Colours of the methods, in order of first appearance (matplotlib's first ten).
const PALETTE: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
];

/// Whether `device` (as `Renderer::device_name` says it) is a software adapter, llvmpipe or
/// lavapipe: wgpu's device type `Cpu`, written last.
fn is_software_adapter(device: &str) -> bool {
    device.ends_with(", Cpu)")
}

/// The chart of `records`: each method (its name without the sample count) in its own colour.
/// Times on a software GPU adapter are the CPU's cores emulating a GPU, nothing a GPU would
/// take: the title's second line names the adapter and its points' legend says where they ran.
fn draw(subject: &str, records: &[Record]) -> String {
    let mut methods: Vec<&str> = Vec::new();
    let mut title = format!("{subject}: speed against accuracy");
    let mut points = Vec::new();
    for record in records {
        let method = record
            .method
            .rsplit_once(", ")
            .map_or(record.method.as_str(), |(method, _)| method);
        let index = methods.iter().position(|m| *m == method).unwrap_or_else(|| {
            methods.push(method);
            methods.len() - 1
        });
        let mut label = record.method.clone();
        if is_software_adapter(&record.device) {
            let adapter = record.device.split(" (").next().unwrap_or(&record.device);
            label += &format!(" [{adapter}: software, on the CPU]");
            let note = format!(
                "\nGPU points: {}, a software adapter on the CPU's cores, not a GPU",
                record.device
            );
            if !title.contains(&note) {
                title += &note;
            }
        }
        points.push(Point {
            label,
            x: record.median_ms,
            y: record.mean_abs_colour_error,
            colour: PALETTE[index % PALETTE.len()].to_string(),
        });
    }
    scatter(
        &title,
        "median time per image (ms)",
        "mean |colour error| vs f64, 64 samples on edges (0-255)",
        &points,
        1e-3,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped() -> String {
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/speed-accuracy.jsonl")).unwrap()
    }

    /// The value of attribute `name` in the SVG element `element`.
    fn attribute<'a>(element: &'a str, name: &str) -> &'a str {
        let start = element.find(&format!(" {name}=\"")).unwrap() + name.len() + 3;
        &element[start..start + element[start..].find('"').unwrap()]
    }

    /// `--chart-from` reads what `--chart` prints: the shipped lines read back and print unchanged.
    #[test]
    fn records_read_back_and_print_as_the_shipped_lines() {
        for line in shipped().lines() {
            let record: Record = serde_json::from_str(line).unwrap();
            assert_eq!(serde_json::to_string(&record).unwrap(), line);
        }
    }

    /// A `--chart-from` file may say a method took 0 ms or less: such a point has no place on
    /// the log time axis, so it is left off and its legend row says why; the chart is drawn at
    /// once (log10(0) = −∞ made the axis' decades run from `i32::MIN`: a hang, then no memory).
    #[test]
    fn times_of_zero_or_less_are_left_off_the_chart_with_a_reason() {
        let lines = [
            r#"{"device":"d","mean_abs_colour_error":0.5,"median_ms":0,"method":"zero, 1","pixels_differing":0.1}"#,
            r#"{"device":"d","mean_abs_colour_error":0.5,"median_ms":-3,"method":"negative, 1","pixels_differing":0.1}"#,
            r#"{"device":"d","mean_abs_colour_error":0.5,"median_ms":4,"method":"drawn, 1","pixels_differing":0.1}"#,
        ];
        let records: Vec<Record> = lines.iter().map(|l| serde_json::from_str(l).unwrap()).collect();
        let svg = draw("omni 250x250", &records);
        let legend: Vec<&str> = svg.lines().filter(|l| l.contains(r#"class="legend""#)).collect();
        let markers = svg.lines().filter(|l| l.contains(r#"class="marker""#)).count();
        assert_eq!((legend.len(), markers), (3, 1));
        for (row, time) in legend.iter().zip(["0", "-3"]) {
            assert!(
                row.contains(&format!(
                    "(not drawn: its median time per image (ms) is {time}, and a log axis holds only finite values above 0)"
                )),
                "{row}"
            );
        }
        assert!(!legend[2].contains("not drawn"), "{}", legend[2]);
    }

    /// docs/speed-accuracy.svg's GPU points were timed on llvmpipe: the chart says so in its
    /// title and in those points' legend rows. Each method has a colour of its own, the same
    /// for its 1, 4 and 16 samples, and each legend swatch is its marker's colour.
    #[test]
    fn the_shipped_chart_names_its_software_adapter_and_colours_methods_apart() {
        let records: Vec<Record> = shipped().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let svg = draw("omni 250x250", &records);
        let title: Vec<&str> = svg.lines().filter(|l| l.contains(r#"class="title""#)).collect();
        assert_eq!(title.len(), 2, "{title:?}");
        assert!(
            title[1].contains("llvmpipe") && title[1].contains("software"),
            "{}",
            title[1]
        );
        let legend: Vec<&str> = svg.lines().filter(|l| l.contains(r#"class="legend""#)).collect();
        let markers: Vec<&str> = svg.lines().filter(|l| l.contains(r#"class="marker""#)).collect();
        assert_eq!((legend.len(), markers.len()), (records.len(), records.len()));
        let mut colours = std::collections::BTreeMap::new();
        for ((row, marker), record) in legend.iter().zip(&markers).zip(&records) {
            assert_eq!(attribute(row, "fill"), attribute(marker, "fill"), "{row}");
            assert_eq!(
                row.contains("[llvmpipe: software, on the CPU]"),
                record.method.starts_with("GPU")
            );
            let method = record.method.rsplit_once(", ").unwrap().0;
            assert_eq!(
                *colours.entry(method).or_insert(attribute(marker, "fill")),
                attribute(marker, "fill")
            );
        }
        let distinct: std::collections::BTreeSet<_> = colours.values().collect();
        assert_eq!(distinct.len(), 5, "{colours:?}");
    }
}
