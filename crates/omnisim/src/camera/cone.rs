//! A pixel's ray cone (Akenine-Möller et al., "Texture Level of Detail Strategies for
//! Real-Time Ray Tracing", Ray Tracing Gems, 2019): how far its neighbours' rays run from its
//! own, the texture footprint's width at any distance along it (`shade/footprint.rs` lays it on
//! the face hit).
//!
//! Every camera model (pinhole, panoramas, mirrors, central or not) is a function from pixel
//! coordinates to a ray o + t·d. Let a neighbour's ray (x + 1, else x − 1 where the image or
//! the mirror ends; the same for y: [`neighbours`]) differ by Δo and Δd, and write
//! v⊥ = v − (v·d)d for the part of a vector across the ray. On the plane across the ray at
//! distance t the neighbour passes Δo⊥ + t·Δd⊥ from the pixel's point (to first order in Δ).
//! With s = |Δd⊥| (the spread) and a = Δo⊥·Δd⊥ / s (the width at the origin), that offset's
//! length is |a + t·s| exactly where Δo⊥ ∥ Δd⊥: always for central cameras (Δo = 0, a = 0:
//! pinhole, panoramas, lenses, central mirrors, whose rays leave the viewpoint), and for a
//! non-central mirror of revolution along the radial and tangential directions; elsewhere on
//! such a mirror it approximates, and only within centimetres of the mirror (t·s dominates
//! beyond). The cone's width is the larger of the two axes', w(t) = maxₖ |aₖ + t·sₖ|
//! (isotropic: an elongated pixel footprint becomes the circle around it). Because lengths and
//! angles do not change with the pose, the cone depends on the camera alone: the CPU keeps one
//! per pixel in the ray table (`trace/ray_table.rs`), computed from its rays (a curved
//! mirror's reflected rays included); the GPU (`cone_axis` in `shaders/texture.wgsl`) computes
//! the same from the camera's WGSL rays.

use glam::{DVec2, DVec3, Vec3};

use super::{Camera, CameraRay};

/// The neighbour `step` ahead of `pixel` if it lies inside an image of `size` pixels, else the
/// one `step` behind if that does (a width-1 image has neither along x: that axis is zero). The
/// GPU's `cone_axis` follows the same rule, so both read only rays inside the image (the GPU's
/// ray table holds no others).
fn neighbours(pixel: DVec2, step: DVec2, size: (u32, u32)) -> [Option<DVec2>; 2] {
    let (ahead, behind) = (pixel + step, pixel - step);
    [
        (ahead.x <= f64::from(size.0) - 1.0 && ahead.y <= f64::from(size.1) - 1.0).then_some(ahead),
        (behind.x >= 0.0 && behind.y >= 0.0).then_some(behind),
    ]
}

/// One image axis of a ray cone: the footprint's width along it at distance t along the ray
/// is |a + t·s| metres (a = `at_origin`, s = `spread`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct ConeAxis {
    /// Width at the ray's origin, metres (zero for central cameras).
    at_origin: f32,
    /// Growth of the width per metre along the ray (the angle between neighbouring rays).
    spread: f32,
}

impl ConeAxis {
    /// The axis from `ray` to its neighbour `neighbour` (module documentation).
    pub(crate) fn between(ray: &CameraRay, neighbour: &CameraRay) -> ConeAxis {
        let d = ray.direction;
        let across = |v: DVec3| v - v.dot(d) * d;
        let (origins, directions) = (across(neighbour.origin - ray.origin), across(neighbour.direction - d));
        let spread = directions.length();
        let at_origin = if spread > 0.0 {
            origins.dot(directions) / spread
        } else {
            origins.length()
        };
        ConeAxis {
            at_origin: at_origin as f32,
            spread: spread as f32,
        }
    }
}

/// A pixel's ray cone: one [`ConeAxis`] per image axis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Cone([ConeAxis; 2]);

impl Cone {
    /// No width: a pixel without a ray, or point sampling.
    pub(crate) const ZERO: Cone = Cone(
        [ConeAxis {
            at_origin: 0.0,
            spread: 0.0,
        }; 2],
    );

    /// The cone of the pixel at `pixel` (sub-pixel positions allowed) of an image of `size`
    /// pixels whose ray is `ray`, with `ray_at` giving the ray at any pixel position inside the
    /// image (`None` where there is none): the neighbour one pixel ahead along each axis, or the
    /// one behind where that one is outside the image or has no ray; an axis without either
    /// inside the image is zero.
    pub(crate) fn around(
        pixel: DVec2,
        size: (u32, u32),
        ray: &CameraRay,
        ray_at: impl Fn(DVec2) -> Option<CameraRay>,
    ) -> Cone {
        let axis = |step: DVec2| {
            let [ahead, behind] = neighbours(pixel, step, size);
            (ahead.and_then(&ray_at))
                .or_else(|| behind.and_then(&ray_at))
                .map_or(ConeAxis::default(), |neighbour| ConeAxis::between(ray, &neighbour))
        };
        Cone([axis(DVec2::X), axis(DVec2::Y)])
    }

    /// The cones of every pixel of `camera`, row by row, with `ray_of` giving the ray of the
    /// pixel at an index (the ray table's, or the camera's own), zero where a pixel has no ray:
    /// what the renderer keeps per camera.
    pub(crate) fn of_image(camera: &Camera, ray_of: impl Fn(usize) -> Option<CameraRay> + Sync) -> Vec<Cone> {
        use rayon::prelude::*;
        let size = camera.size();
        let width = size.0.max(1) as usize;
        // Neighbours lie inside the image.
        let ray_at = |p: DVec2| ray_of(p.y as usize * width + p.x as usize);
        (0..width * size.1 as usize)
            .into_par_iter()
            .map(|index| match ray_of(index) {
                Some(ray) => {
                    let pixel = DVec2::new((index % width) as f64, (index / width) as f64);
                    Cone::around(pixel, size, &ray, ray_at)
                }
                None => Cone::ZERO,
            })
            .collect()
    }

    /// The cone's width at distance `range` along the ray (metres).
    #[inline]
    pub(crate) fn width(&self, range: f32) -> f32 {
        let [x, y] = self.0;
        (x.at_origin + range * x.spread)
            .abs()
            .max((y.at_origin + range * y.spread).abs())
    }
}

/// Every pixel's ray cone and ray direction (f32, as a footprint holds it), row by row, one
/// plane a number: what a ray table keeps for textured frames (`shade/footprint.rs`), so that
/// a run of neighbouring pixels reads each number of its eight footprints as one vector. Read
/// pixel by pixel from the table's 32-byte rays and 16-byte cones (the NaN test, the f64
/// direction's conversion, the cone's copy a lane), an equirect 1024×512 textured frame's
/// footprints cost about 19 M instructions more (docs/benchmarks.md, 2026-11-26 evening (tex)).
/// A pixel without a ray holds zeros: [`Cone::ZERO`] and a zero direction, the point footprint.
pub(crate) struct ConePlanes {
    /// [`ConeAxis::at_origin`] by image axis, pixel.
    at_origin: [Vec<f32>; 2],
    /// [`ConeAxis::spread`] by image axis, pixel.
    spread: [Vec<f32>; 2],
    /// The ray's unit direction in the camera body's frame (f64 rounded to f32), by
    /// component, pixel.
    direction: [Vec<f32>; 3],
}

/// One number of each lane's pixel: a plane's values at the pixels of [`ConePlanes::lanes`].
type Lanes<const L: usize> = [f32; L];

impl ConePlanes {
    /// The planes of every pixel of `camera`, with `ray_of` giving the ray of the pixel at an
    /// index, as [`Cone::of_image`] takes it.
    pub(crate) fn of_image(camera: &Camera, ray_of: impl Fn(usize) -> Option<CameraRay> + Sync) -> ConePlanes {
        use rayon::prelude::*;
        let cones = Cone::of_image(camera, &ray_of);
        let plane = |number: &(dyn Fn(usize, &Cone) -> f32 + Sync)| -> Vec<f32> {
            cones
                .par_iter()
                .enumerate()
                .map(|(index, cone)| number(index, cone))
                .collect()
        };
        let direction =
            |component: usize| plane(&|index, _| ray_of(index).map_or(0.0, |ray| ray.direction[component] as f32));
        ConePlanes {
            at_origin: [0, 1].map(|axis| plane(&|_, cone| cone.0[axis].at_origin)),
            spread: [0, 1].map(|axis| plane(&|_, cone| cone.0[axis].spread)),
            direction: [0, 1, 2].map(direction),
        }
    }

    /// `lane(k, cone, direction)` with pixel `index[k]`'s cone and ray direction for each lane k:
    /// where the pixels are `neighbours` (`index[k]` is `index[0] + k`) every lane's `lane` in
    /// one loop over the planes in place (vector loads), else over copies of the lanes' numbers.
    #[inline(always)]
    pub(crate) fn lanes<const L: usize>(
        &self,
        index: &[usize; L],
        neighbours: bool,
        lane: impl Fn(usize, Cone, Vec3) -> f32,
    ) -> [f32; L] {
        if neighbours && let Some(planes) = self.in_place(index[0]) {
            return each_lane(planes, lane);
        }
        let [at_origin_x, at_origin_y] = &self.at_origin;
        let [spread_x, spread_y] = &self.spread;
        let [x, y, z] = &self.direction;
        let planes = [at_origin_x, spread_x, at_origin_y, spread_y, x, y, z];
        let copies: [Lanes<L>; 7] = std::array::from_fn(|p| std::array::from_fn(|k| planes[p][index[k]]));
        let [a, b, c, d, e, f, g] = &copies;
        each_lane([a, b, c, d, e, f, g], lane)
    }

    /// The numbers of pixels `index`' footprints ([`each_lane`]'s planes' order) in AVX2
    /// registers: read in place where they are `neighbours` (`index[k]` is `index[0] + k`),
    /// else pixel by pixel (plain loads: a gather a plane cost more instructions, an equirect
    /// frame +7.1 M, docs/benchmarks.md, 2026-11-26 night (tex)); `None` where a pixel lies
    /// outside the table.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn lanes_avx2(
        &self,
        _: crate::avx2::Avx2,
        index: &[usize; 8],
        neighbours: bool,
    ) -> Option<[std::arch::x86_64::__m256; 7]> {
        use std::arch::x86_64::_mm256_loadu_ps;
        // Written out plane by plane: a closure over the planes (`map`) was left a call.
        if neighbours {
            let [a, b, c, d, e, f, g] = self.in_place::<8>(index[0])?;
            // SAFETY: each load reads the eight f32 of its lanes.
            return Some(unsafe {
                [
                    _mm256_loadu_ps(a.as_ptr()),
                    _mm256_loadu_ps(b.as_ptr()),
                    _mm256_loadu_ps(c.as_ptr()),
                    _mm256_loadu_ps(d.as_ptr()),
                    _mm256_loadu_ps(e.as_ptr()),
                    _mm256_loadu_ps(f.as_ptr()),
                    _mm256_loadu_ps(g.as_ptr()),
                ]
            });
        }
        self.scattered_lanes(index)
    }

    /// [`ConePlanes::lanes_avx2`] of pixels that are not neighbours: out of line, so that the
    /// neighbours' loads are inlined where their numbers are used.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn scattered_lanes(&self, index: &[usize; 8]) -> Option<[std::arch::x86_64::__m256; 7]> {
        let [at_origin_x, at_origin_y] = &self.at_origin;
        let [spread_x, spread_y] = &self.spread;
        let [x, y, z] = &self.direction;
        let last = index.iter().copied().max().unwrap_or(0);
        if [at_origin_x, spread_x, at_origin_y, spread_y, x, y, z]
            .iter()
            .any(|plane| last >= plane.len())
        {
            return None;
        }
        // SAFETY: every index is at most `last`, inside every plane (checked above).
        Some(unsafe {
            [
                lanes_at(at_origin_x, index),
                lanes_at(spread_x, index),
                lanes_at(at_origin_y, index),
                lanes_at(spread_y, index),
                lanes_at(x, index),
                lanes_at(y, index),
                lanes_at(z, index),
            ]
        })
    }

    /// The numbers of the `L` neighbouring pixels from `start` ([`each_lane`]'s planes), read
    /// in place, where they all lie in the table.
    #[inline(always)]
    pub(crate) fn in_place<const L: usize>(&self, start: usize) -> Option<[&Lanes<L>; 7]> {
        let [at_origin_x, at_origin_y] = &self.at_origin;
        let [spread_x, spread_y] = &self.spread;
        let [x, y, z] = &self.direction;
        // Plane by plane, not by `map` over the array of planes: LLVM kept such a call out of
        // line (about 400 instructions a run).
        fn lanes<const L: usize>(plane: &[f32], start: usize) -> Option<&Lanes<L>> {
            plane.get(start..start + L)?.try_into().ok()
        }
        Some([
            lanes(at_origin_x, start)?,
            lanes(spread_x, start)?,
            lanes(at_origin_y, start)?,
            lanes(spread_y, start)?,
            lanes(x, start)?,
            lanes(y, start)?,
            lanes(z, start)?,
        ])
    }
}

/// The numbers of `plane` at `index`, by lane.
///
/// # Safety
/// Every index lies inside `plane`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn lanes_at(plane: &[f32], index: &[usize; 8]) -> std::arch::x86_64::__m256 {
    // SAFETY: the caller's.
    let at = |k: usize| unsafe { *plane.get_unchecked(index[k]) };
    std::arch::x86_64::_mm256_setr_ps(at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7))
}

/// `lane(k, cone, direction)` for each lane k of the numbers `planes` ([`ConePlanes`]' order:
/// the two axes' width at the origin and spread, then the direction's x, y and z), in one loop.
#[inline(always)]
fn each_lane<const L: usize>(planes: [&Lanes<L>; 7], lane: impl Fn(usize, Cone, Vec3) -> f32) -> [f32; L] {
    let [at_origin_x, spread_x, at_origin_y, spread_y, x, y, z] = planes;
    let mut out = [0.0; L];
    for (k, out) in out.iter_mut().enumerate() {
        let cone = Cone([
            ConeAxis {
                at_origin: at_origin_x[k],
                spread: spread_x[k],
            },
            ConeAxis {
                at_origin: at_origin_y[k],
                spread: spread_y[k],
            },
        ]);
        *out = lane(k, cone, Vec3::new(x[k], y[k], z[k]));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Pinhole;

    /// An image one pixel wide (or high) has no neighbour inside it along that axis: that axis
    /// of every cone is zero, as the GPU's `cone_axis` finds it (it reads only rays inside the
    /// image), and the other axis comes from the neighbouring pixel's ray.
    #[test]
    fn an_image_one_pixel_wide_or_high_has_no_cone_axis_across() {
        for (size, across) in [((1, 4), 0), ((4, 1), 1)] {
            let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(size.0, size.1, 1.0));
            let cones = Cone::of_image(&camera, |index| camera.pixel_ray(index));
            assert_eq!(cones.len(), 4);
            for cone in cones {
                assert_eq!(cone.0[across], ConeAxis::default(), "{size:?}");
                assert!(cone.0[1 - across].spread > 0.0, "{size:?}");
            }
        }
    }
}
