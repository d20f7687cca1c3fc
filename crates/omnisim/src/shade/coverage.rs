//! Which pixels edge supersampling refines: every pixel a visible face outline crosses, found
//! from coverage rather than from pixel centres.
//!
//! Comparing each pixel's centre face with its 4-neighbours' misses whatever touches no pixel
//! centre: a strip 0.3 px wide between two centres, the corner of a square poking into a
//! pixel. Instead, every face's outline (the boundary edges of its triangles) is projected
//! into the image through the camera's closed-form projection, subdivided until consecutive
//! projected points lie at most [`STEP_PX`] apart, and each pixel a sample falls in is
//! refined, unless the sample lies clearly behind what the pixel's centre sees (a hidden
//! edge). Projected points [`STEP_PX`] apart can only miss a pixel whose corner the outline
//! clips by less than ½·STEP² = 0.03 px². Cameras without a closed-form projection (non-central
//! and misaligned mirrors) fall back to the centre-face test widened by one pixel (the
//! neighbours of every edge pixel are refined too).

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::accel::SceneBvh;
use crate::camera::Camera;
use crate::frame::Frame;
use crate::pose::Pose;
use crate::trace::ray_table::RayTable;

/// Largest distance, pixels, between consecutive projected samples of an outline.
pub(crate) const STEP_PX: f64 = 0.25;

/// Halvings of an outline edge at most (2^20 samples: an edge 260,000 px long at the step).
const MAX_DEPTH: u32 = 20;

/// Halvings of a stretch whose two ends both project nowhere (behind a pinhole, beyond a
/// mirror's rim) in search of a part that does: 64 probes.
const BLIND_DEPTH: u32 = 6;

/// An outline point counts as hidden when it lies this much farther (relative) than the
/// surface the pixel's centre sees: the surface's own outline, slanted across the pixel, must
/// not count as hidden.
const HIDDEN_MARGIN: f64 = 0.05;

/// The boundary edges of every face, scene-local (relative to the BVH's offset): triangle
/// edges that no other triangle of the same face shares.
pub(crate) struct Outline {
    edges: Vec<[DVec3; 2]>,
}

impl Outline {
    /// The outline of the faces of `bvh`.
    pub(crate) fn of(bvh: &SceneBvh) -> Outline {
        let mut triangles_of_face: HashMap<u32, Vec<usize>> = HashMap::new();
        for (t, &face) in bvh.face.iter().enumerate() {
            triangles_of_face.entry(face).or_default().push(t);
        }
        let key = |p: DVec3| p.to_array().map(f64::to_bits);
        let mut edges = Vec::new();
        for triangles in triangles_of_face.values() {
            // How many triangles of this face have each edge (either direction).
            let mut uses: HashMap<([u64; 3], [u64; 3]), u32> = HashMap::new();
            let sides = |t: usize| {
                let c = bvh.triangles[t];
                [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])]
            };
            let unordered = |(a, b): (DVec3, DVec3)| {
                let (ka, kb) = (key(a), key(b));
                if ka < kb { (ka, kb) } else { (kb, ka) }
            };
            if triangles.len() > 1 {
                for &t in triangles {
                    for side in sides(t) {
                        *uses.entry(unordered(side)).or_default() += 1;
                    }
                }
            }
            for &t in triangles {
                for side in sides(t) {
                    if triangles.len() == 1 || uses[&unordered(side)] == 1 {
                        edges.push([side.0, side.1]);
                    }
                }
            }
        }
        Outline { edges }
    }
}

/// The pixels to refine in `frame` (traced through `camera` at `pose` from `bvh`), sorted:
/// those whose centre face differs from a 4-neighbour's, and every pixel a visible face
/// outline crosses. `rays` is the camera's ray table where the renderer keeps one.
pub(crate) fn pixels_to_refine(
    frame: &Frame,
    bvh: &SceneBvh,
    outline: &Outline,
    camera: &Camera,
    pose: &Pose,
    rays: Option<&RayTable>,
) -> Vec<usize> {
    let (width, height) = (frame.width as usize, frame.height as usize);
    let mut refine = vec![false; width * height];
    let by_centre = super::antialias::edge_pixels(frame);
    for &i in &by_centre {
        refine[i] = true;
    }
    let rotation = pose.world_from_body_rotation();
    let body = |p: DVec3| rotation.transpose() * (p + bvh.offset - pose.position);
    let projectable = camera
        .ray(DVec2::new((width / 2) as f64, (height / 2) as f64))
        .and_then(|ray| camera.project(ray.origin + ray.direction))
        .is_some();
    if !projectable {
        // The neighbours of every edge pixel.
        for &i in &by_centre {
            let (x, y) = (i % width, i / width);
            for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if (0..width as i64).contains(&nx) && (0..height as i64).contains(&ny) {
                    refine[ny as usize * width + nx as usize] = true;
                }
            }
        }
        return (0..width * height).filter(|&i| refine[i]).collect();
    }
    let crossed: Vec<usize> = outline
        .edges
        .par_iter()
        .flat_map_iter(|&[a, b]| {
            let (a, b) = (body(a), body(b));
            let mut found = Vec::new();
            let mut mark = |point: DVec3, pixel: DVec2| {
                let (column, row) = ((pixel.x + 0.5).floor(), (pixel.y + 0.5).floor());
                if column < 0.0 || row < 0.0 || column >= width as f64 || row >= height as f64 {
                    return;
                }
                let index = row as usize * width + column as usize;
                let hit = &frame.pixels()[index];
                let visible = !hit.is_hit()
                    || rays
                        .map_or_else(|| camera.ray(DVec2::new(column, row)), |rays| rays.ray(index))
                        .is_none_or(|ray| point.distance(ray.origin) <= f64::from(hit.range) * (1.0 + HIDDEN_MARGIN));
                if visible {
                    found.push(index);
                }
            };
            let size = DVec2::new(width as f64, height as f64);
            sample_edge(
                camera,
                size,
                (a, camera.project(a)),
                (b, camera.project(b)),
                MAX_DEPTH,
                &mut mark,
            );
            found.into_iter()
        })
        .collect();
    for i in crossed {
        refine[i] = true;
    }
    (0..width * height).filter(|&i| refine[i]).collect()
}

/// Calls `mark` with points of the body-frame segment a–b and their projections, at most
/// [`STEP_PX`] apart in the image (`size` pixels; halving at most `depth` more times).
fn sample_edge(
    camera: &Camera,
    size: DVec2,
    (a, pa): (DVec3, Option<DVec2>),
    (b, pb): (DVec3, Option<DVec2>),
    depth: u32,
    mark: &mut impl FnMut(DVec3, DVec2),
) {
    match (pa, pb) {
        (Some(pa), Some(pb)) => {
            if pa.distance(pb) <= STEP_PX || depth == 0 {
                mark(a, pa);
                mark(b, pb);
                return;
            }
            // A pinhole projects a segment in front of it to the straight segment between its
            // ends' images: both beyond one border of the image, it crosses no pixel.
            let outside = pa.cmplt(DVec2::splat(-1.0)) & pb.cmplt(DVec2::splat(-1.0)) | pa.cmpgt(size) & pb.cmpgt(size);
            if matches!(camera, Camera::Pinhole(_)) && outside.any() {
                return;
            }
        }
        (None, None) if depth + BLIND_DEPTH <= MAX_DEPTH => return,
        _ if depth == 0 => return,
        _ => {}
    }
    let middle = (a + b) / 2.0;
    let pm = camera.project(middle);
    sample_edge(camera, size, (a, pa), (middle, pm), depth - 1, mark);
    sample_edge(camera, size, (middle, pm), (b, pb), depth - 1, mark);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    #[test]
    fn a_polygon_s_outline_leaves_out_its_triangulation_s_inner_edges() {
        let scene = Scene::from_ron(
            r#"Scene(name: "o", objects: [
                Polygon(name: "l", vertices: [(0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (2.0, 1.0, 0.0), (1.0, 0.5, 0.0), (0.0, 1.0, 0.0)], colour: (1, 1, 1)),
            ])"#,
            std::path::Path::new("o.ron"),
        )
        .unwrap();
        // Three triangles, five outline edges.
        assert_eq!(Outline::of(&SceneBvh::build(&scene).unwrap()).edges.len(), 5);
    }
}
