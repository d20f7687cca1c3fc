//! Checks that a polygon is a usable planar face: finite, non-degenerate, planar.

use glam::{DVec2, DVec3};

/// Newell's normal: twice the vector area of a polygon, robust for concave polygons.
pub(super) fn newell_normal(vertices: &[DVec3]) -> DVec3 {
    let n = vertices.len();
    (0..n).fold(DVec3::ZERO, |acc, i| {
        let (a, b) = (vertices[i], vertices[(i + 1) % n]);
        acc + DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        )
    })
}

/// Returns why `vertices` cannot be a face, in words for the person who wrote it.
pub(super) fn check_face(vertices: &[DVec3]) -> Result<(), String> {
    if vertices.len() < 3 {
        return Err(format!(
            "a face needs at least 3 vertices, this one has {}",
            vertices.len()
        ));
    }
    if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "vertex {i} is not a finite number ({:?}); check for NaN or inf",
            vertices[i]
        ));
    }
    let (lo, hi) = vertices
        .iter()
        .fold((vertices[0], vertices[0]), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let extent = (hi - lo).length();
    let n = vertices.len();
    for i in 0..n {
        for j in i + 1..n {
            if vertices[i].distance(vertices[j]) <= 1e-12 * (1.0 + extent) {
                return Err(format!("vertices {i} and {j} coincide; a face visits each corner once"));
            }
        }
    }
    let normal = newell_normal(vertices);
    if normal.length() <= 1e-12 * extent * extent {
        return Err(
            "the face is degenerate: it has no area (are its vertices on one line, or does its outline cross itself?)"
                .into(),
        );
    }
    let unit = normal.normalize();
    let centroid = vertices.iter().copied().sum::<DVec3>() / n as f64;
    let tolerance = 1e-6 * extent.max(1.0);
    if let Some((i, off)) = vertices
        .iter()
        .map(|v| unit.dot(*v - centroid).abs())
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|(_, off)| *off > tolerance)
    {
        return Err(format!(
            "the face is not planar: vertex {i} is {off:.3e} m off its plane (tolerance {tolerance:.1e} m); split it into planar faces"
        ));
    }
    if let Some((i, j)) = crossing_edges(vertices, unit) {
        return Err(format!(
            "the outline crosses itself: edge {i}–{} meets edge {j}–{}; list the vertices in order around the \
             boundary, or split the face",
            (i + 1) % n,
            (j + 1) % n
        ));
    }
    Ok(())
}

/// The polygon in 2-D: projected onto the coordinate plane it is most face-on to, which keeps
/// its shape's topology (crossings, ear clipping) for any planar polygon with this `normal`.
pub(super) fn flatten(vertices: &[DVec3], normal: DVec3) -> Vec<DVec2> {
    let drop = normal.abs().max_position();
    vertices
        .iter()
        .map(|v| {
            let a = v.to_array();
            DVec2::new(a[(drop + 1) % 3], a[(drop + 2) % 3])
        })
        .collect()
}

/// The first pair of non-adjacent edges that touch or cross, in the plane of the face.
fn crossing_edges(vertices: &[DVec3], normal: DVec3) -> Option<(usize, usize)> {
    let flat = flatten(vertices, normal);
    let n = flat.len();
    let orient = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - a);
    let within = |a: DVec2, b: DVec2, p: DVec2| p.cmpge(a.min(b)).all() && p.cmple(a.max(b)).all();
    let meet = |a: DVec2, b: DVec2, c: DVec2, d: DVec2| {
        let (d1, d2, d3, d4) = (orient(c, d, a), orient(c, d, b), orient(a, b, c), orient(a, b, d));
        (d1 * d2 < 0.0 && d3 * d4 < 0.0)
            || (d1 == 0.0 && within(c, d, a))
            || (d2 == 0.0 && within(c, d, b))
            || (d3 == 0.0 && within(a, b, c))
            || (d4 == 0.0 && within(a, b, d))
    };
    (0..n).flat_map(|i| (i + 2..n).map(move |j| (i, j))).find(|&(i, j)| {
        let adjacent = i == 0 && j == n - 1;
        !adjacent && meet(flat[i], flat[(i + 1) % n], flat[j], flat[(j + 1) % n])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::dvec3;

    fn square(z_of_last: f64) -> Vec<DVec3> {
        vec![
            dvec3(0., 0., 0.),
            dvec3(1., 0., 0.),
            dvec3(1., 1., 0.),
            dvec3(0., 1., z_of_last),
        ]
    }

    #[test]
    fn accepts_a_square_and_rejects_bad_faces() {
        assert!(check_face(&square(0.0)).is_ok());
        assert!(check_face(&square(0.01)).unwrap_err().contains("not planar"));
        assert!(check_face(&square(f64::NAN)).unwrap_err().contains("finite"));
        let collinear = [dvec3(0., 0., 0.), dvec3(1., 0., 0.), dvec3(2., 0., 0.)];
        assert!(check_face(&collinear).unwrap_err().contains("degenerate"));
        assert!(check_face(&square(0.0)[..2]).unwrap_err().contains("at least 3"));
        let revisits = [
            dvec3(0., 0., 0.),
            dvec3(1., 0., 0.),
            dvec3(1., 1., 0.),
            dvec3(0., 0., 0.),
            dvec3(0., 1., 0.),
        ];
        assert!(check_face(&revisits).unwrap_err().contains("vertices 0 and 3 coincide"));
        let bow_tie = [
            dvec3(0., 0., 0.),
            dvec3(2., 2., 0.),
            dvec3(2., 0., 0.),
            dvec3(0., 1., 0.),
        ];
        assert!(
            check_face(&bow_tie).unwrap_err().contains("crosses itself"),
            "{:?}",
            check_face(&bow_tie)
        );
        let symmetric_bow_tie = [
            dvec3(0., 0., 0.),
            dvec3(1., 1., 0.),
            dvec3(1., 0., 0.),
            dvec3(0., 1., 0.),
        ];
        assert!(check_face(&symmetric_bow_tie).unwrap_err().contains("cross itself"));
    }

    #[test]
    fn newell_normal_is_twice_the_area() {
        let n = newell_normal(&square(0.0));
        assert_eq!(n, dvec3(0.0, 0.0, 2.0));
    }
}
