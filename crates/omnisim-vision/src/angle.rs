//! Gradient directions in degrees without libm's `atan2f`, for the descriptors that take one
//! per pixel or sample (SIFT, HOG).

/// Coefficients of atan(c) ≈ c·(A1 + c²·(A3 + c²·(A5 + c²·A7))) on 0 ≤ c ≤ 1, radians: the
/// odd polynomial of degree 7 of least largest error that is exact at c = 1 (so that
/// diagonals are 45° exactly), fitted here by Lawson's reweighted least squares on 4000
/// Chebyshev nodes; 9.1e-5 rad = 0.0052° at most.
const ATAN: [f32; 4] = [0.999_135_9, -0.320_366_86, 0.144_291_28, -0.037_662_2];

/// atan2(y, x) in degrees, 0 ≤ a < 360, within 0.0053° (plus f32 rounding): the polynomial
/// [`ATAN`] on the ratio of the smaller to the larger of |x| and |y|, folded into the octant.
/// libm's `atan2f` was a fifth of SIFT's time once its blur was vectorised, and most
/// of HOG's; `OpenCV`'s SIFT and its `cartToPolar` also use a polynomial (`fastAtan2`, 0.01° at
/// most).
pub(crate) fn atan2_degrees(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (small, large) = if ax >= ay { (ay, ax) } else { (ax, ay) };
    // Selects rather than an early return, so that loops over many angles vectorise.
    let c = if large > 0.0 { small / large } else { 0.0 };
    let c2 = c * c;
    let mut a = (c * (ATAN[0] + c2 * (ATAN[1] + c2 * (ATAN[2] + c2 * ATAN[3])))).to_degrees();
    if ay > ax {
        a = 90.0 - a;
    }
    if x < 0.0 {
        a = 180.0 - a;
    }
    if y < 0.0 {
        a = 360.0 - a;
    }
    if a >= 360.0 { a - 360.0 } else { a }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The polynomial atan2 against f64's on a fine turn, the axes and both signed zeros:
    /// within 0.0053° (circularly), always in [0, 360), and the diagonals exact.
    #[test]
    fn polynomial_atan2_is_within_its_bound() {
        let mut worst = 0.0f64;
        for k in 0..36_000 {
            let turn = f64::from(k) / 100.0 + 0.003;
            for length in [1e-3f64, 1.0, 700.0] {
                let (y, x) = (
                    (turn.to_radians().sin() * length) as f32,
                    (turn.to_radians().cos() * length) as f32,
                );
                let got = f64::from(atan2_degrees(y, x));
                assert!((0.0..360.0).contains(&got), "{got}");
                let exact = f64::from(y).atan2(f64::from(x)).to_degrees().rem_euclid(360.0);
                let gap = (got - exact).abs();
                worst = worst.max(gap.min(360.0 - gap));
            }
        }
        assert!(worst < 0.0053, "{worst}°");
        let axes = [
            (0.0, 1.0, 0.0),
            (1.0, 0.0, 90.0),
            (0.0, -1.0, 180.0),
            (-1.0, 0.0, 270.0),
            (0.0, 0.0, 0.0),
            (-0.0, 2.0, 0.0),
            (3.0, 3.0, 45.0),
            (-3.0, 3.0, 315.0),
            (3.0, -3.0, 135.0),
        ];
        for (y, x, expected) in axes {
            assert!((atan2_degrees(y, x) - expected).abs() < 1e-3, "({y}, {x})");
        }
    }
}
