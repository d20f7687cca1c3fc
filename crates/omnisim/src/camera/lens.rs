//! Central lens models: how a direction in the optical frame (x right, y down, z forward)
//! maps to normalised image coordinates m, with pixel = (fx·mx + cx, fy·my + cy), and back.
//!
//! Each model follows its paper or reference code (docs/cameras.md gives the equations):
//! Brown–Conrady on a perspective lens (`OpenCV` `projectPoints`), Kannala–Brandt
//! (`OpenCV` `cv::fisheye`, Kalibr `equi`), the ideal equidistant, equisolid, stereographic
//! and orthographic fisheyes, the double sphere (Usenko, Demmel, Cremers 2018), the extended
//! unified model (Khomenko et al. 2016), Mei's unified model with radtan (Kalibr
//! `omni-radtan`, `cv::omnidir`) and Scaramuzza's polynomial (`OCamCalib`). Inverses are
//! closed-form where the paper gives one; otherwise the f64 solvers of `solve.rs` and
//! `distortion.rs`, which answer `None` outside the valid field of view.

use std::f64::consts::PI;

use glam::{DVec2, DVec3, dvec2, dvec3};

use super::CameraError;
use super::distortion::BrownConrady;
use super::solve::{first_non_increase, increasing_inverse};
use super::validate::within;

/// Samples along θ (or ρ) when finding where a polynomial lens stops increasing.
const LIMIT_SAMPLES: usize = 8192;

/// A central lens model in normalised image coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum LensModel {
    /// A perspective lens with Brown–Conrady distortion (`OpenCV` `projectPoints`).
    Perspective(BrownConrady),
    /// Kannala–Brandt: r = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸) (`OpenCV` fisheye, Kalibr `equi`).
    KannalaBrandt(KannalaBrandt),
    /// Ideal equidistant fisheye, r = θ.
    Equidistant,
    /// Ideal equisolid-angle fisheye, r = 2 sin(θ/2).
    Equisolid,
    /// Ideal stereographic fisheye, r = 2 tan(θ/2).
    Stereographic,
    /// Ideal orthographic fisheye, r = sin θ (at most a hemisphere).
    Orthographic,
    /// Double sphere (Usenko, Demmel, Cremers 2018).
    DoubleSphere {
        /// ξ, the second sphere's offset.
        xi: f64,
        /// α, the image plane's offset.
        alpha: f64,
    },
    /// Extended unified camera model (Khomenko, Garcia, Sturm 2016).
    ExtendedUnified {
        /// α.
        alpha: f64,
        /// β, the ellipsoid's shape.
        beta: f64,
    },
    /// Mei's unified model with radtan distortion on the sphere's projection (Kalibr
    /// `omni-radtan`, `cv::omnidir`).
    Unified {
        /// ξ, the sphere's offset.
        xi: f64,
        /// k1 k2 p1 p2 applied to the projected sphere point.
        distortion: BrownConrady,
    },
    /// Scaramuzza's polynomial (`OCamCalib`); normalised coordinates are pixel offsets from the
    /// centre (the camera's focal lengths are 1).
    Scaramuzza(Scaramuzza),
}

/// Kannala–Brandt coefficients and the angle where `θ_d(θ)` stops increasing.
#[derive(Debug, Clone, PartialEq)]
pub struct KannalaBrandt {
    k: [f64; 4],
    theta_max: f64,
}

impl KannalaBrandt {
    /// The model with k1..k4; its valid field of view is where `θ_d(θ)` still increases, at
    /// most θ = π (the whole sphere).
    pub fn new(k: [f64; 4]) -> Result<Self, CameraError> {
        for (name, value) in ["k1", "k2", "k3", "k4"].into_iter().zip(k) {
            finite_coefficient(name, value)?;
        }
        let mut model = Self { k, theta_max: PI };
        model.theta_max = first_non_increase(|theta| model.slope(theta), PI, LIMIT_SAMPLES);
        Ok(model)
    }

    /// k1..k4.
    pub fn coefficients(&self) -> [f64; 4] {
        self.k
    }

    /// `θ_d(θ)`.
    fn distorted(&self, theta: f64) -> f64 {
        let [k1, k2, k3, k4] = self.k;
        let t2 = theta * theta;
        theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
    }

    /// `dθ_d/dθ`.
    fn slope(&self, theta: f64) -> f64 {
        let [k1, k2, k3, k4] = self.k;
        let t2 = theta * theta;
        1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
    }
}

/// `OCamCalib`'s model: `pol` (a0, a1, …) of the direct map z = −pol(ρ) (`OCamCalib`'s z points
/// away from the scene; a0 < 0), the affine (c, d, e), and the radius where the angle off
/// axis stops increasing.
#[derive(Debug, Clone, PartialEq)]
pub struct Scaramuzza {
    pol: Vec<f64>,
    affine: [f64; 3],
    rho_max: f64,
}

impl Scaramuzza {
    /// Most polynomial coefficients accepted.
    pub const MAX_COEFFICIENTS: usize = 16;

    /// The model from `OCamCalib`'s `ss` coefficients (a0 < 0) and affine c, d, e; `reach` is
    /// the largest pixel distance from the centre the image has (the valid radius is looked
    /// for up to a little beyond it).
    pub fn new(pol: &[f64], (c, d, e): (f64, f64, f64), reach: f64) -> Result<Self, CameraError> {
        if pol.len() < 2 || pol.len() > Self::MAX_COEFFICIENTS {
            return Err(CameraError::Method(
                "scaramuzza takes 2 to 16 polynomial coefficients a0,a1,... (OCamCalib's ss, a0 < 0)",
            ));
        }
        for &value in pol {
            finite_coefficient("scaramuzza polynomial coefficient", value)?;
        }
        if pol[0].is_nan() || pol[0] >= 0.0 {
            return Err(CameraError::Range {
                name: "scaramuzza a0",
                value: pol[0],
                range: (f64::NEG_INFINITY, -f64::MIN_POSITIVE),
                unit: "px (OCamCalib's a0 is negative: -focal)",
            });
        }
        for (name, value) in [("scaramuzza c", c), ("scaramuzza d", d), ("scaramuzza e", e)] {
            finite_coefficient(name, value)?;
        }
        let determinant = c - d * e;
        if determinant.is_nan() || determinant.abs() <= 1e-9 {
            return Err(CameraError::NoImage(format!(
                "the affine matrix [c d; e 1] is singular (c - d*e = {determinant})"
            )));
        }
        let mut model = Self {
            pol: pol.to_vec(),
            affine: [c, d, e],
            rho_max: 0.0,
        };
        let reach = reach.max(1.0) * 1.5 / determinant.abs().min(1.0);
        model.rho_max = first_non_increase(|rho| model.angle_slope(rho), reach, LIMIT_SAMPLES);
        Ok(model)
    }

    /// `OCamCalib`'s `ss` (a0, a1, …).
    pub fn polynomial(&self) -> &[f64] {
        &self.pol
    }

    /// The affine (c, d, e).
    pub fn affine(&self) -> (f64, f64, f64) {
        (self.affine[0], self.affine[1], self.affine[2])
    }

    /// The largest sensor radius ρ (pixels, before the affine) with a ray.
    pub fn max_rho(&self) -> f64 {
        self.rho_max
    }

    /// The sensor radius ρ seen at angle θ off the optical axis; `None` beyond the valid one.
    pub fn rho_at_angle(&self, theta: f64) -> Option<f64> {
        increasing_inverse(
            |rho| self.angle(rho),
            |rho| self.angle_slope(rho),
            theta,
            (0.0, self.rho_max),
        )
    }

    /// pol(ρ) and its derivative.
    fn pol(&self, rho: f64) -> (f64, f64) {
        let (mut value, mut slope) = (0.0, 0.0);
        for &a in self.pol.iter().rev() {
            slope = slope * rho + value;
            value = value * rho + a;
        }
        (value, slope)
    }

    /// The angle off the optical axis of sensor radius ρ: atan2(ρ, −pol(ρ)).
    fn angle(&self, rho: f64) -> f64 {
        rho.atan2(-self.pol(rho).0)
    }

    fn angle_slope(&self, rho: f64) -> f64 {
        let (value, slope) = self.pol(rho);
        (-value + rho * slope) / (rho * rho + value * value)
    }

    /// Sensor coordinates (x', y') of a pixel offset (Δcolumn, Δrow): `OCamCalib`'s cam2world,
    /// whose x' runs along rows.
    fn sensor(&self, offset: DVec2) -> DVec2 {
        let [c, d, e] = self.affine;
        let inverse = 1.0 / (c - d * e);
        let (row, column) = (offset.y, offset.x);
        dvec2(inverse * (row - d * column), inverse * (-e * row + c * column))
    }

    /// Pixel offset (Δcolumn, Δrow) of sensor coordinates (x', y'): `OCamCalib`'s world2cam.
    fn offset(&self, sensor: DVec2) -> DVec2 {
        let [c, d, e] = self.affine;
        dvec2(e * sensor.x + sensor.y, c * sensor.x + d * sensor.y)
    }
}

/// Largest |coefficient| of a polynomial lens.
const COEFFICIENT_LIMIT: f64 = 1e12;

fn finite_coefficient(name: &'static str, value: f64) -> Result<(), CameraError> {
    within(name, value, (-COEFFICIENT_LIMIT, COEFFICIENT_LIMIT), "")
}

/// w of the unified and extended unified models' valid set z > −w·d (Usenko et al. 2018).
fn unified_w(alpha: f64) -> f64 {
    if alpha <= 0.5 {
        alpha / (1.0 - alpha)
    } else {
        (1.0 - alpha) / alpha
    }
}

/// The direction at angle θ off axis towards image direction `towards` (unit, or zero).
fn direction_at(theta: f64, towards: DVec2) -> DVec3 {
    let (sin, cos) = theta.sin_cos();
    dvec3(sin * towards.x, sin * towards.y, cos)
}

impl LensModel {
    /// Checks a model's own parameters, naming the valid range.
    pub fn check(&self) -> Result<(), CameraError> {
        match self {
            LensModel::DoubleSphere { xi, alpha } => {
                within("double-sphere xi", *xi, (-1.0, 1.0), "")?;
                within("double-sphere alpha", *alpha, (0.0, 1.0 - 1e-9), "")
            }
            LensModel::ExtendedUnified { alpha, beta } => {
                within("eucm alpha", *alpha, (0.0, 1.0 - 1e-9), "")?;
                within("eucm beta", *beta, (1e-9, 1e6), "")
            }
            LensModel::Unified { xi, .. } => within("unified xi", *xi, (0.0, 1e3), ""),
            _ => Ok(()),
        }
    }

    /// Normalised image coordinates of optical-frame point `p`; `None` outside the valid
    /// field of view.
    pub fn project(&self, p: DVec3) -> Option<DVec2> {
        let radial = |theta_max: f64, image_radius: &dyn Fn(f64) -> f64| {
            let r = p.truncate().length();
            let theta = r.atan2(p.z);
            if theta > theta_max || !theta.is_finite() {
                return None;
            }
            if r == 0.0 {
                return (p.z > 0.0).then_some(DVec2::ZERO);
            }
            Some(p.truncate() * (image_radius(theta) / r))
        };
        match self {
            LensModel::Perspective(distortion) => {
                (p.z > 0.0).then_some(())?;
                distortion.distort_checked(p.truncate() / p.z)
            }
            LensModel::KannalaBrandt(model) => radial(model.theta_max, &|theta| model.distorted(theta)),
            LensModel::Equidistant => radial(PI, &|theta| theta),
            LensModel::Equisolid => radial(PI, &|theta| 2.0 * (theta / 2.0).sin()),
            LensModel::Stereographic => radial(PI * (1.0 - f64::EPSILON), &|theta| 2.0 * (theta / 2.0).tan()),
            LensModel::Orthographic => radial(PI / 2.0, &f64::sin),
            LensModel::DoubleSphere { xi, alpha } => {
                let d1 = p.length();
                let w1 = unified_w(*alpha);
                let w2 = (w1 + xi) / (2.0 * w1 * xi + xi * xi + 1.0).sqrt();
                (p.z > -w2 * d1).then_some(())?;
                let shifted = xi * d1 + p.z;
                let d2 = (p.x * p.x + p.y * p.y + shifted * shifted).sqrt();
                Some(p.truncate() / (alpha * d2 + (1.0 - alpha) * shifted))
            }
            LensModel::ExtendedUnified { alpha, beta } => {
                let d = (beta * (p.x * p.x + p.y * p.y) + p.z * p.z).sqrt();
                (p.z > -unified_w(*alpha) * d).then_some(())?;
                Some(p.truncate() / (alpha * d + (1.0 - alpha) * p.z))
            }
            LensModel::Unified { xi, distortion } => {
                let d = p.length();
                (p.z > -xi.min(1.0 / xi) * d).then_some(())?;
                distortion.distort_checked(p.truncate() / (p.z + xi * d))
            }
            LensModel::Scaramuzza(model) => {
                let r = p.truncate().length();
                let theta = r.atan2(p.z);
                if r == 0.0 {
                    return (p.z > 0.0).then_some(DVec2::ZERO);
                }
                let rho = model.rho_at_angle(theta)?;
                // OCamCalib's sensor x' runs along rows (optical y), y' along columns.
                Some(model.offset(dvec2(p.y, p.x) * (rho / r)))
            }
        }
    }

    /// Unit optical-frame direction of normalised image point `m`; `None` where no ray of
    /// the valid field of view maps there.
    pub fn unproject(&self, m: DVec2) -> Option<DVec3> {
        let direction = self.towards(m)?.normalize();
        direction.is_finite().then_some(direction)
    }

    /// An optical-frame direction (of any length) of normalised image point `m`: for a
    /// perspective lens the undistorted point at z = 1, so that an ideal pinhole's ray and a
    /// zero-distortion lens's are the same bit for bit; `None` where no ray of the valid field
    /// of view maps there.
    pub fn towards(&self, m: DVec2) -> Option<DVec3> {
        let r = m.length();
        let towards = if r > 0.0 { m / r } else { DVec2::ZERO };
        let direction = match self {
            LensModel::Perspective(distortion) => distortion.undistort(m)?.extend(1.0),
            LensModel::KannalaBrandt(model) => {
                let theta = increasing_inverse(
                    |theta| model.distorted(theta),
                    |theta| model.slope(theta),
                    r,
                    (0.0, model.theta_max),
                )?;
                direction_at(theta, towards)
            }
            LensModel::Equidistant => direction_at((r <= PI).then_some(r)?, towards),
            LensModel::Equisolid => direction_at(2.0 * (r <= 2.0).then(|| (r / 2.0).asin())?, towards),
            LensModel::Stereographic => direction_at(2.0 * (r / 2.0).atan(), towards),
            LensModel::Orthographic => direction_at((r <= 1.0).then(|| r.asin())?, towards),
            LensModel::DoubleSphere { xi, alpha } => {
                let r2 = r * r;
                let root = 1.0 - (2.0 * alpha - 1.0) * r2;
                (root >= 0.0).then_some(())?;
                let mz = (1.0 - alpha * alpha * r2) / (alpha * root.sqrt() + 1.0 - alpha);
                let discriminant = mz * mz + (1.0 - xi * xi) * r2;
                (discriminant >= 0.0).then_some(())?;
                let factor = (mz * xi + discriminant.sqrt()) / (mz * mz + r2);
                dvec3(factor * m.x, factor * m.y, factor * mz - xi)
            }
            LensModel::ExtendedUnified { alpha, beta } => {
                let r2 = r * r;
                let root = 1.0 - (2.0 * alpha - 1.0) * beta * r2;
                (root >= 0.0).then_some(())?;
                let mz = (1.0 - beta * alpha * alpha * r2) / (alpha * root.sqrt() + 1.0 - alpha);
                m.extend(mz)
            }
            LensModel::Unified { xi, distortion } => {
                let point = distortion.undistort(m)?;
                let r2 = point.length_squared();
                let discriminant = 1.0 + (1.0 - xi * xi) * r2;
                (discriminant >= 0.0).then_some(())?;
                let factor = (xi + discriminant.sqrt()) / (1.0 + r2);
                (point * factor).extend(factor - xi)
            }
            LensModel::Scaramuzza(model) => {
                let sensor = model.sensor(m);
                let rho = sensor.length();
                (rho <= model.rho_max).then_some(())?;
                // Optical x = OCamCalib's y' (columns), optical y = x' (rows), z = −pol.
                dvec3(sensor.y, sensor.x, -model.pol(rho).0)
            }
        };
        direction.is_finite().then_some(direction)
    }

    /// The valid field of view's half-angle off the optical axis, radians (along the image's
    /// x axis where the model is not symmetric).
    pub fn max_angle(&self) -> f64 {
        match self {
            LensModel::Perspective(distortion) => distortion.max_radius().atan(),
            LensModel::KannalaBrandt(model) => model.theta_max,
            LensModel::Equidistant | LensModel::Equisolid | LensModel::Stereographic => PI,
            LensModel::Orthographic => PI / 2.0,
            LensModel::DoubleSphere { xi, alpha } => {
                let w1 = unified_w(*alpha);
                (-(w1 + xi) / (2.0 * w1 * xi + xi * xi + 1.0).sqrt()).acos()
            }
            LensModel::ExtendedUnified { alpha, beta } => {
                let w2 = unified_w(*alpha).powi(2);
                (-(w2 * beta / (1.0 - w2 + w2 * beta)).sqrt()).acos()
            }
            LensModel::Unified { xi, distortion } => {
                let limit = (-xi.min(1.0 / xi)).acos();
                let radius = |theta: f64| theta.sin() / (theta.cos() + xi);
                let slope = |theta: f64| (1.0 + xi * theta.cos()) / (theta.cos() + xi).powi(2);
                let edge = limit * (1.0 - 1e-12);
                increasing_inverse(radius, slope, distortion.max_radius(), (0.0, edge)).unwrap_or(limit)
            }
            LensModel::Scaramuzza(model) => model.angle(model.rho_max),
        }
    }

    /// The normalised image radius at angle θ off axis (along image x), for fitting a focal
    /// length to a field of view; `None` beyond the valid field of view.
    pub fn radius_at(&self, theta: f64) -> Option<f64> {
        self.project(direction_at(theta, DVec2::X)).map(|m| m.x)
    }

    /// The model's parameters by name (normalised-coordinate models; Scaramuzza's in pixels).
    pub fn parameters(&self) -> Vec<(&'static str, Vec<f64>)> {
        match self {
            LensModel::Perspective(distortion) => vec![("distortion", distortion.coefficients().to_vec())],
            LensModel::KannalaBrandt(model) => vec![("k", model.k.to_vec())],
            LensModel::Equidistant | LensModel::Equisolid | LensModel::Stereographic | LensModel::Orthographic => {
                Vec::new()
            }
            LensModel::DoubleSphere { xi, alpha } => vec![("xi", vec![*xi]), ("alpha", vec![*alpha])],
            LensModel::ExtendedUnified { alpha, beta } => vec![("alpha", vec![*alpha]), ("beta", vec![*beta])],
            LensModel::Unified { xi, distortion } => {
                vec![("xi", vec![*xi]), ("distortion", distortion.coefficients().to_vec())]
            }
            LensModel::Scaramuzza(model) => vec![
                ("polynomial", model.pol.clone()),
                ("affine_c_d_e", model.affine.to_vec()),
            ],
        }
    }

    /// The model's name as the command line and exports spell it.
    pub fn name(&self) -> &'static str {
        match self {
            LensModel::Perspective(_) => "pinhole-brown-conrady",
            LensModel::KannalaBrandt(_) => "kannala-brandt",
            LensModel::Equidistant => "equidistant",
            LensModel::Equisolid => "equisolid",
            LensModel::Stereographic => "stereographic",
            LensModel::Orthographic => "orthographic",
            LensModel::DoubleSphere { .. } => "double-sphere",
            LensModel::ExtendedUnified { .. } => "eucm",
            LensModel::Unified { .. } => "unified",
            LensModel::Scaramuzza(_) => "scaramuzza",
        }
    }
}
