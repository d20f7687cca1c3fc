//! The turn between two images of a central camera on a robot moving on a floor, from matched
//! local features: planar motion, a rotation Rz(φ) about the vertical and a translation t in
//! the floor plane, so that a point's body coordinates in the test image are
//! `P_t` = Rz(φ)·`P_m` + t. Its essential matrix E = [t]×·Rz(φ) has four non-zero entries,
//! E = [[0, 0, a], [0, 0, b], [c, d, 0]] with (a, b) = (`t_y`, −`t_x`) and
//! (c, d) = (`t_x`·sin φ − `t_y`·cos φ, `t_x`·cos φ + `t_y`·sin φ), so each pair of unit bearing
//! vectors (`b_m`, `b_t`) — the calibration's rays of the matched pixels, any direction on the
//! sphere — gives one linear equation `b_t`ᵀ·E·`b_m` = 0 in (a, b, c, d): three pairs fix E up
//! to scale. RANSAC over triples, then least squares over the inliers; φ follows from E
//! without its scale or sign: sin φ = (`t_x`·c + `t_y`·d)/|t|², cos φ = (`t_x`·d − `t_y`·c)/|t|².
//! A pure rotation (t = 0) leaves t free but φ still determined.

use glam::DVec3;
use nalgebra::{Matrix4, SymmetricEigen, Vector4};

/// What [`planar_turn`] finds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarTurn {
    /// The body's turn about +z from the map image to the test image, radians (−φ).
    pub turn: f64,
    /// Pairs consistent with it.
    pub inliers: usize,
}

/// The equation row of one pair: `b_t`ᵀ·E·`b_m` = row · (a, b, c, d).
fn row(m: DVec3, t: DVec3) -> Vector4<f64> {
    Vector4::new(t.x * m.z, t.y * m.z, t.z * m.x, t.z * m.y)
}

/// The unit (a, b, c, d) minimising Σ (row · e)² over `rows`: the eigenvector of the smallest
/// eigenvalue of Σ row·rowᵀ.
fn fit(rows: impl Iterator<Item = Vector4<f64>>) -> Vector4<f64> {
    let scatter = rows.fold(Matrix4::zeros(), |s, r| s + r * r.transpose());
    let eigen = SymmetricEigen::new(scatter);
    let smallest = eigen.eigenvalues.imin();
    eigen.eigenvectors.column(smallest).into_owned()
}

/// The turn −φ that E = (a, b, c, d) holds (module docs).
fn turn_of(e: &Vector4<f64>) -> f64 {
    let (tx, ty) = (-e[1], e[0]);
    let (c, d) = (e[2], e[3]);
    -(tx * c + ty * d).atan2(tx * d - ty * c)
}

/// `SplitMix64` (Vigna): the few draws RANSAC needs, the same on every run; a generator
/// crate is not worth a dependency of the library for them.
fn next(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The planar turn between the bearing pairs (`map[i]`, `test[i]`) (unit vectors in each
/// image's body frame): RANSAC over `iterations` triples (seeded, so the same on every run),
/// a pair an inlier when |`b_t`ᵀ·E·`b_m`| < `threshold` with E of unit norm (about the sine of
/// the angle by which a bearing misses its epipolar plane), then least squares over the
/// inliers. `None` with fewer than 3 pairs, or when no triple leaves 3 inliers.
pub fn planar_turn(map: &[DVec3], test: &[DVec3], threshold: f64, iterations: usize) -> Option<PlanarTurn> {
    let n = map.len().min(test.len());
    if n < 3 {
        return None;
    }
    let rows: Vec<Vector4<f64>> = map.iter().zip(test).map(|(&m, &t)| row(m, t)).collect();
    let inliers_of =
        |e: &Vector4<f64>| -> Vec<usize> { (0..n).filter(|&i| rows[i].dot(e).abs() < threshold).collect() };
    let mut state = 16u64;
    let mut best: Vec<usize> = Vec::new();
    for _ in 0..iterations {
        let pick: Vec<usize> = (0..3).map(|_| (next(&mut state) % n as u64) as usize).collect();
        if pick[0] == pick[1] || pick[1] == pick[2] || pick[0] == pick[2] {
            continue;
        }
        let inliers = inliers_of(&fit(pick.iter().map(|&i| rows[i])));
        if inliers.len() > best.len() {
            best = inliers;
        }
    }
    if best.len() < 3 {
        return None;
    }
    let e = fit(best.iter().map(|&i| rows[i]));
    Some(PlanarTurn {
        turn: turn_of(&e),
        inliers: inliers_of(&e).len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;

    /// Points around two body poses on a floor: the turn comes back to 1e-9 without outliers,
    /// and with a third of the pairs replaced by random bearings; a pure rotation too.
    #[test]
    fn recovers_the_turn() {
        let mut state = 7u64;
        let mut uniform = || (next(&mut state) >> 11) as f64 / (1u64 << 53) as f64;
        let points: Vec<DVec3> = (0..60)
            .map(|_| DVec3::new(6.0 * uniform() - 3.0, 4.0 * uniform() - 2.0, 2.5 * uniform() - 0.7))
            .collect();
        for (map_yaw, test_yaw, offset) in [
            (0.3f64, 1.2f64, DVec3::new(0.4, -0.2, 0.0)),
            (-2.0, 2.5, DVec3::new(-0.1, 0.3, 0.0)),
            (1.0, 0.2, DVec3::ZERO),
        ] {
            let (map_at, test_at) = (DVec3::new(0.2, 0.1, 0.4), DVec3::new(0.2, 0.1, 0.4) + offset);
            let bearing = |at: DVec3, yaw: f64, p: DVec3| (DMat3::from_rotation_z(-yaw) * (p - at)).normalize();
            let mut m: Vec<DVec3> = points.iter().map(|&p| bearing(map_at, map_yaw, p)).collect();
            let t: Vec<DVec3> = points.iter().map(|&p| bearing(test_at, test_yaw, p)).collect();
            let found = planar_turn(&m, &t, 1e-6, 200).unwrap();
            let error = (found.turn - (test_yaw - map_yaw) + 3.0 * std::f64::consts::PI)
                .rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            assert!(
                error.abs() < 1e-9,
                "{map_yaw} → {test_yaw}: {} (error {error})",
                found.turn
            );
            assert_eq!(found.inliers, 60);
            // Outliers: 20 of the 60 map bearings replaced.
            for b in m.iter_mut().take(20) {
                *b = DVec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize();
            }
            let found = planar_turn(&m, &t, 1e-6, 500).unwrap();
            let error = (found.turn - (test_yaw - map_yaw) + 3.0 * std::f64::consts::PI)
                .rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            assert!(error.abs() < 1e-9, "with outliers: error {error}");
            assert!((40..=42).contains(&found.inliers), "{} inliers", found.inliers);
        }
        assert!(planar_turn(&[DVec3::X; 2], &[DVec3::Y; 2], 0.01, 10).is_none());
    }
}
