//! A pixel's footprint on the surface it sees, as ray differentials.
//!
//! Every camera model (pinhole, panoramas, mirrors, central or not) is a function from pixel
//! coordinates to a ray; its derivatives along the two image axes, transferred to the face hit,
//! are the pixel's footprint (Igehy 1999, "Tracing ray differentials"). They are taken as the
//! difference between the pixel's ray and its neighbour's (x + 1, else x − 1 where the image
//! or the mirror ends; the same for y; [`neighbour_side`]): the camera's own rays, so a curved mirror's spread of the
//! reflected rays comes out of the camera model with no per-model derivation, and the footprint
//! is exact to first order for every model. Each neighbouring ray is intersected with the plane
//! of the hit face: the points' offsets from the hit point are the footprint's sides (their
//! length already holds the distance and the 1/cos of a slanted face). `shaders/texture.wgsl`
//! does the same with the camera's WGSL rays.

use glam::{DMat3, DVec2, DVec3};

use crate::camera::{Camera, CameraRay};
use crate::pose::Pose;

/// Whether the neighbour `step` ahead of `pixel` lies inside an image of `size` pixels; if it
/// does not (or the camera has no ray there), the one `step` behind stands in. The GPU's
/// `footprint_side` follows the same rule.
fn ahead_is_inside(pixel: DVec2, step: DVec2, size: (u32, u32)) -> bool {
    let ahead = pixel + step;
    ahead.x <= f64::from(size.0) - 1.0 && ahead.y <= f64::from(size.1) - 1.0
}

/// `world` of the ray of the neighbour `step` ahead of `pixel`, or of the one behind where
/// that one is outside the image or has no ray.
#[inline(always)]
fn neighbour<T>(
    pixel: DVec2,
    step: DVec2,
    size: (u32, u32),
    camera: &Camera,
    world: impl Fn(&CameraRay) -> T,
) -> Option<T> {
    let ahead = if ahead_is_inside(pixel, step, size) {
        camera.ray(pixel + step).as_ref().map(&world)
    } else {
        None
    };
    ahead.or_else(|| camera.ray(pixel - step).as_ref().map(&world))
}

/// The rays of a pixel's two image-axis neighbours, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// (origin, unit direction) of the neighbour along x and along y; `None` where the camera
    /// has no such neighbour.
    neighbours: [Option<(DVec3, DVec3)>; 2],
}

impl Footprint {
    /// No footprint: textures are sampled at their finest level (point sampling). What a
    /// caller without a camera gets, and what tests compare filtering against.
    pub const POINT: Footprint = Footprint { neighbours: [None; 2] };

    /// The footprint of pixel `pixel` (sub-pixel positions allowed) of `camera` at `pose`.
    pub fn of_pixel(camera: &Camera, pose: &Pose, pixel: DVec2) -> Footprint {
        Self::around(
            pixel,
            camera.size(),
            pose.world_from_body_rotation(),
            pose.position,
            camera,
        )
    }

    /// The footprint of pixel `pixel` of `camera`'s image of `size` pixels, seen from a pose with rotation `world_from_body` at `position`: the
    /// neighbour one pixel ahead along each axis, or the one behind where the one ahead is
    /// outside the image or has no ray.
    #[inline]
    pub(crate) fn around(
        pixel: DVec2,
        size: (u32, u32),
        world_from_body: DMat3,
        position: DVec3,
        camera: &Camera,
    ) -> Footprint {
        let world = |ray: &CameraRay| (position + world_from_body * ray.origin, world_from_body * ray.direction);
        Footprint {
            neighbours: [
                neighbour(pixel, DVec2::X, size, camera, world),
                neighbour(pixel, DVec2::Y, size, camera, world),
            ],
        }
    }

    /// [`Footprint::around`] for the pixel at `index` (row by row) of an image of `size`
    /// pixels whose pixel-centre rays `table` holds (`camera`'s own rays beyond its edges):
    /// the same neighbours, found by integer index steps (±1, ±width) instead of pixel
    /// positions in f64 (the conversions cost about 50 instructions a textured pixel,
    /// docs/benchmarks.md).
    #[inline]
    pub(crate) fn in_table(
        index: usize,
        size: (u32, u32),
        world_from_body: DMat3,
        position: DVec3,
        table: &[Option<CameraRay>],
        camera: &Camera,
    ) -> Footprint {
        let (width, height) = (size.0.max(1) as usize, size.1 as usize);
        let (x, y) = (index % width, index / width);
        let world = |ray: &CameraRay| (position + world_from_body * ray.origin, world_from_body * ray.direction);
        let at = |i: usize| table.get(i)?.as_ref().map(world);
        // The neighbour `step` entries ahead where `ahead_inside`, else (or where it has no ray)
        // the one behind: in the table, or from the camera at `outside` (pixel −1 of the row or
        // column) where there is none behind.
        let neighbour = |ahead_inside: bool, step: usize, behind_inside: bool, outside: DVec2| {
            let ahead = if ahead_inside { at(index + step) } else { None };
            ahead.or_else(|| match behind_inside {
                true => at(index - step),
                false => camera.ray(outside).as_ref().map(world),
            })
        };
        Footprint {
            neighbours: [
                neighbour(x + 1 < width, 1, x > 0, DVec2::new(-1.0, y as f64)),
                neighbour(y + 1 < height, width, y > 0, DVec2::new(x as f64, -1.0)),
            ],
        }
    }

    /// The footprint's sides on the plane through `point` with normal `normal`: where each
    /// neighbouring ray meets that plane, less `point`. A neighbour that runs parallel to the
    /// plane or meets it behind its origin gives an infinite side; a missing one a zero side.
    #[inline]
    pub fn on_plane(&self, point: DVec3, normal: DVec3) -> [DVec3; 2] {
        // Written out per side: `array::map` kept the sides in memory (a tenth of a textured
        // pixel's time).
        let side = |neighbour: &Option<(DVec3, DVec3)>| {
            let Some((origin, direction)) = *neighbour else {
                return DVec3::ZERO;
            };
            let t = (point - origin).dot(normal) / direction.dot(normal);
            if t.is_finite() && t > 0.0 {
                origin + t * direction - point
            } else {
                DVec3::INFINITY
            }
        };
        [side(&self.neighbours[0]), side(&self.neighbours[1])]
    }
}
