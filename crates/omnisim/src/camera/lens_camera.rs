//! A camera with a lens model (fisheye, distorted pinhole, …), mounted like the pinhole:
//! optical frame x right, y down, z forward, looking along body +x.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::CameraRay;
use super::lens::LensModel;
use super::pinhole::{BODY_FROM_OPTICAL, Pinhole};

/// A pixel whose ray, projected again, lands farther than this from its centre has no ray:
/// the last guard against a wrapped ray at the edge of a lens's field of view.
const ROUND_TRIP_PX: f64 = 1e-6;

/// The pixel of optical-frame direction `optical` through `model` and K (`focal`, `centre`);
/// `None` outside the valid field of view.
pub(crate) fn pixel_through(model: &LensModel, focal: DVec2, centre: DVec2, optical: DVec3) -> Option<DVec2> {
    let m = model.project(optical)?;
    Some(DVec2::new(focal.x * m.x + centre.x, focal.y * m.y + centre.y))
}

/// The optical-frame ray of `pixel` through `model` and K (`focal`, `centre`): the model's
/// [`LensModel::towards`] and its unit direction; `None` outside the valid field of view, or
/// where the unit direction does not project back within [`ROUND_TRIP_PX`] of the pixel. Lens
/// cameras and a mirror's inner lens share it.
pub(crate) fn lens_ray(model: &LensModel, focal: DVec2, centre: DVec2, pixel: DVec2) -> Option<(DVec3, DVec3)> {
    let towards = model.towards(DVec2::new(
        (pixel.x - centre.x) / focal.x,
        (pixel.y - centre.y) / focal.y,
    ))?;
    let direction = towards.normalize();
    let back = pixel_through(model, focal, centre, direction.is_finite().then_some(direction)?)?;
    ((back - pixel).length() <= ROUND_TRIP_PX).then_some((towards, direction))
}

/// A central camera with a lens model: pixel = (fx·mx + cx, fy·my + cy) for the model's
/// normalised image point m.
#[derive(Debug, Clone, PartialEq)]
pub struct LensCamera {
    /// Size, K (fx fy cx cy) and optical centre, as a pinhole has them (Scaramuzza's model,
    /// whose polynomial is in pixels, has fx = fy = 1).
    pub intrinsics: Pinhole,
    /// The lens.
    pub model: LensModel,
}

impl LensCamera {
    /// The unit optical-frame direction seen at `pixel`, or `None` outside the lens's valid
    /// field of view.
    pub fn optical_direction(&self, pixel: DVec2) -> Option<DVec3> {
        let k = &self.intrinsics;
        let (_, direction) = lens_ray(&self.model, DVec2::new(k.fx, k.fy), DVec2::new(k.cx, k.cy), pixel)?;
        Some(direction)
    }

    /// The ray of pixel (u, v) in the body frame; `None` where the lens maps no ray there
    /// (the pixel is background).
    pub fn ray(&self, pixel: DVec2) -> Option<CameraRay> {
        let direction = self.optical_direction(pixel)?;
        Some(CameraRay {
            origin: self.intrinsics.position,
            direction: BODY_FROM_OPTICAL * direction,
            t_min: 0.0,
        })
    }

    fn pixel_of_optical(&self, optical: DVec3) -> Option<DVec2> {
        let k = &self.intrinsics;
        pixel_through(&self.model, DVec2::new(k.fx, k.fy), DVec2::new(k.cx, k.cy), optical)
    }

    /// Pixel of a body-frame point; `None` outside the valid field of view.
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        self.pixel_of_optical(BODY_FROM_OPTICAL.transpose() * (point - self.intrinsics.position))
    }

    /// How many pixels of the image see no ray (beyond the lens's field of view): they are
    /// background in every output.
    pub fn pixels_without_ray(&self) -> u64 {
        let width = self.intrinsics.width;
        (0..self.intrinsics.height)
            .into_par_iter()
            .map(|row| {
                (0..width)
                    .filter(|&column| {
                        self.optical_direction(DVec2::new(f64::from(column), f64::from(row)))
                            .is_none()
                    })
                    .count() as u64
            })
            .sum()
    }

    /// Image size (width, height), pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.intrinsics.width, self.intrinsics.height)
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{FRAC_PI_2, PI};

    use glam::{dvec2, dvec3};

    use super::*;
    use crate::camera::{BrownConrady, KannalaBrandt, Scaramuzza};

    const WIDTH: u32 = 240;
    const HEIGHT: u32 = 200;

    /// A camera whose image circle (the valid field of view's edge) has radius 90 px, so the
    /// image's corners lie beyond it.
    fn camera(model: LensModel) -> LensCamera {
        let (cx, cy) = (119.5, 99.5);
        let (focal, aspect) = match model {
            LensModel::Scaramuzza(_) => (1.0, 1.0),
            // A perspective lens: 50° off axis at 90 px (its field of view reaches 90°).
            LensModel::Perspective(_) => (90.0 / model.radius_at(50f64.to_radians()).expect("inside"), 1.02),
            _ => {
                let edge = model.max_angle().min(175f64.to_radians()) * (1.0 - 1e-9);
                (90.0 / model.radius_at(edge).expect("the edge has a radius"), 1.02)
            }
        };
        LensCamera {
            intrinsics: Pinhole {
                position: DVec3::ZERO,
                width: WIDTH,
                height: HEIGHT,
                fx: focal,
                fy: focal * aspect,
                cx,
                cy,
            },
            model,
        }
    }

    fn scaramuzza() -> LensModel {
        // OCamCalib's example calibration (a fisheye past 180°), affine slightly off identity.
        let pol = [-69.0, 0.0, 5.6e-3, -1.0e-5, 1.5e-8];
        LensModel::Scaramuzza(Scaramuzza::new(&pol, (1.0003, 2e-4, -1e-4), 160.0).expect("valid"))
    }

    /// Every model, with parameters that see past 180° where the model can.
    fn models() -> Vec<LensModel> {
        vec![
            LensModel::Perspective(BrownConrady::new(&[-0.3, 0.09, 1e-3, -2e-3]).expect("radtan")),
            LensModel::Perspective(
                BrownConrady::new(&[-0.28, 0.07, 1e-3, -2e-3, 0.01, 0.02, -0.01, 0.005]).expect("rational"),
            ),
            LensModel::Perspective(
                BrownConrady::new(&[
                    -0.28, 0.07, 1e-3, -2e-3, 0.01, 0.02, -0.01, 0.005, 1e-3, -1e-3, 2e-3, 5e-4,
                ])
                .expect("thin prism"),
            ),
            LensModel::KannalaBrandt(KannalaBrandt::new([0.02, -0.004, 1e-4, -2e-5]).expect("kb")),
            LensModel::Equidistant,
            LensModel::Equisolid,
            LensModel::Stereographic,
            LensModel::Orthographic,
            LensModel::DoubleSphere { xi: -0.2, alpha: 0.6 },
            LensModel::ExtendedUnified { alpha: 0.6, beta: 1.1 },
            LensModel::Unified {
                xi: 1.3,
                distortion: BrownConrady::new(&[-0.05, 0.01, 1e-4, -2e-4]).expect("radtan"),
            },
            scaramuzza(),
        ]
    }

    #[test]
    fn every_pixel_with_a_ray_projects_back_to_itself_within_1e_9_px() {
        for model in models() {
            let camera = camera(model);
            let name = camera.model.name();
            let (mut rays, mut past_90, mut worst) = (0, 0, 0.0_f64);
            for v in 0..HEIGHT {
                for u in 0..WIDTH {
                    let pixel = dvec2(f64::from(u), f64::from(v));
                    let Some(direction) = camera.optical_direction(pixel) else {
                        continue;
                    };
                    rays += 1;
                    past_90 += usize::from(direction.z < 0.0);
                    let back = camera.pixel_of_optical(direction).expect("inside");
                    worst = worst.max((back - pixel).length());
                }
            }
            assert!(worst <= 1e-9, "{name}: a pixel projects back {worst:e} px away");
            let without = camera.pixels_without_ray();
            assert_eq!(rays as u64 + without, u64::from(WIDTH * HEIGHT), "{name}");
            if let LensModel::Perspective(_) | LensModel::Stereographic | LensModel::Scaramuzza(_) = camera.model {
                // Every pixel has a ray: the pinhole's and stereographic's images are unbounded,
                // and this polynomial still rises at the image's corners.
                assert_eq!(without, 0, "{name}: every pixel has a ray");
            } else {
                assert!(without > 0 && rays > 20_000, "{name}: {rays} rays, {without} without");
            }
            let max_angle = camera.model.max_angle();
            if max_angle > FRAC_PI_2 + 0.05 {
                assert!(
                    past_90 > 100,
                    "{name}: only {past_90} rays past 90° (field of view {max_angle})"
                );
            }
            eprintln!(
                "{name}: {rays} rays ({past_90} past 90°), {without} background, valid to {:.2}°",
                max_angle.to_degrees()
            );
        }
    }

    #[test]
    fn directions_inside_the_field_of_view_come_back_and_outside_have_no_pixel() {
        for model in models() {
            let name = model.name();
            let max_angle = model.max_angle();
            for i in 1..200 {
                let theta = max_angle * f64::from(i) / 200.0;
                let phi = f64::from(i) * 2.4;
                let direction = dvec3(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                if let LensModel::Perspective(_) = model {
                    // Symmetric only radially: the fold of p1, p2, s1..s4 is not at one angle.
                    if theta > max_angle * 0.9 {
                        continue;
                    }
                }
                let m = model
                    .project(direction)
                    .unwrap_or_else(|| panic!("{name}: θ = {theta}"));
                let back = model.unproject(m).unwrap_or_else(|| panic!("{name}: θ = {theta}"));
                assert!(
                    (back - direction).length() < 1e-9,
                    "{name}: θ = {theta}: {back} vs {direction}"
                );
            }
            let beyond = max_angle + 0.01;
            if beyond < PI {
                let direction = dvec3(beyond.sin(), 0.0, beyond.cos());
                assert_eq!(
                    model.project(direction),
                    None,
                    "{name}: {beyond} is beyond the field of view"
                );
            }
        }
    }

    #[test]
    fn a_lens_whose_circle_misses_the_image_is_refused_with_its_field_of_view() {
        let mut lens = camera(LensModel::Orthographic);
        lens.intrinsics.cx = 5000.0;
        let message = lens.validate().expect_err("no pixel sees").to_string();
        assert!(
            message.contains("orthographic") && message.contains("90.0°"),
            "{message}"
        );
        assert!(camera(LensModel::Orthographic).validate().is_ok());
    }

    #[test]
    fn double_sphere_is_the_papers_equations() {
        // Usenko, Demmel, Cremers 2018, eqs. (40)-(50), written out.
        let (xi, alpha) = (-0.2_f64, 0.6_f64);
        let model = LensModel::DoubleSphere { xi, alpha };
        let w1 = if alpha <= 0.5 {
            alpha / (1.0 - alpha)
        } else {
            (1.0 - alpha) / alpha
        };
        let w2 = (w1 + xi) / (2.0 * w1 * xi + xi * xi + 1.0).sqrt();
        for (x, y, z) in [
            (0.3_f64, -0.2_f64, 1.0_f64),
            (1.0, 0.5, 0.1),
            (0.7, 0.2, -0.4),
            (-0.1, 0.9, -0.3),
        ] {
            let d1 = (x * x + y * y + z * z).sqrt();
            assert!(z > -w2 * d1);
            let d2 = (x * x + y * y + (xi * d1 + z) * (xi * d1 + z)).sqrt();
            let denominator = alpha * d2 + (1.0 - alpha) * (xi * d1 + z);
            let expected = dvec2(x / denominator, y / denominator);
            let m = model.project(dvec3(x, y, z)).expect("valid");
            assert!((m - expected).length() < 1e-14);
            let (mx, my) = (expected.x, expected.y);
            let r2 = mx * mx + my * my;
            let mz = (1.0 - alpha * alpha * r2) / (alpha * (1.0 - (2.0 * alpha - 1.0) * r2).sqrt() + 1.0 - alpha);
            let factor = (mz * xi + (mz * mz + (1.0 - xi * xi) * r2).sqrt()) / (mz * mz + r2);
            let ray = dvec3(factor * mx, factor * my, factor * mz - xi).normalize();
            assert!((model.unproject(m).expect("valid") - ray).length() < 1e-14);
            assert!((ray - dvec3(x, y, z) / d1).length() < 1e-12);
        }
        // Just outside the paper's valid set z > -w2 d1.
        let theta = (-w2).acos() + 1e-6;
        assert_eq!(model.project(dvec3(theta.sin(), 0.0, theta.cos())), None);
    }

    #[test]
    fn extended_unified_is_the_papers_equations() {
        // Khomenko et al. 2016 as Usenko et al. 2018 write it (eqs. 33-39).
        let (alpha, beta) = (0.6_f64, 1.1_f64);
        let model = LensModel::ExtendedUnified { alpha, beta };
        let w = if alpha <= 0.5 {
            alpha / (1.0 - alpha)
        } else {
            (1.0 - alpha) / alpha
        };
        for (x, y, z) in [(0.3_f64, -0.2_f64, 1.0_f64), (1.0, 0.5, 0.1), (0.7, 0.2, -0.3)] {
            let d = (beta * (x * x + y * y) + z * z).sqrt();
            assert!(z > -w * d);
            let denominator = alpha * d + (1.0 - alpha) * z;
            let expected = dvec2(x / denominator, y / denominator);
            let m = model.project(dvec3(x, y, z)).expect("valid");
            assert!((m - expected).length() < 1e-14);
            let r2 = expected.length_squared();
            let mz = (1.0 - beta * alpha * alpha * r2)
                / (alpha * (1.0 - (2.0 * alpha - 1.0) * beta * r2).sqrt() + (1.0 - alpha));
            let ray = dvec3(expected.x, expected.y, mz).normalize();
            assert!((model.unproject(m).expect("valid") - ray).length() < 1e-14);
            assert!((ray - dvec3(x, y, z).normalize()).length() < 1e-12);
        }
    }

    #[test]
    fn kannala_brandt_is_opencv_fisheye_in_front_of_the_camera() {
        // cv::fisheye::projectPoints: a = x/z, b = y/z, r = |(a,b)|, θ = atan(r),
        // θd = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸), x' = (θd/r)·a.
        let k = [0.02, -0.004, 1e-4, -2e-5];
        let model = LensModel::KannalaBrandt(KannalaBrandt::new(k).expect("valid"));
        for (x, y, z) in [(0.3_f64, -0.2_f64, 1.0_f64), (2.0, 0.5, 0.3), (-0.1, 0.05, 2.0)] {
            let (a, b) = (x / z, y / z);
            let r = (a * a + b * b).sqrt();
            let theta = r.atan();
            let t2 = theta * theta;
            let theta_d = theta * (1.0 + k[0] * t2 + k[1] * t2 * t2 + k[2] * t2.powi(3) + k[3] * t2.powi(4));
            let expected = dvec2(theta_d / r * a, theta_d / r * b);
            assert!((model.project(dvec3(x, y, z)).expect("valid") - expected).length() < 1e-14);
        }
    }

    #[test]
    fn scaramuzza_unprojection_is_ocamcalibs_cam2world() {
        let pol = [-69.0, 0.0, 5.6e-3, -1.0e-5, 1.5e-8];
        let (c, d, e) = (1.0003, 2e-4, -1e-4);
        let camera = camera(scaramuzza());
        // ocam_functions.c cam2world, with point2D = (row, column).
        let (xc, yc) = (camera.intrinsics.cy, camera.intrinsics.cx);
        for (row, column) in [(30.0, 40.0), (99.5, 200.0), (150.0, 119.5)] {
            let inverse = 1.0 / (c - d * e);
            let xp = inverse * ((row - xc) - d * (column - yc));
            let yp = inverse * (-e * (row - xc) + c * (column - yc));
            let rho = (xp * xp + yp * yp).sqrt();
            let zp = pol.iter().rev().fold(0.0, |sum, a| sum * rho + a);
            let ocam = dvec3(xp, yp, zp).normalize();
            let optical = camera.optical_direction(dvec2(column, row)).expect("inside");
            assert!((optical - dvec3(ocam.y, ocam.x, -ocam.z)).length() < 1e-14);
        }
    }
}
