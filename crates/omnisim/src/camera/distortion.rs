//! Brown–Conrady lens distortion exactly as `OpenCV`'s `projectPoints` applies it to normalised
//! image coordinates (x, y) = (X/Z, Y/Z): radial k1 k2 k3 over the rational k4 k5 k6,
//! tangential p1 p2 (decentring) and thin prism s1–s4. The same map is Kalibr's `radtan`
//! (k1 k2 p1 p2) on the pinhole and on Mei's unified sphere.
//!
//! Distortion has no closed-form inverse: [`BrownConrady::undistort`] starts from the inverse
//! of the radial part (monotone, one variable) and polishes with Newton's method on the whole
//! map, and answers `None` unless it converged inside the valid region (where the radial map
//! still increases), so a pixel beyond the lens's reach is background, never a folded ray.

use glam::{DMat2, DVec2, dvec2};

use super::CameraError;
use super::solve::{first_non_increase, increasing_inverse};

/// Coefficient names in `OpenCV`'s order.
pub const COEFFICIENT_NAMES: [&str; 12] = ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4"];

/// How many coefficients a distortion vector may have (`OpenCV`'s 4, 5, 8 and 12).
pub const COEFFICIENT_COUNTS: [usize; 4] = [4, 5, 8, 12];

/// Largest |coefficient| accepted: beyond this the map is numerically meaningless.
const COEFFICIENT_LIMIT: f64 = 1e6;

/// Angles sampled along the radius when finding where the radial map stops increasing.
const RADIAL_SAMPLES: usize = 20_000;

/// Largest undistorted radius considered (89.99999° off axis on a pinhole).
const RADIUS_CAP: f64 = 1e7;

/// Brown–Conrady coefficients and the undistorted radius up to which the map is one-to-one.
#[derive(Debug, Clone, PartialEq)]
pub struct BrownConrady {
    /// k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4, absent ones zero.
    coefficients: [f64; 12],
    /// How many the user gave (4, 5, 8 or 12): what exports write.
    given: usize,
    /// Undistorted radius where r·radial(r) stops increasing (the valid field of view).
    max_radius: f64,
}

impl BrownConrady {
    /// Distortion from `OpenCV`'s vector (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4]]]).
    pub fn new(coefficients: &[f64]) -> Result<Self, CameraError> {
        if !COEFFICIENT_COUNTS.contains(&coefficients.len()) {
            return Err(CameraError::Method(
                "distortion takes 4 (k1,k2,p1,p2), 5 (+k3), 8 (+k4,k5,k6) or 12 (+s1,s2,s3,s4) coefficients, OpenCV's order",
            ));
        }
        for (name, &value) in COEFFICIENT_NAMES.iter().zip(coefficients) {
            if value.is_nan() || value.abs() > COEFFICIENT_LIMIT {
                return Err(CameraError::Range {
                    name,
                    value,
                    range: (-COEFFICIENT_LIMIT, COEFFICIENT_LIMIT),
                    unit: "(distortion coefficient)",
                });
            }
        }
        let mut all = [0.0; 12];
        all[..coefficients.len()].copy_from_slice(coefficients);
        let mut distortion = Self {
            coefficients: all,
            given: coefficients.len(),
            max_radius: RADIUS_CAP,
        };
        // Sampled in the angle off axis, atan(r), so small radii get as many samples as large.
        let turn = first_non_increase(
            |angle| distortion.radial_slope(angle.tan()),
            RADIUS_CAP.atan(),
            RADIAL_SAMPLES,
        );
        distortion.max_radius = turn.tan().min(RADIUS_CAP);
        Ok(distortion)
    }

    /// No distortion.
    pub fn none() -> Self {
        Self {
            coefficients: [0.0; 12],
            given: 4,
            max_radius: RADIUS_CAP,
        }
    }

    /// Whether every coefficient is zero.
    pub fn is_none(&self) -> bool {
        self.coefficients.iter().all(|&c| c == 0.0)
    }

    /// The coefficients as given (4, 5, 8 or 12 of them, `OpenCV`'s order).
    pub fn coefficients(&self) -> &[f64] {
        &self.coefficients[..self.given]
    }

    /// k1 k2 p1 p2 where no further coefficient is non-zero: the radtan distortion of Kalibr
    /// and `cv::omnidir`; `None` otherwise.
    pub fn radtan(&self) -> Option<[f64; 4]> {
        let [k1, k2, p1, p2, further @ ..] = self.coefficients;
        further.iter().all(|&c| c == 0.0).then_some([k1, k2, p1, p2])
    }

    /// The undistorted radius (normalised coordinates) beyond which the map folds back.
    pub fn max_radius(&self) -> f64 {
        self.max_radius
    }

    /// The radial factor (1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶) and its
    /// derivative in r².
    fn radial(&self, r2: f64) -> (f64, f64) {
        let [k1, k2, _, _, k3, k4, k5, k6, ..] = self.coefficients;
        let numerator = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let denominator = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
        let numerator_slope = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
        let denominator_slope = k4 + r2 * (2.0 * k5 + r2 * 3.0 * k6);
        (
            numerator / denominator,
            (numerator_slope * denominator - numerator * denominator_slope) / (denominator * denominator),
        )
    }

    /// d/dr of r·radial(r); negative where the rational denominator is not positive (a pole).
    fn radial_slope(&self, r: f64) -> f64 {
        let [_, _, _, _, _, k4, k5, k6, ..] = self.coefficients;
        let r2 = r * r;
        if 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)) <= 0.0 {
            return -1.0;
        }
        let (factor, slope) = self.radial(r2);
        factor + 2.0 * r2 * slope
    }

    /// Distorted normalised coordinates of undistorted `point` (`OpenCV`'s formula).
    pub fn distort(&self, point: DVec2) -> DVec2 {
        let [_, _, p1, p2, _, _, _, _, s1, s2, s3, s4] = self.coefficients;
        let (x, y) = (point.x, point.y);
        let r2 = x * x + y * y;
        let (factor, _) = self.radial(r2);
        dvec2(
            x * factor + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (s1 + s2 * r2),
            y * factor + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (s3 + s4 * r2),
        )
    }

    /// Jacobian of [`Self::distort`] at `point` (columns: d/dx, d/dy).
    fn jacobian(&self, point: DVec2) -> DMat2 {
        let [_, _, p1, p2, _, _, _, _, s1, s2, s3, s4] = self.coefficients;
        let (x, y) = (point.x, point.y);
        let r2 = x * x + y * y;
        let (factor, slope) = self.radial(r2);
        let prism_x = s1 + 2.0 * s2 * r2;
        let prism_y = s3 + 2.0 * s4 * r2;
        let dx_dx = factor + 2.0 * x * x * slope + 2.0 * p1 * y + 6.0 * p2 * x + 2.0 * x * prism_x;
        let dx_dy = 2.0 * x * y * slope + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * y * prism_x;
        let dy_dx = 2.0 * x * y * slope + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * x * prism_y;
        let dy_dy = factor + 2.0 * y * y * slope + 6.0 * p1 * y + 2.0 * p2 * x + 2.0 * y * prism_y;
        DMat2::from_cols(dvec2(dx_dx, dy_dx), dvec2(dx_dy, dy_dy))
    }

    /// Distorted coordinates of `point`, or `None` beyond the valid region: past the radial
    /// fold, or where the tangential and prism terms fold the map first (Jacobian not positive).
    pub fn distort_checked(&self, point: DVec2) -> Option<DVec2> {
        (point.length() <= self.max_radius && self.jacobian(point).determinant() > 0.0).then(|| self.distort(point))
    }

    /// The undistorted point whose distortion is `distorted`, inside the valid radius; `None`
    /// where no such point exists or Newton's method did not converge.
    pub fn undistort(&self, distorted: DVec2) -> Option<DVec2> {
        if self.is_none() {
            return Some(distorted);
        }
        // The radial part alone, inverted along the ray through `distorted`.
        let radius = distorted.length();
        let mut point = if radius > 0.0 {
            let undistorted = increasing_inverse(
                |r| r * self.radial(r * r).0,
                |r| self.radial_slope(r),
                radius,
                (0.0, self.max_radius),
            )
            .unwrap_or(self.max_radius.min(radius));
            distorted * (undistorted / radius)
        } else {
            distorted
        };
        let tolerance = 8.0 * f64::EPSILON * radius.max(1.0);
        let mut best = (f64::INFINITY, point);
        for _ in 0..60 {
            let residual = self.distort(point) - distorted;
            let size = residual.length();
            if size < best.0 {
                best = (size, point);
            }
            if size <= tolerance {
                break;
            }
            let jacobian = self.jacobian(point);
            if jacobian.determinant().abs() < f64::MIN_POSITIVE {
                break;
            }
            point -= jacobian.inverse() * residual;
            if !point.is_finite() {
                break;
            }
        }
        let (residual, point) = best;
        (residual <= 1e-13 * radius.max(1.0)
            && point.length() <= self.max_radius
            && self.jacobian(point).determinant() > 0.0)
            .then_some(point)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strong() -> BrownConrady {
        BrownConrady::new(&[
            -0.28, 0.07, 1e-3, -2e-3, 0.01, 0.02, -0.01, 0.005, 1e-3, -1e-3, 2e-3, 5e-4,
        ])
        .expect("valid")
    }

    #[test]
    fn distortion_matches_opencv_formula_written_out() {
        // OpenCV's projectPoints, term by term, for the 12-coefficient model.
        let (k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4) = (
            -0.28, 0.07, 1e-3, -2e-3, 0.01, 0.02, -0.01, 0.005, 1e-3, -1e-3, 2e-3, 5e-4,
        );
        let (x, y) = (0.31_f64, -0.22_f64);
        let r2 = x * x + y * y;
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        let radial = (1.0 + k1 * r2 + k2 * r4 + k3 * r6) / (1.0 + k4 * r2 + k5 * r4 + k6 * r6);
        let expected = dvec2(
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + s1 * r2 + s2 * r4,
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * r2 + s4 * r4,
        );
        assert!((strong().distort(dvec2(x, y)) - expected).length() < 1e-15);
    }

    #[test]
    fn undistort_inverts_distort_inside_the_valid_radius() {
        // Barrel radtan folds at a finite radius; the strong rational model does not fold
        // before 90° off axis, so it is checked up to r = 2 (63°).
        let radtan = BrownConrady::new(&[-0.35, 0.05, 1e-3, -2e-3]).expect("valid");
        assert!(
            radtan.max_radius() > 1.0 && radtan.max_radius() < 3.0,
            "{}",
            radtan.max_radius()
        );
        for distortion in [radtan, strong()] {
            let limit = distortion.max_radius().min(2.0);
            for i in 0..40 {
                for j in 0..40 {
                    let angle = f64::from(i) * std::f64::consts::TAU / 40.0;
                    // The tangential terms move the fold by about p·r: stay 5 % inside it.
                    let r = limit * 0.95 * f64::from(j) / 39.0;
                    let point = dvec2(r * angle.cos(), r * angle.sin());
                    let back = distortion.undistort(distortion.distort(point)).expect("inside");
                    assert!((back - point).length() < 1e-12, "{point} -> {back}");
                }
            }
        }
    }

    #[test]
    fn the_fold_is_refused_both_ways() {
        // Barrel distortion k1 = -0.3 folds at r = 1/sqrt(0.9).
        let distortion = BrownConrady::new(&[-0.3, 0.0, 0.0, 0.0]).expect("valid");
        assert!((distortion.max_radius() - (1.0_f64 / 0.9).sqrt()).abs() < 1e-9);
        let peak = distortion.distort(dvec2(distortion.max_radius(), 0.0)).x;
        assert_eq!(distortion.undistort(dvec2(peak * 1.01, 0.0)), None);
        assert_eq!(distortion.distort_checked(dvec2(1.2, 0.0)), None);
    }

    #[test]
    fn wrong_lengths_and_huge_values_are_refused() {
        assert!(BrownConrady::new(&[0.1, 0.2, 0.3]).is_err());
        assert!(BrownConrady::new(&[0.1, 0.2, 0.0, f64::NAN]).is_err());
        assert!(BrownConrady::new(&[1e9, 0.0, 0.0, 0.0]).is_err());
    }
}
