//! Checks that a polygon is a usable planar face: finite, within range, non-degenerate,
//! planar, simple. Every test works in coordinates relative to the face's first vertex and
//! with tolerances relative to the face's size, so a face means the same wherever it is, and
//! every test is near-linear in the number of vertices (a 64k-vertex outline checks in
//! milliseconds).

use glam::{DVec2, DVec3};

/// Largest |coordinate| of a scene vertex, metres. The GPU traces in f32 relative to the
/// scene's centre: at 1000 km it still resolves 6 cm; far beyond it obvhs's f32 boxes
/// overflow (at 1e38) and validation's products lose all digits.
pub const MAX_COORDINATE: f64 = 1e6;

/// Newell's normal: twice the vector area of a polygon, robust for concave polygons; computed
/// relative to the first vertex so that it keeps its digits far from the origin.
pub(super) fn newell_normal(vertices: &[DVec3]) -> DVec3 {
    let n = vertices.len();
    let origin = vertices[0];
    (0..n).fold(DVec3::ZERO, |acc, i| {
        let (a, b) = (vertices[i] - origin, vertices[(i + 1) % n] - origin);
        acc + DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        )
    })
}

/// Why these vertices cannot be placed in a scene at all (for any object, meshes included).
pub(super) fn check_coordinates(vertices: &[DVec3]) -> Result<(), String> {
    if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "vertex {i} is not a finite number ({:?}); check for NaN or inf",
            vertices[i]
        ));
    }
    if let Some(i) = vertices.iter().position(|v| v.abs().max_element() > MAX_COORDINATE) {
        return Err(format!(
            "vertex {i} is {:.3e} m from the origin along an axis; scenes must lie within ±{MAX_COORDINATE:.0e} m, \
             where f32 tracing still resolves centimetres",
            vertices[i].abs().max_element()
        ));
    }
    Ok(())
}

/// Returns why `vertices` (finite and in range, see `check_coordinates`) cannot be a face, in
/// words for the person who wrote it.
pub(super) fn check_face(vertices: &[DVec3]) -> Result<(), String> {
    if vertices.len() < 3 {
        return Err(format!(
            "a face needs at least 3 vertices, this one has {}",
            vertices.len()
        ));
    }
    // A triangle is held in an array (meshes check millions: an allocation, or a SmallVec
    // filled by `collect`, was two thirds of the check).
    let relative = |v: &DVec3| *v - vertices[0];
    let (triangle, polygon): ([DVec3; 3], Vec<DVec3>);
    let local: &[DVec3] = if let [a, b, c] = vertices {
        triangle = [a, b, c].map(relative);
        &triangle
    } else {
        polygon = vertices.iter().map(relative).collect();
        &polygon
    };
    let (lo, hi) = local
        .iter()
        .fold((DVec3::ZERO, DVec3::ZERO), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let extent = (hi - lo).length();
    let n = local.len();
    if let Some((i, j)) = coinciding(local, 1e-12 * extent) {
        return Err(format!("vertices {i} and {j} coincide; a face visits each corner once"));
    }
    let normal = newell_normal(local);
    if normal.length() <= 1e-12 * extent * extent {
        return Err(
            "the face is degenerate: it has no area (are its vertices on one line, or does its outline cross itself?)"
                .into(),
        );
    }
    let unit = normal.normalize();
    let centroid = local.iter().copied().sum::<DVec3>() / n as f64;
    let tolerance = 1e-6 * extent.max(1.0);
    if let Some((i, off)) = local
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
    // A triangle's three edges are pairwise adjacent, so it has no pair to cross: a mesh of a
    // million triangles skips a million grids.
    if n == 3 {
        return Ok(());
    }
    if let Some((i, j)) = crossing_edges(&flatten(local, unit)) {
        return Err(format!(
            "the outline crosses itself: edge {i}–{} meets edge {j}–{}; list the vertices in order around the \
             boundary, or split the face",
            (i + 1) % n,
            (j + 1) % n
        ));
    }
    Ok(())
}

/// The first pair (i < j) of vertices closer than `tolerance`: sorted along the longest axis of
/// the face, only vertices within `tolerance` along it are compared.
fn coinciding(vertices: &[DVec3], tolerance: f64) -> Option<(usize, usize)> {
    let (lo, hi) = vertices
        .iter()
        .fold((vertices[0], vertices[0]), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let axis = (hi - lo).max_position();
    let key = |i: usize| vertices[i][axis];
    let (mut triangle, mut polygon): ([usize; 3], Vec<usize>);
    let order: &mut [usize] = if vertices.len() == 3 {
        triangle = [0, 1, 2];
        &mut triangle
    } else {
        polygon = (0..vertices.len()).collect();
        &mut polygon
    };
    order.sort_by(|&a, &b| key(a).total_cmp(&key(b)));
    let mut found: Option<(usize, usize)> = None;
    for (k, &a) in order.iter().enumerate() {
        for &b in order[k + 1..].iter().take_while(|&&b| key(b) - key(a) <= tolerance) {
            if vertices[a].distance(vertices[b]) <= tolerance {
                let pair = (a.min(b), a.max(b));
                found = Some(found.map_or(pair, |f| f.min(pair)));
            }
        }
    }
    found
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

/// The first pair of non-adjacent edges that touch or cross. Edges are binned into a grid of
/// about one cell per edge (each edge into the cells it passes, widened by half a cell against
/// rounding), and only edges sharing a cell are compared.
fn crossing_edges(flat: &[DVec2]) -> Option<(usize, usize)> {
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
    let (lo, hi) = flat
        .iter()
        .fold((flat[0], flat[0]), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let side = ((n as f64).sqrt().ceil() as usize).clamp(1, 4096);
    let cell = ((hi - lo) / side as f64).max(DVec2::splat(f64::MIN_POSITIVE));
    let index = |v: f64, lo: f64, size: f64| (((v - lo) / size).floor().max(0.0) as usize).min(side - 1);
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); side * side];
    for i in 0..n {
        let (a, b) = (flat[i], flat[(i + 1) % n]);
        let (y_lo, y_hi) = (a.y.min(b.y), a.y.max(b.y));
        let rows = index(y_lo - cell.y / 2.0, lo.y, cell.y)..=index(y_hi + cell.y / 2.0, lo.y, cell.y);
        for row in rows {
            // The part of the edge within this row (widened by half a cell each way).
            let row_lo = (lo.y + (row as f64 - 0.5) * cell.y).max(y_lo);
            let row_hi = (lo.y + (row as f64 + 1.5) * cell.y).min(y_hi);
            let x_at = |y: f64| {
                if a.y == b.y {
                    a.x
                } else {
                    a.x + (b.x - a.x) * ((y - a.y) / (b.y - a.y))
                }
            };
            let (x0, x1) = if a.y == b.y {
                (a.x, b.x)
            } else {
                (x_at(row_lo), x_at(row_hi))
            };
            let columns =
                index(x0.min(x1) - cell.x / 2.0, lo.x, cell.x)..=index(x0.max(x1) + cell.x / 2.0, lo.x, cell.x);
            for column in columns {
                cells[row * side + column].push(i as u32);
            }
        }
    }
    let mut found: Option<(usize, usize)> = None;
    for edges in &cells {
        for (k, &i) in edges.iter().enumerate() {
            for &j in &edges[k + 1..] {
                let (i, j) = (i.min(j) as usize, i.max(j) as usize);
                let adjacent = j == i + 1 || (i == 0 && j == n - 1);
                if !adjacent
                    && found.is_none_or(|f| (i, j) < f)
                    && meet(flat[i], flat[(i + 1) % n], flat[j], flat[(j + 1) % n])
                {
                    found = Some((i, j));
                }
            }
        }
    }
    found
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
        assert!(check_coordinates(&square(f64::NAN)).unwrap_err().contains("finite"));
        assert!(check_coordinates(&square(2e6)).unwrap_err().contains("within ±1e6 m"));
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
