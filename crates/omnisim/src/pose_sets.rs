//! Sets of poses for data sets: a grid map, a trajectory through waypoints, random test poses.
//! Every set is a plain `Vec<Pose>`; the CLI writes them as pose files for `render`.

use std::f64::consts::PI;

use glam::{DVec3, dvec3};
use rand::{Rng, SeedableRng, rngs::StdRng};

use crate::bvh::SceneBvh;
use crate::cpu;
use crate::pose::Pose;

/// Values start, start + step, … up to stop (inclusive, to within a millionth of a step).
pub fn steps(start: f64, stop: f64, step: f64) -> Vec<f64> {
    if step.is_nan() || step <= 0.0 || stop < start {
        return vec![start];
    }
    let count = ((stop - start) / step + 1e-6).floor() as usize + 1;
    (0..count).map(|i| start + i as f64 * step).collect()
}

/// Every combination of the given x, y, z values (x fastest), all with `angles` (radians).
pub fn grid(xs: &[f64], ys: &[f64], zs: &[f64], angles: DVec3) -> Vec<Pose> {
    zs.iter()
        .flat_map(|&z| {
            ys.iter()
                .flat_map(move |&y| xs.iter().map(move |&x| Pose::new(dvec3(x, y, z), angles)))
        })
        .collect()
}

/// Poses every `spacing` metres along the polyline through `waypoints`, turned (θz) to face
/// the direction of travel; the last waypoint is included.
pub fn trajectory(waypoints: &[DVec3], spacing: f64) -> Vec<Pose> {
    let mut poses = Vec::new();
    let facing = |d: DVec3| dvec3(0.0, 0.0, d.y.atan2(d.x));
    let mut carried = 0.0; // distance already walked past the last emitted pose
    for pair in waypoints.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let length = a.distance(b);
        if length == 0.0 {
            continue;
        }
        let direction = (b - a) / length;
        let mut along = if poses.is_empty() { 0.0 } else { spacing - carried };
        while along < length - 1e-12 {
            poses.push(Pose::new(a + direction * along, facing(direction)));
            along += spacing;
        }
        carried = length - (along - spacing);
    }
    if let [.., before, last] = waypoints {
        poses.push(Pose::new(*last, facing(*last - *before)));
    }
    poses
}

/// What `random` may draw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomPoses {
    /// How many poses to draw.
    pub count: usize,
    /// Seed of the generator: the same seed gives the same poses.
    pub seed: u64,
    /// Lowest corner of the box positions are drawn in, world metres.
    pub low: DVec3,
    /// Highest corner of that box.
    pub high: DVec3,
    /// Largest |θx| and |θy| (radians); θz is uniform over the full turn.
    pub max_tilt: f64,
    /// Minimum free distance from every surface along ±x, ±y, ±z, metres.
    pub clearance: f64,
}

/// Uniformly drawn poses whose position is at least `clearance` from every surface along the
/// six axis directions and enclosed (every axis ray hits the scene). Reproducible for a seed.
/// `None` if fewer than `count` such positions turn up in 1000 × count draws.
pub fn random(bvh: &SceneBvh, spec: &RandomPoses) -> Option<Vec<Pose>> {
    let mut rng = StdRng::seed_from_u64(spec.seed);
    let axes = [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z];
    let free = |p: DVec3| {
        axes.iter()
            .all(|&d| cpu::closest_hit(bvh, p - bvh.offset, d, 0.0).is_some_and(|hit| hit.t >= spec.clearance))
    };
    let draw = |rng: &mut StdRng, lo: f64, hi: f64| if hi > lo { rng.random_range(lo..=hi) } else { lo };
    let mut poses = Vec::with_capacity(spec.count);
    for _ in 0..spec.count.saturating_mul(1000) {
        if poses.len() == spec.count {
            break;
        }
        let p = dvec3(
            draw(&mut rng, spec.low.x, spec.high.x),
            draw(&mut rng, spec.low.y, spec.high.y),
            draw(&mut rng, spec.low.z, spec.high.z),
        );
        let angles = dvec3(
            draw(&mut rng, -spec.max_tilt, spec.max_tilt),
            draw(&mut rng, -spec.max_tilt, spec.max_tilt),
            draw(&mut rng, -PI, PI),
        );
        if free(p) {
            poses.push(Pose::new(p, angles));
        }
    }
    (poses.len() == spec.count).then_some(poses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_include_the_end() {
        assert_eq!(steps(-1.0, 1.0, 0.5), vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
        assert_eq!(steps(0.0, 0.25, 0.1).len(), 3);
        assert_eq!(steps(2.0, 2.0, 0.1), vec![2.0]);
    }

    #[test]
    fn grid_is_every_combination_x_fastest() {
        let poses = grid(&[0.0, 1.0], &[5.0, 6.0, 7.0], &[0.4], DVec3::ZERO);
        assert_eq!(poses.len(), 6);
        assert_eq!(poses[1].position, dvec3(1.0, 5.0, 0.4));
        assert_eq!(poses[2].position, dvec3(0.0, 6.0, 0.4));
    }

    #[test]
    fn random_poses_keep_their_clearance_and_repeat_for_a_seed() {
        let text = r#"Scene(name: "cube", objects: [Box(name: "room", size: (4.0, 2.0, 2.0), colour: (9, 9, 9))])"#;
        let scene = crate::scene::Scene::from_ron(text, std::path::Path::new("cube.ron")).unwrap();
        let bvh = SceneBvh::build(&scene);
        let spec = RandomPoses {
            count: 200,
            seed: 5,
            low: dvec3(-2.0, -1.0, 0.0),
            high: dvec3(2.0, 1.0, 2.0),
            max_tilt: 0.1,
            clearance: 0.3,
        };
        let poses = random(&bvh, &spec).unwrap();
        for pose in &poses {
            let p = pose.position;
            assert!(
                p.x.abs() <= 1.7 && p.y.abs() <= 0.7 && (0.3..=1.7).contains(&p.z),
                "{p}"
            );
            assert!(pose.angles.x.abs() <= 0.1 && pose.angles.y.abs() <= 0.1);
        }
        assert_eq!(random(&bvh, &spec).unwrap(), poses);
        assert!(
            random(
                &bvh,
                &RandomPoses {
                    clearance: 1.1,
                    count: 1,
                    ..spec
                }
            )
            .is_none()
        );
    }

    #[test]
    fn trajectory_is_evenly_spaced_and_faces_forward() {
        let poses = trajectory(&[dvec3(0.0, 0.0, 0.4), dvec3(1.0, 0.0, 0.4), dvec3(1.0, 1.0, 0.4)], 0.3);
        // 2 m of path: poses at 0, 0.3, … 1.8 and the end.
        assert_eq!(poses.len(), 8);
        for pair in poses[..7].windows(2) {
            let walked = (pair[1].position - pair[0].position).abs().element_sum();
            assert!((walked - 0.3).abs() < 1e-12, "{walked}");
        }
        assert_eq!(poses[0].angles.z, 0.0);
        assert!((poses[5].angles.z - PI / 2.0).abs() < 1e-12);
        assert_eq!(poses[7].position, dvec3(1.0, 1.0, 0.4));
    }
}
