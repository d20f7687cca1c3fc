//! Sets of poses for data sets: a grid map, a trajectory through waypoints, random test poses.
//! Every set is a plain `Vec<Pose>`; the CLI writes them as pose files for `render`.

use std::collections::HashMap;
use std::f64::consts::PI;

use glam::{DVec3, dvec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha12Rng;

use crate::accel::SceneBvh;
use crate::pose::{MICROMETRES, Pose, rounded};
use crate::scene::Scene;
use crate::trace;

/// Values start, start + step, … up to stop (inclusive, to within a millionth of a step).
pub fn steps(start: f64, stop: f64, step: f64) -> Vec<f64> {
    if step.is_nan() || step <= 0.0 || stop < start {
        return vec![start];
    }
    let count = ((stop - start) / step + 1e-6).floor() as usize + 1;
    (0..count)
        .map(|i| rounded(start + i as f64 * step, MICROMETRES))
        .collect()
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
            let position = (a + direction * along).map(|v| rounded(v, MICROMETRES));
            poses.push(Pose::new(position, facing(direction)));
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

/// Why `random` gave up: the clearance is met too rarely to find `count` poses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "only {accepted} of {drawn} positions drawn were clear; at that rate {count} poses would take more than \
     {budget} draws"
)]
pub struct TooFewClear {
    /// Clear positions found.
    pub accepted: usize,
    /// Positions drawn.
    pub drawn: usize,
    /// Poses asked for.
    pub count: usize,
    /// Most draws allowed for them.
    pub budget: usize,
}

/// Draws after which the acceptance rate is judged.
const TRIAL_DRAWS: usize = 10_000;
/// Draws allowed per pose asked for.
const DRAWS_PER_POSE: usize = 1000;

/// Uniformly drawn poses whose position is at least `clearance` from every surface along the
/// six axis directions, enclosed (every axis ray hits the scene) and not inside a closed object
/// ([`misplaced`]). Reproducible for a seed (`ChaCha12`, a named algorithm: the same poses
/// whatever `rand`'s `StdRng` becomes);
/// positions to the micrometre. Fails fast: after `TRIAL_DRAWS` draws (and every
/// `TRIAL_DRAWS` more) the acceptance rate so far must promise `count` poses within
/// `DRAWS_PER_POSE × count` draws.
pub fn random(scene: &Scene, bvh: &SceneBvh, spec: &RandomPoses) -> Result<Vec<Pose>, TooFewClear> {
    let mut rng = ChaCha12Rng::seed_from_u64(spec.seed);
    let axes = [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z];
    let free = |p: DVec3| {
        axes.iter()
            .all(|&d| trace::closest_hit(bvh, p - bvh.offset, d, 0.0).is_some_and(|hit| hit.t >= spec.clearance))
            && misplaced(scene, bvh, p).is_none()
    };
    let draw = |rng: &mut ChaCha12Rng, lo: f64, hi: f64| if hi > lo { rng.random_range(lo..=hi) } else { lo };
    let budget = spec.count.saturating_mul(DRAWS_PER_POSE).max(TRIAL_DRAWS);
    let mut poses = Vec::with_capacity(spec.count.min(1 << 20));
    let mut drawn = 0usize;
    while poses.len() < spec.count {
        let give_up = |drawn: usize, accepted: usize| TooFewClear {
            accepted,
            drawn,
            count: spec.count,
            budget,
        };
        if drawn >= budget {
            return Err(give_up(drawn, poses.len()));
        }
        if drawn > 0 && drawn.is_multiple_of(TRIAL_DRAWS) {
            // Draws still needed at the rate so far (+1: no acceptance yet is no promise).
            let needed = (spec.count - poses.len()) as f64 * drawn as f64 / (poses.len() as f64 + 1.0);
            if drawn as f64 + needed > budget as f64 {
                return Err(give_up(drawn, poses.len()));
            }
        }
        drawn += 1;
        let p = dvec3(
            draw(&mut rng, spec.low.x, spec.high.x),
            draw(&mut rng, spec.low.y, spec.high.y),
            draw(&mut rng, spec.low.z, spec.high.z),
        )
        .map(|v| rounded(v, MICROMETRES));
        let angles = dvec3(
            draw(&mut rng, -spec.max_tilt, spec.max_tilt),
            draw(&mut rng, -spec.max_tilt, spec.max_tilt),
            draw(&mut rng, -PI, PI),
        );
        if free(p) {
            poses.push(Pose::new(p, angles));
        }
    }
    Ok(poses)
}

/// Where a pose's position lies that a renderer would silently accept but a user would not
/// mean: outside the scene's bounds, or inside a closed object (a `Box`, or a `Mesh` whose
/// every edge is shared by exactly two of its faces).
#[derive(Debug, Clone, PartialEq)]
pub enum Misplaced {
    /// Outside the axis-aligned bounds of every face.
    OutsideBounds,
    /// Inside the named object.
    Inside(String),
}

/// Whether `position` is outside the scene or inside one of its closed objects. Inside is
/// decided by the parity of an object's crossings along three generic rays (two must agree),
/// so it costs a few dozen ray casts; an object that spans the whole scene (a room modelled
/// as one box or one closed mesh) is the enclosure, not something to be inside of.
pub fn misplaced(scene: &Scene, bvh: &SceneBvh, position: DVec3) -> Option<Misplaced> {
    let (lo, hi) = scene.bounds()?;
    if position.cmplt(lo).any() || position.cmpgt(hi).any() {
        return Some(Misplaced::OutsideBounds);
    }
    let directions = [
        dvec3(0.5773, 0.5774, 0.5775),
        dvec3(-0.6, 0.48, -0.64),
        dvec3(0.28, -0.96, 0.0),
    ];
    let mut votes: HashMap<u32, usize> = HashMap::new();
    for direction in directions {
        let direction = direction.normalize();
        let mut crossings: HashMap<u32, usize> = HashMap::new();
        let mut t_min = 0.0;
        // A bounded walk: a ray crosses few faces in any sensible scene.
        for _ in 0..10_000 {
            let Some(hit) = trace::closest_hit(bvh, position - bvh.offset, direction, t_min) else {
                break;
            };
            let object = scene.faces[bvh.face[hit.triangle] as usize].object;
            if matches!(scene.objects[object as usize].kind, "Box" | "Mesh") {
                *crossings.entry(object).or_default() += 1;
            }
            t_min = hit.t * (1.0 + 1e-12) + 1e-12;
        }
        for (object, count) in crossings {
            if count % 2 == 1 {
                *votes.entry(object).or_default() += 1;
            }
        }
    }
    let scene_bounds = (lo, hi);
    let mut inside: Vec<u32> = votes
        .into_iter()
        .filter(|&(_, v)| v >= 2)
        .map(|(object, _)| object)
        .collect();
    inside.sort_unstable();
    // Checked only for the few objects the rays say contain the point: a closed-mesh test
    // walks every face of the object.
    inside
        .into_iter()
        .find(|&object| encloses_a_volume(scene, object) && scene.object_bounds(object) != Some(scene_bounds))
        .map(|object| Misplaced::Inside(scene.objects[object as usize].name.clone()))
}

/// Whether an object bounds a volume: boxes always; meshes when every edge of their faces is
/// shared by exactly two faces (vertices compared exactly: a closed mesh file shares them).
fn encloses_a_volume(scene: &Scene, object: u32) -> bool {
    match scene.objects[object as usize].kind {
        "Box" => true,
        "Mesh" => {
            let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            let mut edges: HashMap<([u64; 3], [u64; 3]), u32> = HashMap::new();
            for face in scene.faces.iter().filter(|f| f.object == object) {
                let n = face.vertices.len();
                for i in 0..n {
                    let (a, b) = (key(face.vertices[i]), key(face.vertices[(i + 1) % n]));
                    *edges.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            !edges.is_empty() && edges.values().all(|&count| count == 2)
        }
        _ => false,
    }
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
        let bvh = SceneBvh::build(&scene).unwrap();
        let spec = RandomPoses {
            count: 200,
            seed: 5,
            low: dvec3(-2.0, -1.0, 0.0),
            high: dvec3(2.0, 1.0, 2.0),
            max_tilt: 0.1,
            clearance: 0.3,
        };
        let poses = random(&scene, &bvh, &spec).unwrap();
        for pose in &poses {
            let p = pose.position;
            assert!(
                p.x.abs() <= 1.7 && p.y.abs() <= 0.7 && (0.3..=1.7).contains(&p.z),
                "{p}"
            );
            assert!(pose.angles.x.abs() <= 0.1 && pose.angles.y.abs() <= 0.1);
        }
        assert_eq!(random(&scene, &bvh, &spec).unwrap(), poses);
        assert!(
            random(
                &scene,
                &bvh,
                &RandomPoses {
                    clearance: 1.1,
                    count: 1,
                    ..spec
                }
            )
            .is_err()
        );
        // Ten million poses nowhere to be found: refused after the first trial, not 47 minutes.
        let started = std::time::Instant::now();
        let refusal = random(
            &scene,
            &bvh,
            &RandomPoses {
                clearance: 1.1,
                count: 10_000_000,
                ..spec
            },
        )
        .unwrap_err();
        assert_eq!((refusal.accepted, refusal.drawn), (0, TRIAL_DRAWS));
        assert!(started.elapsed().as_secs_f64() < 5.0);
    }

    #[test]
    fn poses_inside_boxes_or_outside_the_scene_are_found() {
        let text = r#"Scene(name: "room", objects: [
            Floor(name: "floor", corners: [(-3.0, -2.0), (3.0, -2.0), (3.0, 2.0), (-3.0, 2.0)], colour: (1, 1, 1)),
            Floor(name: "ceiling", corners: [(-3.0, -2.0), (3.0, -2.0), (3.0, 2.0), (-3.0, 2.0)], z: 2.0, colour: (1, 1, 1)),
            Box(name: "table", size: (1.0, 1.0, 0.8), position: (1.0, 0.0, 0.0), colour: (9, 9, 9)),
        ])"#;
        let scene = crate::scene::Scene::from_ron(text, std::path::Path::new("room.ron")).unwrap();
        let bvh = SceneBvh::build(&scene).unwrap();
        assert_eq!(misplaced(&scene, &bvh, dvec3(0.0, 0.0, 1.0)), None);
        assert_eq!(
            misplaced(&scene, &bvh, dvec3(1.2, 0.1, 0.4)),
            Some(Misplaced::Inside("table".into()))
        );
        assert_eq!(misplaced(&scene, &bvh, dvec3(1.2, 0.1, 0.9)), None);
        assert_eq!(
            misplaced(&scene, &bvh, dvec3(0.0, 0.0, 3.0)),
            Some(Misplaced::OutsideBounds)
        );
    }

    /// A tetrahedron as a mesh file, closed or with one face left out.
    fn tetrahedron_ply(dir: &std::path::Path, faces: usize) -> std::path::PathBuf {
        let all = ["3 0 2 1", "3 0 1 3", "3 1 2 3", "3 2 0 3"];
        let text = format!(
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
             element face {faces}\nproperty list uchar int vertex_indices\nend_header\n\
             0 0 0\n1 0 0\n0 1 0\n0 0 1\n{}\n",
            all[..faces].join("\n")
        );
        let path = dir.join(format!("tetra{faces}.ply"));
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn poses_inside_closed_meshes_are_found_and_open_meshes_and_the_room_are_not() {
        let dir = tempfile::tempdir().unwrap();
        tetrahedron_ply(dir.path(), 4);
        tetrahedron_ply(dir.path(), 3);
        let text = r#"Scene(name: "room", objects: [
            Box(name: "room", size: (6.0, 4.0, 3.0), position: (0.0, 0.0, -1.0), colour: (1, 1, 1)),
            Mesh(name: "closed", path: "tetra4.ply", position: (1.0, 0.0, 0.0), colour: (9, 9, 9)),
            Mesh(name: "open", path: "tetra3.ply", position: (-2.0, 0.0, 0.0), colour: (9, 9, 9)),
        ])"#;
        let path = dir.path().join("room.ron");
        std::fs::write(&path, text).unwrap();
        let scene = crate::scene::Scene::load(&path).unwrap();
        let bvh = SceneBvh::build(&scene).unwrap();
        // Inside the tetrahedron x, y, z > 0, x + y + z < 1 (moved by +1 in x).
        assert_eq!(
            misplaced(&scene, &bvh, dvec3(1.2, 0.2, 0.2)),
            Some(Misplaced::Inside("closed".into()))
        );
        // The same place in the open one, and free space in the room that encloses everything.
        assert_eq!(misplaced(&scene, &bvh, dvec3(-1.8, 0.2, 0.2)), None);
        assert_eq!(misplaced(&scene, &bvh, dvec3(0.0, 1.0, 1.0)), None);
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
