//! Catadioptric cameras: a camera looking at a mirror of revolution, traced exactly by the law
//! of reflection at the mirror surface (DESIGN.md §3).
//!
//! Each mirror lives in its own surface frame S (axis +z, from the camera towards the mirror):
//! - hyperbolic: upper sheet of (x²+y²)/a² − z²/b² = −1, foci (0,0,±c), c = √(a²+b²); a
//!   pinhole at the outer focus (0,0,−c); viewpoint F' = (0,0,c);
//! - parabolic: z = h·(x²/a² + y²/b²), seen by an orthographic camera along +z; central with
//!   viewpoint (focus) (0,0,a²/(4h)) when a = b;
//! - spherical: sphere of radius R at the origin, pinhole at (0,0,−D); never central; the body
//!   origin is the sphere's centre.
//!
//! The body frame is S moved to the viewpoint (body origin) and, for `Mount::Down`, turned by
//! π about x so the mirror axis is body −z. With no misalignment the camera's optical axes are
//! S's axes, so a point at body azimuth φ appears at image angle atan2(v − cy, u − cx) = φ
//! (mount up): on screen the image is mirrored, as one reflection flips handedness.

use glam::{DMat3, DVec2, DVec3, dvec2, dvec3};

use super::CameraRay;
use super::lens::LensModel;
use super::lens_camera::{lens_ray, pixel_through};
use crate::pose::rotation_xyz;

/// The mirror's shape and, for the spherical mirror, where its camera is.
#[derive(Debug, Clone, PartialEq)]
pub enum MirrorShape {
    /// (x²+y²)/a² − z²/b² = −1, metres; perspective camera at the outer focus.
    Hyperbolic {
        /// Semi-axis a, metres.
        a: f64,
        /// Semi-axis b, metres.
        b: f64,
    },
    /// z = h·(x²/a² + y²/b²), metres; orthographic camera. Central only when a = b.
    Parabolic {
        /// Radius scale along x, metres.
        a: f64,
        /// Radius scale along y, metres (a = b: a paraboloid of revolution).
        b: f64,
        /// Height h, metres.
        h: f64,
    },
    /// Sphere of `radius` seen by a perspective camera `camera_distance` from its centre.
    Spherical {
        /// Sphere radius, metres.
        radius: f64,
        /// Distance from the sphere's centre to the camera, metres.
        camera_distance: f64,
    },
}

/// Which way the mirror axis points in the body frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mount {
    /// Mirror above the camera, axis along body +z (ground robots).
    #[default]
    Up,
    /// Mirror below the camera, axis along body −z.
    Down,
}

/// How mirror rays are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MirrorRays {
    /// Law of reflection at the mirror surface: exact for every mirror and misalignment.
    #[default]
    Reflect,
    /// The reference paper's method: from the viewpoint F' through the mirror point. Exact
    /// only for an aligned central mirror.
    Shortcut,
}

/// The camera displaced from its nominal place: `offset` (metres, surface frame) and a
/// `tilt` R = Rx·Ry·Rz (radians) of its optical axes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Misalignment {
    /// Displacement of the camera, metres, mirror frame.
    pub offset: DVec3,
    /// Tilt (θx, θy, θz) of the camera axes, radians.
    pub tilt: DVec3,
}

impl Misalignment {
    /// Whether the camera sits exactly at its nominal place (a central mirror stays central).
    pub fn is_zero(&self) -> bool {
        self.offset == DVec3::ZERO && self.tilt == DVec3::ZERO
    }
}

/// Mei's unified-model parameters of an aligned central catadioptric camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnifiedModel {
    /// Mirror parameter ξ (1 for a paraboloid, 0 for a pinhole).
    pub xi: f64,
    /// Generalised focal length in x, pixels.
    pub gamma_x: f64,
    /// Generalised focal length in y, pixels.
    pub gamma_y: f64,
    /// Principal point, column.
    pub cx: f64,
    /// Principal point, row.
    pub cy: f64,
}

/// What every ray of one catadioptric camera shares ([`Catadioptric::ray_constants`]).
pub(crate) struct RayConstants {
    /// Where the camera sits in S and how it is tilted.
    camera: CameraPlace,
    /// The mirror surface in S.
    quadric: Quadric,
    /// S to the body frame.
    body_from_mirror: DMat3,
    /// The body origin in S.
    body_origin: DVec3,
    /// Whether every ray passes through the body origin.
    central: bool,
}

/// The misaligned camera's place in S: its tilt, and its centre.
#[derive(Clone, Copy)]
struct CameraPlace {
    tilt: DMat3,
    centre: DVec3,
}

/// A quadric x·diag·x + linear·x + constant = 0 with a diagonal quadratic part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadric {
    /// Diagonal of the quadratic part.
    pub diag: DVec3,
    /// Linear part.
    pub linear: DVec3,
    /// Constant term.
    pub constant: f64,
    /// Only points with z above this belong to the mirror (the hyperbola's upper sheet).
    pub min_z: f64,
}

impl Quadric {
    /// The quadric's value at `p`: zero on the surface, its sign tells the sides apart.
    pub fn value(&self, p: DVec3) -> f64 {
        (self.diag * p).dot(p) + self.linear.dot(p) + self.constant
    }

    /// Gradient at `p`: the surface normal, unnormalised.
    pub fn gradient(&self, p: DVec3) -> DVec3 {
        2.0 * self.diag * p + self.linear
    }

    /// The same surface in coordinates shifted by `origin` (p' = p − origin).
    pub fn shifted(&self, origin: DVec3) -> Quadric {
        Quadric {
            diag: self.diag,
            linear: self.gradient(origin),
            constant: self.value(origin),
            min_z: self.min_z - origin.z,
        }
    }

    /// Smallest t > 0 where `origin + t·d` is on the mirror, by cancellation-free roots.
    pub fn first_hit(&self, origin: DVec3, d: DVec3) -> Option<f64> {
        let qa = (self.diag * d).dot(d);
        let qb = 2.0 * (self.diag * origin).dot(d) + self.linear.dot(d);
        let qc = self.value(origin);
        let roots = if qa.abs() <= 1e-15 * (qb.abs() + qc.abs()) {
            // Parallel to an asymptote or the axis of a paraboloid: the equation is linear.
            [-qc / qb, f64::NAN]
        } else {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc < 0.0 {
                return None;
            }
            let q = -0.5 * (qb + qb.signum() * disc.sqrt());
            [q / qa, qc / q]
        };
        roots
            .into_iter()
            .filter(|&t| t.is_finite() && t > 0.0 && origin.z + t * d.z > self.min_z)
            .min_by(f64::total_cmp)
    }
}

/// A catadioptric camera: a perspective or orthographic camera looking at a mirror of
/// revolution, traced by the law of reflection at the mirror surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Catadioptric {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Shape and size of the mirror.
    pub mirror: MirrorShape,
    /// Focal length in pixels (perspective camera of hyperbolic and spherical mirrors), or
    /// pixels per metre (orthographic camera of parabolic mirrors).
    pub focal: f64,
    /// Image column of the mirror axis.
    pub cx: f64,
    /// Image row of the mirror axis.
    pub cy: f64,
    /// Radius of the mirror's rim (in the surface frame's xy), metres; `None` for no rim.
    pub rim_radius: Option<f64>,
    /// Pixels closer than this to (cx, cy) see the camera's own body: background.
    pub hidden_centre_px: f64,
    /// Which way the mirror axis points in the body frame.
    pub mount: Mount,
    /// Camera displacement from its nominal place (makes the camera non-central).
    pub misalignment: Misalignment,
    /// How mirror rays are found.
    pub rays: MirrorRays,
    /// The lens of the perspective camera that looks at the mirror (hyperbolic and spherical
    /// mirrors), applied with K = (focal, focal, cx, cy); `None`: the ideal pinhole (boxed: a
    /// lens holds up to 12 coefficients).
    pub lens: Option<Box<LensModel>>,
}

impl Catadioptric {
    fn new(width: u32, height: u32, mirror: MirrorShape, focal: f64) -> Self {
        Self {
            width,
            height,
            mirror,
            focal,
            cx: (f64::from(width) - 1.0) / 2.0,
            cy: (f64::from(height) - 1.0) / 2.0,
            rim_radius: None,
            hidden_centre_px: 0.0,
            mount: Mount::Up,
            misalignment: Misalignment::default(),
            rays: MirrorRays::Reflect,
            lens: None,
        }
    }

    fn image_radius(width: u32, height: u32) -> f64 {
        f64::from(width.min(height)) / 2.0
    }

    /// Hyperbolic mirror (a, b) filling the shorter image side. With `max_elevation`
    /// (radians above the horizon) the rim is placed where the mirror sees that elevation,
    /// r = a²·cos ε/(b − c·sin ε), and the rim circle touches the image border; without it
    /// the mirror reaches its asymptote (elevation asin(b/c), pixel radius f·a/b).
    pub fn hyperbolic(width: u32, height: u32, a: f64, b: f64, max_elevation: Option<f64>) -> Self {
        let radius = Self::image_radius(width, height);
        let mut camera = Self::new(width, height, MirrorShape::Hyperbolic { a, b }, radius * b / a);
        if let Some(elevation) = max_elevation {
            let (sin, cos) = elevation.sin_cos();
            let c = a.hypot(b);
            camera.rim_radius = Some(a * a * cos / (b - c * sin));
            // The rim's pixel radius is f·a²/(b²+c²)·cos ε/(ξ − sin ε); solve for f.
            let xi = 2.0 * b * c / (b * b + c * c);
            camera.focal = radius * (xi - sin) * (b * b + c * c) / (a * a * cos);
        }
        camera
    }

    /// Paraboloid z = h·(x²+y²)/a² with its rim where it sees `max_elevation`, the rim circle
    /// on the image border: focus p = a²/(4h), rim r = 2p·cos ε/(1 − sin ε).
    pub fn parabolic(width: u32, height: u32, a: f64, h: f64, max_elevation: f64) -> Self {
        let p = a * a / (4.0 * h);
        let (sin, cos) = max_elevation.sin_cos();
        let rim = 2.0 * p * cos / (1.0 - sin);
        let mut camera = Self::new(
            width,
            height,
            MirrorShape::Parabolic { a, b: a, h },
            Self::image_radius(width, height) / rim,
        );
        camera.rim_radius = Some(rim);
        camera
    }

    /// Sphere of `radius` seen from `camera_distance`, its silhouette on the image border.
    pub fn spherical(width: u32, height: u32, radius: f64, camera_distance: f64) -> Self {
        let half_angle = (radius / camera_distance).asin();
        let focal = Self::image_radius(width, height) / half_angle.tan();
        Self::new(
            width,
            height,
            MirrorShape::Spherical {
                radius,
                camera_distance,
            },
            focal,
        )
    }

    /// Hyperbola focal distance c = √(a² + b²) (0 for other mirrors).
    pub fn c(&self) -> f64 {
        match self.mirror {
            MirrorShape::Hyperbolic { a, b } => a.hypot(b),
            _ => 0.0,
        }
    }

    /// Whether the camera looks through a lens at a point (perspective) rather than along
    /// parallel rays (orthographic, parabolic mirrors).
    pub fn is_perspective(&self) -> bool {
        !matches!(self.mirror, MirrorShape::Parabolic { .. })
    }

    /// Every pixel's ray passes through one viewpoint: an aligned hyperbolic mirror, or an
    /// aligned paraboloid of revolution.
    pub fn is_central(&self) -> bool {
        self.misalignment.is_zero()
            && match self.mirror {
                MirrorShape::Hyperbolic { .. } => true,
                MirrorShape::Parabolic { a, b, .. } => a == b,
                MirrorShape::Spherical { .. } => false,
            }
    }

    /// The mirror surface in the surface frame S.
    pub fn quadric(&self) -> Quadric {
        match self.mirror {
            MirrorShape::Hyperbolic { a, b } => Quadric {
                diag: dvec3(1.0 / (a * a), 1.0 / (a * a), -1.0 / (b * b)),
                linear: DVec3::ZERO,
                constant: 1.0,
                min_z: 0.0,
            },
            MirrorShape::Parabolic { a, b, h } => Quadric {
                diag: dvec3(h / (a * a), h / (b * b), 0.0),
                linear: dvec3(0.0, 0.0, -1.0),
                constant: 0.0,
                min_z: f64::NEG_INFINITY,
            },
            MirrorShape::Spherical { radius, .. } => Quadric {
                diag: DVec3::ONE,
                linear: DVec3::ZERO,
                constant: -radius * radius,
                min_z: f64::NEG_INFINITY,
            },
        }
    }

    /// The body origin in S: F' for central mirrors, the paraboloid's (x-section) focus, the
    /// sphere's centre.
    pub fn body_origin_in_mirror(&self) -> DVec3 {
        match self.mirror {
            MirrorShape::Hyperbolic { .. } => dvec3(0.0, 0.0, self.c()),
            MirrorShape::Parabolic { a, h, .. } => dvec3(0.0, 0.0, a * a / (4.0 * h)),
            MirrorShape::Spherical { .. } => DVec3::ZERO,
        }
    }

    /// Where the aligned camera sits in S: the pinhole, or for the orthographic camera the
    /// point of its image plane on the axis (any plane below the mirror gives the same rays).
    pub fn nominal_camera_in_mirror(&self) -> DVec3 {
        match self.mirror {
            MirrorShape::Hyperbolic { .. } => dvec3(0.0, 0.0, -self.c()),
            MirrorShape::Parabolic { a, b, .. } => dvec3(0.0, 0.0, -2.0 * a.max(b)),
            MirrorShape::Spherical { camera_distance, .. } => dvec3(0.0, 0.0, -camera_distance),
        }
    }

    /// `body_from_mirror` rotation: identity, or Rx(π) for a mirror mounted below.
    pub fn body_from_mirror(&self) -> DMat3 {
        match self.mount {
            Mount::Up => DMat3::IDENTITY,
            Mount::Down => DMat3::from_diagonal(dvec3(1.0, -1.0, -1.0)),
        }
    }

    /// The ray of the camera's lens at `pixel`, in its optical frame before the misalignment
    /// tilt (`lens_camera::lens_ray`): (towards, unit direction); `None` without a lens or
    /// beyond its field of view.
    pub fn lens_ray(&self, pixel: DVec2) -> Option<(DVec3, DVec3)> {
        lens_ray(
            self.lens.as_deref()?,
            DVec2::splat(self.focal),
            dvec2(self.cx, self.cy),
            pixel,
        )
    }

    /// The camera's ray for `pixel` in S, before the mirror: (origin, unit direction); `None`
    /// beyond the field of view of the camera's lens.
    pub fn camera_ray_in_mirror(&self, pixel: DVec2) -> Option<(DVec3, DVec3)> {
        self.camera_ray_in_mirror_with(self.camera_place(), pixel)
    }

    /// Where the misaligned camera sits in S and how it is tilted.
    fn camera_place(&self) -> CameraPlace {
        CameraPlace {
            tilt: rotation_xyz(self.misalignment.tilt),
            centre: self.nominal_camera_in_mirror() + self.misalignment.offset,
        }
    }

    /// [`Catadioptric::camera_ray_in_mirror`] from the camera's `place`.
    #[inline(always)]
    fn camera_ray_in_mirror_with(&self, place: CameraPlace, pixel: DVec2) -> Option<(DVec3, DVec3)> {
        let CameraPlace { tilt, centre } = place;
        let offset = (pixel - dvec2(self.cx, self.cy)) / self.focal;
        Some(if self.is_perspective() {
            let towards = match &self.lens {
                None => offset.extend(1.0),
                // The lens's f64 inverse: the undistorted point at z = 1 for a perspective lens
                // (as above, bit for bit, when its distortion is zero).
                Some(_) => self.lens_ray(pixel)?.0,
            };
            (centre, (tilt * towards).normalize())
        } else {
            (centre + tilt * offset.extend(0.0), tilt * DVec3::Z)
        })
    }

    /// What every pixel's ray shares, worked out by the calls [`Catadioptric::ray`] makes for
    /// each pixel (the tilt's sines and cosines, `hypot`s): a camera's ray source
    /// (`camera/ray_source.rs`) works it out once, to the same bits.
    pub(crate) fn ray_constants(&self) -> RayConstants {
        RayConstants {
            camera: self.camera_place(),
            quadric: self.quadric(),
            body_from_mirror: self.body_from_mirror(),
            body_origin: self.body_origin_in_mirror(),
            central: self.is_central(),
        }
    }

    /// Every ray's origin where all rays start at the body origin (a central mirror, or the
    /// shortcut's rays), else `None`: as [`Catadioptric::ray`] gives them, bit for bit.
    pub(crate) fn shared_origin(&self, constants: &RayConstants) -> Option<DVec3> {
        (self.rays == MirrorRays::Shortcut || constants.central).then_some(DVec3::ZERO)
    }

    /// Traces pixel (u, v) to the mirror and off it. `None` where the pixel sees the camera
    /// body, misses the mirror, or hits it past the rim.
    pub fn ray(&self, pixel: DVec2) -> Option<CameraRay> {
        if self.sees_camera_body(pixel) {
            return None;
        }
        self.ray_beside_the_body(&self.ray_constants(), pixel)
    }

    /// [`Catadioptric::ray`] with the camera's `constants` worked out already.
    #[inline(always)]
    pub(crate) fn ray_with(&self, constants: &RayConstants, pixel: DVec2) -> Option<CameraRay> {
        if self.sees_camera_body(pixel) {
            return None;
        }
        self.ray_beside_the_body(constants, pixel)
    }

    /// Whether `pixel` lies in the hidden centre, where the camera sees its own body.
    #[inline(always)]
    fn sees_camera_body(&self, pixel: DVec2) -> bool {
        let centre = pixel - dvec2(self.cx, self.cy);
        centre.length_squared() < self.hidden_centre_px * self.hidden_centre_px
    }

    /// [`Catadioptric::ray_with`] of a pixel outside the hidden centre.
    #[inline(always)]
    fn ray_beside_the_body(&self, constants: &RayConstants, pixel: DVec2) -> Option<CameraRay> {
        let (origin, d) = self.camera_ray_in_mirror_with(constants.camera, pixel)?;
        let quadric = &constants.quadric;
        let q = origin + quadric.first_hit(origin, d)? * d;
        if let Some(rim) = self.rim_radius
            && q.x * q.x + q.y * q.y > rim * rim
        {
            return None;
        }
        let body_from_mirror = constants.body_from_mirror;
        let q_body = body_from_mirror * (q - constants.body_origin);
        let normal = quadric.gradient(q).normalize();
        let reflected = body_from_mirror * (d - 2.0 * d.dot(normal) * normal).normalize();
        Some(match self.rays {
            MirrorRays::Shortcut => CameraRay {
                origin: DVec3::ZERO,
                direction: q_body.normalize(),
                t_min: q_body.length(),
            },
            MirrorRays::Reflect if constants.central => CameraRay {
                origin: DVec3::ZERO,
                direction: reflected,
                t_min: q_body.length(),
            },
            MirrorRays::Reflect => CameraRay {
                origin: q_body,
                direction: reflected,
                t_min: 0.0,
            },
        })
    }

    /// Mei's unified model of an aligned central mirror seen by the ideal pinhole (the inner
    /// lens is [`Self::unified_distortion`]); `None` for non-central cameras.
    pub fn unified_model(&self) -> Option<UnifiedModel> {
        if !self.is_central() {
            return None;
        }
        let (xi, scale) = match self.mirror {
            MirrorShape::Hyperbolic { a, b } => {
                let c = self.c();
                (2.0 * b * c / (b * b + c * c), a * a / (b * b + c * c))
            }
            MirrorShape::Parabolic { a, h, .. } => (1.0, a * a / (2.0 * h)),
            MirrorShape::Spherical { .. } => return None,
        };
        Some(UnifiedModel {
            xi,
            gamma_x: self.focal * scale,
            gamma_y: self.focal * scale,
            cx: self.cx,
            cy: self.cy,
        })
    }

    /// The inner lens as the unified model's radtan (k1 k2 p1 p2 on the projected sphere point,
    /// Kalibr `omni-radtan`, `cv::omnidir`), exact: the ideal pinhole's normalised point is
    /// s·m for the model's m, with s = γ/focal, so distorting it by (k1, k2, p1, p2) and dividing
    /// by s distorts m by (k1·s², k2·s⁴, p1·s, p2·s). Zero without a lens; `None` where the
    /// camera has no unified model or the lens is not radtan (k3 and beyond zero).
    pub fn unified_distortion(&self) -> Option<[f64; 4]> {
        let model = self.unified_model()?;
        match self.lens.as_deref() {
            None => Some([0.0; 4]),
            Some(LensModel::Perspective(distortion)) => {
                let [k1, k2, p1, p2] = distortion.radtan()?;
                let s = model.gamma_x / self.focal;
                Some([k1 * s * s, k2 * s.powi(4), p1 * s, p2 * s])
            }
            Some(_) => None,
        }
    }

    /// Highest elevation above the horizon (mirror frame) the mirror shape can show without a
    /// rim: asin(b/c) for the hyperbola, 90° otherwise.
    pub fn asymptote_elevation(&self) -> f64 {
        match self.mirror {
            MirrorShape::Hyperbolic { b, .. } => (b / self.c()).asin(),
            _ => std::f64::consts::FRAC_PI_2,
        }
    }

    /// Closed-form (unified model) pixel of a body-frame point, for central cameras; `None`
    /// outside the mirror's field of view, past the rim or behind the camera body.
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        let model = self.unified_model()?;
        let s = (self.body_from_mirror().transpose() * point).try_normalize()?;
        // Distance from the viewpoint to the mirror along s.
        let lambda = match self.mirror {
            MirrorShape::Hyperbolic { a, b } => {
                let denominator = b - self.c() * s.z;
                if denominator <= 0.0 {
                    return None;
                }
                a * a / denominator
            }
            MirrorShape::Parabolic { a, h, .. } => {
                if s.z >= 1.0 {
                    return None;
                }
                a * a / (2.0 * h) / (1.0 - s.z)
            }
            MirrorShape::Spherical { .. } => return None,
        };
        if let Some(rim) = self.rim_radius
            && (lambda * s).truncate().length() > rim
        {
            return None;
        }
        let ideal = dvec2(
            model.cx + model.gamma_x * s.x / (model.xi - s.z),
            model.cy + model.gamma_y * s.y / (model.xi - s.z),
        );
        let pixel = match self.lens.as_deref() {
            None => ideal,
            // The ideal pinhole's pixel is where the inner camera sees the mirror point: its
            // lens moves it.
            Some(lens) => {
                let (focal, centre) = (DVec2::splat(self.focal), dvec2(self.cx, self.cy));
                pixel_through(lens, focal, centre, ((ideal - centre) / focal).extend(1.0))?
            }
        };
        (pixel.distance(dvec2(self.cx, self.cy)) >= self.hidden_centre_px).then_some(pixel)
    }
}
