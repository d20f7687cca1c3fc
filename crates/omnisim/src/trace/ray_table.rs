//! Camera rays computed once per camera for the CPU backend.
//!
//! A pixel's body-frame ray depends on the camera alone, not on the pose, and for a
//! catadioptric camera it costs more than tracing it (the f64 mirror intersection: two thirds
//! of an omni pixel, measured with callgrind, docs/benchmarks.md). A run of many poses through
//! one camera (a data set, a trajectory, a benchmark) therefore reads them from a table.

use std::sync::{Arc, Mutex, OnceLock};

use glam::DVec3;
use rayon::prelude::*;

use crate::accel::SceneBvh;
use crate::camera::{Camera, CameraRay, Cone, ConePlanes};
use crate::frame::Frame;
use crate::pose::Pose;
use crate::trace::{CpuTracer, FrameRays};

/// Cameras whose rays are kept: two, so a stereo rig's left and right views alternate
/// without recomputing.
const CAMERAS: usize = 2;

/// Largest image whose rays are kept (32 bytes a pixel for a camera whose rays share one origin,
/// else 64; 28 more with the cones and f32 directions of textured frames, [`ConePlanes`]: at
/// most 92 MB kept a camera, and up to 108 MB at the peak while the cones of rays with their
/// own origins are made, 64 + 16 + 28 bytes a pixel); larger ones are computed per frame.
const MAX_PIXELS: usize = 1 << 20;

/// Largest image whose ray cones are kept where its rays are not (16 bytes a pixel: 64 MB): a
/// textured pixel then computes its own camera ray only, not its neighbours' too (equirect
/// 2048×1024: docs/benchmarks.md, "Ray cones").
const MAX_CONE_PIXELS: usize = 1 << 22;

/// Every pixel centre's body-frame ray of one camera, row by row, and, once a textured face
/// is shaded through it, every pixel's ray cone and f32 direction (the texture footprint,
/// `shade/footprint.rs`).
pub(crate) struct RayTable {
    camera: Camera,
    rays: Rays,
    cones: OnceLock<ConePlanes>,
}

/// A ray table's rays, held in the smallest form that gives every ray back bit for bit.
enum Rays {
    /// Rays that all start at `origin` (every camera whose rays share one origin: all but the
    /// spherical and misaligned mirrors; checked on the rays, not the camera type): each
    /// pixel's direction and `t_min`, half the bytes of a [`CameraRay`] in an `Option`. The
    /// tile loop reads a frame's table once a frame; at 1000² a 64-byte entry made that 64 MB
    /// of memory traffic.
    Central { origin: DVec3, entries: Vec<CentralRay> },
    /// Rays of their own origins (a non-central camera's: the spherical mirror's start at
    /// their mirror points).
    OwnOrigins(Vec<Option<CameraRay>>),
}

/// One pixel's ray of [`Rays::Central`]: `t_min` NaN where the pixel has no ray (a ray's
/// `t_min` never is: the table is made central only where none is). Aligned so that an entry
/// never straddles two cache lines.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct CentralRay {
    direction: DVec3,
    t_min: f64,
}

const _: () = assert!(size_of::<CentralRay>() == 32);

impl CentralRay {
    /// The camera ray this entry holds, from the table's shared `origin`.
    #[inline(always)]
    fn ray(self, origin: DVec3) -> Option<CameraRay> {
        self.direction().map(|direction| CameraRay {
            origin,
            direction,
            t_min: self.t_min,
        })
    }

    /// The entry's direction, `None` for a pixel without a ray (marked by a NaN `t_min`).
    #[inline(always)]
    fn direction(self) -> Option<DVec3> {
        (!self.t_min.is_nan()).then_some(self.direction)
    }
}

/// Four entries of a central table side by side, for the tile loop's lane-wise turn: each
/// axis of their directions and their `t_min`s, entry k in lane k (loaded whole and
/// transposed: `CentralRay` is one 256-bit row).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct FourRays {
    pub(crate) direction: [std::arch::x86_64::__m256d; 3],
    pub(crate) t_min: std::arch::x86_64::__m256d,
}

#[cfg(target_arch = "x86_64")]
impl FourRays {
    /// The first four entries of `entries` (at least four).
    ///
    /// # Safety
    /// The CPU has AVX2 (this is compiled into the tile loop's AVX2 build, `with_avx2`).
    #[inline(always)]
    pub(crate) unsafe fn of(entries: &[CentralRay]) -> Self {
        use std::arch::x86_64::{_mm256_load_pd, _mm256_permute2f128_pd, _mm256_unpackhi_pd, _mm256_unpacklo_pd};
        let entries = &entries[..4];
        let row = |k: usize| std::ptr::from_ref(&entries[k]).cast::<f64>();
        // SAFETY: each load reads one `CentralRay`, 32 bytes aligned to 32 (`repr(C)`: its
        // direction's x, y, z, then `t_min`); AVX2 as the caller promises.
        unsafe {
            let (a, b) = (_mm256_load_pd(row(0)), _mm256_load_pd(row(1)));
            let (c, d) = (_mm256_load_pd(row(2)), _mm256_load_pd(row(3)));
            // [x0 x1 z0 z1], [y0 y1 t0 t1], [x2 x3 z2 z3], [y2 y3 t2 t3].
            let (xz01, yt01) = (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b));
            let (xz23, yt23) = (_mm256_unpacklo_pd(c, d), _mm256_unpackhi_pd(c, d));
            Self {
                direction: [
                    _mm256_permute2f128_pd::<0x20>(xz01, xz23),
                    _mm256_permute2f128_pd::<0x20>(yt01, yt23),
                    _mm256_permute2f128_pd::<0x31>(xz01, xz23),
                ],
                t_min: _mm256_permute2f128_pd::<0x31>(yt01, yt23),
            }
        }
    }
}

impl Rays {
    /// `rays` in the central form where every ray starts at the same origin (bit for bit)
    /// and none has a NaN `t_min`, else as they are.
    fn of(rays: Vec<Option<CameraRay>>) -> Self {
        let Some(origin) = rays.iter().flatten().next().map(|ray| ray.origin) else {
            return Self::OwnOrigins(rays);
        };
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        let central = rays
            .par_iter()
            .flatten()
            .all(|ray| bits(ray.origin) == bits(origin) && !ray.t_min.is_nan());
        if !central {
            return Self::OwnOrigins(rays);
        }
        let none = CentralRay {
            direction: DVec3::ZERO,
            t_min: f64::NAN,
        };
        let entries = rays
            .par_iter()
            .map(|ray| {
                ray.map_or(none, |ray| CentralRay {
                    direction: ray.direction,
                    t_min: ray.t_min,
                })
            })
            .collect();
        Self::Central { origin, entries }
    }
}

impl RayTable {
    /// The body-frame ray of pixel `index` (row by row), as the camera gives it.
    #[inline(always)]
    pub(crate) fn ray(&self, index: usize) -> Option<CameraRay> {
        match &self.rays {
            Rays::Central { origin, entries } => entries[index].ray(*origin),
            Rays::OwnOrigins(rays) => rays[index],
        }
    }

    /// Every pixel's ray cone and ray direction, made on first use from the table's rays.
    pub(crate) fn cones(&self) -> &ConePlanes {
        if let Some(cones) = self.cones.get() {
            return cones;
        }
        // Made outside `get_or_init`: making runs parallel loops, and a rayon thread waiting in
        // them may take up another frame that asks for these cones (a caller may render from
        // rayon's threads), which would enter `get_or_init` again on the same thread and never
        // return.
        // Two threads may both make them; the first kept wins, and both are the same numbers.
        let made = ConePlanes::of_image(&self.camera, |index| self.ray(index));
        self.cones.get_or_init(|| made)
    }

    /// Traces one frame with `tracer` from this table's rays: when tracing, the layout is matched
    /// once a frame, not once a ray.
    fn trace(&self, tracer: CpuTracer, bvh: &SceneBvh, pose: &Pose) -> Frame {
        let size = self.camera.size();
        match &self.rays {
            Rays::Central { origin, entries } => {
                let rays = FrameRays {
                    size,
                    shared_origin: Some(*origin),
                    ray: |index: usize| entries[index].ray(*origin),
                    central: Some(entries),
                };
                tracer.trace_rays(bvh, pose, &rays)
            }
            Rays::OwnOrigins(rays) => {
                let rays = FrameRays {
                    size,
                    shared_origin: None,
                    ray: |index: usize| rays[index],
                    central: None,
                };
                tracer.trace_rays(bvh, pose, &rays)
            }
        }
    }
}

/// Every pixel's ray cone of one camera whose rays are not kept (its image is larger than
/// `MAX_PIXELS`).
pub(crate) struct ConeTable {
    camera: Camera,
    pub(crate) cones: Vec<Cone>,
}

/// The ray tables (and cone tables) of the last cameras a renderer traced on the CPU.
#[derive(Default)]
pub(crate) struct RayCache {
    tables: Mutex<Vec<Arc<RayTable>>>,
    cone_tables: Mutex<Vec<Arc<ConeTable>>>,
}

/// The entry of `list` made for `camera`, or `make()` added (the oldest dropped beyond
/// `CAMERAS`).
fn cached<T>(
    list: &Mutex<Vec<Arc<T>>>,
    camera: &Camera,
    of: impl Fn(&T) -> &Camera,
    make: impl FnOnce() -> T,
) -> Arc<T> {
    // A poisoned lock only means another thread panicked while holding it: the tables are
    // complete or absent, never half made, so they stay usable.
    let lock = || list.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let find = |list: &[Arc<T>]| list.iter().find(|entry| of(entry) == camera).map(Arc::clone);
    if let Some(entry) = find(&lock()) {
        return entry;
    }
    // Made without the lock held: making runs parallel loops, and a rayon thread waiting in
    // them may take up another frame of this renderer (a caller may render from rayon's
    // threads) that asks for a table, which would lock again on the same thread and never
    // return. Two threads may both make one camera's table (a passing peak of two); the first
    // kept is used by both.
    let entry = Arc::new(make());
    let mut list = lock();
    if let Some(kept) = find(&list) {
        return kept;
    }
    if list.len() == CAMERAS {
        list.remove(0);
    }
    list.push(Arc::clone(&entry));
    entry
}

/// Traces one frame with `tracer`, reading `camera`'s rays from `table` (its
/// [`RayCache::table`]) where there is one.
pub(crate) fn trace_frame(
    tracer: CpuTracer,
    bvh: &SceneBvh,
    camera: &Camera,
    pose: &Pose,
    table: Option<&RayTable>,
) -> Frame {
    match table {
        Some(table) => table.trace(tracer, bvh, pose),
        None => tracer.trace(bvh, camera, pose),
    }
}

impl RayCache {
    /// `camera`'s ray table, made on first use, where the image is small enough to keep one.
    pub(crate) fn table(&self, camera: &Camera) -> Option<Arc<RayTable>> {
        let (width, height) = camera.size();
        let pixels = width as usize * height as usize;
        if pixels > MAX_PIXELS {
            return None;
        }
        Some(cached(
            &self.tables,
            camera,
            |table| &table.camera,
            || RayTable {
                camera: camera.clone(),
                rays: Rays::of(camera.ray_source().all()),
                cones: OnceLock::new(),
            },
        ))
    }

    /// `camera`'s ray cones alone, made on first use, where its image is too large for a ray
    /// table ([`RayCache::table`]) but small enough to keep its cones.
    pub(crate) fn cone_table(&self, camera: &Camera) -> Option<Arc<ConeTable>> {
        let (width, height) = camera.size();
        let pixels = width as usize * height as usize;
        if pixels <= MAX_PIXELS || pixels > MAX_CONE_PIXELS {
            return None;
        }
        Some(cached(
            &self.cone_tables,
            camera,
            |table| &table.camera,
            || ConeTable {
                camera: camera.clone(),
                cones: {
                    let source = camera.ray_source();
                    Cone::of_image(camera, |index| source.ray(index))
                },
            },
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Cylindrical, Equirectangular, Pinhole};
    use glam::dvec3;

    /// Every field of `ray` as bits, so that a comparison tells `0.0` from `-0.0` and NaN
    /// equals itself.
    fn bits(ray: Option<CameraRay>) -> Option<Vec<u64>> {
        ray.map(|ray| {
            [ray.origin, ray.direction]
                .map(|v| v.to_array().map(f64::to_bits))
                .concat()
                .into_iter()
                .chain([ray.t_min.to_bits()])
                .collect()
        })
    }

    /// Each camera's table gives back every pixel's ray bit for bit, in the central form where
    /// all rays share an origin (pinhole, also away from the body origin as a stereo rig's
    /// right camera, equirect, the hyperbolic mirror with its rays' own `t_min`) and as they
    /// are where they do not (the spherical mirror's mirror points).
    #[test]
    fn a_table_gives_back_every_ray_and_is_central_only_where_the_rays_share_an_origin() {
        use crate::camera::Catadioptric;
        let right = Pinhole {
            position: dvec3(0.0, -0.05, 0.0),
            ..Pinhole::with_horizontal_fov(40, 30, 1.2)
        };
        // (camera, central, has pixels without rays)
        let cameras = [
            (Camera::Pinhole(Pinhole::with_horizontal_fov(40, 30, 1.2)), true, false),
            (Camera::Pinhole(right), true, false),
            (
                Camera::Equirectangular(Equirectangular { width: 48, height: 24 }),
                true,
                false,
            ),
            (
                Camera::Catadioptric(Catadioptric::hyperbolic(64, 64, 0.04, 0.16, Some(20f64.to_radians()))),
                true,
                true,
            ),
            (
                Camera::Catadioptric(Catadioptric::spherical(64, 64, 0.05, 0.3)),
                false,
                true,
            ),
        ];
        let cache = RayCache::default();
        for (index, (camera, central, has_holes)) in cameras.iter().enumerate() {
            let table = cache.table(camera).expect("a small image has a table");
            assert_eq!(matches!(table.rays, Rays::Central { .. }), *central, "camera {index}");
            let pixels = camera.size().0 as usize * camera.size().1 as usize;
            let mut missing = 0;
            for pixel in 0..pixels {
                let want = camera.pixel_ray(pixel);
                missing += usize::from(want.is_none());
                assert_eq!(bits(table.ray(pixel)), bits(want), "camera {index}, pixel {pixel}");
            }
            assert_eq!(missing > 0, *has_holes, "camera {index}: pixels without rays");
        }
    }

    /// The form `Rays::of` picks for made-up rays the cameras do not give: a NaN `t_min` (which
    /// the central form would read back as no ray), origins `0.0` and `-0.0` (equal as numbers,
    /// not bit for bit), no ray at all, and an infinite `t_min` beside a pixel without a ray
    /// (central: infinity is not NaN). Every ray comes back bit for bit.
    #[test]
    fn rays_fall_back_to_their_own_origins_unless_every_ray_comes_back_bit_for_bit() {
        let ray = |origin: DVec3, t_min: f64| {
            Some(CameraRay {
                origin,
                direction: dvec3(0.0, 0.6, -0.8),
                t_min,
            })
        };
        let origin = dvec3(0.0, -0.05, 0.1);
        let cases = [
            (vec![ray(origin, f64::NAN), None], false),
            (vec![ray(DVec3::ZERO, 0.0), ray(dvec3(0.0, -0.0, 0.0), 0.0)], false),
            (vec![None, None], false),
            (vec![ray(origin, f64::INFINITY), None, ray(origin, 0.25)], true),
        ];
        for (index, (rays, central)) in cases.into_iter().enumerate() {
            let table = RayTable {
                camera: Camera::Equirectangular(Equirectangular { width: 1, height: 1 }),
                rays: Rays::of(rays.clone()),
                cones: OnceLock::new(),
            };
            assert_eq!(matches!(table.rays, Rays::Central { .. }), central, "case {index}");
            for (pixel, want) in rays.into_iter().enumerate() {
                assert_eq!(bits(table.ray(pixel)), bits(want), "case {index}, pixel {pixel}");
            }
        }
    }

    /// A central table's rays turned four at a time (the tile loop's AVX2 path) are the rays
    /// turned one by one, bit for bit in f64 and in f32, and the pixel without a ray is left
    /// out as one by one.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn rays_turned_four_at_a_time_are_the_rays_turned_one_by_one() {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked on the line above).
            unsafe { turned_four_at_a_time() };
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn turned_four_at_a_time() {
        use crate::trace::{LocalPose, fast::PacketRoom};
        let (_, bvh) = crate::trace::test_scene("env1");
        let pose = LocalPose::new(&bvh, &Pose::new(dvec3(1.5, 0.1, 0.4), dvec3(0.3, -0.2, 1.1)));
        let entries: Vec<CentralRay> = (0..8)
            .map(|k| {
                let angle = 0.7 * f64::from(k) + 0.1;
                let direction = dvec3(angle.cos(), angle.sin(), 0.3 - 0.1 * f64::from(k)).normalize();
                match k {
                    5 => CentralRay {
                        direction: DVec3::ZERO,
                        t_min: f64::NAN,
                    },
                    _ => CentralRay {
                        direction,
                        t_min: 1e-3 * f64::from(k),
                    },
                }
            })
            .collect();
        let origin = dvec3(0.25, -1.5, 0.75);
        let (mut fours, mut ones) = (Box::<PacketRoom>::default(), Box::<PacketRoom>::default());
        let mut set = 0u64;
        for first in [0, 4] {
            // SAFETY: this function is built with AVX2 and called only where the CPU has it.
            unsafe {
                let rays = pose.turn_four(FourRays::of(&entries[first..]));
                set |= u64::from(fours.set_four(first, origin, &rays)) << first;
            }
        }
        for (r, entry) in entries.iter().enumerate() {
            match entry.direction() {
                Some(direction) => ones.set(r, origin, pose.turn_direction(direction), entry.t_min),
                None => ones.clear(r),
            }
        }
        assert_eq!(set, 0b1101_1111, "the pixel without a ray is left out");
        for r in 0..8 {
            let (four, one) = (fours.bits(r), ones.bits(r));
            assert_eq!(four.1, one.1, "ray {r}'s f32 staging");
            if set >> r & 1 != 0 {
                assert_eq!(four.0, one.0, "ray {r}'s f64 ray");
            }
        }
    }

    /// Frames traced from tables (both forms; the mirrors' with pixels without rays) equal
    /// frames traced from the camera's ray source (how frames too large for a table are
    /// traced), which equal frames traced from each pixel's own ray; and the cache keeps the
    /// last `CAMERAS` cameras' tables.
    #[test]
    fn frames_from_ray_tables_equal_frames_from_the_camera_and_tables_follow_the_camera() {
        use crate::camera::Catadioptric;
        let (_, bvh) = crate::trace::test_scene("env1");
        let cache = RayCache::default();
        let cameras = [
            Camera::Pinhole(Pinhole::with_horizontal_fov(40, 30, 1.2)),
            Camera::Equirectangular(Equirectangular { width: 48, height: 24 }),
            Camera::Pinhole(Pinhole::with_horizontal_fov(40, 30, 0.6)),
            Camera::Catadioptric(Catadioptric::hyperbolic(64, 64, 0.04, 0.16, Some(20f64.to_radians()))),
            Camera::Catadioptric(Catadioptric::spherical(64, 64, 0.05, 0.3)),
            Camera::Cylindrical(Cylindrical::with_vertical_fov(48, 20, 1.5)),
            // Rows of 41: a central table's right-edge tiles take the one-by-one turn.
            Camera::Pinhole(Pinhole::with_horizontal_fov(41, 30, 1.2)),
        ];
        let mut central = Vec::new();
        for round in 0..2 {
            for (index, camera) in cameras.iter().enumerate() {
                let pose = Pose::new(
                    dvec3(1.0, 0.5 + 0.1 * f64::from(round), 0.4),
                    dvec3(0.0, 0.1, index as f64),
                );
                let direct = CpuTracer::Fast.trace(&bvh, camera, &pose);
                // A frame too large for a table is traced as `direct` is (its camera's ray
                // source, with its shared origin where it names one): equal to each pixel's
                // own ray turned on its own.
                let each_pixel = FrameRays {
                    size: camera.size(),
                    shared_origin: None,
                    ray: |index: usize| camera.pixel_ray(index),
                    central: None,
                };
                let own = CpuTracer::Fast.trace_rays(&bvh, &pose, &each_pixel);
                assert_eq!(direct.pixels(), own.pixels(), "camera {index}, round {round}");
                let table = cache.table(camera).expect("a small image has a table");
                central.push(matches!(table.rays, Rays::Central { .. }));
                let cached = trace_frame(CpuTracer::Fast, &bvh, camera, &pose, Some(&table));
                assert_eq!(direct.pixels(), cached.pixels(), "camera {index}, round {round}");
            }
        }
        assert_eq!(
            central,
            [true, true, true, true, false, true, true].repeat(2),
            "both forms are traced"
        );
        let tables = cache.tables.lock().unwrap();
        assert_eq!(tables.len(), CAMERAS);
        assert!(
            tables.iter().all(|table| table.camera != cameras[0]),
            "the oldest table is dropped"
        );
    }
}
