//! Localization by global appearance, the experiment of the reference paper's group (Payá et
//! al. 2010, Sensors 10(12); Payá et al. 2014, Sensors 14(2); Berenguer et al. 2015, Sensors
//! 15(10); Amorós et al. 2021, Sensors 21(10)): every test image is compared with every map
//! image by one descriptor and one distance, its position is the pose of the nearest map image
//! (or a distance-weighted mean of the k nearest), and its heading comes from the Fourier
//! signature's phases or the Radon transform's phase-only correlation with that map image.
//!
//! The poses are planar (x, y, yaw): the map and test images of these papers are taken by a
//! robot on the floor. A test image's pose is used only by [`score`] to measure the error;
//! [`localize`] never sees it.
//!
//! - [`distance`]: the distances the papers compare.
//! - [`metrics`]: error summaries and recall.
//! - [`relative`]: the turn between two images from matched local features (planar motion).
//! - [`report`]: the JSON report (its schema ships as `docs/localization-report.schema.json`)
//!   and its charts.

pub mod distance;
pub mod metrics;
pub mod relative;
pub mod report;

use std::f64::consts::{PI, TAU};

pub use distance::Distance;

use rayon::prelude::*;

use crate::fourier::FourierSignature;
use crate::keypoints::Features;
use crate::radon::Radon;
use crate::{VisionError, require};

/// A robot's pose on the floor: position (metres) and heading about +z (radians,
/// counter-clockwise from above, from +x).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlanarPose {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading, radians.
    pub yaw: f64,
}

/// What estimates a test image's heading relative to a map image.
#[derive(Debug, Clone)]
pub enum Heading {
    /// Fourier signatures of the panoramas (one per image): the phase shift (resolution
    /// 2π/W, W the panorama's width).
    Fourier(Vec<FourierSignature>),
    /// Radon transforms of the omnidirectional images (one per image): phase-only
    /// correlation (resolution 2π/angles). omnisim's mirrors look up, so a body yaw of +δ
    /// turns the image by −δ.
    Radon(Vec<Radon>),
}

impl Heading {
    /// Name in reports.
    pub fn name(&self) -> &'static str {
        match self {
            Heading::Fourier(_) => "fourier-phase",
            Heading::Radon(_) => "radon-poc",
        }
    }

    fn len(&self) -> usize {
        match self {
            Heading::Fourier(s) => s.len(),
            Heading::Radon(r) => r.len(),
        }
    }

    /// The turn of the body from map image `m` (of `map`) to test image `t` (of `self`),
    /// radians.
    fn turn(&self, t: usize, map: &Heading, m: usize) -> Result<f64, VisionError> {
        match (self, map) {
            (Heading::Fourier(test), Heading::Fourier(map)) => Ok(map[m].rotation_to(&test[t])?.radians),
            (Heading::Radon(test), Heading::Radon(map)) => Ok(-map[m].rotation_to(&test[t])?.0.radians),
            _ => Err(VisionError::Parameter {
                name: "heading",
                reason: "the map and test images' headings come from different descriptors".to_string(),
            }),
        }
    }
}

/// The images of one set as one descriptor sees them.
#[derive(Debug, Clone)]
pub struct Described {
    /// One descriptor per image, all of one length.
    pub rows: Vec<Vec<f32>>,
    /// What gives the heading, where the descriptor has a way.
    pub heading: Option<Heading>,
}

impl Described {
    /// Checks that every row has the same length, and the heading one entry per image.
    fn check(&self, what: &'static str) -> Result<usize, VisionError> {
        let length = self.rows.first().map_or(0, Vec::len);
        require(self.rows.iter().all(|r| r.len() == length), what, || {
            "descriptors of different lengths".to_string()
        })?;
        require(
            self.heading.as_ref().is_none_or(|h| h.len() == self.rows.len()),
            what,
            || "one heading estimate per image is needed".to_string(),
        )?;
        Ok(length)
    }
}

/// How a test image is localized.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Method {
    /// The distance between descriptors.
    pub distance: Distance,
    /// Neighbours averaged for the position (weights 1/distance); 1: the nearest alone.
    pub neighbours: usize,
}

/// What [`localize`] estimates for one test image.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Estimate {
    /// The nearest map image.
    pub nearest: usize,
    /// Its distance.
    pub distance: f64,
    /// The position: the nearest map pose's, or the weighted mean of the k nearest.
    pub x: f64,
    /// The position, y.
    pub y: f64,
    /// The heading (radians), where the descriptor gives one: the nearest map image's heading
    /// plus the turn from it.
    pub yaw: Option<f64>,
}

/// Localizes every test image against the map, knowing only the map's poses. Ties go to
/// the lower map index.
pub fn localize(
    map: &Described,
    map_poses: &[PlanarPose],
    test: &Described,
    method: Method,
) -> Result<Vec<Estimate>, VisionError> {
    let length = map.check("map")?;
    require(test.check("test")? == length || test.rows.is_empty(), "test", || {
        format!("test descriptors are not {length} values long, as the map's")
    })?;
    require(
        map_poses.len() == map.rows.len() && !map_poses.is_empty(),
        "map",
        || format!("{} map poses for {} map images", map_poses.len(), map.rows.len()),
    )?;
    require(method.neighbours >= 1, "neighbours", || "at least 1".to_string())?;
    let k = method.neighbours.min(map.rows.len());
    test.rows
        .par_iter()
        .enumerate()
        .map(|(t, row)| {
            let ranked = nearest(&map.rows, row, method.distance, k);
            let (nearest, distance) = ranked[0];
            let (x, y) = weighted_position(map_poses, &ranked);
            let yaw = match (&test.heading, &map.heading) {
                (Some(test_heading), Some(map_heading)) => Some(wrap(
                    map_poses[nearest].yaw + test_heading.turn(t, map_heading, nearest)?,
                )),
                _ => None,
            };
            Ok(Estimate {
                nearest,
                distance,
                x,
                y,
                yaw,
            })
        })
        .collect()
}

/// A test image retrieved by local features: its estimate and its ratio-test matches with the
/// nearest map image (pairs of keypoint indices, test then map), kept for the heading.
#[derive(Debug, Clone)]
pub struct Retrieved {
    /// Position (and, after [`add_feature_headings`], heading).
    pub estimate: Estimate,
    /// Ratio-test matches with map image `estimate.nearest`.
    pub matches: Vec<(usize, usize)>,
}

/// Localizes every test image by local features: the map image with which it shares most
/// ratio-test matches (Lowe 2004 §7.1, `ratio` 0.8 there) is the nearest, `distance` =
/// 1/(1 + matches), and with `neighbours` > 1 the position is the mean of the k best weighted
/// by 1 + matches. Ties go to the lower map index. No heading.
pub fn localize_by_matches(
    map: &[Features],
    map_poses: &[PlanarPose],
    test: &[Features],
    ratio: f32,
    neighbours: usize,
) -> Result<Vec<Retrieved>, VisionError> {
    require(map_poses.len() == map.len() && !map.is_empty(), "map", || {
        format!("{} map poses for {} map images", map_poses.len(), map.len())
    })?;
    require(neighbours >= 1, "neighbours", || "at least 1".to_string())?;
    require(ratio > 0.0 && ratio <= 1.0, "ratio", || {
        format!("needs 0 < ratio ≤ 1, got {ratio}")
    })?;
    Ok(test
        .par_iter()
        .map(|features| {
            let mut matches: Vec<Vec<(usize, usize)>> = map.iter().map(|m| features.match_ratio(m, ratio)).collect();
            let mut ranked: Vec<(usize, f64)> = matches
                .iter()
                .enumerate()
                .map(|(i, found)| (i, 1.0 / (1.0 + found.len() as f64)))
                .collect();
            ranked.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            ranked.truncate(neighbours.min(map.len()));
            let (x, y) = weighted_position(map_poses, &ranked);
            Retrieved {
                estimate: Estimate {
                    nearest: ranked[0].0,
                    distance: ranked[0].1,
                    x,
                    y,
                    yaw: None,
                },
                matches: std::mem::take(&mut matches[ranked[0].0]),
            }
        })
        .collect())
}

/// Name in reports of the heading that local features give ([`relative::planar_turn`]).
pub const FEATURE_HEADING: &str = "feature-planar-motion";

/// Adds to each estimate of [`localize_by_matches`] the heading the local features give: the
/// nearest map image's heading turned by [`relative::planar_turn`] of their ratio-test matches
/// (found by the retrieval, not searched again), each keypoint's pixel (x, y) taken to a unit
/// bearing by `bearing` (the camera's ray; `None` where the pixel sees nothing). Estimates with
/// fewer than 3 usable matches keep no heading.
pub fn add_feature_headings(
    retrieved: &mut [Retrieved],
    map: &[Features],
    map_poses: &[PlanarPose],
    test: &[Features],
    bearing: &(dyn Fn(f32, f32) -> Option<glam::DVec3> + Sync),
) {
    retrieved.par_iter_mut().zip(test).for_each(|(found, features)| {
        let estimate = &mut found.estimate;
        let nearest = &map[estimate.nearest];
        let (mut from, mut to) = (Vec::new(), Vec::new());
        for &(i, j) in &found.matches {
            let (t, m) = (features.keypoints[i], nearest.keypoints[j]);
            if let (Some(bt), Some(bm)) = (bearing(t.x, t.y), bearing(m.x, m.y)) {
                from.push(bm);
                to.push(bt);
            }
        }
        // 0.02: about a degree off the epipolar plane, a keypoint's half-pixel error on a
        // small omni image.
        estimate.yaw =
            relative::planar_turn(&from, &to, 0.02, 500).map(|turn| wrap(map_poses[estimate.nearest].yaw + turn.turn));
    });
}

/// The `k` map rows nearest to `query`, nearest first (ties: lower index first).
pub fn nearest(map: &[Vec<f32>], query: &[f32], distance: Distance, k: usize) -> Vec<(usize, f64)> {
    let mut all: Vec<(usize, f64)> = map
        .iter()
        .enumerate()
        .map(|(i, row)| (i, distance.between(row, query)))
        .collect();
    all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    all.truncate(k.max(1));
    all
}

/// The mean of the neighbours' positions weighted by 1/distance; a neighbour at distance 0
/// (an identical descriptor) is the answer alone.
fn weighted_position(poses: &[PlanarPose], ranked: &[(usize, f64)]) -> (f64, f64) {
    if ranked.len() == 1 || ranked[0].1 <= 0.0 {
        let p = poses[ranked[0].0];
        return (p.x, p.y);
    }
    let (mut x, mut y, mut total) = (0.0, 0.0, 0.0);
    for &(i, d) in ranked {
        let w = 1.0 / d;
        x += w * poses[i].x;
        y += w * poses[i].y;
        total += w;
    }
    (x / total, y / total)
}

/// An angle wrapped to (−π, π].
pub fn wrap(angle: f64) -> f64 {
    let a = (angle + PI).rem_euclid(TAU) - PI;
    if a <= -PI { a + TAU } else { a }
}

/// Errors of one test image: position (metres, in the floor plane) and heading (radians,
/// absolute), scored against its true pose.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Score {
    /// |estimated − true position| in the floor plane, metres.
    pub position_m: f64,
    /// |estimated − true heading| wrapped, radians; `None` without a heading estimate.
    pub heading_rad: Option<f64>,
}

/// Scores the estimates against the test images' true poses (the only use of those poses).
pub fn score(estimates: &[Estimate], truth: &[PlanarPose]) -> Vec<Score> {
    estimates
        .iter()
        .zip(truth)
        .map(|(e, t)| Score {
            position_m: (e.x - t.x).hypot(e.y - t.y),
            heading_rad: e.yaw.map(|yaw| wrap(yaw - t.yaw).abs()),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f64, y: f64, yaw: f64) -> PlanarPose {
        PlanarPose { x, y, yaw }
    }

    /// Identical descriptors give the map pose exactly; the nearest is chosen under each
    /// distance; k-NN weighting lands between two map poses, nearer the closer descriptor.
    #[test]
    fn nearest_and_weighted_positions() {
        let map = Described {
            rows: vec![vec![0.0, 1.0], vec![1.0, 0.0], vec![1.0, 1.0]],
            heading: None,
        };
        let poses = [pose(0.0, 0.0, 0.0), pose(1.0, 0.0, 0.0), pose(0.0, 2.0, 0.0)];
        let test = Described {
            rows: vec![vec![1.0, 0.0], vec![0.9, 0.1]],
            heading: None,
        };
        for distance in Distance::ALL {
            let method = Method {
                distance,
                neighbours: 1,
            };
            let estimates = localize(&map, &poses, &test, method).unwrap();
            assert_eq!(estimates[0].nearest, 1, "{distance:?}");
            assert_eq!((estimates[0].x, estimates[0].y), (1.0, 0.0));
            assert!(estimates[0].distance.abs() < 1e-12);
        }
        let two = Method {
            distance: Distance::L2,
            neighbours: 2,
        };
        let e = &localize(&map, &poses, &test, two).unwrap()[1];
        // Nearest rows 1 (d = √0.02) and 2 (d = √0.82): weights 1/d.
        let (w1, w2) = (1.0 / 0.02f64.sqrt(), 1.0 / 0.82f64.sqrt());
        assert!((e.x - w1 / (w1 + w2)).abs() < 1e-6 && (e.y - 2.0 * w2 / (w1 + w2)).abs() < 1e-6);
        let scores = score(&localize(&map, &poses, &test, two).unwrap(), &[pose(1.0, 0.0, 0.0); 2]);
        assert_eq!(scores[0].position_m, 0.0);
        assert!(scores[1].position_m > 0.0);
    }

    #[test]
    fn angles_wrap() {
        assert!((wrap(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap(-PI) - PI).abs() < 1e-12);
        assert!((wrap(0.1 - TAU) - 0.1).abs() < 1e-12);
    }

    /// Mismatched inputs are errors, not panics.
    #[test]
    fn mismatches_are_refused() {
        let map = Described {
            rows: vec![vec![0.0, 1.0]],
            heading: None,
        };
        let test = Described {
            rows: vec![vec![0.0]],
            heading: None,
        };
        let method = Method {
            distance: Distance::L1,
            neighbours: 1,
        };
        assert!(localize(&map, &[pose(0.0, 0.0, 0.0)], &test, method).is_err());
        assert!(localize(&map, &[], &map, method).is_err());
    }
}
