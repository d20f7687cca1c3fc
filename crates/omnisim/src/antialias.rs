//! Edge supersampling: pixels where the face changes are traced again at n×n stratified
//! sub-pixel positions (f64 CPU tracer) and given the mean colour. Range, face id and hit point
//! stay those of the pixel centre, so the geometric outputs remain exact per pixel.

use glam::DVec2;
use rayon::prelude::*;

use crate::bvh::SceneBvh;
use crate::camera::Camera;
use crate::cpu;
use crate::frame::{BACKGROUND, Frame};
use crate::pose::Pose;

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

/// Replaces the colour of every edge pixel by the mean of `samples_per_axis²` stratified
/// samples. Returns how many pixels were refined.
pub fn supersample_edges(
    bvh: &SceneBvh,
    camera: &Camera,
    pose: &Pose,
    frame: &mut Frame,
    samples_per_axis: u32,
) -> usize {
    if samples_per_axis <= 1 {
        return 0;
    }
    let edges = edge_pixels(frame);
    let width = frame.width as usize;
    let n = samples_per_axis as usize;
    let local = cpu::LocalPose::new(bvh, pose);
    let colours: Vec<[u8; 3]> = edges
        .par_iter()
        .map(|&i| {
            let centre = DVec2::new((i % width) as f64, (i / width) as f64);
            let mut sum = [0u32; 3];
            for sy in 0..n {
                for sx in 0..n {
                    let offset = DVec2::new((sx as f64 + 0.5) / n as f64 - 0.5, (sy as f64 + 0.5) / n as f64 - 0.5);
                    let colour = cpu::trace_pixel(bvh, camera, &local, centre + offset).map_or(BACKGROUND, |traced| {
                        bvh.face_colours[bvh.face[traced.hit.triangle] as usize]
                    });
                    for k in 0..3 {
                        sum[k] += colour[k] as u32;
                    }
                }
            }
            let count = (n * n) as u32;
            sum.map(|s| ((s + count / 2) / count) as u8)
        })
        .collect();
    for (&i, colour) in edges.iter().zip(colours) {
        frame.pixels_mut()[i].colour = colour;
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
    fn half_and_half() -> (SceneBvh, Camera, Pose) {
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
            SceneBvh::build(&scene),
            camera,
            Pose::new(DVec3::ZERO, dvec3(0.0, 0.0, 0.0)),
        )
    }

    #[test]
    fn border_pixels_get_the_mean_of_both_faces() {
        let (bvh, camera, pose) = half_and_half();
        let mut frame = cpu::render(&bvh, &camera, &pose);
        let edges = edge_pixels(&frame);
        assert!(!edges.is_empty() && edges.iter().all(|&i| (3..=5).contains(&(i % 9))));
        let refined = supersample_edges(&bvh, &camera, &pose, &mut frame, 4);
        assert_eq!(refined, edges.len());
        // The middle column is half red, half blue: 16 samples split 8/8.
        assert_eq!(frame.pixel(4, 4).colour, [100, 0, 50]);
        // Columns left and right of it lie wholly on one face and keep its colour.
        assert_eq!(frame.pixel(3, 4).colour, [200, 0, 0]);
        assert_eq!(frame.pixel(5, 4).colour, [0, 0, 100]);
    }
}
