//! Resampled views of catadioptric images: a 3-D point lands where each view's own model puts
//! it, and the resampled views match the same views traced exactly by omnisim.

use std::path::PathBuf;

use glam::dvec3;
use omnisim::camera::Catadioptric;
use omnisim::{BackendChoice, Camera, Planes, Pose, Renderer, Scene};
use omnisim_vision::accuracy::{chart_pose, chart_views, colour_error, point_displacements, sample_points};
use omnisim_vision::{Interpolation, Raster, Remap, View};

/// The resampling-error chart's figures at 500² omni pixels (docs/vision.md), per chart view
/// and (bilinear, bicubic): (mean colour error 0–255, mean point displacement in view pixels).
const CHART_500: [[(f64, f64); 2]; 3] = [
    [(0.36, 0.055), (0.43, 0.050)],
    [(0.43, 0.082), (0.50, 0.080)],
    [(0.45, 0.188), (0.50, 0.183)],
];

fn mirrors(size: u32) -> Vec<(&'static str, Catadioptric)> {
    vec![
        (
            "hyperbolic",
            Catadioptric::hyperbolic(size, size, 0.04, 0.16, Some(20f64.to_radians())),
        ),
        (
            "parabolic",
            Catadioptric::parabolic(size, size, 0.04, 0.02, 20f64.to_radians()),
        ),
    ]
}

fn views() -> Vec<(&'static str, View)> {
    vec![
        (
            "panorama",
            View::panorama(1024, 256, (-45f64).to_radians(), 15f64.to_radians()).unwrap(),
        ),
        ("equirectangular", View::equirectangular(1024, 512)),
        (
            "perspective",
            View::perspective(400, 300, 90f64.to_radians(), 2.2, (-25f64).to_radians()).unwrap(),
        ),
        ("birds-eye", View::birds_eye(400, 400, 0.01, -0.7).unwrap()),
    ]
}

/// A spot painted where the omni camera sees a point is found, after resampling, where the
/// view's own model projects that point: the whole chain (view rays, mirror projection, pixel
/// centre conventions, interpolation weights) within 0.5 px.
#[test]
fn points_land_where_each_view_puts_them() {
    let mut worst: f64 = 0.0;
    for (mirror_name, omni) in mirrors(600) {
        for (view_name, view) in views() {
            let remap = Remap::new(&omni, &view).unwrap();
            for interpolation in [Interpolation::Bilinear, Interpolation::Bicubic] {
                let moved = point_displacements(&omni, &view, &remap, &sample_points(&view), interpolation);
                assert!(
                    moved.len() >= 4,
                    "{mirror_name} {view_name}: only {} points inside the view",
                    moved.len()
                );
                let largest = moved.iter().copied().fold(0.0, f64::max);
                worst = worst.max(largest);
                assert!(
                    largest < 0.5,
                    "{mirror_name} {view_name} {interpolation:?}: a point moved {largest:.3} px"
                );
            }
        }
    }
    eprintln!("largest spot displacement: {worst:.3} px");
}

fn scene() -> Scene {
    Scene::load(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/env1.ron")).unwrap()
}

/// Resampled views against the same views traced exactly from the same viewpoint (the
/// bird's-eye view as a pinhole looking straight down, `View::exact_camera`), 800² omni
/// images of both mirrors. Measured (docs/vision.md): 0.21–0.27 / 255 bilinear, 0.26–0.31
/// bicubic, all at face edges; the resampled panorama shifted by one column is 0.71 off, so
/// the bounds catch a one-column error.
#[test]
fn resampled_views_match_exact_renders() {
    let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
    let prepared = renderer.prepare(&scene()).unwrap();
    let omni_pose = Pose::from_degrees(dvec3(0.5, 0.2, 0.4), dvec3(0.0, 0.0, 30.0));
    for (mirror_name, omni) in mirrors(800) {
        let frame = renderer
            .render(
                &prepared,
                &Camera::Catadioptric(omni.clone()),
                &omni_pose,
                Planes::COLOUR,
            )
            .unwrap();
        let omni_image = Raster::from_rgb8(800, 800, frame.colour().unwrap()).unwrap();
        for (view_name, view) in views() {
            let (camera, view_pose) = view.exact_render(&omni_pose).unwrap();
            let exact = renderer.render(&prepared, &camera, &view_pose, Planes::COLOUR).unwrap();
            let remap = Remap::new(&omni, &view).unwrap();
            for (interpolation, bound) in [(Interpolation::Bilinear, 0.4), (Interpolation::Bicubic, 0.45)] {
                let error = colour_error(
                    &remap.apply(&omni_image, interpolation).unwrap(),
                    exact.colour().unwrap(),
                    &remap,
                )
                .expect("pixels in both views");
                eprintln!(
                    "{mirror_name} {view_name} {interpolation:?}: mean |Δ| {:.3} / 255 over {} px",
                    error.mean, error.pixels
                );
                assert!(
                    error.pixels > 10_000,
                    "{mirror_name} {view_name}: only {} pixels compared",
                    error.pixels
                );
                assert!(
                    error.mean < bound,
                    "{mirror_name} {view_name} {interpolation:?}: mean |Δ| {:.3}",
                    error.mean
                );
            }
        }
    }
}

/// The resampling-error chart's figures at 500² (docs/images/resampling-error.svg, made by
/// `examples/resampling_error.rs`): colour error within 25 % of the documented value over at
/// least 90 % of the view's pixels (all of them, measured) and the mean point displacement
/// within 0.05 px of it, for each view and interpolation.
#[test]
fn resampled_views_stay_within_the_chart() {
    // (view, interpolation) → (mean colour error 0–255, mean displacement px) at 500².
    let documented: [[(f64, f64); 2]; 3] = CHART_500;
    let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
    let prepared = renderer.prepare(&scene()).unwrap();
    let pose = chart_pose();
    let omni = Catadioptric::hyperbolic(500, 500, 0.04, 0.16, Some(20f64.to_radians()));
    let frame = renderer
        .render(&prepared, &Camera::Catadioptric(omni.clone()), &pose, Planes::COLOUR)
        .unwrap();
    let omni_image = Raster::from_rgb8(500, 500, frame.colour().unwrap()).unwrap();
    for ((view_name, view), figures) in chart_views().into_iter().zip(documented) {
        let (camera, view_pose) = view.exact_render(&pose).unwrap();
        let exact = renderer.render(&prepared, &camera, &view_pose, Planes::COLOUR).unwrap();
        let remap = Remap::new(&omni, &view).unwrap();
        for (interpolation, (colour, moved)) in [Interpolation::Bilinear, Interpolation::Bicubic]
            .into_iter()
            .zip(figures)
        {
            let error = colour_error(
                &remap.apply(&omni_image, interpolation).unwrap(),
                exact.colour().unwrap(),
                &remap,
            )
            .expect("pixels in both views");
            let displacements = point_displacements(&omni, &view, &remap, &sample_points(&view), interpolation);
            let mean = displacements.iter().sum::<f64>() / displacements.len() as f64;
            eprintln!(
                "{view_name} {interpolation:?}: colour {:.3} over {} of {} px (chart {colour}), displacement {mean:.4} px (chart {moved})",
                error.mean,
                error.pixels,
                remap.width * remap.height
            );
            assert!(displacements.len() >= 10, "{view_name}: {} points", displacements.len());
            // Every pixel of these views is seen by both (measured): an error over a few
            // pixels would say nothing about the chart.
            let compared = error.pixels as f64 / (remap.width * remap.height) as f64;
            assert!(
                compared >= 0.9,
                "{view_name}: only {:.1} % of the view compared",
                100.0 * compared
            );
            assert!(
                error.mean < 1.25 * colour,
                "{view_name} {interpolation:?}: colour error {:.3}, chart {colour}",
                error.mean
            );
            assert!(
                mean < moved + 0.05,
                "{view_name} {interpolation:?}: points moved {mean:.4} px, chart {moved}"
            );
        }
    }
}
