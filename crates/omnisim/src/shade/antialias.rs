//! Edge supersampling: pixels a face outline crosses (`coverage.rs` picks them) are traced again at n×n stratified
//! sub-pixel positions (a CPU tracer), each sample shaded by the shading stage, and given
//! the mean. The 8-bit colour is the mean of the samples' 8-bit colours (a box filter on what
//! a viewer sees, as before lights existed); the linear plane is the mean in linear light.
//! Range, face id, normal and hit point stay those of the pixel centre, so the geometric
//! outputs remain exact per pixel.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::accel::SceneBvh;
use crate::camera::Camera;
use crate::frame::{BACKGROUND, Frame};
use crate::pose::Pose;
use crate::shade::{self, Appearance};
use crate::trace::{self, CpuTracer};

/// Pixels whose face id differs from one of their 4-neighbours.
pub fn edge_pixels(frame: &Frame) -> Vec<usize> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let face = |x: usize, y: usize| frame.pixels()[y * w + x].face;
    (0..w * h)
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            let here = face(x, y);
            (x > 0 && face(x - 1, y) != here)
                || (x + 1 < w && face(x + 1, y) != here)
                || (y > 0 && face(x, y - 1) != here)
                || (y + 1 < h && face(x, y + 1) != here)
        })
        .collect()
}

/// Sub-pixel offsets of n×n stratified samples, row by row.
pub(crate) fn sample_offsets(samples_per_axis: u32) -> impl Iterator<Item = DVec2> {
    let n = f64::from(samples_per_axis);
    (0..samples_per_axis).flat_map(move |sy| {
        (0..samples_per_axis)
            .map(move |sx| DVec2::new((f64::from(sx) + 0.5) / n - 0.5, (f64::from(sy) + 0.5) / n - 0.5))
    })
}

/// Replaces the shaded planes of the pixels `edges` by the mean of `samples_per_axis²`
/// stratified samples. Returns how many pixels were refined.
#[allow(clippy::too_many_arguments)]
pub(crate) fn supersample_edges(
    tracer: CpuTracer,
    bvh: &SceneBvh,
    appearance: &Appearance,
    camera: &Camera,
    pose: &Pose,
    frame: &mut Frame,
    samples_per_axis: u32,
    edges: &[usize],
) -> usize {
    if samples_per_axis <= 1 {
        return 0;
    }
    let width = frame.width as usize;
    let local = trace::LocalPose::new(bvh, pose);
    // Sub-pixel samples: footprints from the camera's own rays, not a table of pixel centres.
    let view = shade::View::new(camera, pose, None, None);
    let count = samples_per_axis * samples_per_axis;
    let refined: Vec<([u8; 3], [f32; 3])> = edges
        .par_iter()
        .map(|&i| {
            let centre = DVec2::new((i % width) as f64, (i / width) as f64);
            let mut encoded = [0u32; 3];
            let mut linear = DVec3::ZERO;
            for offset in sample_offsets(samples_per_axis) {
                let hit = tracer.trace_pixel(bvh, camera, &local, centre + offset);
                let footprint = if appearance.needs_footprint(hit.face) {
                    view.footprint_at(centre + offset)
                } else {
                    shade::Footprint::POINT
                };
                let sample = shade::shade(tracer, bvh, appearance, &hit, &footprint);
                let colour = if hit.is_hit() {
                    shade::encode(sample)
                } else {
                    BACKGROUND
                };
                for k in 0..3 {
                    encoded[k] += u32::from(colour[k]);
                }
                linear += sample;
            }
            (
                encoded.map(|s| ((s + count / 2) / count) as u8),
                (linear / f64::from(count)).as_vec3().to_array(),
            )
        })
        .collect();
    let (colour, linear) = frame.shading_mut();
    if let Some(colour) = colour {
        for (&i, (c, _)) in edges.iter().zip(&refined) {
            colour[i] = *c;
        }
    }
    if let Some(linear) = linear {
        for (&i, (_, l)) in edges.iter().zip(&refined) {
            linear[i] = *l;
        }
    }
    edges.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Pinhole;
    use crate::scene::Scene;
    use glam::{DVec3, dvec3};
    use std::path::Path;

    /// A pinhole facing two coloured half-planes whose border crosses a pixel at its centre.
    fn half_and_half() -> (Scene, SceneBvh, Camera, Pose) {
        let scene = Scene::from_ron(
            r#"Scene(name: "halves", objects: [
                Polygon(name: "left", vertices: [(2.0, 0.0, -1.0), (2.0, 1.0, -1.0), (2.0, 1.0, 1.0), (2.0, 0.0, 1.0)], colour: (200, 0, 0)),
                Polygon(name: "right", vertices: [(2.0, -1.0, -1.0), (2.0, 0.0, -1.0), (2.0, 0.0, 1.0), (2.0, -1.0, 1.0)], colour: (0, 0, 100)),
            ])"#,
            Path::new("halves.ron"),
        )
        .unwrap();
        // Odd width: the middle column's centre looks exactly along the border y = 0.
        let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(9, 9, 0.2));
        (
            scene.clone(),
            SceneBvh::build(&scene).unwrap(),
            camera,
            Pose::new(DVec3::ZERO, dvec3(0.0, 0.0, 0.0)),
        )
    }

    #[test]
    fn border_pixels_get_the_mean_of_both_faces() {
        let (scene, bvh, camera, pose) = half_and_half();
        let appearance = Appearance::of(&scene);
        let mut frame = trace::trace(&bvh, &camera, &pose);
        let tracer = CpuTracer::Reference;
        let view = crate::shade::View::new(&camera, &pose, None, None);
        crate::shade::shade_frame(
            tracer,
            &bvh,
            &appearance,
            view,
            &mut frame,
            crate::frame::Planes::COLOUR,
        );
        let edges = edge_pixels(&frame);
        assert!(!edges.is_empty() && edges.iter().all(|&i| (3..=5).contains(&(i % 9))));
        let refined = supersample_edges(tracer, &bvh, &appearance, &camera, &pose, &mut frame, 4, &edges);
        assert_eq!(refined, edges.len());
        let colour = |u, v| frame.colour().unwrap()[frame.index(u, v)];
        // The middle column is half red, half blue: 16 samples split 8/8.
        assert_eq!(colour(4, 4), [100, 0, 50]);
        // Columns left and right of it lie wholly on one face and keep its colour.
        assert_eq!(colour(3, 4), [200, 0, 0]);
        assert_eq!(colour(5, 4), [0, 0, 100]);
    }
}
