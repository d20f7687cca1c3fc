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
    /// ratio 0.8). Brute force: O(n·m), fine for the few thousand features of one image.
    pub fn match_ratio(&self, other: &Features, ratio: f32) -> Vec<(usize, usize)> {
        if self.length != other.length || other.keypoints.len() < 2 {
            return Vec::new();
        }
        let squared = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f32>();
        (0..self.keypoints.len())
            .filter_map(|i| {
                let a = self.descriptor(i);
                let (mut best, mut second, mut best_j) = (f32::INFINITY, f32::INFINITY, 0);
                for j in 0..other.keypoints.len() {
                    let d = squared(a, other.descriptor(j));
                    if d < best {
                        (second, best, best_j) = (best, d, j);
                    } else if d < second {
                        second = d;
                    }
                }
                (best < ratio * ratio * second).then_some((i, best_j))
            })
            .collect()
    }
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

    /// The ratio test keeps a distinctive match and drops an ambiguous one.
    #[test]
    fn ratio_test() {
        let kp = Keypoint {
            x: 0.0,
            y: 0.0,
            sigma: 1.0,
            angle: 0.0,
            response: 1.0,
            octave: 0,
        };
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
}
