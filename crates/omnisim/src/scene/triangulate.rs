//! Splits planar faces into triangles for the BVH, remembering which face each came from.

use glam::DVec3;

use super::Scene;
use super::validate::{flatten, newell_normal};

/// The triangles of a scene. Triangle `i` has corners `corners[i]` and belongs to face
/// `face[i]` of the scene.
#[derive(Debug, Clone, Default)]
pub struct Triangles {
    /// Corners of each triangle, world metres.
    pub corners: Vec<[DVec3; 3]>,
    /// Scene face of each triangle.
    pub face: Vec<u32>,
}

impl Triangles {
    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }
}

pub(super) fn triangulate(scene: &Scene) -> Triangles {
    let mut out = Triangles::default();
    for triangle in triangle_indices(scene) {
        out.corners.push(triangle.corners(scene));
        out.face.push(triangle.face);
    }
    out
}

/// A triangle of a scene by reference: its face and three vertex indices into that face.
/// 16 bytes instead of 76, for the BVH build, which holds every triangle at once. The build
/// makes this list only for scenes with a face that is not a triangle: in a mesh of triangles,
/// triangle i is face i (`accel/mod.rs`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriangleIndex {
    pub(crate) face: u32,
    corners: [u32; 3],
}

impl TriangleIndex {
    /// Face `face`, a triangle, whole: its vertices in order.
    pub(crate) fn whole_face(face: u32) -> Self {
        Self {
            face,
            corners: [0, 1, 2],
        }
    }

    /// The triangle's corners, world metres.
    pub(crate) fn corners(&self, scene: &Scene) -> [DVec3; 3] {
        let vertices = &scene.faces[self.face as usize].vertices;
        self.corners.map(|i| vertices[i as usize])
    }
}

/// Every face's triangles, by reference, in face order. A triangle is its own fan, without the
/// polygon's normal and convexity test (the BVH build times this; docs/benchmarks.md).
pub(crate) fn triangle_indices(scene: &Scene) -> Vec<TriangleIndex> {
    let mut out = Vec::with_capacity(scene.faces.len());
    for (face, polygon) in scene.faces.iter().enumerate() {
        let corners = |t: [usize; 3]| TriangleIndex {
            face: face as u32,
            corners: t.map(|i| i as u32),
        };
        if polygon.vertices.len() == 3 {
            out.push(TriangleIndex::whole_face(face as u32));
        } else {
            out.extend(polygon_triangles(&polygon.vertices).into_iter().map(corners));
        }
    }
    out
}

/// Index triples covering a simple planar polygon: a fan when convex, ear clipping otherwise.
fn polygon_triangles(vertices: &[DVec3]) -> Vec<[usize; 3]> {
    let n = vertices.len();
    let normal = newell_normal(vertices);
    let convex = (0..n).all(|i| {
        let (a, b, c) = (vertices[i], vertices[(i + 1) % n], vertices[(i + 2) % n]);
        (b - a).cross(c - b).dot(normal) >= 0.0
    });
    if convex {
        return (1..n - 1).map(|i| [0, i, i + 1]).collect();
    }
    // Ear clipping (earcutr) works on the polygon flattened to 2-D.
    let local: Vec<DVec3> = vertices.iter().map(|v| *v - vertices[0]).collect();
    let flat: Vec<f64> = flatten(&local, normal).iter().flat_map(glam::DVec2::to_array).collect();
    match earcutr::earcut(&flat, &[], 2) {
        Ok(indices) if indices.len() / 3 == n - 2 => indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        // Validation refuses crossing outlines, so earcutr should not fail; a fan is the safety net.
        _ => (1..n - 1).map(|i| [0, i, i + 1]).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::dvec3;

    fn area(vertices: &[DVec3], triangles: &[[usize; 3]]) -> f64 {
        triangles
            .iter()
            .map(|t| {
                (vertices[t[1]] - vertices[t[0]])
                    .cross(vertices[t[2]] - vertices[t[0]])
                    .length()
                    / 2.0
            })
            .sum()
    }

    #[test]
    fn concave_polygon_keeps_its_area() {
        // An L shape of area 3 in a vertical plane.
        let l = [
            dvec3(0., 0., 0.),
            dvec3(2., 0., 0.),
            dvec3(2., 0., 1.),
            dvec3(1., 0., 1.),
            dvec3(1., 0., 2.),
            dvec3(0., 0., 2.),
        ];
        let t = polygon_triangles(&l);
        assert_eq!(t.len(), 4);
        assert!((area(&l, &t) - 3.0).abs() < 1e-12);
    }
}
