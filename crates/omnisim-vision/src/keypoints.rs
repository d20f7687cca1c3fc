//! What SIFT and SURF share: keypoints and their descriptors, the 3 × 3 × 3 scale-space
//! neighbourhood, its extremum test and quadratic sub-sample fit (Brown & Lowe 2002, used by
//! both Lowe 2004 §4 and Bay et al. 2006 §3.3), and nearest-neighbour matching with Lowe's
//! ratio test.

use nalgebra::{Matrix3, Vector3};

/// A local feature's frame, in the input image's pixels (centres at integer coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keypoint {
    /// Column.
    pub x: f32,
    /// Row.
    pub y: f32,
    /// Scale: the σ (pixels) of the Gaussian the feature was found at. `OpenCV`'s `size` is 2σ
    /// for SIFT and 9σ/1.2 (the box filter's side) for SURF.
    pub sigma: f32,
    /// Dominant orientation in degrees, 0..360, from +x towards +y (image rows, downwards):
    /// `OpenCV`'s `KeyPoint::angle`.
    pub angle: f32,
    /// Detector strength: |`DoG`| contrast (SIFT) or the Hessian's determinant (SURF).
    pub response: f32,
    /// Octave the feature was found in (−1 is SIFT's doubled image).
    pub octave: i32,
}

/// Keypoints and their descriptors, one row of `length` values per keypoint.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Features {
    /// The keypoints, in the order of the descriptor rows.
    pub keypoints: Vec<Keypoint>,
    /// Values per descriptor.
    pub length: usize,
    /// `keypoints.len() × length` values, row-major.
    pub descriptors: Vec<f32>,
}

impl Features {
    /// The descriptor of keypoint `i`.
    pub fn descriptor(&self, i: usize) -> &[f32] {
        &self.descriptors[i * self.length..(i + 1) * self.length]
    }

    /// Pairs (index in `self`, index in `other`) whose nearest neighbour (Euclidean distance
    /// of descriptors) is closer than `ratio` times the second nearest (Lowe 2004 §7.1,
    /// ratio 0.8). Brute force, O(n·m), with an early exit: a candidate is dropped as soon as
    /// its partial distance reaches the second nearest's (the squares only add up), which
    /// leaves the result unchanged and skips most of each 128-value descriptor.
    pub fn match_ratio(&self, other: &Features, ratio: f32) -> Vec<(usize, usize)> {
        if self.length != other.length || other.keypoints.len() < 2 {
            return Vec::new();
        }
        (0..self.keypoints.len())
            .filter_map(|i| {
                let a = self.descriptor(i);
                let (mut best, mut second, mut best_j) = (f32::INFINITY, f32::INFINITY, 0);
                for j in 0..other.keypoints.len() {
                    let Some(d) = squared_distance_below(a, other.descriptor(j), second) else {
                        continue;
                    };
                    if d < best {
                        (second, best, best_j) = (best, d, j);
                    } else {
                        second = d;
                    }
                }
                (best < ratio * ratio * second).then_some((i, best_j))
            })
            .collect()
    }
}

/// Values summed between checks against the bound in [`squared_distance_below`].
const LANES: usize = 8;

/// |a − b|² where it is below `bound`, else `None` (found early: the partial sum is checked
/// every 32 values). Eight running sums, so that the compiler keeps them in one vector register.
fn squared_distance_below(a: &[f32], b: &[f32], bound: f32) -> Option<f32> {
    let mut sums = [0.0f32; LANES];
    let (a_chunks, b_chunks) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f32 = a_chunks
        .remainder()
        .iter()
        .zip(b_chunks.remainder())
        .map(|(x, y)| (x - y) * (x - y))
        .sum();
    for (k, (x, y)) in a_chunks.zip(b_chunks).enumerate() {
        for ((s, x), y) in sums.iter_mut().zip(x).zip(y) {
            *s += (x - y) * (x - y);
        }
        if k % 4 == 3 && sums.iter().sum::<f32>() >= bound {
            return None;
        }
    }
    let total = sums.iter().sum::<f32>() + tail;
    (total < bound).then_some(total)
}

/// Values at (scale −1..=1, row −1..=1, column −1..=1) around a sample: `n[s][y][x]`.
pub(crate) type Neighbourhood = [[[f32; 3]; 3]; 3];

/// The 3 × 3 × 3 neighbourhood of (x, y) in three same-size row-major layers of `width`
/// columns, or `None` if one value is not finite (a sample where the filter did not fit).
pub(crate) fn neighbourhood(layers: [&[f32]; 3], width: usize, x: usize, y: usize) -> Option<Neighbourhood> {
    let mut n = [[[0.0; 3]; 3]; 3];
    for (plane, layer) in n.iter_mut().zip(layers) {
        for (dy, row) in plane.iter_mut().enumerate() {
            let start = (y + dy - 1) * width + x - 1;
            row.copy_from_slice(&layer[start..start + 3]);
            if !row.iter().all(|v| v.is_finite()) {
                return None;
            }
        }
    }
    Some(n)
}

/// Whether the centre is strictly above (`maximum`) or below all 26 neighbours.
pub(crate) fn is_extremum(n: &Neighbourhood, maximum: bool) -> bool {
    let centre = n[1][1][1];
    n.iter()
        .flatten()
        .flatten()
        .enumerate()
        .all(|(i, &v)| i == 13 || if maximum { centre > v } else { centre < v })
}

/// The second-order Taylor expansion of a neighbourhood about its centre, by central
/// differences (Lowe 2004 §4).
pub(crate) struct QuadraticFit {
    /// ∂/∂x, ∂/∂y, ∂/∂scale.
    pub(crate) gradient: Vector3<f32>,
    /// The 3 × 3 Hessian in the same order.
    pub(crate) hessian: Matrix3<f32>,
}

impl QuadraticFit {
    pub(crate) fn new(n: &Neighbourhood) -> Self {
        let c = n[1][1][1];
        let dx = (n[1][1][2] - n[1][1][0]) * 0.5;
        let dy = (n[1][2][1] - n[1][0][1]) * 0.5;
        let ds = (n[2][1][1] - n[0][1][1]) * 0.5;
        let dxx = n[1][1][2] + n[1][1][0] - 2.0 * c;
        let dyy = n[1][2][1] + n[1][0][1] - 2.0 * c;
        let dss = n[2][1][1] + n[0][1][1] - 2.0 * c;
        let dxy = (n[1][2][2] - n[1][2][0] - n[1][0][2] + n[1][0][0]) * 0.25;
        let dxs = (n[2][1][2] - n[2][1][0] - n[0][1][2] + n[0][1][0]) * 0.25;
        let dys = (n[2][2][1] - n[2][0][1] - n[0][2][1] + n[0][0][1]) * 0.25;
        Self {
            gradient: Vector3::new(dx, dy, ds),
            hessian: Matrix3::new(dxx, dxy, dxs, dxy, dyy, dys, dxs, dys, dss),
        }
    }

    /// The extremum's offset x̂ = −H⁻¹·∇ (x, y, scale), or `None` if H is singular.
    pub(crate) fn offset(&self) -> Option<Vector3<f32>> {
        self.hessian
            .lu()
            .solve(&self.gradient)
            .map(|v| -v)
            .filter(|v| v.iter().all(|c| c.is_finite()))
    }

    /// The change of value at `offset`: ½·∇ᵀx̂ (Lowe 2004 §4).
    pub(crate) fn gain(&self, offset: &Vector3<f32>) -> f32 {
        0.5 * self.gradient.dot(offset)
    }
}

/// Scales `values` to unit Euclidean length (left as they are if all zero).
pub(crate) fn normalise(values: &mut [f32]) {
    let norm = values.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm > f32::EPSILON {
        values.iter_mut().for_each(|v| *v /= norm);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sampled quadratic bowl with its minimum at a known sub-sample offset: the fit finds
    /// the offset and the value there exactly (the Taylor expansion of a quadratic is exact).
    #[test]
    fn quadratic_fit_finds_a_bowls_minimum() {
        let (x0, y0, s0) = (0.3f32, -0.2f32, 0.4f32);
        let f = |x: f32, y: f32, s: f32| {
            2.0 * (x - x0).powi(2) + (y - y0).powi(2) + 0.5 * (s - s0).powi(2) + 0.3 * (x - x0) * (y - y0) - 1.0
        };
        let mut n = [[[0.0; 3]; 3]; 3];
        for (s, plane) in n.iter_mut().enumerate() {
            for (y, row) in plane.iter_mut().enumerate() {
                for (x, v) in row.iter_mut().enumerate() {
                    *v = f(x as f32 - 1.0, y as f32 - 1.0, s as f32 - 1.0);
                }
            }
        }
        let fit = QuadraticFit::new(&n);
        let offset = fit.offset().unwrap();
        assert!((offset - Vector3::new(x0, y0, s0)).norm() < 1e-5, "{offset:?}");
        assert!((n[1][1][1] + fit.gain(&offset) - (-1.0)).abs() < 1e-5);
        assert!(!is_extremum(&n, true));
        n[1][1][1] = -5.0;
        assert!(is_extremum(&n, false));
    }

    /// A keypoint for tests of matching, which reads only the descriptors.
    const KEYPOINT: Keypoint = Keypoint {
        x: 0.0,
        y: 0.0,
        sigma: 1.0,
        angle: 0.0,
        response: 1.0,
        octave: 0,
    };

    /// The ratio test keeps a distinctive match and drops an ambiguous one.
    #[test]
    fn ratio_test() {
        let kp = KEYPOINT;
        let a = Features {
            keypoints: vec![kp; 2],
            length: 2,
            descriptors: vec![1.0, 0.0, 0.0, 1.0],
        };
        let b = Features {
            keypoints: vec![kp; 3],
            length: 2,
            descriptors: vec![0.99, 0.01, 0.0, 0.9, 0.05, 0.9],
        };
        assert_eq!(a.match_ratio(&b, 0.8), vec![(0, 0)]);
    }

    /// The early exit changes nothing: on seeded 128- and 61-value descriptors (a tail past the
    /// lanes), matches equal those of a plain search over every full distance.
    #[test]
    fn early_exit_matches_a_full_search() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let kp = KEYPOINT;
        for length in [128, 61] {
            let mut features = |n: usize| Features {
                keypoints: vec![kp; n],
                length,
                descriptors: (0..n * length).map(|_| next()).collect(),
            };
            let (a, mut b) = (features(60), features(80));
            // A few near copies, so that some matches pass the ratio test.
            for i in 0..10 {
                for k in 0..length {
                    b.descriptors[(3 * i) * length + k] = a.descriptors[i * length + k] + 0.01 * (k % 3) as f32;
                }
            }
            let full = |x: &[f32], y: &[f32]| x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum::<f32>();
            let expected: Vec<(usize, usize)> = (0..60)
                .filter_map(|i| {
                    let mut d: Vec<(f32, usize)> =
                        (0..80).map(|j| (full(a.descriptor(i), b.descriptor(j)), j)).collect();
                    d.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
                    (d[0].0 < 0.64 * d[1].0).then_some((i, d[0].1))
                })
                .collect();
            let found = a.match_ratio(&b, 0.8);
            assert!(found.len() >= 10, "{length}: {found:?}");
            assert_eq!(found, expected, "{length}");
        }
    }
}
