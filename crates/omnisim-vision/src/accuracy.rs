//! How far a resampled view is from the truth: its colour against the same view traced
//! exactly, and where a point feature lands against where the view's model puts it. Used by
//! the resampling-error chart (`examples/resampling_error.rs`) and the tests that hold the
//! chart's figures.

use glam::{DMat3, DVec2, DVec3, EulerRot, dvec2, dvec3};
use omnisim::Pose;
use omnisim::camera::{Camera, Catadioptric, Pinhole};

use crate::projection::PlaneView;
use crate::{Interpolation, Raster, Remap, View};

impl View {
    /// The omnisim camera that traces this view exactly from the same viewpoint, and its
    /// body frame in the omni camera's body frame. A bird's-eye view of a plane below the
    /// viewpoint is a pinhole looking straight down with focal |`plane_z`| / metres per pixel:
    /// both are central projections from the viewpoint onto planes parallel to the floor.
    /// `None` for a plane above the viewpoint (that view is mirrored: no pinhole gives it).
    pub fn exact_camera(&self) -> Option<(Camera, DMat3)> {
        match self {
            View::Camera { camera, body_from_view } => Some((camera.clone(), *body_from_view)),
            View::Plane(PlaneView {
                width,
                height,
                metres_per_pixel,
                plane_z,
                centre,
            }) => {
                if *plane_z >= 0.0 || *centre != DVec2::ZERO {
                    return None;
                }
                let f = -plane_z / metres_per_pixel;
                let pinhole = Pinhole {
                    fx: f,
                    fy: f,
                    ..Pinhole::with_horizontal_fov(*width, *height, 1.0)
                };
                // The pinhole looks along its body +x: turned to body −z, its image right stays
                // body −y and its image up becomes body +x, as the bird's-eye view's.
                Some((
                    Camera::Pinhole(pinhole),
                    DMat3::from_rotation_y(std::f64::consts::FRAC_PI_2),
                ))
            }
        }
    }

    /// The camera and pose that trace this view exactly when the omni camera is at `pose`.
    pub fn exact_render(&self, pose: &Pose) -> Option<(Camera, Pose)> {
        let (camera, body_from_view) = self.exact_camera()?;
        let rotation = pose.world_from_body_rotation() * body_from_view;
        let (ax, ay, az) = rotation.to_euler(EulerRot::XYZ);
        Some((camera, Pose::new(pose.position, dvec3(ax, ay, az))))
    }
}

/// The views of the resampling-error chart (docs/images/resampling-error.svg).
pub fn chart_views() -> Vec<(&'static str, View)> {
    let panorama = View::panorama(512, 128, (-45f64).to_radians(), 15f64.to_radians());
    let perspective = View::perspective(400, 300, 90f64.to_radians(), 2.2, (-25f64).to_radians());
    vec![
        ("panorama 512×128", panorama.expect("a valid band")),
        ("perspective 400×300, 90°", perspective.expect("a valid field of view")),
        (
            "bird's-eye 400², 1 cm/px",
            View::birds_eye(400, 400, 0.01, -0.7).expect("a valid plane"),
        ),
    ]
}

/// The pose of the chart's omni camera in env1.
pub fn chart_pose() -> Pose {
    Pose::from_degrees(dvec3(0.5, 0.2, 0.4), dvec3(0.0, 0.0, 30.0))
}

/// Points every view of the shipped rooms sees, for [`point_displacements`]: 48 directions
/// (at 2 m) spread over the full turn and elevations −40° … +12° for camera views, and for
/// bird's-eye views points of the plane 0.4 … 1.8 m from under the viewpoint.
pub fn sample_points(view: &View) -> Vec<DVec3> {
    (0..48)
        .map(|i| {
            let azimuth = 0.37 + f64::from(i) * std::f64::consts::TAU / 48.0;
            match view {
                View::Plane(plane) => {
                    let range = 0.4 + 1.4 * f64::from(i % 5) / 4.0;
                    dvec3(range * azimuth.cos(), range * azimuth.sin(), plane.plane_z)
                }
                View::Camera { .. } => {
                    2.0 * crate::projection::direction(azimuth, (-40.0 + 52.0 * f64::from(i % 7) / 6.0f64).to_radians())
                }
            }
        })
        .collect()
}

/// Colour difference of a resampled view and an exact render, over the pixels both have.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourError {
    /// Mean absolute difference per channel, 0–255 scale.
    pub mean: f64,
    /// Share of pixels more than 32 / 255 off (mean over channels).
    pub far: f64,
    /// Pixels compared: valid in the resampled view and hit (not black) in the exact render.
    pub pixels: usize,
}

/// [`ColourError`] of `resampled` (RGB 0..1) against `exact` (8-bit RGB, black = no hit);
/// `None` when no pixel is in both (an error over nothing is not 0).
pub fn colour_error(resampled: &Raster, exact: &[[u8; 3]], remap: &Remap) -> Option<ColourError> {
    let (mut sum, mut far, mut pixels) = (0.0, 0usize, 0usize);
    for ((pixel, exact), valid) in resampled.data.chunks(3).zip(exact).zip(remap.valid()) {
        if valid && exact != &[0, 0, 0] {
            let d = pixel
                .iter()
                .zip(exact)
                .map(|(a, &b)| (f64::from(a.clamp(0.0, 1.0)) * 255.0 - f64::from(b)).abs())
                .sum::<f64>()
                / 3.0;
            sum += d;
            far += usize::from(d > 32.0);
            pixels += 1;
        }
    }
    let n = pixels as f64;
    (pixels > 0).then(|| ColourError {
        mean: sum / n,
        far: far as f64 / n,
        pixels,
    })
}

/// Geometric error: for each body-frame point (a direction for camera views; a point of the
/// plane for bird's-eye views) that both cameras see, a Gaussian spot (σ = 1.5 px) is painted
/// where the omni camera sees it, resampled, and its centroid found; the distances (view
/// pixels) to where the view's own model projects the point. Points within 12 px of the view's
/// border are left out.
pub fn point_displacements(
    omni: &Catadioptric,
    view: &View,
    remap: &Remap,
    points: &[DVec3],
    interpolation: Interpolation,
) -> Vec<f64> {
    let (w, h) = view.size();
    let margin = 12.0;
    points
        .iter()
        .filter_map(|&point| {
            let expected = view.project(point)?;
            let inside = expected.x >= margin
                && expected.y >= margin
                && expected.x <= f64::from(w) - 1.0 - margin
                && expected.y <= f64::from(h) - 1.0 - margin;
            let source = omni.project(point).filter(|_| inside)?;
            let image = remap
                .apply(&spot(omni.width, omni.height, source), interpolation)
                .ok()?;
            Some(centroid(&image, expected, 9.0).distance(expected))
        })
        .collect()
}

/// A Gaussian spot (σ = 1.5 px) at `centre` of a one-channel image.
fn spot(width: u32, height: u32, centre: DVec2) -> Raster {
    let mut image = Raster::new(width as usize, height as usize, 1);
    let reach = 8.0;
    let (x0, x1) = (
        (centre.x - reach).max(0.0) as usize,
        ((centre.x + reach) as usize).min(width as usize - 1),
    );
    let (y0, y1) = (
        (centre.y - reach).max(0.0) as usize,
        ((centre.y + reach) as usize).min(height as usize - 1),
    );
    for y in y0..=y1 {
        for x in x0..=x1 {
            let d2 = (dvec2(x as f64, y as f64) - centre).length_squared();
            image.data[y * width as usize + x] = (-d2 / (2.0 * 1.5 * 1.5)).exp() as f32;
        }
    }
    image
}

/// Intensity-weighted centroid within `radius` px of `around`.
fn centroid(image: &Raster, around: DVec2, radius: f64) -> DVec2 {
    let (mut sum, mut weight) = (DVec2::ZERO, 0.0);
    let clamp = |v: f64, n: usize| v.clamp(0.0, n as f64 - 1.0) as usize;
    for y in clamp((around.y - radius).floor(), image.height)..=clamp((around.y + radius).ceil(), image.height) {
        for x in clamp((around.x - radius).floor(), image.width)..=clamp((around.x + radius).ceil(), image.width) {
            let value = f64::from(image.at(x, y));
            sum += value * dvec2(x as f64, y as f64);
            weight += value;
        }
    }
    if weight > 0.0 {
        sum / weight
    } else {
        DVec2::splat(f64::INFINITY)
    }
}
