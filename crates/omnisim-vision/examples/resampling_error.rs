//! The resampling-error chart of docs/vision.md and README (docs/images/resampling-error.svg):
//! colour error against exact renders and geometric error of point features, for the
//! panorama, perspective and bird's-eye views resampled from omni images of 250² to 2000²
//! pixels, bilinear and bicubic.
//!
//! cargo run --release -p omnisim-vision --example `resampling_error` -- docs/images/resampling-error.svg

use std::path::PathBuf;

use omnisim::camera::Catadioptric;
use omnisim::{BackendChoice, Camera, Planes, Pose, Renderer, Scene};
use omnisim_vision::accuracy::{chart_pose, chart_views, colour_error, point_displacements, sample_points};
use omnisim_vision::chart::{Marker, Series, lines, stack};
use omnisim_vision::{Interpolation, Raster, Remap};

const SIZES: [u32; 4] = [250, 500, 1000, 2000];

fn main() {
    let out = std::env::args().nth(1).map(PathBuf::from);
    let scene = Scene::load(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/env1.ron")).unwrap();
    let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
    let prepared = renderer.prepare(&scene).unwrap();
    let pose = chart_pose();
    let render = |camera: &Camera, pose: &Pose| {
        let frame = renderer.render(&prepared, camera, pose, Planes::COLOUR).unwrap();
        frame.colour().unwrap().to_vec()
    };
    let views = chart_views();
    // The exact render of each view: its camera at the viewpoint, turned as the view is.
    let exact: Vec<Vec<[u8; 3]>> = views
        .iter()
        .map(|(_, view)| {
            let (camera, view_pose) = view.exact_render(&pose).unwrap();
            render(&camera, &view_pose)
        })
        .collect();
    let interpolations = [Interpolation::Bilinear, Interpolation::Bicubic];
    // (view, interpolation) → per size: (mean colour error, mean and largest displacement).
    let mut colour = vec![vec![Vec::new(); interpolations.len()]; views.len()];
    let mut geometry = vec![vec![Vec::new(); interpolations.len()]; views.len()];
    println!(
        "| omni image | view | interpolation | mean abs colour error (0–255) | pixels > 32 off | point displacement mean / max (px) |"
    );
    println!("|---|---|---|---|---|---|");
    for size in SIZES {
        let omni = Catadioptric::hyperbolic(size, size, 0.04, 0.16, Some(20f64.to_radians()));
        let image = Raster::from_rgb8(
            size as usize,
            size as usize,
            &render(&Camera::Catadioptric(omni.clone()), &pose),
        )
        .unwrap();
        for (v, (name, view)) in views.iter().enumerate() {
            let remap = Remap::new(&omni, view).unwrap();
            let points = sample_points(view);
            for (i, &interpolation) in interpolations.iter().enumerate() {
                let error = colour_error(&remap.apply(&image, interpolation).unwrap(), &exact[v], &remap)
                    .expect("the resampled and exact views share pixels");
                let moved = point_displacements(&omni, view, &remap, &points, interpolation);
                let mean = moved.iter().sum::<f64>() / moved.len() as f64;
                let max = moved.iter().copied().fold(0.0, f64::max);
                println!(
                    "| {size}² | {name} | {interpolation:?} | {:.2} | {:.2} % | {mean:.3} / {max:.3} ({} points) |",
                    error.mean,
                    100.0 * error.far,
                    moved.len()
                );
                colour[v][i].push((f64::from(size), error.mean));
                geometry[v][i].push((f64::from(size), mean));
            }
        }
    }
    let Some(out) = out else { return };
    // A colour per view; bilinear solid with discs, bicubic dashed with rings, in the legend too.
    let series = |values: &[Vec<Vec<(f64, f64)>>]| -> Vec<Series> {
        let colours = ["#1f77b4", "#d62728", "#2ca02c"];
        let mut all = Vec::new();
        for (v, (name, _)) in views.iter().enumerate() {
            for (i, interpolation) in interpolations.iter().enumerate() {
                let (dash, marker) = if i == 0 {
                    (String::new(), Marker::Disc)
                } else {
                    ("6 4".to_string(), Marker::Ring)
                };
                all.push(Series {
                    label: format!("{name}, {interpolation:?}").to_lowercase(),
                    colour: colours[v].to_string(),
                    dash,
                    marker,
                    points: values[v][i].clone(),
                });
            }
        }
        all
    };
    let svg = stack(&[
        lines(
            "Resampled views against exact renders (env1, hyperbolic mirror)",
            "omni image side (px)",
            "mean |colour error| (0–255)",
            &series(&colour),
            1e-3,
        ),
        lines(
            "Point features: resampled position against the view's model",
            "omni image side (px)",
            "mean displacement (view px)",
            &series(&geometry),
            1e-4,
        ),
    ]);
    std::fs::write(&out, svg).unwrap();
    eprintln!("wrote {}", out.display());
}
