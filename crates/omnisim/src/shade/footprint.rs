//! A pixel's footprint on the face it sees: its ray cone (`camera/cone.rs`, where it is
//! derived) laid on the face.
//!
//! On a face whose normal makes angle θ with the ray, the cone's section at range t is an
//! ellipse with axes w(t) and w(t)/|cos θ|; shading takes the longer ([`Footprint::longer_axis`]).
//! The finite-difference footprint's longer side on that face (the neighbours' rays met with
//! its plane, what the previous differential footprint computed) lies between w and w/|cos θ|:
//! equal to w/|cos θ| where the pixel's longer axis lies along the slant (a pinhole looking
//! along a floor), up to 1/|cos θ| shorter where it lies across it (the level of detail is
//! then up to log2 1/|cos θ| coarser: grazing views blur slightly more, never alias).
//! `tests/tests/textures.rs` checks both, for every camera model: w against the neighbours'
//! spacing on the plane across the ray within 5 %, and the bounds on known planes. Per pixel
//! this costs a multiply-add per axis and a division (a frame's footprints are laid in the
//! camera body's frame, on the face's normal turned there once per face), where
//! intersecting the two neighbours' rays with the face's plane cost about 300 instructions
//! (docs/benchmarks.md).
//!
//! It also holds where a frame's footprints come from ([`Footprints`]: the ray table, a cone
//! table, or the camera's rays), chosen once a frame, so that textured runs read their lanes'
//! footprints without asking per pixel.

use std::sync::Arc;

use glam::{DMat3, DVec2, DVec3, Vec3};

use crate::camera::{Camera, CameraRay, Cone, ConePlanes, RaySource};
use crate::pose::Pose;
use crate::trace::ray_table::ConeTable;

/// A pixel's footprint: its ray cone and its ray's direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    cone: Cone,
    /// Unit direction of the pixel's ray (zero for [`Footprint::POINT`]), in the frame of the
    /// normals it is laid on: the world's ([`Footprint::of_pixel`]), or the camera body's
    /// ([`Footprint::in_body`]).
    direction: Vec3,
}

impl Footprint {
    /// No footprint: textures are sampled at their finest level (point sampling). What a
    /// caller without a camera gets, and what tests compare filtering against.
    pub const POINT: Footprint = Footprint {
        cone: Cone::ZERO,
        direction: Vec3::ZERO,
    };

    /// The footprint of pixel `pixel` (sub-pixel positions allowed) of `camera` at `pose`;
    /// [`Footprint::POINT`] where the pixel has no ray.
    pub fn of_pixel(camera: &Camera, pose: &Pose, pixel: DVec2) -> Footprint {
        Self::around(pixel, pose.world_from_body_rotation(), camera)
    }

    /// [`Footprint::of_pixel`] with the pose's rotation `world_from_body`, from the camera's
    /// own rays.
    pub(crate) fn around(pixel: DVec2, world_from_body: DMat3, camera: &Camera) -> Footprint {
        Self::from_rays(pixel, camera, |cone, ray| Footprint::new(cone, world_from_body, ray))
    }

    /// The footprint of pixel `pixel` of `camera` in the camera body's frame
    /// ([`Footprint::in_body`]), from the camera's own rays: [`Footprint::around`] without
    /// multiplying each ray by a rotation (the identity there).
    pub(crate) fn in_body_around(pixel: DVec2, camera: &Camera) -> Footprint {
        Self::from_rays(pixel, camera, |cone, ray| Footprint::in_body(cone, ray.direction))
    }

    /// The footprint `footprint` makes of pixel `pixel`'s cone and ray, from `camera`'s own
    /// rays; [`Footprint::POINT`] where the pixel has no ray.
    #[inline(always)]
    fn from_rays(pixel: DVec2, camera: &Camera, footprint: impl FnOnce(Cone, &CameraRay) -> Footprint) -> Footprint {
        match camera.ray(pixel) {
            Some(ray) => footprint(Cone::around(pixel, camera.size(), &ray, |p| camera.ray(p)), &ray),
            None => Footprint::POINT,
        }
    }

    /// The footprint of the pixel whose cone is `cone` and body-frame ray `ray`, seen from a
    /// pose with rotation `world_from_body`.
    #[inline]
    fn new(cone: Cone, world_from_body: DMat3, ray: &CameraRay) -> Footprint {
        Footprint {
            cone,
            direction: (world_from_body * ray.direction).as_vec3(),
        }
    }

    /// The footprint of the pixel whose cone is `cone` and body-frame ray direction
    /// `direction`, in the body frame: laid on normals turned into the body frame, so a
    /// frame's textured pixels turn their face's normal once per face rather than each ray
    /// into the world.
    #[inline]
    pub(crate) fn in_body(cone: Cone, direction: DVec3) -> Footprint {
        Footprint {
            cone,
            direction: direction.as_vec3(),
        }
    }

    /// The cone's width at distance `range` along the ray (metres): the footprint's axis
    /// across the slant of any face there.
    #[inline]
    pub fn width(&self, range: f32) -> f32 {
        self.cone.width(range)
    }

    /// The footprint's longer axis (metres) on a face with unit normal `normal` (in the frame
    /// of the footprint's direction) at distance `range`: the width over |cos θ|, θ between
    /// the ray and the normal. Infinite (or huge) where the ray grazes the face; zero for
    /// [`Footprint::POINT`].
    #[inline]
    pub fn longer_axis(&self, range: f32, normal: Vec3) -> f32 {
        self.width(range) / self.direction.dot(normal).abs().max(f32::MIN_POSITIVE)
    }
}

/// Where the footprints of a frame's pixels come from, chosen once a frame
/// (`View::footprints`): all in the camera body's frame ([`Footprint::in_body`]).
pub(crate) enum Footprints<'a> {
    /// The ray table's cones and ray directions.
    Table(&'a ConePlanes),
    /// A cone table, and each pixel's own ray from the camera's ray source (an image too
    /// large for a ray table).
    Cones { table: Arc<ConeTable>, rays: RaySource<'a> },
    /// The camera's rays alone, three a pixel; `width` is the image's (pixels are row by row).
    Camera { camera: &'a Camera, width: u32 },
}

impl Footprints<'_> {
    /// The longer axis ([`Footprint::longer_axis`]) of each pixel `index[k]`'s footprint
    /// (pixels row by row; `neighbours` where `index[k]` is `index[0] + k`) at range `range[k]`
    /// on a face with unit normal `normal` (in the camera body's frame): the source matched
    /// once for the lanes; from a ray table, each number of the lanes' footprints read as
    /// one vector where they are neighbours ([`ConePlanes::lanes`]).
    #[inline(always)]
    pub(crate) fn longer_axes<const L: usize>(
        &self,
        index: &[usize; L],
        neighbours: bool,
        range: &[f32; L],
        normal: Vec3,
    ) -> [f32; L] {
        let footprints: [Footprint; L] = match self {
            Footprints::Table(cones) => {
                return cones.lanes(index, neighbours, |k, cone, direction| {
                    Footprint { cone, direction }.longer_axis(range[k], normal)
                });
            }
            Footprints::Cones { table, rays } => {
                std::array::from_fn(|k| with_cone(table.cones[index[k]], rays.ray(index[k]).map(|ray| ray.direction)))
            }
            Footprints::Camera { camera, width } => std::array::from_fn(|k| {
                Footprint::in_body_around(crate::camera::pixel_centre(index[k], *width), camera)
            }),
        };
        std::array::from_fn(|k| footprints[k].longer_axis(range[k], normal))
    }
}

impl Footprints<'_> {
    /// The ray table's cones, where the footprints come from one.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn table(&self) -> Option<&ConePlanes> {
        match self {
            Footprints::Table(cones) => Some(cones),
            _ => None,
        }
    }
}

/// [`Footprints::longer_axes`] of eight lanes in AVX2 registers: from their cones' and
/// directions' numbers `planes` ([`ConePlanes::lanes_avx2`]) and ranges `range`, on a face
/// with unit normal `normal`, the same operations in the same order, so the same bits (tested).
/// LLVM's code for the lanes of `longer_axes` took about ten instructions a lane
/// (docs/benchmarks.md, 2026-11-26 night (tex)).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn longer_axes_in_lanes(
    planes: [std::arch::x86_64::__m256; 7],
    range: std::arch::x86_64::__m256,
    normal: Vec3,
) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::{
        __m256, _CMP_UNORD_Q, _mm256_add_ps, _mm256_andnot_ps, _mm256_blendv_ps, _mm256_cmp_ps, _mm256_div_ps,
        _mm256_max_ps, _mm256_mul_ps, _mm256_set1_ps,
    };
    let [at_origin_x, spread_x, at_origin_y, spread_y, x, y, z] = planes;
    let magnitude = |value: __m256| _mm256_andnot_ps(_mm256_set1_ps(-0.0), value);
    // `f32::max`: the other where one is NaN (`max_ps` gives its second operand where either
    // is).
    let max = |a: __m256, b: __m256| _mm256_blendv_ps(_mm256_max_ps(a, b), a, _mm256_cmp_ps::<_CMP_UNORD_Q>(b, b));
    // `Cone::width`.
    let width = max(
        magnitude(_mm256_add_ps(at_origin_x, _mm256_mul_ps(range, spread_x))),
        magnitude(_mm256_add_ps(at_origin_y, _mm256_mul_ps(range, spread_y))),
    );
    // `Vec3::dot`, then the width over its magnitude (at least the least normal f32).
    let cos = _mm256_add_ps(
        _mm256_add_ps(
            _mm256_mul_ps(x, _mm256_set1_ps(normal.x)),
            _mm256_mul_ps(y, _mm256_set1_ps(normal.y)),
        ),
        _mm256_mul_ps(z, _mm256_set1_ps(normal.z)),
    );
    _mm256_div_ps(width, _mm256_max_ps(magnitude(cos), _mm256_set1_ps(f32::MIN_POSITIVE)))
}

/// The footprint in the camera body's frame of a pixel whose cone is `cone` and ray
/// direction `direction`; [`Footprint::POINT`] where it has no ray.
#[inline(always)]
fn with_cone(cone: Cone, direction: Option<DVec3>) -> Footprint {
    direction.map_or(Footprint::POINT, |direction| Footprint::in_body(cone, direction))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::avx2::Avx2;
    use crate::camera::Pinhole;

    /// The longer axes of eight pixels from a ray table in AVX2 registers: the bits of the lanes
    /// as `longer_axes` works them out, at ranges and on normals near, far, zero, infinite and
    /// NaN, for every run of eight neighbours that fits in the image and runs of pixels that
    /// are not neighbours; none for pixels outside the table.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn longer_axes_in_registers_are_the_lanes_bits() {
        let Some(avx2) = Avx2::detected() else {
            eprintln!("no AVX2 on this CPU: nothing to compare");
            return;
        };
        let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(13, 5, 1.3));
        let planes = ConePlanes::of_image(&camera, |index| camera.pixel_ray(index));
        let footprints = Footprints::Table(&planes);
        let ranges = [0.0, 0.3, 1.7, 40.0, 1e30, f32::INFINITY, f32::NAN, f32::MIN_POSITIVE];
        let normals = [
            Vec3::Z,
            Vec3::new(0.6, 0.0, -0.8),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::ZERO,
            Vec3::splat(f32::NAN),
        ];
        let pixels = 13 * 5;
        for start in 0..pixels + 2 {
            for (turn, &normal) in normals.iter().enumerate() {
                let range: [f32; 8] = std::array::from_fn(|k| ranges[(k + turn + start) % ranges.len()]);
                let spread = start % 3 + 1;
                for (index, neighbours) in [
                    (std::array::from_fn(|k| start + k), true),
                    (std::array::from_fn(|k| (start + spread * k * k) % (pixels + 1)), false),
                ] {
                    // SAFETY: `avx2` proves the CPU has AVX2.
                    let in_registers = unsafe { longer_axes_of(avx2, &planes, &index, neighbours, &range, normal) };
                    if index.iter().any(|&index| index >= pixels) {
                        assert_eq!(in_registers, None, "{index:?}");
                        continue;
                    }
                    let lanes = footprints.longer_axes(&index, neighbours, &range, normal);
                    assert_eq!(
                        in_registers.map(|axes| axes.map(f32::to_bits)),
                        Some(lanes.map(f32::to_bits)),
                        "{index:?}"
                    );
                }
            }
        }
    }

    /// [`longer_axes_in_lanes`] of pixels `index` of `planes`, through memory.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn longer_axes_of(
        avx2: Avx2,
        planes: &ConePlanes,
        index: &[usize; 8],
        neighbours: bool,
        range: &[f32; 8],
        normal: Vec3,
    ) -> Option<[f32; 8]> {
        use std::arch::x86_64::{_mm256_loadu_ps, _mm256_storeu_ps};
        let lanes = planes.lanes_avx2(avx2, index, neighbours)?;
        let mut out = [0.0; 8];
        // SAFETY: the load reads the eight f32 of `range`, the store writes the eight of `out`.
        unsafe {
            let range = _mm256_loadu_ps(range.as_ptr());
            _mm256_storeu_ps(out.as_mut_ptr(), longer_axes_in_lanes(lanes, range, normal));
        }
        Some(out)
    }
}
