//! Occluders: upright prisms (boxes, person-sized octagons) placed at random free places. A
//! place is free when the prism crosses no scene triangle (separating-axis test, touching
//! counts as crossing), lies inside the scene and in no closed object, overlaps no other
//! occluder of the frame, and keeps `clearance` from every camera. They join the scene as
//! objects of their own, so segmentation shows them.

use std::f64::consts::PI;

use glam::{DVec2, DVec3, dvec2, dvec3};
use rand::Rng;
use serde::Serialize;

use super::spec::{OccluderShape, OccluderSpec};
use omnisim::advanced::SceneBvh;
use omnisim::pose_sets::{Misplaced, misplaced};
use omnisim::scene::{Face, Scene, SceneObject};

/// Gap left under an occluder standing on the floor, so that it does not touch (and so
/// cross) the floor's faces. Far below a pixel at any sensible distance.
pub const FLOOR_GAP: f64 = 1e-3;

/// Draws per occluder before the free space is declared too small.
const ATTEMPTS: usize = 1000;

/// Kind of the objects occluders add to a scene (the segmentation legend shows it).
pub const OCCLUDER_KIND: &str = "Occluder";

/// One placed occluder: a convex footprint extruded from `bottom` to `top`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Occluder {
    /// Object name in the frame's scene.
    pub name: String,
    /// `box` or `person`.
    pub shape: &'static str,
    /// Footprint corners counter-clockwise seen from above, world metres.
    pub footprint: Vec<DVec2>,
    /// Height of the bottom face, metres.
    pub bottom: f64,
    /// Height of the top face, metres.
    pub top: f64,
    /// sRGB colour of every face.
    pub colour: [u8; 3],
}

impl Occluder {
    /// The 2·n corners: bottom ring, then top ring.
    fn corners(&self) -> Vec<DVec3> {
        let ring = |z: f64| self.footprint.iter().map(move |p| p.extend(z));
        ring(self.bottom).chain(ring(self.top)).collect()
    }

    /// Faces with outward vertex order: bottom, top, then the sides.
    fn faces(&self) -> Vec<Vec<DVec3>> {
        let n = self.footprint.len();
        let c = self.corners();
        let mut faces = vec![c[..n].iter().rev().copied().collect(), c[n..].to_vec()];
        faces.extend((0..n).map(|i| {
            let j = (i + 1) % n;
            vec![c[i], c[j], c[n + j], c[n + i]]
        }));
        faces
    }

    /// Distance from `point` to the prism (0 inside).
    pub fn distance(&self, point: DVec3) -> f64 {
        let p = point.truncate();
        let n = self.footprint.len();
        let mut inside = true;
        let mut nearest = f64::INFINITY;
        for i in 0..n {
            let (a, b) = (self.footprint[i], self.footprint[(i + 1) % n]);
            if (b - a).perp_dot(p - a) < 0.0 {
                inside = false;
            }
            let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            nearest = nearest.min(p.distance(a + (b - a) * t));
        }
        let horizontal = if inside { 0.0 } else { nearest };
        let vertical = (self.bottom - point.z).max(point.z - self.top).max(0.0);
        horizontal.hypot(vertical)
    }

    fn bounds(&self) -> (DVec3, DVec3) {
        let c = self.corners();
        c.iter().fold((c[0], c[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)))
    }

    /// Whether the prism and a triangle share any point (separating-axis theorem; a gap under
    /// 1e-9 m counts as touching).
    pub fn crosses_triangle(&self, triangle: &[DVec3; 3]) -> bool {
        let corners = self.corners();
        let n = self.footprint.len();
        let edges: Vec<DVec3> = (0..n)
            .map(|i| (self.footprint[(i + 1) % n] - self.footprint[i]).extend(0.0))
            .chain([DVec3::Z])
            .collect();
        let sides = [
            triangle[1] - triangle[0],
            triangle[2] - triangle[1],
            triangle[0] - triangle[2],
        ];
        let mut axes: Vec<DVec3> = edges[..n].iter().map(|e| e.cross(DVec3::Z)).collect();
        axes.push(DVec3::Z);
        axes.push(sides[0].cross(sides[1]));
        for e in &edges {
            axes.extend(sides.iter().map(|s| e.cross(*s)));
        }
        !axes.iter().any(|axis| {
            let length = axis.length();
            if length < 1e-12 {
                return false;
            }
            let axis = *axis / length;
            let span = |points: &mut dyn Iterator<Item = f64>| {
                points.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
            };
            let (a_lo, a_hi) = span(&mut corners.iter().map(|p| p.dot(axis)));
            let (b_lo, b_hi) = span(&mut triangle.iter().map(|p| p.dot(axis)));
            a_hi < b_lo - 1e-9 || b_hi < a_lo - 1e-9
        })
    }
}

/// Why occluders could not be placed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "no free place for occluder {number} ({shape}) after {ATTEMPTS} draws: the region is too crowded, or the \
     clearance from the cameras too large"
)]
pub struct NoFreePlace {
    /// 1-based number of the occluder that found no place.
    pub number: usize,
    /// Its shape.
    pub shape: &'static str,
}

/// The footprint (centred at the origin, unturned) and height of a shape.
fn outline(shape: OccluderShape) -> (&'static str, Vec<DVec2>, f64) {
    match shape {
        OccluderShape::Box { size: (l, w, h) } => (
            "box",
            vec![
                dvec2(-l / 2.0, -w / 2.0),
                dvec2(l / 2.0, -w / 2.0),
                dvec2(l / 2.0, w / 2.0),
                dvec2(-l / 2.0, w / 2.0),
            ],
            h,
        ),
        OccluderShape::Person => {
            // An octagon around an ellipse of 0.5 m (shoulders) by 0.3 m (chest).
            let corners = (0..8)
                .map(|k| {
                    let angle = (f64::from(k) + 0.5) * PI / 4.0;
                    dvec2(0.25 * angle.cos(), 0.15 * angle.sin()) / (PI / 8.0).cos()
                })
                .collect();
            ("person", corners, 1.75)
        }
    }
}

/// Places the occluders of `specs` in `scene` (whose BVH is `bvh`), away from `cameras`, after
/// `existing` ones (named on from them). Draws come from `rng` alone.
pub fn place(
    scene: &Scene,
    bvh: &SceneBvh,
    specs: &[&OccluderSpec],
    cameras: &[DVec3],
    existing: &[Occluder],
    rng: &mut impl Rng,
) -> Result<Vec<Occluder>, NoFreePlace> {
    let (lo, hi) = scene.bounds().unwrap_or((DVec3::ZERO, DVec3::ZERO));
    let mut placed: Vec<Occluder> = Vec::new();
    for spec in specs {
        let ((x0, y0), (x1, y1)) = spec.region.unwrap_or(((lo.x, lo.y), (hi.x, hi.y)));
        let floor = spec.floor.unwrap_or(lo.z) + FLOOR_GAP;
        let (shape, outline, height) = outline(spec.shape);
        for _ in 0..spec.count {
            let number = existing.len() + placed.len() + 1;
            let colour = spec.colour.map(|(r, g, b)| [r, g, b]);
            let found = (0..ATTEMPTS).find_map(|_| {
                let centre = dvec2(rng.random_range(x0..=x1), rng.random_range(y0..=y1));
                let turn = DVec2::from_angle(rng.random_range(0.0..2.0 * PI));
                let drawn = rng.random::<[u8; 3]>();
                let candidate = Occluder {
                    name: format!("occluder {number} ({shape})"),
                    shape,
                    footprint: outline.iter().map(|p| centre + turn.rotate(*p)).collect(),
                    bottom: floor,
                    top: floor + height,
                    colour: colour.unwrap_or(drawn),
                };
                free(
                    scene,
                    bvh,
                    &candidate,
                    cameras,
                    spec.clearance,
                    existing.iter().chain(&placed),
                )
                .then_some(candidate)
            });
            placed.push(found.ok_or(NoFreePlace { number, shape })?);
        }
    }
    Ok(placed)
}

fn free<'a>(
    scene: &Scene,
    bvh: &SceneBvh,
    candidate: &Occluder,
    cameras: &[DVec3],
    clearance: f64,
    others: impl Iterator<Item = &'a Occluder>,
) -> bool {
    if cameras.iter().any(|c| candidate.distance(*c) < clearance) {
        return false;
    }
    let (lo, hi) = candidate.bounds();
    let overlaps = |(a_lo, a_hi): (DVec3, DVec3)| a_lo.cmple(hi).all() && lo.cmple(a_hi).all();
    if others.map(Occluder::bounds).any(overlaps) {
        return false;
    }
    let crosses = bvh.triangles().iter().any(|t| {
        let world = t.map(|p| p + bvh.offset());
        let box_of = world
            .iter()
            .fold((world[0], world[0]), |(l, h), &p| (l.min(p), h.max(p)));
        overlaps(box_of) && candidate.crosses_triangle(&world)
    });
    // No face crossed: the prism lies wholly inside or outside each closed object, so its
    // centre decides.
    let centre = dvec3(0.0, 0.0, (candidate.bottom + candidate.top) / 2.0)
        + (candidate.footprint.iter().sum::<DVec2>() / candidate.footprint.len() as f64).extend(0.0);
    !crosses
        && !matches!(
            misplaced(scene, bvh, centre),
            Some(Misplaced::Inside(_) | Misplaced::OutsideBounds)
        )
}

/// `scene` with the occluders added as objects of their own, after the scene's objects.
pub fn with_occluders(scene: &Scene, occluders: &[Occluder]) -> Scene {
    let mut scene = scene.clone();
    for occluder in occluders {
        let object = scene.objects.len() as u32;
        scene.objects.push(SceneObject {
            name: occluder.name.clone(),
            kind: OCCLUDER_KIND,
        });
        scene.faces.extend(occluder.faces().into_iter().map(|vertices| Face {
            vertices: vertices.into(),
            colour: occluder.colour,
            object,
        }));
    }
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};

    #[test]
    fn separating_axes_find_crossings_and_gaps() {
        let (_, footprint, _) = outline(OccluderShape::Box { size: (2.0, 2.0, 2.0) });
        let cube = Occluder {
            name: "c".into(),
            shape: "box",
            footprint,
            bottom: 0.0,
            top: 2.0,
            colour: [0; 3],
        };
        let t = |a: DVec3, b: DVec3, c: DVec3| cube.crosses_triangle(&[a, b, c]);
        // Through the middle, touching a face, inside, beside it, and across a corner's diagonal gap.
        assert!(t(dvec3(-5.0, -5.0, 1.0), dvec3(5.0, -5.0, 1.0), dvec3(0.0, 5.0, 1.0)));
        assert!(t(dvec3(1.0, -5.0, 0.0), dvec3(1.0, 5.0, 0.0), dvec3(1.0, 0.0, 5.0)));
        assert!(t(dvec3(0.0, 0.0, 0.5), dvec3(0.1, 0.0, 0.5), dvec3(0.0, 0.1, 0.5)));
        assert!(!t(dvec3(1.01, -5.0, 0.0), dvec3(1.01, 5.0, 0.0), dvec3(1.01, 0.0, 5.0)));
        assert!(!t(dvec3(1.5, 0.9, 1.0), dvec3(0.9, 1.5, 1.0), dvec3(1.5, 1.5, 3.0)));
        assert!(cube.distance(dvec3(0.0, 0.0, 1.0)) == 0.0);
        assert!((cube.distance(dvec3(4.0, 0.0, 3.0)) - 10f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn occluders_never_cross_the_scene_nor_hold_a_camera() {
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/env1.ron")).unwrap();
        let scene = Scene::from_ron(&text, std::path::Path::new("env1.ron")).unwrap();
        let bvh = SceneBvh::build(&scene).unwrap();
        let specs = [
            OccluderSpec {
                shape: OccluderShape::Person,
                count: 3,
                per_frame: true,
                region: None,
                floor: None,
                clearance: 0.3,
                colour: None,
            },
            OccluderSpec {
                shape: OccluderShape::Box { size: (0.6, 0.4, 0.9) },
                count: 2,
                per_frame: true,
                region: None,
                floor: None,
                clearance: 0.3,
                colour: Some((200, 10, 10)),
            },
        ];
        let specs: Vec<&OccluderSpec> = specs.iter().collect();
        let cameras = [dvec3(0.0, 0.0, 0.4), dvec3(1.5, 0.0, 0.4)];
        for seed in 0..40 {
            let mut rng = stream(seed, "test", Some(0), Purpose::Occluders);
            let placed = place(&scene, &bvh, &specs, &cameras, &[], &mut rng).unwrap();
            assert_eq!(placed.len(), 5);
            for occluder in &placed {
                for t in bvh.triangles() {
                    assert!(
                        !occluder.crosses_triangle(&t.map(|p| p + bvh.offset())),
                        "seed {seed}: {occluder:?}"
                    );
                }
                for camera in cameras {
                    assert!(occluder.distance(camera) >= 0.3, "seed {seed}");
                }
                // Inside the room: a ray up from its top meets the ceiling above.
                let centre = occluder.footprint.iter().sum::<DVec2>() / occluder.footprint.len() as f64;
                let above =
                    omnisim::advanced::closest_hit(&bvh, centre.extend(occluder.top) - bvh.offset(), DVec3::Z, 0.0);
                assert!(above.is_some(), "seed {seed}: nothing above {occluder:?}");
            }
            let scene = with_occluders(&scene, &placed);
            assert_eq!(
                scene.objects.len(),
                scene.objects.iter().filter(|o| o.kind != OCCLUDER_KIND).count() + 5
            );
        }
    }
}
